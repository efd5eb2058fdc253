//! The fit of a set of nonlinear FRFs, its comparison with the element a
//! virtual test was simulated with, `fit.json` and the fit's figures
//! (paper Figures 2.2, 3.3 and 3.4).

mod request;
pub use request::IdentifyRequest;

use super::flags::{Flag, flag_estimates, flag_words, parameter_unit, unit_suffix};
use super::recording::MULTISINE_LINES;
use crate::error::{Error, Result};
use crate::extract::NonlinearFrf;
use crate::fit::time::time_parameters;
use crate::fit::{
    Estimate, FitData, FitOptions, FitResult, HbPredictor, TimeFitOptions, TimeFitResult,
    TimeRecord, identify, identify_time,
};
use crate::harmonics::Quantity;
use crate::model::{ElementSpec, Model};
use crate::observe::{Event, Observer};
use crate::plot::{self, ConvergenceSeries};
use crate::record::McapRecorder;
use crate::testbench::TestDefinition;
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::sync::Mutex;

/// How the fit compares with the element the data were simulated with.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Comparison {
    /// Parameter name.
    pub parameter: String,
    /// Reference value.
    pub reference: f64,
    /// Estimate.
    pub estimate: f64,
    /// `estimate/reference − 1`.
    pub relative_error: f64,
    /// Whether the 95 % interval covers the reference.
    pub covered: bool,
}

/// `fit.json`: the fit with what it was fitted to.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct FitReport {
    /// `identify`.
    pub command: String,
    /// Tool version.
    pub version: String,
    /// The recordings fitted to, their paths as given.
    pub recording: Vec<String>,
    /// The response analysed.
    pub response: String,
    /// The reference channel named by the user (`--reference`); none: the
    /// recording format's rule (the first force, else the first voltage).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub reference_channel: Option<String>,
    /// The fit.
    #[serde(flatten)]
    pub fit: FitResult,
    /// The element the data came from, when known.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub reference: Option<ElementSpec>,
    /// Estimates against the reference.
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub comparison: Vec<Comparison>,
    /// The fit's flagged parameters with their flags (as `run.json` flags
    /// its final model's); none: every estimate a plain result.
    #[serde(skip_serializing_if = "BTreeMap::is_empty")]
    pub flags: BTreeMap<String, Vec<Flag>>,
    /// Files written.
    pub files: Vec<PathBuf>,
    /// The fit refined in the time domain on the recordings themselves
    /// (`identify --domain time`): its model is the one `validate` uses.
    /// Set with [`FitReport::set_time_domain`], which flags it.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub time_domain: Option<TimeFitResult>,
    /// The time-domain refinement's flagged parameters.
    #[serde(skip_serializing_if = "BTreeMap::is_empty")]
    pub time_domain_flags: BTreeMap<String, Vec<Flag>>,
    /// The shaker's coil, where a recording holds its voltage beside the
    /// force it applies ([`crate::fit::coil`]).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub coil: Option<crate::fit::coil::CoilFit>,
}

/// The report's own fields, beside the flattened fit.
#[derive(Deserialize)]
struct ReportHead {
    command: String,
    version: String,
    #[serde(deserialize_with = "listed")]
    recording: Vec<String>,
    response: String,
    #[serde(default)]
    reference_channel: Option<String>,
    #[serde(default)]
    reference: Option<ElementSpec>,
    #[serde(default)]
    comparison: Vec<Comparison>,
    #[serde(default)]
    flags: BTreeMap<String, Vec<Flag>>,
    #[serde(default)]
    files: Vec<PathBuf>,
    #[serde(default)]
    time_domain: Option<TimeFitResult>,
    #[serde(default)]
    time_domain_flags: BTreeMap<String, Vec<Flag>>,
    #[serde(default)]
    coil: Option<crate::fit::coil::CoilFit>,
}

/// fit.json's `recording`: a list of paths; a file of an earlier version
/// held one string (several comma-joined), read as the one entry it is.
fn listed<'de, D: serde::Deserializer<'de>>(d: D) -> std::result::Result<Vec<String>, D::Error> {
    #[derive(Deserialize)]
    #[serde(untagged)]
    enum Listed {
        One(String),
        Many(Vec<String>),
    }
    Ok(match Listed::deserialize(d)? {
        Listed::One(s) => vec![s],
        Listed::Many(v) => v,
    })
}

// By hand, through a JSON value: serde's derived `flatten` buffers the fit's
// fields in a way that cannot read a map with integer keys
// (`error.per_harmonic`), which a JSON value can.
impl<'de> Deserialize<'de> for FitReport {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> std::result::Result<Self, D::Error> {
        use serde::de::Error as _;
        let value = serde_json::Value::deserialize(d)?;
        let head: ReportHead = serde_json::from_value(value.clone()).map_err(D::Error::custom)?;
        let fit: FitResult = serde_json::from_value(value).map_err(D::Error::custom)?;
        Ok(FitReport {
            command: head.command,
            version: head.version,
            recording: head.recording,
            response: head.response,
            reference_channel: head.reference_channel,
            fit,
            reference: head.reference,
            comparison: head.comparison,
            flags: head.flags,
            files: head.files,
            time_domain: head.time_domain,
            time_domain_flags: head.time_domain_flags,
            coil: head.coil,
        })
    }
}

impl FitReport {
    /// The report of `fit`, fitted to `recording`'s `response`, compared with
    /// `reference` when known.
    pub fn new(
        recording: Vec<String>,
        response: String,
        mut fit: FitResult,
        reference: Option<ElementSpec>,
        files: Vec<PathBuf>,
    ) -> FitReport {
        let comparison = compare(&fit, reference.as_ref());
        let flags = flag_estimates(&mut fit.parameters, &fit.model, &fit.at_bound, fit.transfer);
        FitReport {
            command: "identify".into(),
            version: super::VERSION.into(),
            recording,
            response,
            reference_channel: None,
            fit,
            reference,
            comparison,
            flags,
            files,
            time_domain: None,
            time_domain_flags: BTreeMap::new(),
            coil: None,
        }
    }

    /// Sets the time-domain refinement (none: clears it) with its flags.
    pub fn set_time_domain(&mut self, mut t: Option<TimeFitResult>) {
        self.time_domain_flags = t.as_mut().map_or_else(BTreeMap::new, |t| {
            let transfer = self.fit.transfer || t.response_sign < 0.0;
            flag_estimates(&mut t.parameters, &t.model, &t.at_bound, transfer)
        });
        self.time_domain = t;
    }

    /// The terminal's lines for the fit's parameters: value, interval, the
    /// reference when known, flags; each estimate's note below it.
    pub fn parameter_lines(&self) -> Vec<String> {
        let unit = |name: &str| parameter_unit(name, &self.fit.model, self.drive());
        estimate_lines(&self.fit.parameters, &self.comparison, &self.flags, &unit)
    }

    /// [`FitReport::parameter_lines`] for the time-domain refinement.
    pub fn time_domain_lines(&self) -> Vec<String> {
        self.time_domain.as_ref().map_or_else(Vec::new, |t| {
            let unit = |name: &str| parameter_unit(name, &t.model, self.drive());
            estimate_lines(&t.parameters, &[], &self.time_domain_flags, &unit)
        })
    }

    /// What the model's forces are measured against (see
    /// [`super::flags::force_drive`]): its parameters' units follow it.
    pub fn drive(&self) -> Quantity {
        let reference = self.fit.reference_quantity.unwrap_or(Quantity::Force);
        super::flags::force_drive(&self.fit.model, reference)
    }

    /// The model the report stands for: the time-domain refinement's when
    /// there is one, else the FRF fit's; with its response sign.
    pub fn final_model(&self) -> (&Model, f64) {
        match &self.time_domain {
            Some(t) => (&t.model, t.response_sign),
            None => (&self.fit.model, self.fit.response_sign),
        }
    }

    /// Reads a `fit.json`.
    pub fn read(path: &Path) -> Result<FitReport> {
        let text = std::fs::read(path).map_err(|e| Error::io(path, e))?;
        FitReport::parse(path, &text)
    }

    /// [`FitReport::read`] on a file already in memory; `path` names it in
    /// messages.
    pub fn parse(path: &Path, bytes: &[u8]) -> Result<FitReport> {
        serde_json::from_slice(bytes).map_err(|e| {
            Error::format(
                path,
                "fit",
                format!(
                    "expected a fit.json written by `hystid identify` (with `model`, `linear` and `response_sign`): {e}"
                ),
            )
        })
    }
}

/// One line per estimate (see [`FitReport::parameter_lines`]), each in the
/// unit `unit` gives its name.
fn estimate_lines(
    estimates: &BTreeMap<String, Estimate>,
    comparison: &[Comparison],
    flags: &BTreeMap<String, Vec<Flag>>,
    unit: &dyn Fn(&str) -> &'static str,
) -> Vec<String> {
    let mut out = Vec::new();
    for (name, e) in estimates {
        let cmp = comparison.iter().find(|c| &c.parameter == name);
        let r = cmp.map_or(String::new(), |c| {
            format!(
                "  (reference {:.6e}: {:+.2} %{})",
                c.reference,
                100.0 * c.relative_error,
                if c.covered {
                    ", covered"
                } else {
                    ", NOT covered"
                }
            )
        });
        let f = flags.get(name).map_or(String::new(), |f| flag_words(f));
        out.push(format!(
            "  {name:>10} = {:.6e}  ci95 [{:.4e}, {:.4e}]{}{r}{f}",
            e.value,
            e.ci95[0],
            e.ci95[1],
            unit_suffix(unit(name)),
        ));
        if let Some(n) = &e.note {
            out.push(format!("             {n}"));
        }
    }
    out
}

/// The reference joint of a virtual test.
pub fn reference_joint(truth: Option<&TestDefinition>) -> Option<ElementSpec> {
    truth?.model().ok()?.joint
}

/// Compares estimates with a reference element's parameters.
pub fn compare(fit: &FitResult, reference: Option<&ElementSpec>) -> Vec<Comparison> {
    let Some(r) = reference else {
        return Vec::new();
    };
    r.parameters()
        .into_iter()
        .filter_map(|(name, value)| {
            let e = fit.parameters.get(name)?;
            Some(Comparison {
                parameter: name.to_string(),
                reference: value,
                estimate: e.value,
                relative_error: e.value / value - 1.0,
                covered: e.ci95[0] <= value && value <= e.ci95[1],
            })
        })
        .collect()
}

/// Writes the fit's figures into `dir`: the FRF overlay (`fit_frf`, the
/// model on a fine grid), the hysteresis loops at the amplitudes the test
/// reached (`loops`) and the convergence (`convergence`).
pub fn write_fit_plots(
    dir: &Path,
    frf: &NonlinearFrf,
    fit: &FitResult,
    reference: Option<&ElementSpec>,
    predictor: &HbPredictor,
) -> Result<Vec<PathBuf>> {
    let mut files = write_fit_frf(dir, frf, fit, predictor)?;
    files.extend(write_fit_loops(
        dir,
        frf,
        &fit.model,
        fit.response_sign,
        reference,
    )?);
    files.extend(write_convergence(dir, fit)?);
    Ok(files)
}

/// The fit's FRF overlay, `fit_frf` (paper Fig. 3.4 right).
pub fn write_fit_frf(
    dir: &Path,
    frf: &NonlinearFrf,
    fit: &FitResult,
    predictor: &HbPredictor,
) -> Result<Vec<PathBuf>> {
    super::figures::write_frf_overlay(
        &dir.join("fit_frf"),
        &format!(
            "Measured (markers) and the fitted {} model (lines)",
            fit.element.name()
        ),
        frf,
        None,
        super::figures::Drawn {
            model: &fit.model,
            response_sign: fit.response_sign,
        },
        predictor,
    )
}

/// `model`'s joint loops, `loops`, at the largest displacement amplitude
/// each level of `frf` reached (Fig. 3.2 / 3.4 left), over `reference`'s
/// when known; nothing without a joint.
pub fn write_fit_loops(
    dir: &Path,
    frf: &NonlinearFrf,
    model: &Model,
    response_sign: f64,
    reference: Option<&ElementSpec>,
) -> Result<Vec<PathBuf>> {
    let Some(spec) = &model.joint else {
        return Ok(Vec::new());
    };
    let data = FitData::from_frf(frf, &[1], None, None)?.with_sign(response_sign);
    super::figures::write_joint_loops(
        &dir.join("loops"),
        spec,
        reference,
        &super::figures::reached_amplitudes(&data),
        frf.reference.si_unit(),
    )
}

/// The optimiser's cost per evaluation, `convergence`.
pub fn write_convergence(dir: &Path, fit: &FitResult) -> Result<Vec<PathBuf>> {
    let cost: Vec<f64> = fit.trace.iter().map(|t| t.cost).collect();
    if cost.is_empty() {
        return Ok(Vec::new());
    }
    plot::write_convergence_plot(
        &dir.join("convergence"),
        &format!("{}: cost per evaluation", fit.optimiser.method.title()),
        "cost: squared relative FRF error (eq. 9)",
        &[ConvergenceSeries {
            label: "cost of each evaluation".into(),
            group: 0,
            cost,
        }],
    )
}

/// The recordings as the time-domain fit reads them: each one's reference
/// and response channels (as `choice` names them, else as
/// [`super::load_recording`] chooses), the whole
/// record judged, or only what `band_hz` holds (see
/// [`TimeRecord::from_recording`]).
pub fn time_records(
    recordings: &[PathBuf],
    choice: super::ChannelChoice,
    band_hz: Option<(f64, f64)>,
) -> Result<Vec<TimeRecord>> {
    time_records_in(recordings, choice, None, band_hz)
}

/// [`time_records`] judged over `window_s` (seconds from each record's
/// first sample; e.g. after a transient, or the steady periods of a
/// multisine).
pub fn time_records_in(
    recordings: &[PathBuf],
    choice: super::ChannelChoice,
    window_s: Option<(f64, f64)>,
    band_hz: Option<(f64, f64)>,
) -> Result<Vec<TimeRecord>> {
    recordings
        .iter()
        .map(|p| super::load_time_record(p, choice, window_s, band_hz))
        .collect()
}

/// A time-domain fit's start from periodic recordings (multisines played
/// several times): see [`periodic_start`].
#[derive(Clone, Debug)]
pub struct PeriodicStart {
    /// The recordings, each judged over its whole periods after the first,
    /// one segment per period.
    pub records: Vec<TimeRecord>,
    /// The start: the linear estimate and a joint, the closest of a grid.
    pub start: Model,
    /// What the start was made of, for the report.
    pub note: String,
}

/// The start of a time-domain fit when no model is written down and the
/// recordings are periodic multisines, which an FRF fit cannot read: each
/// recording's period ([`crate::extract::find_period`]), the linear FRF at
/// the excited lines over the periods after the first
/// ([`crate::extract::periodic_frf`]), an SDOF fitted to it and a joint of
/// `kind` ([`crate::fit::time::periodic_starts`]), the closest to the
/// recordings of a grid of stiffness shares and slip forces
/// ([`crate::fit::time::closest_start`]).
///
/// `None` when a recording states a stepped or swept excitation, or is not
/// a multisine (no period, or fewer than [`MULTISINE_LINES`] lines): the
/// FRF fit's path.
pub fn periodic_start(
    recordings: &[PathBuf],
    choice: super::ChannelChoice,
    kind: crate::model::ElementKind,
    modes: usize,
) -> Result<Option<PeriodicStart>> {
    // a recording that states its excitation is no multisine: known from
    // its description, before its samples are read
    for p in recordings {
        if !super::recording::stated_excitation(p)?.may_be_multisine() {
            return Ok(None);
        }
    }
    let held = recordings
        .iter()
        .map(|p| {
            let l = super::load_held_reference_and_response(p, choice)?;
            Ok((p.display().to_string(), l))
        })
        .collect::<Result<Vec<_>>>()?;
    periodic_start_of(held, kind, modes)
}

/// [`periodic_start`] of recordings read, each with its name: taken over
/// (their reference and response become the time records' without a copy)
/// and read a period at a time ([`crate::extract::find_period`],
/// [`crate::extract::periodic_frf`]), so that a long recording spilled
/// to a scratch file is never held whole.
pub fn periodic_start_of(
    recordings: Vec<(String, super::HeldRecording)>,
    kind: crate::model::ElementKind,
    modes: usize,
) -> Result<Option<PeriodicStart>> {
    let mut records = Vec::new();
    let mut lines = Vec::new();
    let mut spectra = Vec::new();
    let mut quantity = None;
    let mut notes = Vec::new();
    for (name, held) in recordings {
        let Some(p) = periodic_recording(&name, held)? else {
            return Ok(None);
        };
        if quantity.is_some_and(|was| was != p.quantity) {
            return Err(Error::input(
                format!("{name}: response"),
                "the recordings' responses are different quantities".to_string(),
            ));
        }
        quantity = Some(p.quantity);
        notes.push(p.note);
        lines.extend(p.lines.iter().map(|l| crate::fit::FrfSample {
            frequency_hz: l.frequency_hz,
            h: l.h,
            std_error: l.std_error,
        }));
        spectra.push((p.period, p.lines));
        records.push(p.record);
    }
    let Some(quantity) = quantity else {
        return Ok(None);
    };
    lines.sort_by(|a, b| a.frequency_hz.total_cmp(&b.frequency_hz));
    // the displacement the linear estimate predicts (Parseval over the
    // lines of one period, `amplitude` each), the loudest recording's
    let displacement_rms = |amplitude: &dyn Fn(&crate::extract::Line) -> f64| {
        spectra
            .iter()
            .map(|(period, ls)| {
                let sum: f64 = ls.iter().map(|l| amplitude(l).powi(2)).sum();
                (2.0 * sum).sqrt() / *period as f64
            })
            .fold(0.0, f64::max)
    };
    // the starts, what the linear estimate is, and its sign
    let (starts, estimate, sign) = if modes > 1 {
        let (starts, linear) =
            crate::fit::time::periodic_starts_modal(&lines, quantity, kind, modes, |m| {
                displacement_rms(&|l| {
                    l.reference * m.receptance(crate::harmonics::omega(l.frequency_hz)).norm()
                })
            })?;
        let estimate = format!("with {modes} modes ({})", modes_listed(&linear));
        (starts, estimate, linear.modes[0].residue.signum())
    } else {
        let (starts, linear) = crate::fit::time::periodic_starts(&lines, quantity, kind, |e| {
            displacement_rms(&|l| {
                let w = 2.0 * std::f64::consts::PI * l.frequency_hz;
                let d = num_complex::Complex64::new(e.stiffness - e.mass * w * w, e.damping * w);
                l.reference / d.norm()
            })
        })?;
        // in the drive's units (volts for the force on a voltage reference)
        let drive = records
            .first()
            .map_or(crate::harmonics::Quantity::Force, |r| r.reference_quantity);
        let estimate = sdof_listed(&linear, drive);
        (starts, estimate, linear.sign)
    };
    let options = TimeFitOptions::default();
    let models: Vec<Model> = starts.iter().map(|(m, _)| m.clone()).collect();
    let Some((best, misfit)) = crate::fit::time::closest_start(&models, &records, &options)? else {
        return Err(Error::input(
            "recordings",
            "the simulator rejects every start made from the linear estimate",
        ));
    };
    let shape = starts[best].1;
    // the structure's shares are of its (first) mode's
    let part = if modes > 1 {
        "the first mode"
    } else {
        "the structure"
    };
    notes.push(format!(
        "started from the linear estimate at the excited lines {estimate}: \
         {part} {:.0} % of its stiffness and {:.0} % of its damping, a {} joint {} times as stiff \
         slipping at {} RMS of the displacement it predicts (the closest of {} such starts: a per-segment \
         relative misfit of {:.2} %)",
        100.0 * shape.structure,
        100.0 * shape.damping,
        kind.name(),
        shape.joint,
        shape.slip_rms,
        starts.len(),
        100.0 * (misfit / records.len() as f64).sqrt(),
    ));
    let start = models[best].clone();
    if sign < 0.0 {
        notes.push("the linear estimate's modal constant is negative (a transfer); the response is fitted as recorded".into());
    }
    Ok(Some(PeriodicStart {
        records,
        start,
        note: notes.join("; "),
    }))
}

/// Each mode's frequency and damping ratio, for a note.
fn modes_listed(linear: &crate::model::ModalModel) -> String {
    let listed: Vec<String> = linear
        .modes
        .iter()
        .map(|m| {
            format!(
                "{:.4} Hz ({:.2} %)",
                m.frequency_hz,
                100.0 * m.damping_ratio
            )
        })
        .collect();
    listed.join(", ")
}

/// The SDOF estimate's mass, damping and stiffness in the `drive`'s units
/// (volts for the force on a voltage reference), for a note.
fn sdof_listed(linear: &crate::fit::SdofEstimate, drive: crate::harmonics::Quantity) -> String {
    let unit = |name| super::flags::law_parameter_unit(None, name, drive);
    format!(
        "(m {:.5e} {}, c {:.5e} {}, k {:.5e} {})",
        linear.mass,
        unit("mass"),
        linear.damping,
        unit("damping"),
        linear.stiffness,
        unit("stiffness")
    )
}

/// One recording found to be a multisine: its steady periods as the time
/// fit takes them, its response's quantity, its period and excited lines,
/// and a note of them.
struct PeriodicRecording {
    record: TimeRecord,
    quantity: crate::harmonics::Quantity,
    period: usize,
    lines: Vec<crate::extract::Line>,
    note: String,
}

/// `held` as a multisine's periods, or None where it is not one (no force
/// that repeats, fewer than [`MULTISINE_LINES`] lines excited).
fn periodic_recording(name: &str, held: super::HeldRecording) -> Result<Option<PeriodicRecording>> {
    if !held.meta.excitation.kind.may_be_multisine() {
        return Ok(None);
    }
    let Some(reference) = held.meta.reference_channel() else {
        return Ok(None);
    };
    let (u, y) = (
        held.channels[reference].view(),
        held.channels[held.response].view(),
    );
    let fs = held.meta.sample_rate_hz;
    let mut pair = crate::signals::InMemoryFrames::pair(u, y, fs)?;
    let Some(period) = crate::extract::find_period(&mut pair, 0)? else {
        return Ok(None);
    };
    let found = crate::extract::periodic_frf(&mut pair, 0, 1, period)?;
    if found.len() < MULTISINE_LINES {
        return Ok(None);
    }
    let periods = u.len().min(y.len()) / period;
    let q = held.meta.channels[held.response].quantity;
    let super::HeldRecording {
        meta,
        channels,
        response,
        ..
    } = held;
    let mut channels: Vec<Option<crate::signals::Samples>> =
        channels.into_iter().map(Some).collect();
    let reference_samples = channels[reference].take().expect("one channel each");
    let response_samples = match channels[response].take() {
        Some(r) => r,
        // the reference judged against itself
        None => reference_samples.clone(),
    };
    let held = (reference_samples, response_samples);
    let Some(r) = TimeRecord::steady_periods(name, &meta, response, held, period)? else {
        return Err(Error::input(
            format!("{name}: periods"),
            format!(
                "one period of {period} samples: a time fit judges the periods after the \
                 first (the replay starts from rest); record at least two"
            ),
        ));
    };
    let note = format!(
        "{name}: {periods} periods of {period} samples, {} lines excited ({:.4}-{:.4} Hz)",
        found.len(),
        found[0].frequency_hz,
        found[found.len() - 1].frequency_hz
    );
    Ok(Some(PeriodicRecording {
        record: r,
        quantity: q,
        period,
        lines: found,
        note,
    }))
}

/// Refines `fit` in the time domain on `records`: every parameter of its
/// model free (the linear part's inside `band_hz` as the FRF fit sees it),
/// started from the FRF fit.
pub fn run_time_fit(
    fit: &FitResult,
    records: &[TimeRecord],
    options: &TimeFitOptions,
    band_hz: Option<(f64, f64)>,
    observer: &dyn Observer,
) -> Result<TimeFitResult> {
    let params = time_parameters(&fit.model, options.refine_linear, band_hz);
    identify_time(
        &fit.model,
        params,
        fit.response_sign,
        records,
        options,
        Some(observer),
    )
}

/// `fit.json` of a time-domain fit from a model written down
/// (`identify --domain time --start MODEL.toml`): no FRF fit, the start and
/// the refinement. `validate` reads it as it reads an FRF fit's.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct TimeFitReport {
    /// `identify`.
    pub command: String,
    /// Tool version.
    pub version: String,
    /// The recordings fitted to, their paths as given.
    #[serde(deserialize_with = "listed")]
    pub recording: Vec<String>,
    /// The response channel fitted to: the one named by the user, else the
    /// one the first recording gives by default (empty in files of earlier
    /// versions: the first channel that is not the reference).
    pub response: String,
    /// The reference channel named by the user (`--reference`); none: the
    /// recording format's rule (the first force, else the first voltage).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub reference_channel: Option<String>,
    /// The model the fit started from, as written down.
    pub start: Model,
    /// The parameters held at the start's values.
    pub fixed: Vec<String>,
    /// The fit.
    pub time_domain: TimeFitResult,
    /// Its flagged parameters.
    #[serde(default, skip_serializing_if = "BTreeMap::is_empty")]
    pub time_domain_flags: BTreeMap<String, Vec<Flag>>,
    /// Files written.
    pub files: Vec<PathBuf>,
}

/// The fit.json of a model written down fitted to the nonlinear FRFs
/// (`identify --start MODEL`, see [`crate::diagnose::fit_declared`]).
/// `validate` and `identify --domain time --start` read it.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct DeclaredFitReport {
    /// `identify`.
    pub command: String,
    /// Tool version.
    pub version: String,
    /// The recordings fitted to, their paths as given.
    #[serde(deserialize_with = "listed")]
    pub recording: Vec<String>,
    /// The response channel fitted to: the one named by the user, else the
    /// one the first recording gives by default (empty in files of earlier
    /// versions: the first channel that is not the reference).
    pub response: String,
    /// The reference channel named by the user (`--reference`); none: the
    /// recording format's rule (the first force, else the first voltage).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub reference_channel: Option<String>,
    /// The model the fit started from, as written down.
    pub start: Model,
    /// The fit.
    pub frequency_domain: crate::diagnose::DeclaredFit,
    /// The quantity of the reference the FRFs were measured against (a
    /// force or a voltage): `validate` refuses a recording driven by the
    /// other.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub reference_quantity: Option<crate::harmonics::Quantity>,
    /// Files written.
    pub files: Vec<PathBuf>,
}

impl DeclaredFitReport {
    /// The report of `start` fitted to `frf` with `options`' harmonics, band
    /// and transfer (`identify --start`; see [`crate::diagnose::fit_declared`]),
    /// `observer` told of every evaluation.
    pub fn fit(
        frf: &NonlinearFrf,
        start: &Model,
        response_sign: f64,
        options: &FitOptions,
        recording: Vec<String>,
        response: String,
        observer: &dyn Observer,
    ) -> Result<DeclaredFitReport> {
        start.check_reference(
            frf.reference,
            &format!("{}: the reference", recording.join(", ")),
        )?;
        let fit = crate::diagnose::fit_declared(
            frf,
            start,
            response_sign,
            options.transfer || response_sign < 0.0,
            &options.harmonics,
            options.band_hz,
            &HbPredictor::default(),
            crate::diagnose::DiagnoseOptions::default().patience,
            observer,
        )?;
        Ok(DeclaredFitReport {
            command: "identify".into(),
            version: super::VERSION.into(),
            recording,
            response,
            reference_channel: None,
            start: start.clone(),
            frequency_domain: fit,
            reference_quantity: Some(frf.reference),
            files: Vec::new(),
        })
    }

    /// Whether a fit.json's text is this kind of report.
    pub fn is_one(value: &serde_json::Value) -> bool {
        value.get("start").is_some() && value.get("frequency_domain").is_some()
    }

    /// The terminal's lines for the fitted parameters.
    pub fn parameter_lines(&self) -> Vec<String> {
        let fit = &self.frequency_domain;
        let reference = self.reference_quantity.unwrap_or(Quantity::Force);
        let drive = super::flags::force_drive(&fit.model, reference);
        let unit = |name: &str| parameter_unit(name, &fit.model, drive);
        estimate_lines(&fit.parameters, &[], &BTreeMap::new(), &unit)
    }
}

impl TimeFitReport {
    /// Whether a fit.json's text is this kind of report (it has a `start`
    /// and no FRF fit).
    pub fn is_one(value: &serde_json::Value) -> bool {
        value.get("start").is_some() && value.get("time_domain").is_some()
    }

    /// The terminal's lines for the fitted parameters.
    pub fn parameter_lines(&self) -> Vec<String> {
        let t = &self.time_domain;
        let reference = t.reference_quantity.unwrap_or(Quantity::Force);
        let drive = super::flags::force_drive(&t.model, reference);
        let unit = |name: &str| parameter_unit(name, &t.model, drive);
        estimate_lines(&t.parameters, &[], &self.time_domain_flags, &unit)
    }
}

/// Fits `start`'s parameters, except those named in `fixed`, to `records`
/// in the time domain (every element's, and the linear part's), the
/// response taken as recorded (sign +1). Errors name an unknown `fixed`
/// name with the free ones.
pub fn run_time_fit_from_start(
    recording: Vec<String>,
    response: String,
    start: &Model,
    fixed: &[String],
    records: &[TimeRecord],
    options: &TimeFitOptions,
    observer: &dyn Observer,
) -> Result<TimeFitReport> {
    run_time_fit_from_start_signed(
        recording, response, start, 1.0, fixed, records, options, observer,
    )
}

/// [`run_time_fit_from_start`] for a start that predicts `response_sign`
/// times the recorded response (a fit's or a diagnosis's model of a
/// transfer with a negative modal constant).
#[allow(clippy::too_many_arguments)]
pub fn run_time_fit_from_start_signed(
    recording: Vec<String>,
    response: String,
    start: &Model,
    response_sign: f64,
    fixed: &[String],
    records: &[TimeRecord],
    options: &TimeFitOptions,
    observer: &dyn Observer,
) -> Result<TimeFitReport> {
    let mut params = time_parameters(start, true, None);
    // the gauges (Bouc-Wen's β, a shaker's gain) are held whether named or
    // not, under the names the parameters take
    let gauges: Vec<String> = start
        .placed_all()
        .flat_map(|(at, e)| {
            let prefix = start.parameter_prefix(at);
            e.description()
                .parameters
                .iter()
                .filter(|q| q.role == crate::model::Role::Gauge)
                .map(move |q| {
                    if prefix.is_empty() {
                        q.name.to_string()
                    } else {
                        format!("{prefix}.{}", q.name)
                    }
                })
        })
        .collect();
    let names: Vec<String> = params
        .parameters
        .iter()
        .map(|p| p.name.clone())
        .chain(gauges)
        .collect();
    for f in fixed {
        if !names.contains(f) {
            return Err(Error::input(
                "--fix",
                format!(
                    "`{f}` is not a parameter of the start (its parameters: {})",
                    names.join(", ")
                ),
            ));
        }
    }
    params.parameters.retain(|p| !fixed.contains(&p.name));
    let mut t = identify_time(
        start,
        params,
        response_sign,
        records,
        options,
        Some(observer),
    )?;
    let time_domain_flags = flag_estimates(
        &mut t.parameters,
        &t.model,
        &t.at_bound,
        t.response_sign < 0.0,
    );
    Ok(TimeFitReport {
        command: "identify".into(),
        version: super::VERSION.into(),
        recording,
        response,
        reference_channel: None,
        start: start.clone(),
        fixed: fixed.to_vec(),
        time_domain_flags,
        time_domain: t,
        files: Vec::new(),
    })
}

/// Fits `frf`, telling `observer` of every cost evaluation and writing each
/// to the MCAP run file's fit channel when given.
pub fn run_fit(
    frf: &NonlinearFrf,
    options: &FitOptions,
    observer: &dyn Observer,
    mcap: Option<&Mutex<&mut McapRecorder>>,
) -> Result<(FitResult, HbPredictor)> {
    let predictor = HbPredictor::default();
    // the first write error is kept and returned after the fit (an observer
    // cannot stop the optimiser)
    let write_error: Mutex<Option<Error>> = Mutex::new(None);
    let observe = |e: Event<'_>| {
        observer.observe(e);
        if let Event::Cost(t) = e
            && let Some(m) = mcap
            && let Err(e) = m
                .lock()
                .expect("mcap lock")
                .write_fit_iteration(t.evaluation as u64, t)
        {
            write_error.lock().expect("lock").get_or_insert(e);
        }
    };
    let fit = identify(frf, options, &predictor, Some(&observe))?;
    if let Some(e) = write_error.into_inner().expect("lock") {
        return Err(e);
    }
    Ok((fit, predictor))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A fit.json written by `hystid run` reads back into the same report.
    #[test]
    fn fit_report_round_trips_through_json() {
        let def = TestDefinition::embedded_default();
        let run =
            crate::testbench::run(&def, &mut crate::testbench::NoSink, &crate::observe::Silent)
                .unwrap();
        let options = FitOptions::default();
        let (fit, _) = run_fit(&run.frf, &options, &crate::observe::Silent, None).unwrap();
        let report = FitReport::new(
            vec!["run.mcap".into()],
            "acceleration".into(),
            fit,
            reference_joint(Some(&def)),
            vec!["fit.json".into()],
        );
        let text = serde_json::to_string_pretty(&report).unwrap();
        let back: FitReport = serde_json::from_str(&text).unwrap();
        assert_eq!(back, report);
        assert_eq!(serde_json::to_string_pretty(&back).unwrap(), text);
        // a fit.json from before the status still reads
        let mut old: serde_json::Value = serde_json::from_str(&text).unwrap();
        old.as_object_mut().unwrap().remove("status");
        let old: FitReport = serde_json::from_value(old).unwrap();
        assert_eq!(old.fit.status, crate::fit::FitStatus::Unknown);
        // and one from before the flags: read without them
        let mut old: serde_json::Value = serde_json::from_str(&text).unwrap();
        for field in ["at_bound", "flags", "time_domain_flags"] {
            old.as_object_mut().unwrap().remove(field);
        }
        let old: FitReport = serde_json::from_value(old).unwrap();
        assert!(old.flags.is_empty() && old.fit.at_bound.is_empty());
    }
}
