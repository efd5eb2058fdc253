//! Whether the data resolve an effect's size: a refit's confidence intervals
//! and what they say of each effect it holds.

use super::{Effect, Refit, fmt_value, model_parameters};
use crate::error::Result;
use crate::fit::{FitData, FitProblem, HbPredictor, ParameterSet, Prediction, Weighting};
use crate::model::Model;

/// A refit's parameters and their confidence intervals: computed once per
/// model and asked of each effect it holds.
pub(super) struct Intervals {
    pub(super) params: ParameterSet,
    pub(super) conf: crate::fit::identify::Confidence,
}

impl Intervals {
    pub(super) fn at(r: &Refit, data: &FitData, predictor: &HbPredictor) -> Result<Intervals> {
        let params = model_parameters(&r.model, data.band_hz());
        let conf = confidence_at(&r.model, &params, &r.pred, data, predictor)?;
        Ok(Intervals { params, conf })
    }
}

/// Why the data do not resolve an effect's size in `r` (k3, kb, c2, a
/// clearance's stiffness, a mode's modal constant), if they do not: an
/// interval that includes zero (the effect may not be there at all) or
/// spans more than a decade. `intervals` are the refit's, computed once
/// for every effect it holds.
pub(super) fn unresolved_in(
    effect: Effect,
    r: &Refit,
    intervals: &Intervals,
    data: &FitData,
) -> Option<String> {
    let Intervals { params, conf } = intervals;
    let candidate = effect.candidate();
    for (p, e) in params.parameters.iter().zip(&conf.estimates) {
        let Some(name) = candidate.own_parameter(effect.name(), &r.model, &p.name) else {
            continue;
        };
        if let Some(why) = candidate.implausible(name, e, &r.model, data) {
            return Some(why);
        }
        // the effect's size; its shape (a mode's frequency and damping, a
        // gap) may sit at a bound without making the effect doubtful
        if !candidate.size_parameters().contains(&name) {
            continue;
        }
        let at_bound = p
            .bounds
            .iter()
            .any(|&b| b.is_finite() && (e.value - b).abs() <= 1e-9 * b.abs().max(e.value.abs()));
        if !e.identifiable {
            return Some(format!(
                "lowered χ² enough, but the data do not determine its {name}{}",
                e.note
                    .as_deref()
                    .map(|n| format!(" ({n})"))
                    .unwrap_or_default()
            ));
        }
        if at_bound || e.value == 0.0 {
            return Some(format!(
                "lowered χ² enough, but its {name} = {} sits at its bound: not resolved from the noise",
                fmt_value(e.value)
            ));
        }
        let [lo, hi] = e.ci95;
        let straddles = lo <= 0.0 && hi >= 0.0;
        let too_wide = !(lo.is_finite() && hi.is_finite())
            || (lo > 0.0 && hi / lo > 10.0)
            || (hi < 0.0 && lo / hi > 10.0);
        if straddles || too_wide {
            return Some(format!(
                "lowered χ² enough, but its {name} = {} has the 95 % interval [{}, {}]: not resolved from the noise",
                fmt_value(e.value),
                fmt_value(lo),
                fmt_value(hi)
            ));
        }
    }
    None
}

/// The σ-weighted confidence intervals of `params` at `model`.
pub(super) fn confidence_at(
    model: &Model,
    params: &ParameterSet,
    pred: &Prediction,
    data: &FitData,
    predictor: &HbPredictor,
) -> Result<crate::fit::identify::Confidence> {
    let problem = FitProblem::new(
        model.clone(),
        params.clone(),
        data,
        predictor,
        Weighting::StandardError,
        None,
    )
    .with_warm_start(pred.clone());
    let theta = params.theta_of(model)?;
    crate::fit::identify::confidence(&problem, &theta, pred)
}
