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

/// Points per level of the model's curves.
pub const FINE_POINTS: usize = 400;

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

/// One model drawn over the measurements.
pub struct Drawn<'a> {
    /// The model.
    pub model: &'a Model,
    /// The sign its `H` are multiplied by to compare with the measured ones.
    pub response_sign: f64,
}

/// Writes the FRF overlay `stem` (`.png`, `.svg`): the measured `|H1|` and
/// phase of every level in `band_hz` (markers with their standard errors)
/// and `model`'s on a fine grid of [`FINE_POINTS`] per level (lines).
pub fn write_frf_overlay(
    stem: &Path,
    title: &str,
    frf: &NonlinearFrf,
    band_hz: Option<(f64, f64)>,
    model: Drawn<'_>,
    predictor: &HbPredictor,
) -> Result<Vec<PathBuf>> {
    let data = FitData::from_frf(frf, &[1], band_hz, None)?;
    let fine = fine_grid(&data, FINE_POINTS);
    let pred = predictor.predict(model.model, &fine)?;
    let unit = frf.reference.si_unit();
    let mut series = Vec::new();
    for (g, (s, (f, p))) in data
        .series
        .iter()
        .zip(fine.series.iter().zip(&pred.h))
        .enumerate()
    {
        let label = plot::level_label(s.level, unit);
        series.push(FrfSeries {
            label,
            group: g,
            frequency_hz: s.points.iter().map(|p| p.frequency_hz).collect(),
            h: s.points.iter().map(|p| p.h[0]).collect(),
            std_error: Some(s.points.iter().map(|p| p.std_error[0]).collect()),
            style: SeriesStyle::Measured,
        });
        series.push(FrfSeries {
            // one legend entry per level: the line shares the markers' colour
            label: String::new(),
            group: g,
            frequency_hz: f.points.iter().map(|p| p.frequency_hz).collect(),
            h: p.iter()
                .map(|m| {
                    m.as_ref().map_or(Complex64::new(f64::NAN, f64::NAN), |m| {
                        m[0] * model.response_sign
                    })
                })
                .collect(),
            std_error: None,
            style: SeriesStyle::Model,
        });
    }
    plot::write_frf_plot(stem, title, &plot::frf_magnitude_label(frf, 1), &series)
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

    #[test]
    fn engineering_notation_reads_as_a_person_writes_it() {
        assert_eq!(engineering(1.234e-6, "m"), "1.23 µm");
        assert_eq!(engineering(8.2e-5, "m"), "82.0 µm");
        assert_eq!(engineering(0.5, "m"), "500 mm");
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
            unusable_points: 0,
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
