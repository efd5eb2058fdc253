//! A mass, spring and damper attached at the drive point: a shaker's moving
//! armature on its suspension, or a transducer's mass loading the structure.
//!
//! The attachment moves with the drive point, so it adds the dynamic stiffness
//!
//! ```text
//! Z_a(ω) = ks − ma ω² + jω cs
//! ```
//!
//! there, and the structure as driven has the receptance `H/(1 + H Z_a)`: its
//! modes move down (the armature's mass) and up (its suspension), each by its
//! modal constant at the drive point, so a light structure is changed more
//! than a heavy one (mass loading; McConnell & Varoto, *Vibration Testing*,
//! 2nd ed., ch. 6). With a voltage reference it is the shaker's armature, on
//! which the coil's force acts ([`crate::model::Shaker`]); with a force
//! reference, whatever sits between the force gauge and the structure.
//!
//! **How the stages see it.** The attachment is linear, so harmonic balance
//! takes it exactly, harmonic by harmonic, in the receptance (see
//! `hb::linear::Driven`). The digital-filter simulator takes it inside each
//! sample's implicit equation: the filters give `x`, `v` and `a` affine in
//! the sample's net input `u`, so `u = F − g − ma a − cs v − ks x` is solved
//! for `u` with the joint (see `sim`), as exact as the joint itself. Its
//! march exerts nothing (it is not a force law of `x` and `v` alone: the
//! mass needs the acceleration). Beside a hysteretic mode it would couple the
//! mode to the point structure, which is not modelled: such a model is
//! refused.
//!
//! For one mode the attachment is the same as adding `ma`, `cs`, `ks` to the
//! mode's mass, damping and stiffness: a voltage or a force alone cannot tell
//! them apart. Over several modes it shifts each by its own modal constant.

use super::element::{
    Attachment, Description, Domain, Element, ElementForce, FitScale, Law, ParameterInfo, Role,
};
use crate::error::Result;
use num_complex::Complex64;

/// Why a model with an armature beside a hysteretic mode is refused (by
/// `Model::validate` and the simulator alike).
pub(crate) const BESIDE_A_HYSTERETIC_MODE: &str = "an armature beside a hysteretic mode would \
     couple the mode to the point structure, which is not modelled: put the mode's joint on the \
     point structure or leave the armature out";

/// A mass on a spring and damper at the drive point (see the module docs).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Armature {
    /// The attachment, as the stages see it.
    pub attachment: Attachment,
}

impl Element for Armature {
    /// Nothing in the march: the stages take it through the linear part.
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
        Self::DESCRIPTION.memory
    }
    fn odd_law(&self) -> bool {
        Self::DESCRIPTION.odd
    }
    fn describing_function(&mut self, _amplitude: f64, _omega: f64, _samples: usize) -> Complex64 {
        Complex64::new(0.0, 0.0)
    }
    fn attachment(&self) -> Option<Attachment> {
        Some(self.attachment)
    }
}

impl Law for Armature {
    const DESCRIPTION: Description = Description {
        name: "armature",
        summary: "a mass on a spring and damper attached at the drive point (a shaker's \
                  armature on its suspension, a transducer's mass loading): Z = ks - ma w^2 + j w cs",
        parameters: &[
            ParameterInfo {
                name: "ma",
                unit: "kg",
                meaning: "armature mass, moving with the drive point",
                domain: Domain::NonNegative,
                scale: FitScale::Linear,
                role: Role::Other,
                start: 0.0,
            },
            ParameterInfo {
                name: "ks",
                unit: "N/m",
                meaning: "suspension stiffness to the ground",
                domain: Domain::NonNegative,
                scale: FitScale::Linear,
                role: Role::Other,
                start: 0.0,
            },
            ParameterInfo {
                name: "cs",
                unit: "N s/m",
                meaning: "suspension damping to the ground",
                domain: Domain::NonNegative,
                scale: FitScale::Linear,
                role: Role::Other,
                start: 0.0,
            },
        ],
        memory: false,
        odd: true,
        samples_per_period: 0,
        smooth_samples: Some(|_| 0),
        example: &[2.0, 2e5, 30.0],
    };

    fn from_parameters(values: &[f64]) -> Result<Self> {
        Ok(Armature {
            attachment: Attachment {
                mass: values[0],
                stiffness: values[1],
                damping: values[2],
            },
        })
    }
}
