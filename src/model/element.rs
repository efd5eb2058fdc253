//! The `Element` abstraction: a nonlinear force acting at the joint point.
//!
//! An element exerts the force `g` in the equation of motion
//! `m x'' + c x' + k x = F − g` (paper eq. 1, `g = F_nlf`). Both stages that
//! solve the structure use this one trait, so no element law is written twice:
//!
//! * the time-domain simulator (`sim`) evaluates `trial` inside its per-sample
//!   implicit solve, then `commit`s the accepted sample;
//! * harmonic balance (`hb`) `reset`s the element and `commit`s the samples of
//!   one period in order (a virgin ramp to the displacement maximum first:
//!   every inner loop then closes within the period, so one period is
//!   already periodic).
//!
//! `trial` takes `&self`: the compiler guarantees that evaluating a candidate
//! leaves no trace in the element's memory (turning points, slider position).

use serde::{Deserialize, Serialize};

/// An element's force and its tangents at one `(x, v)`.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct ElementForce {
    /// Force `g`, N (acting against the structure, as `F_nl` in eq. 1).
    pub force: f64,
    /// Tangent stiffness `∂g/∂x`, N/m.
    pub stiffness: f64,
    /// Tangent damping `∂g/∂v`, N s/m.
    pub damping: f64,
}

impl std::ops::Add for ElementForce {
    type Output = ElementForce;
    fn add(self, o: ElementForce) -> ElementForce {
        ElementForce {
            force: self.force + o.force,
            stiffness: self.stiffness + o.stiffness,
            damping: self.damping + o.damping,
        }
    }
}

/// The per-sample implicit equation of the digital-filter simulator.
///
/// The filters give `x = x_pred + bx·u` and `v = v_pred + bv·u` for the net
/// input `u = F − g(x, v)` of the current sample (`bx`, `bv` are the summed
/// direct terms `b0`, both > 0). The root `u` of
/// `u − F + g(x_pred + bx u, v_pred + bv u) = 0` is the sample's input.
#[derive(Clone, Copy, Debug)]
pub struct ImplicitStep {
    /// Displacement from the filters' past, m.
    pub x_pred: f64,
    /// Velocity from the filters' past, m/s.
    pub v_pred: f64,
    /// Displacement direct term, m/N.
    pub bx: f64,
    /// Velocity direct term, m/(N s).
    pub bv: f64,
    /// External force of this sample, N.
    pub force: f64,
}

/// A nonlinear force law, with or without memory.
pub trait Element {
    /// The force at `(x, v)` if this sample were accepted, evaluated from the
    /// last committed state. Has no effect on the element's history; an
    /// element may cache its last exact evaluation to expand nearby trials
    /// around it (the Masing element does, to within 1e-13 of its slip
    /// force), so the same sequence of calls always gives the same bits.
    fn trial(&self, x: f64, v: f64) -> ElementForce;

    /// Accepts `(x, v)` as the next sample of the element's history and
    /// returns its force (the same as `trial(x, v)` would).
    fn commit(&mut self, x: f64, v: f64) -> ElementForce;

    /// Back to the virgin state (no load history).
    fn reset(&mut self);

    /// Whether the force depends on the history (hysteresis).
    fn has_memory(&self) -> bool;

    /// Whether the force depends on velocity.
    fn uses_velocity(&self) -> bool {
        false
    }

    /// The root `u` of the per-sample implicit equation in closed form, when
    /// the element has one (the Jenkins element does). `None`: the simulator
    /// solves it iteratively with [`Element::trial`].
    fn solve_implicit(&self, _step: &ImplicitStep) -> Option<f64> {
        None
    }

    /// Commits like [`Element::commit`] and carries first-order sensitivities
    /// through the element's memory: when the committed samples depend on
    /// parameters `p` (harmonic balance's unknowns), `dx[k] = ∂x/∂p_k` and
    /// `dv[k] = ∂v/∂p_k` for this sample, this **adds** `∂g/∂p_k` to `df[k]`
    /// (adding lets an [`ElementSet`] sum its members without scratch).
    ///
    /// The derivative includes the dependence of the force on earlier samples
    /// through the history (a turning point, the slider position), which the
    /// element keeps alongside its state. It is exact for the samples
    /// committed through this method since the last [`Element::reset`]; plain
    /// `commit`s in between leave the carried sensitivities stale.
    ///
    /// The default, `∂g/∂p = k ∂x/∂p + c ∂v/∂p` from the tangents, is exact
    /// for memoryless elements; an element with memory must override it
    /// (harmonic balance's Newton step otherwise sees an approximate
    /// Jacobian).
    ///
    /// # Panics
    /// May panic if `dx`, `dv` and `df` differ in length.
    fn commit_sensitivity(
        &mut self,
        x: f64,
        v: f64,
        dx: &[f64],
        dv: &[f64],
        df: &mut [f64],
    ) -> ElementForce {
        let f = self.commit(x, v);
        for ((d, &a), &b) in df.iter_mut().zip(dx).zip(dv) {
            *d += f.stiffness * a + f.damping * b;
        }
        f
    }
}

/// A set of elements acting at the same point: their forces add.
#[derive(Clone, Debug, Default)]
pub struct ElementSet<E> {
    /// The elements.
    pub elements: Vec<E>,
}

impl<E: Element> ElementSet<E> {
    /// A set from elements.
    pub fn new(elements: Vec<E>) -> Self {
        ElementSet { elements }
    }
}

impl<E: Element> Element for ElementSet<E> {
    #[inline]
    fn trial(&self, x: f64, v: f64) -> ElementForce {
        self.elements
            .iter()
            .fold(ElementForce::default(), |acc, e| acc + e.trial(x, v))
    }
    #[inline]
    fn commit(&mut self, x: f64, v: f64) -> ElementForce {
        self.elements
            .iter_mut()
            .fold(ElementForce::default(), |acc, e| acc + e.commit(x, v))
    }
    fn reset(&mut self) {
        self.elements.iter_mut().for_each(Element::reset);
    }
    fn has_memory(&self) -> bool {
        self.elements.iter().any(Element::has_memory)
    }
    fn uses_velocity(&self) -> bool {
        self.elements.iter().any(Element::uses_velocity)
    }
    #[inline]
    fn commit_sensitivity(
        &mut self,
        x: f64,
        v: f64,
        dx: &[f64],
        dv: &[f64],
        df: &mut [f64],
    ) -> ElementForce {
        self.elements
            .iter_mut()
            .fold(ElementForce::default(), |acc, e| {
                acc + e.commit_sensitivity(x, v, dx, dv, df)
            })
    }
    #[inline]
    fn solve_implicit(&self, step: &ImplicitStep) -> Option<f64> {
        match self.elements.as_slice() {
            [] => Some(step.force),
            [one] => one.solve_implicit(step),
            _ => None,
        }
    }
}

/// No element: the linear structure alone.
#[derive(Clone, Copy, Debug, Default)]
pub struct NoElement;

impl Element for NoElement {
    #[inline]
    fn trial(&self, _x: f64, _v: f64) -> ElementForce {
        ElementForce::default()
    }
    #[inline]
    fn commit(&mut self, _x: f64, _v: f64) -> ElementForce {
        ElementForce::default()
    }
    fn reset(&mut self) {}
    fn has_memory(&self) -> bool {
        false
    }
    #[inline]
    fn solve_implicit(&self, step: &ImplicitStep) -> Option<f64> {
        Some(step.force)
    }
}

/// The sign of `x` as ±1 (0 maps to +1).
#[inline]
pub(crate) fn sign(x: f64) -> f64 {
    if x < 0.0 { -1.0 } else { 1.0 }
}

/// How an element kind is named in files and reports.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum ElementKind {
    /// Spring `kd` in series with a Coulomb slider `Fd`.
    Jenkins,
    /// Paper eq. (10) backbone with Masing rules.
    Masing,
    /// `k3 x³`.
    CubicStiffness,
    /// `c2 |v| v`.
    QuadraticDamping,
    /// `kb x` for `x > 0`, nothing for `x < 0`.
    BilinearStiffness,
    /// A two-sided gap: `k (|x| − gap) sign(x)` beyond the gap.
    Clearance,
    /// An extra viscous term `cj v`.
    ViscousDamping,
}

impl ElementKind {
    /// The snake-case name.
    pub fn name(self) -> &'static str {
        match self {
            ElementKind::Jenkins => "jenkins",
            ElementKind::Masing => "masing",
            ElementKind::CubicStiffness => "cubic_stiffness",
            ElementKind::QuadraticDamping => "quadratic_damping",
            ElementKind::BilinearStiffness => "bilinear_stiffness",
            ElementKind::Clearance => "clearance",
            ElementKind::ViscousDamping => "viscous_damping",
        }
    }
}

#[cfg(test)]
pub(crate) mod check {
    //! One checker run over every element (design lesson 5).
    use super::*;

    /// A displacement history with reversals of several sizes, including
    /// nested inner loops.
    pub fn history(scale: f64) -> Vec<f64> {
        let turning = [0.0, 1.0, -0.4, 0.6, -1.3, 0.2, -0.1, 1.5, -1.5, 0.3, 1.5];
        let mut xs = Vec::new();
        for w in turning.windows(2) {
            for i in 1..=40 {
                xs.push(scale * (w[0] + (w[1] - w[0]) * i as f64 / 40.0));
            }
        }
        xs
    }

    /// `trial` has no side effect and predicts `commit`; the tangent matches
    /// a one-sided finite difference in the direction of motion; `reset`
    /// restores the virgin response.
    pub fn check_element<E: Element + Clone>(mut e: E, scale: f64, force_scale: f64) {
        let xs = history(scale);
        let mut first = Vec::new();
        let mut prev = 0.0;
        for (i, &x) in xs.iter().enumerate() {
            let v = (x - prev) * 1000.0;
            let a = e.trial(x, v);
            let b = e.trial(x, v);
            assert_eq!(a, b, "trial changed the state at sample {i}");
            // tangent against a small step in the direction of motion (on a
            // clone: an element may cache its last exact trial)
            let dx = (x - prev) * 1e-4;
            if dx != 0.0 {
                let e = e.clone();
                let c = e.trial(x + dx, v);
                let fd = (c.force - a.force) / dx;
                let tol = 1e-3 * a.stiffness.abs().max(force_scale / scale) + 1e-9;
                // skip samples that straddle a kink (switch of branch)
                let d = e.trial(x + 2.0 * dx, v);
                let fd2 = (d.force - c.force) / dx;
                let b = e.trial(x - dx, v);
                let back = (a.force - b.force) / dx;
                if (fd2 - fd).abs() < tol && (back - fd).abs() < tol {
                    assert!(
                        (fd - a.stiffness).abs() < tol,
                        "tangent at {i}: fd {fd} vs {}",
                        a.stiffness
                    );
                }
            }
            let c = e.commit(x, v);
            assert_eq!(a, c, "commit differs from trial at sample {i}");
            first.push(c.force);
            prev = x;
        }
        e.reset();
        prev = 0.0;
        for (i, &x) in xs.iter().enumerate() {
            let v = (x - prev) * 1000.0;
            let c = e.commit(x, v);
            assert_eq!(
                c.force, first[i],
                "reset did not restore the virgin state at {i}"
            );
            prev = x;
        }
    }
}
