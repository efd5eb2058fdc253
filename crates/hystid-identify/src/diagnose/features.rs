//! What a fit's residual says: its features, in units of the measured noise.
//!
//! The residual `H_measured − H_model` is taken per level, frequency and
//! harmonic, and scaled by the measured standard error, so `|z|² ≈ 2` per
//! point means "consistent with the noise". Its features point to what the
//! model lacks (the paper's section 4: "something in the structure that is not
//! taken into account"):
//!
//! * even harmonics and DC well above the noise: the element is not
//!   symmetric (a symmetric element under symmetric forcing makes only odd
//!   harmonics);
//! * a residual that is the same at every level: a linear effect, such as a
//!   mode the model does not have;
//! * a peak that shifts with level differently from the model's: a stiffness
//!   the element cannot produce (the joint only softens);
//! * a peak that falls short of the model's more at high levels: damping
//!   that grows with velocity.

use crate::fit::{FitData, MeasuredPoint, Prediction};
use crate::harmonics::omega;
use num_complex::Complex64;
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;

/// The residual's features.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ResidualFeatures {
    /// `χ²` per degree of freedom, per harmonic.
    pub chi2_per_dof_by_harmonic: BTreeMap<usize, f64>,
    /// `χ²` per degree of freedom of the fundamental, per level (in the data's
    /// order), with the level.
    pub chi2_per_dof_by_level: Vec<(f64, f64)>,
    /// Slope of `ln χ²` against `ln level` for the fundamental: > 0 when the
    /// misfit grows with level.
    pub growth_with_level: f64,
    /// Share of the fundamental's residual that is the same at every level
    /// (0..1): high for a linear effect.
    pub level_independent_share: f64,
    /// Per level: measured minus model peak frequency of `|H1|`, Hz.
    pub peak_shift_hz: Vec<(f64, f64)>,
    /// Per level: measured over model peak `|H1|`.
    pub peak_ratio: Vec<(f64, f64)>,
    /// Correlation of the peak shift with level (−1..1): > 0 when the
    /// measured peak moves up relative to the model as the level grows.
    pub peak_shift_trend: f64,
    /// Correlation of the peak ratio with level: < 0 when the measured peak
    /// falls short of the model more at high levels.
    pub peak_ratio_trend: f64,
}

/// The smallest `|r|` of a trend's correlation with level that an
/// explanation calls a trend: with a few levels, a weaker correlation is as
/// likely scatter as a shift, and saying "the peak moved downward" on
/// `r = −0.04` claims what the data do not show.
pub const TREND_CORRELATION: f64 = 0.5;

/// `|z|²` of a point and harmonic (2 expected for noise).
fn z2(meas: Complex64, model: Complex64, sigma: f64) -> f64 {
    2.0 * (meas - model).norm_sqr() / sigma.max(f64::MIN_POSITIVE).powi(2)
}

fn correlation(x: &[f64], y: &[f64]) -> f64 {
    let n = x.len() as f64;
    if x.len() < 3 {
        return 0.0;
    }
    let (mx, my) = (x.iter().sum::<f64>() / n, y.iter().sum::<f64>() / n);
    let (mut sxy, mut sxx, mut syy) = (0.0, 0.0, 0.0);
    for (a, b) in x.iter().zip(y) {
        sxy += (a - mx) * (b - my);
        sxx += (a - mx).powi(2);
        syy += (b - my).powi(2);
    }
    if sxx <= 0.0 || syy <= 0.0 {
        0.0
    } else {
        sxy / (sxx * syy).sqrt()
    }
}

/// The features of `pred`'s residual against `data`.
pub fn features(data: &FitData, pred: &Prediction) -> ResidualFeatures {
    let nh = data.harmonics.len();
    let mut by_h = vec![(0.0, 0usize); nh];
    let mut by_level = Vec::new();
    let k1 = data.harmonic_index(1);
    for (s, ps) in data.series.iter().zip(&pred.h) {
        let mut lev = (0.0, 0usize);
        for (p, m) in s.points.iter().zip(ps) {
            let Some(m) = m else { continue };
            for k in 0..nh {
                let v = z2(p.h[k], m[k], p.std_error[k]);
                by_h[k].0 += v;
                by_h[k].1 += 2;
                if Some(k) == k1 {
                    lev.0 += v;
                    lev.1 += 2;
                }
            }
        }
        by_level.push((s.level, lev.0 / lev.1.max(1) as f64));
    }
    let chi2_per_dof_by_harmonic = data
        .harmonics
        .iter()
        .zip(&by_h)
        .map(|(&h, &(c, n))| (h, c / n.max(1) as f64))
        .collect();
    let growth = log_slope(&by_level);
    let share = k1.map_or(0.0, |k| common_share(data, pred, k));
    let (peak_shift, peak_ratio) =
        k1.map_or_else(Default::default, |k| peak_changes(data, pred, k));
    let levels: Vec<f64> = peak_shift.iter().map(|(l, _)| l.ln()).collect();
    ResidualFeatures {
        chi2_per_dof_by_harmonic,
        chi2_per_dof_by_level: by_level,
        growth_with_level: growth,
        level_independent_share: share,
        peak_shift_trend: correlation(&levels, &peak_shift.iter().map(|p| p.1).collect::<Vec<_>>()),
        peak_ratio_trend: correlation(&levels, &peak_ratio.iter().map(|p| p.1).collect::<Vec<_>>()),
        peak_shift_hz: peak_shift,
        peak_ratio,
    }
}

/// The slope of `ln χ²/dof` against `ln level`: how the residual grows with
/// the level.
fn log_slope(by_level: &[(f64, f64)]) -> f64 {
    let lx: Vec<f64> = by_level.iter().map(|(l, _)| l.ln()).collect();
    let ly: Vec<f64> = by_level.iter().map(|(_, c)| c.max(1e-12).ln()).collect();
    let n = lx.len() as f64;
    let (mx, my) = (lx.iter().sum::<f64>() / n, ly.iter().sum::<f64>() / n);
    let sxx: f64 = lx.iter().map(|x| (x - mx).powi(2)).sum();
    if sxx > 0.0 {
        lx.iter()
            .zip(&ly)
            .map(|(x, y)| (x - mx) * (y - my))
            .sum::<f64>()
            / sxx
    } else {
        0.0
    }
}

/// The share of the fundamental's residual (at harmonic index `k`) common
/// to all levels, on the frequencies every level has.
fn common_share(data: &FitData, pred: &Prediction, k: usize) -> f64 {
    let mut grid: BTreeMap<u64, Vec<Complex64>> = BTreeMap::new();
    for (s, ps) in data.series.iter().zip(&pred.h) {
        for (p, m) in s.points.iter().zip(ps) {
            if let Some(m) = m {
                grid.entry((p.frequency_hz * 1e6).round() as u64)
                    .or_default()
                    .push((p.h[k] - m[k]) / p.std_error[k].max(f64::MIN_POSITIVE));
            }
        }
    }
    let (mut total, mut common) = (0.0, 0.0);
    for v in grid
        .values()
        .filter(|v| v.len() == data.series.len() && v.len() > 1)
    {
        let mean: Complex64 = v.iter().sum::<Complex64>() / v.len() as f64;
        total += v.iter().map(|z| z.norm_sqr()).sum::<f64>();
        common += v.len() as f64 * mean.norm_sqr();
    }
    if total > 0.0 { common / total } else { 0.0 }
}

/// The shift of the peak of `|H1|` (harmonic index `k`) from the model's,
/// and the ratio of their heights, per level.
fn peak_changes(data: &FitData, pred: &Prediction, k: usize) -> (Vec<(f64, f64)>, Vec<(f64, f64)>) {
    let mut peak_shift = Vec::new();
    let mut peak_ratio = Vec::new();
    for (s, ps) in data.series.iter().zip(&pred.h) {
        let meas = s
            .points
            .iter()
            .enumerate()
            .max_by(|a, b| a.1.h[k].norm().total_cmp(&b.1.h[k].norm()));
        let model = s
            .points
            .iter()
            .zip(ps)
            .enumerate()
            .filter_map(|(i, (p, m))| m.as_ref().map(|m| (i, p.frequency_hz, m[k].norm())))
            .max_by(|a, b| a.2.total_cmp(&b.2));
        if let (Some((_, mp)), Some((_, mf, mv))) = (meas, model) {
            peak_shift.push((
                s.level,
                refined_peak(s, k, true).unwrap_or(mp.frequency_hz)
                    - refined_model_peak(s, ps, k).unwrap_or(mf),
            ));
            peak_ratio.push((s.level, mp.h[k].norm() / mv));
        }
    }
    (peak_shift, peak_ratio)
}

/// The peak of `|H_k|` refined by a parabola through the three largest
/// neighbouring points (measured).
fn refined_peak(s: &crate::fit::MeasuredSeries, k: usize, _measured: bool) -> Option<f64> {
    let v: Vec<(f64, f64)> = s
        .points
        .iter()
        .map(|p| (p.frequency_hz, p.h[k].norm()))
        .collect();
    parabola_peak(&v)
}

fn refined_model_peak(
    s: &crate::fit::MeasuredSeries,
    ps: &[Option<Vec<Complex64>>],
    k: usize,
) -> Option<f64> {
    let v: Vec<(f64, f64)> = s
        .points
        .iter()
        .zip(ps)
        .filter_map(|(p, m)| m.as_ref().map(|m| (p.frequency_hz, m[k].norm())))
        .collect();
    parabola_peak(&v)
}

fn parabola_peak(v: &[(f64, f64)]) -> Option<f64> {
    let mut v = v.to_vec();
    v.sort_by(|a, b| a.0.total_cmp(&b.0));
    let i = (0..v.len()).max_by(|&a, &b| v[a].1.total_cmp(&v[b].1))?;
    if i == 0 || i + 1 >= v.len() {
        return Some(v[i].0);
    }
    let (x0, y0) = v[i - 1];
    let (x1, y1) = v[i];
    let (x2, y2) = v[i + 1];
    let d = (x0 - x1) * (x0 - x2) * (x1 - x2);
    if d == 0.0 {
        return Some(x1);
    }
    let a = (x2 * (y1 - y0) + x1 * (y0 - y2) + x0 * (y2 - y1)) / d;
    let b = (x2 * x2 * (y0 - y1) + x1 * x1 * (y2 - y0) + x0 * x0 * (y1 - y2)) / d;
    if a >= 0.0 {
        return Some(x1);
    }
    Some((-b / (2.0 * a)).clamp(x0, x2))
}

/// A measured point with its model fundamental and the factor `conv`.
type PointWithModel<'a> = (&'a MeasuredPoint, Complex64, Complex64);

/// The measured points with a model prediction, grouped by frequency (1e-6 Hz
/// apart counts as one), each with its fundamental's index, its `ω` and the
/// factor `conv` that turns a receptance into the data's response quantity:
/// the frequency grid on which a residual common to all levels is read.
fn fundamental_by_frequency<'a>(
    data: &'a FitData,
    pred: &'a Prediction,
) -> Option<(usize, BTreeMap<u64, Vec<PointWithModel<'a>>>)> {
    let k = data.harmonic_index(1)?;
    let mut grid: BTreeMap<u64, Vec<_>> = BTreeMap::new();
    for (s, ps) in data.series.iter().zip(&pred.h) {
        for (p, m) in s.points.iter().zip(ps) {
            if let Some(m) = m {
                let conv = data.response.from_displacement(omega(p.frequency_hz));
                grid.entry((p.frequency_hz * 1e6).round() as u64)
                    .or_default()
                    .push((p, m[k], conv));
            }
        }
    }
    Some((k, grid))
}

/// The level-averaged fundamental residual as a receptance, per frequency
/// (`(f, mean residual, mean σ)`), for locating a missing mode.
pub fn common_receptance_residual(data: &FitData, pred: &Prediction) -> Vec<(f64, Complex64, f64)> {
    let Some((k, grid)) = fundamental_by_frequency(data, pred) else {
        return Vec::new();
    };
    grid.values()
        .map(|pts| {
            let n = pts.len() as f64;
            let d: Complex64 = pts.iter().map(|(p, m, c)| (p.h[k] - m) / c).sum();
            let s: f64 = pts.iter().map(|(p, _, c)| p.std_error[k] / c.norm()).sum();
            (pts[0].0.frequency_hz, d / n, s / n / n.sqrt())
        })
        .collect()
}

/// The model's receptance sensitivities to its stiffness, mass and damping
/// (`−H²`, `ω²H²`, `−iωH²` of a single-mode dynamic stiffness, averaged over
/// the levels), at the points of [`common_receptance_residual`]: what the
/// fitted model can already absorb of a missing mode by bending its own
/// linear parameters.
pub fn common_receptance_background(data: &FitData, pred: &Prediction) -> Vec<Vec<Complex64>> {
    let Some((_, grid)) = fundamental_by_frequency(data, pred) else {
        return Vec::new();
    };
    let mean = |pts: &[PointWithModel<'_>], j: usize| {
        let sum: Complex64 = pts
            .iter()
            .map(|(p, m, c)| {
                let w = omega(p.frequency_hz);
                let h2 = (m / c) * (m / c);
                [-h2, w * w * h2, -Complex64::i() * w * h2][j]
            })
            .sum();
        sum / pts.len() as f64
    };
    (0..3)
        .map(|j| grid.values().map(|pts| mean(pts, j)).collect())
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parabola_finds_a_sampled_peak() {
        let f = |x: f64| 1.0 / ((x - 101.3f64).powi(2) + 4.0);
        let v: Vec<(f64, f64)> = (0..21)
            .map(|i| (90.0 + i as f64, f(90.0 + i as f64)))
            .collect();
        let p = parabola_peak(&v).unwrap();
        assert!((p - 101.3).abs() < 0.1, "{p}");
    }
}
