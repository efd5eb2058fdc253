//! Optimisers over a [`super::FitProblem`] and the uncertainty of their result.
//!
//! * Nelder–Mead (argmin), as the paper's MATLAB `fminsearch`, in the
//!   problem's log coordinates with an explicit initial simplex.
//! * Levenberg–Marquardt (the MINPACK port in `levenberg-marquardt`), a
//!   second, derivative-based optimiser that must land at the same optimum.
//!   A problem of very many residuals (a time-domain fit of a long
//!   recording) can hand it its Jacobian folded into the R factor of
//!   `[r J]` instead ([`Objective::folds_jacobian`]): the trust-region step
//!   is the same least-squares problem, so the optimiser holds `(n+1)²`
//!   numbers where it held one row per residual.
//! * Confidence intervals from the Jacobian at the optimum and the measured
//!   noise: a sandwich covariance `A⁻¹ B A⁻¹` (`A = JᵀJ` of the residuals as
//!   fitted, `B` the same with each row scaled by its measured variance),
//!   inflated by the reduced `χ²` when the fit is worse than the noise.

use crate::error::{Error, Result};

/// What an optimiser minimises: residuals as functions of the optimiser
/// coordinates `θ`, the last row a penalty for the distance outside the
/// parameters' bounds (zero inside). The FRF fit ([`super::FitProblem`]) and the
/// time-domain fit ([`super::time::TimeProblem`]) are both one.
pub trait Objective: Sync {
    /// Residuals at `theta`, the penalty row last. A model the library
    /// rejects or cannot solve is a bad point here, not an error.
    fn residuals(&self, theta: &[f64]) -> Result<Vec<f64>>;
    /// `Σ r²` at `theta`.
    fn cost(&self, theta: &[f64]) -> Result<f64>;
    /// Evaluations so far.
    fn evaluations(&self) -> usize;
    /// The forward-difference Jacobian of the residuals at `theta` (whose
    /// residuals are `r0`), penalty row excluded, columns in parallel.
    fn jacobian(&self, theta: &[f64], r0: &[f64], step: f64) -> Result<DMatrix<f64>> {
        forward_difference(theta, r0, step, |t| self.residuals(t))
    }
    /// [`Objective::jacobian`] with the penalty row's derivative (zero
    /// inside the bounds) as its last row: what Levenberg–Marquardt takes.
    /// The default copies the Jacobian into one a row taller; a problem of
    /// many residuals (a time-domain fit of a long recording, where the
    /// Jacobian is the largest thing the fit holds) writes it there at once.
    fn jacobian_with_penalty_row(
        &self,
        theta: &[f64],
        r0: &[f64],
        step: f64,
    ) -> Result<DMatrix<f64>> {
        let j = self.jacobian(theta, r0, step)?;
        let m = j.nrows();
        let mut full = DMatrix::zeros(m + 1, j.ncols());
        full.rows_mut(0, m).copy_from(&j);
        Ok(full)
    }
    /// Whether Levenberg–Marquardt is to take this problem's Jacobian as
    /// [`Objective::jacobian_r_factor`] gives it, never whole: for a problem
    /// whose Jacobian would be the largest thing the fit holds.
    fn folds_jacobian(&self) -> bool {
        false
    }
    /// The upper-triangular `R` (`(n+1)×(n+1)`, `R₀₀ ≥ 0`) of the QR
    /// factorisation of `[r₀ J]`: the residuals at `theta` (penalty row
    /// included) beside their forward-difference Jacobian (whose penalty
    /// row is zero). `‖r₀ + J δ‖ = ‖R (1, δ)‖` for every `δ`, which is all a
    /// Gauss–Newton or Levenberg–Marquardt step needs of `J`, and `JᵀJ` is
    /// `R`'s last `n` columns' own. The default folds the whole Jacobian; a
    /// problem that can make its columns' rows a stretch at a time folds
    /// them as they come and never holds `J`.
    fn jacobian_r_factor(&self, theta: &[f64], r0: &[f64], step: f64) -> Result<DMatrix<f64>> {
        let j = self.jacobian_with_penalty_row(theta, r0, step)?;
        let mut fold = RowFold::new(theta.len() + 1);
        fold.fold(&DMatrix::from_fn(r0.len(), theta.len() + 1, |i, k| {
            if k == 0 { r0[i] } else { j[(i, k - 1)] }
        }));
        Ok(fold.finish())
    }
}

/// The R factor of a tall matrix whose rows come a block at a time: each
/// block is stacked under the R so far and factored again (Householder QR,
/// the tall-skinny QR's fold), so that only `k×k` numbers are held however
/// many rows there are. The rows' order changes `R` by rounding only.
pub struct RowFold {
    r: DMatrix<f64>,
}

impl RowFold {
    /// A fold of rows of `columns` entries.
    pub fn new(columns: usize) -> RowFold {
        RowFold {
            r: DMatrix::zeros(0, columns),
        }
    }

    /// Folds `rows` (as many columns as the fold) in.
    pub fn fold(&mut self, rows: &DMatrix<f64>) {
        if rows.nrows() == 0 {
            return;
        }
        let (held, k) = self.r.shape();
        let mut stacked = DMatrix::zeros(held + rows.nrows(), k);
        stacked.rows_mut(0, held).copy_from(&self.r);
        stacked.rows_mut(held, rows.nrows()).copy_from(rows);
        // `R` of the stacked rows: `min(rows, k) × k`
        self.r = stacked.qr().r();
    }

    /// The `k×k` upper-triangular factor (zero rows below the rows folded,
    /// if fewer than `k`), its first row turned so that `R₀₀ ≥ 0`.
    pub fn finish(self) -> DMatrix<f64> {
        let k = self.r.ncols();
        let mut r = DMatrix::zeros(k, k);
        let held = self.r.nrows().min(k);
        r.rows_mut(0, held).copy_from(&self.r.rows(0, held));
        if k > 0 && r[(0, 0)] < 0.0 {
            r.row_mut(0).neg_mut();
        }
        r
    }
}

use nalgebra::{DMatrix, DVector, Dyn, Owned};
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

/// Which optimiser.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Optimiser {
    /// Nelder–Mead simplex (argmin).
    #[default]
    NelderMead,
    /// Levenberg–Marquardt with a finite-difference Jacobian.
    LevenbergMarquardt,
}

impl Optimiser {
    /// The method's name as the literature writes it, for titles.
    pub fn title(self) -> &'static str {
        match self {
            Optimiser::NelderMead => "Nelder-Mead",
            Optimiser::LevenbergMarquardt => "Levenberg-Marquardt",
        }
    }
}

/// How a fit (or one optimiser run) ended, from the optimiser's own
/// termination type, never from its message text.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum FitStatus {
    /// The optimiser met its tolerance (or its target cost), and for a whole
    /// fit the model solved at every point at the optimum.
    Converged,
    /// The optimiser ran out of iterations (or evaluations); the result is
    /// its best point so far.
    IterationLimit,
    /// The optimiser stopped for another reason (interrupted, timed out, or
    /// the solver gave up, e.g. on non-finite residuals).
    Stopped,
    /// Harmonic balance did not converge at some model points at the
    /// optimum, whatever the optimiser's own status (the fit's notes say how
    /// many): those points are missing from the fit's error.
    ModelNotConverged,
    /// A start racing others of the same fit, given up: after the
    /// evaluations its [`Race`] allowed it had not come below the cost
    /// another start had already reached (the result is its best point).
    Abandoned,
    /// Not recorded: a result written before the status was.
    #[default]
    Unknown,
}

impl FitStatus {
    /// The status of an argmin run.
    pub fn of_argmin(status: &argmin::core::TerminationStatus) -> Self {
        use argmin::core::{TerminationReason as R, TerminationStatus as S};
        match status {
            S::Terminated(R::SolverConverged | R::TargetCostReached) => FitStatus::Converged,
            S::Terminated(R::MaxItersReached) => FitStatus::IterationLimit,
            S::Terminated(R::Interrupt | R::Timeout | R::SolverExit(_)) | S::NotTerminated => {
                FitStatus::Stopped
            }
        }
    }

    /// The status of a Levenberg–Marquardt run.
    pub fn of_levenberg_marquardt(reason: &levenberg_marquardt::TerminationReason) -> Self {
        if reason.was_successful() {
            FitStatus::Converged
        } else if matches!(reason, levenberg_marquardt::TerminationReason::LostPatience) {
            FitStatus::IterationLimit
        } else {
            FitStatus::Stopped
        }
    }
}

/// What an optimiser run ended with.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct OptimiserRun {
    /// Which optimiser.
    pub method: Optimiser,
    /// Optimiser coordinates at the optimum.
    pub theta: Vec<f64>,
    /// Cost at the optimum.
    pub cost: f64,
    /// Iterations.
    pub iterations: u64,
    /// Cost (or residual) evaluations.
    pub evaluations: usize,
    /// Why it stopped.
    pub termination: String,
    /// Whether that is a convergence (`status` is `converged`).
    pub converged: bool,
    /// How it ended.
    #[serde(default)]
    pub status: FitStatus,
}

/// The objective as argmin sees it. The first error (a cancelled fit, say)
/// is kept and returned once the solver stops: argmin's Nelder–Mead unwraps
/// the costs of its first simplex, so there the error is reported to it as
/// an infinite cost, and afterwards as the error that ends its run.
struct Cost<'a, P: ?Sized> {
    problem: &'a P,
    /// Costs argmin evaluates before it can take an error (the first
    /// simplex's vertices).
    unchecked: usize,
    calls: std::sync::atomic::AtomicUsize,
    failure: &'a std::sync::Mutex<Option<Error>>,
}

impl<P: Objective + ?Sized> argmin::core::CostFunction for Cost<'_, P> {
    type Param = DVector<f64>;
    type Output = f64;
    fn cost(&self, p: &Self::Param) -> std::result::Result<f64, argmin::core::Error> {
        let call = self
            .calls
            .fetch_add(1, std::sync::atomic::Ordering::Relaxed);
        match self.problem.cost(p.as_slice()) {
            Ok(c) => Ok(c),
            Err(e) => {
                let message = e.to_string();
                self.failure.lock().expect("failure lock").get_or_insert(e);
                if call < self.unchecked {
                    Ok(f64::INFINITY)
                } else {
                    Err(argmin::core::Error::msg(message))
                }
            }
        }
    }
}

/// Nelder–Mead from `theta0` with an initial simplex of `step` along each
/// coordinate, until the simplex's cost spread falls below `rel_tol` of the
/// initial cost or `max_iters` iterations.
pub fn nelder_mead<P: Objective + ?Sized>(
    problem: &P,
    theta0: &[f64],
    step: &[f64],
    max_iters: u64,
    rel_tol: f64,
) -> Result<OptimiserRun> {
    use argmin::core::{Executor, State};
    use argmin::solver::neldermead::NelderMead;
    let n = theta0.len();
    let start = problem.evaluations();
    let c0 = problem.cost(theta0)?;
    let mut simplex = vec![DVector::from_column_slice(theta0)];
    for i in 0..n {
        let mut v = DVector::from_column_slice(theta0);
        v[i] += step[i];
        simplex.push(v);
    }
    let solver = NelderMead::new(simplex)
        .with_sd_tolerance(rel_tol * c0.max(f64::MIN_POSITIVE))
        .map_err(|e| Error::plan("nelder_mead", e.to_string()))?;
    let failure = std::sync::Mutex::new(None);
    let cost = Cost {
        problem,
        unchecked: n + 1,
        calls: Default::default(),
        failure: &failure,
    };
    let res = Executor::new(cost, solver)
        .configure(|s| s.max_iters(max_iters))
        .run();
    if let Some(e) = failure.lock().expect("failure lock").take() {
        return Err(e);
    }
    let res = res.map_err(|e| Error::NotConverged {
        stage: "Nelder-Mead",
        reason: e.to_string(),
    })?;
    let state = res.state();
    let theta = state
        .get_best_param()
        .map(|p| p.as_slice().to_vec())
        .ok_or(Error::NotConverged {
            stage: "Nelder-Mead",
            reason: "no best point".into(),
        })?;
    let reason = state
        .get_termination_reason()
        .map(|r| r.text().to_string())
        .unwrap_or_default();
    let status = FitStatus::of_argmin(state.get_termination_status());
    Ok(OptimiserRun {
        method: Optimiser::NelderMead,
        cost: state.get_best_cost(),
        iterations: state.get_iter(),
        evaluations: problem.evaluations() - start,
        converged: status == FitStatus::Converged,
        status,
        termination: reason,
        theta,
    })
}

/// Forward-difference Jacobian of the residuals (penalty row excluded),
/// columns computed in parallel: `problem`'s own (see
/// [`Objective::jacobian`]).
pub fn jacobian<P: Objective + ?Sized>(
    problem: &P,
    theta: &[f64],
    r0: &[f64],
    step: f64,
) -> Result<DMatrix<f64>> {
    problem.jacobian(theta, r0, step)
}

/// Forward differences of `residuals` at `theta` (whose residuals are
/// `r0`), penalty row excluded, columns computed in parallel.
pub fn forward_difference(
    theta: &[f64],
    r0: &[f64],
    step: f64,
    residuals: impl Fn(&[f64]) -> Result<Vec<f64>> + Sync,
) -> Result<DMatrix<f64>> {
    forward_difference_padded(theta, r0, step, 0, residuals)
}

/// [`forward_difference`] with `pad` rows of zeros below the columns
/// (Levenberg–Marquardt's penalty row: see
/// [`Objective::jacobian_with_penalty_row`]). Each column is written into
/// the matrix as its residuals come (the matrix is column-major), so the
/// Jacobian is held once, not once as columns and again as a matrix.
pub fn forward_difference_padded(
    theta: &[f64],
    r0: &[f64],
    step: f64,
    pad: usize,
    residuals: impl Fn(&[f64]) -> Result<Vec<f64>> + Sync,
) -> Result<DMatrix<f64>> {
    let m = r0.len() - 1;
    by_columns(m + pad, theta, step, |t, column| {
        let r = residuals(t)?;
        for ((d, a), b) in column[..m].iter_mut().zip(&r[..m]).zip(&r0[..m]) {
            *d = (a - b) / step;
        }
        Ok(())
    })
}

/// [`forward_difference_padded`] with one row of padding, each column's
/// residuals written by `residuals_into` straight into the column (as many
/// rows as `r0`, the penalty row last) and differenced there: the Jacobian
/// is then all a column costs (the residual vector of each column in flight
/// was another column). The same bits as the padded one.
pub fn forward_difference_in_place(
    theta: &[f64],
    r0: &[f64],
    step: f64,
    residuals_into: impl Fn(&[f64], &mut [f64]) -> Result<()> + Sync,
) -> Result<DMatrix<f64>> {
    let m = r0.len() - 1;
    by_columns(r0.len(), theta, step, |t, column| {
        residuals_into(t, column)?;
        for (d, b) in column[..m].iter_mut().zip(&r0[..m]) {
            *d = (*d - b) / step;
        }
        // the penalty row's derivative: zero inside the bounds
        column[m] = 0.0;
        Ok(())
    })
}

/// A matrix of `rows` rows, column `j` written by `column(θ + step e_j,
/// column)` (zeros given), the columns in parallel; every column computed,
/// the first error by column returned (as the columns' order, not the
/// threads', decides).
fn by_columns(
    rows: usize,
    theta: &[f64],
    step: f64,
    column: impl Fn(&[f64], &mut [f64]) -> Result<()> + Sync,
) -> Result<DMatrix<f64>> {
    let mut jac = DMatrix::zeros(rows, theta.len());
    if rows == 0 {
        return Ok(jac);
    }
    let done: Vec<Result<()>> = jac
        .as_mut_slice()
        .par_chunks_mut(rows)
        .enumerate()
        .map(|(j, c)| {
            let mut t = theta.to_vec();
            t[j] += step;
            column(&t, c)
        })
        .collect();
    done.into_iter().collect::<Result<()>>()?;
    Ok(jac)
}

/// A start racing another of the same fit that has already ended: it is
/// given up once it has made `after` residual evaluations without coming
/// below `cost_to_beat` (the other's cost). A start that needs far more work
/// than the winner to catch up with it costs the most and changes nothing.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Race {
    /// Residual evaluations allowed before it must be winning.
    pub after: usize,
    /// The cost it must be below by then.
    pub cost_to_beat: f64,
}

struct Lm<'a, P: ?Sized> {
    problem: &'a P,
    theta: DVector<f64>,
    residuals: std::cell::RefCell<Option<(DVector<f64>, Vec<f64>)>>,
    error: std::cell::RefCell<Option<Error>>,
    race: Option<Race>,
    /// Residual evaluations made (cached ones not counted).
    calls: std::cell::Cell<usize>,
    /// The lowest cost evaluated and where.
    best: std::cell::RefCell<Option<(f64, DVector<f64>)>>,
    abandoned: std::cell::Cell<bool>,
}

impl<P: Objective + ?Sized> Lm<'_, P> {
    fn current(&self) -> Option<Vec<f64>> {
        if let Some((t, r)) = self.residuals.borrow().as_ref()
            && *t == self.theta
        {
            return Some(r.clone());
        }
        if let Some(race) = self.race
            && self.calls.get() >= race.after
            && self
                .best
                .borrow()
                .as_ref()
                .is_some_and(|(c, _)| *c >= race.cost_to_beat)
        {
            self.abandoned.set(true);
            return None;
        }
        self.calls.set(self.calls.get() + 1);
        match self.problem.residuals(self.theta.as_slice()) {
            Ok(r) => {
                let cost = r.iter().map(|v| v * v).sum::<f64>();
                let mut best = self.best.borrow_mut();
                if best.as_ref().is_none_or(|(c, _)| cost < *c) {
                    *best = Some((cost, self.theta.clone()));
                }
                *self.residuals.borrow_mut() = Some((self.theta.clone(), r.clone()));
                Some(r)
            }
            Err(e) => {
                *self.error.borrow_mut() = Some(e);
                None
            }
        }
    }
}

impl<P: Objective + ?Sized> levenberg_marquardt::LeastSquaresProblem<f64, Dyn, Dyn> for Lm<'_, P> {
    type ResidualStorage = Owned<f64, Dyn>;
    type JacobianStorage = Owned<f64, Dyn, Dyn>;
    type ParameterStorage = Owned<f64, Dyn>;

    fn set_params(&mut self, x: &DVector<f64>) {
        self.theta.copy_from(x);
    }
    fn params(&self) -> DVector<f64> {
        self.theta.clone()
    }
    fn residuals(&self) -> Option<DVector<f64>> {
        let r = self.current()?;
        if self.problem.folds_jacobian() {
            // the residuals in the frame of `[r J]`'s QR: `(‖r‖, 0, …, 0)`,
            // whose norm is the trial's and whose Jacobian is `R`'s last
            // columns (see `Objective::jacobian_r_factor`)
            let mut folded = DVector::zeros(self.theta.len() + 1);
            folded[0] = r.iter().map(|v| v * v).sum::<f64>().sqrt();
            return Some(folded);
        }
        Some(DVector::from_vec(r))
    }
    fn jacobian(&self) -> Option<DMatrix<f64>> {
        let r = self.current()?;
        let theta = self.theta.as_slice();
        // the penalty row's derivative: zero inside the bounds
        let jacobian = if self.problem.folds_jacobian() {
            self.problem
                .jacobian_r_factor(theta, &r, 1e-6)
                .map(|rf| rf.columns(1, theta.len()).into_owned())
        } else {
            self.problem.jacobian_with_penalty_row(theta, &r, 1e-6)
        };
        match jacobian {
            Ok(j) => Some(j),
            Err(e) => {
                *self.error.borrow_mut() = Some(e);
                None
            }
        }
    }
}

/// Levenberg–Marquardt from `theta0`, at most `patience·(n+1)` residual
/// evaluations, to the crate's tolerance (30 machine epsilons: it mostly
/// stops on its patience).
pub fn levenberg_marquardt<P: Objective + ?Sized>(
    problem: &P,
    theta0: &[f64],
    patience: usize,
) -> Result<OptimiserRun> {
    levenberg_marquardt_to(problem, theta0, patience, 30.0 * f64::EPSILON)
}

/// [`levenberg_marquardt`] stopping where a step changes the sum of squares
/// or the (scaled) parameters by less than `tolerance`, relative (MINPACK's
/// `ftol` and `xtol`; MINPACK's default is 1.49e-8).
pub fn levenberg_marquardt_to<P: Objective + ?Sized>(
    problem: &P,
    theta0: &[f64],
    patience: usize,
    tolerance: f64,
) -> Result<OptimiserRun> {
    levenberg_marquardt_racing(problem, theta0, patience, tolerance, None)
}

/// [`levenberg_marquardt_to`] in a [`Race`]: a run given up ends with
/// [`FitStatus::Abandoned`] at the best point it evaluated.
pub fn levenberg_marquardt_racing<P: Objective + ?Sized>(
    problem: &P,
    theta0: &[f64],
    patience: usize,
    tolerance: f64,
    race: Option<Race>,
) -> Result<OptimiserRun> {
    let start = problem.evaluations();
    let lm = Lm {
        problem,
        theta: DVector::from_column_slice(theta0),
        residuals: Default::default(),
        error: Default::default(),
        race,
        calls: Default::default(),
        best: Default::default(),
        abandoned: Default::default(),
    };
    let (lm, report) = levenberg_marquardt::LevenbergMarquardt::new()
        .with_patience(patience)
        .with_ftol(tolerance)
        .with_xtol(tolerance)
        .minimize(lm);
    if let Some(e) = lm.error.into_inner() {
        return Err(e);
    }
    if lm.abandoned.get() {
        let calls = lm.calls.get();
        let (cost, theta) = lm.best.into_inner().expect("abandoned after evaluations");
        return Ok(OptimiserRun {
            method: Optimiser::LevenbergMarquardt,
            theta: theta.as_slice().to_vec(),
            cost,
            iterations: calls as u64,
            evaluations: problem.evaluations() - start + calls,
            converged: false,
            status: FitStatus::Abandoned,
            termination: "abandoned: another start was ahead".into(),
        });
    }
    let theta = lm.theta.as_slice().to_vec();
    let cost = problem.cost(&theta)?;
    Ok(OptimiserRun {
        method: Optimiser::LevenbergMarquardt,
        theta,
        cost,
        iterations: report.number_of_evaluations as u64,
        evaluations: problem.evaluations() - start + report.number_of_evaluations,
        converged: report.termination.was_successful(),
        status: FitStatus::of_levenberg_marquardt(&report.termination),
        termination: format!("{:?}", report.termination),
    })
}

/// A Jacobian column below this fraction of the largest one is a parameter
/// the data do not feel.
const UNFELT: f64 = 1e-9;

/// Which columns of `jac` the data do not feel: below [`UNFELT`] of the
/// largest column not `excluded` (an exactly zero one: a damping driven to
/// 1e-18 beside a joint that gives all the damping, a step in it leaving
/// the prediction the same to the bit). Such a column makes `JᵀJ` singular
/// and would leave every parameter without an interval.
pub fn unfelt_columns(jac: &DMatrix<f64>, excluded: &[bool]) -> Vec<bool> {
    let norms: Vec<f64> = jac.column_iter().map(|c| c.norm()).collect();
    unfelt_of_norms(&norms, excluded)
}

/// [`unfelt_columns`] of a Jacobian known by its columns' norms (one folded
/// into its R factor: see [`Objective::jacobian_r_factor`]).
pub fn unfelt_of_norms(norms: &[f64], excluded: &[bool]) -> Vec<bool> {
    let largest = (0..norms.len())
        .filter(|&j| !excluded[j])
        .map(|j| norms[j])
        .fold(0.0, f64::max);
    (0..norms.len())
        .map(|j| {
            // a NaN column is not felt either
            let felt = norms[j] > UNFELT * largest;
            !excluded[j] && !felt
        })
        .collect()
}

/// Covariance of the optimiser coordinates at `theta` (free parameters
/// only: `fixed[j]` excludes parameter `j`, e.g. one sitting at a bound;
/// a column the data do not feel, [`unfelt_columns`], is left out too, its
/// row and column NaN).
///
/// `variances[i]` is the measurement variance of residual row `i` as fitted
/// (1 for rows already scaled by their standard error). Returns the
/// covariance and the reduced `χ²` used to inflate it.
pub fn covariance(
    jac: &DMatrix<f64>,
    variances: &[f64],
    residual_chi2: f64,
    fixed: &[bool],
) -> Option<(DMatrix<f64>, f64)> {
    let unfelt = unfelt_columns(jac, fixed);
    let free: Vec<usize> = (0..jac.ncols())
        .filter(|&j| !fixed[j] && !unfelt[j])
        .collect();
    let m = jac.nrows();
    let jf = DMatrix::from_fn(m, free.len(), |i, k| jac[(i, free[k])]);
    let a = jf.transpose() * &jf;
    let mut b = DMatrix::zeros(free.len(), free.len());
    for i in 0..m {
        let row = jf.row(i);
        b += row.transpose() * row * variances[i];
    }
    let ainv = a.try_inverse()?;
    let dof = (m as f64 - free.len() as f64).max(1.0);
    let reduced = residual_chi2 / dof;
    let cov_free = &ainv * b * &ainv * reduced.max(1.0);
    let mut cov = DMatrix::from_element(jac.ncols(), jac.ncols(), f64::NAN);
    for (a_, &i) in free.iter().enumerate() {
        for (b_, &j) in free.iter().enumerate() {
            cov[(i, j)] = cov_free[(a_, b_)];
        }
    }
    Some((cov, reduced))
}

#[cfg(test)]
mod tests {
    use super::FitStatus;
    use argmin::core::{TerminationReason as R, TerminationStatus as S};

    /// The Jacobian written in place is the padded one to the bit: the
    /// residuals of a smooth function of three parameters (many rows, the
    /// penalty row last), differenced against those at the point, the
    /// penalty row zero; and against the closed-form derivative to the
    /// forward difference's order.
    #[test]
    fn a_jacobian_written_in_place_is_the_padded_one() {
        let rows = 1001;
        let f = |t: &[f64]| -> Vec<f64> {
            let mut r: Vec<f64> = (0..rows)
                .map(|i| {
                    let x = i as f64 / rows as f64;
                    t[0] * (t[1] * x).sin() + t[2] * x * x
                })
                .collect();
            r.push(t.iter().sum());
            r
        };
        let theta = [1.5, 2.0, -0.7];
        let r0 = f(&theta);
        let step = 1e-7;
        let padded = super::forward_difference_padded(&theta, &r0, step, 1, |t| Ok(f(t))).unwrap();
        let in_place = super::forward_difference_in_place(&theta, &r0, step, |t, out| {
            out.copy_from_slice(&f(t));
            Ok(())
        })
        .unwrap();
        assert_eq!(padded.shape(), (rows + 1, 3));
        assert!(
            padded
                .iter()
                .zip(in_place.iter())
                .all(|(a, b)| a.to_bits() == b.to_bits())
        );
        assert!(in_place.row(rows).iter().all(|&v| v == 0.0));
        let x = 0.5;
        let i = rows / 2;
        let x_i = i as f64 / rows as f64;
        assert!((x - x_i).abs() < 1e-3);
        let want = [(2.0 * x_i).sin(), 1.5 * x_i * (2.0 * x_i).cos(), x_i * x_i];
        for (k, w) in want.iter().enumerate() {
            assert!((in_place[(i, k)] - w).abs() < 1e-6, "column {k}");
        }
    }

    /// The status comes from the termination's type; fit.json spells it in
    /// snake case.
    #[test]
    fn fit_status_follows_the_termination_type() {
        let of = |r: R| FitStatus::of_argmin(&S::Terminated(r));
        assert_eq!(of(R::SolverConverged), FitStatus::Converged);
        assert_eq!(of(R::MaxItersReached), FitStatus::IterationLimit);
        assert_eq!(of(R::SolverExit("maximum".into())), FitStatus::Stopped);
        assert_eq!(
            FitStatus::of_levenberg_marquardt(
                &levenberg_marquardt::TerminationReason::LostPatience
            ),
            FitStatus::IterationLimit
        );
        assert_eq!(
            serde_json::to_string(&FitStatus::IterationLimit).unwrap(),
            "\"iteration_limit\""
        );
    }

    /// A column the data do not feel (exactly zero: a step in its parameter
    /// leaves the prediction the same to the bit) is left out of the
    /// covariance, which the others then have (with it, `JᵀJ` is singular
    /// and every interval was lost); a parameter at a bound stays out too.
    #[test]
    fn an_unfelt_column_is_left_out_of_the_covariance() {
        let jac = nalgebra::DMatrix::from_row_slice(
            4,
            4,
            &[
                1.0, 0.0, 0.5, 3.0, //
                0.0, 0.0, 1.0, 1.0, //
                2.0, 1e-12, 0.0, 0.0, //
                1.0, 0.0, 1.0, 2.0,
            ],
        );
        let fixed = [false, false, false, true];
        assert_eq!(
            super::unfelt_columns(&jac, &fixed),
            vec![false, true, false, false]
        );
        let (cov, reduced) = super::covariance(&jac, &[1.0; 4], 2.0, &fixed).expect("invertible");
        // dof = 4 rows − 2 free columns: the reduced χ² 1 leaves s² = 1
        assert_eq!(reduced, 1.0);
        // the two felt free columns' (JᵀJ)⁻¹ (variances 1: the sandwich
        // is the plain inverse), by hand: JᵀJ = [[6, 1.5], [1.5, 2.25]]
        let det = 6.0 * 2.25 - 1.5 * 1.5;
        for ((i, j), want) in [
            ((0, 0), 2.25 / det),
            ((0, 2), -1.5 / det),
            ((2, 2), 6.0 / det),
        ] {
            assert!(
                (cov[(i, j)] - want).abs() < 1e-12,
                "({i}, {j}): {}",
                cov[(i, j)]
            );
        }
        assert!(cov[(1, 1)].is_nan() && cov[(3, 3)].is_nan() && cov[(0, 1)].is_nan());
    }

    /// A quadratic bowl that fails from its `fail_at`-th cost on.
    struct Failing {
        fail_at: usize,
        calls: std::sync::atomic::AtomicUsize,
    }

    impl super::Objective for Failing {
        fn residuals(&self, theta: &[f64]) -> crate::Result<Vec<f64>> {
            let call = self
                .calls
                .fetch_add(1, std::sync::atomic::Ordering::Relaxed)
                + 1;
            if call >= self.fail_at {
                return Err(crate::Error::Cancelled);
            }
            Ok(theta.iter().map(|t| t - 1.0).collect())
        }
        fn cost(&self, theta: &[f64]) -> crate::Result<f64> {
            Ok(self.residuals(theta)?.iter().map(|r| r * r).sum())
        }
        fn evaluations(&self) -> usize {
            self.calls.load(std::sync::atomic::Ordering::Relaxed)
        }
    }

    /// A cost that fails inside Nelder–Mead's first simplex (which argmin
    /// would unwrap) or later ends the run with that error, never a panic;
    /// one that never fails finds the bowl's bottom.
    #[test]
    fn a_failing_cost_ends_nelder_mead_with_its_error() {
        for fail_at in [3, 40] {
            let p = Failing {
                fail_at,
                calls: Default::default(),
            };
            let r = super::nelder_mead(&p, &[0.0; 3], &[0.5; 3], 500, 1e-12);
            assert!(
                matches!(r, Err(crate::Error::Cancelled)),
                "{fail_at}: {r:?}"
            );
        }
        let p = Failing {
            fail_at: usize::MAX,
            calls: Default::default(),
        };
        let r = super::nelder_mead(&p, &[0.0; 3], &[0.5; 3], 500, 1e-12).unwrap();
        assert!(
            r.theta.iter().all(|t| (t - 1.0).abs() < 1e-3),
            "{:?}",
            r.theta
        );
    }

    /// Rosenbrock's valley as residuals, above a floor: `Σ r²` is 0.01 at
    /// (1, 1), its least.
    struct Valley(std::sync::atomic::AtomicUsize);

    impl super::Objective for Valley {
        fn residuals(&self, t: &[f64]) -> crate::Result<Vec<f64>> {
            self.0.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
            // the last row is the penalty row, which the Jacobian leaves out
            Ok(vec![10.0 * (t[1] - t[0] * t[0]), 1.0 - t[0], 0.1, 0.0])
        }
        fn cost(&self, t: &[f64]) -> crate::Result<f64> {
            Ok(self.residuals(t)?.iter().map(|r| r * r).sum())
        }
        fn evaluations(&self) -> usize {
            self.0.load(std::sync::atomic::Ordering::Relaxed)
        }
    }

    /// Rosenbrock's valley with its Jacobian folded into the R factor of
    /// `[r J]` (the default fold of the whole Jacobian).
    struct FoldedValley(Valley);

    impl super::Objective for FoldedValley {
        fn residuals(&self, t: &[f64]) -> crate::Result<Vec<f64>> {
            self.0.residuals(t)
        }
        fn cost(&self, t: &[f64]) -> crate::Result<f64> {
            self.0.cost(t)
        }
        fn evaluations(&self) -> usize {
            self.0.evaluations()
        }
        fn folds_jacobian(&self) -> bool {
            true
        }
    }

    /// The R factor folded a block of rows at a time is the whole matrix's
    /// (`RᵀR = AᵀA` to rounding, upper triangular, `R₀₀ ≥ 0`, a short
    /// matrix padded with zero rows), and Levenberg–Marquardt on a folded
    /// Jacobian walks Rosenbrock's valley to the optimum the whole one
    /// reaches, in the same evaluations.
    #[test]
    fn a_jacobian_folded_into_its_r_factor_reaches_the_same_optimum() {
        use super::{Objective, RowFold, levenberg_marquardt_to};
        let a = nalgebra::DMatrix::from_fn(1_000, 4, |i, j| {
            ((i * 3 + j * 11) as f64 * 0.731).cos() + if i == j { 2.0 } else { 0.0 }
        });
        for block in [1, 7, 1_000] {
            let mut fold = RowFold::new(4);
            for start in (0..1_000).step_by(block) {
                let rows = block.min(1_000 - start);
                fold.fold(&a.rows(start, rows).into_owned());
            }
            let r = fold.finish();
            assert!(r[(0, 0)] >= 0.0 && (0..4).all(|i| (0..i).all(|k| r[(i, k)] == 0.0)));
            let worst = (r.tr_mul(&r) - a.tr_mul(&a)).amax();
            assert!(worst < 1e-12 * a.tr_mul(&a).amax(), "{block}: {worst:e}");
        }
        let mut short = RowFold::new(3);
        short.fold(&nalgebra::DMatrix::from_row_slice(1, 3, &[-3.0, 4.0, 0.0]));
        assert_eq!(
            short.finish(),
            nalgebra::DMatrix::from_row_slice(
                3,
                3,
                &[3.0, -4.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0]
            )
        );
        let start = [-1.2, 1.0];
        let whole =
            levenberg_marquardt_to(&Valley(Default::default()), &start, 100, 1e-12).unwrap();
        let folded = FoldedValley(Valley(Default::default()));
        assert!(folded.folds_jacobian());
        let run = levenberg_marquardt_to(&folded, &start, 100, 1e-12).unwrap();
        assert_eq!(run.status, whole.status);
        assert_eq!(run.iterations, whole.iterations);
        for (a, b) in run.theta.iter().zip(&whole.theta) {
            assert!(
                (a - b).abs() < 1e-9,
                "{:?} against {:?}",
                run.theta,
                whole.theta
            );
        }
        assert!((run.cost - 0.01).abs() < 1e-10);
    }

    /// A start racing one that reached a cost it cannot reach is given up
    /// after the evaluations it was allowed, at the best point it
    /// evaluated; one already below the cost to beat runs as if alone.
    #[test]
    fn a_start_that_cannot_catch_up_is_abandoned_at_its_best_point() {
        use super::{FitStatus, Objective, Race, levenberg_marquardt_racing};
        let start = [-1.2, 1.0];
        let alone =
            levenberg_marquardt_racing(&Valley(Default::default()), &start, 100, 1e-12, None)
                .unwrap();
        assert_eq!(alone.status, FitStatus::Converged);
        assert!((alone.theta[0] - 1.0).abs() < 1e-6 && (alone.cost - 0.01).abs() < 1e-10);
        // Rosenbrock's valley takes LM more than five evaluations
        assert!(alone.iterations > 10, "{}", alone.iterations);

        let v = Valley(Default::default());
        let unreachable = Race {
            after: 5,
            cost_to_beat: 0.005,
        };
        let given_up =
            levenberg_marquardt_racing(&v, &start, 100, 1e-12, Some(unreachable)).unwrap();
        assert_eq!(given_up.status, FitStatus::Abandoned);
        assert!(!given_up.converged);
        assert_eq!(given_up.iterations, 5);
        // its cost is that of the point it returns, below the start's
        assert_eq!(given_up.cost, v.cost(&given_up.theta).unwrap());
        assert!(given_up.cost < v.cost(&start).unwrap());

        let ahead = Race {
            after: 5,
            cost_to_beat: 1e9,
        };
        let unhindered = levenberg_marquardt_racing(
            &Valley(Default::default()),
            &start,
            100,
            1e-12,
            Some(ahead),
        )
        .unwrap();
        assert_eq!(unhindered.theta, alone.theta);
        assert_eq!(unhindered.status, FitStatus::Converged);
    }
}
