//! An electrodynamic shaker between the amplifier's voltage and the
//! structure: the standard lumped model of its coil and magnet.
//!
//! With a voltage reference `e` the structure is not driven by a known force.
//! The coil (resistance `R`, inductance `L`, force factor `Bl`) obeys
//! `L i' + R i + Bl v = e` and pushes with `Bl i`, so the force on the
//! structure is
//!
//! ```text
//! F = (Bl/R) · (e − Bl v) / (1 + s τe),      τe = L/R
//! ```
//!
//! the drive lagged by the coil's electrical time constant, less the back-EMF
//! force: a damper `ce = Bl²/R` at the drive point, lagged the same way. Near
//! a resonance the structure's velocity is largest, so the force drops there
//! (the classic force drop of a voltage-driven test). A model identified from
//! the voltage has its forces in the drive's unit, `F·R/Bl`, in which the
//! gain is 1 and `ce` is `Bl` (V s/m). The armature's mass and suspension
//! move with the drive point: an effect of their own,
//! [`crate::model::Armature`].
//!
//! **How the stages see it.** The shaker is linear, so harmonic balance takes
//! it exactly, harmonic by harmonic, as [`DriveLoad`]: the drive reaches the
//! structure through `D(ω) = 1/(1 + jωτe)` and the back-EMF adds the dynamic
//! stiffness `Z(ω) = jω ce/(1 + jωτe)` at the drive point (see
//! `hb::linear::Driven`). Its march there exerts nothing: harmonic balance
//! gives no time step. The digital-filter simulator gives one
//! ([`Element::set_time_step`]); the element then carries the lagged
//! back-EMF force sample by sample, and the simulator lags its drive by the
//! same first-order filter. Both filters are ramp-invariant, as the
//! structure's own sections are: exact for a drive and a velocity linear
//! between samples.
//!
//! **With hysteretic modes** (each an SDOF of its own, balanced and
//! simulated apart: `Model::parts`) the lag drives every part alike, exactly,
//! but the back-EMF answers the point structure's motion only, an
//! approximation: coupling it to the hysteretic modes' motion would couple
//! the parts. Harmonic balance and the simulator make the same one.
//!
//! **What a voltage alone tells.** At one frequency the back-EMF damping is
//! the modes' own viscous damping; only its lag's frequency dependence tells
//! them apart, so over a band around one mode `ce` is poorly determined
//! while `te` (a phase the modes' real modal constants cannot make) is well
//! determined.
//!
//! Reference: the lumped electrodynamic shaker of McConnell & Varoto,
//! *Vibration Testing*, 2nd ed., ch. 6 (force drop at resonance), and Olsen,
//! "Using and understanding electrodynamic shakers in modal applications",
//! IMAC IV (1986).

use super::element::{
    Description, Domain, DriveLoad, Element, ElementForce, FitScale, Law, ParameterInfo, Role,
};
use crate::error::Result;
use num_complex::Complex64;

/// The shaker's back-EMF at the drive point, lagged by the coil (see the
/// module docs).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Shaker {
    /// Back-EMF damping `ce = Bl²/R` (in the drive's unit: `Bl`), N s/m.
    pub ce: f64,
    /// Electrical time constant `τe = L/R`, s.
    pub te: f64,
    /// The lag of the back-EMF force, marched by the simulator.
    lag: Lag,
}

/// A first-order lag `1/(1 + sτ)`, discretised ramp-invariantly: with the
/// input linear over a sample of length `h`,
/// `y₁ = a y₀ + (1 − a − c) w₀ + c w₁`, `a = e^{−h/τ}`, `c = 1 − (τ/h)(1 − a)`
/// (exact for such an input; `c → 1` as `τ/h → 0`).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Lag {
    a: f64,
    c: f64,
    /// Output at the last committed sample.
    y: f64,
    /// Input at the last committed sample.
    w: f64,
    /// Whether a time step was given (else the lag passes nothing).
    on: bool,
}

impl Lag {
    /// The lag with time constant `tau` (s) at time step `h` (s).
    pub fn new(tau: f64, h: f64) -> Lag {
        if !(h > 0.0 && h.is_finite()) {
            return Lag::default();
        }
        let r = h / tau.max(0.0);
        // 1 − a without cancellation; τ = 0 passes the input through
        let one_minus_a = if r.is_finite() { -(-r).exp_m1() } else { 1.0 };
        let c = if r.is_finite() {
            1.0 - one_minus_a / r
        } else {
            1.0
        };
        Lag {
            a: 1.0 - one_minus_a,
            c,
            y: 0.0,
            w: 0.0,
            on: true,
        }
    }

    /// The output if the input at this sample were `w` (`dy/dw = c`).
    #[inline]
    pub fn trial(&self, w: f64) -> f64 {
        self.a * self.y + (1.0 - self.a - self.c) * self.w + self.c * w
    }

    /// Accepts `w` as this sample's input; returns the output.
    #[inline]
    pub fn commit(&mut self, w: f64) -> f64 {
        self.y = self.trial(w);
        self.w = w;
        self.y
    }

    /// The direct term `dy/dw`.
    #[inline]
    pub fn direct(&self) -> f64 {
        self.c
    }

    /// Whether a time step was given.
    pub fn is_on(&self) -> bool {
        self.on
    }

    /// Back to rest.
    pub fn reset(&mut self) {
        self.y = 0.0;
        self.w = 0.0;
    }
}

impl Shaker {
    /// The shaker with back-EMF damping `ce` and time constant `te`.
    pub fn new(ce: f64, te: f64) -> Shaker {
        Shaker {
            ce,
            te,
            lag: Lag::default(),
        }
    }
}

impl Element for Shaker {
    #[inline]
    fn trial(&self, _x: f64, v: f64) -> ElementForce {
        if !self.lag.on {
            return ElementForce::default();
        }
        ElementForce {
            force: self.lag.trial(self.ce * v),
            stiffness: 0.0,
            damping: self.lag.direct() * self.ce,
        }
    }
    #[inline]
    fn commit(&mut self, x: f64, v: f64) -> ElementForce {
        let f = self.trial(x, v);
        if self.lag.on {
            self.lag.commit(self.ce * v);
        }
        f
    }
    fn reset(&mut self) {
        self.lag.reset();
    }
    /// In the simulator only: harmonic balance takes the shaker through its
    /// [`DriveLoad`].
    fn has_memory(&self) -> bool {
        self.lag.on
    }
    fn uses_velocity(&self) -> bool {
        self.lag.on
    }
    fn odd_law(&self) -> bool {
        Self::DESCRIPTION.odd
    }
    fn describing_function(&mut self, _amplitude: f64, _omega: f64, _samples: usize) -> Complex64 {
        Complex64::new(0.0, 0.0)
    }
    fn set_time_step(&mut self, h: f64) {
        self.lag = Lag::new(self.te, h);
    }
    fn drive_load(&self) -> Option<DriveLoad> {
        Some(DriveLoad {
            back_emf: self.ce,
            time_constant: self.te,
        })
    }
}

impl Law for Shaker {
    const DESCRIPTION: Description = Description {
        name: "shaker",
        summary: "an electrodynamic shaker between a voltage drive and the structure: its coil's \
                  lag te = L/R on the drive and its back-EMF damping ce = Bl²/R, lagged alike",
        parameters: &[
            ParameterInfo {
                name: "ce",
                unit: "N s/m",
                meaning: "back-EMF damping Bl²/R (Bl in the drive's unit)",
                domain: Domain::NonNegative,
                scale: FitScale::Linear,
                role: Role::Other,
                start: 0.0,
            },
            ParameterInfo {
                name: "te",
                unit: "s",
                meaning: "coil's electrical time constant L/R",
                domain: Domain::NonNegative,
                scale: FitScale::Linear,
                role: Role::Other,
                start: 0.0,
            },
        ],
        memory: false,
        odd: true,
        samples_per_period: 0,
        example: &[50.0, 2e-4],
    };

    fn from_parameters(values: &[f64]) -> Result<Self> {
        Ok(Shaker::new(values[0], values[1]))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The ramp-invariant lag against the exact response of `1/(1 + sτ)` to
    /// a ramp from rest, `y(t) = t − τ(1 − e^{−t/τ})`, and to a step held
    /// (ramp over one sample, then constant).
    #[test]
    fn the_lag_is_exact_for_a_piecewise_linear_input() {
        let (tau, h) = (3e-4, 1e-4);
        let mut lag = Lag::new(tau, h);
        for n in 1..=50 {
            let t = n as f64 * h;
            let y = lag.commit(t);
            let exact = t - tau * (1.0 - (-t / tau).exp());
            assert!((y - exact).abs() < 1e-15, "n = {n}: {y} vs {exact}");
        }
        // τ → 0 passes the input through; no time step passes nothing
        let mut through = Lag::new(0.0, h);
        assert_eq!(through.commit(2.5), 2.5);
        assert!(!Lag::new(tau, 0.0).is_on());
    }

    /// The shaker's force in the simulator's march: the lagged back-EMF,
    /// its tangent the direct term; without a time step nothing.
    #[test]
    fn marched_it_is_the_lagged_back_emf() {
        let mut s = Shaker::new(40.0, 3e-4);
        assert_eq!(s.commit(0.0, 1.0).force, 0.0);
        s.set_time_step(1e-4);
        let mut lag = Lag::new(3e-4, 1e-4);
        for n in 1..=20 {
            let v = (n as f64 * 0.3).sin();
            let t = s.trial(0.0, v);
            assert_eq!(t.damping, 40.0 * lag.direct());
            assert_eq!(s.commit(0.0, v).force, t.force);
            assert_eq!(t.force, lag.commit(40.0 * v));
        }
    }
}
