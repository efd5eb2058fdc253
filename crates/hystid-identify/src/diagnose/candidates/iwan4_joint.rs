//! Segalman's four-parameter Iwan joint in place of the joint law fitted:
//! the joint itself is not the law the user declared. A bolted lap joint in
//! microslip dissipates `∝ A^(3+χ)` per cycle with `χ` between −1 and 0, a
//! power no eq. (10) Masing curve or Jenkins slider reproduces over a range
//! of levels together with the full-slip force (see `model::iwan`). Its
//! residual is the joint's: level-dependent, in every harmonic, with no
//! effect of its own to point at, so every diagnosis tries it.

use super::{
    Candidate, Context, best_as_it_stands, joint_misfit_score, replaceable_joint,
    replacing_parameters,
};
use crate::diagnose::lines::LineContext;
use crate::diagnose::{ResidualFeatures, SelectedEffect, fmt_value};
use crate::error::Result;
use crate::model::{ElementKind, ElementSpec, Model};

/// See the module docs.
pub(crate) struct Iwan4Joint;

/// The starting shapes: `χ` from a nearly uniform slider density to one
/// crowded at small slips, with a small and a large spike.
const SHAPES: [(f64, f64); 3] = [(-0.5, 0.3), (-0.2, 1.0), (-0.8, 0.1)];

/// `model` with its joint replaced by an Iwan joint of each of [`SHAPES`]
/// (none when the joint cannot be replaced).
fn shapes(model: &Model) -> impl Iterator<Item = Model> + '_ {
    let joint = replaceable_joint(model, ElementKind::Iwan4);
    SHAPES.iter().filter_map(move |&(chi, beta)| {
        let (kt, fs) = joint?;
        let mut m = model.clone();
        m.joint = Some(ElementSpec::Iwan4 { fs, kt, chi, beta });
        Some(m)
    })
}

impl Candidate for Iwan4Joint {
    fn help(&self) -> Option<&'static str> {
        Some("an Iwan joint in place of the fitted joint law")
    }

    fn law(&self) -> Option<ElementKind> {
        Some(ElementKind::Iwan4)
    }

    fn replaces_joint(&self) -> bool {
        true
    }

    /// A joint that is not one already, with a stick stiffness and a slip
    /// force to start from (not a Bouc-Wen joint, whose saturation force is
    /// no parameter).
    fn applies_to(&self, model: &Model) -> bool {
        replaceable_joint(model, ElementKind::Iwan4).is_some()
    }

    /// Its four parameters in place of the fitted joint's.
    fn added_parameters(&self, before: &Model) -> usize {
        replacing_parameters(self.size(), before)
    }

    fn score(&self, f: &ResidualFeatures) -> f64 {
        joint_misfit_score(f)
    }

    /// The fitted joint's stick stiffness and slip force carried over (they
    /// mean the same to every law: the initial slope and the force it
    /// saturates at), at the shape of [`SHAPES`] whose model fits best as it
    /// stands (one prediction each; a refit from each would cost a full
    /// refit each, and the refit from the best one reached the same optimum
    /// on the independent Iwan recordings); none when the joint already is
    /// one (see [`Candidate::applies_to`]).
    fn starts(&self, cx: &Context<'_>) -> Result<Vec<Model>> {
        Ok(best_as_it_stands(cx, shapes(cx.model()))
            .map(|(_, m)| m)
            .into_iter()
            .collect())
    }

    /// The same shapes, the one of lowest `χ²` on the lines.
    fn line_starts(&self, cx: &LineContext<'_>) -> Vec<Model> {
        cx.best_as_it_stands(shapes(cx.model()))
            .map(|(_, m)| m)
            .into_iter()
            .collect()
    }

    /// The joint the law replaces must itself be determined: its stiffness,
    /// its slip force and `χ`, which decides whether the Iwan law is what
    /// the data show (resolved inside (−1, 0)). The spike's share `β` may
    /// sit at 0.
    fn size_parameters(&self) -> &'static [&'static str] {
        &["kt", "fs", "chi"]
    }

    /// A law swap cannot be taken out again: the model needs a joint.
    fn remove(&self, _model: &Model) -> Option<Model> {
        None
    }

    fn explain(&self, f: &ResidualFeatures, selected: &SelectedEffect) -> String {
        let chi = selected
            .parameters
            .get("chi")
            .map(|e| {
                format!(
                    " (χ = {}: dissipation per cycle ∝ A^{:.2} in microslip)",
                    fmt_value(e.value),
                    3.0 + e.value
                )
            })
            .unwrap_or_default();
        format!(
            "the residual changed with level (slope {:.2}, {:.0} % of it level-dependent) in a way the fitted joint law cannot follow, and an Iwan joint does{chi}",
            f.growth_with_level,
            100.0 * (1.0 - f.level_independent_share)
        )
    }
}
