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
use crate::error::{Error, Result};
use num_complex::Complex64;

/// The shaker's back-EMF at the drive point, lagged by the coil (see the
/// module docs).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Shaker {
    /// Back-EMF damping `ce = Bl²/R` (in the drive's unit: `Bl`), N s/m.
    pub ce: f64,
    /// Electrical time constant `τe = L/R`, s.
    pub te: f64,
    /// The blocked force per unit of drive, `Bl/R` (N/V); 1 when the
    /// model's forces are in the drive's unit.
    pub gain: f64,
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
    /// The shaker with back-EMF damping `ce` and time constant `te`, its
    /// forces in the drive's unit (gain 1).
    pub fn new(ce: f64, te: f64) -> Shaker {
        Shaker::with_gain(ce, te, 1.0)
    }

    /// The shaker with back-EMF damping `ce`, time constant `te` and
    /// blocked force `gain` per unit of drive.
    pub fn with_gain(ce: f64, te: f64, gain: f64) -> Shaker {
        Shaker {
            ce,
            te,
            gain,
            lag: Lag::default(),
        }
    }

    /// The shaker of a coil with resistance `r` (Ω), inductance `l` (H)
    /// and force factor `bl` (N/A), its forces in newtons.
    pub fn of_coil(r: f64, l: f64, bl: f64) -> Shaker {
        Shaker::with_gain(bl * bl / r, l / r, bl / r)
    }

    /// The coil `(R, L, Bl)` this shaker stands for, when its gain is
    /// physical (`Bl = ce/gain`, `R = Bl/gain`, `L = te R`).
    pub fn coil(&self) -> (f64, f64, f64) {
        let bl = self.ce / self.gain;
        let r = bl / self.gain;
        (r, self.te * r, bl)
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
    /// The lagged back-EMF force just committed.
    fn drive_reaction(&self) -> f64 {
        if self.lag.on { self.lag.y } else { 0.0 }
    }
    fn drive_load(&self) -> Option<DriveLoad> {
        Some(DriveLoad {
            back_emf: self.ce,
            time_constant: self.te,
            gain: self.gain,
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
            ParameterInfo {
                name: "gain",
                unit: "N/V",
                meaning: "blocked force per unit of drive Bl/R (1: forces in the drive's unit)",
                domain: Domain::Positive,
                scale: FitScale::Log,
                // the drive alone tells it only together with the
                // structure's scale: a fit holds it where it is declared
                role: Role::Gauge,
                start: 1.0,
            },
        ],
        memory: false,
        odd: true,
        samples_per_period: 0,
        smooth_samples: Some(|_| 0),
        example: &[50.0, 2e-4, 1.0],
    };

    fn from_parameters(values: &[f64]) -> Result<Self> {
        Ok(Shaker::with_gain(values[0], values[1], values[2]))
    }

    /// A shaker is declared by its model's terms (`ce`, `te`, and `gain`,
    /// 1 when left out) or by its coil's (`r`, `l`, `bl`: the model's forces
    /// are then newtons), not a mixture.
    fn declared(fields: &mut serde_json::Map<String, serde_json::Value>) -> Result<()> {
        const COIL: [&str; 3] = ["r", "l", "bl"];
        let given: Vec<&str> = COIL
            .into_iter()
            .filter(|k| fields.contains_key(*k))
            .collect();
        if given.is_empty() {
            fields.entry("gain").or_insert(serde_json::Value::from(1.0));
            return Ok(());
        }
        if let Some(model) = ["ce", "te", "gain"]
            .into_iter()
            .find(|k| fields.contains_key(*k))
        {
            return Err(Error::model(
                format!("shaker.{model}"),
                format!(
                    "give the shaker's coil (r, l, bl) or its model's terms (ce, te, gain), \
                     not both (`{model}` beside `{}`)",
                    given[0]
                ),
            ));
        }
        let mut value = |k: &str| -> Result<f64> {
            let v = fields.remove(k).ok_or_else(|| {
                Error::model(
                    format!("shaker.{k}"),
                    "missing: the coil needs r (ohm), l (H) and bl (N/A)",
                )
            })?;
            v.as_f64().ok_or_else(|| {
                Error::model(format!("shaker.{k}"), format!("expected a number, got {v}"))
            })
        };
        let (r, l, bl) = (value("r")?, value("l")?, value("bl")?);
        let positive = |v: f64| v > 0.0 && v.is_finite();
        if !(positive(r) && positive(bl) && (l == 0.0 || positive(l))) {
            return Err(Error::model(
                "shaker",
                format!(
                    "expected r > 0 (ohm), l >= 0 (H) and bl > 0 (N/A), got r = {r}, l = {l}, bl = {bl}"
                ),
            ));
        }
        let s = Shaker::of_coil(r, l, bl);
        for (k, v) in [("ce", s.ce), ("te", s.te), ("gain", s.gain)] {
            fields.insert(k.into(), serde_json::Value::from(v));
        }
        Ok(())
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

    /// Declared by its coil, a shaker is `ce = Bl²/R`, `te = L/R` and gain
    /// `Bl/R`, and gives its coil back; declared by its model's terms its
    /// gain is 1 unless given; a mixture, a missing coil term or a coil
    /// that cannot be are refused, naming what is wrong.
    #[test]
    fn a_shaker_is_declared_by_its_coil_or_its_models_terms() {
        use crate::model::ElementSpec;
        let read = |t: &str| toml::from_str::<ElementSpec>(t).map_err(|e| e.to_string());
        let coil = read("kind = \"shaker\"\nr = 2.0\nl = 1e-3\nbl = 10").unwrap();
        assert_eq!(
            coil,
            ElementSpec::Shaker {
                ce: 50.0,
                te: 5e-4,
                gain: 5.0
            }
        );
        let (r, l, bl) = Shaker::with_gain(50.0, 5e-4, 5.0).coil();
        assert!((r - 2.0).abs() < 1e-15 && (l - 1e-3).abs() < 1e-18 && (bl - 10.0).abs() < 1e-14);
        assert_eq!(
            read("kind = \"shaker\"\nce = 50.0\nte = 5e-4").unwrap(),
            ElementSpec::Shaker {
                ce: 50.0,
                te: 5e-4,
                gain: 1.0
            }
        );
        // what fit.json writes reads back as it was
        let json = serde_json::to_string(&coil).unwrap();
        assert_eq!(serde_json::from_str::<ElementSpec>(&json).unwrap(), coil);
        let mixed = read("kind = \"shaker\"\nr = 2.0\nl = 1e-3\nbl = 10\nte = 1e-4").unwrap_err();
        assert!(mixed.contains("not both (`te` beside `r`)"), "{mixed}");
        let partial = read("kind = \"shaker\"\nr = 2.0\nbl = 10").unwrap_err();
        assert!(partial.contains("`shaker.l`: missing"), "{partial}");
        let bad = read("kind = \"shaker\"\nr = 0.0\nl = 1e-3\nbl = 10").unwrap_err();
        assert!(bad.contains("expected r > 0"), "{bad}");
        let unknown = read("kind = \"shaker\"\nce = 1.0\nte = 0.0\nrr = 1").unwrap_err();
        assert!(unknown.contains("unknown field `rr`"), "{unknown}");
    }
}
