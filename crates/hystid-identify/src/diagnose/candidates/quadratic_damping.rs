//! Quadratic damping `c2 |v| v`: the measured peaks fall short of the
//! model's more as the level rises (losses growing with velocity).

use super::{Candidate, Context};
use crate::diagnose::lines::LineContext;
use crate::diagnose::{ResidualFeatures, SelectedEffect};
use crate::error::Result;
use crate::model::{ElementKind, ElementSpec, Model};

/// See the module docs.
pub(crate) struct QuadraticDamping;

fn with(c2: f64) -> ElementSpec {
    ElementSpec::QuadraticDamping { c2 }
}

impl Candidate for QuadraticDamping {
    fn law(&self) -> Option<ElementKind> {
        Some(ElementKind::QuadraticDamping)
    }

    fn score(&self, f: &ResidualFeatures) -> f64 {
        5.0 * (-f.peak_ratio_trend).max(0.0) + f.growth_with_level.max(0.0)
    }

    /// Probed where it adds 1 % of the viscous damping at the largest
    /// velocity; never negative.
    fn starts(&self, cx: &Context<'_>) -> Result<Vec<Model>> {
        let (c, _) = cx.damping_and_stiffness();
        let (_, v_max) = cx.amplitudes();
        Ok(cx.sized_starts(&with, 0.01 * c / v_max, false))
    }

    /// Probed as on the FRFs, sized by the Gauss–Newton step on the lines.
    fn line_starts(&self, cx: &LineContext<'_>) -> Vec<Model> {
        let (c, _) = cx.damping_and_stiffness();
        let (_, v_max) = cx.amplitudes();
        cx.sized_starts(&with, 0.01 * c / v_max, false)
    }

    fn size_parameters(&self) -> &'static [&'static str] {
        &["c2"]
    }

    fn explain(&self, f: &ResidualFeatures, _: &SelectedEffect) -> String {
        // only a falling ratio is the shortfall this effect explains
        if f.peak_ratio_trend > -crate::diagnose::features::TREND_CORRELATION {
            return format!(
                "damping that grows with velocity fitted the residual better; the measured peaks show no clear shortfall against the model's with level (correlation {:+.2})",
                f.peak_ratio_trend
            );
        }
        format!(
            "the measured peaks fell short of the model's more at higher levels (correlation {:+.2}): damping that grows with velocity",
            f.peak_ratio_trend
        )
    }
}
