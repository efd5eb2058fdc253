//! Multi-harmonic balance with the alternating frequency–time scheme.
//!
//! The analytic nonlinear FRF of the paper (section 2, eqs. 3–8): the
//! response at the drive/joint point is a Fourier series over a harmonic set
//! (default `{1, 3, 5}`, the paper's choice), and each harmonic balances
//!
//! ```text
//! Z_h X_h + G_h(X) − F δ_{h1} = 0,     Z_h = 1/H(hω)      (eq. 8)
//! ```
//!
//! where `H` is the underlying linear receptance ([`LinearPart`]: a
//! [`ModalModel`] or a [`TabulatedFrf`]) and `G_h` the element force's
//! harmonic, computed by AFT from the *same* [`Element`]s the time simulator
//! uses (Cameron & Griffin 1989).
//!
//! **Residual form.** Newton solves eq. (8) multiplied by `H(hω)`:
//!
//! ```text
//! R_h = X_h − H(hω) (F δ_{h1} − G_h(X)) = 0,   converged when ‖R‖₂/‖X‖₂ ≤ tolerance
//! ```
//!
//! Every row is then a displacement and the Jacobian `I + H ∂G/∂X` is the
//! identity plus the element's effect, well scaled across harmonics (the
//! impedance form mixes `|Z_5| ≈ 6e8 N/m` rows with near-zero `|Z_1|` rows
//! at resonance), and no `1/H` is formed, so a tabulated or multi-mode
//! receptance near an antiresonance is harmless. The residual measure is the
//! relative misfit of the displacement harmonics. `∂G/∂X` is carried through
//! the hysteresis march by [`Element::commit_sensitivity`] (exact, checked
//! against finite differences) and kept while steps contract the residual
//! tenfold (modified Newton); an Armijo line search damps the steps, and a
//! point whose line search fails retries with a finite-difference Jacobian.
//!
//! **Periodic loops and turning points.** AFT marches the element through a
//! period from a virgin ramp to the loop tip ([`PeriodicLoop`]), committing,
//! besides the `N` samples, the exact extrema of `x(θ)` between them, so
//! loops reverse at the true tips (the samples alone cut them short: an
//! `O(N⁻²)` error, ~3e-4 in `H_1` at 256 samples; with the extrema the
//! Masing error is 6e-5 at 256 and 3e-6 at 512 samples, Jenkins' slip kinks
//! keep ~`N⁻²`: 2e-4 at 256, 1e-4 at 512). With odd harmonics and odd
//! element laws half a period is marched ([`HbOptions::half_wave_symmetry`]).
//!
//! **Sweeps** ([`HbSolver::sweep`]) follow a frequency list in its order (the
//! sweep direction). The first point starts from the single-harmonic
//! describing function ([`describing`]); each later one from the balance at
//! its frequency with the element linearised at the last solution (no AFT
//! march). Where the branch folds, natural continuation jumps as a
//! stepped-sine test would; a large jump (or a failed Newton solve) is checked
//! by pseudo-arclength continuation in `(X, ω)`, which locates the fold and
//! reports it as a [`Fold`].
//!
//! **Failures.** A point that does not converge is data, not an error:
//! `converged = false`, `failure` says why, and `x` and `h` are **NaN** so
//! that it can never pass for a number (serialised as `null` in JSON).
//! Errors are kept for bad input (options, frequencies, a linear part that
//! does not cover every `h·f`).
//!
//! Fourier convention: [`crate::harmonics`] (`x(t) = X_0 + Re Σ X_h e^{jhωt}`,
//! single-sided; `H_h = X_h/F` with the force `F cos ωt`).

pub(crate) mod aft;
mod check;
mod continuation;
pub mod describing;
pub mod linear;
mod newton;
pub mod points;

pub use check::{HbCheck, SteadyDwell, check_hb};
pub use linear::{Driven, LinearPart, SampledReceptance, TabulatedFrf};

use crate::error::{Error, Result};
#[cfg(doc)]
use crate::model::ModalModel;
use crate::model::{Element, Model};
use newton::{Core, Counters};
use num_complex::Complex64;
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

/// How AFT makes the hysteresis loop periodic.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum PeriodicLoop {
    /// Reset, commit the sample of largest `|x|` (a virgin ramp to the loop
    /// tip), then march the period from the next sample back to it. Every
    /// Masing-type loop then closes within the one period. (The largest
    /// *magnitude*, not the maximum, is what makes the march periodic when a
    /// static offset makes `|x_min| > x_max`.)
    #[default]
    MaxAmplitude,
    /// March two periods from the virgin state and keep the second (NLvib's
    /// `HB_residual.m`): twice the work, a check on the first.
    TwoPeriods,
}

/// How Newton's Jacobian is obtained.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum JacobianMethod {
    /// Carried through the march by [`Element::commit_sensitivity`]; falls
    /// back to differences for a point whose line search fails.
    #[default]
    Analytic,
    /// Forward differences, step `1e-7·‖X‖∞` (one AFT per unknown).
    FiniteDifference,
}

/// Harmonic-balance settings.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct HbOptions {
    /// The harmonic set, strictly increasing, holding 1; 0 is the static
    /// part (needed by asymmetric elements such as `BilinearStiffness`, with
    /// the even harmonics). Default `{1, 3, 5}`.
    pub harmonics: Vec<usize>,
    /// AFT time samples per period, more than twice the highest harmonic.
    /// Default 256 (512 recommended for the Jenkins element, whose slip
    /// kinks keep AFT's error at ~`N⁻²`).
    pub samples_per_period: usize,
    /// Convergence: `‖R‖₂/‖X‖₂` of the receptance-form residual. Default
    /// 1e-10.
    pub tolerance: f64,
    /// Newton iterations per solve. Default 50.
    pub max_iterations: usize,
    /// Periodic-loop method. Default [`PeriodicLoop::MaxAmplitude`].
    pub periodic_loop: PeriodicLoop,
    /// Jacobian. Default [`JacobianMethod::Analytic`].
    pub jacobian: JacobianMethod,
    /// Use half-wave symmetry where it holds: with odd harmonics only, an
    /// even sample count and elements whose laws are odd, the periodic
    /// force obeys `g(θ + π) = −g(θ)` and AFT marches half a period (half
    /// the cost; the same answer to round-off). Applied automatically to
    /// the built-in odd elements (Jenkins, Masing, cubic stiffness,
    /// quadratic and viscous damping, clearance; not bilinear stiffness),
    /// never to other element types. Default true.
    pub half_wave_symmetry: bool,
}

impl Default for HbOptions {
    fn default() -> Self {
        HbOptions {
            harmonics: vec![1, 3, 5],
            samples_per_period: 256,
            tolerance: 1e-10,
            max_iterations: 50,
            periodic_loop: PeriodicLoop::MaxAmplitude,
            jacobian: JacobianMethod::Analytic,
            half_wave_symmetry: true,
        }
    }
}

impl HbOptions {
    /// The defaults with another harmonic set.
    pub fn with_harmonics(harmonics: Vec<usize>) -> HbOptions {
        HbOptions {
            harmonics,
            ..HbOptions::default()
        }
    }

    /// Checks the settings.
    pub fn validate(&self) -> Result<()> {
        let h = &self.harmonics;
        if !h.contains(&1) {
            return Err(Error::plan(
                "hb.harmonics",
                format!("must contain the forced harmonic 1, got {h:?}"),
            ));
        }
        if h.windows(2).any(|w| w[1] <= w[0]) {
            return Err(Error::plan(
                "hb.harmonics",
                format!("must increase strictly, got {h:?}"),
            ));
        }
        let top = *h.last().unwrap_or(&1);
        let ns = self.samples_per_period;
        if ns <= 2 * top || ns < 8 {
            return Err(Error::plan(
                "hb.samples_per_period",
                format!(
                    "must exceed twice the highest harmonic ({top}) and be at least 8, got {ns}"
                ),
            ));
        }
        if !(self.tolerance.is_finite() && self.tolerance > 0.0 && self.tolerance < 1.0) {
            return Err(Error::plan(
                "hb.tolerance",
                format!("must be in (0, 1), got {}", self.tolerance),
            ));
        }
        if self.max_iterations == 0 {
            return Err(Error::plan("hb.max_iterations", "must be at least 1"));
        }
        Ok(())
    }
}

/// The odd harmonics `{1, 3, …, max}`.
pub fn odd_harmonics(max: usize) -> Vec<usize> {
    (1..=max).step_by(2).collect()
}

/// Every harmonic `{0, 1, 2, …, max}`, the static part included.
pub fn all_harmonics(max: usize) -> Vec<usize> {
    (0..=max).collect()
}

/// One harmonic-balance solution.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct HbPoint {
    /// Excitation frequency, Hz.
    pub frequency_hz: f64,
    /// Force amplitude `F` (the force is `F cos ωt`), N.
    pub force_amplitude: f64,
    /// The harmonic set, in the order of `x` and `h`.
    pub harmonics: Vec<usize>,
    /// Displacement harmonics `X_h`, m (`X_0` real). NaN when not converged.
    pub x: Vec<Complex64>,
    /// FRFs `H_h = X_h/F`, m/N. NaN when not converged.
    pub h: Vec<Complex64>,
    /// Newton iterations of the final solve.
    pub iterations: usize,
    /// Relative residual `‖R‖₂/‖X‖₂` reached.
    pub residual: f64,
    /// Whether the residual met the tolerance.
    pub converged: bool,
    /// Why not, when not converged.
    pub failure: Option<String>,
}

impl HbPoint {
    /// The FRF of harmonic `h`, if it is in the set.
    pub fn frf(&self, h: usize) -> Option<Complex64> {
        self.harmonics
            .iter()
            .position(|&k| k == h)
            .map(|i| self.h[i])
    }

    /// `|X_1|`, m.
    pub fn amplitude(&self) -> f64 {
        self.frf(1)
            .map_or(f64::NAN, |h| h.norm() * self.force_amplitude)
    }
}

/// A fold met by a sweep: the branch being followed turned back, and the
/// sweep jumped to another branch (as a stepped-sine test does).
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Fold {
    /// Index of the first sweep point after the jump.
    pub index: usize,
    /// The turning point's frequency, Hz (from the arc-length trace when
    /// `located`, else the midpoint of the two sweep frequencies).
    pub frequency_hz: f64,
    /// Whether arc-length continuation located the turning point. `false`:
    /// the solution moved far from its prediction, Newton from it did not
    /// return to the previous point, and the branch could not be traced, so
    /// the jump is reported without its turning point.
    pub located: bool,
    /// `|X_1|` at the turning point (NaN if not located), m.
    pub amplitude_at_fold: f64,
    /// `|X_1|` at the last point before the jump, m.
    pub amplitude_before: f64,
    /// `|X_1|` at the first point after the jump, m.
    pub amplitude_after: f64,
}

/// A frequency sweep at one force level.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct HbSweep {
    /// One point per frequency, in sweep order.
    pub points: Vec<HbPoint>,
    /// Folds (jumps) met, in sweep order.
    pub folds: Vec<Fold>,
    /// AFT residual evaluations spent (a cost measure).
    pub evaluations: u64,
}

/// A reusable harmonic-balance solver: the AFT workspace (FFT plans, basis
/// tables) and Newton buffers for one [`HbOptions`]. Warm-started points
/// do not allocate in the Newton loop.
pub struct HbSolver {
    core: Core,
    counters: Counters,
    walk: Walk,
}

/// The last point [`HbSolver::solve_point`] converged at and the element's
/// linearisation there: a walk along the frequencies that passes it back
/// as the next guess starts from the balance linearised about it instead.
#[derive(Default)]
struct Walk {
    /// Whether `x`, `g` and `dg` describe the last converged point.
    held: bool,
    omega: f64,
    force: f64,
    x: Vec<f64>,
    g: Vec<f64>,
    dg: Vec<f64>,
    /// The prediction, `n` long.
    predicted: Vec<f64>,
}

/// The largest relative step from the last point that
/// [`HbSolver::solve_point`] takes from a linearised prediction: a
/// larger one means the balance is near a fold, where the linearisation
/// points across it, and the walk starts from the last point instead (as a
/// stepped-sine test stays on its branch). At a twentieth a fit makes the
/// same solves as without the prediction; a larger bound (a tenth, or the
/// fifth a sweep holds a solve to, [`continuation::JUMP_CHECK`]) saves a
/// few AFT evaluations a point, but the fits converge from points
/// predicted 5-20 % away to other bits within the tolerance, take other
/// paths and cost more model solves overall.
const PREDICTION_TRUST: f64 = 0.05;

/// How close (relative) a guess must be to the last converged point to
/// continue its walk: the same solution reached another way (a sweep, an
/// earlier solve) differs from it by the Newton tolerance's order, 1e-13
/// to 1e-10 on the speed bench's grid.
const SAME_SOLUTION: f64 = 1e-8;

impl HbSolver {
    /// A solver; checks the options.
    pub fn new(opts: &HbOptions) -> Result<HbSolver> {
        opts.validate()?;
        Ok(HbSolver {
            core: Core::new(opts),
            counters: Counters::default(),
            walk: Walk::default(),
        })
    }

    /// The options.
    pub fn options(&self) -> &HbOptions {
        &self.core.opts
    }

    /// Makes every solve take at least one Newton step, even from a guess
    /// already within the tolerance: a point solved at parameters a
    /// difference step away from its guess's then moves with the step
    /// (see [`crate::fit::FrfPredictor::predict_near`]).
    pub fn step_at_least_once(&mut self, yes: bool) {
        self.core.step_at_least_once = yes;
    }

    /// AFT residual evaluations so far.
    pub fn evaluations(&self) -> u64 {
        self.counters.residuals
    }

    /// Solves at one frequency.
    ///
    /// `guess`: displacement harmonics, one per harmonic of the set (e.g. a
    /// neighbouring point's `x`); `None` starts from the single-harmonic
    /// describing function (the smallest-amplitude solution when there are
    /// several). If Newton fails from a given guess, the describing-function
    /// start is tried too.
    ///
    /// A walk along the frequencies that passes this solver's last solution
    /// back as the guess (at the same force) starts from the balance
    /// linearised about it, as [`HbSolver::sweep`] does (one small linear
    /// solve, no AFT march; 3.4 evaluations per point instead of 5.1 on the
    /// speed bench's curve), unless the predicted step exceeds a twentieth of
    /// the last solution (near a fold, where the linearisation points across
    /// it) or Newton lands farther from the prediction than a sweep's jump
    /// check allows: then it starts from the guess itself, so the walk stays
    /// on the branch a stepped-sine test would.
    pub fn solve_point<L: LinearPart, E: Element>(
        &mut self,
        linear: &L,
        elements: &mut E,
        frequency_hz: f64,
        force_amplitude: f64,
        guess: Option<&[Complex64]>,
    ) -> Result<HbPoint> {
        check_force(force_amplitude)?;
        check_frequency(0, frequency_hz)?;
        // a drive model among the elements (a shaker) is balanced exactly
        // through the linear part
        let linear = &Driven::of(linear, elements);
        let omega = 2.0 * std::f64::consts::PI * frequency_hz;
        self.core.set_frequency(linear, omega)?;
        let n = self.core.n;
        let mut first_failure = None;
        if let Some(g) = guess {
            let nh = self.core.opts.harmonics.len();
            if g.len() != nh {
                return Err(Error::input(
                    "hb guess",
                    format!("{} harmonics given, the set has {nh}", g.len()),
                ));
            }
            if g.iter().any(|z| !(z.re.is_finite() && z.im.is_finite())) {
                return Err(Error::input("hb guess", "must be finite"));
            }
            let mut x = vec![0.0; n];
            self.core.aft.layout.pack(g, &mut x);
            if self.predict_walk(linear, omega, force_amplitude, &x) {
                // from the prediction; kept if Newton stays near it
                let mut xp = self.walk.predicted.clone();
                let out = self
                    .core
                    .newton(elements, force_amplitude, &mut xp, &mut self.counters);
                let moved = continuation::distance(&xp, &self.walk.predicted)
                    / newton::norm(&xp).max(newton::norm(&self.walk.predicted));
                if out.converged && moved <= continuation::JUMP_CHECK {
                    self.hold_walk(omega, force_amplitude, &xp);
                    return Ok(self.point(frequency_hz, force_amplitude, &xp, &out));
                }
            }
            let out = self
                .core
                .newton(elements, force_amplitude, &mut x, &mut self.counters);
            if out.converged {
                self.hold_walk(omega, force_amplitude, &x);
                return Ok(self.point(frequency_hz, force_amplitude, &x, &out));
            }
            first_failure = Some(out);
        }
        self.walk.held = false;
        let (x, mut out) = self.cold_start(linear, elements, omega, force_amplitude, 0.0)?;
        if out.converged {
            self.hold_walk(omega, force_amplitude, &x);
        }
        if let (false, Some(f)) = (out.converged, first_failure) {
            out.failure = Some(format!(
                "from the guess: {}; from the describing function: {}",
                f.failure.unwrap_or_default(),
                out.failure.unwrap_or_default()
            ));
        }
        Ok(self.point(frequency_hz, force_amplitude, &x, &out))
    }

    /// Sweeps the frequencies in the given order (up, down, or any order),
    /// following the branch, reporting folds. See the module docs.
    pub fn sweep<L: LinearPart, E: Element>(
        &mut self,
        linear: &L,
        elements: &mut E,
        frequencies_hz: &[f64],
        force_amplitude: f64,
    ) -> Result<HbSweep> {
        check_force(force_amplitude)?;
        let linear = &Driven::of(linear, elements);
        for (i, &f) in frequencies_hz.iter().enumerate() {
            check_frequency(i, f)?;
            // the linear part must cover every harmonic of every point
            self.core
                .set_frequency(linear, 2.0 * std::f64::consts::PI * f)?;
        }
        let before = self.counters.residuals;
        let (points, folds) = self.run_sweep(linear, elements, frequencies_hz, force_amplitude)?;
        Ok(HbSweep {
            points,
            folds,
            evaluations: self.counters.residuals - before,
        })
    }

    /// Keeps the converged `x` at `omega` and the element's linearisation
    /// there (if the solve left it) for the next point of a walk.
    fn hold_walk(&mut self, omega: f64, force: f64, x: &[f64]) {
        let w = &mut self.walk;
        w.held = self.core.element_linearisation(&mut w.g, &mut w.dg);
        w.omega = omega;
        w.force = force;
        w.x.clear();
        w.x.extend_from_slice(x);
    }

    /// Whether the guess `x` continues a walk from the last converged point
    /// (the same displacements and force, another frequency) and the
    /// balance linearised there predicts a step within
    /// [`PREDICTION_TRUST`]; the prediction is then in `walk.predicted`.
    fn predict_walk<L: LinearPart>(
        &mut self,
        linear: &L,
        omega: f64,
        force: f64,
        x: &[f64],
    ) -> bool {
        let w = &mut self.walk;
        let same = w.x.len() == x.len()
            && continuation::distance(&w.x, x) <= SAME_SOLUTION * newton::norm(&w.x);
        if !(w.held && w.force == force && w.omega != omega && same) {
            return false;
        }
        w.predicted.resize(x.len(), 0.0);
        if !self.core.linearised_prediction(
            linear,
            omega,
            force,
            &w.x,
            &w.g,
            &w.dg,
            &mut w.predicted,
        ) {
            return false;
        }
        continuation::distance(&w.predicted, &w.x) <= PREDICTION_TRUST * newton::norm(&w.x)
    }

    fn point(&self, frequency_hz: f64, force: f64, x: &[f64], out: &newton::Outcome) -> HbPoint {
        let layout = &self.core.aft.layout;
        let (xs, hs) = if out.converged {
            let xs = layout.unpack(x);
            let hs = xs.iter().map(|z| z / force).collect();
            (xs, hs)
        } else {
            let nan = vec![Complex64::new(f64::NAN, f64::NAN); layout.harmonics.len()];
            (nan.clone(), nan)
        };
        HbPoint {
            frequency_hz,
            force_amplitude: force,
            harmonics: layout.harmonics.clone(),
            x: xs,
            h: hs,
            iterations: out.iterations,
            residual: out.residual,
            converged: out.converged,
            failure: out.failure.clone(),
        }
    }
}

fn check_force(f: f64) -> Result<()> {
    if f.is_finite() && f > 0.0 {
        Ok(())
    } else {
        Err(Error::plan(
            "hb.force_amplitude",
            format!("must be a finite number > 0 N, got {f}"),
        ))
    }
}

fn check_frequency(i: usize, f: f64) -> Result<()> {
    if f.is_finite() && f > 0.0 {
        Ok(())
    } else {
        Err(Error::plan(
            format!("hb.frequencies_hz[{i}]"),
            format!("must be a finite number > 0 Hz, got {f}"),
        ))
    }
}

// a solver can live in a worker thread (the fit stage keeps one per worker)
const _: fn() = || {
    fn send<T: Send>() {}
    send::<HbSolver>();
};

/// Solves at one frequency (a one-off [`HbSolver`]; see
/// [`HbSolver::solve_point`]).
pub fn solve_point<L: LinearPart, E: Element>(
    linear: &L,
    elements: &mut E,
    frequency_hz: f64,
    force_amplitude: f64,
    guess: Option<&[Complex64]>,
    opts: &HbOptions,
) -> Result<HbPoint> {
    HbSolver::new(opts)?.solve_point(linear, elements, frequency_hz, force_amplitude, guess)
}

/// Sweeps the frequencies in the given order at one force level (a one-off
/// [`HbSolver`]; see [`HbSolver::sweep`]).
pub fn sweep<L: LinearPart, E: Element>(
    linear: &L,
    elements: &mut E,
    frequencies_hz: &[f64],
    force_amplitude: f64,
    opts: &HbOptions,
) -> Result<HbSweep> {
    HbSolver::new(opts)?.sweep(linear, elements, frequencies_hz, force_amplitude)
}

/// Nonlinear FRFs over force levels × frequencies: one [`sweep`] per level
/// (each in the frequencies' order), in parallel over the levels with rayon.
/// The output is in level order and does not depend on the thread count.
pub fn frf_set<L, E>(
    linear: &L,
    elements: &E,
    levels: &[f64],
    frequencies_hz: &[f64],
    opts: &HbOptions,
) -> Result<Vec<HbSweep>>
where
    L: LinearPart + Sync,
    E: Element + Clone + Send + 'static,
{
    opts.validate()?;
    // each level gets its own element state (a Masing element is not Sync)
    let jobs: Vec<(f64, E)> = levels.iter().map(|&l| (l, elements.clone())).collect();
    jobs.into_par_iter()
        .map(|(level, mut e)| HbSolver::new(opts)?.sweep(linear, &mut e, frequencies_hz, level))
        .collect()
}

/// [`frf_set`] for a [`Model`]: its modes and its elements.
pub fn frf_set_for_model(
    model: &Model,
    levels: &[f64],
    frequencies_hz: &[f64],
    opts: &HbOptions,
) -> Result<Vec<HbSweep>> {
    model.validate()?;
    let elements = model.element_set()?;
    frf_set(&model.linear, &elements, levels, frequencies_hz, opts)
}
