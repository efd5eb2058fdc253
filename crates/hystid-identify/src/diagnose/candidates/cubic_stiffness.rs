//! A cubic stiffness `k3 x³`: the measured peak moves against the model as
//! the level rises (a hardening or softening no joint can make).

use super::{Candidate, Context};
use crate::diagnose::lines::LineContext;
use crate::diagnose::{ResidualFeatures, SelectedEffect};
use crate::error::Result;
use crate::model::{ElementKind, ElementSpec, Model};

/// See the module docs.
pub(crate) struct CubicStiffness;

fn with(k3: f64) -> ElementSpec {
    ElementSpec::CubicStiffness { k3 }
}

/// 1 % of the stiffness `k` at the largest amplitude `a_max`.
fn probe(k: f64, a_max: f64) -> f64 {
    0.01 * k / (a_max * a_max)
}

impl Candidate for CubicStiffness {
    fn law(&self) -> Option<ElementKind> {
        Some(ElementKind::CubicStiffness)
    }

    fn score(&self, f: &ResidualFeatures) -> f64 {
        5.0 * f.peak_shift_trend.abs() + f.growth_with_level.max(0.0)
    }

    /// Probed where it adds 1 % of the stiffness at the largest amplitude,
    /// either sign.
    fn starts(&self, cx: &Context<'_>) -> Result<Vec<Model>> {
        let (_, k) = cx.damping_and_stiffness();
        let (a_max, _) = cx.amplitudes();
        Ok(cx.sized_starts(&with, probe(k, a_max), true))
    }

    /// Probed as on the FRFs, sized by the Gauss–Newton step on the lines.
    fn line_starts(&self, cx: &LineContext<'_>) -> Vec<Model> {
        let (_, k) = cx.damping_and_stiffness();
        let (a_max, _) = cx.amplitudes();
        cx.sized_starts(&with, probe(k, a_max), true)
    }

    fn size_parameters(&self) -> &'static [&'static str] {
        &["k3"]
    }

    fn explain(&self, f: &ResidualFeatures, _: &SelectedEffect) -> String {
        if f.peak_shift_trend.abs() < crate::diagnose::features::TREND_CORRELATION {
            return format!(
                "the residual changed with level (slope {:.2}); the measured peak shows no clear shift with level relative to the model (correlation {:+.2})",
                f.growth_with_level, f.peak_shift_trend
            );
        }
        let dir = if f.peak_shift_trend > 0.0 {
            "upward"
        } else {
            "downward"
        };
        format!(
            "the residual changed with level (slope {:.2}) and the measured peak moved {dir} relative to the model as the level rose (correlation {:+.2}), which the joint cannot do",
            f.growth_with_level, f.peak_shift_trend
        )
    }
}
