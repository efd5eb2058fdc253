//! A one-sided contact, `g = kb x` for `x > 0`: the stiffness of a support or
//! a second part that the structure touches on one side only. It breaks the
//! half-wave symmetry: even harmonics and a static offset appear.

use super::element::{
    Description, Domain, Element, ElementForce, FitScale, Law, ParameterInfo, Role,
};
use crate::error::Result;

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
        Self::DESCRIPTION.memory
    }
    fn odd_law(&self) -> bool {
        Self::DESCRIPTION.odd
    }
}

impl Law for BilinearStiffness {
    const DESCRIPTION: Description = Description {
        name: "bilinear_stiffness",
        summary: "a one-sided contact stiffness kb x for x > 0, nothing for x ≤ 0",
        parameters: &[ParameterInfo {
            name: "kb",
            unit: "N/m",
            meaning: "contact stiffness on the positive side",
            domain: Domain::Signed,
            scale: FitScale::Linear,
            role: Role::Other,
            start: 0.0,
        }],
        memory: false,
        odd: false,
        samples_per_period: 0,
        smooth_samples: None,
        example: &[5e6],
    };

    fn from_parameters(values: &[f64]) -> Result<Self> {
        Ok(BilinearStiffness { kb: values[0] })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::element::check::check_element;

    #[test]
    fn passes_the_element_checker() {
        check_element(BilinearStiffness { kb: 5e6 }, 1e-4, 500.0);
    }
}
