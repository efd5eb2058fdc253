//! The shaker between a voltage drive and the structure (see
//! [`crate::model::Shaker`]): with a voltage reference the force reaching the
//! structure lags the drive by the coil's time constant (a phase the modes'
//! real modal constants cannot make) and its back-EMF damps the motion, both
//! the same at every level.

use super::{Candidate, Context, best_as_it_stands};
use crate::diagnose::lines::LineContext;
use crate::diagnose::{ResidualFeatures, SelectedEffect};
use crate::error::Result;
use crate::harmonics::Quantity;
use crate::model::{ElementKind, ElementSpec, Model};

/// See the module docs.
pub(crate) struct Shaker;

/// The coil's lags tried as starts, as phases at the first mode: 3, 9 and
/// 22 degrees (`ωτ = 0.05, 0.15, 0.4`).
const LAGS: [f64; 3] = [0.05, 0.15, 0.4];

impl Candidate for Shaker {
    fn help(&self) -> Option<&'static str> {
        Some(
            "the coil's lag and back-EMF between a voltage reference and the structure; for a voltage reference only",
        )
    }

    fn law(&self) -> Option<ElementKind> {
        Some(ElementKind::Shaker)
    }

    /// Not on a model that has one.
    fn applies_to(&self, model: &Model) -> bool {
        model.laws().all(|e| e.drive_load().is_none())
    }

    fn not_applicable_to(&self, reference: Quantity) -> Option<&'static str> {
        (reference != Quantity::Voltage).then_some(
            "the reference is a measured force, which needs no model of the shaker that made it",
        )
    }

    fn score(&self, f: &ResidualFeatures) -> f64 {
        3.0 * f.level_independent_share
    }

    /// Only for a voltage reference (a measured force needs no model of
    /// what made it): the first point mode's viscous damping split half and
    /// half between the structure and the back-EMF (which one frequency
    /// cannot tell apart), at the lags of [`LAGS`]; the best as it stands.
    fn starts(&self, cx: &Context<'_>) -> Result<Vec<Model>> {
        if cx.frf.reference != Quantity::Voltage {
            return Ok(Vec::new());
        }
        Ok(best_as_it_stands(cx, lagged(cx.model()).into_iter())
            .map(|(_, m)| m)
            .into_iter()
            .collect())
    }

    /// The same coils, the one of lowest `χ²` on a multisine's lines, for a
    /// voltage reference only.
    fn line_starts(&self, cx: &LineContext<'_>) -> Vec<Model> {
        if cx.reference_quantity() != Quantity::Voltage {
            return Vec::new();
        }
        cx.best_as_it_stands(lagged(cx.model()).into_iter())
            .map(|(_, m)| m)
            .into_iter()
            .collect()
    }

    fn size_parameters(&self) -> &'static [&'static str] {
        &["te"]
    }

    fn explain(&self, _: &ResidualFeatures, selected: &SelectedEffect) -> String {
        let lag = selected
            .parameters
            .get("te")
            .map(|e| format!(" of {:.3} ms", 1e3 * e.value))
            .unwrap_or_default();
        format!(
            "the response lagged the voltage by more than the modes could: a lag{lag} between \
             the drive and the structure, as a shaker's coil makes, with its back-EMF damping \
             (which a band around one mode cannot tell from the modes' own; a delay in the \
             amplifier or the sensor lags alike)"
        )
    }
}
/// `model` with a shaker at each lag of [`LAGS`] at its first mode, the
/// back-EMF taking half the mode's damping (empty where the model has no
/// such mode).
fn lagged(model: &Model) -> Vec<Model> {
    let Some(first) = model.linear.modes.iter().position(|m| !m.is_hysteretic()) else {
        return Vec::new();
    };
    let mode = model.linear.modes[first];
    let (w, c) = (mode.omega(), mode.modal_damping());
    if !(w > 0.0 && c.is_finite() && c > 0.0) {
        return Vec::new();
    }
    let mut base = model.clone();
    base.linear.modes[first].damping_ratio *= 0.5;
    LAGS.iter()
        .map(|&wt| {
            base.with_effect(ElementSpec::Shaker {
                ce: 0.5 * c,
                te: wt / w,
                gain: 1.0,
            })
        })
        .collect()
}
