//! The Masing element: the paper's eq. (10) backbone with memory.
//!
//! Eq. (10), `F = kd x / (1 + (kd x/Fd)^N)^(1/N)`, is a backbone (virgin
//! curve). Written with `|x|` it is odd and defined for any real `N > 0`
//! (method notes c.1). Loading and unloading follow the extended Masing rules
//! (Masing 1926; Pyke 1979; method notes c.2), kept with a stack of turning
//! points (c.3):
//!
//! 1. first loading follows the backbone `f`;
//! 2. after a reversal at `(x_r, F_r)` the branch is `F_r + 2 f((x − x_r)/2)`;
//! 3. a branch that passes the largest past excursion rejoins the backbone;
//! 4. a branch that meets the branch of an earlier cycle continues along it,
//!    and the inner loop is erased (wipe-out, return-point memory).
//!
//! The backbone is a type parameter: [`PowerBackbone`] is eq. (10);
//! [`PiecewiseLinearBackbone`] gives the exact Masing model of a parallel bank
//! of Jenkins elements (an Iwan model), which the tests use as an independent
//! reference for the stack logic.

use super::element::{Element, ElementForce, sign};
use crate::error::{Error, Result, require_positive};
use std::cell::Cell;

/// An odd, monotone virgin curve `f(x)` with `f'(0) > 0`.
pub trait Backbone: Clone {
    /// `(f(x), f'(x))`.
    fn eval(&self, x: f64) -> (f64, f64);

    /// `(f(x), f'(x), f''(x))`; the default has no curvature information and
    /// reports 0, which is only right together with `taylor_radius() = 0`.
    fn eval_with_curvature(&self, x: f64) -> (f64, f64, f64) {
        let (f, k) = self.eval(x);
        (f, k, 0.0)
    }

    /// Within this distance of an exactly evaluated point, a second-order
    /// Taylor expansion reproduces the branch to ~1e-13 of the slip force
    /// (0: never expand).
    fn taylor_radius(&self) -> f64 {
        0.0
    }
}

/// `r^N` below this is lost in `1 + r^N` (2^-60): the backbone is linear.
const NEGLIGIBLE_LN: f64 = 41.6;

/// Paper eq. (10) made odd: `f(x) = kd x / (1 + |kd x/Fd|^N)^(1/N)`.
///
/// Evaluated without overflow for any `N > 0` (tested up to 1e4): for
/// `r = |kd x/Fd| ≤ 1` as `kd x (1 + r^N)^(-1/N)`, above as
/// `±Fd (1 + r^-N)^(-1/N)`; far from the knee the transcendental functions are
/// skipped because the correction is below f64 resolution.
#[derive(Clone, Debug, PartialEq)]
pub struct PowerBackbone {
    kd: f64,
    fd: f64,
    n: f64,
    kd_over_fd: f64,
    /// Below this `r`, `r^N < 2^-60`.
    r_linear: f64,
    /// Above this `r`, `r^-N < 2^-60`.
    r_saturated: f64,
    /// See [`Backbone::taylor_radius`].
    taylor_radius: f64,
}

impl PowerBackbone {
    /// Eq. (10) with stick stiffness `kd`, slip force `fd` and curvature `n`.
    pub fn new(kd: f64, fd: f64, n: f64) -> Result<PowerBackbone> {
        require_positive("joint.kd", kd)?;
        require_positive("joint.fd", fd)?;
        require_positive("joint.n", n)?;
        Ok(PowerBackbone {
            kd,
            fd,
            n,
            kd_over_fd: kd / fd,
            r_linear: (-NEGLIGIBLE_LN / n).exp(),
            r_saturated: (NEGLIGIBLE_LN / n).exp(),
            // the expansion's error is ~ f''' h³/6 with f''' ~ kd N²/x_c² near
            // the knee: h = 8e-5 x_c N^(-2/3) keeps it below 1e-13 Fd
            taylor_radius: 8e-5 * (fd / kd) / n.max(1.0).powf(2.0 / 3.0),
        })
    }

    /// `(kd, fd, n)`.
    pub fn parameters(&self) -> (f64, f64, f64) {
        (self.kd, self.fd, self.n)
    }
}

impl Backbone for PowerBackbone {
    #[inline]
    fn eval(&self, x: f64) -> (f64, f64) {
        let (f, k, _) = self.eval_with_curvature(x);
        (f, k)
    }

    /// The tangent and curvature follow from `f` without further
    /// transcendentals: with `p = r^N`, `f' = (f/x)/(1 + p)` and
    /// `f'' = −(N + 1) f' p / (x (1 + p))`.
    #[inline]
    fn eval_with_curvature(&self, x: f64) -> (f64, f64, f64) {
        let r = (self.kd_over_fd * x).abs();
        if r <= self.r_linear {
            return (self.kd * x, self.kd, 0.0);
        }
        if r >= self.r_saturated {
            // the tangent kd r^-(N+1) (1 + r^-N)^(-(N+1)/N) is below kd 2^-60
            // here; it is returned as 0 (Newton and AFT cannot tell)
            return (sign(x) * self.fd, 0.0, 0.0);
        }
        // ln(1 + p) rather than ln_1p(p): only its absolute accuracy matters
        let n = self.n;
        let ln_r = r.ln();
        if r <= 1.0 {
            let p = (n * ln_r).exp(); // r^N
            let s = (-(1.0 + p).ln() / n).exp();
            let k = self.kd * s / (1.0 + p);
            (self.kd * x * s, k, -(n + 1.0) * k * p / ((1.0 + p) * x))
        } else {
            let q = (-n * ln_r).exp(); // r^-N
            let f = sign(x) * self.fd * (-(1.0 + q).ln() / n).exp();
            let k = f / x * q / (1.0 + q);
            (f, k, -(n + 1.0) * k / ((1.0 + q) * x))
        }
    }

    fn taylor_radius(&self) -> f64 {
        self.taylor_radius
    }
}

/// A piecewise-linear backbone `f(x) = Σ_i k_i min(|x|, δ_i) sign(x)`: the
/// virgin curve of a parallel bank of Jenkins elements with stiffnesses `k_i`
/// and slip displacements `δ_i` (Iwan 1966).
#[derive(Clone, Debug, PartialEq)]
pub struct PiecewiseLinearBackbone {
    /// `(δ_i, k_i)`, sorted by `δ_i`.
    pub slips: Vec<(f64, f64)>,
}

impl Backbone for PiecewiseLinearBackbone {
    fn eval(&self, x: f64) -> (f64, f64) {
        let a = x.abs();
        let mut f = 0.0;
        let mut k = 0.0;
        for &(d, ki) in &self.slips {
            if a < d {
                f += ki * a;
                k += ki;
            } else {
                f += ki * d;
            }
        }
        (sign(x) * f, k)
    }
}

/// A hysteresis element following the extended Masing rules around a
/// backbone, with a turning-point stack.
#[derive(Clone, Debug)]
pub struct Masing<B: Backbone = PowerBackbone> {
    backbone: B,
    /// Turning points `(x_r, F_r)` that are still open, oldest first.
    stack: Vec<(f64, f64)>,
    x_prev: f64,
    f_prev: f64,
    /// Direction of the last committed move: -1, 0 (virgin, at rest), +1.
    direction: i8,
    /// The last exactly evaluated trial since the last commit: nearby trials
    /// on the same branch (the implicit solve's Newton iterates, then the
    /// commit) expand around it instead of re-evaluating the backbone.
    anchor: Cell<Option<Anchor>>,
    /// Sensitivities carried by [`Element::commit_sensitivity`]: their
    /// length `n`, then `(∂x, ∂F)` of the previous sample (`2n`) and of each
    /// open turning point (`2n` each, in stack order).
    sens_dim: usize,
    prev_sens: Vec<f64>,
    stack_sens: Vec<f64>,
}

/// An exact evaluation on a branch: position, branch identity, force, tangent
/// and curvature.
#[derive(Clone, Copy, Debug)]
struct Anchor {
    x: f64,
    at: Located,
    force: f64,
    stiffness: f64,
    curvature: f64,
}

/// Where a displacement lands: its direction, whether the previous sample
/// becomes a turning point, and how many stack entries stay open.
#[derive(Clone, Copy, Debug, PartialEq)]
struct Located {
    direction: i8,
    push: bool,
    open: usize,
}

impl Masing<PowerBackbone> {
    /// The eq. (10) Masing element with stick stiffness `kd`, slip force `fd`
    /// and curvature `n`.
    pub fn new(kd: f64, fd: f64, n: f64) -> Result<Self> {
        Ok(Masing::with_backbone(PowerBackbone::new(kd, fd, n)?))
    }
}

impl<B: Backbone> Masing<B> {
    /// A virgin element around any backbone.
    pub fn with_backbone(backbone: B) -> Self {
        Masing {
            backbone,
            stack: Vec::with_capacity(16),
            x_prev: 0.0,
            f_prev: 0.0,
            direction: 0,
            anchor: Cell::new(None),
            sens_dim: 0,
            prev_sens: Vec::new(),
            stack_sens: Vec::new(),
        }
    }

    /// The backbone.
    pub fn backbone(&self) -> &B {
        &self.backbone
    }

    /// Open turning points, oldest first.
    pub fn turning_points(&self) -> &[(f64, f64)] {
        &self.stack
    }

    #[inline]
    fn point(&self, i: usize) -> (f64, f64) {
        if i < self.stack.len() {
            self.stack[i]
        } else {
            (self.x_prev, self.f_prev)
        }
    }

    #[inline]
    fn locate(&self, x: f64) -> Located {
        let mut direction = self.direction;
        let mut push = false;
        if x != self.x_prev {
            let d = if x > self.x_prev { 1 } else { -1 };
            push = direction != 0 && d != direction;
            direction = d;
        }
        let mut open = self.stack.len() + push as usize;
        while open > 0 {
            // a branch from the only turning point meets the backbone at the
            // mirror point; otherwise it meets the branch it departed from at
            // that branch's own origin
            let target = if open == 1 {
                -self.point(0).0
            } else {
                self.point(open - 2).0
            };
            let closed = if direction > 0 {
                x >= target
            } else {
                x <= target
            };
            if !closed {
                break;
            }
            open -= if open == 1 { 1 } else { 2 };
        }
        Located {
            direction,
            push,
            open,
        }
    }

    /// The branch's force at `x`, from the anchor when it is close and on
    /// the same branch, else exactly (and then it becomes the anchor).
    #[inline]
    fn force_at(&self, x: f64, at: Located) -> ElementForce {
        if let Some(a) = self.anchor.get() {
            let h = x - a.x;
            if a.at == at && h.abs() <= self.backbone.taylor_radius() {
                return ElementForce {
                    force: a.force + h * (a.stiffness + 0.5 * h * a.curvature),
                    stiffness: a.stiffness + h * a.curvature,
                    damping: 0.0,
                };
            }
        }
        let (force, stiffness, curvature) = if at.open == 0 {
            self.backbone.eval_with_curvature(x)
        } else {
            // F_r + 2 f((x − x_r)/2): tangent f'(·), curvature f''(·)/2
            let (xr, fr) = self.point(at.open - 1);
            let (f, k, c) = self.backbone.eval_with_curvature(0.5 * (x - xr));
            (fr + 2.0 * f, k, 0.5 * c)
        };
        self.anchor.set(Some(Anchor {
            x,
            at,
            force,
            stiffness,
            curvature,
        }));
        ElementForce {
            force,
            stiffness,
            damping: 0.0,
        }
    }
}

impl<B: Backbone> Element for Masing<B> {
    #[inline]
    fn trial(&self, x: f64, _v: f64) -> ElementForce {
        self.force_at(x, self.locate(x))
    }

    #[inline]
    fn commit(&mut self, x: f64, _v: f64) -> ElementForce {
        let at = self.locate(x);
        let f = self.force_at(x, at);
        if at.push && at.open > self.stack.len() {
            self.stack.push((self.x_prev, self.f_prev));
        } else {
            self.stack.truncate(at.open);
        }
        self.direction = at.direction;
        self.x_prev = x;
        self.f_prev = f.force;
        // branch identities are relative to the state just changed
        self.anchor.set(None);
        f
    }

    fn reset(&mut self) {
        self.stack.clear();
        self.x_prev = 0.0;
        self.f_prev = 0.0;
        self.direction = 0;
        self.anchor.set(None);
        self.sens_dim = 0;
        self.prev_sens.clear();
        self.stack_sens.clear();
    }

    /// On the backbone `∂F = f'(x) ∂x`; on a branch from the turning point
    /// `(x_r, F_r)`, `∂F = ∂F_r + f'((x − x_r)/2) (∂x − ∂x_r)` (method notes
    /// d.1). Each turning point keeps the `(∂x, ∂F)` of the sample it was.
    fn commit_sensitivity(
        &mut self,
        x: f64,
        _v: f64,
        dx: &[f64],
        _dv: &[f64],
        df: &mut [f64],
    ) -> ElementForce {
        let n = dx.len();
        if self.sens_dim != n {
            // first use since reset (or a new size): the history so far is
            // taken as independent of p
            self.sens_dim = n;
            self.prev_sens.clear();
            self.prev_sens.resize(2 * n, 0.0);
            self.stack_sens.clear();
            self.stack_sens.resize(2 * n * self.stack.len(), 0.0);
        }
        let at = self.locate(x);
        let f = self.force_at(x, at);
        if at.push && at.open > self.stack.len() {
            self.stack.push((self.x_prev, self.f_prev));
            self.stack_sens.extend_from_slice(&self.prev_sens);
        } else {
            self.stack.truncate(at.open);
            self.stack_sens.truncate(2 * n * at.open);
        }
        // the branch's origin is now the top of the stack
        let k = f.stiffness;
        if at.open == 0 {
            for i in 0..n {
                let d = k * dx[i];
                self.prev_sens[n + i] = d;
                df[i] += d;
            }
        } else {
            let r = &self.stack_sens[2 * n * (at.open - 1)..2 * n * at.open];
            for i in 0..n {
                let d = r[n + i] + k * (dx[i] - r[i]);
                self.prev_sens[n + i] = d;
                df[i] += d;
            }
        }
        self.prev_sens[..n].copy_from_slice(dx);
        self.direction = at.direction;
        self.x_prev = x;
        self.f_prev = f.force;
        self.anchor.set(None);
        f
    }

    fn has_memory(&self) -> bool {
        true
    }
}

/// Checks an `n` for the Masing element (used by configuration code).
pub fn validate_curvature(field: &str, n: f64) -> Result<()> {
    if n.is_finite() && n > 0.0 {
        Ok(())
    } else {
        Err(Error::model(
            field,
            format!("must be a finite number > 0, got {n}"),
        ))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::Jenkins;
    use crate::model::element::check::check_element;
    use proptest::prelude::*;

    const KD: f64 = 2.4e7;
    const FD: f64 = 246.048;

    #[test]
    fn passes_the_element_checker() {
        for n in [1.0, 3.0, 22.55, 1000.0] {
            check_element(Masing::new(KD, FD, n).unwrap(), 2e-5, FD);
        }
    }

    #[test]
    fn backbone_is_overflow_safe_and_smooth_across_its_fast_paths() {
        for n in [0.5, 2.0, 22.55, 1e3, 1e4] {
            let b = PowerBackbone::new(KD, FD, n).unwrap();
            for k in -400..=400 {
                let x = FD / KD * 10f64.powf(k as f64 / 100.0);
                let (f, df) = b.eval(x);
                assert!(f.is_finite() && df.is_finite() && df >= 0.0);
                // reference in extended precision-free form, valid where r^N is representable
                let r: f64 = KD * x / FD;
                if (n * r.ln()).abs() < 600.0 {
                    let exact = KD * x / (1.0 + r.powf(n)).powf(1.0 / n);
                    assert!(
                        (f - exact).abs() <= 1e-12 * exact.abs(),
                        "n={n} x={x}: {f} vs {exact}"
                    );
                    let exact_df = KD * (1.0 + r.powf(n)).powf(-(n + 1.0) / n);
                    assert!(
                        (df - exact_df).abs() <= 1e-12 * KD,
                        "n={n} x={x}: {df} vs {exact_df}"
                    );
                }
                let (fm, _) = b.eval(-x);
                assert_eq!(fm, -f);
            }
        }
    }

    #[test]
    fn curvature_matches_a_finite_difference_of_the_tangent() {
        for n in [1.5, 3.0, 22.55, 200.0] {
            let b = PowerBackbone::new(KD, FD, n).unwrap();
            for k in -100..=100 {
                let x = FD / KD * 10f64.powf(k as f64 / 100.0);
                let (_, _, c) = b.eval_with_curvature(x);
                let h = 1e-6 * x;
                let fd = (b.eval(x + h).1 - b.eval(x - h).1) / (2.0 * h);
                assert!(
                    (c - fd).abs() <= 1e-5 * fd.abs() + 1e-9 * KD * KD / FD,
                    "n={n} x={x}: {c} vs {fd}"
                );
            }
        }
    }

    #[test]
    fn taylor_expansion_stays_within_1e_13_of_the_slip_force() {
        // trials near an exact one reuse it; they must agree with a fresh element
        for n in [1.5, 3.0, 22.55, 1000.0] {
            let hist: Vec<f64> = (1..=30).map(|i| i as f64 * 0.05 * FD / KD).collect();
            let fresh = || {
                let mut m = Masing::new(KD, FD, n).unwrap();
                for &x in &hist {
                    m.commit(x, 0.0);
                }
                m
            };
            let a = fresh();
            let x0 = 1.6 * FD / KD;
            a.trial(x0, 0.0);
            let r = a.backbone().taylor_radius();
            for frac in [0.1, 0.5, 1.0, -1.0] {
                let x = x0 + frac * r;
                let got = a.trial(x, 0.0).force;
                let exact = fresh().trial(x, 0.0).force;
                assert!((got - exact).abs() < 1e-13 * FD, "n={n}: {got} vs {exact}");
            }
        }
    }

    #[test]
    fn large_n_matches_jenkins_within_half_a_percent_of_fd() {
        let mut m = Masing::new(KD, FD, 1000.0).unwrap();
        let mut j = Jenkins::new(KD, FD).unwrap();
        let xs = crate::model::element::check::history(3.0 * FD / KD);
        let mut worst: f64 = 0.0;
        for &x in &xs {
            let a = m.commit(x, 0.0).force;
            let b = j.commit(x, 0.0).force;
            worst = worst.max((a - b).abs());
        }
        assert!(worst < 0.005 * FD, "worst difference {worst} N");
    }

    /// An Iwan bank of Jenkins elements, the independent reference.
    fn iwan_bank(slips: &[(f64, f64)]) -> Vec<Jenkins> {
        slips
            .iter()
            .map(|&(d, k)| Jenkins::new(k, k * d).unwrap())
            .collect()
    }

    fn history_from(turns: &[f64]) -> Vec<f64> {
        let mut xs = Vec::new();
        let mut last = 0.0;
        for &t in turns {
            for i in 1..=7 {
                xs.push(last + (t - last) * i as f64 / 7.0);
            }
            last = t;
        }
        xs
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(200))]

        /// The turning-point stack reproduces an Iwan bank exactly: loops
        /// close, inner loops are wiped out, the backbone is rejoined.
        #[test]
        fn stack_equals_an_iwan_bank_on_random_histories(
            turns in prop::collection::vec(-3.0f64..3.0, 1..25),
            ks in prop::collection::vec(0.1f64..1.0, 3..6),
        ) {
            let slips: Vec<(f64, f64)> = ks.iter().enumerate()
                .map(|(i, &k)| (0.3 * (i + 1) as f64, k)).collect();
            let mut masing = Masing::with_backbone(PiecewiseLinearBackbone { slips: slips.clone() });
            let mut bank = iwan_bank(&slips);
            for x in history_from(&turns) {
                let a = masing.commit(x, 0.0).force;
                let b: f64 = bank.iter_mut().map(|j| j.commit(x, 0.0).force).sum();
                prop_assert!((a - b).abs() < 1e-9, "x={} masing {} bank {}", x, a, b);
            }
        }

        /// Rules 3 and 4 stated directly for eq. (10): after an excursion past
        /// every earlier one the force is on the backbone; returning to a
        /// turning point gives that point's force.
        #[test]
        fn returns_to_turning_points_and_rejoins_the_backbone(
            turns in prop::collection::vec(-2.0f64..2.0, 2..15), n in 1.5f64..50.0,
        ) {
            let xc = FD / KD;
            let mut m = Masing::new(KD, FD, n).unwrap();
            let xs = history_from(&turns.iter().map(|t| t * xc).collect::<Vec<_>>());
            for &x in &xs { m.commit(x, 0.0); }
            let peak = xs.iter().fold(0.0f64, |a, x| a.max(x.abs()));
            // return to the last open turning point, if any
            if let Some(&(xr, fr)) = m.turning_points().last() {
                let f = m.commit(xr, 0.0).force;
                prop_assert!((f - fr).abs() < 1e-9 * FD, "return point {} vs {}", f, fr);
            }
            // then go beyond everything: backbone
            let far = 1.2 * peak + 0.1 * xc;
            let steps = 50;
            let start = xs.last().copied().unwrap_or(0.0);
            let mut f = 0.0;
            // (the last point is `far` up to rounding; committing `far` again
            // could be a 1-ulp reversal and open a turning point)
            for i in 1..=steps { f = m.commit(start + (far - start) * i as f64 / steps as f64, 0.0).force; }
            let (fb, _) = m.backbone().eval(far);
            prop_assert!((f - fb).abs() < 1e-9 * FD, "backbone {} vs {}", f, fb);
            prop_assert!(m.turning_points().is_empty());
        }
    }
}
