//! The residual of a model refined on the recorded time histories, in the
//! plane the FRFs live in, traced to the candidates.
//!
//! A model fitted in the time domain leaves a residual in time,
//! `y_measured(t) − y_replayed(t)`. The measured response and the model's
//! replay (driven by the measured reference) are reduced into nonlinear FRFs
//! the same way: the same windows of the same reference, the same sweep
//! compensation. Their difference is then the time residual per level,
//! frequency and harmonic, in units of the measured noise, and what the
//! reduction does to a steady state (a sweep's distortion, a transient left
//! in a dwell) is in both and cancels. Its features are those of
//! [`mod@super::features`]: which harmonics, which levels, where the peaks sit.
//!
//! Each candidate is traced by its own signature in that plane: `δ_c`, how
//! the model's harmonic-balance FRFs change when the candidate, as the FRFs
//! size it, is added to the refined model. The share of the residual's `χ²`
//! that a step along `δ_c` removes at best,
//!
//! `s_c = max(0, ⟨r, δ_c⟩)² / (‖r‖² ‖δ_c‖²)`,
//!
//! (the Gauss–Newton step in that one direction, its size kept to the sign
//! the FRFs gave it; the inner product over points and judged harmonics,
//! real and imaginary parts, each scaled by the measured standard error)
//! ranks the candidates: those that explain the most of what the time
//! histories still show are put to them first. A candidate whose effect the
//! residual does not contain, or contains with the other sign, scores near
//! zero however large the FRFs made it.

use crate::diagnose::Effect;
use crate::fit::{FitData, Prediction};
use num_complex::Complex64;
use serde::Serialize;

use super::features::ResidualFeatures;

/// The time residual's features and how much of it each candidate explains.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct TimeResidual {
    /// The features of the measured FRFs against the replay's, reduced
    /// alike (see the module docs).
    pub features: ResidualFeatures,
    /// Points judged (those both reductions hold).
    pub points: usize,
    /// Each candidate traced, the largest share first (empty when no
    /// candidate was put to the time histories).
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub traced: Vec<TracedCandidate>,
}

/// One candidate traced in the time residual.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct TracedCandidate {
    /// The effect.
    pub effect: Effect,
    /// `s_c` of the module docs: the share of the time residual's `χ²` a
    /// step along the candidate's signature removes (0..1; `NaN` when it
    /// could not be traced).
    pub share: f64,
    /// Why it could not be traced, when it could not.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub failed: Option<String>,
}

/// The replay's FRFs as a prediction of `data`: each point of each level
/// matched to the replay's point of the same level at the same frequency
/// (the same reference reduced alike gives the same frequencies, to
/// rounding); `None` where the replay has no such point.
pub fn replay_prediction(data: &FitData, replayed: &FitData) -> Prediction {
    let h = data
        .series
        .iter()
        .enumerate()
        .map(|(s, series)| {
            let theirs = replayed.series.get(s).filter(|r| {
                (r.level - series.level).abs() <= 1e-9 * series.level.abs().max(f64::MIN_POSITIVE)
            });
            series
                .points
                .iter()
                .map(|p| {
                    let r = theirs?.points.iter().find(|q| {
                        (q.frequency_hz - p.frequency_hz).abs() <= 1e-9 * p.frequency_hz.abs()
                    })?;
                    (r.h.len() == p.h.len()).then(|| r.h.clone())
                })
                .collect()
        })
        .collect();
    Prediction {
        h,
        ..Prediction::default()
    }
}

/// Points of `data` that every prediction holds.
fn common_points(data: &FitData, predictions: &[&Prediction]) -> usize {
    let mut n = 0;
    for (s, series) in data.series.iter().enumerate() {
        for i in 0..series.points.len() {
            if predictions.iter().all(|p| at(p, s, i).is_some()) {
                n += 1;
            }
        }
    }
    n
}

fn at(p: &Prediction, s: usize, i: usize) -> Option<&Vec<Complex64>> {
    p.h.get(s)?.get(i)?.as_ref()
}

/// `s_c` of the module docs: `replayed` is the refined model's replay
/// reduced as `data` was; `without` and `with` the harmonic-balance FRFs of
/// the refined model and of the refined model with the candidate. Judged on
/// the points all three hold. 0 where the candidate changes nothing or the
/// residual is nil.
pub fn share_explained(
    data: &FitData,
    replayed: &Prediction,
    without: &Prediction,
    with: &Prediction,
) -> f64 {
    let (mut rd, mut rr, mut dd) = (0.0, 0.0, 0.0);
    for (s, series) in data.series.iter().enumerate() {
        for (i, p) in series.points.iter().enumerate() {
            let (Some(y), Some(a), Some(b)) =
                (at(replayed, s, i), at(without, s, i), at(with, s, i))
            else {
                continue;
            };
            for k in 0..p.h.len() {
                let w = 1.0 / p.std_error[k].max(f64::MIN_POSITIVE);
                let r = (p.h[k] - y[k]) * w;
                let d = (b[k] - a[k]) * w;
                rd += r.re * d.re + r.im * d.im;
                rr += r.norm_sqr();
                dd += d.norm_sqr();
            }
        }
    }
    if rd <= 0.0 || rr <= 0.0 || dd <= 0.0 {
        0.0
    } else {
        (rd * rd / (rr * dd)).min(1.0)
    }
}

/// The time residual of `replayed` against `data` (see the module docs),
/// with no candidate traced yet.
pub fn time_residual(data: &FitData, replayed: &FitData) -> (TimeResidual, Prediction) {
    let pred = replay_prediction(data, replayed);
    let residual = TimeResidual {
        features: super::features::features(data, &pred),
        points: common_points(data, &[&pred]),
        traced: Vec::new(),
    };
    (residual, pred)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::fit::{MeasuredPoint, MeasuredSeries};

    fn data(points: &[(f64, Complex64)]) -> FitData {
        FitData {
            response: crate::harmonics::Quantity::Displacement,
            harmonics: vec![1],
            series: vec![MeasuredSeries {
                level: 10.0,
                direction: crate::extract::Direction::Up,
                points: points
                    .iter()
                    .map(|&(f, h)| MeasuredPoint {
                        frequency_hz: f,
                        force_amplitude: 10.0,
                        h: vec![h],
                        std_error: vec![0.5],
                        blocks: 0,
                    })
                    .collect(),
            }],
            response_sign: 1.0,
            transfer: false,
            unusable_points: 0,
            subharmonic_points: Vec::new(),
            anchor: None,
        }
    }

    /// A residual that is exactly the candidate's signature is explained
    /// whole; one orthogonal to it not at all; the opposite sign not at
    /// all; half and half: the squared cosine, 1/2.
    #[test]
    fn the_share_is_the_squared_cosine_of_residual_and_signature() {
        let c = |re, im| Complex64::new(re, im);
        let measured = data(&[(10.0, c(1.0, 0.0)), (11.0, c(0.0, 2.0))]);
        let replay_of = |h: &[Complex64]| Prediction {
            h: vec![h.iter().map(|&v| Some(vec![v])).collect()],
            ..Prediction::default()
        };
        let replayed = replay_of(&[c(0.0, 0.0), c(0.0, 0.0)]);
        let without = replay_of(&[c(5.0, 5.0), c(5.0, 5.0)]);
        let along = replay_of(&[c(5.5, 5.0), c(5.0, 6.0)]);
        let across = replay_of(&[c(5.0, 5.0), c(6.0, 5.0)]);
        let against = replay_of(&[c(4.5, 5.0), c(5.0, 4.0)]);
        let half = replay_of(&[c(6.0, 5.0), c(5.0, 5.0)]);
        let s = |with: &Prediction| share_explained(&measured, &replayed, &without, with);
        assert!((s(&along) - 1.0).abs() < 1e-12, "{}", s(&along));
        assert_eq!(s(&across), 0.0);
        assert_eq!(s(&against), 0.0);
        // r = (1, 2i)/σ, δ = (1, 0)/σ: cos² = 1/5
        assert!((s(&half) - 0.2).abs() < 1e-12, "{}", s(&half));
        // a point the replay lacks is left out of every sum
        let gap = Prediction {
            h: vec![vec![Some(vec![c(0.0, 0.0)]), None]],
            ..Prediction::default()
        };
        assert!((share_explained(&measured, &gap, &without, &half) - 1.0).abs() < 1e-12);
    }

    /// The replay's points are matched by level and frequency, not by
    /// position: a replay with a point fewer leaves that point out.
    #[test]
    fn replay_points_are_matched_by_frequency() {
        let c = |re| Complex64::new(re, 0.0);
        let measured = data(&[(10.0, c(1.0)), (11.0, c(2.0)), (12.0, c(3.0))]);
        let replayed = data(&[(10.0, c(1.5)), (12.0, c(2.5))]);
        let p = replay_prediction(&measured, &replayed);
        assert_eq!(p.h[0][0].as_ref().unwrap()[0], c(1.5));
        assert!(p.h[0][1].is_none());
        assert_eq!(p.h[0][2].as_ref().unwrap()[0], c(2.5));
        let (r, _) = time_residual(&measured, &replayed);
        assert_eq!(r.points, 2);
        // |z|² = 2 |Δ|²/σ² = 2 (0.25 + 0.25)/0.25 over 2 dof each: chi²/dof 1
        assert!((r.features.chi2_per_dof_by_harmonic[&1] - 1.0).abs() < 1e-12);
    }
}
