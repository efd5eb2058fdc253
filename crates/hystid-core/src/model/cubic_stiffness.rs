//! Cubic stiffness, `g = k3 x³`: a hardening (or softening) spring, the
//! effect a structure's geometric nonlinearity or a contact's Hertzian
//! stiffening adds at the higher levels.

use super::element::{
    Description, Domain, Element, ElementForce, FitScale, Law, ParameterInfo, Role,
};
use crate::error::Result;
use num_complex::Complex64;

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
        Self::DESCRIPTION.memory
    }
    fn odd_law(&self) -> bool {
        Self::DESCRIPTION.odd
    }
    /// `x = a cos θ`: the fundamental of `k3 a³ cos³ θ` is `¾ k3 a³`.
    fn describing_function(&mut self, amplitude: f64, _omega: f64, _samples: usize) -> Complex64 {
        Complex64::new(0.75 * self.k3 * amplitude * amplitude, 0.0)
    }
}

impl Law for CubicStiffness {
    const DESCRIPTION: Description = Description {
        name: "cubic_stiffness",
        summary: "a cubic spring k3 x³ (hardening for k3 > 0, softening for k3 < 0)",
        parameters: &[ParameterInfo {
            name: "k3",
            unit: "N/m³",
            meaning: "cubic stiffness",
            domain: Domain::Signed,
            scale: FitScale::Linear,
            role: Role::Other,
            start: 0.0,
        }],
        memory: false,
        odd: true,
        samples_per_period: 0,
        smooth_samples: Some(|_| 0),
        example: &[1e15],
    };

    fn from_parameters(values: &[f64]) -> Result<Self> {
        Ok(CubicStiffness { k3: values[0] })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::element::check::check_element;

    #[test]
    fn passes_the_element_checker() {
        check_element(CubicStiffness { k3: 1e15 }, 1e-4, 1e3);
        check_element(CubicStiffness { k3: -1e15 }, 1e-4, 1e3);
    }
}
