//! A multi-response FRF fit of a structure seen at several points
//! ([`PointModes`]) with one joint between two of them (or one point and
//! the ground), driven at a third.
//!
//! The data are the first-harmonic FRFs `H_p = Y_p,1/F_1` of several
//! response points (receptance, mobility or accelerance: the model's
//! receptance is multiplied by `(jω)^k` as [`Quantity::from_displacement`]
//! says), per drive level and line. The model is the structure's modes
//! (`f_r`, `ζ_r` and the mass-normalised shape `φ_r(p)` at every point, all
//! free) and the joint's law; each line is solved by harmonic balance of the
//! joint's relative motion ([`JointReceptance`]) and every point's motion
//! follows from the joint's force harmonics ([`point_harmonics`]):
//!
//! ```text
//! X_p,1 = H_pd(ω) F − H_pj(ω) G_1,   r_p = (X_p,1 (jω)^k / F − H_p,measured) / w_p
//! ```
//!
//! each residual's real and imaginary parts divided by the line's weight
//! `w_p` (the response's RMS over the level, or the line's measured
//! standard error: [`PointMeasurement::from_frf`]). Where the model cannot
//! meet the data to within the noise, as on a measured structure, standard
//! errors far smaller than the model's own error would let the few
//! quietest lines decide the fit. Levenberg–Marquardt
//! ([`levenberg_marquardt()`]) minimises `Σ r²` over `θ = (ln f_r, ln ζ_r, φ_r(p)/|φ_r,0(p)|, θ_joint)`; `ζ_r` is held
//! within `[1e-4, 0.5]` (`[0.02, 0.5]` for a mode starting outside the
//! lines: only its residual is seen), `f_r` within a factor 1.25 of its
//! start, and the joint's parameters in the coordinates and bounds the
//! one-point fit gives its law ([`super::params::ParameterSet::for_law`]:
//! a signed `χ`, `1/N`, six decades for a stiffness), the distance outside
//! added as a penalty row.
//!
//! The start ([`start`]): the lowest level's FRFs fitted by the linear
//! modes alone (the joint stuck, so inside the modes), from each peak's
//! mode fitted near its peak ([`poles`]), then the joint's stated stick
//! stiffness taken out of those modes in modal coordinates (`Ω² − k_d ψ
//! ψᵀ`, `ψ_r = φ_r(a) − φ_r(b)`) to give the structure beside the joint.
//!
//! A joint's ends need no sensor: a point that no measurement reads is a
//! coordinate whose value in each mode is fitted like any other. The
//! motion across a bolted interface is seldom what two accelerometers
//! beside it read; a joint from a coordinate of its own to the ground,
//! `ψ_r` free in every mode, is the joint that several modes share
//! ([`with_joint_point`] starts it from the modes' drop in frequency with
//! level).

mod joint_start;
mod layout;
pub mod poles;
mod problem;
pub mod start;
#[cfg(test)]
mod tests;

use super::Weighting;
use super::optimise::{OptimiserRun, levenberg_marquardt};
use crate::error::{Error, Result};
use crate::extract::NonlinearFrf;
use crate::harmonics::Quantity;
use crate::hb::points::{JointReceptance, point_harmonics};
use crate::model::{ElementSpec, PointModes, Role};
use crate::observe::Observer;
use layout::Layout;
use num_complex::Complex64;
use problem::JointProblem;
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

pub use joint_start::{JOINT_COORDINATE, JointPlacement, StartPlan, highest_level, joint_start};
pub use start::{linear_modes, linear_modes_beside, lowest_level, with_joint_point, without_joint};

/// One measured line of one response point.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct PointLine {
    /// Hz.
    pub frequency_hz: f64,
    /// `|F_1|`, N.
    pub force_amplitude: f64,
    /// `H = Y_1/F_1` in the measurement's response quantity.
    pub h: Complex64,
    /// What a residual is divided by ([`PointMeasurement::from_frf`]).
    pub weight: f64,
}

/// The lines of one drive level, in measurement order.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct PointLevel {
    /// Nominal level.
    pub level: f64,
    /// Lines in measurement order.
    pub lines: Vec<PointLine>,
}

/// The first-harmonic FRFs of one response point.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct PointMeasurement {
    /// The point's index in the structure's points.
    pub point: usize,
    /// The response quantity of `h`.
    pub response: Quantity,
    /// The levels.
    pub levels: Vec<PointLevel>,
}

impl PointMeasurement {
    /// The first harmonic of `frf` at `point`, each line weighted as
    /// `weighting` says: [`Weighting::None`], by the RMS of `|H_1|` over its
    /// level (every response and level in its own scale, the FRF error the
    /// fit is judged by); [`Weighting::StandardError`], by its standard
    /// error where that is finite and positive, else by that RMS.
    pub fn from_frf(
        point: usize,
        frf: &NonlinearFrf,
        weighting: Weighting,
    ) -> Result<PointMeasurement> {
        if !frf.response.is_motion() || frf.reference != Quantity::Force {
            return Err(Error::input(
                "frf",
                format!(
                    "a fit at points needs a motion over a force, got {} over {}",
                    frf.response, frf.reference
                ),
            ));
        }
        let levels = frf
            .levels
            .iter()
            .map(|l| {
                let h1 = |p: &crate::extract::FrfPoint| p.h.get(1).copied().unwrap_or_default();
                let rms = (l.points.iter().map(|p| h1(p).norm_sqr()).sum::<f64>()
                    / l.points.len().max(1) as f64)
                    .sqrt();
                let lines = l
                    .points
                    .iter()
                    .map(|p| {
                        let se = p.std_error.get(1).copied().unwrap_or(f64::NAN);
                        PointLine {
                            frequency_hz: p.frequency_hz,
                            force_amplitude: p.force_amplitude,
                            h: h1(p),
                            weight: match weighting {
                                Weighting::StandardError if se.is_finite() && se > 0.0 => se,
                                _ => rms,
                            },
                        }
                    })
                    .collect();
                PointLevel {
                    level: l.level,
                    lines,
                }
            })
            .collect();
        Ok(PointMeasurement {
            point,
            response: frf.response,
            levels,
        })
    }
}

/// A joint between two points of the structure.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct PointJoint {
    /// Its ends (`None`: the ground).
    pub ends: (usize, Option<usize>),
    /// Its law and parameters.
    pub law: ElementSpec,
}

/// How the fit solves and how long it runs.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct PointFitOptions {
    /// Harmonic-balance harmonics (odd, holding 1).
    pub harmonics: Vec<usize>,
    /// AFT samples per period.
    pub samples_per_period: usize,
    /// Levenberg–Marquardt's patience (residual evaluations per parameter).
    pub patience: usize,
}

impl Default for PointFitOptions {
    fn default() -> Self {
        PointFitOptions {
            harmonics: vec![1, 3, 5],
            samples_per_period: 256,
            patience: 100,
        }
    }
}

/// What [`fit_points`] found.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct PointFit {
    /// The structure beside the joint.
    pub structure: PointModes,
    /// The joint.
    pub joint: PointJoint,
    /// RMS of the weighted residuals (real and imaginary parts) at the
    /// start.
    pub start_rms: f64,
    /// The same at the optimum.
    pub residual_rms: f64,
    /// Lines whose balance did not converge at the optimum.
    pub failed_lines: usize,
    /// The joint's parameters that ended within 1 % of a bound of their
    /// range: the law at its limit (Masing's `n` at its largest is the
    /// Jenkins joint), or a fit gone astray; either way not a value to
    /// report as found.
    pub at_bounds: Vec<String>,
    /// Whether the fit ended with a joint parameter at a bound and was run
    /// again with it held there (the better of the two is this one).
    pub restarted: bool,
    /// The optimiser's run.
    pub run: OptimiserRun,
}

/// Fits `structure` and `joint` (both as starts) to `data`, the structure
/// driven at point `drive`, by Levenberg–Marquardt (see the module docs).
/// Among a decade either way of the start's slip force, two starts are
/// descended from, the one that meets the data best and the best half a
/// decade or more from it, and the better end is kept: on a measured
/// structure the descents reach different minima. A fit that ends with a
/// joint parameter at a bound of its range (the law at its limit, as
/// Masing's `n` at its largest is the Jenkins joint) is run once more from
/// its start with that parameter held there, and the better of the two is
/// kept ([`PointFit::restarted`]): a free parameter pressed against its
/// bound stalls the descent of the others.
///
/// `observer` is asked before each evaluation whether to stop.
///
/// Errors: measurements whose levels or lines differ from one another, a
/// point out of range, a joint parameter not positive; [`Error::Cancelled`]
/// when the observer asks the work to stop.
pub fn fit_points(
    data: &[PointMeasurement],
    structure: &PointModes,
    drive: usize,
    joint: &PointJoint,
    options: &PointFitOptions,
    observer: &dyn Observer,
) -> Result<PointFit> {
    structure.validate()?;
    let starts = slip_force_starts(data, structure, drive, joint, options)?;
    // the best start and the best half a decade or more from it: where
    // the joint slips decides which minimum a descent reaches
    let slip = |j: &PointJoint| slip_force(j).unwrap_or(1.0);
    let apart = |j: &&PointJoint| (slip(j) / slip(&starts[0])).ln().abs() >= 0.5 * 10f64.ln();
    let mut from = &starts[0];
    let mut first = descend(data, structure, drive, (from, &[]), options, observer)?;
    if let Some(other) = starts.iter().find(apart) {
        let second = descend(data, structure, drive, (other, &[]), options, observer)?;
        if second.residual_rms < first.residual_rms {
            (first, from) = (second, other);
        }
    }
    if first.at_bounds.is_empty() {
        return Ok(first);
    }
    // the law at the limit of its range: held there, the rest descends
    // again from the same start
    let held = &first.at_bounds;
    let limit = first.joint.law.parameters();
    let values: Vec<f64> = (from.law.parameters().iter().zip(&limit))
        .map(|((name, v), (_, at))| {
            if held.iter().any(|h| h == name) {
                *at
            } else {
                *v
            }
        })
        .collect();
    let restart = PointJoint {
        law: from.law.with_parameters(&values),
        ..*from
    };
    let second = descend(data, structure, drive, (&restart, held), options, observer)?;
    let better = if second.residual_rms < first.residual_rms {
        PointFit {
            at_bounds: held.clone(),
            ..second
        }
    } else {
        first
    };
    Ok(PointFit {
        restarted: true,
        ..better
    })
}

/// One Levenberg–Marquardt descent of [`fit_points`] from `joint`, its
/// parameters named in `held` held at their start.
fn descend(
    data: &[PointMeasurement],
    structure: &PointModes,
    drive: usize,
    (joint, held): (&PointJoint, &[String]),
    options: &PointFitOptions,
    observer: &dyn Observer,
) -> Result<PointFit> {
    let layout = Layout::new(structure, Some(&joint.law))?
        .damped_outside(problem::lines_hz(data), start::START_DAMPING)
        .holding(held);
    let problem = JointProblem::new(data, &layout, drive, joint.ends, options)?.observed(observer);
    let theta0 = layout.theta_of(structure, Some(&joint.law));
    let start_rms = problem.rms(&theta0)?.0;
    let run = levenberg_marquardt(&problem, &theta0, options.patience)?;
    let (residual_rms, failed_lines) = problem.rms(&run.theta)?;
    let at_bounds = layout.joint_at_bounds(&run.theta);
    let (structure, _) = layout.structure_at(&run.theta);
    let (law, _) = layout
        .joint_at(&run.theta)
        .expect("the layout holds a joint");
    Ok(PointFit {
        structure,
        joint: PointJoint {
            ends: joint.ends,
            law,
        },
        start_rms,
        residual_rms,
        failed_lines,
        at_bounds,
        restarted: false,
        run,
    })
}

/// The factors of the start's slip force tried before the descent: a
/// decade either way in quarter decades.
const SLIP_FORCE_FACTORS: [f64; 9] = [
    0.1,
    0.177_827_941,
    0.316_227_766,
    0.562_341_325,
    1.0,
    1.778_279_41,
    3.162_277_66,
    5.623_413_25,
    10.0,
];

/// The joint's slip force ([`Role::SlipForce`]), if its law has one.
fn slip_force(joint: &PointJoint) -> Option<f64> {
    let at = joint.law.description().index_of(Role::SlipForce)?;
    Some(joint.law.parameters()[at].1)
}

/// `joint` with its slip force ([`Role::SlipForce`]) each factor of
/// [`SLIP_FORCE_FACTORS`], best first by how well its start meets `data`:
/// where the joint slips decides which levels it softens, and a descent
/// from the wrong side of that stays there. A law without a slip force is
/// the one start.
fn slip_force_starts(
    data: &[PointMeasurement],
    structure: &PointModes,
    drive: usize,
    joint: &PointJoint,
    options: &PointFitOptions,
) -> Result<Vec<PointJoint>> {
    let Some(at) = joint.law.description().index_of(Role::SlipForce) else {
        return Ok(vec![*joint]);
    };
    let mut tried = Vec::with_capacity(SLIP_FORCE_FACTORS.len());
    for factor in SLIP_FORCE_FACTORS {
        let mut values: Vec<f64> = joint.law.parameters().iter().map(|p| p.1).collect();
        values[at] *= factor;
        let law = joint.law.with_parameters(&values);
        if law.build().is_err() {
            continue;
        }
        let layout = Layout::new(structure, Some(&law))?;
        let problem = JointProblem::new(data, &layout, drive, joint.ends, options)?;
        let (rms, _) = problem.rms(&layout.theta_of(structure, Some(&law)))?;
        tried.push((rms, PointJoint { law, ..*joint }));
    }
    if tried.is_empty() {
        return Ok(vec![*joint]);
    }
    tried.sort_by(|a, b| a.0.total_cmp(&b.0));
    Ok(tried.into_iter().map(|t| t.1).collect())
}

/// Every response point's predicted first harmonic (`[level][line][m]`,
/// in `data`'s quantities; `None` where the balance failed), solved along
/// each level in measurement order from the previous line's solution.
pub fn predict_points(
    data: &[PointMeasurement],
    structure: &PointModes,
    drive: usize,
    joint: &PointJoint,
    options: &PointFitOptions,
) -> Result<Vec<Vec<Option<Vec<Complex64>>>>> {
    let shape = problem::check_lines(data, structure.points.len())?;
    let receptance = JointReceptance {
        structure,
        drive,
        ends: joint.ends,
    };
    // each level is independent: solved side by side, each along its own
    // lines in order, so the result does not depend on the thread count
    shape
        .par_iter()
        .enumerate()
        .map(|(level, lines)| predict_level(data, &receptance, joint, options, (level, *lines)))
        .collect()
}

/// Each response's FRF error at each level, `[m][level]`: RMS `|H_pred −
/// H_meas|` over RMS `|H_meas|` of the level's lines, %, from
/// [`predict_points`]'s `predicted` (a line not solved predicts nothing).
pub fn frf_errors_percent(
    data: &[PointMeasurement],
    predicted: &[Vec<Option<Vec<Complex64>>>],
) -> Vec<Vec<f64>> {
    let level_error = |m: usize, l: usize, level: &PointLevel| {
        let (mut e, mut s) = (0.0, 0.0);
        for (i, line) in level.lines.iter().enumerate() {
            let p = predicted[l][i].as_ref().map_or(0.0.into(), |h| h[m]);
            e += (p - line.h).norm_sqr();
            s += line.h.norm_sqr();
        }
        100.0 * (e / s).sqrt()
    };
    (data.iter().enumerate())
        .map(|(m, d)| {
            (d.levels.iter().enumerate())
                .map(|(l, level)| level_error(m, l, level))
                .collect()
        })
        .collect()
}

/// [`predict_points`] of level `level`, along its `lines` lines.
fn predict_level(
    data: &[PointMeasurement],
    receptance: &JointReceptance,
    joint: &PointJoint,
    options: &PointFitOptions,
    (level, lines): (usize, usize),
) -> Result<Vec<Option<Vec<Complex64>>>> {
    let mut solver = crate::hb::HbSolver::new(&problem::hb_options(options))?;
    let mut element = joint.law.build()?;
    let mut guess: Option<Vec<Complex64>> = None;
    let mut predicted = Vec::with_capacity(lines);
    for line in 0..lines {
        let at = data[0].levels[level].lines[line];
        let solved = solver.solve_point(
            receptance,
            &mut element,
            at.frequency_hz,
            at.force_amplitude,
            guess.as_deref(),
        );
        let point = match solved {
            Ok(p) if p.converged => p,
            _ => {
                guess = None;
                predicted.push(None);
                continue;
            }
        };
        let one = point.harmonics.iter().position(|&k| k == 1).unwrap_or(0);
        let x = point_harmonics(receptance, &point);
        let w = 2.0 * std::f64::consts::PI * at.frequency_hz;
        predicted.push(Some(
            data.iter()
                .map(|m| x[m.point][one] / at.force_amplitude * m.response.from_displacement(w))
                .collect(),
        ));
        guess = Some(point.x);
    }
    Ok(predicted)
}
