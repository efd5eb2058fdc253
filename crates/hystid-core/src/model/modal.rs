//! The underlying linear structure: modes seen at one point.
//!
//! The structure is described, as in the digital-filter method (Ahlin,
//! Magnevall & Josefsson, ISMA 2006; the paper's ref. [1]), by its modes at
//! the drive point, which is also the joint's and the response's point:
//!
//! ```text
//! H(ω) = X/F = Σ_r  R_r / (ω_r² − ω² + 2 j ζ_r ω_r ω)
//! ```
//!
//! with `R_r = 1/m_r` the modal constant (residue) of mode `r`. A single mode
//! with `R = 1/m`, `ω_r = √(k/m)`, `ζ = c/(2√(km))` is exactly the paper's SDOF
//! `1/(k − mω² + jcω)` (eq. 1). Damping is viscous per mode and below critical.
//!
//! A mode may carry a joint of its own, a **hysteretic mode** (the modal
//! joint of modal Iwan models: Segalman 2006; Deaner, Allen et al. 2015): its
//! contribution `x_r` at the point is then an SDOF of its own, mass `1/|R|`,
//! stiffness `ω_r²/|R|`, damping `2ζω_r/|R|`, driven by the force and held
//! by its joint acting on `|x_r|`'s coordinate (a negative modal constant
//! turns the contribution over). It is uncoupled from the other modes: the
//! model's own joint and effects act on the sum of the other modes, the
//! **point structure** ([`ModalModel::point_part`]); the response is the
//! point structure's plus every hysteretic mode's.

use crate::error::{Error, Result, require_positive};
use crate::harmonics::{Quantity, omega};
use num_complex::Complex64;
use serde::{Deserialize, Serialize};
use std::f64::consts::PI;

/// One real normal mode seen at the drive/response point.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Mode {
    /// Undamped natural frequency, Hz.
    pub frequency_hz: f64,
    /// Viscous damping ratio ζ (0 ≤ ζ < 1).
    pub damping_ratio: f64,
    /// Modal constant `R = 1/m_r`, in 1/kg (m/N per (rad/s)²). May be negative
    /// for a transfer (non-point) response.
    pub residue: f64,
    /// The mode's own joint (a hysteretic mode, see the module docs); `None`:
    /// a linear mode of the point structure.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub joint: Option<crate::model::ElementSpec>,
}

impl Mode {
    /// The mode of an SDOF mass-spring-damper, from `m`, `c`, `k`.
    pub fn from_mck(mass: f64, damping: f64, stiffness: f64) -> Result<Mode> {
        require_positive("system.mass", mass)?;
        require_positive("system.stiffness", stiffness)?;
        if !(damping.is_finite() && damping >= 0.0) {
            return Err(Error::model(
                "system.damping",
                format!("must be a finite number >= 0, got {damping}"),
            ));
        }
        let wn = (stiffness / mass).sqrt();
        let zeta = damping / (2.0 * (stiffness * mass).sqrt());
        let mode = Mode {
            frequency_hz: wn / (2.0 * PI),
            damping_ratio: zeta,
            residue: 1.0 / mass,
            joint: None,
        };
        mode.validate("system")?;
        Ok(mode)
    }

    /// A mode from natural frequency, damping ratio and modal mass.
    pub fn from_modal_mass(frequency_hz: f64, damping_ratio: f64, modal_mass: f64) -> Result<Mode> {
        if !(modal_mass.is_finite() && modal_mass != 0.0) {
            return Err(Error::model(
                "modal_mass",
                format!("must be finite and non-zero, got {modal_mass}"),
            ));
        }
        let mode = Mode {
            frequency_hz,
            damping_ratio,
            residue: 1.0 / modal_mass,
            joint: None,
        };
        mode.validate("mode")?;
        Ok(mode)
    }

    /// Checks the parameters; `at` names the mode in the message.
    pub fn validate(&self, at: &str) -> Result<()> {
        require_positive(&format!("{at}.frequency_hz"), self.frequency_hz)?;
        if !(self.damping_ratio.is_finite() && (0.0..1.0).contains(&self.damping_ratio)) {
            return Err(Error::model(
                format!("{at}.damping_ratio"),
                format!(
                    "must be in [0, 1) (underdamped), got {}",
                    self.damping_ratio
                ),
            ));
        }
        if !(self.residue.is_finite() && self.residue != 0.0) {
            return Err(Error::model(
                format!("{at}.residue"),
                format!("must be finite and non-zero, got {}", self.residue),
            ));
        }
        if let Some(j) = &self.joint {
            if !j.description().is_joint() {
                return Err(Error::model(
                    format!("{at}.joint"),
                    format!(
                        "`{}` is not a joint law (a hysteretic mode carries a joint)",
                        j.kind().name()
                    ),
                ));
            }
            j.validate(&format!("{at}.joint"))?;
        }
        Ok(())
    }

    /// A hysteretic mode's own SDOF: the bare mode with `|R|`, and the sign
    /// its contribution takes at the point.
    pub fn own_sdof(&self) -> (f64, ModalModel) {
        let m = Mode {
            residue: self.residue.abs(),
            joint: None,
            ..*self
        };
        (self.residue.signum(), ModalModel { modes: vec![m] })
    }

    /// Whether the mode carries its own joint.
    pub fn is_hysteretic(&self) -> bool {
        self.joint.is_some()
    }

    /// Whether a replay whose threshold is `above_hz` takes this mode
    /// quasi-static, its flexibility alone: a linear mode above it (see
    /// [`crate::validate::QUASI_STATIC_ABOVE_RATE`]).
    pub fn is_quasi_static_above(&self, above_hz: f64) -> bool {
        !self.is_hysteretic() && self.frequency_hz > above_hz
    }

    /// Undamped natural angular frequency ω_r, rad/s.
    pub fn omega(&self) -> f64 {
        omega(self.frequency_hz)
    }

    /// Modal mass `1/R`.
    pub fn modal_mass(&self) -> f64 {
        1.0 / self.residue
    }

    /// Modal stiffness `ω_r²/R`.
    pub fn modal_stiffness(&self) -> f64 {
        self.omega().powi(2) / self.residue
    }

    /// Static flexibility `R/ω_r²` (m/N): what a mode above a measured band
    /// adds there (the residual flexibility of modal analysis).
    pub fn static_flexibility(&self) -> f64 {
        self.residue / self.omega().powi(2)
    }

    /// Modal viscous damping `2ζω_r/R`.
    pub fn modal_damping(&self) -> f64 {
        2.0 * self.damping_ratio * self.omega() / self.residue
    }

    /// Receptance of this mode alone at angular frequency `w`.
    pub fn receptance(&self, w: f64) -> Complex64 {
        let wr = self.omega();
        Complex64::new(self.residue, 0.0)
            / Complex64::new(wr * wr - w * w, 2.0 * self.damping_ratio * wr * w)
    }
}

/// The underlying linear structure: a sum of modes at one point.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ModalModel {
    /// The modes, any order.
    pub modes: Vec<Mode>,
}

impl ModalModel {
    /// A model from modes; checks them.
    pub fn new(modes: Vec<Mode>) -> Result<ModalModel> {
        let model = ModalModel { modes };
        model.validate()?;
        Ok(model)
    }

    /// The SDOF model `m x'' + c x' + k x = F` (paper eq. 1 without the element).
    pub fn sdof(mass: f64, damping: f64, stiffness: f64) -> Result<ModalModel> {
        Ok(ModalModel {
            modes: vec![Mode::from_mck(mass, damping, stiffness)?],
        })
    }

    /// Checks every mode.
    pub fn validate(&self) -> Result<()> {
        if self.modes.is_empty() {
            return Err(Error::model("modes", "at least one mode is needed"));
        }
        for (i, m) in self.modes.iter().enumerate() {
            m.validate(&format!("modes[{i}]"))?;
        }
        Ok(())
    }

    /// The modes the joint and effects act on: every mode without a joint
    /// of its own (see the module docs; may be none).
    pub fn point_part(&self) -> ModalModel {
        ModalModel {
            modes: self
                .modes
                .iter()
                .filter(|m| !m.is_hysteretic())
                .copied()
                .collect(),
        }
    }

    /// How fits and reports name mode `i` (`i ≥ 1`; the first mode is the
    /// SDOF, `mass`, `damping`, `stiffness`): `second_mode`, `mode_2`, ...,
    /// and a hysteretic mode `hysteretic_mode` (then `hysteretic_mode_2`,
    /// ... in order).
    pub fn label(&self, i: usize) -> String {
        if self.modes.get(i).is_some_and(Mode::is_hysteretic) {
            let k = self.modes[..i].iter().filter(|m| m.is_hysteretic()).count();
            if k == 0 {
                "hysteretic_mode".into()
            } else {
                format!("hysteretic_mode_{}", k + 1)
            }
        } else if i == 1 {
            "second_mode".into()
        } else {
            format!("mode_{i}")
        }
    }

    /// Whether any mode carries a joint of its own.
    pub fn has_hysteretic_modes(&self) -> bool {
        self.modes.iter().any(Mode::is_hysteretic)
    }

    /// Receptance `X/F` at angular frequency `w` (rad/s), every mode taken
    /// as linear (a hysteretic mode without its joint: fully slipped).
    pub fn receptance(&self, w: f64) -> Complex64 {
        self.modes.iter().map(|m| m.receptance(w)).sum()
    }

    /// The FRF of a motion quantity per force at `w`: receptance, mobility or
    /// accelerance.
    pub fn frf(&self, quantity: Quantity, w: f64) -> Complex64 {
        self.receptance(w) * quantity.from_displacement(w)
    }

    /// Static compliance `H(0)`, m/N.
    pub fn static_compliance(&self) -> f64 {
        self.modes
            .iter()
            .map(|m| m.residue / m.omega().powi(2))
            .sum()
    }

    /// Highest natural frequency, Hz.
    pub fn highest_frequency_hz(&self) -> f64 {
        self.modes
            .iter()
            .map(|m| m.frequency_hz)
            .fold(0.0, f64::max)
    }

    /// Smallest decay rate `ζ_r ω_r` over the modes, 1/s (sets settling times).
    pub fn slowest_decay_rate(&self) -> f64 {
        self.modes
            .iter()
            .map(|m| m.damping_ratio * m.omega())
            .fold(f64::INFINITY, f64::min)
    }

    /// For a single-mode model, its `(m, c, k)`; `None` with more modes.
    pub fn as_mck(&self) -> Option<(f64, f64, f64)> {
        match self.modes.as_slice() {
            [m] => Some((m.modal_mass(), m.modal_damping(), m.modal_stiffness())),
            _ => None,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sdof_receptance_is_the_paper_impedance_inverse() {
        let (m, c, k) = (10.0, 200.0, 1.0e7);
        let model = ModalModel::sdof(m, c, k).unwrap();
        for f in [0.0, 50.0, 159.0, 300.0, 1000.0] {
            let w = omega(f);
            let z = Complex64::new(k - m * w * w, c * w);
            let h = model.receptance(w);
            assert!((h * z - 1.0).norm() < 1e-12, "f={f}");
        }
        let (m2, c2, k2) = model.as_mck().unwrap();
        assert!((m2 / m - 1.0).abs() < 1e-14);
        assert!((c2 / c - 1.0).abs() < 1e-12);
        assert!((k2 / k - 1.0).abs() < 1e-14);
        assert!((model.static_compliance() * k - 1.0).abs() < 1e-14);
    }

    #[test]
    fn bad_parameters_are_errors() {
        assert!(ModalModel::sdof(-1.0, 1.0, 1.0).is_err());
        assert!(ModalModel::sdof(0.0, 1.0, 1.0).is_err());
        assert!(ModalModel::sdof(1.0, -1.0, 1.0).is_err());
        assert!(ModalModel::sdof(1.0, f64::NAN, 1.0).is_err());
        let e = ModalModel::sdof(1.0, 10.0, 1.0).unwrap_err().to_string();
        assert!(e.contains("damping_ratio"), "{e}");
    }
}
