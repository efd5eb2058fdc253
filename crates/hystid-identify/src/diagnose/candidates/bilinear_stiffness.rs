//! A one-sided contact `kb x` for `x > 0`: even harmonics far above the
//! noise, which a symmetric joint cannot make.

use super::{Candidate, Context};
use crate::diagnose::lines::LineContext;
use crate::diagnose::{ResidualFeatures, SelectedEffect};
use crate::error::Result;
use crate::model::{ElementKind, ElementSpec, Model};

/// See the module docs.
pub(crate) struct BilinearStiffness;

fn with(kb: f64) -> ElementSpec {
    ElementSpec::BilinearStiffness { kb }
}

impl Candidate for BilinearStiffness {
    fn law(&self) -> Option<ElementKind> {
        Some(ElementKind::BilinearStiffness)
    }

    /// The worst even harmonic's `χ²/dof` above the noise's 1.
    fn score(&self, f: &ResidualFeatures) -> f64 {
        f.chi2_per_dof_by_harmonic
            .iter()
            .filter(|(h, _)| *h % 2 == 0)
            .map(|(_, c)| c - 1.0)
            .fold(0.0, f64::max)
    }

    /// Probed at 1 % of the stiffness, either sign (the contact may be on
    /// either side).
    fn starts(&self, cx: &Context<'_>) -> Result<Vec<Model>> {
        let (_, k) = cx.damping_and_stiffness();
        Ok(cx.sized_starts(&with, 0.01 * k, true))
    }

    /// Probed as on the FRFs, sized by the Gauss–Newton step on the lines.
    fn line_starts(&self, cx: &LineContext<'_>) -> Vec<Model> {
        let (_, k) = cx.damping_and_stiffness();
        cx.sized_starts(&with, 0.01 * k, true)
    }

    fn size_parameters(&self) -> &'static [&'static str] {
        &["kb"]
    }

    fn explain(&self, f: &ResidualFeatures, _: &SelectedEffect) -> String {
        let even: Vec<String> = f
            .chi2_per_dof_by_harmonic
            .iter()
            .filter(|(h, _)| *h % 2 == 0)
            .map(|(h, c)| format!("H{h} χ²/dof = {c:.1}"))
            .collect();
        format!(
            "even harmonics stood far above the noise ({}), which a symmetric joint cannot make: one side is stiffer",
            if even.is_empty() {
                "–".to_string()
            } else {
                even.join(", ")
            }
        )
    }
}
