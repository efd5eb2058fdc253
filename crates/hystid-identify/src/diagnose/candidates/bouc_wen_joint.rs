//! A Bouc-Wen joint in place of the joint law fitted: the joint's loops are
//! not Masing loops. Masing laws (Jenkins, the eq. (10) element, Iwan) unload
//! along the loading curve scaled by two, so the loop's shape is fixed by
//! the backbone; a Bouc-Wen joint (`model::bouc_wen`) unloads by its own
//! rule (`γ − δ` against `γ + δ` on loading), its transition from stick to
//! slip is as sharp as `ν` says, and its memory of an earlier amplitude
//! fades over cycles. Its residual, like the Iwan joint's, is the joint's:
//! level-dependent, in every harmonic, with no effect of its own to point
//! at, so every diagnosis of a joint with a slip force tries it.

use super::{
    Candidate, Context, best_as_it_stands, joint_misfit_score, replaceable_joint,
    replacing_parameters,
};
use crate::diagnose::lines::LineContext;
use crate::diagnose::{ResidualFeatures, SelectedEffect, fmt_value};
use crate::error::Result;
use crate::model::{ElementKind, ElementSpec, Model, Role};

/// See the module docs.
pub(crate) struct BoucWenJoint;

/// The starting shapes `(γ / (γ + δ), ν)`: symmetric and stiffer-unloading
/// loops, each at the exponential transition of `ν = 1` and a sharper one.
const SHAPES: [(f64, f64); 4] = [(0.5, 1.0), (0.5, 2.0), (0.8, 1.0), (0.8, 2.0)];

/// How much worse than the current model the best start may fit for the
/// law to be refitted. Its harmonic balance marches periods until the
/// loop's memory settles, so a refit costs several times another
/// candidate's (on the paper's test, 55 s of CPU against 5 for the Iwan
/// joint's); a start 10 times worse is far from a basin the data call for
/// (the paper's Jenkins test: 2000 times; a Bouc-Wen recording fitted with
/// a Masing law: 5; an Iwan one: 1.1).
const START_GATE: f64 = 10.0;

/// `model` with its joint replaced by a Bouc-Wen joint of each of
/// [`SHAPES`] (none when the joint cannot be replaced).
fn shapes(model: &Model) -> impl Iterator<Item = Model> + '_ {
    let joint = replaceable_joint(model, ElementKind::BoucWen);
    SHAPES.iter().filter_map(move |&(share, nu)| {
        let (kt, fs) = joint?;
        // saturation at fs: β (γ + δ) fs^ν = α, with β = α / fs
        let sum = fs.powf(1.0 - nu);
        let mut m = model.clone();
        m.joint = Some(ElementSpec::BoucWen {
            alpha: kt,
            beta: kt / fs,
            gamma: share * sum,
            delta: (1.0 - share) * sum,
            nu,
        });
        m.joint.as_ref()?.validate("joint").ok()?;
        Some(m)
    })
}

impl Candidate for BoucWenJoint {
    fn help(&self) -> Option<&'static str> {
        Some(
            "a Bouc-Wen joint in its place; tried when named, its refit costing many times the others'",
        )
    }

    fn law(&self) -> Option<ElementKind> {
        Some(ElementKind::BoucWen)
    }

    /// Its free parameters: the law's, but for the gauge `β` a fit holds.
    fn size(&self) -> usize {
        let law = ElementKind::BoucWen.description();
        law.parameters
            .iter()
            .filter(|p| p.role != Role::Gauge)
            .count()
    }

    /// Tried when named (`--candidates bouc_wen_joint`, or `all`): its
    /// refit costs many times another candidate's (harmonic balance marches
    /// periods until the loop's memory settles), and the start's gate
    /// ([`START_GATE`]) lets it through wherever the baseline misses by as
    /// much for another reason (a missing mode: 2x the diagnosis's time;
    /// the F-16: 9x).
    fn by_default(&self) -> bool {
        false
    }

    fn replaces_joint(&self) -> bool {
        true
    }

    /// A joint with a stick stiffness and a slip force to start from (not a
    /// Bouc-Wen joint already).
    fn applies_to(&self, model: &Model) -> bool {
        replaceable_joint(model, ElementKind::BoucWen).is_some()
    }

    /// Its free parameters in place of the fitted joint's.
    fn added_parameters(&self, before: &Model) -> usize {
        replacing_parameters(self.size(), before)
    }

    fn score(&self, f: &ResidualFeatures) -> f64 {
        joint_misfit_score(f)
    }

    /// The fitted joint's stick stiffness as `α` and its slip force as the
    /// force the law saturates at, `(α / (β (γ + δ)))^(1/ν)`, with `β` at
    /// the gauge every Bouc-Wen fit holds (`α` over the slip force, as
    /// `identify --element bouc_wen` starts it), at the shape of [`SHAPES`]
    /// whose model fits best as it stands (one prediction each); none when
    /// that start fits more than [`START_GATE`] times worse than the current
    /// model.
    fn starts(&self, cx: &Context<'_>) -> Result<Vec<Model>> {
        Ok(best_as_it_stands(cx, shapes(cx.model()))
            .filter(|(chi2, _)| *chi2 <= START_GATE * cx.current.chi2)
            .map(|(_, m)| m)
            .into_iter()
            .collect())
    }

    /// The same shapes, the one of lowest `χ²` on the lines, gated alike.
    fn line_starts(&self, cx: &LineContext<'_>) -> Vec<Model> {
        cx.best_as_it_stands(shapes(cx.model()))
            .filter(|(chi2, _)| *chi2 <= START_GATE * cx.chi2)
            .map(|(_, m)| m)
            .into_iter()
            .collect()
    }

    /// The law's stiffness and its sharpness: a `ν` run to its bound is a
    /// slider's sharp corner, which the law replaced already had.
    fn size_parameters(&self) -> &'static [&'static str] {
        &["alpha", "nu"]
    }

    /// A law swap cannot be taken out again: the model needs a joint.
    fn remove(&self, _model: &Model) -> Option<Model> {
        None
    }

    fn explain(&self, f: &ResidualFeatures, selected: &SelectedEffect) -> String {
        let p = |n: &str| selected.parameters.get(n).map(|e| e.value);
        // along a reversal the slope is α − β|z|^ν (δ − γ), against
        // α − β|z|^ν (γ + δ) while loading: γ > 0 unloads stiffer
        let shape = match (p("gamma"), p("delta"), p("nu")) {
            (Some(g), Some(d), Some(nu)) => format!(
                " (ν = {}, γ = {}, δ = {}: it unloads {} than it loads)",
                fmt_value(nu),
                fmt_value(g),
                fmt_value(d),
                if g > 0.0 { "stiffer" } else { "softer" },
            ),
            _ => String::new(),
        };
        format!(
            "the residual changed with level (slope {:.2}, {:.0} % of it level-dependent) in a way the fitted joint's Masing loops cannot follow, and a Bouc-Wen joint's loops do{shape}",
            f.growth_with_level,
            100.0 * (1.0 - f.level_independent_share)
        )
    }
}
