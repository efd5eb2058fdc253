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
        if !within_a_decade(e.ci95) {
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

/// Whether a 95 % interval resolves a value from zero and from a decade
/// either way: finite, of one sign, its ends within a factor 10.
pub(super) fn within_a_decade([lo, hi]: [f64; 2]) -> bool {
    let finite = lo.is_finite() && hi.is_finite();
    finite && ((lo > 0.0 && hi / lo <= 10.0) || (hi < 0.0 && lo / hi <= 10.0))
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

/// The largest change `after` makes to `before`'s predicted FRFs at any
/// measured point and harmonic judged, in units of that point's standard
/// error: how far the effect a refit added shows at the one point that
/// sees it best. A χ² drop pooled from many points that each move by a
/// fraction of their noise is what a model's own small inaccuracies (a
/// floor below the noise, the same at every point) also give; an effect of
/// the structure shows at some point by more than its noise.
pub(super) fn largest_change(data: &FitData, before: &Prediction, after: &Prediction) -> f64 {
    let mut largest = 0.0f64;
    for (s, series) in data.series.iter().enumerate() {
        for (p, point) in series.points.iter().enumerate() {
            let at = |pred: &Prediction| pred.h.get(s)?.get(p)?.clone();
            let (Some(b), Some(a)) = (at(before), at(after)) else {
                continue;
            };
            for ((x, y), sigma) in b.iter().zip(&a).zip(&point.std_error) {
                if *sigma > 0.0 {
                    largest = largest.max((x - y).norm() / sigma);
                }
            }
        }
    }
    largest
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::extract::Direction;
    use crate::fit::{MeasuredPoint, MeasuredSeries};
    use crate::harmonics::Quantity;
    use num_complex::Complex64;

    fn point(f: f64, sigma: [f64; 2]) -> MeasuredPoint {
        MeasuredPoint {
            frequency_hz: f,
            force_amplitude: 1.0,
            h: vec![Complex64::new(1.0, 0.0), Complex64::new(0.0, 0.0)],
            std_error: sigma.to_vec(),
            blocks: 16,
        }
    }

    /// The largest change is read point by point and harmonic by harmonic in
    /// that point's own standard error, not pooled: a change of 0.5 at a
    /// point of σ = 0.1 is 5σ, however small the other points' changes;
    /// a point whose solve failed on either side is passed over.
    #[test]
    fn the_largest_change_is_counted_in_each_points_own_noise() {
        let data = FitData {
            response: Quantity::Displacement,
            harmonics: vec![1, 2],
            series: vec![MeasuredSeries {
                level: 1.0,
                direction: Direction::Up,
                points: vec![
                    point(10.0, [1.0, 1.0]),
                    point(11.0, [0.1, 0.5]),
                    point(12.0, [1.0, 1.0]),
                ],
            }],
            response_sign: 1.0,
            transfer: false,
            unusable_points: 0,
            subharmonic_points: Vec::new(),
            anchor: None,
        };
        let h = |v: [[f64; 2]; 3]| Prediction {
            h: vec![
                v.iter()
                    .map(|p| Some(p.iter().map(|x| Complex64::new(*x, 0.0)).collect()))
                    .collect(),
            ],
            ..Prediction::default()
        };
        let before = h([[1.0, 0.0], [1.0, 0.0], [1.0, 0.0]]);
        let after = h([[1.2, 0.0], [1.0, 0.5], [1.0, 0.0]]);
        // 0.2/1 at the first point's H1, 0.5/0.5 at the second's H2
        assert!((largest_change(&data, &before, &after) - 1.0).abs() < 1e-12);
        let after = h([[1.2, 0.0], [1.5, 0.0], [1.0, 0.0]]);
        assert!((largest_change(&data, &before, &after) - 5.0).abs() < 1e-12);
        let mut failed = after.clone();
        failed.h[0][1] = None;
        assert!((largest_change(&data, &before, &failed) - 0.2).abs() < 1e-12);
    }
}
