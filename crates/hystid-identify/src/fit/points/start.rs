//! The fit's start: the linear modes of the lowest level, where the joint
//! sticks, and the structure beside the joint once its stick stiffness is
//! taken out of them.
//!
//! The linear modes start from peaks of the summed, normalised receptances
//! `Σ_p |H_pd|/max|H_pd|` (a parabola through each peak's three lines in
//! `ln`), each mode's pole fitted near its own peak and every residue over
//! all the lines ([`super::poles`]); then Levenberg–Marquardt fits them to
//! the level's FRFs. Fitted near its peak, a mode is not pulled towards a
//! larger neighbour by lines far from it. Where a peak's neighbourhood
//! holds no mode, the start is its quadrature response,
//! `Im H_pd(ω_r) ≈ −φ_r(p) φ_r(d)/(2 ζ_r ω_r²)` at a damping ratio of
//! [`START_DAMPING`].

use super::layout::Layout;
use super::poles::peak_modes;
use super::problem::{LinearProblem, check_lines};
use super::{PointMeasurement, PointModes};
use crate::error::{Error, Result};
use crate::fit::optimise::levenberg_marquardt;
use crate::model::ShapedMode;
use num_complex::Complex64;
use std::f64::consts::PI;
use std::sync::atomic::AtomicUsize;

/// The damping ratio every mode starts at.
pub const START_DAMPING: f64 = 0.02;

/// The level of the smallest median force amplitude.
pub fn lowest_level(data: &[PointMeasurement]) -> Result<usize> {
    let first = data
        .first()
        .ok_or_else(|| Error::input("data", "no measurement"))?;
    let median = |l: usize| median_force(&first.levels[l]).unwrap_or(f64::INFINITY);
    (0..first.levels.len())
        .min_by(|&a, &b| median(a).total_cmp(&median(b)))
        .ok_or_else(|| Error::input("data", "no level"))
}

/// The median force amplitude of a level's lines (`None`: no line).
pub(super) fn median_force(level: &super::PointLevel) -> Option<f64> {
    let mut f: Vec<f64> = level.lines.iter().map(|x| x.force_amplitude).collect();
    f.sort_by(f64::total_cmp);
    f.get(f.len() / 2).copied()
}

/// The receptance of measurement `m` at each line of `level`.
fn receptances(m: &PointMeasurement, level: usize) -> Vec<Complex64> {
    m.levels[level]
        .lines
        .iter()
        .map(|l| l.h / m.response.from_displacement(2.0 * PI * l.frequency_hz))
        .collect()
}

/// The receptances of `data`'s level `level`, `[p][k]` in point order,
/// and the lines' `ω`.
fn receptances_by_point(
    data: &[PointMeasurement],
    level: usize,
) -> (Vec<f64>, Vec<Vec<Complex64>>) {
    let omega: Vec<f64> = (data[0].levels[level].lines.iter())
        .map(|l| 2.0 * PI * l.frequency_hz)
        .collect();
    let mut by_point: Vec<&PointMeasurement> = data.iter().collect();
    by_point.sort_by_key(|m| m.point);
    let h = by_point.iter().map(|m| receptances(m, level)).collect();
    (omega, h)
}

/// How far `y[i]` stands above the higher of the lowest values on either
/// side before a higher one (or the end): a ripple beside a resonance
/// stands out less than a small mode of its own.
fn prominence(y: &[f64], i: usize) -> f64 {
    let side = |range: &mut dyn Iterator<Item = usize>| {
        let mut low = y[i];
        for j in range {
            if y[j] > y[i] {
                break;
            }
            low = low.min(y[j]);
        }
        low
    };
    y[i] - side(&mut (0..i).rev()).max(side(&mut (i + 1..y.len())))
}

/// `modes` peaks of the summed normalised receptances, the most prominent
/// ([`prominence`]), in measurement order: the frequency of the parabola's
/// vertex through each peak's line and its neighbours (in `ln` of the sum).
fn peaks(data: &[PointMeasurement], level: usize, modes: usize) -> Result<Vec<f64>> {
    let f: Vec<f64> = data[0].levels[level]
        .lines
        .iter()
        .map(|l| l.frequency_hz)
        .collect();
    let mut sum = vec![0.0; f.len()];
    for m in data {
        let r = receptances(m, level);
        let top = r.iter().fold(0.0, |a: f64, h| a.max(h.norm()));
        sum.iter_mut()
            .zip(&r)
            .for_each(|(s, h)| *s += h.norm() / top.max(f64::MIN_POSITIVE));
    }
    let mut found: Vec<usize> = (1..f.len().saturating_sub(1))
        .filter(|&i| sum[i] > sum[i - 1] && sum[i] >= sum[i + 1])
        .collect();
    if found.len() < modes {
        return Err(Error::input(
            "data",
            format!(
                "{} peaks in the lowest level for {modes} modes",
                found.len()
            ),
        ));
    }
    let prominence: Vec<f64> = (0..sum.len()).map(|i| prominence(&sum, i)).collect();
    found.sort_by(|&a, &b| prominence[b].total_cmp(&prominence[a]));
    found.truncate(modes);
    found.sort_unstable();
    Ok(found
        .into_iter()
        .map(|i| {
            let (x, y) = (
                [f[i - 1], f[i], f[i + 1]],
                [sum[i - 1], sum[i], sum[i + 1]].map(f64::ln),
            );
            // the vertex of the parabola through three points
            let d1 = (y[1] - y[0]) / (x[1] - x[0]);
            let d2 = (y[2] - y[1]) / (x[2] - x[1]);
            let a = (d2 - d1) / (x[2] - x[0]);
            let vertex = if a < 0.0 {
                0.5 * (x[0] + x[1]) - d1 / (2.0 * a)
            } else {
                x[1]
            };
            // lines in measurement order: a sweep down has them falling
            vertex.clamp(x[0].min(x[2]), x[0].max(x[2]))
        })
        .collect())
}

/// The linear modes (`modes` of them) fitted to level `level` alone, the
/// structure driven at `drive` and every point measured: the structure
/// with the joint stuck at that level. Returns them and the RMS of the
/// weighted residuals.
pub fn linear_modes(
    data: &[PointMeasurement],
    points: Vec<String>,
    drive: usize,
    modes: usize,
    level: usize,
) -> Result<(PointModes, f64)> {
    linear_modes_beside(data, points, drive, (modes, &[]), level)
}

/// [`linear_modes`] with modes outside the lines besides: `modes.0` at
/// the peaks, each fitted near its own peak ([`peak_modes`]), and one at
/// each of `modes.1` (Hz, held there, at [`START_DAMPING`]: the residual
/// of modes below and above the band); then all are fitted together.
pub fn linear_modes_beside(
    data: &[PointMeasurement],
    points: Vec<String>,
    drive: usize,
    modes: (usize, &[f64]),
    level: usize,
) -> Result<(PointModes, f64)> {
    check_lines(data, points.len())?;
    let at = |p: usize| data.iter().find(|m| m.point == p);
    let Some(d) = at(drive) else {
        return Err(Error::input("data", "the drive point needs a sensor"));
    };
    if (0..points.len()).any(|p| at(p).is_none()) {
        return Err(Error::input("data", "every point needs a sensor"));
    }
    let found = peaks(data, level, modes.0)?;
    let (omega, h) = receptances_by_point(data, level);
    let start = match peak_modes(&omega, &h, drive, &found, (modes.1, START_DAMPING)) {
        Ok(start) => start,
        // a peak whose neighbourhood alone holds no mode: its quadrature
        // response gives the start instead
        Err(_) => quadrature_start(data, (d, drive), &found, modes.1, level)?,
    };
    refined(data, (points, start), drive, level)
}

/// Modes at the peaks `found` from each peak's quadrature response (see
/// the module docs), and modes at `outside` from what those leave.
fn quadrature_start(
    data: &[PointMeasurement],
    (d, drive): (&PointMeasurement, usize),
    found: &[f64],
    outside: &[f64],
    level: usize,
) -> Result<Vec<ShapedMode>> {
    let points = data.len();
    let f: Vec<f64> = data[0].levels[level]
        .lines
        .iter()
        .map(|l| l.frequency_hz)
        .collect();
    let mut start = Vec::with_capacity(found.len() + outside.len());
    for &peak in found {
        let i = (0..f.len())
            .min_by(|&a, &b| (f[a] - peak).abs().total_cmp(&(f[b] - peak).abs()))
            .unwrap_or(0);
        let w2 = (2.0 * PI * peak).powi(2);
        let constant =
            |m: &PointMeasurement| -receptances(m, level)[i].im * 2.0 * START_DAMPING * w2;
        let phi_d = constant(d).abs().sqrt().max(f64::MIN_POSITIVE);
        let mut shape = vec![0.0; points];
        for m in data {
            shape[m.point] = constant(m) / phi_d;
        }
        start.push(ShapedMode {
            frequency_hz: peak,
            damping_ratio: START_DAMPING,
            shape,
        });
    }
    let structure = PointModes {
        points: vec![String::new(); points],
        modes: start,
    };
    let mut all = structure.modes.clone();
    all.extend(outside_modes(data, &structure, drive, outside, level));
    Ok(all)
}

/// `start` fitted to level `level` by Levenberg–Marquardt, the modes
/// outside the lines damped at [`START_DAMPING`] or more.
fn refined(
    data: &[PointMeasurement],
    (points, start): (Vec<String>, Vec<ShapedMode>),
    drive: usize,
    level: usize,
) -> Result<(PointModes, f64)> {
    let structure = PointModes {
        points,
        modes: start,
    };
    let layout = Layout::new(&structure, None)?
        .damped_outside(super::problem::lines_hz(data), START_DAMPING);
    let problem = LinearProblem {
        data,
        level,
        layout: &layout,
        drive,
        evaluations: AtomicUsize::new(0),
    };
    let run = levenberg_marquardt(&problem, &layout.theta_of(&structure, None), 200)?;
    Ok((layout.structure_at(&run.theta).0, problem.rms(&run.theta)))
}

/// Modes at `frequencies` whose products `c_p = φ(p) φ(d)` fit, by least
/// squares over the level's lines, what `structure` leaves of each
/// receptance; `φ(d) = √|c_d|`.
fn outside_modes(
    data: &[PointMeasurement],
    structure: &PointModes,
    drive: usize,
    frequencies: &[f64],
    level: usize,
) -> Vec<ShapedMode> {
    let lines = &data[0].levels[level].lines;
    let basis = |f: f64, w: f64| {
        let wr = 2.0 * PI * f;
        1.0 / Complex64::new(wr * wr - w * w, 2.0 * START_DAMPING * w * wr)
    };
    let n = frequencies.len();
    let a = nalgebra::DMatrix::from_fn(2 * lines.len(), n, |row, r| {
        let b = basis(frequencies[r], 2.0 * PI * lines[row / 2].frequency_hz);
        if row % 2 == 0 { b.re } else { b.im }
    });
    let svd = a.svd(true, true);
    let mut c = vec![vec![0.0; n]; structure.points.len()];
    for m in data {
        let measured = receptances(m, level);
        let left = nalgebra::DVector::from_fn(2 * lines.len(), |row, _| {
            let w = 2.0 * PI * lines[row / 2].frequency_hz;
            let model = structure.receptance_between(
                crate::model::Site::Point(m.point),
                crate::model::Site::Point(drive),
                w,
            );
            let e = measured[row / 2] - model;
            if row % 2 == 0 { e.re } else { e.im }
        });
        if let Ok(x) = svd.solve(&left, 1e-12) {
            c[m.point] = x.iter().copied().collect();
        }
    }
    (0..n)
        .map(|r| {
            let phi_d = c[drive][r].abs().sqrt().max(f64::MIN_POSITIVE);
            ShapedMode {
                frequency_hz: frequencies[r],
                damping_ratio: START_DAMPING,
                shape: c.iter().map(|cp| cp[r] / phi_d).collect(),
            }
        })
        .collect()
}

/// The structure beside a joint of stick stiffness `kd` between `ends`,
/// from the modes of the structure with the joint stuck: in the stuck
/// modes' coordinates the stiffness is `Ω² − kd ψ ψᵀ` (`ψ_r = φ_r(a) −
/// φ_r(b)`, the mass the identity), whose eigenvectors `v_i` give the
/// shapes `Φ v_i`; each new mode's damping ratio is the stuck ones' mean
/// weighted by `v_i,r²`. Exact for a complete set of modes.
///
/// Errors: a `kd` that leaves a mode without stiffness.
pub fn without_joint(
    stuck: &PointModes,
    ends: (usize, Option<usize>),
    kd: f64,
) -> Result<PointModes> {
    stuck.validate()?;
    let n = stuck.modes.len();
    let site = crate::model::Site::Across(ends.0, ends.1);
    let psi: Vec<f64> = stuck.modes.iter().map(|m| m.at(site)).collect();
    let k = nalgebra::DMatrix::from_fn(n, n, |r, s| {
        let w = 2.0 * PI * stuck.modes[r].frequency_hz;
        (if r == s { w * w } else { 0.0 }) - kd * psi[r] * psi[s]
    });
    let eigen = nalgebra::SymmetricEigen::new(k);
    let mut modes = Vec::with_capacity(n);
    for i in 0..n {
        let l = eigen.eigenvalues[i];
        if l <= 0.0 || l.is_nan() {
            return Err(Error::model(
                "kd",
                format!("a stick stiffness of {kd} N/m leaves a mode without stiffness"),
            ));
        }
        let v = eigen.eigenvectors.column(i);
        let mut shape: Vec<f64> = (0..stuck.points.len())
            .map(|p| (0..n).map(|r| stuck.modes[r].shape[p] * v[r]).sum())
            .collect();
        let largest = shape
            .iter()
            .fold(0.0, |m: f64, &x| if x.abs() > m.abs() { x } else { m });
        if largest < 0.0 {
            shape.iter_mut().for_each(|x| *x = -*x);
        }
        modes.push(ShapedMode {
            frequency_hz: l.sqrt() / (2.0 * PI),
            damping_ratio: (0..n)
                .map(|r| v[r] * v[r] * stuck.modes[r].damping_ratio)
                .sum(),
            shape,
        });
    }
    modes.sort_by(|a, b| a.frequency_hz.total_cmp(&b.frequency_hz));
    let out = PointModes {
        points: stuck.points.clone(),
        modes,
    };
    out.validate()?;
    Ok(out)
}

/// The stuck modes `stuck` with one more point, `name`, whose motion no
/// sensor reads: the joint's own coordinate, for a joint from it to the
/// ground (`ends = (last point, None)`), when the sensors beside a joint
/// do not read the motion across it. Its value in each mode inside
/// `lines_hz`, `ψ_r = √(max(ω_r,stuck² − ω_r,soft², 10⁻³ ω_r,stuck²)/k_d)`,
/// is what a joint of stick stiffness `kd` that slips fully at the level of
/// `soft` (the same modes fitted to the highest level) takes from each
/// mode; 0 in modes outside the lines. Only `k_d ψ²` is seen, so `kd` sets
/// the coordinate's scale.
///
/// Errors: `soft` with other modes than `stuck`; `kd` not positive.
pub fn with_joint_point(
    stuck: &PointModes,
    soft: &PointModes,
    kd: f64,
    lines_hz: (f64, f64),
    name: &str,
) -> Result<PointModes> {
    if soft.modes.len() != stuck.modes.len() {
        return Err(Error::input(
            "soft",
            "needs the stuck structure's modes, fitted to another level",
        ));
    }
    if !(kd > 0.0 && kd.is_finite()) {
        return Err(Error::input("kd", format!("must be positive, got {kd}")));
    }
    let mut out = stuck.clone();
    out.points.push(name.to_string());
    for (m, s) in out.modes.iter_mut().zip(&soft.modes) {
        let w2 = |f: f64| (2.0 * PI * f).powi(2);
        let drop = (w2(m.frequency_hz) - w2(s.frequency_hz)).max(1e-3 * w2(m.frequency_hz));
        let inside = (lines_hz.0..=lines_hz.1).contains(&m.frequency_hz);
        m.shape.push(if inside { (drop / kd).sqrt() } else { 0.0 });
    }
    out.validate()?;
    Ok(out)
}
