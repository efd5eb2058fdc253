//! An extra viscous damper at the joint, `g = cj v`.

use super::element::{
    Description, Domain, Element, ElementForce, FitScale, Law, ParameterInfo, Role,
};
use crate::error::Result;
use num_complex::Complex64;

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
        Self::DESCRIPTION.memory
    }
    fn odd_law(&self) -> bool {
        Self::DESCRIPTION.odd
    }
    fn describing_function(&mut self, _amplitude: f64, omega: f64, _samples: usize) -> Complex64 {
        Complex64::new(0.0, self.cj * omega)
    }
    fn uses_velocity(&self) -> bool {
        true
    }
}

impl Law for ViscousDamping {
    const DESCRIPTION: Description = Description {
        name: "viscous_damping",
        summary: "an extra viscous damper cj v at the joint",
        parameters: &[ParameterInfo {
            name: "cj",
            unit: "N s/m",
            meaning: "viscous damping coefficient",
            domain: Domain::NonNegative,
            scale: FitScale::Linear,
            role: Role::Other,
            start: 0.0,
        }],
        memory: false,
        odd: true,
        samples_per_period: 0,
        smooth_samples: Some(|_| 0),
        example: &[20.0],
    };

    fn from_parameters(values: &[f64]) -> Result<Self> {
        Ok(ViscousDamping { cj: values[0] })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::element::check::check_element;

    #[test]
    fn passes_the_element_checker() {
        check_element(ViscousDamping { cj: 20.0 }, 1e-4, 1.0);
    }
}
