//! The figures a model is shown in, shared by `identify`, `run` and their
//! reports: the measured FRFs with the model's on a fine frequency grid, and
//! the model's joint loops at the amplitudes the test reached.

use crate::error::Result;
use crate::extract::NonlinearFrf;
use crate::fit::{FitData, FrfPredictor, HbPredictor, MeasuredPoint, MeasuredSeries};
use crate::harmonics::omega;
use crate::model::{ElementSpec, Model, Role};
use crate::plot::{self, FrfSeries, LoopSeries, SeriesStyle};
use num_complex::Complex64;
use std::path::{Path, PathBuf};

/// Points per level of the model's curves, at least.
pub const FINE_POINTS: usize = 400;

/// Points a model curve puts within each resonance's half-power width, at
/// least: enough to draw its peak round, not as a corner.
pub const POINTS_PER_HALF_POWER_WIDTH: usize = 5;

/// Points per level of the model's curves, at most: each is a harmonic
/// balance solved twice (both sweep directions) at every level.
pub const MAX_FINE_POINTS: usize = 5 * FINE_POINTS;

/// The points per level `model`'s curves over `data`'s band need:
/// [`FINE_POINTS`], or more where a resonance is so narrow that fewer than
/// [`POINTS_PER_HALF_POWER_WIDTH`] would fall within its half-power width;
/// at most [`MAX_FINE_POINTS`]. A mode's half-power width is `2ζ f`, its
/// damping over its mass (`c/2πm` Hz), whether the joint sticks or slips;
/// a joint only adds damping, so no level's resonance is narrower.
pub fn fine_points(model: &Model, data: &FitData) -> usize {
    let (lo, hi) = data
        .series
        .iter()
        .flat_map(|s| s.points.iter().map(|p| p.frequency_hz))
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), f| {
            (a.min(f), b.max(f))
        });
    let narrowest = model
        .linear
        .modes
        .iter()
        .zip(model.linearised_frequencies_hz())
        .filter_map(|(m, stuck)| {
            let width = 2.0 * m.damping_ratio * m.frequency_hz;
            // its resonance somewhere between slipping and stuck, in the band
            let seen =
                m.frequency_hz.min(stuck) - width <= hi && m.frequency_hz.max(stuck) + width >= lo;
            (seen && width > 0.0).then_some(width)
        })
        .fold(f64::INFINITY, f64::min);
    let needed = (POINTS_PER_HALF_POWER_WIDTH as f64 * (hi - lo) / narrowest).ceil();
    if needed.is_finite() {
        // one more for each end
        (needed as usize + 2).clamp(FINE_POINTS, MAX_FINE_POINTS)
    } else {
        FINE_POINTS
    }
}

/// `data` with each series' points replaced by `points` frequencies spread
/// evenly over its measured range, in the series' own order (an up sweep
/// ascending, a down sweep descending), each at the force amplitude
/// interpolated between the measured ones: a prediction of it follows the
/// branch the test followed, point by point, as the fit's own does.
pub fn fine_grid(data: &FitData, points: usize) -> FitData {
    let n = points.max(2);
    let series = data
        .series
        .iter()
        .map(|s| {
            let mut by_f: Vec<(f64, f64)> = s
                .points
                .iter()
                .map(|p| (p.frequency_hz, p.force_amplitude))
                .collect();
            by_f.sort_by(|a, b| a.0.total_cmp(&b.0));
            let (lo, hi) = (by_f[0].0, by_f[by_f.len() - 1].0);
            let descending = s.points.len() > 1
                && s.points[0].frequency_hz > s.points[s.points.len() - 1].frequency_hz;
            let k = data.harmonics.len();
            let grid: Vec<MeasuredPoint> = (0..n)
                .map(|i| {
                    let t = i as f64 / (n - 1) as f64;
                    let t = if descending { 1.0 - t } else { t };
                    let f = lo + t * (hi - lo);
                    MeasuredPoint {
                        frequency_hz: f,
                        force_amplitude: interpolate(&by_f, f),
                        h: vec![Complex64::new(0.0, 0.0); k],
                        std_error: vec![1.0; k],
                        blocks: 0,
                    }
                })
                .collect();
            MeasuredSeries {
                level: s.level,
                direction: s.direction,
                points: grid,
            }
        })
        .collect();
    FitData {
        series,
        ..data.clone()
    }
}

/// Linear interpolation in `(x, y)` sorted by `x`; the end values outside.
fn interpolate(xy: &[(f64, f64)], x: f64) -> f64 {
    match xy.iter().position(|p| p.0 >= x) {
        None => xy[xy.len() - 1].1,
        Some(0) => xy[0].1,
        Some(i) => {
            let ((x0, y0), (x1, y1)) = (xy[i - 1], xy[i]);
            if x1 > x0 {
                y0 + (y1 - y0) * (x - x0) / (x1 - x0)
            } else {
                y1
            }
        }
    }
}

/// The largest displacement amplitude each level reached, m (from the
/// measured fundamental: `|H1|·|F1|`, referred to displacement), with the
/// level, in the order of `data`'s series; one entry per nominal level
/// (an up and a down sweep share it).
pub fn reached_amplitudes(data: &FitData) -> Vec<(f64, f64)> {
    let Some(k) = data.harmonic_index(1) else {
        return Vec::new();
    };
    let sign = data.response_sign;
    let mut out: Vec<(f64, f64)> = Vec::new();
    for s in &data.series {
        let a = s
            .points
            .iter()
            .map(|p| {
                (p.h[k] * sign).norm()
                    / data
                        .response
                        .from_displacement(omega(p.frequency_hz))
                        .norm()
                    * p.force_amplitude
            })
            .filter(|a| a.is_finite())
            .fold(0.0f64, f64::max);
        match out.iter_mut().find(|(l, _)| *l == s.level) {
            Some(e) => e.1 = e.1.max(a),
            None => out.push((s.level, a)),
        }
    }
    out
}

/// Two solutions of one level at one frequency are two branches when their
/// fundamentals differ by more than this share of the larger: the same
/// branch solved twice agrees to the solver's tolerance (~1e-8), the
/// branches of a fold differ by tens of per cent.
pub const BRANCH_TOLERANCE: f64 = 0.01;

/// A level's model curve as lines, `(frequency, H)` with NaN gaps: `own`,
/// solved along the level's grid in its sweep's order, broken where it jumps
/// off a branch; `other`, solved the opposite way, where it differs from
/// `own` (a fold's other stable branch) joined to the shared curve on the
/// side it continues from; empty without a fold.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct LevelLines {
    /// The continuation in the sweep's order.
    pub own: Vec<(f64, Complex64)>,
    /// The opposite continuation where it finds another branch.
    pub other: Vec<(f64, Complex64)>,
    /// Between the two, where they differ: the unstable solution a fold's
    /// branches are joined by (no sweep reaches it; drawn dashed).
    pub unstable: Vec<(f64, Complex64)>,
}

/// The model's lines for each series of `fine` (see [`LevelLines`]): each
/// series solved point by point from the previous point's solution, in its
/// own order and in the reverse. A steady response with a fold (a hardening
/// or softening effect driven hard) has two stable branches over a band of
/// frequency; a sweep stays on one until it ends, so the two directions
/// find both.
pub fn model_lines(
    model: &Model,
    response_sign: f64,
    fine: &FitData,
    predictor: &HbPredictor,
) -> Result<Vec<LevelLines>> {
    let mut both = fine.clone();
    both.series
        .extend(fine.series.iter().map(|s| MeasuredSeries {
            points: s.points.iter().rev().cloned().collect(),
            ..s.clone()
        }));
    let pred = predictor.predict(model, &both)?;
    let n = fine.series.len();
    let fundamental = |h: &[Option<Vec<Complex64>>]| -> Vec<Complex64> {
        h.iter()
            .map(|m| {
                m.as_ref()
                    .map_or(Complex64::new(f64::NAN, f64::NAN), |m| m[0] * response_sign)
            })
            .collect()
    };
    Ok(fine
        .series
        .iter()
        .enumerate()
        .map(|(i, s)| {
            let f: Vec<f64> = s.points.iter().map(|p| p.frequency_hz).collect();
            let own = fundamental(&pred.h[i]);
            let mut other = fundamental(&pred.h[n + i]);
            other.reverse();
            let mut lines = split_branches(&f, &own, &other);
            if !lines.other.is_empty() {
                lines.unstable =
                    unstable_branch(model, response_sign, fine, s, &own, &other, predictor);
            }
            lines
        })
        .collect())
}

/// The unstable solution of a fold at each point of `series` where the two
/// continuations `own` and `other` differ, with NaN gaps elsewhere (empty
/// where none is found). The single-harmonic balance has three amplitudes
/// there ([`crate::hb::describing::solve`]); the middle one starts Newton on
/// the full harmonic balance, which converges to the unstable solution as
/// readily as to a stable one (it solves the balance, it does not march in
/// time). A solution that lands on either stable branch is not drawn.
fn unstable_branch(
    model: &Model,
    response_sign: f64,
    fine: &FitData,
    series: &MeasuredSeries,
    own: &[Complex64],
    other: &[Complex64],
    predictor: &HbPredictor,
) -> Vec<(f64, Complex64)> {
    let nan = Complex64::new(f64::NAN, f64::NAN);
    let (Ok(mut elements), opts) = (model.element_set(), predictor.options_for(model, fine)) else {
        return Vec::new();
    };
    let Ok(mut solver) = crate::hb::HbSolver::new(&opts) else {
        return Vec::new();
    };
    let Some(first) = opts.harmonics.iter().position(|&h| h == 1) else {
        return Vec::new();
    };
    let apart =
        |x: Complex64, y: Complex64| (x - y).norm() > BRANCH_TOLERANCE * x.norm().max(y.norm());
    let mut line = Vec::with_capacity(series.points.len());
    let mut found = false;
    for (j, p) in series.points.iter().enumerate() {
        let (a, b) = (own[j], other[j]);
        let solved = (a.re.is_finite() && b.re.is_finite() && apart(a, b))
            .then(|| {
                let w = omega(p.frequency_hz);
                // through the drive model, if any (a shaker), as the solver
                let driven = crate::hb::Driven::of(&model.linear, &elements);
                let roots = crate::hb::describing::solve_on(
                    &driven,
                    &mut elements,
                    w,
                    p.force_amplitude,
                    opts.samples_per_period,
                )
                .ok()?;
                let &middle = roots.get(1).filter(|_| roots.len() >= 3)?;
                let mut guess = vec![Complex64::new(0.0, 0.0); opts.harmonics.len()];
                guess[first] = middle;
                let pt = solver
                    .solve_point(
                        &model.linear,
                        &mut elements,
                        p.frequency_hz,
                        p.force_amplitude,
                        Some(&guess),
                    )
                    .ok()
                    .filter(|pt| pt.converged)?;
                let z = pt.frf(1)? * fine.response.from_displacement(w) * response_sign;
                (apart(z, a) && apart(z, b)).then_some(z)
            })
            .flatten();
        found |= solved.is_some();
        line.push((p.frequency_hz, solved.unwrap_or(nan)));
    }
    if found { line } else { Vec::new() }
}

/// The lines of two continuations `a` (the sweep's) and `b` (the opposite)
/// on the grid `f` (see [`LevelLines`]). Each is broken, in and next to
/// the fold, where it jumps: a step that changes its magnitude by more than
/// a tenth and by more than twice the other's change (so a steep but shared
/// resonance is never broken). A continuation can near the tip of a branch
/// a little apart from the other before it jumps, so `b` is drawn from
/// where the two differ, whichever branch it is on.
pub fn split_branches(f: &[f64], a: &[Complex64], b: &[Complex64]) -> LevelLines {
    let nan = Complex64::new(f64::NAN, f64::NAN);
    let finite = |z: Complex64| z.re.is_finite() && z.im.is_finite();
    let n = f.len().min(a.len()).min(b.len());
    let differ: Vec<bool> = (0..n)
        .map(|i| {
            finite(a[i])
                && finite(b[i])
                && (a[i] - b[i]).norm() > BRANCH_TOLERANCE * a[i].norm().max(b[i].norm())
        })
        .collect();
    let mut lines = LevelLines::default();
    if !differ.iter().any(|&d| d) {
        lines.own = (0..n).map(|i| (f[i], a[i])).collect();
        return lines;
    }
    // whether `x` jumps between i − 1 and i, `y` being the other: by the
    // magnitude (near a branch's tip its phase turns fast while its
    // magnitude barely changes)
    let jumps = |x: &[Complex64], y: &[Complex64], i: usize| {
        if i == 0 {
            return false;
        }
        let step = |z: &[Complex64]| (z[i].norm() - z[i - 1].norm()).abs();
        let (dx, dy) = (step(x), step(y));
        (differ[i] || differ[i - 1])
            && dx > 2.0 * dy
            && dx > JUMP * x[i].norm().max(x[i - 1].norm())
    };
    for i in 0..n {
        if i > 0 && jumps(a, b, i) {
            lines.own.push((0.5 * (f[i - 1] + f[i]), nan));
        }
        lines.own.push((f[i], a[i]));
    }
    // `b` where it differs, and its neighbours it continues into
    let drawn = |i: usize| {
        differ[i]
            || (i > 0 && differ[i - 1] && !jumps(b, a, i))
            || (i + 1 < n && differ[i + 1] && !jumps(b, a, i + 1))
    };
    for i in 0..n {
        if i > 0 && drawn(i) && drawn(i - 1) && jumps(b, a, i) {
            lines.other.push((0.5 * (f[i - 1] + f[i]), nan));
        }
        lines.other.push((f[i], if drawn(i) { b[i] } else { nan }));
    }
    lines
}

/// A step changing a continuation by more than this share is a jump between
/// branches (where the other continuation changes by less than half as
/// much); a fold's branches differ by a factor of 2 or more.
const JUMP: f64 = 0.1;

/// One model drawn over the measurements.
pub struct Drawn<'a> {
    /// The model.
    pub model: &'a Model,
    /// The sign its `H` are multiplied by to compare with the measured ones.
    pub response_sign: f64,
}

/// Writes the FRF overlay `stem` (`.png`, `.svg`): the measured `|H1|` and
/// phase of every level in `band_hz` (markers with their standard errors)
/// and `model`'s on a fine grid (lines, see [`fine_points`]).
pub fn write_frf_overlay(
    stem: &Path,
    title: &str,
    frf: &NonlinearFrf,
    band_hz: Option<(f64, f64)>,
    model: Drawn<'_>,
    predictor: &HbPredictor,
) -> Result<Vec<PathBuf>> {
    write_models_overlay(stem, title, frf, band_hz, &[model], predictor)
}

/// [`write_frf_overlay`] of several models on one grid: the last solid
/// (with a fold's unstable branch dashed), those before it as baselines
/// (thin, pale). The legend: one entry per level, and one per line style.
pub fn write_models_overlay(
    stem: &Path,
    title: &str,
    frf: &NonlinearFrf,
    band_hz: Option<(f64, f64)>,
    models: &[Drawn<'_>],
    predictor: &HbPredictor,
) -> Result<Vec<PathBuf>> {
    let data = FitData::from_frf(frf, &[1], band_hz, None)?;
    let points = models.iter().map(|m| fine_points(m.model, &data)).max();
    let fine = fine_grid(&data, points.unwrap_or(FINE_POINTS));
    let mut lines = Vec::with_capacity(models.len());
    for (i, m) in models.iter().enumerate() {
        let last = i + 1 == models.len();
        lines.push((
            last,
            model_lines(m.model, m.response_sign, &fine, predictor)?,
        ));
    }
    let unit = frf.reference.si_unit();
    let mut series = Vec::new();
    for (g, s) in data.series.iter().enumerate() {
        series.push(FrfSeries {
            label: plot::level_label(s.level, unit),
            group: g,
            frequency_hz: s.points.iter().map(|p| p.frequency_hz).collect(),
            h: s.points.iter().map(|p| p.h[0]).collect(),
            std_error: Some(s.points.iter().map(|p| p.std_error[0]).collect()),
            style: SeriesStyle::Measured,
        });
        for (last, l) in &lines {
            series.extend(level_series(g, &l[g], *last));
        }
    }
    plot::write_frf_plot(stem, title, &plot::frf_magnitude_label(frf, 1), &series)
}

/// A level's model lines as series of colour group `g`, out of the legend
/// (the lines share the markers' colour): `last`, the model drawn solid,
/// else a baseline, without its unstable branch.
fn level_series(g: usize, l: &LevelLines, last: bool) -> Vec<FrfSeries> {
    let stable = if last {
        SeriesStyle::Model
    } else {
        SeriesStyle::Baseline
    };
    let unstable = last.then_some(&l.unstable);
    [(&l.own, stable), (&l.other, stable)]
        .into_iter()
        .chain(unstable.map(|u| (u, SeriesStyle::Unstable)))
        .filter(|(line, _)| !line.is_empty())
        .map(|(line, style)| FrfSeries {
            label: String::new(),
            group: g,
            frequency_hz: line.iter().map(|p| p.0).collect(),
            h: line.iter().map(|p| p.1).collect(),
            std_error: None,
            style,
        })
        .collect()
}

/// Writes the hysteresis loops `stem` of `joint` at `amplitudes` (level,
/// displacement amplitude in m; one loop each), over `truth`'s where the
/// joint the data came from is known (a virtual test).
pub fn write_joint_loops(
    stem: &Path,
    joint: &ElementSpec,
    truth: Option<&ElementSpec>,
    amplitudes: &[(f64, f64)],
    level_unit: &str,
) -> Result<Vec<PathBuf>> {
    // the levels whose loops show the joint's shape: up to 30 slip
    // displacements Fd/kd (beyond, a loop is a rectangle 2 Fd high that
    // dwarfs the others); at least the smallest
    let slip = joint.value_of(Role::SlipForce).unwrap_or(f64::NAN) / joint.stick_stiffness();
    let mut shown: Vec<(usize, f64, f64)> = amplitudes
        .iter()
        .enumerate()
        .filter(|(_, (_, a))| a.is_finite() && *a > 0.0)
        .map(|(g, &(l, a))| (g, l, a))
        .collect();
    let total = shown.len();
    if slip.is_finite() && slip > 0.0 {
        let small: Vec<(usize, f64, f64)> = shown
            .iter()
            .copied()
            .filter(|&(_, _, a)| a <= 30.0 * slip)
            .collect();
        shown = if small.is_empty() {
            shown
                .iter()
                .copied()
                .min_by(|a, b| a.2.total_cmp(&b.2))
                .into_iter()
                .collect()
        } else {
            small
        };
    }
    let mut loops = Vec::new();
    for &(g, level, a) in &shown {
        let label = format!(
            "{}: a = {}",
            plot::level_label(level, level_unit),
            engineering(a, "m")
        );
        if let Some(r) = truth {
            let (x, f) = r.steady_loop(a, 400)?;
            loops.push(LoopSeries {
                label: String::new(),
                group: g,
                displacement: x,
                force: f,
                style: SeriesStyle::Measured,
            });
        }
        let (x, f) = joint.steady_loop(a, 400)?;
        loops.push(LoopSeries {
            label,
            group: g,
            displacement: x,
            force: f,
            style: SeriesStyle::Model,
        });
    }
    let title = format!(
        "Joint loops at the amplitudes reached{}",
        if shown.len() < total {
            format!(
                " ({} of {total} levels; the rest slip fully, beyond 30 Fd/kd)",
                shown.len()
            )
        } else {
            String::new()
        }
    );
    // the bands named once: what they are
    if let Some(first) = loops.iter_mut().find(|l| l.style == SeriesStyle::Measured)
        && let Some(r) = truth
    {
        first.label = format!("simulated {} (bands)", r.kind().name());
    }
    if let Some(i) = loops.iter().position(|l| l.style == SeriesStyle::Model) {
        loops[i].label = format!("fitted {}, {}", joint.kind().name(), loops[i].label);
    }
    plot::write_loop_plot(
        stem,
        &title,
        "joint displacement [m]",
        "joint force [N]",
        &loops,
    )
}

/// `v` with an SI prefix and 3 significant digits (`1.23 µm`).
pub fn engineering(v: f64, unit: &str) -> String {
    if !v.is_finite() || v == 0.0 {
        return format!("{v} {unit}");
    }
    let prefixes = [
        (1e-12, "p"),
        (1e-9, "n"),
        (1e-6, "µ"),
        (1e-3, "m"),
        (1.0, ""),
        (1e3, "k"),
        (1e6, "M"),
    ];
    let (scale, p) = prefixes
        .iter()
        .rev()
        .find(|(s, _)| v.abs() >= *s)
        .copied()
        .unwrap_or(prefixes[0]);
    let x = v / scale;
    let decimals = (2 - x.abs().log10().floor() as i32).max(0) as usize;
    format!("{x:.decimals$} {p}{unit}")
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The fundamental amplitude of the Duffing oscillator
    /// `m x'' + c x' + k x + k3 x³ = F cos ωt` at `f_hz` on the branch
    /// nearest `start` (m): harmonic balance written out here, apart from
    /// `hb` (harmonics 1, 3, 5, 7, the cubic force sampled at 256 points a
    /// period, Newton with a finite-difference Jacobian).
    fn duffing_hb(p: [f64; 5], f_hz: f64, start: Complex64) -> f64 {
        let [m, c, k, k3, force] = p;
        let w = 2.0 * std::f64::consts::PI * f_hz;
        let (n, harmonics) = (256, [1.0, 3.0, 5.0, 7.0]);
        let residual = |q: &[f64]| -> Vec<f64> {
            let mut out = vec![0.0; 8];
            for i in 0..n {
                let t = 2.0 * std::f64::consts::PI * i as f64 / n as f64;
                let (mut x, mut v, mut acc) = (0.0, 0.0, 0.0);
                for (j, h) in harmonics.iter().enumerate() {
                    let (a, b) = (q[2 * j], q[2 * j + 1]);
                    let (cs, sn) = ((h * t).cos(), (h * t).sin());
                    x += a * cs + b * sn;
                    v += w * h * (-a * sn + b * cs);
                    acc -= (w * h).powi(2) * (a * cs + b * sn);
                }
                let r = m * acc + c * v + k * x + k3 * x.powi(3) - force * t.cos();
                for (j, h) in harmonics.iter().enumerate() {
                    out[2 * j] += 2.0 / n as f64 * r * (h * t).cos();
                    out[2 * j + 1] += 2.0 / n as f64 * r * (h * t).sin();
                }
            }
            out
        };
        // x = Re(X e^{iωt}) = a cos + b sin with X = a − i b
        let mut q = vec![0.0; 8];
        q[0] = start.re * force;
        q[1] = -start.im * force;
        for _ in 0..50 {
            let r = residual(&q);
            let jac = nalgebra::DMatrix::from_fn(8, 8, |i, j| {
                let mut d = q.clone();
                d[j] += 1e-10;
                (residual(&d)[i] - r[i]) / 1e-10
            });
            let step = jac.lu().solve(&nalgebra::DVector::from_vec(r)).unwrap();
            q.iter_mut().zip(step.iter()).for_each(|(x, s)| *x -= s);
        }
        q[0].hypot(q[1])
    }

    /// A hardening Duffing oscillator (m = 1 kg, f0 = 10 Hz, ζ = 1 %,
    /// k3 = 2e7 N/m³) driven at 1 N has a fold: two stable branches from
    /// above f0 to where the backbone `ω² = ω0² (1 + ¾ (k3/k) A²)` meets the
    /// peak amplitude `A = F/(c ω)` (the single-harmonic estimate of where an
    /// up sweep drops, here 11.9 Hz). Both continuations are drawn, more than
    /// a factor 2 apart inside the fold, each the oscillator's steady response
    /// by a harmonic balance written out in this test, and the up sweep's line
    /// is broken where it drops instead of joining the branches.
    #[test]
    fn a_fold_is_drawn_as_its_two_branches() {
        use std::f64::consts::PI;
        let (m, f0, zeta, k3, force) = (1.0, 10.0, 0.01, 2e7, 1.0);
        let k = m * (2.0 * PI * f0).powi(2);
        let c = 2.0 * zeta * (k * m).sqrt();
        let model = Model::with_joint(
            crate::model::ModalModel::sdof(m, c, k).unwrap(),
            None,
            vec![ElementSpec::CubicStiffness { k3 }],
        )
        .unwrap();
        // the backbone at the peak amplitude, by fixed point
        let mut w = 2.0 * PI * f0;
        for _ in 0..200 {
            let a = force / (c * w);
            w = ((k + 0.75 * k3 * a * a) / m).sqrt();
        }
        let f_drop = w / (2.0 * PI);
        let grid: Vec<MeasuredPoint> = (0..400)
            .map(|i| MeasuredPoint {
                frequency_hz: 5.0 + 15.0 * i as f64 / 399.0,
                force_amplitude: force,
                h: vec![Complex64::new(0.0, 0.0)],
                std_error: vec![1.0],
                blocks: 0,
            })
            .collect();
        let fine = FitData {
            response: crate::harmonics::Quantity::Displacement,
            harmonics: vec![1],
            series: vec![MeasuredSeries {
                level: force,
                direction: crate::extract::Direction::Up,
                points: grid,
            }],
            response_sign: 1.0,
            transfer: false,
            unusable_points: 0,
            subharmonic_points: Vec::new(),
            anchor: None,
        };
        let lines = model_lines(&model, 1.0, &fine, &HbPredictor::default()).unwrap();
        let l = &lines[0];
        let finite = |z: &Complex64| z.re.is_finite();
        let own_at = |f: f64| l.own.iter().find(|p| p.0 == f).unwrap().1;
        // the fold's band: where the other branch is drawn apart from the
        // sweep's
        let band: Vec<(f64, Complex64)> = l
            .other
            .iter()
            .copied()
            .filter(|p| finite(&p.1) && (p.1 - own_at(p.0)).norm() > 0.5 * p.1.norm())
            .collect();
        assert!(band.len() > 10, "no second branch: {} points", band.len());
        let (lo, hi) = (band[0].0, band[band.len() - 1].0);
        // the up sweep drops within 3 % of the single-harmonic estimate (the
        // higher harmonics, a grid step of 0.04 Hz, and a continuation
        // without arclength losing the branch just before its tip)
        assert!(
            (hi / f_drop - 1.0).abs() < 0.03,
            "drop at {hi} Hz, estimate {f_drop} Hz"
        );
        assert!(lo > f0 && lo < hi, "fold {lo}-{hi} Hz");
        // inside the fold: two branches, a factor > 2 apart, each solving
        // the single-harmonic equation within 2 % (the third harmonic is
        // ~2 % of the response)
        let (fm, lower) = band[band.len() / 2];
        let upper = own_at(fm);
        assert!(
            upper.norm() > 2.0 * lower.norm(),
            "{upper} vs {lower} at {fm} Hz"
        );
        // each a steady response: the independent balance, started from it,
        // stays on it (its Newton converges to ~1e-15; the library's to its
        // tolerance, so 1e-6)
        for h in [upper, lower] {
            let a = duffing_hb([m, c, k, k3, force], fm, h);
            let drawn = h.norm() * force;
            assert!(
                (a / drawn - 1.0).abs() < 1e-6,
                "{drawn} m drawn, {a} m by the balance at {fm} Hz"
            );
        }
        // between them, the unstable branch, at most points of the band:
        // each between the two stable ones and a steady solution of the
        // independent balance
        let unstable: Vec<(f64, Complex64)> = l
            .unstable
            .iter()
            .copied()
            .filter(|p| finite(&p.1))
            .collect();
        assert!(
            unstable.len() * 10 >= band.len() * 9,
            "unstable branch at {} of {} points of the fold",
            unstable.len(),
            band.len()
        );
        let other_at = |f: f64| l.other.iter().find(|p| p.0 == f).unwrap().1;
        for &(f, z) in &unstable {
            let (hi_b, lo_b) = (own_at(f).norm(), other_at(f).norm());
            assert!(
                z.norm() > lo_b.min(hi_b) && z.norm() < lo_b.max(hi_b),
                "{f} Hz: unstable |H| {} outside [{lo_b}, {hi_b}]",
                z.norm()
            );
            let a = duffing_hb([m, c, k, k3, force], f, z);
            assert!(
                (a / (z.norm() * force) - 1.0).abs() < 1e-6,
                "{f} Hz: unstable {} m drawn, {a} m by the balance",
                z.norm() * force
            );
        }
        // the up sweep's line: one break, at its drop
        let gaps: Vec<f64> = l
            .own
            .iter()
            .filter(|p| !finite(&p.1))
            .map(|p| p.0)
            .collect();
        assert_eq!(gaps.len(), 1, "{gaps:?}");
        assert!(gaps[0] > hi && gaps[0] < hi + 0.04, "{gaps:?} vs {hi}");
    }

    #[test]
    fn engineering_notation_reads_as_a_person_writes_it() {
        assert_eq!(engineering(1.234e-6, "m"), "1.23 µm");
        assert_eq!(engineering(8.2e-5, "m"), "82.0 µm");
        assert_eq!(engineering(0.5, "m"), "500 mm");
    }

    /// A lightly damped SDOF (ζ = 0.2 % at 100 Hz) measured from 50 to
    /// 150 Hz: its curves' grid puts at least 5 points within the half-power
    /// band of its receptance, `f² = fn² (1 − 2ζ² ∓ 2ζ√(1 − ζ²))` (0.4 Hz
    /// wide), where 400 points (0.25 Hz apart) put 2; a well-damped one
    /// (ζ = 5 %, 10 Hz wide) keeps the 400.
    #[test]
    fn the_fine_grid_resolves_a_lightly_damped_resonance() {
        let (fn_hz, zeta) = (100.0, 0.002);
        let sdof = |zeta: f64| {
            let mode = crate::model::Mode::from_modal_mass(fn_hz, zeta, 1.0).unwrap();
            let linear = crate::model::ModalModel::new(vec![mode]).unwrap();
            Model::new(linear, vec![]).unwrap()
        };
        let p = |f: f64| MeasuredPoint {
            frequency_hz: f,
            force_amplitude: 1.0,
            h: vec![Complex64::new(1.0, 0.0)],
            std_error: vec![0.1],
            blocks: 1,
        };
        let data = FitData {
            response: crate::harmonics::Quantity::Displacement,
            harmonics: vec![1],
            series: vec![MeasuredSeries {
                level: 1.0,
                direction: crate::extract::Direction::Up,
                points: vec![p(50.0), p(150.0)],
            }],
            response_sign: 1.0,
            transfer: false,
            unusable_points: 0,
            subharmonic_points: Vec::new(),
            anchor: None,
        };
        let half_power = |sign: f64| {
            let x = 1.0 - 2.0 * zeta * zeta + sign * 2.0 * zeta * (1.0 - zeta * zeta).sqrt();
            fn_hz * x.sqrt()
        };
        let (lo, hi) = (half_power(-1.0), half_power(1.0));
        let within = |points: usize| {
            let fine = fine_grid(&data, points);
            let f = fine.series[0].points.iter().map(|p| p.frequency_hz);
            f.filter(|f| (lo..=hi).contains(f)).count()
        };
        let points = fine_points(&sdof(zeta), &data);
        assert!(
            within(points) >= 5,
            "{} points in [{lo}, {hi}] Hz",
            within(points)
        );
        assert!(points <= MAX_FINE_POINTS);
        assert_eq!(within(FINE_POINTS), 2);
        assert_eq!(fine_points(&sdof(0.05), &data), FINE_POINTS);
    }

    #[test]
    fn a_fine_grid_keeps_the_sweep_order_and_interpolates_the_force() {
        let p = |f: f64, a: f64| MeasuredPoint {
            frequency_hz: f,
            force_amplitude: a,
            h: vec![Complex64::new(1.0, 0.0)],
            std_error: vec![0.1],
            blocks: 1,
        };
        let data = FitData {
            response: crate::harmonics::Quantity::Displacement,
            harmonics: vec![1],
            series: vec![MeasuredSeries {
                level: 10.0,
                direction: crate::extract::Direction::Down,
                points: vec![p(300.0, 12.0), p(100.0, 10.0)],
            }],
            response_sign: 1.0,
            transfer: false,
            unusable_points: 0,
            subharmonic_points: Vec::new(),
            anchor: None,
        };
        let fine = fine_grid(&data, 5);
        let f: Vec<f64> = fine.series[0]
            .points
            .iter()
            .map(|p| p.frequency_hz)
            .collect();
        assert_eq!(f, vec![300.0, 250.0, 200.0, 150.0, 100.0]);
        assert_eq!(fine.series[0].points[2].force_amplitude, 11.0);
        assert_eq!(reached_amplitudes(&data), vec![(10.0, 12.0)]);
    }
}
