//! The harmonic-balance residual and its damped Newton solve.
//!
//! Per harmonic `h` of the set, the paper's eq. (8) `Z_h X_h + G_h − F δ_{h1}
//! = 0` with `Z_h = 1/H(hω)` is solved in the receptance form
//!
//! ```text
//! R_h = X_h − H(hω) (F δ_{h1} − G_h(X)) = 0
//! ```
//!
//! (the same equation multiplied by `H(hω)`). Why this form: every row is a
//! displacement, so the Jacobian `I + H ∂G/∂X` is the identity plus the
//! element's effect and stays well scaled across harmonics (the impedance
//! form mixes `|Z_5| ≈ 6e8 N/m` rows with near-zero `|Z_1|` rows at
//! resonance), and no `1/H` is formed, so a tabulated or multi-mode
//! receptance with near-zeros (antiresonances) is harmless.
//!
//! Convergence: `‖R‖₂/‖X‖₂ ≤ tolerance` — the relative misfit of the
//! displacement harmonics. Newton steps use the analytic Jacobian
//! ([`crate::model::Element::commit_sensitivity`] through the AFT march) with
//! an Armijo backtracking line search on `‖R‖`. The Jacobian is kept while a
//! step contracts the residual at least tenfold (modified Newton: a march
//! without sensitivities costs ~60 % of one with them) and refreshed
//! otherwise, or when a kept one stops giving descent. If the line search
//! fails with a fresh analytic Jacobian, the point switches to forward
//! differences before giving up.

use super::aft::{Aft, EvalError};
use super::linear::LinearPart;
use super::{HbOptions, JacobianMethod};
use crate::model::Element;
use num_complex::Complex64;

/// Why a Newton solve stopped without converging; its text becomes the
/// point's `failure`.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub(crate) enum SolveFailure {
    /// The residual could not be evaluated at the starting point.
    #[error("at the starting point: {0}")]
    AtStart(EvalError),
    /// The relative residual became NaN or infinite.
    #[error("the residual is not finite")]
    NonFiniteResidual,
    /// The iteration limit was reached.
    #[error(
        "no convergence in {iterations} Newton iterations (relative residual {residual:.3e} > {tolerance:.1e})"
    )]
    StepLimit {
        /// Iterations made (the limit).
        iterations: usize,
        /// Relative residual reached.
        residual: f64,
        /// Relative residual required.
        tolerance: f64,
    },
    /// The Jacobian could not be factored.
    #[error("singular Jacobian")]
    SingularJacobian,
    /// No step length along the Newton direction decreased the residual,
    /// with a fresh Jacobian and with finite differences.
    #[error(
        "line search found no decrease of the residual along the Newton step (relative residual {residual:.3e})"
    )]
    LineSearch {
        /// Relative residual where the search failed.
        residual: f64,
    },
    /// The residual could not be evaluated during the iteration.
    #[error("{0}")]
    Evaluation(EvalError),
}

/// The result of one Newton solve.
#[derive(Clone, Debug)]
pub(crate) struct Outcome {
    pub converged: bool,
    pub iterations: usize,
    pub residual: f64,
    pub failure: Option<String>,
}

/// The solver's reusable state: AFT workspace and Newton buffers.
pub(crate) struct Core {
    pub aft: Aft,
    pub opts: HbOptions,
    /// Real unknowns.
    pub n: usize,
    /// `H(hω)` for each harmonic at `omega`.
    hs: Vec<Complex64>,
    /// `D(ω)`: how the drive reaches the structure (1 without a drive model,
    /// see [`LinearPart::drive`]).
    drive: Complex64,
    omega: f64,
    g: Vec<f64>,
    dg: Vec<f64>,
    r: Vec<f64>,
    jac: Vec<f64>,
    lu: Vec<f64>,
    piv: Vec<usize>,
    step: Vec<f64>,
    xt: Vec<f64>,
    rt: Vec<f64>,
    jact: Vec<f64>,
    xfd: Vec<f64>,
    rfd: Vec<f64>,
    /// Whether `jac`, `g` and `r` are those of the last converged point.
    at_solution: bool,
    /// Take one Newton step even from a start already within the
    /// tolerance (see [`Core::newton`]).
    pub step_at_least_once: bool,
}

/// Counts expensive evaluations (for reports and benches).
#[derive(Clone, Copy, Debug, Default)]
pub(crate) struct Counters {
    pub residuals: u64,
    pub jacobians: u64,
}

impl Core {
    pub fn new(opts: &HbOptions) -> Core {
        let aft = Aft::new(&opts.harmonics, opts.samples_per_period);
        let n = aft.layout.len;
        Core {
            aft,
            opts: opts.clone(),
            n,
            hs: vec![Complex64::new(0.0, 0.0); opts.harmonics.len()],
            drive: Complex64::new(1.0, 0.0),
            omega: f64::NAN,
            g: vec![0.0; n],
            dg: vec![0.0; n * n],
            r: vec![0.0; n],
            jac: vec![0.0; n * n],
            lu: vec![0.0; n * n],
            piv: vec![0; n],
            step: vec![0.0; n],
            xt: vec![0.0; n],
            rt: vec![0.0; n],
            jact: vec![0.0; n * n],
            xfd: vec![0.0; n],
            rfd: vec![0.0; n],
            at_solution: false,
            step_at_least_once: false,
        }
    }

    /// Sets the frequency: evaluates `H(hω)` for every harmonic.
    pub fn set_frequency<L: LinearPart>(&mut self, linear: &L, omega: f64) -> crate::Result<()> {
        let drive = linear.drive(omega);
        if omega == self.omega && drive == self.drive {
            return Ok(());
        }
        self.at_solution = false;
        self.drive = drive;
        for (i, &h) in self.aft.layout.harmonics.iter().enumerate() {
            let z = linear.receptance(h as f64 * omega).map_err(|e| match e {
                crate::Error::InvalidInput { what, message } => crate::Error::input(
                    what,
                    format!(
                        "{message} (harmonic {h} of {} Hz)",
                        omega / (2.0 * std::f64::consts::PI)
                    ),
                ),
                other => other,
            })?;
            if !(z.re.is_finite() && z.im.is_finite()) {
                return Err(crate::Error::input(
                    "receptance",
                    format!("not finite at harmonic {h} of ω = {omega} rad/s: {z}"),
                ));
            }
            self.hs[i] = z;
        }
        self.omega = omega;
        Ok(())
    }

    /// The residual `R` at `x` (and the Jacobian `∂R/∂X` when asked), at the
    /// frequency last set.
    pub fn residual<E: Element>(
        &mut self,
        elements: &mut E,
        force: f64,
        x: &[f64],
        r: &mut [f64],
        jac: Option<&mut [f64]>,
    ) -> Result<(), EvalError> {
        self.at_solution = false;
        let odd = self.opts.half_wave_symmetry && elements.odd_law();
        residual(
            &mut self.aft,
            &mut self.g,
            &mut self.dg,
            &self.hs,
            self.omega,
            self.opts.periodic_loop,
            odd,
            elements,
            force * self.drive,
            x,
            r,
            jac,
        )
    }

    /// Damped Newton from `x` (overwritten with the last iterate).
    pub fn newton<E: Element>(
        &mut self,
        elements: &mut E,
        force: f64,
        x: &mut [f64],
        counters: &mut Counters,
    ) -> Outcome {
        let n = self.n;
        self.at_solution = false;
        let once = self.step_at_least_once;
        let Core {
            aft,
            opts,
            at_solution,
            hs,
            omega,
            g,
            dg,
            r,
            jac,
            lu,
            piv,
            step,
            xt,
            rt,
            jact,
            xfd,
            rfd,
            ..
        } = self;
        let omega = *omega;
        let method = opts.periodic_loop;
        let odd = opts.half_wave_symmetry && elements.odd_law();
        let force = force * self.drive;
        let mut eval = |x: &[f64], r: &mut [f64], j: Option<&mut [f64]>, c: &mut Counters| {
            c.residuals += 1;
            if j.is_some() {
                c.jacobians += 1;
            }
            residual(aft, g, dg, hs, omega, method, odd, elements, force, x, r, j)
        };
        let fail = |iterations: usize, residual: f64, why: SolveFailure| Outcome {
            converged: false,
            iterations,
            residual,
            failure: Some(why.to_string()),
        };
        let mut use_fd = opts.jacobian == JacobianMethod::FiniteDifference;
        let first = if use_fd {
            eval(x, r, None, counters)
                .and_then(|_| fd_jacobian(&mut eval, x, r, jac, xfd, rfd, counters))
        } else {
            eval(x, r, Some(jac), counters)
        };
        if let Err(why) = first {
            return fail(0, f64::NAN, SolveFailure::AtStart(why));
        }
        let mut nr = norm(r);
        let mut switched = false;
        let mut iteration = 0;
        // modified Newton: the Jacobian is kept while steps contract the
        // residual at least tenfold (an AFT march without sensitivities costs
        // ~60 % of one with them), refreshed otherwise
        let mut jac_fresh = true;
        let mut trial_jacobian = false;
        let mut forced = false;
        // whether `lu` holds the factors of `jac` (a kept Jacobian is
        // factored once)
        let mut factored = false;
        loop {
            let rel = nr / norm(x).max(f64::MIN_POSITIVE);
            if !rel.is_finite() {
                return fail(iteration, rel, SolveFailure::NonFiniteResidual);
            }
            if rel <= opts.tolerance && once && iteration == 0 && !forced {
                // a derivative by differences perturbs a converged point by
                // less than the tolerance may notice: one plain Newton step
                // (exact to second order in the perturbation) makes `x`
                // follow it
                forced = true;
                lu.copy_from_slice(jac);
                factored = lu_factor(lu, piv, n);
                if factored {
                    for (s, ri) in step.iter_mut().zip(r.iter()) {
                        *s = -ri;
                    }
                    lu_solve(lu, piv, n, step);
                    for i in 0..n {
                        xt[i] = x[i] + step[i];
                    }
                    if eval(xt, rt, None, counters).is_ok() && norm(rt) <= opts.tolerance * norm(xt)
                    {
                        x.copy_from_slice(xt);
                        r.copy_from_slice(rt);
                        nr = norm(r);
                    }
                }
                continue;
            }
            if rel <= opts.tolerance {
                // finite differences leave `g` and `r` at a perturbed point,
                // and so does a forced step (evaluated without sensitivities)
                *at_solution = !use_fd && !forced;
                return Outcome {
                    converged: true,
                    iterations: iteration,
                    residual: rel,
                    failure: None,
                };
            }
            if iteration >= opts.max_iterations {
                return fail(
                    iteration,
                    rel,
                    SolveFailure::StepLimit {
                        iterations: opts.max_iterations,
                        residual: rel,
                        tolerance: opts.tolerance,
                    },
                );
            }
            iteration += 1;
            if !factored {
                lu.copy_from_slice(jac);
                if !lu_factor(lu, piv, n) {
                    return fail(iteration, rel, SolveFailure::SingularJacobian);
                }
                factored = true;
            }
            for (s, ri) in step.iter_mut().zip(r.iter()) {
                *s = -ri;
            }
            lu_solve(lu, piv, n, step);
            // Armijo backtracking on ‖R‖; after a poor contraction the full
            // step also brings its Jacobian (usually accepted: saves a march)
            let mut t = 1.0;
            let mut accepted = None;
            while t >= 1.0 / 1024.0 {
                for i in 0..n {
                    xt[i] = x[i] + t * step[i];
                }
                let with_jac = t == 1.0 && !use_fd && trial_jacobian;
                let ok = eval(xt, rt, if with_jac { Some(jact) } else { None }, counters);
                if ok.is_ok() {
                    let nt = norm(rt);
                    if nt <= (1.0 - 1e-4 * t) * nr {
                        accepted = Some(with_jac);
                        break;
                    }
                }
                t *= 0.5;
            }
            match accepted {
                None => {
                    if !jac_fresh && !use_fd {
                        // a kept Jacobian gone stale: refresh it and retry
                        if let Err(why) = eval(x, rt, Some(jac), counters) {
                            return fail(iteration, rel, SolveFailure::Evaluation(why));
                        }
                        factored = false;
                        jac_fresh = true;
                        trial_jacobian = true;
                        continue;
                    }
                    if !switched {
                        // the analytic Jacobian may be poor (a kink, an element
                        // without exact sensitivities): retry with differences
                        switched = true;
                        use_fd = true;
                        factored = false;
                        if let Err(why) = fd_jacobian(&mut eval, x, r, jac, xfd, rfd, counters) {
                            return fail(iteration, rel, SolveFailure::Evaluation(why));
                        }
                        continue;
                    }
                    return fail(iteration, rel, SolveFailure::LineSearch { residual: rel });
                }
                Some(with_jac) => {
                    x.copy_from_slice(xt);
                    r.copy_from_slice(rt);
                    let contraction = norm(r) / nr;
                    nr = norm(r);
                    let poor = contraction > 0.1;
                    trial_jacobian = poor;
                    // every branch but the last brings a new Jacobian
                    factored &= !(with_jac || use_fd || poor);
                    if with_jac {
                        jac.copy_from_slice(jact);
                        jac_fresh = true;
                    } else if use_fd {
                        if let Err(why) = fd_jacobian(&mut eval, x, r, jac, xfd, rfd, counters) {
                            return fail(iteration, rel, SolveFailure::Evaluation(why));
                        }
                    } else if poor {
                        if let Err(why) = eval(x, rt, Some(jac), counters) {
                            return fail(iteration, rel, SolveFailure::Evaluation(why));
                        }
                        jac_fresh = true;
                    } else {
                        jac_fresh = false;
                    }
                }
            }
        }
    }
}

impl Core {
    /// Copies `G` and `∂G/∂X` of the last converged point, if the buffers
    /// hold them (analytic Jacobian), for [`Core::linearised_prediction`].
    pub fn element_linearisation(&self, g: &mut Vec<f64>, dg: &mut Vec<f64>) -> bool {
        if !(self.at_solution && self.opts.jacobian == JacobianMethod::Analytic) {
            return false;
        }
        g.clear();
        g.extend_from_slice(&self.g);
        dg.clear();
        dg.extend_from_slice(&self.dg);
        true
    }

    /// A predictor at `omega` from the converged `(x0, G0, ∂G/∂X)` of
    /// another frequency: the balance with the element linearised,
    /// `X = H(hω)(F δ_{h1} − G0 − ∂G/∂X (X − X0))`, solved exactly (no AFT).
    /// The receptance's change is taken in full, so a sharp resonance between
    /// sweep points is predicted well where a tangent extrapolation is not.
    #[allow(clippy::too_many_arguments)]
    pub fn linearised_prediction<L: LinearPart>(
        &mut self,
        linear: &L,
        omega: f64,
        force: f64,
        x0: &[f64],
        g0: &[f64],
        dg0: &[f64],
        out: &mut [f64],
    ) -> bool {
        let n = self.n;
        let layout = &self.aft.layout;
        for (i, &h) in layout.harmonics.iter().enumerate() {
            let s = layout.slots[i];
            let Ok(hh) = linear.receptance(h as f64 * omega) else {
                return false;
            };
            let (a, b) = (hh.re, hh.im);
            if h == 0 {
                // R = X − H (−G − dG (X − X0)) at X0
                self.rfd[s] = x0[s] + a * g0[s];
                for k in 0..n {
                    self.lu[s * n + k] = a * dg0[s * n + k];
                }
            } else {
                let f = if h == 1 {
                    force * linear.drive(omega)
                } else {
                    Complex64::new(0.0, 0.0)
                };
                let v =
                    Complex64::new(x0[s], x0[s + 1]) - hh * (f - Complex64::new(g0[s], g0[s + 1]));
                self.rfd[s] = v.re;
                self.rfd[s + 1] = v.im;
                for k in 0..n {
                    let (c, d) = (dg0[s * n + k], dg0[(s + 1) * n + k]);
                    self.lu[s * n + k] = a * c - b * d;
                    self.lu[(s + 1) * n + k] = a * d + b * c;
                }
            }
        }
        for k in 0..n {
            self.lu[k * n + k] += 1.0;
        }
        if !lu_factor(&mut self.lu, &mut self.piv, n) {
            return false;
        }
        lu_solve(&self.lu, &self.piv, n, &mut self.rfd);
        for k in 0..n {
            out[k] = x0[k] - self.rfd[k];
        }
        out.iter().all(|v| v.is_finite())
    }

    /// The branch tangent `dX/dω` at the converged point `x` (frequency as
    /// set): `J t = −∂R/∂ω`. For rate-independent elements `∂R_h/∂ω =
    /// −h H'(hω)(F δ_{h1} − G_h)` needs no march (the Jacobian and `G` of the
    /// last Newton solve are reused); otherwise `∂R/∂ω` is a forward
    /// difference. `false` if it cannot be formed.
    pub fn tangent<L: LinearPart, E: Element>(
        &mut self,
        linear: &L,
        elements: &mut E,
        force: f64,
        x: &[f64],
        t: &mut [f64],
        counters: &mut Counters,
    ) -> bool {
        let n = self.n;
        let omega = self.omega;
        if !self.at_solution {
            counters.residuals += 1;
            counters.jacobians += 1;
            let (mut r, mut jac) = (std::mem::take(&mut self.r), std::mem::take(&mut self.jac));
            let ok = self.residual(elements, force, x, &mut r, Some(&mut jac));
            self.r = r;
            self.jac = jac;
            if ok.is_err() {
                return false;
            }
            self.at_solution = true;
        }
        let eps = 1e-7;
        let w2 = omega * (1.0 + eps);
        if elements.uses_velocity() {
            let saved_hs = self.hs.clone();
            let saved_drive = self.drive;
            if self.set_frequency(linear, w2).is_err() {
                return false;
            }
            counters.residuals += 1;
            let mut rfd = std::mem::take(&mut self.rfd);
            let odd = self.opts.half_wave_symmetry && elements.odd_law();
            let ok = residual(
                &mut self.aft,
                &mut self.g,
                &mut self.dg,
                &self.hs,
                w2,
                self.opts.periodic_loop,
                odd,
                elements,
                force * self.drive,
                x,
                &mut rfd,
                None,
            );
            self.hs = saved_hs;
            self.drive = saved_drive;
            self.omega = omega;
            self.at_solution = false;
            if ok.is_err() {
                self.rfd = rfd;
                return false;
            }
            for i in 0..n {
                t[i] = -(rfd[i] - self.r[i]) / (w2 - omega);
            }
            self.rfd = rfd;
        } else {
            for (i, &h) in self.aft.layout.harmonics.iter().enumerate() {
                let s = self.aft.layout.slots[i];
                if h == 0 {
                    t[s] = 0.0;
                    continue;
                }
                let Ok(h2) = linear.receptance(h as f64 * w2) else {
                    return false;
                };
                let dh = (h2 - self.hs[i]) / (w2 - omega);
                let g = Complex64::new(self.g[s], self.g[s + 1]);
                // ∂/∂ω of H(hω)(F D(ω) δ_{h1} − G_h)
                let rw = if h == 1 {
                    let dhd = (h2 * linear.drive(w2) - self.hs[i] * self.drive) / (w2 - omega);
                    -(dhd * force - dh * g)
                } else {
                    dh * g
                };
                t[s] = -rw.re;
                t[s + 1] = -rw.im;
            }
        }
        self.lu.copy_from_slice(&self.jac);
        if !lu_factor(&mut self.lu, &mut self.piv, n) {
            return false;
        }
        lu_solve(&self.lu, &self.piv, n, t);
        t.iter().all(|v| v.is_finite())
    }
}

/// Forward differences, step `1e-7·‖X‖∞` (relative, so it scales with the
/// response).
fn fd_jacobian(
    eval: &mut impl FnMut(
        &[f64],
        &mut [f64],
        Option<&mut [f64]>,
        &mut Counters,
    ) -> Result<(), EvalError>,
    x: &[f64],
    r: &[f64],
    jac: &mut [f64],
    xfd: &mut [f64],
    rfd: &mut [f64],
    counters: &mut Counters,
) -> Result<(), EvalError> {
    let n = x.len();
    let scale = x
        .iter()
        .fold(0.0f64, |m, v| m.max(v.abs()))
        .max(f64::MIN_POSITIVE);
    let h = 1e-7 * scale;
    for k in 0..n {
        xfd.copy_from_slice(x);
        xfd[k] += h;
        eval(xfd, rfd, None, counters)?;
        for i in 0..n {
            jac[i * n + k] = (rfd[i] - r[i]) / h;
        }
    }
    Ok(())
}

#[allow(clippy::too_many_arguments)]
fn residual<E: Element>(
    aft: &mut Aft,
    g: &mut [f64],
    dg: &mut [f64],
    hs: &[Complex64],
    omega: f64,
    method: super::PeriodicLoop,
    odd_law: bool,
    elements: &mut E,
    force: Complex64,
    x: &[f64],
    r: &mut [f64],
    jac: Option<&mut [f64]>,
) -> Result<(), EvalError> {
    let n = x.len();
    let want = jac.is_some();
    aft.evaluate(
        x,
        omega,
        elements,
        method,
        odd_law,
        g,
        if want { Some(dg) } else { None },
    )?;
    let layout = &aft.layout;
    for (i, &h) in layout.harmonics.iter().enumerate() {
        let s = layout.slots[i];
        let hh = hs[i];
        if h == 0 {
            // H(0) is real for a physical structure
            r[s] = x[s] + hh.re * g[s];
        } else {
            let f = if h == 1 {
                force
            } else {
                Complex64::new(0.0, 0.0)
            };
            let v = Complex64::new(x[s], x[s + 1]) - hh * (f - Complex64::new(g[s], g[s + 1]));
            r[s] = v.re;
            r[s + 1] = v.im;
        }
    }
    if let Some(k) = r.iter().position(|v| !v.is_finite()) {
        return Err(EvalError::Residual { component: k });
    }
    if let Some(j) = jac {
        for (i, &h) in layout.harmonics.iter().enumerate() {
            let s = layout.slots[i];
            let (a, b) = (hs[i].re, hs[i].im);
            if h == 0 {
                for k in 0..n {
                    j[s * n + k] = a * dg[s * n + k];
                }
            } else {
                for k in 0..n {
                    let (c, d) = (dg[s * n + k], dg[(s + 1) * n + k]);
                    j[s * n + k] = a * c - b * d;
                    j[(s + 1) * n + k] = a * d + b * c;
                }
            }
        }
        for k in 0..n {
            j[k * n + k] += 1.0;
        }
    }
    Ok(())
}

/// Euclidean norm.
#[inline]
pub(crate) fn norm(v: &[f64]) -> f64 {
    v.iter().map(|x| x * x).sum::<f64>().sqrt()
}

/// In-place LU with partial pivoting of a row-major `n × n` matrix; `false`
/// if singular.
pub(crate) fn lu_factor(a: &mut [f64], piv: &mut [usize], n: usize) -> bool {
    for k in 0..n {
        let mut p = k;
        let mut best = a[k * n + k].abs();
        for i in k + 1..n {
            let v = a[i * n + k].abs();
            if v > best {
                best = v;
                p = i;
            }
        }
        piv[k] = p;
        if !(best > 0.0 && best.is_finite()) {
            return false;
        }
        if p != k {
            for j in 0..n {
                a.swap(k * n + j, p * n + j);
            }
        }
        let d = a[k * n + k];
        for i in k + 1..n {
            let l = a[i * n + k] / d;
            a[i * n + k] = l;
            if l != 0.0 {
                for j in k + 1..n {
                    a[i * n + j] -= l * a[k * n + j];
                }
            }
        }
    }
    true
}

/// Solves with the factors of [`lu_factor`], in place.
pub(crate) fn lu_solve(lu: &[f64], piv: &[usize], n: usize, b: &mut [f64]) {
    for (k, &p) in piv.iter().enumerate().take(n) {
        b.swap(k, p);
    }
    for i in 0..n {
        let mut s = b[i];
        for j in 0..i {
            s -= lu[i * n + j] * b[j];
        }
        b[i] = s;
    }
    for i in (0..n).rev() {
        let mut s = b[i];
        for j in i + 1..n {
            s -= lu[i * n + j] * b[j];
        }
        b[i] = s / lu[i * n + i];
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::{ElementSet, ElementSpec, ModalModel};

    /// `∂R/∂X` (receptance assembly over the AFT Jacobian, static and even
    /// harmonics included) against central differences of `R`.
    #[test]
    fn residual_jacobian_equals_finite_differences() {
        let linear = ModalModel::sdof(10.0, 200.0, 1e7).unwrap();
        let opts = HbOptions::with_harmonics(vec![0, 1, 2, 3, 5]);
        let mut core = Core::new(&opts);
        core.set_frequency(&linear, 2.0 * std::f64::consts::PI * 230.0)
            .unwrap();
        let mut e = ElementSet::new(vec![
            ElementSpec::Masing {
                kd: 2.4e7,
                fd: 246.048,
                n: 5.0,
            }
            .build()
            .unwrap(),
            ElementSpec::BilinearStiffness { kb: 3e6 }.build().unwrap(),
        ]);
        let n = core.n;
        let x: Vec<f64> = (0..n)
            .map(|k| 2e-5 * ((k as f64 * 2.3).cos() + 0.2) / (1.0 + k as f64))
            .collect();
        let (mut r, mut j) = (vec![0.0; n], vec![0.0; n * n]);
        core.residual(&mut e, 300.0, &x, &mut r, Some(&mut j))
            .unwrap();
        let scale = j.iter().fold(0.0f64, |m, v| m.max(v.abs()));
        for k in 0..n {
            let h = 1e-13;
            let (mut xp, mut xm) = (x.clone(), x.clone());
            xp[k] += h;
            xm[k] -= h;
            let (mut rp, mut rm) = (vec![0.0; n], vec![0.0; n]);
            core.residual(&mut e, 300.0, &xp, &mut rp, None).unwrap();
            core.residual(&mut e, 300.0, &xm, &mut rm, None).unwrap();
            for i in 0..n {
                let fd = (rp[i] - rm[i]) / (2.0 * h);
                assert!(
                    (fd - j[i * n + k]).abs() <= 1e-6 * scale,
                    "∂R[{i}]/∂X[{k}]: {fd} vs {}",
                    j[i * n + k]
                );
            }
        }
    }

    #[test]
    fn lu_solves_a_pivoting_system() {
        let n = 3;
        let a = [0.0, 2.0, 1.0, 1.0, 1.0, 0.0, 3.0, 0.0, 1.0];
        let x = [1.0, -2.0, 0.5];
        let mut b = [0.0; 3];
        for i in 0..n {
            for j in 0..n {
                b[i] += a[i * n + j] * x[j];
            }
        }
        let mut lu = a;
        let mut piv = [0; 3];
        assert!(lu_factor(&mut lu, &mut piv, n));
        lu_solve(&lu, &piv, n, &mut b);
        for i in 0..n {
            assert!((b[i] - x[i]).abs() < 1e-14);
        }
        let mut sing = [1.0, 2.0, 2.0, 4.0];
        assert!(!lu_factor(&mut sing, &mut [0; 2], 2));
    }
}
