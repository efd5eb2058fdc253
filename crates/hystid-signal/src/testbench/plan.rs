//! The test definition: a TOML file describing the structure and the
//! stepped-sine test, and the resolved plan the bench executes.
//!
//! The key names of the TOML are a contract (see `signals/default.toml`);
//! unknown keys and out-of-range values are errors that name the key.

use crate::error::{Error, Result};
use crate::extract::Direction;
use crate::harmonics::Quantity;
use crate::model::{ElementKind, ElementSpec, ModalModel, Mode, Model};
use serde::{Deserialize, Serialize};

/// The embedded default test definition (the paper's simulated case).
pub const DEFAULT_TEST: &str = include_str!("../../../../signals/default.toml");

/// A whole test definition file.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TestDefinition {
    /// The underlying linear SDOF (`mass`, `damping`, `stiffness`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub system: Option<SystemSpec>,
    /// The multi-mode form of the underlying linear structure.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub modes: Vec<ModeSpec>,
    /// The joint element.
    #[serde(default)]
    pub joint: JointSpec,
    /// Further effects acting with the joint.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub effects: Vec<EffectSpec>,
    /// The stepped-sine test.
    pub test: TestSpec,
}

/// The structure of a test definition alone: its `[system]` (or
/// `[[modes]]`), `[joint]` and `[[effects]]`, without `[test]`; what a
/// [`Model`] is built from ([`model_from_toml`] takes either).
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct StructureDefinition {
    /// The underlying linear SDOF (`mass`, `damping`, `stiffness`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub system: Option<SystemSpec>,
    /// The multi-mode form of the underlying linear structure.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub modes: Vec<ModeSpec>,
    /// The joint element.
    #[serde(default)]
    pub joint: JointSpec,
    /// Further effects acting with the joint.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub effects: Vec<EffectSpec>,
}

/// The model of a test definition's TOML text, or of its structure alone
/// (no `[test]` table); `origin` names the text in errors. A text with a
/// `[test]` table is checked whole, as [`TestDefinition::from_toml`] does.
pub fn model_from_toml(text: &str, origin: &str) -> Result<Model> {
    let has_test = text
        .parse::<toml::Table>()
        .is_ok_and(|t| t.contains_key("test"));
    let model = if has_test {
        TestDefinition::from_toml(text, origin)?.model()
    } else {
        StructureDefinition::from_toml(text, origin)?.model()
    };
    model.map_err(|e| in_file(origin, e))
}

/// A value refused in a file's definition, said with the file: the checks
/// name the field only, as they also check models built in code.
fn in_file(origin: &str, e: Error) -> Error {
    match e {
        Error::InvalidPlan { field, message } | Error::InvalidModel { field, message } => {
            Error::format(origin, field, message)
        }
        e => e,
    }
}

/// An SDOF `m, c, k`.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SystemSpec {
    /// kg.
    pub mass: f64,
    /// N s/m.
    pub damping: f64,
    /// N/m.
    pub stiffness: f64,
}

/// One mode of the multi-mode form.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ModeSpec {
    /// Natural frequency, Hz.
    pub frequency_hz: f64,
    /// Damping ratio.
    pub damping_ratio: f64,
    /// Modal mass at the joint point, kg (give this or `residue`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub modal_mass: Option<f64>,
    /// Modal constant `1/m_r`, 1/kg.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub residue: Option<f64>,
    /// The mode's own joint: a hysteretic mode (see [`crate::model::modal`]).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub joint: Option<ElementSpec>,
}

/// The joint: a registered joint law (see
/// [`crate::model::Description::is_joint`]), or none (`kind = "none"`, or no
/// `[joint]` table).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct JointSpec(pub Option<ElementSpec>);

impl Serialize for JointSpec {
    fn serialize<S: serde::Serializer>(&self, s: S) -> std::result::Result<S::Ok, S::Error> {
        use serde::ser::SerializeMap;
        match &self.0 {
            Some(e) => e.serialize(s),
            None => {
                let mut m = s.serialize_map(Some(1))?;
                m.serialize_entry("kind", "none")?;
                m.end()
            }
        }
    }
}

impl<'de> Deserialize<'de> for JointSpec {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> std::result::Result<Self, D::Error> {
        use serde::de::Error as _;
        let v = serde_json::Value::deserialize(d)?;
        if v.get("kind").and_then(|k| k.as_str()) == Some("none") {
            return match v.as_object().map(|o| o.len()) {
                Some(1) => Ok(JointSpec(None)),
                _ => Err(D::Error::custom(
                    "a joint of kind `none` takes no parameters",
                )),
            };
        }
        // an unknown kind: the joints, not every law serde would list
        if let Some(kind) = v.get("kind").and_then(|k| k.as_str())
            && ElementKind::from_name(kind).is_none()
        {
            return Err(D::Error::custom(format!(
                "unknown joint kind `{kind}`: expected one of {}, or none",
                joint_names().join(", ")
            )));
        }
        let spec: ElementSpec = serde_json::from_value(v).map_err(D::Error::custom)?;
        if !spec.description().is_joint() {
            return Err(D::Error::custom(format!(
                "`{}` is not a joint law (joints: {}, or none); give it under [[effects]]",
                spec.kind().name(),
                joint_names().join(", ")
            )));
        }
        Ok(JointSpec(Some(spec)))
    }
}

fn joint_names() -> Vec<&'static str> {
    ElementKind::joints().map(ElementKind::name).collect()
}

/// An effect acting besides the joint: a registered law that is not a joint,
/// or a further linear mode (`kind = "second_mode"`).
#[derive(Clone, Debug, PartialEq)]
pub enum EffectSpec {
    /// An element law at the joint point.
    Element(ElementSpec),
    /// A further linear mode.
    SecondMode(SecondModeSpec),
}

/// A further linear mode given as an effect.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SecondModeSpec {
    /// Hz.
    pub frequency_hz: f64,
    /// Damping ratio.
    pub damping_ratio: f64,
    /// Modal mass at the joint point, kg.
    pub modal_mass: f64,
}

/// The parameter names of a further mode given as an effect.
const SECOND_MODE_KEYS: &[&str] = &["frequency_hz", "damping_ratio", "modal_mass"];

impl Serialize for EffectSpec {
    fn serialize<S: serde::Serializer>(&self, s: S) -> std::result::Result<S::Ok, S::Error> {
        use serde::ser::SerializeMap;
        match self {
            EffectSpec::Element(e) => e.serialize(s),
            EffectSpec::SecondMode(m) => {
                let mut map = s.serialize_map(Some(4))?;
                map.serialize_entry("kind", "second_mode")?;
                map.serialize_entry("frequency_hz", &m.frequency_hz)?;
                map.serialize_entry("damping_ratio", &m.damping_ratio)?;
                map.serialize_entry("modal_mass", &m.modal_mass)?;
                map.end()
            }
        }
    }
}

impl<'de> Deserialize<'de> for EffectSpec {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> std::result::Result<Self, D::Error> {
        use serde::de::Error as _;
        let mut v = serde_json::Value::deserialize(d)?;
        if v.get("kind").and_then(|k| k.as_str()) == Some("second_mode") {
            if let Some(o) = v.as_object_mut() {
                o.remove("kind");
            }
            return serde_json::from_value(v)
                .map(EffectSpec::SecondMode)
                .map_err(D::Error::custom);
        }
        // an unknown kind: the effects, not every law serde would list
        if let Some(kind) = v.get("kind").and_then(|k| k.as_str())
            && ElementKind::from_name(kind).is_none()
        {
            let effects: Vec<&str> = ElementKind::ALL
                .iter()
                .filter(|k| !k.description().is_joint())
                .map(|k| k.name())
                .collect();
            return Err(D::Error::custom(format!(
                "unknown effect kind `{kind}`: expected one of {}, or second_mode",
                effects.join(", ")
            )));
        }
        let spec: ElementSpec = serde_json::from_value(v).map_err(D::Error::custom)?;
        if spec.description().is_joint() {
            return Err(D::Error::custom(format!(
                "`{}` is a joint law: give it as [joint]",
                spec.kind().name()
            )));
        }
        Ok(EffectSpec::Element(spec))
    }
}

/// Frequencies: an explicit list or an evenly spaced range.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(untagged)]
pub enum FrequencyList {
    /// `{ start, stop, count }`, optionally `spacing = "log"`.
    Range(FrequencyRange),
    /// Explicit values, Hz.
    List(Vec<f64>),
}

/// An evenly spaced frequency range.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct FrequencyRange {
    /// First frequency, Hz.
    pub start: f64,
    /// Last frequency, Hz.
    pub stop: f64,
    /// Number of frequencies (≥ 1).
    pub count: usize,
    /// `linear` (default) or `log`.
    #[serde(default)]
    pub spacing: Spacing,
}

/// Spacing of a frequency range.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Spacing {
    /// Equal steps in Hz.
    #[default]
    Linear,
    /// Equal ratios.
    Log,
}

/// Sweep order of the dwells within a level.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum SweepOrder {
    /// Increasing frequency.
    #[default]
    Up,
    /// Decreasing frequency.
    Down,
    /// Up, then down again without stopping.
    Both,
}

/// The stepped-sine test.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TestSpec {
    /// Dwell frequencies.
    pub frequencies_hz: FrequencyList,
    /// Force amplitudes, N (one sweep per level).
    pub levels_n: Vec<f64>,
    /// Sweep order.
    #[serde(default)]
    pub sweep: SweepOrder,
    /// Response noise RMS as a fraction of the clean response RMS, per dwell
    /// and channel.
    #[serde(default = "default_noise")]
    pub noise: f64,
    /// Force noise RMS as a fraction of the clean force RMS.
    #[serde(default)]
    pub force_noise: f64,
    /// With a shaker: also record the force it applies (a force gauge
    /// between the shaker and the structure, noise `force_noise`) as a
    /// `force` channel beside the voltage. The recording's reference is
    /// then that force (the first force channel), and so is the bench's.
    #[serde(default, skip_serializing_if = "std::ops::Not::not")]
    pub force_gauge: bool,
    /// Noise seed.
    #[serde(default = "default_seed")]
    pub seed: u64,
    /// The response quantity of the FRFs.
    #[serde(default = "default_response")]
    pub response: ResponseKind,
    /// Sample rate, Hz; default: at least 100 samples per period of the
    /// stiffest linearised mode (a joint's stick mode, not the drive, is what
    /// must be resolved), rounded up to 1 kHz.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub sample_rate_hz: Option<f64>,
    /// The simulator runs this many times faster than the recording, which
    /// keeps every `oversample`-th sample; default: enough for 200 samples
    /// per period of the stiffest linearised mode (the digital-filter
    /// method's error is then ~1e-4 in H1; `tests/sim.rs` holds it below
    /// 5e-4 against an RK4 reference).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub oversample: Option<usize>,
    /// Highest harmonic extracted (K).
    #[serde(default = "default_max_harmonic")]
    pub max_harmonic: usize,
    /// Settling: consecutive blocks must agree to this relative tolerance.
    #[serde(default = "default_settle_tolerance")]
    pub settle_tolerance: f64,
    /// Settling cap, periods.
    #[serde(default = "default_max_settle_periods")]
    pub max_settle_periods: usize,
    /// Periods measured after settling (rounded up to whole blocks).
    #[serde(default = "default_measure_periods")]
    pub measure_periods: usize,
    /// Largest relative shift of a dwell frequency allowed to make the
    /// sampling coherent (a block of whole periods in whole samples).
    #[serde(default = "default_frequency_tolerance")]
    pub frequency_tolerance: f64,
}

/// The response quantity of the FRFs.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum ResponseKind {
    /// Receptance.
    Displacement,
    /// Mobility.
    Velocity,
    /// Accelerance.
    Acceleration,
}

impl ResponseKind {
    /// As a [`Quantity`].
    pub fn quantity(self) -> Quantity {
        match self {
            ResponseKind::Displacement => Quantity::Displacement,
            ResponseKind::Velocity => Quantity::Velocity,
            ResponseKind::Acceleration => Quantity::Acceleration,
        }
    }
}

fn default_noise() -> f64 {
    0.10
}
fn default_seed() -> u64 {
    1
}
fn default_response() -> ResponseKind {
    ResponseKind::Displacement
}
fn default_max_harmonic() -> usize {
    7
}
fn default_settle_tolerance() -> f64 {
    1e-6
}
fn default_max_settle_periods() -> usize {
    3000
}
fn default_measure_periods() -> usize {
    32
}
fn default_frequency_tolerance() -> f64 {
    // a dwell's frequency may move by 0.1 % (it is recorded and used
    // exactly) so that a coherent block needs few periods
    1e-3
}

/// Keys that hold numbers, per table: the laws' parameters from the
/// element registry, and the fixed keys of the other tables.
fn number_keys() -> Vec<(&'static str, Vec<&'static str>)> {
    let names = |joints: bool| -> Vec<&'static str> {
        let mut v: Vec<&'static str> = ElementKind::ALL
            .iter()
            .map(|k| k.description())
            .filter(|d| d.is_joint() == joints)
            .flat_map(|d| d.parameters.iter().map(|p| p.name))
            .collect();
        v.sort_unstable();
        v.dedup();
        v
    };
    let mut effects = names(false);
    effects.extend_from_slice(SECOND_MODE_KEYS);
    vec![
        ("system", vec!["mass", "damping", "stiffness"]),
        ("joint", names(true)),
        ("effects", effects),
        (
            "modes",
            vec!["frequency_hz", "damping_ratio", "modal_mass", "residue"],
        ),
        (
            "test",
            vec![
                "noise",
                "force_noise",
                "sample_rate_hz",
                "settle_tolerance",
                "frequency_tolerance",
                "seed",
                "oversample",
                "max_harmonic",
                "max_settle_periods",
                "measure_periods",
            ],
        ),
    ]
}

/// Names the key of a value that should be a number but is not.
fn check_value_types(root: &toml::Table, origin: &str) -> Result<()> {
    let bad = |field: String, v: &toml::Value| {
        Error::format(
            origin,
            field,
            format!("expected a number, got {} `{v}`", v.type_str()),
        )
    };
    for (table, keys) in number_keys() {
        let tables: Vec<(String, &toml::Table)> = match root.get(table) {
            Some(toml::Value::Table(t)) => vec![(table.to_string(), t)],
            Some(toml::Value::Array(a)) => a
                .iter()
                .enumerate()
                .filter_map(|(i, v)| v.as_table().map(|t| (format!("{table}[{i}]"), t)))
                .collect(),
            _ => Vec::new(),
        };
        for (name, t) in tables {
            for key in &keys {
                if let Some(v) = t.get(*key)
                    && !(v.is_float() || v.is_integer())
                {
                    return Err(bad(format!("{name}.{key}"), v));
                }
            }
        }
    }
    if let Some(levels) = root
        .get("test")
        .and_then(|t| t.get("levels_n"))
        .and_then(|l| l.as_array())
    {
        for (i, v) in levels.iter().enumerate() {
            if !(v.is_float() || v.is_integer()) {
                return Err(bad(format!("test.levels_n[{i}]"), v));
            }
        }
    }
    Ok(())
}

/// Most dwell frequencies a `{ start, stop, count }` range may ask for: the
/// count is a declared size, checked before the list is made (a count of
/// 2^40 would otherwise be a 8 TB allocation).
pub const MAX_FREQUENCIES: usize = 100_000;

/// Most periods a dwell may settle or measure for: each is simulated and
/// kept in memory, so a huge value would exhaust memory mid-run.
pub const MAX_PERIODS: usize = 1_000_000;

/// Parses a definition (or its structure) from TOML, naming the key, line
/// and table of the first bad value; `origin` names the text in errors.
fn parse_toml<T: serde::de::DeserializeOwned>(text: &str, origin: &str) -> Result<T> {
    // a first, untyped pass: serde cannot name the key of a mistyped value
    // inside the tagged tables, so check the number-valued keys here
    if let Ok(value) = text.parse::<toml::Table>() {
        check_value_types(&value, origin)?;
    }
    toml::from_str(text).map_err(|e| {
            let msg = e.message().to_string();
            let msg = if msg.contains("untagged enum FrequencyList") {
                "`test.frequencies_hz`: expected a list of frequencies in Hz or { start, stop, count [, spacing] }"
                    .to_string()
            } else {
                msg
            };
            // serde's message may not name the key: show the line, and the
            // table it is in, so the user sees which one
            let (field, at) = match e.span() {
                Some(s) => {
                    let start = s.start.min(text.len());
                    let n = text[..start].matches('\n').count();
                    let line = text.lines().nth(n).unwrap_or("").trim();
                    let table = text
                        .lines()
                        .take(n + 1)
                        .filter_map(|l| l.trim().strip_prefix('[').and_then(|l| l.split(']').next()))
                        .last()
                        .map(|t| t.trim_start_matches('[').to_string());
                    let key = line.split('=').next().unwrap_or("").trim();
                    let field = match (&table, key.is_empty() || line.starts_with('[')) {
                        (Some(t), false) => format!("{t}.{key}"),
                        (None, false) => key.to_string(),
                        (Some(t), true) => t.clone(),
                        (None, true) => "toml".to_string(),
                    };
                    (field, format!(" (line {}: `{line}`)", n + 1))
                }
                None => ("toml".to_string(), String::new()),
            };
            Error::format(origin, field, format!("{msg}{at}"))
        })
}

impl StructureDefinition {
    /// Parses a structure (no `[test]` table); `origin` names the text in
    /// errors.
    pub fn from_toml(text: &str, origin: &str) -> Result<StructureDefinition> {
        parse_toml(text, origin)
    }

    /// The structural model: linear part, joint, effects (a `second_mode`
    /// effect adds a mode to the linear part).
    pub fn model(&self) -> Result<Model> {
        let mut modes = match (&self.system, self.modes.is_empty()) {
            (Some(s), true) => vec![Mode::from_mck(s.mass, s.damping, s.stiffness)?],
            (None, false) => self
                .modes
                .iter()
                .enumerate()
                .map(|(i, m)| {
                    let at = format!("modes[{i}]");
                    let residue = match (m.modal_mass, m.residue) {
                        (Some(mm), None) => {
                            if !(mm.is_finite() && mm != 0.0) {
                                return Err(Error::model(
                                    format!("{at}.modal_mass"),
                                    format!("must be finite and non-zero, got {mm}"),
                                ));
                            }
                            1.0 / mm
                        }
                        (None, Some(r)) => r,
                        _ => {
                            return Err(Error::model(
                                at,
                                "give exactly one of modal_mass and residue",
                            ));
                        }
                    };
                    let mode = Mode {
                        frequency_hz: m.frequency_hz,
                        damping_ratio: m.damping_ratio,
                        residue,
                        joint: m.joint,
                    };
                    mode.validate(&at)?;
                    Ok(mode)
                })
                .collect::<Result<_>>()?,
            (Some(_), false) => {
                return Err(Error::model(
                    "system",
                    "give either [system] or [[modes]], not both",
                ));
            }
            (None, true) => {
                return Err(Error::model(
                    "system",
                    "missing: give [system] (mass, damping, stiffness) or [[modes]]",
                ));
            }
        };
        let mut effects = Vec::new();
        if let Some(joint) = &self.joint.0 {
            joint.validate("joint")?;
        }
        for (i, e) in self.effects.iter().enumerate() {
            let at = format!("effects[{i}]");
            match e {
                EffectSpec::Element(spec) => {
                    spec.validate(&at)?;
                    effects.push(*spec);
                }
                EffectSpec::SecondMode(m) => {
                    let mode = Mode::from_modal_mass(m.frequency_hz, m.damping_ratio, m.modal_mass)
                        .map_err(|e| Error::model(at.clone(), e.to_string()))?;
                    modes.push(mode);
                }
            }
        }
        Model::with_joint(ModalModel::new(modes)?, self.joint.0, effects)
    }
}

/// Checks a noise level, a fraction of a channel's clean RMS: above 1 it
/// is most likely a percentage (`noise = 5` meant as 5 %), so it is
/// refused with the fraction it would be.
fn noise_fraction(field: &str, v: f64, channel: &str) -> Result<()> {
    if v.is_finite() && (0.0..=1.0).contains(&v) {
        return Ok(());
    }
    let key = field.rsplit('.').next().unwrap_or(field);
    let hint = if v.is_finite() && v > 1.0 && v <= 100.0 {
        format!(
            "; a percentage is written as its fraction: `{key} = {}` for {v} %",
            v / 100.0
        )
    } else {
        format!(" (e.g. `{key} = 0.05` for 5 %)")
    };
    Err(Error::plan(
        field,
        format!("must be a fraction of the {channel} RMS in [0, 1], got {v}{hint}"),
    ))
}

impl TestDefinition {
    /// Parses and checks a definition; `origin` names the file in errors.
    pub fn from_toml(text: &str, origin: &str) -> Result<TestDefinition> {
        let def: TestDefinition = parse_toml(text, origin)?;
        def.validate().map_err(|e| in_file(origin, e))?;
        Ok(def)
    }

    /// The embedded default.
    pub fn embedded_default() -> TestDefinition {
        TestDefinition::from_toml(DEFAULT_TEST, "signals/default.toml")
            .expect("the embedded default is valid")
    }

    /// Checks every value, naming the key of the first bad one.
    pub fn validate(&self) -> Result<()> {
        self.model()?;
        self.oversample()?;
        let t = &self.test;
        let freqs = self.frequencies()?;
        for (i, f) in freqs.iter().enumerate() {
            if !(f.is_finite() && *f > 0.0) {
                return Err(Error::plan(
                    format!("test.frequencies_hz[{i}]"),
                    format!("must be finite and > 0, got {f}"),
                ));
            }
        }
        if t.levels_n.is_empty() {
            return Err(Error::plan("test.levels_n", "needs at least one level"));
        }
        for (i, l) in t.levels_n.iter().enumerate() {
            if !(l.is_finite() && *l > 0.0) {
                return Err(Error::plan(
                    format!("test.levels_n[{i}]"),
                    format!("must be a finite force amplitude > 0 N, got {l}"),
                ));
            }
        }
        noise_fraction("test.noise", t.noise, "response")?;
        if t.force_gauge && !self.model()?.laws().any(|e| e.drive_load().is_some()) {
            return Err(Error::plan(
                "test.force_gauge",
                "needs a shaker ([[effects]] kind = \"shaker\"): without one the drive is \
                 the force itself, recorded as the reference",
            ));
        }
        noise_fraction("test.force_noise", t.force_noise, "force")?;
        if t.max_harmonic == 0 || t.max_harmonic > 64 {
            return Err(Error::plan(
                "test.max_harmonic",
                format!("must be in 1..=64, got {}", t.max_harmonic),
            ));
        }
        if !(t.settle_tolerance.is_finite() && t.settle_tolerance > 0.0 && t.settle_tolerance < 1.0)
        {
            return Err(Error::plan(
                "test.settle_tolerance",
                format!("must be in (0, 1), got {}", t.settle_tolerance),
            ));
        }
        if !(1..=MAX_PERIODS).contains(&t.max_settle_periods) {
            return Err(Error::plan(
                "test.max_settle_periods",
                format!("must be in 1..={MAX_PERIODS}, got {}", t.max_settle_periods),
            ));
        }
        if !(2..=MAX_PERIODS).contains(&t.measure_periods) {
            return Err(Error::plan(
                "test.measure_periods",
                format!(
                    "must be in 2..={MAX_PERIODS} (standard errors need 2 blocks), got {}",
                    t.measure_periods
                ),
            ));
        }
        if !(t.frequency_tolerance.is_finite()
            && t.frequency_tolerance > 0.0
            && t.frequency_tolerance < 0.05)
        {
            return Err(Error::plan(
                "test.frequency_tolerance",
                format!("must be in (0, 0.05), got {}", t.frequency_tolerance),
            ));
        }
        let fs = self.sample_rate_hz()?;
        let model = self.model()?;
        let top = model.linear.highest_frequency_hz();
        if fs <= 2.0 * top {
            return Err(Error::plan(
                "test.sample_rate_hz",
                format!("{fs} Hz is not above twice the highest mode ({top:.3} Hz)"),
            ));
        }
        for (i, f) in freqs.iter().enumerate() {
            let h = t.max_harmonic as f64 * f;
            if h >= fs / 2.0 {
                return Err(Error::plan(
                    format!("test.frequencies_hz[{i}]"),
                    format!(
                        "{f} Hz: its harmonic {} ({h} Hz) is above the Nyquist frequency {} Hz; raise test.sample_rate_hz or lower test.max_harmonic",
                        t.max_harmonic,
                        fs / 2.0
                    ),
                ));
            }
        }
        Ok(())
    }

    /// The structure alone (no `[test]`).
    pub fn structure(&self) -> StructureDefinition {
        StructureDefinition {
            system: self.system,
            modes: self.modes.clone(),
            joint: self.joint.clone(),
            effects: self.effects.clone(),
        }
    }

    /// The structural model: linear part, joint, effects (a `second_mode`
    /// effect adds a mode to the linear part).
    pub fn model(&self) -> Result<Model> {
        self.structure().model()
    }

    /// The dwell frequencies as listed (before sweep ordering), Hz.
    pub fn frequencies(&self) -> Result<Vec<f64>> {
        match &self.test.frequencies_hz {
            FrequencyList::List(v) => {
                if v.is_empty() {
                    return Err(Error::plan(
                        "test.frequencies_hz",
                        "needs at least one frequency",
                    ));
                }
                Ok(v.clone())
            }
            FrequencyList::Range(r) => {
                if !(1..=MAX_FREQUENCIES).contains(&r.count) {
                    return Err(Error::plan(
                        "test.frequencies_hz.count",
                        format!("must be in 1..={MAX_FREQUENCIES}, got {}", r.count),
                    ));
                }
                for (k, v) in [("start", r.start), ("stop", r.stop)] {
                    if !(v.is_finite() && v > 0.0) {
                        return Err(Error::plan(
                            format!("test.frequencies_hz.{k}"),
                            format!("must be finite and > 0, got {v}"),
                        ));
                    }
                }
                if r.count == 1 {
                    return Ok(vec![r.start]);
                }
                let n = (r.count - 1) as f64;
                Ok((0..r.count)
                    .map(|i| match r.spacing {
                        Spacing::Linear => r.start + (r.stop - r.start) * i as f64 / n,
                        Spacing::Log => r.start * (r.stop / r.start).powf(i as f64 / n),
                    })
                    .collect())
            }
        }
    }

    /// The sample rate, Hz.
    pub fn sample_rate_hz(&self) -> Result<f64> {
        match self.test.sample_rate_hz {
            Some(fs) if fs.is_finite() && fs > 0.0 => Ok(fs),
            Some(fs) => Err(Error::plan(
                "test.sample_rate_hz",
                format!("must be finite and > 0, got {fs}"),
            )),
            None => {
                let f = self.model()?.highest_linearised_frequency_hz();
                Ok(((100.0 * f) / 1000.0).ceil() * 1000.0)
            }
        }
    }

    /// The simulator's oversampling factor over the recording rate.
    pub fn oversample(&self) -> Result<usize> {
        match self.test.oversample {
            Some(k) if (1..=64).contains(&k) => Ok(k),
            Some(k) => Err(Error::plan(
                "test.oversample",
                format!("must be in 1..=64, got {k}"),
            )),
            None => {
                let f = self.model()?.highest_linearised_frequency_hz();
                Ok(((200.0 * f / self.sample_rate_hz()?).ceil() as usize).clamp(1, 64))
            }
        }
    }

    /// Each level's dwell frequencies in measurement order, with the sweep
    /// direction of each run.
    pub fn sweeps(&self) -> Result<Vec<(Direction, Vec<f64>)>> {
        let mut up = self.frequencies()?;
        up.sort_by(f64::total_cmp);
        let down: Vec<f64> = up.iter().rev().copied().collect();
        Ok(match self.test.sweep {
            SweepOrder::Up => vec![(Direction::Up, up)],
            SweepOrder::Down => vec![(Direction::Down, down)],
            SweepOrder::Both => vec![(Direction::Up, up), (Direction::Down, down)],
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A structure without `[test]` gives the model its test definition
    /// gives; its errors name the file and the key, as a test definition's
    /// do.
    #[test]
    fn a_structure_alone_gives_the_definitions_model() {
        let whole = TestDefinition::embedded_default().model().unwrap();
        let structure: String = DEFAULT_TEST.split("[test]").next().unwrap().to_string();
        assert!(!structure.contains("levels_n"));
        assert_eq!(model_from_toml(&structure, "s.toml").unwrap(), whole);
        assert_eq!(model_from_toml(DEFAULT_TEST, "d.toml").unwrap(), whole);
        let bad = structure.replace("mass = 10.0", "mass = -10.0");
        let e = model_from_toml(&bad, "s.toml").unwrap_err().to_string();
        assert_eq!(
            e,
            "s.toml: `system.mass`: must be a finite number > 0, got -10"
        );
        let e = model_from_toml(&structure.replace("kd =", "kx ="), "s.toml")
            .unwrap_err()
            .to_string();
        assert!(e.starts_with("s.toml: `joint`") && e.contains("kx"), "{e}");
        let e = model_from_toml("[system]\nmass = \"ten\"\n", "s.toml")
            .unwrap_err()
            .to_string();
        assert!(e.contains("`system.mass`: expected a number"), "{e}");
    }

    #[test]
    fn the_embedded_default_is_the_paper_case() {
        let d = TestDefinition::embedded_default();
        let m = d.model().unwrap();
        assert_eq!(
            m.joint,
            Some(ElementSpec::Jenkins {
                kd: 2.4e7,
                fd: 246.048
            })
        );
        assert!(m.effects.is_empty());
        assert_eq!(d.frequencies().unwrap().len(), 51);
        assert_eq!(d.test.levels_n.len(), 7);
        // 100 samples per stick period (293.4 Hz), rounded up to 1 kHz
        assert_eq!(d.sample_rate_hz().unwrap(), 30000.0);
    }

    fn with(edit: &str, replace: &str) -> String {
        assert!(DEFAULT_TEST.contains(edit), "{edit}");
        DEFAULT_TEST.replace(edit, replace)
    }

    #[test]
    fn bad_fields_are_named() {
        let cases = [
            (with("mass = 10.0", "mass = -10.0"), "system.mass"),
            (with("damping = 200.0", "damping = -1.0"), "system.damping"),
            (with("kd = 2.4e7", "kd = 0.0"), "joint.kd"),
            (
                with("levels_n = [5.0,", "levels_n = [-5.0,"),
                "test.levels_n[0]",
            ),
            (with("noise = 0.10", "noise = -0.1"), "test.noise"),
            (
                with("seed = 1", "seed = 1\nsample_rate_hz = 2000.0"),
                "test.frequencies_hz[9]",
            ),
            (with("seed = 1", "seed = 1\nbogus = 3"), "bogus"),
            (with("kind = \"jenkins\"", "kind = \"slidey\""), "slidey"),
            (
                with("count = 51 }", "count = 0 }"),
                "test.frequencies_hz.count",
            ),
            (with("sweep = \"up\"", "sweep = \"sideways\""), "sideways"),
            (
                with(
                    "frequencies_hz = { start = 100.0, stop = 350.0, count = 51 }",
                    "frequencies_hz = \"many\"",
                ),
                "frequencies_hz",
            ),
            (
                with("response = \"displacement\"", "response = \"force\""),
                "force",
            ),
            // a gauge needs a shaker; a shaker's coil all its terms
            (
                with("seed = 1", "seed = 1\nforce_gauge = true"),
                "test.force_gauge",
            ),
            (
                with(
                    "[test]",
                    "[[effects]]\nkind = \"shaker\"\nr = 1.0\nbl = 5.0\n[test]",
                ),
                "shaker.l",
            ),
        ];
        for (text, needle) in cases {
            let e = TestDefinition::from_toml(&text, "t.toml")
                .unwrap_err()
                .to_string();
            assert!(e.contains(needle), "expected `{needle}` in: {e}");
        }
        let nan = with("levels_n = [5.0,", "levels_n = [nan,");
        let e = TestDefinition::from_toml(&nan, "t.toml")
            .unwrap_err()
            .to_string();
        assert!(e.contains("test.levels_n[0]"), "{e}");
    }

    #[test]
    fn effects_and_modes_build_the_model() {
        let text = with(
            "[test]",
            "[[effects]]\nkind = \"second_mode\"\nfrequency_hz = 500.0\ndamping_ratio = 0.01\nmodal_mass = 5.0\n\n[[effects]]\nkind = \"cubic_stiffness\"\nk3 = 1e15\n\n[test]",
        );
        let m = TestDefinition::from_toml(&text, "t.toml")
            .unwrap()
            .model()
            .unwrap();
        assert_eq!(m.linear.modes.len(), 2);
        assert!(m.joint.is_some());
        assert_eq!(m.effects.len(), 1);
        let text = DEFAULT_TEST
            .replace(
                "[system]",
                "[[modes]]\nfrequency_hz = 159.15\ndamping_ratio = 0.01\nmodal_mass = 1e1\n#",
            )
            .replace("mass = 10.0", "")
            .replace("damping = 200.0", "")
            .replace("stiffness = 1.0e7", "");
        let d = TestDefinition::from_toml(&text, "t.toml").unwrap();
        assert_eq!(d.model().unwrap().linear.modes.len(), 1);
    }
}
