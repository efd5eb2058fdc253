//! Memoryless elements: the effects the diagnosis stage adds to a model.
//!
//! Each is a force law of the instantaneous `(x, v)` only. They are used, like
//! the hysteresis elements, unchanged by the simulator and by harmonic
//! balance.

use super::element::{Element, ElementForce};

/// Cubic stiffness `g = k3 x³` (hardening for `k3 > 0`, softening for `k3 < 0`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CubicStiffness {
    /// `k3`, N/m³.
    pub k3: f64,
}

impl Element for CubicStiffness {
    #[inline]
    fn trial(&self, x: f64, _v: f64) -> ElementForce {
        ElementForce {
            force: self.k3 * x * x * x,
            stiffness: 3.0 * self.k3 * x * x,
            damping: 0.0,
        }
    }
    #[inline]
    fn commit(&mut self, x: f64, v: f64) -> ElementForce {
        self.trial(x, v)
    }
    fn reset(&mut self) {}
    fn has_memory(&self) -> bool {
        false
    }
}

/// Quadratic (velocity-squared) damping `g = c2 |v| v`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct QuadraticDamping {
    /// `c2`, N s²/m².
    pub c2: f64,
}

impl Element for QuadraticDamping {
    #[inline]
    fn trial(&self, _x: f64, v: f64) -> ElementForce {
        ElementForce {
            force: self.c2 * v.abs() * v,
            stiffness: 0.0,
            damping: 2.0 * self.c2 * v.abs(),
        }
    }
    #[inline]
    fn commit(&mut self, x: f64, v: f64) -> ElementForce {
        self.trial(x, v)
    }
    fn reset(&mut self) {}
    fn has_memory(&self) -> bool {
        false
    }
    fn uses_velocity(&self) -> bool {
        true
    }
}

/// An extra stiffness acting on one side only: `g = kb x` for `x > 0`, 0 for
/// `x ≤ 0` (a contact that closes for positive displacement). Breaks the
/// half-wave symmetry: even harmonics and a static offset appear.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BilinearStiffness {
    /// `kb`, N/m.
    pub kb: f64,
}

impl Element for BilinearStiffness {
    #[inline]
    fn trial(&self, x: f64, _v: f64) -> ElementForce {
        if x > 0.0 {
            ElementForce {
                force: self.kb * x,
                stiffness: self.kb,
                damping: 0.0,
            }
        } else {
            ElementForce::default()
        }
    }
    #[inline]
    fn commit(&mut self, x: f64, v: f64) -> ElementForce {
        self.trial(x, v)
    }
    fn reset(&mut self) {}
    fn has_memory(&self) -> bool {
        false
    }
}

/// A symmetric clearance: a spring `k` that engages beyond `±gap`,
/// `g = k (|x| − gap) sign(x)` for `|x| > gap`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Clearance {
    /// Contact stiffness, N/m.
    pub k: f64,
    /// Gap, m.
    pub gap: f64,
}

impl Element for Clearance {
    #[inline]
    fn trial(&self, x: f64, _v: f64) -> ElementForce {
        if x > self.gap {
            ElementForce {
                force: self.k * (x - self.gap),
                stiffness: self.k,
                damping: 0.0,
            }
        } else if x < -self.gap {
            ElementForce {
                force: self.k * (x + self.gap),
                stiffness: self.k,
                damping: 0.0,
            }
        } else {
            ElementForce::default()
        }
    }
    #[inline]
    fn commit(&mut self, x: f64, v: f64) -> ElementForce {
        self.trial(x, v)
    }
    fn reset(&mut self) {}
    fn has_memory(&self) -> bool {
        false
    }
}

/// An extra viscous damper at the joint, `g = cj v`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ViscousDamping {
    /// `cj`, N s/m.
    pub cj: f64,
}

impl Element for ViscousDamping {
    #[inline]
    fn trial(&self, _x: f64, v: f64) -> ElementForce {
        ElementForce {
            force: self.cj * v,
            stiffness: 0.0,
            damping: self.cj,
        }
    }
    #[inline]
    fn commit(&mut self, x: f64, v: f64) -> ElementForce {
        self.trial(x, v)
    }
    fn reset(&mut self) {}
    fn has_memory(&self) -> bool {
        false
    }
    fn uses_velocity(&self) -> bool {
        true
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::element::check::check_element;

    #[test]
    fn pass_the_element_checker() {
        check_element(CubicStiffness { k3: 1e15 }, 1e-4, 1e3);
        check_element(CubicStiffness { k3: -1e15 }, 1e-4, 1e3);
        check_element(QuadraticDamping { c2: 50.0 }, 1e-4, 1.0);
        check_element(BilinearStiffness { kb: 5e6 }, 1e-4, 500.0);
        check_element(Clearance { k: 5e6, gap: 5e-5 }, 1e-4, 500.0);
        check_element(ViscousDamping { cj: 20.0 }, 1e-4, 1.0);
    }
}
