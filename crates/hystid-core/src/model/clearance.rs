//! A symmetric clearance, `g = k (|x| − gap) sign(x)` beyond `±gap`: free
//! play that closes on both sides at the larger levels (a loose bolt, a
//! bearing's play).

use super::element::{
    Description, Domain, Element, ElementForce, FitScale, Law, ParameterInfo, Role,
};
use crate::error::Result;

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
        Self::DESCRIPTION.memory
    }
    fn odd_law(&self) -> bool {
        Self::DESCRIPTION.odd
    }
}

impl Law for Clearance {
    const DESCRIPTION: Description = Description {
        name: "clearance",
        summary: "a spring k engaging beyond a symmetric gap ±gap",
        parameters: &[
            ParameterInfo {
                name: "k",
                unit: "N/m",
                meaning: "contact stiffness beyond the gap",
                domain: Domain::NonNegative,
                scale: FitScale::Log,
                role: Role::Other,
                start: 0.0,
            },
            ParameterInfo {
                name: "gap",
                unit: "m",
                meaning: "half-width of the free play",
                domain: Domain::NonNegative,
                scale: FitScale::Linear,
                role: Role::Other,
                start: 0.0,
            },
        ],
        memory: false,
        odd: true,
        samples_per_period: 0,
        smooth_samples: None,
        example: &[5e6, 5e-6],
    };

    fn from_parameters(values: &[f64]) -> Result<Self> {
        Ok(Clearance {
            k: values[0],
            gap: values[1],
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::element::check::check_element;

    #[test]
    fn passes_the_element_checker() {
        check_element(Clearance { k: 5e6, gap: 5e-5 }, 1e-4, 500.0);
    }
}
