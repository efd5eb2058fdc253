//! A symmetric clearance, a spring `k` beyond `±gap`: the stiffness rises
//! beyond a certain amplitude on both sides (the measured peak moves up as
//! the level rises).

use super::{Candidate, Context};
use crate::diagnose::lines::LineContext;
use crate::diagnose::{ResidualFeatures, SelectedEffect};
use crate::error::Result;
use crate::model::{ElementKind, ElementSpec, Model};

/// See the module docs.
pub(crate) struct Clearance;

/// The gaps tried, as fractions of the largest amplitude.
const GAPS: [f64; 3] = [0.25, 0.5, 0.75];

impl Candidate for Clearance {
    fn law(&self) -> Option<ElementKind> {
        Some(ElementKind::Clearance)
    }

    fn score(&self, f: &ResidualFeatures) -> f64 {
        2.0 * f.peak_shift_trend.max(0.0)
    }

    /// Gaps at a quarter, half and three quarters of the largest amplitude,
    /// each with its stiffness scanned from 1 % of the structure's; the
    /// best of the three.
    fn starts(&self, cx: &Context<'_>) -> Result<Vec<Model>> {
        let (_, k) = cx.damping_and_stiffness();
        let (a_max, _) = cx.amplitudes();
        Ok(GAPS
            .iter()
            .filter_map(|&g| {
                let gap = g * a_max;
                crate::diagnose::scan_start(
                    cx.model(),
                    cx.data,
                    cx.pred(),
                    cx.predictor,
                    &|p| ElementSpec::Clearance { k: p, gap },
                    0.01 * k,
                    false,
                )
                .map(|(kc, chi2, _)| (ElementSpec::Clearance { k: kc, gap }, chi2))
            })
            .min_by(|a, b| a.1.total_cmp(&b.1))
            .map(|(e, _)| cx.with_element(e))
            .into_iter()
            .collect())
    }

    /// The same gaps, each stiffness sized by the Gauss–Newton step on the
    /// lines; the one of lowest `χ²` there.
    fn line_starts(&self, cx: &LineContext<'_>) -> Vec<Model> {
        let (_, k) = cx.damping_and_stiffness();
        let (a_max, _) = cx.amplitudes();
        let sized = GAPS.iter().flat_map(|&g| {
            let gap = g * a_max;
            cx.sized_starts(&|p| ElementSpec::Clearance { k: p, gap }, 0.01 * k, false)
        });
        cx.best_as_it_stands(sized)
            .map(|(_, m)| m)
            .into_iter()
            .collect()
    }

    fn size_parameters(&self) -> &'static [&'static str] {
        &["k"]
    }

    fn explain(&self, _: &ResidualFeatures, _: &SelectedEffect) -> String {
        "the stiffness rose beyond a certain amplitude on both sides: a gap closing".to_string()
    }
}
