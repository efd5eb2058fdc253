//! The one Fourier convention used everywhere in hystid.
//!
//! * Time convention `e^{+jωt}`: a periodic signal with fundamental `ω` is
//!   `y(t) = Y_0 + Re Σ_{h≥1} Y_h e^{j h ω t}`.
//! * Amplitudes are single-sided: `|Y_h|` is the amplitude of harmonic `h`
//!   (not RMS, not half), and `Y_0` is the mean (DC, real).
//! * Harmonic index `h = 1` is the excitation frequency.
//! * A (nonlinear) FRF is `H_h = Y_h / (F_1 u^(h−1))`, `u = F_1/|F_1|`: the
//!   response's harmonic `h` divided by the *measured* force fundamental and
//!   referred to the force's phase, i.e. the response to a force
//!   `|F_1| cos ωt` (harmonic balance's forcing). Moving the time origin by
//!   `τ` turns `Y_h` by `e^{jhωτ}` and `F_1` by `e^{jωτ}`: `Y_h/F_1` alone
//!   would keep `e^{j(h−1)ωτ}` of it for `h ≠ 1`, so a recording whose
//!   analysis window does not start at a force maximum would have its `H_2`,
//!   `H_3`, ... turned by an arbitrary angle (see [`referred_to_force`]).
//!   Phases are of the response relative to the force.
//! * SI units throughout: N, m, m/s, m/s², Hz for frequencies the user sees,
//!   rad/s inside the formulas.
//!
//! This module also names the physical quantities a channel or a model output
//! can carry, and converts a receptance into mobility or accelerance.

use num_complex::Complex64;
use serde::{Deserialize, Serialize};
use std::f64::consts::PI;

/// The physical quantity of a signal.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Quantity {
    /// Force, N.
    Force,
    /// Displacement, m.
    Displacement,
    /// Velocity, m/s.
    Velocity,
    /// Acceleration, m/s².
    Acceleration,
    /// Voltage (e.g. a shaker amplifier's drive), V.
    Voltage,
}

impl Quantity {
    /// Every quantity, in the order messages list them.
    pub const ALL: [Quantity; 5] = [
        Quantity::Force,
        Quantity::Displacement,
        Quantity::Velocity,
        Quantity::Acceleration,
        Quantity::Voltage,
    ];

    /// The names of [`Quantity::ALL`], comma separated, for messages.
    pub fn names() -> String {
        Quantity::ALL.map(Quantity::name).join(", ")
    }

    /// The SI unit text used in recordings.
    pub fn si_unit(self) -> &'static str {
        match self {
            Quantity::Force => "N",
            Quantity::Displacement => "m",
            Quantity::Velocity => "m/s",
            Quantity::Acceleration => "m/s^2",
            Quantity::Voltage => "V",
        }
    }

    /// The name used in recordings and TOML files.
    pub fn name(self) -> &'static str {
        match self {
            Quantity::Force => "force",
            Quantity::Displacement => "displacement",
            Quantity::Velocity => "velocity",
            Quantity::Acceleration => "acceleration",
            Quantity::Voltage => "voltage",
        }
    }

    /// Parses a recording's quantity name.
    pub fn from_name(name: &str) -> Option<Quantity> {
        Quantity::ALL.into_iter().find(|q| q.name() == name)
    }

    /// Whether this is a motion (response) quantity.
    pub fn is_motion(self) -> bool {
        matches!(
            self,
            Quantity::Displacement | Quantity::Velocity | Quantity::Acceleration
        )
    }

    /// The factor `(jω)^p` that turns a displacement harmonic at angular
    /// frequency `omega` into this quantity's harmonic (1 for displacement,
    /// `jω` for velocity, `-ω²` for acceleration).
    ///
    /// # Panics
    /// For `Force` and `Voltage`, which are not motions.
    pub fn from_displacement(self, omega: f64) -> Complex64 {
        match self {
            Quantity::Displacement => Complex64::new(1.0, 0.0),
            Quantity::Velocity => Complex64::new(0.0, omega),
            Quantity::Acceleration => Complex64::new(-omega * omega, 0.0),
            Quantity::Force | Quantity::Voltage => {
                panic!("{} is not a motion quantity", self.name())
            }
        }
    }
}

impl std::fmt::Display for Quantity {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

/// `y_h` referred to the phase of the force fundamental `f1`: `y_h u^(1−h)`
/// with `u = f1/|f1|` (the module's FRF convention; `h = 1` and a force at
/// phase 0 leave `y_h` as it is). Divide by `|f1|` for the FRF.
#[inline]
pub fn referred_to_force(y_h: Complex64, h: usize, f1: Complex64) -> Complex64 {
    let n = f1.norm();
    if h == 1 || !(n > 0.0) {
        return y_h;
    }
    let u = f1 / n;
    y_h * u.powi(1 - h as i32)
}

/// Angular frequency in rad/s from a frequency in Hz.
#[inline]
pub fn omega(frequency_hz: f64) -> f64 {
    2.0 * PI * frequency_hz
}

/// `sinc(u) = sin(πu)/(πu)`, with `sinc(0) = 1`.
pub fn sinc(u: f64) -> f64 {
    if u.abs() < 1e-8 {
        1.0 - (PI * u).powi(2) / 6.0
    } else {
        (PI * u).sin() / (PI * u)
    }
}

/// Evaluates `Y_0 + Re Σ_h Y_h e^{j h θ}` at phase `theta` (rad) for harmonics
/// `0..Y.len()`.
pub fn synthesize(harmonics: &[Complex64], theta: f64) -> f64 {
    let mut y = 0.0;
    for (h, yh) in harmonics.iter().enumerate() {
        if h == 0 {
            y += yh.re;
        } else {
            let (s, c) = (h as f64 * theta).sin_cos();
            y += yh.re * c - yh.im * s;
        }
    }
    y
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn synthesize_follows_the_convention() {
        // 2 cos(θ + 0.3) + 0.5 = Re(2 e^{j0.3} e^{jθ}) + 0.5
        let y = [Complex64::new(0.5, 0.0), Complex64::from_polar(2.0, 0.3)];
        for k in 0..10 {
            let th = k as f64 * 0.7;
            assert!((synthesize(&y, th) - (0.5 + 2.0 * (th + 0.3).cos())).abs() < 1e-12);
        }
    }

    #[test]
    fn quantity_names_round_trip() {
        for q in Quantity::ALL {
            assert_eq!(Quantity::from_name(q.name()), Some(q));
        }
    }
}
