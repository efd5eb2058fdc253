//! The structural model: the underlying linear structure plus elements.
//!
//! Paper eq. (1): `m x'' + c x' + k x = F − F_nl`. The linear part is a
//! [`ModalModel`] (one or more modes at the joint point); `F_nl` is the sum of
//! the forces of the [`Element`]s attached there: the joint (Jenkins, the
//! eq. (10) Masing element, an Iwan element), a field of its own in
//! [`Model`], and any effects (cubic stiffness, ...).
//!
//! [`ElementSpec`] is an element's kind and parameters as data (what TOML files,
//! fits and reports handle); [`AnyElement`] is the element built from it, with
//! state, dispatched without virtual calls in the simulator's loop.

pub mod armature;
pub mod bilinear_stiffness;
pub mod bouc_wen;
pub mod clearance;
pub mod cubic_stiffness;
pub mod element;
pub mod iwan;
pub mod jenkins;
pub mod masing;
pub mod modal;
pub mod points;
pub mod quadratic_damping;
pub mod shaker;
pub mod units;
pub mod viscous_damping;

pub use armature::Armature;
pub use bilinear_stiffness::BilinearStiffness;
pub use bouc_wen::BoucWen;
pub use clearance::Clearance;
pub use cubic_stiffness::CubicStiffness;
pub use element::{
    Attachment, Description, Domain, DriveLoad, Element, ElementForce, ElementSet, FitScale,
    ImplicitStep, Law, NoElement, ParameterInfo, Role, SensitivityTerms,
};
pub use iwan::Iwan4Backbone;
pub use jenkins::Jenkins;
pub use masing::{Backbone, Masing, PiecewiseLinearBackbone, PowerBackbone};
pub use modal::{ModalModel, Mode};
pub use points::{Lumped, PointModes, ShapedMode, Site};
pub use quadratic_damping::QuadraticDamping;
pub use shaker::Shaker;
pub use viscous_damping::ViscousDamping;

use crate::error::{Error, Result, require_finite, require_non_negative, require_positive};
use serde::{Deserialize, Serialize};

/// The element registry: each law's kind, its type (which implements
/// [`Element`] and [`Law`]) and its parameter fields, once. From it come
/// [`ElementKind`], [`ElementSpec`] (the kind and parameters as data, what
/// TOML files, fits and reports hold) and [`AnyElement`] (the built element,
/// dispatched without virtual calls in the simulator's loop). Adding a law is
/// its own file and one line here.
macro_rules! registry {
    ($($kind:ident($ty:ty) { $($p:ident),+ }),+ $(,)?) => {
        /// How an element kind is named in files and reports.
        #[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
        #[serde(rename_all = "snake_case")]
        pub enum ElementKind {
            $(
                #[doc = concat!("See [`", stringify!($ty), "`].")]
                $kind,
            )+
        }

        impl ElementKind {
            /// Every registered kind.
            pub const ALL: &'static [ElementKind] = &[$(ElementKind::$kind),+];

            /// What the pipeline knows about the law.
            pub fn description(self) -> &'static Description {
                match self {
                    $(ElementKind::$kind => &<$ty as Law>::DESCRIPTION,)+
                }
            }
        }

        /// An element's kind and parameters (see each law's
        /// [`Description::parameters`] for their units and meaning). Read
        /// through the law's [`Law::declared`] (other terms, defaults).
        #[derive(Clone, Copy, Debug, PartialEq, Serialize)]
        #[serde(tag = "kind", rename_all = "snake_case")]
        pub enum ElementSpec {
            $(
                #[doc = concat!("See [`", stringify!($ty), "`].")]
                $kind {
                    $(
                        #[doc = concat!("`", stringify!($p), "`: see the law's parameter table.")]
                        $p: f64,
                    )+
                },
            )+
        }

        /// [`ElementSpec`] as read once its law has rewritten the fields.
        #[derive(Deserialize)]
        #[serde(tag = "kind", rename_all = "snake_case", deny_unknown_fields)]
        enum DeclaredSpec {
            $($kind { $($p: f64,)+ },)+
        }

        impl<'de> Deserialize<'de> for ElementSpec {
            fn deserialize<D: serde::Deserializer<'de>>(d: D) -> std::result::Result<Self, D::Error> {
                use serde::de::Error as _;
                let mut fields = serde_json::Map::<String, serde_json::Value>::deserialize(d)?;
                let kind = fields
                    .get("kind")
                    .and_then(serde_json::Value::as_str)
                    .and_then(ElementKind::from_name);
                match kind {
                    $(Some(ElementKind::$kind) => <$ty as Law>::declared(&mut fields).map_err(D::Error::custom)?,)+
                    None => {}
                }
                let spec = DeclaredSpec::deserialize(serde_json::Value::Object(fields))
                    .map_err(D::Error::custom)?;
                Ok(match spec {
                    $(DeclaredSpec::$kind { $($p),+ } => ElementSpec::$kind { $($p),+ },)+
                })
            }
        }

        impl ElementSpec {
            /// The kind.
            pub fn kind(&self) -> ElementKind {
                match self {
                    $(ElementSpec::$kind { .. } => ElementKind::$kind,)+
                }
            }

            /// Parameter names and values, in the law's order.
            pub fn parameters(&self) -> Vec<(&'static str, f64)> {
                match *self {
                    $(ElementSpec::$kind { $($p),+ } => vec![$((stringify!($p), $p)),+],)+
                }
            }

            /// An element of `kind` with parameter `values` in the law's
            /// order (unchecked: see [`ElementSpec::validate`]).
            ///
            /// # Panics
            /// If `values` has the wrong length (a programming error).
            pub fn from_values(kind: ElementKind, values: &[f64]) -> ElementSpec {
                let n = kind.description().parameters.len();
                assert_eq!(values.len(), n, "{} takes {n} parameters", kind.name());
                match kind {
                    $(ElementKind::$kind => {
                        let mut v = values.iter().copied();
                        ElementSpec::$kind { $($p: v.next().unwrap_or(f64::NAN)),+ }
                    })+
                }
            }

            fn build_law(&self) -> Result<AnyElement> {
                let values: Vec<f64> = self.parameters().iter().map(|p| p.1).collect();
                Ok(match self.kind() {
                    $(ElementKind::$kind => AnyElement::$kind(<$ty as Law>::from_parameters(&values)?),)+
                })
            }
        }

        /// Any registered element, with its state.
        #[derive(Clone, Debug)]
        pub enum AnyElement {
            $(
                #[doc = concat!("See [`", stringify!($ty), "`].")]
                $kind($ty),
            )+
        }

        macro_rules! dispatch {
            ($self_:expr, $e:ident => $body:expr) => {
                match $self_ {
                    $(AnyElement::$kind($e) => $body,)+
                }
            };
        }
    };
}

registry! {
    Jenkins(Jenkins) { kd, fd },
    Masing(Masing) { kd, fd, n },
    Iwan4(Masing<Iwan4Backbone>) { fs, kt, chi, beta },
    BoucWen(BoucWen) { alpha, beta, gamma, delta, nu },
    CubicStiffness(CubicStiffness) { k3 },
    QuadraticDamping(QuadraticDamping) { c2 },
    BilinearStiffness(BilinearStiffness) { kb },
    Clearance(Clearance) { k, gap },
    ViscousDamping(ViscousDamping) { cj },
    Shaker(Shaker) { ce, te, gain },
    Armature(Armature) { ma, ks, cs },
}

impl ElementKind {
    /// The snake-case name.
    pub fn name(self) -> &'static str {
        self.description().name
    }

    /// The kind called `name` in files and on the command line.
    pub fn from_name(name: &str) -> Option<ElementKind> {
        ElementKind::ALL.iter().copied().find(|k| k.name() == name)
    }

    /// The registered joint laws (see [`Description::is_joint`]).
    pub fn joints() -> impl Iterator<Item = ElementKind> {
        ElementKind::ALL
            .iter()
            .copied()
            .filter(|k| k.description().is_joint())
    }

    /// The joint laws `identify` fits (see [`Description::is_fitted_joint`]).
    pub fn fitted_joints() -> impl Iterator<Item = ElementKind> {
        ElementKind::ALL
            .iter()
            .copied()
            .filter(|k| k.description().is_fitted_joint())
    }
}

impl ElementSpec {
    /// What the pipeline knows about the law.
    pub fn description(&self) -> &'static Description {
        self.kind().description()
    }

    /// The same kind with parameters replaced, in the order of
    /// [`ElementSpec::parameters`].
    ///
    /// # Panics
    /// If `values` has the wrong length (a programming error).
    pub fn with_parameters(&self, values: &[f64]) -> ElementSpec {
        ElementSpec::from_values(self.kind(), values)
    }

    /// A joint of `kind` started at stick stiffness `kd` and slip force
    /// `fd` (a gauge at `kd / fd`, see [`Role::Gauge`]), its other
    /// parameters at their law's start; an error naming `field` if the kind
    /// is not a joint.
    pub fn joint(kind: ElementKind, kd: f64, fd: f64, field: &str) -> Result<ElementSpec> {
        let d = kind.description();
        if !d.is_fitted_joint() {
            let joints: Vec<&str> = ElementKind::fitted_joints()
                .map(ElementKind::name)
                .collect();
            return Err(Error::plan(
                field,
                format!(
                    "{} is not a joint element (use one of: {})",
                    d.name,
                    joints.join(", ")
                ),
            ));
        }
        let values: Vec<f64> = d
            .parameters
            .iter()
            .map(|p| match p.role {
                Role::StickStiffness => kd,
                Role::SlipForce => fd,
                Role::Gauge => kd / fd,
                Role::Other => p.start,
            })
            .collect();
        Ok(ElementSpec::from_values(kind, &values))
    }

    /// The value of the parameter with `role`, if the law has one.
    pub fn value_of(&self, role: Role) -> Option<f64> {
        let i = self.description().index_of(role)?;
        Some(self.parameters()[i].1)
    }

    /// Checks each parameter against its domain; `at` prefixes the field
    /// names in messages (e.g. `joint` or `effects[1]`).
    pub fn validate(&self, at: &str) -> Result<()> {
        for (info, (name, value)) in self.description().parameters.iter().zip(self.parameters()) {
            let field = format!("{at}.{name}");
            match info.domain {
                Domain::Positive => require_positive(&field, value)?,
                Domain::NonNegative => require_non_negative(&field, value)?,
                Domain::Signed => require_finite(&field, value)?,
                Domain::Range { min, max } => {
                    if !(value > min && value < max) {
                        return Err(Error::model(
                            field,
                            format!("must be between {min} and {max} (excluded), got {value}"),
                        ));
                    }
                }
            }
        }
        Ok(())
    }

    /// Builds a virgin element.
    pub fn build(&self) -> Result<AnyElement> {
        self.validate(self.kind().name())?;
        self.build_law()
    }

    /// The element's steady force–displacement loop under `x = a cos θ`:
    /// the second of two periods of `samples` points from the virgin state
    /// (for plots of hysteresis loops, paper Fig. 3.2).
    pub fn steady_loop(&self, amplitude: f64, samples: usize) -> Result<(Vec<f64>, Vec<f64>)> {
        let mut e = self.build()?;
        let n = samples.max(8);
        let (mut xs, mut fs) = (Vec::with_capacity(n + 1), Vec::with_capacity(n + 1));
        for i in 0..=2 * n {
            let th = 2.0 * std::f64::consts::PI * i as f64 / n as f64;
            let x = amplitude * th.cos();
            let v = -amplitude * th.sin();
            let f = e.commit(x, v).force;
            if i >= n {
                xs.push(x);
                fs.push(f);
            }
        }
        Ok((xs, fs))
    }

    /// The drive model it stands for, if it is one (a shaker).
    /// (Read from the parameters, not a built element: `Model::validate`
    /// asks it of every element on each prediction.)
    pub fn drive_load(&self) -> Option<DriveLoad> {
        match *self {
            ElementSpec::Shaker { ce, te, gain } => Shaker::with_gain(ce, te, gain).drive_load(),
            _ => None,
        }
    }

    /// The attachment it stands for, if it is one (an armature).
    pub fn attachment(&self) -> Option<Attachment> {
        match *self {
            ElementSpec::Armature { ma, ks, cs } => Some(Attachment {
                mass: ma,
                stiffness: ks,
                damping: cs,
            }),
            _ => None,
        }
    }

    /// The stick stiffness a hysteresis element adds at small amplitude
    /// (0 for the others).
    pub fn stick_stiffness(&self) -> f64 {
        self.value_of(Role::StickStiffness).unwrap_or(0.0)
    }
}

impl Element for AnyElement {
    #[inline]
    fn trial(&self, x: f64, v: f64) -> ElementForce {
        dispatch!(self, e => e.trial(x, v))
    }
    #[inline]
    fn commit(&mut self, x: f64, v: f64) -> ElementForce {
        dispatch!(self, e => e.commit(x, v))
    }
    fn reset(&mut self) {
        dispatch!(self, e => e.reset())
    }
    fn has_memory(&self) -> bool {
        dispatch!(self, e => e.has_memory())
    }
    fn uses_velocity(&self) -> bool {
        dispatch!(self, e => e.uses_velocity())
    }
    fn odd_law(&self) -> bool {
        dispatch!(self, e => e.odd_law())
    }
    fn periods_to_settle(&self) -> usize {
        dispatch!(self, e => e.periods_to_settle())
    }
    fn open_period(&mut self) {
        dispatch!(self, e => e.open_period())
    }
    fn start_symmetric_loop(&mut self, x: f64) {
        dispatch!(self, e => e.start_symmetric_loop(x))
    }
    fn close_period(&mut self, mirror: bool) -> f64 {
        dispatch!(self, e => e.close_period(mirror))
    }
    fn describing_function(
        &mut self,
        amplitude: f64,
        omega: f64,
        samples: usize,
    ) -> num_complex::Complex64 {
        dispatch!(self, e => e.describing_function(amplitude, omega, samples))
    }
    #[inline]
    fn solve_implicit(&self, step: &ImplicitStep) -> Option<f64> {
        dispatch!(self, e => e.solve_implicit(step))
    }
    fn set_sample_interval(&mut self, h: f64) {
        dispatch!(self, e => e.set_sample_interval(h))
    }
    #[inline]
    fn kink_impulse(&self) -> f64 {
        dispatch!(self, e => e.kink_impulse())
    }
    fn set_time_step(&mut self, h: f64) {
        dispatch!(self, e => e.set_time_step(h))
    }
    fn drive_load(&self) -> Option<element::DriveLoad> {
        dispatch!(self, e => e.drive_load())
    }
    fn attachment(&self) -> Option<Attachment> {
        dispatch!(self, e => e.attachment())
    }
    fn drive_reaction(&self) -> f64 {
        dispatch!(self, e => e.drive_reaction())
    }
    #[inline]
    fn commit_sensitivity(
        &mut self,
        x: f64,
        v: f64,
        dx: &[f64],
        dv: &[f64],
        df: &mut [f64],
    ) -> ElementForce {
        dispatch!(self, e => e.commit_sensitivity(x, v, dx, dv, df))
    }
    fn commit_run(&mut self, x: &[f64], v: &[f64], g: &mut [f64]) {
        dispatch!(self, e => e.commit_run(x, v, g))
    }
    fn memory_terms(&self) -> Option<usize> {
        dispatch!(self, e => e.memory_terms())
    }
    #[inline]
    fn commit_sensitivity_terms(
        &mut self,
        x: f64,
        v: f64,
        dx: &[f64],
        dv: &[f64],
        terms: &mut element::SensitivityTerms,
    ) -> ElementForce {
        dispatch!(self, e => e.commit_sensitivity_terms(x, v, dx, dv, terms))
    }
}

/// Where an element sits in a [`Model`]: the joint, or one of the effects.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum ElementAt {
    /// The joint.
    Joint,
    /// Effect `i` (in `Model::effects`).
    Effect(usize),
    /// The own joint of mode `i` (in `Model::linear.modes`): a hysteretic
    /// mode's.
    ModeJoint(usize),
}

impl std::fmt::Display for ElementAt {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            ElementAt::Joint => f.write_str("joint"),
            ElementAt::Effect(i) => write!(f, "effects[{i}]"),
            ElementAt::ModeJoint(i) => write!(f, "modes[{i}].joint"),
        }
    }
}

/// A structure: the underlying linear modes, the joint, and the effects
/// acting beside it at the joint point; their forces add.
///
/// The joint is a field of its own, not a position in a list: it is the
/// element a fit identifies by stick stiffness and slip force
/// ([`Description::is_joint`]), the one a diagnosis keeps while it adds
/// effects. Files hold `{linear, joint, effects}`; a file from before
/// the split (`elements`, a list) is read with its joint law, wherever it
/// stood, as the joint.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(try_from = "ModelForm")]
pub struct Model {
    /// The underlying linear structure.
    pub linear: ModalModel,
    /// The joint, if any: a joint law.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub joint: Option<ElementSpec>,
    /// The effects: laws that are not joints.
    pub effects: Vec<ElementSpec>,
}

/// A model as files hold it, in the current form or the older list form.
#[derive(Deserialize)]
struct ModelForm {
    linear: ModalModel,
    #[serde(default)]
    joint: Option<ElementSpec>,
    #[serde(default)]
    effects: Vec<ElementSpec>,
    #[serde(default)]
    elements: Option<Vec<ElementSpec>>,
}

impl TryFrom<ModelForm> for Model {
    type Error = Error;
    fn try_from(f: ModelForm) -> Result<Model> {
        let m = match f.elements {
            Some(_) if f.joint.is_some() || !f.effects.is_empty() => {
                return Err(Error::model(
                    "elements",
                    "give either `elements` (the old form) or `joint` and `effects`, not both",
                ));
            }
            Some(list) => Model::classified(f.linear, list)?,
            None => Model {
                linear: f.linear,
                joint: f.joint,
                effects: f.effects,
            },
        };
        m.check_places()?;
        Ok(m)
    }
}

impl Model {
    /// A model from the elements at the joint point, each placed by its law:
    /// a joint law is the joint, every other law an effect. Checks every
    /// part.
    pub fn new(linear: ModalModel, elements: Vec<ElementSpec>) -> Result<Model> {
        let m = Model::classified(linear, elements)?;
        m.validate()?;
        Ok(m)
    }

    /// A model with its joint and effects given apart. Checks every part.
    pub fn with_joint(
        linear: ModalModel,
        joint: Option<ElementSpec>,
        effects: Vec<ElementSpec>,
    ) -> Result<Model> {
        let m = Model {
            linear,
            joint,
            effects,
        };
        m.validate()?;
        Ok(m)
    }

    /// Places each element by its law (no value checks).
    fn classified(linear: ModalModel, elements: Vec<ElementSpec>) -> Result<Model> {
        let (joints, effects): (Vec<_>, Vec<_>) = elements
            .into_iter()
            .partition(|e| e.description().is_joint());
        if joints.len() > 1 {
            let names: Vec<_> = joints.iter().map(|e| e.kind().name()).collect();
            return Err(Error::model(
                "elements",
                format!(
                    "{} joint laws ({}); a model has one joint",
                    joints.len(),
                    names.join(", ")
                ),
            ));
        }
        Ok(Model {
            linear,
            joint: joints.into_iter().next(),
            effects,
        })
    }

    /// Error unless the joint is a joint law and no effect is.
    fn check_places(&self) -> Result<()> {
        if let Some(j) = &self.joint
            && !j.description().is_joint()
        {
            return Err(Error::model(
                "joint",
                format!(
                    "`{}` is not a joint law; give it as an effect",
                    j.kind().name()
                ),
            ));
        }
        for (i, e) in self.effects.iter().enumerate() {
            if e.description().is_joint() {
                return Err(Error::model(
                    format!("effects[{i}]"),
                    format!(
                        "`{}` is a joint law; a model has one joint",
                        e.kind().name()
                    ),
                ));
            }
        }
        Ok(())
    }

    /// Checks every part.
    pub fn validate(&self) -> Result<()> {
        self.linear.validate()?;
        self.check_places()?;
        if (self.joint.is_some() || !self.effects.is_empty())
            && self.linear.modes.iter().all(|m| m.is_hysteretic())
        {
            return Err(Error::model(
                "modes",
                "every mode carries its own joint, so nothing is left for the model's joint \
                 and effects to act on: give a mode without a joint",
            ));
        }
        for (at, e) in self.placed() {
            e.validate(&at.to_string())?;
        }
        let drives: Vec<(ElementAt, &ElementSpec)> = self
            .placed()
            .filter(|(_, e)| e.drive_load().is_some())
            .collect();
        if drives.len() > 1 {
            return Err(Error::model(
                drives[1].0.to_string(),
                "a model has one shaker (the drive of its one reference)",
            ));
        }
        if let Some((at, _)) = self.placed().find(|(_, e)| e.attachment().is_some())
            && self.linear.modes.iter().any(|m| m.is_hysteretic())
        {
            return Err(Error::model(
                at.to_string(),
                armature::BESIDE_A_HYSTERETIC_MODE,
            ));
        }
        Ok(())
    }

    /// Every element with its place: the joint first, then the effects.
    pub fn placed(&self) -> impl Iterator<Item = (ElementAt, &ElementSpec)> {
        self.joint.iter().map(|j| (ElementAt::Joint, j)).chain(
            self.effects
                .iter()
                .enumerate()
                .map(|(i, e)| (ElementAt::Effect(i), e)),
        )
    }

    /// [`Model::placed`], then each hysteretic mode's own joint: every law
    /// a fit may free.
    pub fn placed_all(&self) -> impl Iterator<Item = (ElementAt, &ElementSpec)> {
        self.placed().chain(
            self.linear
                .modes
                .iter()
                .enumerate()
                .filter_map(|(i, m)| m.joint.as_ref().map(|j| (ElementAt::ModeJoint(i), j))),
        )
    }

    /// How a fit names the parameters of the element at `at`: the joint's
    /// plainly (`kd`), an effect's after its law (`cubic_stiffness.k3`), a
    /// hysteretic mode's joint after its mode as the linear part names it
    /// (`hysteretic_mode.joint.kd`, see [`ModalModel::label`]).
    pub fn parameter_prefix(&self, at: ElementAt) -> String {
        match at {
            ElementAt::Joint => String::new(),
            ElementAt::Effect(i) => self
                .effects
                .get(i)
                .map_or_else(String::new, |e| e.kind().name().to_string()),
            ElementAt::ModeJoint(i) => format!("{}.joint", self.linear.label(i)),
        }
    }

    /// Every element: the joint first, then the effects.
    pub fn elements(&self) -> impl Iterator<Item = &ElementSpec> {
        self.placed().map(|(_, e)| e)
    }

    /// The element at `at`.
    pub fn element(&self, at: ElementAt) -> Result<&ElementSpec> {
        match at {
            ElementAt::Joint => self.joint.as_ref(),
            ElementAt::Effect(i) => self.effects.get(i),
            ElementAt::ModeJoint(i) => self.linear.modes.get(i).and_then(|m| m.joint.as_ref()),
        }
        .ok_or_else(|| Error::model(at.to_string(), "no such element"))
    }

    /// The element at `at`, to change.
    pub fn element_mut(&mut self, at: ElementAt) -> Result<&mut ElementSpec> {
        match at {
            ElementAt::Joint => self.joint.as_mut(),
            ElementAt::Effect(i) => self.effects.get_mut(i),
            ElementAt::ModeJoint(i) => self.linear.modes.get_mut(i).and_then(|m| m.joint.as_mut()),
        }
        .ok_or_else(|| Error::model(at.to_string(), "no such element"))
    }

    /// The model with one more effect.
    pub fn with_effect(&self, effect: ElementSpec) -> Model {
        let mut m = self.clone();
        m.effects.push(effect);
        m
    }

    /// The elements, built and virgin.
    pub fn element_set(&self) -> Result<ElementSet<AnyElement>> {
        Ok(ElementSet::new(
            self.elements()
                .map(ElementSpec::build)
                .collect::<Result<_>>()?,
        ))
    }

    /// Total stick stiffness the hysteresis elements add at small amplitude.
    pub fn stick_stiffness(&self) -> f64 {
        self.elements().map(ElementSpec::stick_stiffness).sum()
    }

    /// The highest frequency the linearised structure can ring at, Hz: the
    /// highest mode, or the SDOF's stick natural frequency `√((k + kd)/m)/2π`
    /// when a hysteresis element stiffens it. Sample rates are counted against
    /// it, not against the drive: the filter must resolve the stick mode.
    pub fn highest_linearised_frequency_hz(&self) -> f64 {
        self.linearised_frequencies_hz().fold(0.0, f64::max)
    }

    /// [`Model::highest_linearised_frequency_hz`] without the linear modes
    /// above `quasi_static_above_hz`, which a replay takes quasi-static
    /// (see [`crate::validate::QUASI_STATIC_ABOVE_RATE`]): the frequency a
    /// replay's rate must resolve. Zero when every mode is quasi-static.
    pub fn highest_replayed_frequency_hz(&self, quasi_static_above_hz: f64) -> f64 {
        self.linear
            .modes
            .iter()
            .zip(self.linearised_frequencies_hz())
            .filter(|(m, _)| !m.is_quasi_static_above(quasi_static_above_hz))
            .map(|(_, f)| f)
            .fold(0.0, f64::max)
    }

    /// The lowest of the modes' linearised frequencies, Hz (as
    /// [`Model::highest_linearised_frequency_hz`] counts them).
    pub fn lowest_linearised_frequency_hz(&self) -> f64 {
        self.linearised_frequencies_hz()
            .fold(f64::INFINITY, f64::min)
    }

    /// Each mode's frequency with the joints stuck, Hz.
    pub fn linearised_frequencies_hz(&self) -> impl Iterator<Item = f64> + '_ {
        let kd = self.stick_stiffness();
        self.linear.modes.iter().map(move |m| {
            // a hysteretic mode is stiffened by its own joint alone
            let k = m.joint.as_ref().map_or(kd, ElementSpec::stick_stiffness);
            let w2 = m.omega().powi(2) + k * m.residue.abs();
            w2.sqrt() / (2.0 * std::f64::consts::PI)
        })
    }

    /// Every law in the model: the joint, the effects, and the hysteretic
    /// modes' joints.
    pub fn laws(&self) -> impl Iterator<Item = &ElementSpec> {
        self.placed_all().map(|(_, e)| e)
    }

    /// Whether any element has memory.
    pub fn has_memory(&self) -> bool {
        self.laws().any(|e| e.description().memory)
    }

    /// Whether any element breaks the half-wave symmetry (makes even
    /// harmonics and DC under symmetric forcing).
    pub fn is_asymmetric(&self) -> bool {
        self.laws().any(|e| !e.description().odd)
    }

    /// The most samples per period any element's law needs (0: none).
    pub fn samples_per_period(&self) -> usize {
        self.laws()
            .map(|e| e.description().samples_per_period)
            .max()
            .unwrap_or(0)
    }

    /// The samples per period a fit's harmonic balance needs when every law
    /// the model holds is smooth enough to state its own count
    /// ([`Description::smooth_samples`]): the largest they state (0: none
    /// beyond what the harmonics ask). `None` when a law states none, or
    /// there is no law: the default count then stands.
    pub fn smooth_samples_per_period(&self) -> Option<usize> {
        let mut most = None;
        for e in self.laws() {
            let values: Vec<f64> = e.parameters().iter().map(|&(_, v)| v).collect();
            let need = e.description().smooth_samples?(&values);
            most = Some(most.map_or(need, |m: usize| m.max(need)));
        }
        most
    }

    /// The model as uncoupled parts whose responses add (see
    /// [`modal`](crate::model::modal)): the point structure with the joint
    /// and effects (sign 1), then each hysteretic mode as its own SDOF with
    /// its joint, with the sign its contribution takes at the point. A model
    /// without hysteretic modes is one part, itself. The point structure may
    /// have no mode (every mode hysteretic): it is then left out.
    pub fn parts(&self) -> Vec<(f64, Model)> {
        if !self.linear.has_hysteretic_modes() {
            return vec![(1.0, self.clone())];
        }
        let point = self.linear.point_part();
        let mut parts = Vec::new();
        if !point.modes.is_empty() {
            parts.push((
                1.0,
                Model {
                    linear: point,
                    joint: self.joint,
                    effects: self.effects.clone(),
                },
            ));
        }
        // the drive's lag (a shaker's coil) reaches every part alike; its
        // back-EMF answers the point structure's motion alone (see
        // `Shaker`), so a hysteretic mode gets the lag without it
        let drive: Vec<ElementSpec> = self
            .effects
            .iter()
            .filter_map(|e| match *e {
                ElementSpec::Shaker { te, gain, .. } => {
                    Some(ElementSpec::Shaker { ce: 0.0, te, gain })
                }
                _ => None,
            })
            .collect();
        for m in self.linear.modes.iter().filter(|m| m.is_hysteretic()) {
            let (sign, linear) = m.own_sdof();
            parts.push((
                sign,
                Model {
                    linear,
                    joint: m.joint,
                    effects: drive.clone(),
                },
            ));
        }
        parts
    }

    /// Errors unless a reference of quantity `reference` (named `what`) can
    /// drive the model: a model with a shaker takes the voltage that drives
    /// the shaker, not a measured force (the force a gauge reads is what
    /// the shaker already made of the voltage).
    pub fn check_reference(&self, reference: crate::harmonics::Quantity, what: &str) -> Result<()> {
        if reference == crate::harmonics::Quantity::Force
            && self.laws().any(|e| e.drive_load().is_some())
        {
            return Err(Error::input(
                what,
                "is a force, and the model has a shaker, which a voltage drives: take a \
                 model without the shaker (the force is the structure's own input), or the \
                 amplifier's voltage as the reference (`--reference` with its channel's name)",
            ));
        }
        Ok(())
    }

    /// The position of parameter `name` in the element at `at` (an error
    /// naming both if there is none).
    pub fn parameter_index(&self, at: ElementAt, name: &str) -> Result<usize> {
        let e = self.element(at)?;
        e.parameters()
            .iter()
            .position(|(p, _)| *p == name)
            .ok_or_else(|| {
                Error::model(
                    format!("{at}.{name}"),
                    format!("{} has no such parameter", e.kind().name()),
                )
            })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn specs_parse_from_toml_and_reject_unknown_keys() {
        #[derive(Deserialize)]
        struct W {
            joint: ElementSpec,
        }
        let w: W =
            toml::from_str("[joint]\nkind = \"jenkins\"\nkd = 2.4e7\nfd = 246.048\n").unwrap();
        assert_eq!(
            w.joint,
            ElementSpec::Jenkins {
                kd: 2.4e7,
                fd: 246.048
            }
        );
        let e = toml::from_str::<W>("[joint]\nkind = \"jenkins\"\nkd = 2.4e7\nfd = 1.0\nkx = 3\n")
            .err()
            .unwrap()
            .to_string();
        assert!(e.contains("kx"), "{e}");
        let e = toml::from_str::<W>("[joint]\nkind = \"bouncy\"\n")
            .err()
            .unwrap()
            .to_string();
        assert!(e.contains("bouncy"), "{e}");
    }

    /// The joint is a field: placed by its law whatever the order it is
    /// given in, read from the list form older files hold, and a second
    /// joint, a joint among the effects or an effect as the joint is an
    /// error naming the place.
    #[test]
    fn the_joint_is_placed_by_its_law() {
        let linear = ModalModel::sdof(10.0, 200.0, 1e7).unwrap();
        let cubic = ElementSpec::CubicStiffness { k3: 1e12 };
        let jenkins = ElementSpec::Jenkins {
            kd: 2.4e7,
            fd: 246.0,
        };
        let m = Model::new(linear.clone(), vec![cubic, jenkins]).unwrap();
        assert_eq!(m.joint, Some(jenkins));
        assert_eq!(m.effects, vec![cubic]);
        assert_eq!(
            m.placed().map(|(at, _)| at).collect::<Vec<_>>(),
            [ElementAt::Joint, ElementAt::Effect(0)]
        );
        // today's form round-trips; the old list form reads the same
        let json = serde_json::to_value(&m).unwrap();
        assert_eq!(json["joint"]["kind"], "jenkins");
        assert_eq!(json["effects"][0]["kind"], "cubic_stiffness");
        assert!(json.get("elements").is_none());
        assert_eq!(serde_json::from_value::<Model>(json.clone()).unwrap(), m);
        let mut old = json.clone();
        let o = old.as_object_mut().unwrap();
        let (j, e) = (o.remove("joint").unwrap(), o.remove("effects").unwrap());
        o.insert("elements".into(), serde_json::json!([e[0], j]));
        assert_eq!(serde_json::from_value::<Model>(old).unwrap(), m);
        // misplaced laws
        let e = Model::new(linear.clone(), vec![jenkins, jenkins])
            .unwrap_err()
            .to_string();
        assert!(e.contains("one joint"), "{e}");
        let e = Model::with_joint(linear.clone(), Some(cubic), vec![])
            .unwrap_err()
            .to_string();
        assert!(e.contains("joint") && e.contains("cubic_stiffness"), "{e}");
        let mut bad = json;
        bad["effects"] = serde_json::json!([bad["joint"]]);
        let e = serde_json::from_value::<Model>(bad)
            .unwrap_err()
            .to_string();
        assert!(e.contains("effects[0]") && e.contains("joint law"), "{e}");
        // a model without a joint is a linear structure with effects
        let m = Model::with_joint(linear, None, vec![cubic]).unwrap();
        assert!(m.element(ElementAt::Joint).is_err());
        assert!(!m.has_memory());
    }

    /// The registry and each law's description agree, and what a
    /// description says is what the element does: its symmetry (forces
    /// mirrored under a mirrored history), its memory (the force along a
    /// reversing history is a function of `(x, v)` alone, or not), its
    /// velocity dependence, and its describing function (the marched loop's
    /// fundamental). Every law passes the element checker at its example.
    #[test]
    fn every_registered_law_is_what_its_description_says() {
        use element::check::{check_element, history};
        for &kind in ElementKind::ALL {
            let d = kind.description();
            let spec = ElementSpec::from_values(kind, d.example);
            let names: Vec<&str> = spec.parameters().iter().map(|p| p.0).collect();
            let described: Vec<&str> = d.parameters.iter().map(|p| p.name).collect();
            assert_eq!(names, described, "{}", d.name);
            assert_eq!(ElementKind::from_name(d.name), Some(kind));
            assert_eq!(
                serde_json::to_value(kind).unwrap(),
                serde_json::json!(d.name),
                "the serde name of {kind:?}"
            );
            let mut e = spec.build().unwrap();
            assert_eq!(e.has_memory(), d.memory, "{}", d.name);
            assert_eq!(e.odd_law(), d.odd, "{}", d.name);
            check_element(e.clone(), 3e-5, 300.0);
            // symmetry, memory and velocity, from forces along a history
            let xs = history(3e-5);
            let march = |e: &mut AnyElement, sign: f64, speed: f64| -> Vec<f64> {
                e.reset();
                let mut prev = 0.0;
                xs.iter()
                    .map(|&x| {
                        let v = (x - prev) * speed;
                        prev = x;
                        e.commit(sign * x, sign * v).force
                    })
                    .collect()
            };
            let up = march(&mut e, 1.0, 1e3);
            let down = march(&mut e, -1.0, 1e3);
            let odd = up
                .iter()
                .zip(&down)
                .all(|(a, b)| (a + b).abs() <= 1e-12 * a.abs().max(1e-9));
            assert_eq!(odd, d.odd, "{}: odd law", d.name);
            let slow = march(&mut e, 1.0, 2e3);
            let velocity = up
                .iter()
                .zip(&slow)
                .any(|(a, b)| (a - b).abs() > 1e-9 * a.abs().max(1e-9));
            assert_eq!(
                velocity,
                e.uses_velocity(),
                "{}: velocity dependence",
                d.name
            );
            if !e.uses_velocity() {
                // without memory the force at the same x is the same on the
                // way up and the way down
                let mut seen: Vec<(f64, f64)> = Vec::new();
                let mut history_dependent = false;
                for (&x, &f) in xs.iter().zip(&up) {
                    if let Some(&(_, g)) = seen.iter().find(|(y, _)| (y - x).abs() < 1e-18) {
                        history_dependent |= (g - f).abs() > 1e-9 * f.abs().max(1e-6);
                    }
                    seen.push((x, f));
                }
                assert_eq!(history_dependent, d.memory, "{}: memory", d.name);
            }
            // the describing function against one marched loop of many samples
            let omega = 2.0 * std::f64::consts::PI * 200.0;
            for a in [3e-6, 2e-5, 1e-4] {
                let own = e.describing_function(a, omega, 4096);
                let marched = element::loop_fundamental(&mut e, a, omega, 1 << 16);
                assert!(
                    (own - marched).norm() <= 2e-4 * marched.norm() + 1e-9,
                    "{} at a = {a}: {own} vs {marched}",
                    d.name
                );
            }
            if d.is_fitted_joint() {
                let j = ElementSpec::joint(kind, 1e7, 100.0, "element").unwrap();
                assert_eq!(j.stick_stiffness(), 1e7);
                match j.value_of(Role::SlipForce) {
                    Some(fd) => assert_eq!(fd, 100.0),
                    None => {
                        // a gauged law started at (kd, fd) saturates at fd:
                        // loaded to ten slip displacements, within 1e-3
                        let mut e = j.build().unwrap();
                        let mut f = 0.0;
                        for i in 1..=1000 {
                            f = e.commit(1e-4 * i as f64 / 1000.0, 1.0).force;
                        }
                        assert!((f / 100.0 - 1.0).abs() < 1e-3, "{}: {f}", d.name);
                    }
                }
            } else {
                let err = ElementSpec::joint(kind, 1e7, 100.0, "element").unwrap_err();
                assert!(err.to_string().contains("not a joint"), "{err}");
            }
        }
        assert_eq!(
            ElementKind::joints().collect::<Vec<_>>(),
            [
                ElementKind::Jenkins,
                ElementKind::Masing,
                ElementKind::Iwan4,
                ElementKind::BoucWen
            ]
        );
        assert_eq!(
            ElementKind::fitted_joints().collect::<Vec<_>>(),
            [
                ElementKind::Jenkins,
                ElementKind::Masing,
                ElementKind::Iwan4,
                ElementKind::BoucWen
            ]
        );
    }

    #[test]
    fn parameters_round_trip() {
        let s = ElementSpec::Masing {
            kd: 1.0,
            fd: 2.0,
            n: 3.0,
        };
        let v: Vec<f64> = s.parameters().iter().map(|p| p.1).collect();
        assert_eq!(s.with_parameters(&v), s);
        assert!(
            ElementSpec::Masing {
                kd: 1.0,
                fd: -2.0,
                n: 3.0
            }
            .build()
            .is_err()
        );
    }

    #[test]
    fn stick_frequency_of_the_paper_system() {
        let m = Model::new(
            ModalModel::sdof(10.0, 200.0, 1e7).unwrap(),
            vec![ElementSpec::Jenkins {
                kd: 2.4e7,
                fd: 246.048,
            }],
        )
        .unwrap();
        let f = m.highest_linearised_frequency_hz();
        assert!((f - (3.4e7f64 / 10.0).sqrt() / (2.0 * std::f64::consts::PI)).abs() < 1e-9);
    }
}
