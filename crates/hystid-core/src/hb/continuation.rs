//! Sweeps: natural continuation in frequency, describing-function starts,
//! and pseudo-arclength continuation to check jumps and locate folds.
//!
//! * Each point starts from a prediction that costs no AFT march: the
//!   balance at the new frequency with the element linearised at the last
//!   solution (`G ≈ G0 + ∂G/∂X (X − X0)`, the receptance exact), solved
//!   directly. Near a sharp resonance this beats extrapolation along the
//!   branch by orders of magnitude (5 Hz steps, paper system: typically
//!   1e-7…1e-3 relative, one or two Newton steps). Where it is not available
//!   (finite-difference Jacobian) the tangent `dX/dω` (`J t = −∂R/∂ω`) with a
//!   quadratic term through the point before is used.
//! * A solve that lands farther than [`JUMP_CHECK`] (relative) from its
//!   prediction is first checked cheaply: Newton back at the previous
//!   frequency from the new point must return to the previous point (after
//!   a jump it stays on the other branch). If that fails, or the solve
//!   itself failed, the branch is traced from the last point by
//!   pseudo-arclength steps in the scaled unknowns `(X/‖X‖, (ω − ω_prev)/Δω)`
//!   (Keller's predictor–corrector; Seydel, *Practical Bifurcation and
//!   Stability Analysis*; NLvib's `solve_and_continue.m`):
//!   - the trace reaches the new frequency: the branch continues and that
//!     solution is taken (natural continuation may have hopped onto another
//!     branch);
//!   - the tangent's frequency component changes sign first: the branch
//!     folds. The fold is approached again in short steps and interpolated
//!     (`ω(s)` quadratic), the sweep jumps (to the natural solve's solution,
//!     or else to a describing-function restart), and the [`Fold`] is
//!     reported.
//! * The first point starts from the single-harmonic describing function FRF.
//!   If it has several amplitudes there, the one on the branch the sweep comes
//!   from is chosen by following the describing function from a frequency (up
//!   to 50 % back) where it has one.

use super::aft::EvalError;
use super::describing;
use super::newton::{Outcome, lu_factor, lu_solve, norm};
use super::{Fold, HbPoint, HbSolver, LinearPart};
use crate::error::Result;
use crate::model::Element;
use num_complex::Complex64;
use std::f64::consts::PI;

/// Relative distance between a solve and its prediction above which the
/// branch is traced to check for a jump.
pub(crate) const JUMP_CHECK: f64 = 0.2;

/// What tracing a branch toward a frequency found.
enum Trace {
    /// The branch reaches the target; its solution there.
    Reached(Vec<f64>, Outcome),
    /// The branch turns back at `omega`, state `x`.
    Fold { omega: f64, x: Vec<f64> },
    /// The trace could not follow the branch.
    Failed(TraceFailure),
}

/// Why pseudo-arclength continuation could not follow a branch.
#[derive(Debug, thiserror::Error)]
enum TraceFailure {
    /// The receptance could not be evaluated at a frequency on the way.
    #[error("{0}")]
    Frequency(crate::Error),
    /// The residual could not be evaluated at a point on the way.
    #[error("{0}")]
    Evaluation(EvalError),
    /// No tangent at the starting point.
    #[error("singular Jacobian at the start of the trace")]
    SingularAtStart,
    /// The corrector failed at every step length down to the minimum.
    #[error("the arc-length corrector failed down to step {step:.1e}")]
    Corrector {
        /// The last step length tried (scaled units).
        step: f64,
    },
    /// No tangent at a corrected point.
    #[error("singular augmented Jacobian on the branch")]
    SingularOnBranch,
    /// Newton at the target frequency, from the traced point, failed.
    #[error("Newton at the traced end failed: {0}")]
    EndNewton(String),
    /// The step limit was reached before the target frequency.
    #[error("did not reach the frequency in {steps} arc-length steps")]
    StepLimit {
        /// Steps taken.
        steps: usize,
    },
}

impl HbSolver {
    pub(super) fn run_sweep<L: LinearPart, E: Element>(
        &mut self,
        linear: &L,
        elements: &mut E,
        freqs: &[f64],
        force: f64,
    ) -> Result<(Vec<HbPoint>, Vec<Fold>)> {
        let n = self.core.n;
        let direction = match (freqs.first(), freqs.last()) {
            (Some(a), Some(b)) if b > a => 1.0,
            (Some(a), Some(b)) if b < a => -1.0,
            _ => 0.0,
        };
        let mut points = Vec::with_capacity(freqs.len());
        let mut folds = Vec::new();
        // the last converged point of the current branch and its tangent
        let mut last: Option<(f64, Vec<f64>, Option<Vec<f64>>)> = None;
        let mut before: Option<(f64, Vec<f64>)> = None;
        // the element linearisation at `last`, when the solve left it
        let (mut g0, mut dg0) = (Vec::new(), Vec::new());
        let mut linearised = false;

        let mut guess = vec![0.0; n];
        let mut x = vec![0.0; n];
        let mut tangent = vec![0.0; n];
        for (i, &f) in freqs.iter().enumerate() {
            let omega = 2.0 * PI * f;
            let (xi, out, fresh) = match &last {
                None => {
                    let (x0, out) = self.cold_start(linear, elements, omega, force, direction)?;
                    (x0, out, false)
                }
                Some((w0, x0, t0)) => {
                    let dw = omega - w0;
                    let predicted = linearised
                        && self
                            .core
                            .linearised_prediction(linear, omega, force, x0, &g0, &dg0, &mut guess);
                    match (t0, &before) {
                        _ if predicted => {}
                        // quadratic through the tangent and the point before
                        (Some(t0), Some((wm, xm))) => {
                            let dm = wm - w0;
                            for k in 0..n {
                                let c = (xm[k] - x0[k] - t0[k] * dm) / (dm * dm);
                                guess[k] = x0[k] + dw * t0[k] + c * dw * dw;
                            }
                        }
                        (Some(t0), None) => {
                            for k in 0..n {
                                guess[k] = x0[k] + dw * t0[k];
                            }
                        }
                        _ => guess.copy_from_slice(x0),
                    }
                    self.core.set_frequency(linear, omega)?;
                    x.copy_from_slice(&guess);
                    let out = self
                        .core
                        .newton(elements, force, &mut x, &mut self.counters);
                    let moved = distance(&x, &guess) / norm(&x).max(norm(&guess));
                    if out.converged && moved <= JUMP_CHECK {
                        (x.clone(), out, false)
                    } else if out.converged
                        && self.returns_to(
                            linear,
                            elements,
                            force,
                            &x,
                            omega,
                            x0,
                            *w0,
                            &mut tangent,
                        )
                    {
                        // the same branch, just a large step
                        (x.clone(), out, false)
                    } else {
                        let (w0, x0) = (*w0, x0.clone());
                        let (xd, out, _) = self.check_jump(
                            linear, elements, force, i, &x0, w0, omega, &x, out, &mut folds,
                        )?;
                        (xd, out, true)
                    }
                }
            };
            let point = self.point(f, force, &xi, &out);
            if out.converged {
                // the tangent for the next prediction (no march needed for
                // rate-independent elements right after a solve)
                if fresh {
                    self.core.set_frequency(linear, omega)?;
                }
                let ok = self.core.tangent(
                    linear,
                    elements,
                    force,
                    &xi,
                    &mut tangent,
                    &mut self.counters,
                );
                linearised = self.core.element_linearisation(&mut g0, &mut dg0);
                before = match (fresh, last.take()) {
                    (false, Some((w, x, _))) => Some((w, x)),
                    _ => None,
                };
                last = Some((omega, xi, ok.then(|| tangent.clone())));
            }
            points.push(point);
        }
        Ok((points, folds))
    }

    /// Whether Newton from the converged `x` at `omega`, taken back along its
    /// tangent to `w0`, returns to `x0`: a cheap check that a large step
    /// stayed on the branch (after a jump it lands on the other branch).
    #[allow(clippy::too_many_arguments)]
    fn returns_to<L: LinearPart, E: Element>(
        &mut self,
        linear: &L,
        elements: &mut E,
        force: f64,
        x: &[f64],
        omega: f64,
        x0: &[f64],
        w0: f64,
        tangent: &mut [f64],
    ) -> bool {
        if !self
            .core
            .tangent(linear, elements, force, x, tangent, &mut self.counters)
        {
            return false;
        }
        let mut back: Vec<f64> = x
            .iter()
            .zip(tangent.iter())
            .map(|(a, t)| a + (w0 - omega) * t)
            .collect();
        if self.core.set_frequency(linear, w0).is_err() {
            return false;
        }
        let out = self
            .core
            .newton(elements, force, &mut back, &mut self.counters);
        let same = out.converged && distance(&back, x0) <= 1e-6 * norm(x0);
        // leave the solver at the point's own frequency
        let _ = self.core.set_frequency(linear, omega);
        same
    }

    /// After a failed or far-moved natural step from `(x0, w0)` to `omega`:
    /// trace the branch, decide, report a fold. Returns the point's state,
    /// outcome and whether it starts a new branch.
    #[allow(clippy::too_many_arguments)]
    fn check_jump<L: LinearPart, E: Element>(
        &mut self,
        linear: &L,
        elements: &mut E,
        force: f64,
        index: usize,
        x0: &[f64],
        w0: f64,
        omega: f64,
        natural: &[f64],
        natural_out: Outcome,
        folds: &mut Vec<Fold>,
    ) -> Result<(Vec<f64>, Outcome, bool)> {
        let layout = self.core.aft.layout.clone();
        let before_amp = layout.fundamental(x0).norm();
        match self.trace(linear, elements, force, x0, w0, omega) {
            Trace::Reached(xa, out) => {
                if natural_out.converged && distance(natural, &xa) <= 1e-6 * norm(&xa) {
                    Ok((natural.to_vec(), natural_out, false))
                } else {
                    Ok((xa, out, false))
                }
            }
            Trace::Fold { omega: wf, x: xf } => {
                let fold_amp = layout.fundamental(&xf).norm();
                let (xd, out) = if natural_out.converged {
                    (natural.to_vec(), natural_out)
                } else {
                    self.restart(linear, elements, omega, force, Some(fold_amp))?
                };
                folds.push(Fold {
                    index,
                    frequency_hz: wf / (2.0 * PI),
                    located: true,
                    amplitude_at_fold: fold_amp,
                    amplitude_before: before_amp,
                    amplitude_after: if out.converged {
                        layout.fundamental(&xd).norm()
                    } else {
                        f64::NAN
                    },
                });
                Ok((xd, out, true))
            }
            Trace::Failed(why) => {
                if natural_out.converged {
                    // the branch could not be traced, and Newton back from the
                    // new point did not return: most likely a jump. Keep
                    // natural continuation's answer and report the fold as
                    // not located.
                    folds.push(Fold {
                        index,
                        frequency_hz: 0.5 * (w0 + omega) / (2.0 * PI),
                        located: false,
                        amplitude_at_fold: f64::NAN,
                        amplitude_before: before_amp,
                        amplitude_after: layout.fundamental(natural).norm(),
                    });
                    return Ok((natural.to_vec(), natural_out, true));
                }
                let (xd, mut out) =
                    self.restart(linear, elements, omega, force, Some(before_amp))?;
                if !out.converged {
                    out.failure = Some(format!(
                        "warm start: {}; arc-length: {why}; describing-function restart: {}",
                        natural_out.failure.unwrap_or_default(),
                        out.failure.unwrap_or_default()
                    ));
                }
                Ok((xd, out, true))
            }
        }
    }

    /// Single-harmonic describing-function solutions at `omega`, as guesses.
    fn df_guesses<L: LinearPart, E: Element>(
        &mut self,
        linear: &L,
        elements: &mut E,
        omega: f64,
        force: f64,
    ) -> Result<Vec<Complex64>> {
        describing::solve_on(
            linear,
            elements,
            omega,
            force,
            self.core.opts.samples_per_period,
        )
    }

    /// The first point of a branch: describing-function start(s), then
    /// Newton. `direction` (+1 up, −1 down, 0 none) picks among several
    /// describing-function amplitudes.
    pub(super) fn cold_start<L: LinearPart, E: Element>(
        &mut self,
        linear: &L,
        elements: &mut E,
        omega: f64,
        force: f64,
        direction: f64,
    ) -> Result<(Vec<f64>, Outcome)> {
        let mut roots = self.df_guesses(linear, elements, omega, force)?;
        let pick = if roots.len() > 1 && direction != 0.0 {
            self.branch_root(linear, elements, omega, force, direction, &roots)
        } else {
            None
        };
        if let Some(pick) = pick {
            // try the branch's root first
            roots.sort_by(|a, b| {
                log_gap(a.norm(), pick.norm()).total_cmp(&log_gap(b.norm(), pick.norm()))
            });
        }
        self.polish(linear, elements, omega, force, &roots)
    }

    /// A describing-function restart, trying the amplitude closest to
    /// `prefer` first.
    fn restart<L: LinearPart, E: Element>(
        &mut self,
        linear: &L,
        elements: &mut E,
        omega: f64,
        force: f64,
        prefer: Option<f64>,
    ) -> Result<(Vec<f64>, Outcome)> {
        let mut roots = self.df_guesses(linear, elements, omega, force)?;
        if let Some(p) = prefer.filter(|p| p.is_finite() && *p > 0.0) {
            roots.sort_by(|a, b| log_gap(a.norm(), p).total_cmp(&log_gap(b.norm(), p)));
        }
        self.polish(linear, elements, omega, force, &roots)
    }

    /// Newton from each single-harmonic guess in turn until one converges.
    fn polish<L: LinearPart, E: Element>(
        &mut self,
        linear: &L,
        elements: &mut E,
        omega: f64,
        force: f64,
        roots: &[Complex64],
    ) -> Result<(Vec<f64>, Outcome)> {
        self.core.set_frequency(linear, omega)?;
        let n = self.core.n;
        let layout = self.core.aft.layout.clone();
        let i1 = layout.harmonics.iter().position(|&h| h == 1).unwrap_or(0);
        let mut x = vec![0.0; n];
        let mut reasons = Vec::new();
        let (mut iterations, mut residual) = (0, f64::NAN);
        for r in roots {
            x.fill(0.0);
            x[layout.slots[i1]] = r.re;
            x[layout.slots[i1] + 1] = r.im;
            let out = self
                .core
                .newton(elements, force, &mut x, &mut self.counters);
            if out.converged {
                return Ok((x, out));
            }
            // report the closest attempt's figures
            if residual.is_nan() || out.residual < residual {
                iterations = out.iterations;
                residual = out.residual;
            }
            reasons.push(format!(
                "from |X1| = {:.4e} m: {}",
                r.norm(),
                out.failure.unwrap_or_default()
            ));
        }
        let why = if roots.is_empty() {
            "the single-harmonic describing function gave no starting amplitude".to_string()
        } else {
            reasons.join("; ")
        };
        Ok((
            x,
            Outcome {
                converged: false,
                iterations,
                residual,
                failure: Some(why),
            },
        ))
    }

    /// With several describing-function amplitudes at `omega`, the one on
    /// the branch a sweep in `direction` arrives on: step back (0.5 % at a
    /// time, up to 50 %) until the amplitude is unique, then follow it
    /// forward, picking at each step the amplitude nearest to the linear
    /// extrapolation (in log amplitude) of the last two.
    fn branch_root<L: LinearPart, E: Element>(
        &mut self,
        linear: &L,
        elements: &mut E,
        omega: f64,
        force: f64,
        direction: f64,
        roots: &[Complex64],
    ) -> Option<Complex64> {
        const STEP: f64 = 0.005;
        let at = |k: usize| omega * (1.0 - direction * STEP * k as f64);
        let mut behind: Vec<Vec<Complex64>> = Vec::new();
        for k in 1..=100 {
            let r = self.df_guesses(linear, elements, at(k), force).ok()?;
            if r.len() == 1 {
                let (mut prev, mut current) = (r[0].norm(), r[0].norm());
                for rm in behind.iter().rev().chain(std::iter::once(&roots.to_vec())) {
                    let guess = current * current / prev;
                    let best = nearest(rm, guess)?.norm();
                    prev = current;
                    current = best;
                }
                return nearest(roots, current);
            }
            behind.push(r);
        }
        None
    }

    /// Pseudo-arclength continuation of the branch through `(x0, w0)` toward
    /// `w1`.
    fn trace<L: LinearPart, E: Element>(
        &mut self,
        linear: &L,
        elements: &mut E,
        force: f64,
        x0: &[f64],
        w0: f64,
        w1: f64,
    ) -> Trace {
        const DS_MAX: f64 = 0.25;
        const DS_MIN: f64 = 1e-6;
        // the step (scaled units) over which a fold is finally interpolated
        const FOLD_STEP: f64 = 2e-3;
        const MAX_STEPS: usize = 200;
        const CORRECTOR_ITERATIONS: usize = 12;
        let n = self.core.n;
        let m = n + 1;
        let sx = norm(x0);
        let dw = w1 - w0;
        // scaled unknowns: y = (x/sx, (ω − w0)/dw)
        let mut y = vec![0.0; m];
        for k in 0..n {
            y[k] = x0[k] / sx;
        }
        let tol = self.core.opts.tolerance.max(1e-9);
        let mut r = vec![0.0; n];
        let mut ja = vec![0.0; n * m];
        let mut a = vec![0.0; m * m];
        let mut piv = vec![0; m];
        let mut rhs = vec![0.0; m];
        // the augmented Jacobian [∂R/∂u | ∂R/∂w] at y
        let mut augmented = |s: &mut HbSolver,
                             y: &[f64],
                             r: &mut [f64],
                             ja: &mut [f64]|
         -> std::result::Result<f64, TraceFailure> {
            let x: Vec<f64> = y[..n].iter().map(|u| u * sx).collect();
            let omega = w0 + dw * y[n];
            s.core
                .set_frequency(linear, omega)
                .map_err(TraceFailure::Frequency)?;
            let mut jx = vec![0.0; n * n];
            s.counters.residuals += 1;
            s.counters.jacobians += 1;
            s.core
                .residual(elements, force, &x, r, Some(&mut jx))
                .map_err(TraceFailure::Evaluation)?;
            let h = 1e-7 * omega.abs().max(1.0);
            s.core
                .set_frequency(linear, omega + h)
                .map_err(TraceFailure::Frequency)?;
            let mut rp = vec![0.0; n];
            s.counters.residuals += 1;
            s.core
                .residual(elements, force, &x, &mut rp, None)
                .map_err(TraceFailure::Evaluation)?;
            for i in 0..n {
                for k in 0..n {
                    ja[i * m + k] = jx[i * n + k] * sx;
                }
                ja[i * m + n] = (rp[i] - r[i]) / h * dw;
            }
            Ok(norm(r) / norm(&x).max(f64::MIN_POSITIVE))
        };
        // tangent: [J; t_prev] t = e_last, normalised
        let tangent = |ja: &[f64],
                       prev: &[f64],
                       a: &mut [f64],
                       piv: &mut [usize],
                       rhs: &mut [f64]|
         -> Option<Vec<f64>> {
            a[..n * m].copy_from_slice(ja);
            a[n * m..].copy_from_slice(prev);
            if !lu_factor(a, piv, m) {
                return None;
            }
            rhs.fill(0.0);
            rhs[n] = 1.0;
            lu_solve(a, piv, m, rhs);
            let s = norm(rhs);
            Some(rhs.iter().map(|v| v / s).collect())
        };
        if let Err(why) = augmented(self, &y, &mut r, &mut ja) {
            return Trace::Failed(why);
        }
        let mut e_last = vec![0.0; m];
        e_last[n] = 1.0;
        let Some(mut t) = tangent(&ja, &e_last, &mut a, &mut piv, &mut rhs) else {
            return Trace::Failed(TraceFailure::SingularAtStart);
        };
        let mut ds = (1.0 / t[n].max(1e-12)).min(DS_MAX);
        // shrinks when a fold is straddled, to locate it with short steps
        let mut ds_cap = DS_MAX;
        let mut z = vec![0.0; m];
        let mut pred = vec![0.0; m];
        for _ in 0..MAX_STEPS {
            let mut last_step = false;
            if t[n] > 0.0 && y[n] + ds * t[n] >= 1.0 {
                ds = (1.0 - y[n]) / t[n];
                last_step = true;
            }
            for k in 0..m {
                pred[k] = y[k] + ds * t[k];
            }
            z.copy_from_slice(&pred);
            let mut converged = false;
            let mut iterations = 0;
            for it in 0..CORRECTOR_ITERATIONS {
                iterations = it + 1;
                let rel = match augmented(self, &z, &mut r, &mut ja) {
                    Ok(v) => v,
                    Err(_) => break,
                };
                let arc: f64 = (0..m).map(|k| t[k] * (z[k] - pred[k])).sum();
                if rel <= tol && arc.abs() <= 1e-9 {
                    converged = true;
                    break;
                }
                a[..n * m].copy_from_slice(&ja);
                a[n * m..].copy_from_slice(&t);
                if !lu_factor(&mut a, &mut piv, m) {
                    break;
                }
                for i in 0..n {
                    rhs[i] = -r[i];
                }
                rhs[n] = -arc;
                lu_solve(&a, &piv, m, &mut rhs);
                for k in 0..m {
                    z[k] += rhs[k];
                }
            }
            if !converged {
                ds *= 0.5;
                if ds < DS_MIN {
                    return Trace::Failed(TraceFailure::Corrector { step: ds });
                }
                continue;
            }
            let Some(t_new) = tangent(&ja, &t, &mut a, &mut piv, &mut rhs) else {
                return Trace::Failed(TraceFailure::SingularOnBranch);
            };
            if t_new[n] <= 0.0 && ds > FOLD_STEP {
                // a fold between y and z: approach it again in shorter steps
                ds_cap = (0.25 * ds).max(FOLD_STEP);
                ds = ds_cap;
                continue;
            }
            if t_new[n] <= 0.0 {
                // the frequency turned back between y and z: w(s) ≈ quadratic
                let step = distance(&y, &z);
                let sf = step * t[n] / (t[n] - t_new[n]);
                let wf = y[n] + 0.5 * t[n] * sf;
                let frac = if step > 0.0 { sf / step } else { 0.0 };
                let xf: Vec<f64> = (0..n).map(|k| sx * (y[k] + frac * (z[k] - y[k]))).collect();
                return Trace::Fold {
                    omega: w0 + dw * wf,
                    x: xf,
                };
            }
            y.copy_from_slice(&z);
            t = t_new;
            if last_step || (y[n] - 1.0).abs() < 1e-9 {
                let mut x: Vec<f64> = y[..n].iter().map(|u| u * sx).collect();
                if let Err(e) = self.core.set_frequency(linear, w1) {
                    return Trace::Failed(TraceFailure::Frequency(e));
                }
                let out = self
                    .core
                    .newton(elements, force, &mut x, &mut self.counters);
                return if out.converged {
                    Trace::Reached(x, out)
                } else {
                    Trace::Failed(TraceFailure::EndNewton(out.failure.unwrap_or_default()))
                };
            }
            if iterations <= 3 {
                ds = (ds * 1.5).min(ds_cap);
            }
        }
        Trace::Failed(TraceFailure::StepLimit { steps: MAX_STEPS })
    }
}

pub(crate) fn distance(a: &[f64], b: &[f64]) -> f64 {
    a.iter()
        .zip(b)
        .map(|(x, y)| (x - y) * (x - y))
        .sum::<f64>()
        .sqrt()
}

fn log_gap(a: f64, b: f64) -> f64 {
    (a.ln() - b.ln()).abs()
}

fn nearest(roots: &[Complex64], amplitude: f64) -> Option<Complex64> {
    roots
        .iter()
        .copied()
        .min_by(|a, b| log_gap(a.norm(), amplitude).total_cmp(&log_gap(b.norm(), amplitude)))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::hb::HbOptions;
    use crate::model::{CubicStiffness, ModalModel, NoElement};

    fn converged_at(
        s: &mut HbSolver,
        linear: &ModalModel,
        e: &mut impl Element,
        f: f64,
        force: f64,
        guess: &[f64],
    ) -> Vec<f64> {
        s.core.set_frequency(linear, 2.0 * PI * f).unwrap();
        let mut x = guess.to_vec();
        let out = s.core.newton(e, force, &mut x, &mut s.counters);
        assert!(out.converged);
        x
    }

    /// Across a linear resonance the trace reaches the target, equal to
    /// the receptance there.
    #[test]
    fn trace_reaches_the_far_side_of_a_linear_resonance() {
        let linear = ModalModel::sdof(10.0, 200.0, 1e7).unwrap();
        let mut s = HbSolver::new(&HbOptions::with_harmonics(vec![1])).unwrap();
        let force = 10.0;
        let h = linear.receptance(2.0 * PI * 150.0) * force;
        let x0 = converged_at(&mut s, &linear, &mut NoElement, 150.0, force, &[h.re, h.im]);
        match s.trace(
            &linear,
            &mut NoElement,
            force,
            &x0,
            2.0 * PI * 150.0,
            2.0 * PI * 170.0,
        ) {
            Trace::Reached(x, _) => {
                let exact = linear.receptance(2.0 * PI * 170.0) * force;
                let got = Complex64::new(x[0], x[1]);
                assert!(
                    (got - exact).norm() < 1e-9 * exact.norm(),
                    "{got} vs {exact}"
                );
            }
            Trace::Fold { omega, .. } => panic!("a fold at {omega} in a linear system"),
            Trace::Failed(why) => panic!("{why}"),
        }
    }

    /// Past the upper fold of a hardening Duffing oscillator the trace
    /// turns back there (single harmonic: closed form 177.3740 Hz, see the
    /// integration tests).
    #[test]
    fn trace_stops_at_a_fold() {
        let linear = ModalModel::sdof(10.0, 200.0, 1e7).unwrap();
        let mut s = HbSolver::new(&HbOptions::with_harmonics(vec![1])).unwrap();
        let mut e = CubicStiffness { k3: 4e12 };
        let force = 200.0;
        // on the upper branch at 177 Hz (from a sweep up)
        let freqs: Vec<f64> = (0..=27).map(|i| 150.0 + i as f64).collect();
        let sweep = s.sweep(&linear, &mut e, &freqs, force).unwrap();
        let p = sweep.points.last().unwrap();
        assert!(sweep.folds.is_empty() && p.amplitude() > 5e-4);
        let x0 = [p.x[0].re, p.x[0].im];
        match s.trace(
            &linear,
            &mut e,
            force,
            &x0,
            2.0 * PI * 177.0,
            2.0 * PI * 178.0,
        ) {
            Trace::Fold { omega, x } => {
                assert!(
                    (omega / (2.0 * PI) - 177.3740).abs() < 1e-3,
                    "{}",
                    omega / (2.0 * PI)
                );
                assert!(x[0].hypot(x[1]) > 5e-4);
            }
            Trace::Reached(..) => panic!("went past the fold"),
            Trace::Failed(why) => panic!("{why}"),
        }
    }
}
