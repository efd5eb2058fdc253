//! Quadratic (velocity-squared) damping, `g = c2 |v| v`: losses that grow
//! faster than viscous damping with the response (air or fluid drag, a
//! rattling part).

use super::element::{
    Description, Domain, Element, ElementForce, FitScale, Law, ParameterInfo, Role,
};
use crate::error::Result;
use num_complex::Complex64;
use std::f64::consts::PI;

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
        Self::DESCRIPTION.memory
    }
    fn odd_law(&self) -> bool {
        Self::DESCRIPTION.odd
    }
    /// `v = −aω sin θ`: the fundamental of `c2 |v| v` is `(8/3π) c2 a² ω²`
    /// in quadrature with the displacement.
    fn describing_function(&mut self, amplitude: f64, omega: f64, _samples: usize) -> Complex64 {
        Complex64::new(
            0.0,
            8.0 / (3.0 * PI) * self.c2 * amplitude.abs() * omega * omega,
        )
    }
    fn uses_velocity(&self) -> bool {
        true
    }
}

impl Law for QuadraticDamping {
    const DESCRIPTION: Description = Description {
        name: "quadratic_damping",
        summary: "velocity-squared damping c2 |v| v (air, fluid or impact losses)",
        parameters: &[ParameterInfo {
            name: "c2",
            unit: "N s²/m²",
            meaning: "quadratic damping coefficient",
            domain: Domain::NonNegative,
            scale: FitScale::Linear,
            role: Role::Other,
            start: 0.0,
        }],
        memory: false,
        odd: true,
        samples_per_period: 0,
        smooth_samples: None,
        example: &[50.0],
    };

    fn from_parameters(values: &[f64]) -> Result<Self> {
        Ok(QuadraticDamping { c2: values[0] })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::element::check::check_element;

    #[test]
    fn passes_the_element_checker() {
        check_element(QuadraticDamping { c2: 50.0 }, 1e-4, 1.0);
    }
}
