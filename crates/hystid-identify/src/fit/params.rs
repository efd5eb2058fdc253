//! Fit parameters: which model numbers are free, and in what coordinates.
//!
//! Optimisers work in transformed coordinates `θ`: `ln p` for quantities that
//! are positive by nature (stiffnesses, slip forces, `N`, masses, damping) so
//! that relative steps are uniform and `kd ~ 1e7` and `N ~ 10` are on the same
//! footing (an absolute simplex size or tolerance means nothing for `kd` in
//! N/m); `p/scale` for signed ones (`k3`, a residue). Each parameter may have
//! physical bounds; outside them the model is clamped and the cost is
//! penalised, so simplex methods stay inside.

use crate::error::{Error, Result};
use crate::model::{Domain, ElementAt, ElementSpec, FitScale, Mode, Model, Role};
use serde::{Deserialize, Serialize};

/// What a parameter changes in the model.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case", tag = "of")]
pub enum Target {
    /// Parameter `name` of the element at `at`.
    Element {
        /// The joint or an effect.
        at: ElementAt,
        /// Parameter name (`kd`, `fd`, `n`, `k3`, ...).
        name: String,
    },
    /// Mass of mode `mode` seen as an SDOF (`1/R`).
    Mass {
        /// Mode index.
        mode: usize,
    },
    /// Viscous damping of mode `mode` seen as an SDOF (`2ζω/R`).
    Damping {
        /// Mode index.
        mode: usize,
    },
    /// Stiffness of mode `mode` seen as an SDOF (`ω²/R`).
    Stiffness {
        /// Mode index.
        mode: usize,
    },
    /// Natural frequency of mode `mode`, Hz.
    Frequency {
        /// Mode index.
        mode: usize,
    },
    /// Damping ratio of mode `mode`.
    DampingRatio {
        /// Mode index.
        mode: usize,
    },
    /// Modal constant of mode `mode`, 1/kg.
    Residue {
        /// Mode index.
        mode: usize,
    },
    /// Static flexibility of mode `mode`, `R/ω²` (m/N), at its current
    /// frequency: the size of a mode above the measured band, which shows
    /// there only as a residual flexibility (its modal constant alone is
    /// tied to its poorly seen frequency).
    Flexibility {
        /// Mode index.
        mode: usize,
    },
    /// The joint's stick stiffness `kd` taken out of mode `mode`'s
    /// stiffness so that `k + kd = total` stays fixed: the stick stiffness a
    /// nearly linear low level measured, split between structure and joint.
    TiedStickStiffness {
        /// Mode index.
        mode: usize,
        /// `k + kd`, N/m.
        total: f64,
    },
}

/// The coordinate an optimiser sees.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case", tag = "kind")]
pub enum Transform {
    /// `θ = ln p` (p > 0).
    Log,
    /// `θ = p / scale`.
    Scaled {
        /// Typical magnitude.
        scale: f64,
    },
    /// `θ = 1/p`: for the Masing curvature `N`, whose Jenkins limit
    /// `N → ∞` is the ordinary point `θ → 0`, near which the cost is smooth
    /// (the loop's knee rounds off as `1/N`).
    Reciprocal,
}

/// One free parameter.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Parameter {
    /// Report name (`kd`, `fd`, `n`, `mass`, `k3`, `second_mode.frequency_hz`, ...).
    pub name: String,
    /// What it changes.
    pub target: Target,
    /// Optimiser coordinate.
    pub transform: Transform,
    /// Physical bounds `[lo, hi]`.
    pub bounds: [f64; 2],
}

impl Parameter {
    /// Physical value from the optimiser coordinate (unclamped).
    pub fn value(&self, theta: f64) -> f64 {
        match self.transform {
            Transform::Log => theta.exp(),
            Transform::Scaled { scale } => theta * scale,
            Transform::Reciprocal => 1.0 / theta,
        }
    }

    /// Optimiser coordinate of a physical value.
    pub fn theta(&self, value: f64) -> f64 {
        match self.transform {
            Transform::Log => value.ln(),
            Transform::Scaled { scale } => value / scale,
            Transform::Reciprocal => 1.0 / value,
        }
    }

    /// Value clamped to the bounds, and how far (in θ) outside it was.
    pub fn clamped(&self, theta: f64) -> (f64, f64) {
        let lo = self.theta(self.bounds[0]);
        let hi = self.theta(self.bounds[1]);
        let (lo, hi) = (lo.min(hi), lo.max(hi));
        // at a bound, the bound itself (not exp(ln(bound)), which is 1 ulp off)
        let (blo, bhi) = (
            self.bounds[0].min(self.bounds[1]),
            self.bounds[0].max(self.bounds[1]),
        );
        if theta <= lo {
            return (blo, lo - theta);
        }
        if theta >= hi {
            return (bhi, theta - hi);
        }
        (self.value(theta), 0.0)
    }

    /// The name of the element parameter it changes (its report name for
    /// any other target).
    pub fn target_name(&self) -> &str {
        match &self.target {
            Target::Element { name, .. } => name,
            _ => &self.name,
        }
    }

    /// Reads the current value from a model.
    pub fn read(&self, model: &Model) -> Result<f64> {
        let mode = |i: usize| {
            model
                .linear
                .modes
                .get(i)
                .ok_or_else(|| Error::model(format!("modes[{i}]"), "no such mode"))
        };
        Ok(match &self.target {
            Target::Element { at, name } => {
                let j = model.parameter_index(*at, name)?;
                model.element(*at)?.parameters()[j].1
            }
            Target::Mass { mode: i } => mode(*i)?.modal_mass(),
            Target::Damping { mode: i } => mode(*i)?.modal_damping(),
            Target::Stiffness { mode: i } => mode(*i)?.modal_stiffness(),
            Target::Frequency { mode: i } => mode(*i)?.frequency_hz,
            Target::DampingRatio { mode: i } => mode(*i)?.damping_ratio,
            Target::Residue { mode: i } => mode(*i)?.residue,
            Target::Flexibility { mode: i } => mode(*i)?.static_flexibility(),
            Target::TiedStickStiffness { .. } => {
                let at = ElementAt::Joint;
                let j = model.parameter_index(at, stick_stiffness_name(model, at)?)?;
                model.element(at)?.parameters()[j].1
            }
        })
    }

    /// Writes a value into a model.
    pub fn write(&self, model: &mut Model, value: f64) -> Result<()> {
        let mode_mut = |model: &mut Model, i: usize| -> Result<Mode> {
            model
                .linear
                .modes
                .get(i)
                .copied()
                .ok_or_else(|| Error::model(format!("modes[{i}]"), "no such mode"))
        };
        match &self.target {
            Target::Element { at, name } => {
                let j = model.parameter_index(*at, name)?;
                let e = model.element_mut(*at)?;
                let mut v: Vec<f64> = e.parameters().iter().map(|p| p.1).collect();
                v[j] = value;
                *e = e.with_parameters(&v);
            }
            Target::Mass { mode } | Target::Damping { mode } | Target::Stiffness { mode } => {
                let m0 = mode_mut(model, *mode)?;
                let (mut m, mut c, mut k) =
                    (m0.modal_mass(), m0.modal_damping(), m0.modal_stiffness());
                match self.target {
                    Target::Mass { .. } => m = value,
                    Target::Damping { .. } => c = value,
                    _ => k = value,
                }
                // keep the residue's sign (a transfer FRF may have R < 0)
                let s = m0.residue.signum();
                let joint = m0.joint;
                let (m, c, k) = (m * s, c * s, k * s);
                let wn = (k / m).sqrt();
                model.linear.modes[*mode] = Mode {
                    frequency_hz: wn / (2.0 * std::f64::consts::PI),
                    damping_ratio: c / (2.0 * (k * m).sqrt()),
                    residue: 1.0 / m,
                    joint,
                };
            }
            Target::Frequency { mode } => model.linear.modes[*mode].frequency_hz = value,
            Target::DampingRatio { mode } => model.linear.modes[*mode].damping_ratio = value,
            Target::Residue { mode } => model.linear.modes[*mode].residue = value,
            Target::Flexibility { mode } => {
                let w = mode_mut(model, *mode)?.omega();
                model.linear.modes[*mode].residue = value * w * w;
            }
            Target::TiedStickStiffness { mode, total } => {
                Parameter {
                    name: String::new(),
                    target: Target::Element {
                        at: ElementAt::Joint,
                        name: stick_stiffness_name(model, ElementAt::Joint)?.into(),
                    },
                    transform: self.transform,
                    bounds: self.bounds,
                }
                .write(model, value)?;
                Parameter {
                    name: String::new(),
                    target: Target::Stiffness { mode: *mode },
                    transform: self.transform,
                    bounds: self.bounds,
                }
                .write(model, total - value)?;
            }
        }
        Ok(())
    }
}

/// The free parameters of a fit.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct ParameterSet {
    /// In optimiser order.
    pub parameters: Vec<Parameter>,
}

impl ParameterSet {
    /// Number of parameters.
    pub fn len(&self) -> usize {
        self.parameters.len()
    }

    /// Whether there are none.
    pub fn is_empty(&self) -> bool {
        self.parameters.is_empty()
    }

    /// The optimiser coordinates of a model's current values.
    pub fn theta_of(&self, model: &Model) -> Result<Vec<f64>> {
        self.parameters
            .iter()
            .map(|p| Ok(p.theta(p.read(model)?)))
            .collect()
    }

    /// The model at `theta` (values clamped to their bounds) and the total
    /// distance outside the bounds (for a penalty).
    ///
    /// A mode's damping ratio is bounded here too, whatever coordinates
    /// moved it: `m, c, k` in log coordinates can reach any ratio, and a mode
    /// past [`ZETA_MAX`] is held there with the excess (in `ln ζ`) added to
    /// the distance, so an optimiser is pushed back instead of handed a model
    /// the simulator rejects.
    pub fn model_at(&self, base: &Model, theta: &[f64]) -> Result<(Model, f64)> {
        let mut m = base.clone();
        let mut outside = 0.0;
        for (p, &t) in self.parameters.iter().zip(theta) {
            let (v, o) = p.clamped(t);
            outside += o;
            p.write(&mut m, v)?;
        }
        for mode in &mut m.linear.modes {
            let z = mode.damping_ratio;
            if z.is_finite() && z > ZETA_MAX {
                outside += (z / ZETA_MAX).ln();
                mode.damping_ratio = ZETA_MAX;
            }
        }
        Ok((m, outside))
    }

    /// Which of `values` (one per parameter) sit at a bound (within 1 %):
    /// no Wald interval there.
    pub fn at_bounds(&self, values: &[f64]) -> Vec<bool> {
        self.parameters
            .iter()
            .zip(values)
            .map(|(p, &v)| {
                p.bounds
                    .iter()
                    .any(|&b| (v - b).abs() <= 0.01 * b.abs().max(f64::MIN_POSITIVE))
            })
            .collect()
    }

    /// Physical values at `theta` (clamped).
    pub fn values(&self, theta: &[f64]) -> Vec<f64> {
        self.parameters
            .iter()
            .zip(theta)
            .map(|(p, &t)| p.clamped(t).0)
            .collect()
    }

    /// The own parameters of the element at `at` as free parameters, with
    /// default transforms and bounds (none if there is no such element).
    pub fn for_element(model: &Model, at: ElementAt, prefix: &str) -> ParameterSet {
        let Ok(e) = model.element(at) else {
            return ParameterSet::default();
        };
        // a hysteretic mode's own joint: stuck, the mode rings at most
        // MAX_STUCK_RATIO times its bare frequency
        let stiffest = match at {
            ElementAt::ModeJoint(i) => model
                .linear
                .modes
                .get(i)
                .map(|m| (MAX_STUCK_RATIO * MAX_STUCK_RATIO - 1.0) * m.modal_stiffness().abs()),
            _ => None,
        };
        ParameterSet {
            parameters: law_parameters(e, at, prefix, stiffest),
        }
    }

    /// The parameters of a joint's law `law` alone (no model around it),
    /// with default transforms and bounds, its gauges (see [`Role::Gauge`])
    /// left out: what the fit at points frees of its joint.
    pub fn for_law(law: &ElementSpec) -> ParameterSet {
        let mut parameters = law_parameters(law, ElementAt::Joint, "", None);
        let gauge = |name: &str| {
            law.description()
                .parameters
                .iter()
                .any(|q| q.name == name && q.role == Role::Gauge)
        };
        parameters.retain(|p| !gauge(p.target_name()));
        ParameterSet { parameters }
    }

    /// The set without the gauges of `model`'s elements (see
    /// [`Role::Gauge`]: Bouc-Wen's `β`, a shaker's gain): a fit holds them,
    /// as the data cannot tell them from the parameters they trade with.
    pub fn without_gauges(mut self, model: &Model) -> ParameterSet {
        self.parameters.retain(|p| match &p.target {
            Target::Element { at, name } => !model.element(*at).is_ok_and(|e| {
                e.description()
                    .parameters
                    .iter()
                    .any(|q| q.name == name && q.role == Role::Gauge)
            }),
            _ => true,
        });
        self
    }

    /// The set as a replay of recordings can fit it, with a note per mode
    /// held: a linear mode of `model` above `quasi_static_above_hz` is
    /// replayed quasi-statically (see
    /// [`crate::validate::QUASI_STATIC_ABOVE_RATE`]), so its frequency and
    /// damping ratio do not change the replay and are held (its flexibility
    /// or modal constant stays free); a free frequency of any other linear
    /// mode is bounded by it, so that no step takes the mode across.
    pub fn for_replay(
        mut self,
        model: &Model,
        quasi_static_above_hz: f64,
    ) -> (ParameterSet, Vec<String>) {
        let quasi_static = |mode: usize| {
            model
                .linear
                .modes
                .get(mode)
                .is_some_and(|m| m.is_quasi_static_above(quasi_static_above_hz))
        };
        let mut notes = Vec::new();
        for (i, m) in model.linear.modes.iter().enumerate() {
            let held = self.parameters.iter().any(|p| {
                matches!(p.target, Target::Frequency { mode } | Target::DampingRatio { mode } if mode == i)
            });
            if quasi_static(i) && held {
                notes.push(format!(
                    "{} at {:.6} Hz is above {:.6} Hz, twice the slowest recording's sample rate: replayed \
                     quasi-statically (its flexibility alone), its frequency and damping ratio \
                     held",
                    model.linear.label(i),
                    m.frequency_hz,
                    quasi_static_above_hz
                ));
            }
        }
        self.parameters.retain(|p| match p.target {
            Target::Frequency { mode } | Target::DampingRatio { mode } => !quasi_static(mode),
            _ => true,
        });
        for p in &mut self.parameters {
            if let Target::Frequency { mode } = p.target
                && model
                    .linear
                    .modes
                    .get(mode)
                    .is_some_and(|m| !m.is_hysteretic())
            {
                p.bounds[1] = p.bounds[1].min(quasi_static_above_hz);
            }
        }
        (self, notes)
    }

    /// The viscous damping of an SDOF mode as a free parameter.
    pub fn for_sdof_damping(mode: usize) -> ParameterSet {
        ParameterSet {
            parameters: vec![Parameter {
                name: "damping".into(),
                target: Target::Damping { mode },
                transform: Transform::Log,
                bounds: [1e-30, 1e30],
            }],
        }
    }

    /// `m, c, k` of an SDOF mode as free parameters.
    pub fn for_sdof(mode: usize) -> ParameterSet {
        let p = |name: &str, target| Parameter {
            name: name.into(),
            target,
            transform: Transform::Log,
            bounds: [1e-30, 1e30],
        };
        ParameterSet {
            parameters: vec![
                p("mass", Target::Mass { mode }),
                p("damping", Target::Damping { mode }),
                p("stiffness", Target::Stiffness { mode }),
            ],
        }
    }

    /// The linear part's parameters: the first mode as an SDOF (`m, c, k`),
    /// and each further mode's frequency, damping ratio and modal constant.
    pub fn for_linear(model: &Model) -> ParameterSet {
        ParameterSet::for_linear_in(model, None)
    }

    /// [`ParameterSet::for_linear`] for data measured over `band_hz`: a
    /// further mode outside the band has no resonance in it, and is sized
    /// by what the band does see: a mode above by its static flexibility
    /// `R/ω²` (the residual flexibility of modal analysis), a mode below by
    /// its modal constant (the residual mass line `−R/ω²`). Each stays on
    /// its side of the band, so that a mode that is only a background cannot
    /// become a sharp resonance inside it. (Its damping stays free: near
    /// the band it still sets the phase of the mode's tail.)
    pub fn for_linear_in(model: &Model, band_hz: Option<(f64, f64)>) -> ParameterSet {
        let mut p = ParameterSet::for_sdof(0);
        for m in 1..model.linear.modes.len() {
            let mode = model.linear.modes[m];
            let label = model.linear.label(m);
            let name = |f: &str| format!("{label}.{f}");
            let side = band_side(mode.frequency_hz, band_hz);
            p.parameters.push(Parameter {
                name: name("frequency_hz"),
                target: Target::Frequency { mode: m },
                transform: Transform::Log,
                bounds: match (side, band_hz) {
                    (Some(BandSide::Above), Some((_, hi))) => [hi, 1e9],
                    (Some(BandSide::Below), Some((lo, _))) => [1e-6, lo],
                    _ => [1e-6, 1e9],
                },
            });
            p.parameters.push(Parameter {
                name: name("damping_ratio"),
                target: Target::DampingRatio { mode: m },
                transform: Transform::Log,
                bounds: [1e-5, ZETA_MAX],
            });
            let (target, label, value) = match side {
                Some(BandSide::Above) => (
                    Target::Flexibility { mode: m },
                    "flexibility",
                    mode.static_flexibility(),
                ),
                _ => (Target::Residue { mode: m }, "residue", mode.residue),
            };
            p.parameters.push(Parameter {
                name: name(label),
                target,
                transform: Transform::Scaled {
                    scale: value.abs().max(f64::MIN_POSITIVE),
                },
                bounds: [-1e30, 1e30],
            });
        }
        p
    }

    /// Appends another set.
    pub fn extend(&mut self, other: ParameterSet) {
        self.parameters.extend(other.parameters);
    }
}

/// The highest ratio of a hysteretic mode's stuck frequency to its bare
/// one a fit may reach: its joint's stick stiffness is bounded by
/// `(r² − 1)` times the mode's own stiffness at the start. Jointed modes
/// stiffen by a few per cent to tens of per cent when they stick (the
/// F-16's 6.2-6.6 Hz mode, a lap joint's first mode); a joint a fit drives
/// far stiffer makes a mode that vanishes while stuck, and its stuck mode,
/// far above what a recording resolves, is replayed at up to 64 times the
/// rate for it (an independent recording at 65.5 kHz: a joint at 19 400
/// times its mode's stiffness, stuck at 921 kHz).
pub const MAX_STUCK_RATIO: f64 = 10.0;

/// A further mode counts as outside the measured band when its frequency
/// is beyond the band's edge by more than this factor.
pub const BAND_MARGIN: f64 = 1.05;

/// Where a mode lies against a measured band.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum BandSide {
    /// Above the band's top by more than [`BAND_MARGIN`].
    Above,
    /// Below the band's bottom by more than [`BAND_MARGIN`].
    Below,
}

/// The side of `band_hz` a mode at `frequency_hz` lies on (`None`: inside
/// it, or no band known).
pub fn band_side(frequency_hz: f64, band_hz: Option<(f64, f64)>) -> Option<BandSide> {
    let (lo, hi) = band_hz?;
    if frequency_hz > hi * BAND_MARGIN {
        Some(BandSide::Above)
    } else if frequency_hz * BAND_MARGIN < lo {
        Some(BandSide::Below)
    } else {
        None
    }
}

/// The largest damping ratio a fitted mode may take: a mode damped beyond it
/// has no resonance to fit and is a model of something else.
pub const ZETA_MAX: f64 = 0.9;

/// Upper bound of the Masing curvature (see [`crate::model::masing::N_MAX`]).
pub use crate::model::masing::N_MAX;

/// The name of the stick stiffness of the element at `at` (an error if it
/// has none).
fn stick_stiffness_name(model: &Model, at: ElementAt) -> Result<&'static str> {
    let d = model.element(at)?.description();
    d.index_of(Role::StickStiffness)
        .map(|i| d.parameters[i].name)
        .ok_or_else(|| Error::model(at.to_string(), format!("{} has no stick stiffness", d.name)))
}

/// The own parameters of `e` (at `at`) as free parameters, named with
/// `prefix`; a stick stiffness no higher than `stiffest` (or its start).
fn law_parameters(
    e: &ElementSpec,
    at: ElementAt,
    prefix: &str,
    stiffest: Option<f64>,
) -> Vec<Parameter> {
    e.parameters()
        .into_iter()
        .map(|(name, value)| {
            let (transform, mut bounds) = default_coordinates(e, name, value);
            let stick = e
                .description()
                .parameters
                .iter()
                .any(|q| q.name == name && q.role == Role::StickStiffness);
            if let Some(top) = stiffest.filter(|_| stick) {
                // never below the start: a start outside would be clamped
                bounds[1] = bounds[1].min(top.max(value));
            }
            Parameter {
                name: if prefix.is_empty() {
                    name.to_string()
                } else {
                    format!("{prefix}.{name}")
                },
                target: Target::Element {
                    at,
                    name: name.to_string(),
                },
                transform,
                bounds,
            }
        })
        .collect()
}

/// A parameter's fit coordinate and bounds, from its law's description.
fn default_coordinates(e: &ElementSpec, name: &str, value: f64) -> (Transform, [f64; 2]) {
    let scale = if value != 0.0 { value.abs() } else { 1.0 };
    let Some(info) = e.description().parameters.iter().find(|p| p.name == name) else {
        return (Transform::Log, [1e-30, 1e30]);
    };
    let (lower, upper) = match info.domain {
        Domain::Signed => (-1e30, 1e30),
        Domain::Positive | Domain::NonNegative => (0.0, 1e30),
        Domain::Range { min, max } => (min, max),
    };
    // an excluded end of the domain is no bound a fit may stop at: a
    // parameter at its bound must still make a valid model
    let inside = |b: f64| match info.domain {
        Domain::Range { min, max } => b.clamp(
            min + 1e-9 * (max - min).abs(),
            max - 1e-9 * (max - min).abs(),
        ),
        _ => b,
    };
    match info.scale {
        FitScale::Reciprocal { min, max } => (Transform::Reciprocal, [inside(min), inside(max)]),
        FitScale::Linear => (Transform::Scaled { scale }, [inside(lower), inside(upper)]),
        // positive by nature: six decades either side of the start, which
        // no fit from a data-based start should need, and which keeps a
        // runaway (a slip force above every level, a stiffness of 1e30) from
        // wandering where the model means nothing
        FitScale::Log if value.is_finite() && value > 0.0 => {
            (Transform::Log, [value * 1e-6, value * 1e6])
        }
        FitScale::Log => (Transform::Log, [1e-30, 1e30]),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::ModalModel;

    /// A hysteretic mode's joint may stiffen it, stuck, to at most ten
    /// times its bare frequency: kd ≤ 99 k_mode (checked on the model the
    /// bound makes: its stuck frequency, √(ω² + kd R)); the slip force and
    /// the drive point's joint keep their six decades.
    #[test]
    fn a_hysteretic_modes_joint_is_bounded_by_its_stuck_frequency() {
        let mut mode = Mode::from_modal_mass(6600.0, 0.01, 50.0).unwrap();
        let k = mode.modal_stiffness();
        mode.joint = Some(ElementSpec::Jenkins { kd: k, fd: 40.0 });
        let mut linear = ModalModel::sdof(7.5, 4500.0, 8.3e8).unwrap();
        linear.modes.push(mode);
        let model = Model::new(
            linear,
            vec![ElementSpec::Jenkins {
                kd: 3.1e8,
                fd: 413.0,
            }],
        )
        .unwrap();
        let own =
            ParameterSet::for_element(&model, ElementAt::ModeJoint(1), "hysteretic_mode.joint");
        let bound = |set: &ParameterSet, name: &str| {
            set.parameters
                .iter()
                .find(|p| p.name.ends_with(name))
                .unwrap()
                .bounds
        };
        let top = bound(&own, ".kd")[1];
        assert!(
            (top / (99.0 * k) - 1.0).abs() < 1e-12,
            "{top} against {}",
            99.0 * k
        );
        let mut stiffest = model.clone();
        stiffest.linear.modes[1].joint = Some(ElementSpec::Jenkins { kd: top, fd: 40.0 });
        let stuck = stiffest.highest_linearised_frequency_hz();
        assert!((stuck / 66_000.0 - 1.0).abs() < 1e-9, "{stuck}");
        assert_eq!(bound(&own, ".fd"), [40.0 * 1e-6, 40.0 * 1e6]);
        let drive_point = ParameterSet::for_element(&model, ElementAt::Joint, "");
        assert_eq!(bound(&drive_point, "kd"), [3.1e8 * 1e-6, 3.1e8 * 1e6]);
    }

    #[test]
    fn parameters_read_and_write_the_model() {
        let base = Model::new(
            ModalModel::sdof(10.0, 200.0, 1e7).unwrap(),
            vec![ElementSpec::Masing {
                kd: 2.4e7,
                fd: 246.0,
                n: 3.0,
            }],
        )
        .unwrap();
        let mut set = ParameterSet::for_element(&base, ElementAt::Joint, "");
        set.extend(ParameterSet::for_sdof(0));
        let theta = set.theta_of(&base).unwrap();
        let (m, out) = set.model_at(&base, &theta).unwrap();
        assert_eq!(out, 0.0);
        let (m2, c2, k2) = m.linear.as_mck().unwrap();
        assert!((m2 - 10.0).abs() < 1e-12 && (c2 - 200.0).abs() < 1e-9 && (k2 - 1e7).abs() < 1e-5);
        let mut t = theta.clone();
        t[2] = (5000.0f64).ln(); // n beyond N_MAX: clamped
        let (m, out) = set.model_at(&base, &t).unwrap();
        assert!(out > 0.0);
        let Some(ElementSpec::Masing { kd, fd, n }) = m.joint else {
            panic!()
        };
        assert!((kd / 2.4e7 - 1.0).abs() < 1e-14 && (fd / 246.0 - 1.0).abs() < 1e-14);
        assert_eq!(n, N_MAX);
    }

    #[test]
    fn a_mode_outside_the_band_is_sized_by_what_the_band_sees() {
        use crate::model::Mode;
        let mut linear = ModalModel::sdof(10.0, 200.0, 1e7).unwrap();
        let above = Mode {
            frequency_hz: 900.0,
            damping_ratio: 0.02,
            residue: 0.5,
            joint: None,
        };
        let below = Mode {
            frequency_hz: 40.0,
            damping_ratio: 0.03,
            residue: 0.2,
            joint: None,
        };
        linear.modes.push(above);
        linear.modes.push(below);
        let base = Model::new(linear, vec![]).unwrap();
        // measured from 100 to 300 Hz: the 900 Hz mode is above, 40 Hz below
        let set = ParameterSet::for_linear_in(&base, Some((100.0, 300.0)));
        let names: Vec<&str> = set.parameters.iter().map(|p| p.name.as_str()).collect();
        assert_eq!(
            names,
            [
                "mass",
                "damping",
                "stiffness",
                "second_mode.frequency_hz",
                "second_mode.damping_ratio",
                "second_mode.flexibility",
                "mode_2.frequency_hz",
                "mode_2.damping_ratio",
                "mode_2.residue"
            ]
        );
        // the flexibility is R / ω² (closed form), and written back at a new
        // frequency it keeps the static flexibility, not the modal constant
        let w = 2.0 * std::f64::consts::PI * 900.0;
        let flex = set.parameters[5].read(&base).unwrap();
        assert!((flex / (0.5 / (w * w)) - 1.0).abs() < 1e-14);
        let mut theta = set.theta_of(&base).unwrap();
        theta[3] = 1800f64.ln();
        let (m, out) = set.model_at(&base, &theta).unwrap();
        assert_eq!(out, 0.0);
        let w2 = 2.0 * std::f64::consts::PI * 1800.0;
        assert!((m.linear.modes[1].residue / (flex * w2 * w2) - 1.0).abs() < 1e-12);
        // each stays on its side of the band
        assert_eq!(set.parameters[3].bounds[0], 300.0);
        assert_eq!(set.parameters[6].bounds[1], 100.0);
        // without a band, every mode has all three
        assert_eq!(ParameterSet::for_linear(&base).len(), 9);
    }
}
