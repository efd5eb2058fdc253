//! A fitted model driven by recordings' measured force, its simulated
//! response compared with the measured one (e_RMS, `H1`): the model read
//! from `fit.json`, `validate.json` and the overlay figures.

mod request;
pub use request::ValidateRequest;

use super::identify::FitReport;
use super::recording::{Loaded, ReductionOptions, SineTest, excitation_of, stepped_options};
use crate::error::{Error, Result};
use crate::extract::lines::LineClass;
use crate::harmonics::Quantity;
use crate::model::{ModalModel, Model};
use crate::plot::{self, FrfSeries, SeriesStyle, TimeTrace, TimeTraceBuilder};
use crate::signals::{InMemoryFrames, RecordingView, SamplesView};
use crate::validate::{Reduction, ReplayTap, ValidateOptions, Validation, validate_view};
use num_complex::Complex64;
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};

/// The model to validate, from a fit.json or a model file.
pub struct FitModel {
    /// The model.
    pub model: Model,
    /// The model predicts `sign × H_measured`.
    pub response_sign: f64,
    /// The response channel the fit used.
    pub response: Option<String>,
    /// The reference channel the fit was made with, when the user named it.
    pub reference: Option<String>,
    /// The quantity the fit's reference was (a force or a voltage), when
    /// its report says (a model written down does not).
    pub reference_quantity: Option<Quantity>,
    /// `fitted`, `fitted in the time domain`, `diagnosed`, `linear` or
    /// `declared`.
    pub kind: &'static str,
    /// How the recorded response was decimated, where the model file says
    /// (its `[acquisition]`): the replay is put through the same chain.
    pub acquisition: Option<crate::validate::acquisition::Acquisition>,
}

/// Reads the model to validate: a fit.json's `model` (or, with `linear`,
/// the SDOF of `linear.stick` with no element) and `response_sign`; a
/// diagnosis.json's final `model` and `response_sign`; or a
/// model written down (`*.toml`: a test definition or its structure alone,
/// e.g. a benchmark's published model), which predicts the response as
/// recorded, or its opposite with a top-level `response_sign = -1` (a
/// transfer whose first modal constant is negative, as fit.json says).
pub fn read_fit(path: &Path, linear: bool) -> Result<FitModel> {
    if path
        .extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("toml"))
    {
        if linear {
            return Err(Error::format(
                path,
                "model",
                "--linear takes a fit.json (its linear.stick); a declared model is validated as written",
            ));
        }
        let text = std::fs::read_to_string(path).map_err(|e| Error::io(path, e))?;
        let (text, response_sign, acquisition) = toml_measurement(text, path)?;
        let model = crate::testbench::model_from_toml(&text, &path.display().to_string())?;
        return Ok(FitModel {
            model,
            response_sign,
            response: None,
            reference: None,
            reference_quantity: None,
            kind: "declared",
            acquisition,
        });
    }
    let text = std::fs::read(path).map_err(|e| Error::io(path, e))?;
    FitModel::of_json(&text, linear, path)
}

/// A model file's top-level `response_sign` (1 when absent) and
/// `[acquisition]` (see [`crate::validate::acquisition`]), and its text
/// without them (the structure's own schema has neither).
fn toml_measurement(
    text: String,
    path: &Path,
) -> Result<(
    String,
    f64,
    Option<crate::validate::acquisition::Acquisition>,
)> {
    let Ok(mut table) = text.parse::<toml::Table>() else {
        // the structure's parser names what is wrong
        return Ok((text, 1.0, None));
    };
    if !table.contains_key("acquisition") && !table.contains_key("response_sign") {
        return Ok((text, 1.0, None));
    }
    let acquisition = table
        .remove("acquisition")
        .map(|v| {
            let a: crate::validate::acquisition::Acquisition = v
                .try_into()
                .map_err(|e: toml::de::Error| Error::format(path, "acquisition", e.to_string()))?;
            a.check()
                .map_err(|e| Error::format(path, "acquisition", e.to_string()))?;
            Ok::<_, Error>(a)
        })
        .transpose()?;
    let sign = match table.remove("response_sign") {
        None => 1.0,
        Some(value) => value
            .as_float()
            .or_else(|| value.as_integer().map(|i| i as f64))
            .filter(|s| *s == 1.0 || *s == -1.0)
            .ok_or_else(|| {
                Error::format(
                    path,
                    "response_sign",
                    format!("expected 1 or -1, got {value}"),
                )
            })?,
    };
    let text =
        toml::to_string(&table).map_err(|e| Error::format(path, "response_sign", e.to_string()))?;
    Ok((text, sign, acquisition))
}

impl FitModel {
    /// The model of a fit.json's text, either kind: an FRF fit's
    /// (optionally refined in the time domain) or a time-domain fit from a
    /// model written down; `path` names it in errors.
    pub fn of_json(text: &[u8], linear: bool, path: &Path) -> Result<FitModel> {
        let value = serde_json::from_slice::<serde_json::Value>(text).ok();
        if let Some(value) = value.as_ref().filter(|v| v["command"] == "diagnose") {
            // the diagnosis's final model: the fit with the effects it kept
            if linear {
                return Err(Error::format(
                    path,
                    "model",
                    "--linear takes an FRF fit's fit.json (its linear.stick), not a diagnosis",
                ));
            }
            let model: Model = serde_json::from_value(value["model"].clone())
                .map_err(|e| Error::format(path, "model", e.to_string()))?;
            model
                .validate()
                .map_err(|e| Error::format(path, "model", e.to_string()))?;
            let response_sign = value["response_sign"]
                .as_f64()
                .filter(|s| *s == 1.0 || *s == -1.0)
                .ok_or_else(|| Error::format(path, "response_sign", "expected 1 or -1"))?;
            return Ok(FitModel {
                model,
                response_sign,
                response: None,
                reference: value["reference_channel"].as_str().map(str::to_string),
                reference_quantity: serde_json::from_value(value["reference_quantity"].clone())
                    .ok(),
                kind: "diagnosed",
                // the chain its time-domain refit declared: a stepped or
                // swept diagnosis's (`time_domain.refit`), a multisine's
                // (`refit`)
                acquisition: [&value["time_domain"]["refit"], &value["refit"]]
                    .into_iter()
                    .find_map(|r| serde_json::from_value(r["acquisition"].clone()).ok()),
            });
        }
        if let Some(value) = value
            .as_ref()
            .filter(|v| super::identify::DeclaredFitReport::is_one(v))
        {
            let report: super::identify::DeclaredFitReport = serde_json::from_value(value.clone())
                .map_err(|e| Error::format(path, "frequency_domain", e.to_string()))?;
            if linear {
                return Err(Error::format(
                    path,
                    "fit",
                    "--linear takes an FRF fit's fit.json (its linear.stick); this fit started from a model written down",
                ));
            }
            let f = report.frequency_domain;
            return Ok(FitModel {
                model: f.model,
                response_sign: f.response_sign,
                response: (!report.response.is_empty()).then_some(report.response),
                reference: report.reference_channel,
                reference_quantity: report.reference_quantity,
                kind: "fitted to the FRFs from a start",
                acquisition: None,
            });
        }
        if let Some(value) = value.filter(super::identify::TimeFitReport::is_one) {
            let report: super::identify::TimeFitReport = serde_json::from_value(value)
                .map_err(|e| Error::format(path, "time_domain", e.to_string()))?;
            if linear {
                return Err(Error::format(
                    path,
                    "fit",
                    "--linear takes an FRF fit's fit.json (its linear.stick); this fit started from a model written down",
                ));
            }
            let t = report.time_domain;
            t.model
                .validate()
                .map_err(|e| Error::format(path, "time_domain.model", e.to_string()))?;
            return Ok(FitModel {
                model: t.model,
                response_sign: t.response_sign,
                // none named: the first channel that is not the reference, as
                // the fit took it
                response: (!report.response.is_empty()).then_some(report.response),
                reference: report.reference_channel,
                reference_quantity: t.reference_quantity,
                kind: "fitted in the time domain",
                acquisition: t.acquisition,
            });
        }
        FitModel::of_report(FitReport::parse(path, text)?, linear, path)
    }
}

impl FitModel {
    /// The model of a fit report read from `path` (which errors name): its
    /// final model (or, with `linear`, the SDOF of `linear.stick` with no
    /// element) and response sign.
    pub fn of_report(report: FitReport, linear: bool, path: &Path) -> Result<FitModel> {
        let response = (!report.response.is_empty()).then(|| report.response.clone());
        let reference = report.reference_channel.clone();
        let reference_quantity = report
            .time_domain
            .as_ref()
            .and_then(|t| t.reference_quantity)
            .or(report.fit.reference_quantity);
        let (final_model, final_sign) = report.final_model();
        let (final_model, final_sign) = (final_model.clone(), final_sign);
        let kind = if report.time_domain.is_some() {
            "fitted in the time domain"
        } else {
            "fitted"
        };
        // the recorded response's chain the time-domain refinement declared
        // (the recording's, whichever model is replayed)
        let acquisition = report
            .time_domain
            .as_ref()
            .and_then(|t| t.acquisition.clone());
        let fit = report.fit;
        if linear {
            let s = &fit.linear.stick;
            let model = ModalModel::sdof(s.mass, s.damping, s.stiffness)
                .and_then(|m| Model::new(m, Vec::new()))
                .map_err(|e| Error::format(path, "linear.stick", e.to_string()))?;
            return Ok(FitModel {
                model,
                response_sign: s.sign,
                response,
                reference,
                reference_quantity,
                kind: "linear",
                acquisition,
            });
        }
        if final_sign != 1.0 && final_sign != -1.0 {
            return Err(Error::format(
                path,
                "response_sign",
                format!("must be 1 or -1, got {final_sign}"),
            ));
        }
        final_model
            .validate()
            .map_err(|e| Error::format(path, "model", e.to_string()))?;
        Ok(FitModel {
            model: final_model,
            response_sign: final_sign,
            response,
            reference,
            reference_quantity,
            kind,
            acquisition,
        })
    }
}

/// One recording's entry in validate.json.
#[derive(Serialize)]
pub struct RecordingValidation {
    /// The recording.
    pub recording: String,
    /// The response channel.
    pub response: String,
    /// The figures (none where the replay failed).
    #[serde(flatten)]
    pub validation: Option<Validation>,
    /// Why the model could not be replayed on this recording (a solve
    /// that did not converge: the model runs away under this drive), which
    /// leaves the other recordings' figures standing.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub replay_failed: Option<String>,
}

/// validate.json.
#[derive(Serialize)]
pub struct ValidateReport<'a> {
    /// `validate`.
    pub command: &'static str,
    /// Tool version.
    pub version: &'static str,
    /// The fit file.
    pub fit: String,
    /// `fitted` or `linear` (the fit's smallest-level SDOF).
    pub model_kind: &'static str,
    /// The model simulated.
    pub model: &'a Model,
    /// The sign the simulated response was multiplied by.
    pub response_sign: f64,
    /// The acquisition chain the simulated response was put through, where
    /// the model file declares one.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub acquisition: Option<&'a crate::validate::acquisition::Acquisition>,
    /// Per recording.
    pub recordings: Vec<RecordingValidation>,
    /// Files written.
    pub files: Vec<PathBuf>,
}

/// How a recording is validated on.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct ValidationSettings {
    /// Band of the FRF comparison (and of a sweep's second error figure), Hz.
    pub band_hz: Option<(f64, f64)>,
    /// Time window of the second error figure, s.
    pub window_s: Option<(f64, f64)>,
    /// Fewest samples per period of the model's highest linearised
    /// frequency before the simulation is upsampled.
    pub min_samples_per_period: f64,
    /// Compare FRFs too (else the time domain only).
    pub frf: bool,
    /// How both signals are reduced for the FRF comparison.
    pub reduction: ReductionOptions,
    /// Each recording is one period of a periodic steady state (see
    /// [`ValidateOptions::periodic`]); no FRF comparison then.
    pub periodic: bool,
    /// What the reference and the joint's force are between samples (see
    /// [`crate::validate::DriveInput`]).
    pub input: crate::validate::DriveInput,
}

/// A file stem for `path`'s figures not yet in `used` (`name`, `name_2`, …).
pub fn unique_stem(path: &Path, used: &mut Vec<String>) -> String {
    let base = path
        .file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_else(|| "recording".into());
    let mut name = base.clone();
    let mut k = 2;
    while used.contains(&name) {
        name = format!("{base}_{k}");
        k += 1;
    }
    used.push(name.clone());
    name
}

/// Validates `fit` on a loaded recording, its progress told to `observer`
/// (which may stop it): [`validate_on`] without the figures, the replay
/// kept ([`Validation::simulated`]). `name` names the recording in a
/// multisine's strongest lines.
pub fn validate_loaded(
    fit: &FitModel,
    name: &str,
    loaded: &Loaded,
    settings: &ValidationSettings,
    observer: &dyn crate::observe::Observer,
) -> Result<Validation> {
    validate_held(
        fit,
        name,
        (&loaded.recording.view(), loaded.response),
        settings,
        true,
        observer,
        &mut (),
    )
}

/// [`validate_loaded`] on a recording however it is held, `keep_replay`
/// saying whether the replay is kept whole and `tap` handed it as it is
/// made (see [`crate::validate::validate_view`]).
fn validate_held(
    fit: &FitModel,
    name: &str,
    (rec, response): (&RecordingView, usize),
    settings: &ValidationSettings,
    keep_replay: bool,
    observer: &dyn crate::observe::Observer,
    tap: &mut dyn ReplayTap,
) -> Result<Validation> {
    let reference = rec
        .meta
        .reference_channel()
        .ok_or_else(|| Error::input("recording", "no reference channel"))?;
    let channel = &rec.meta.channels[reference];
    check_reference_quantity(fit, channel)?;
    // a multisine (excitation not stated, a reference that repeats) has no
    // nonlinear FRFs to compare: its time error is the whole validation
    let multisine = settings
        .reduction
        .excitation
        .is_none()
        .then(|| super::recording::multisine_period(rec, response))
        .flatten()
        .map(|m| m.0);
    let broadband = settings.frf
        && !settings.periodic
        && multisine.is_none()
        && drive_is_broadband(rec, reference, settings)?;
    let reduction = if settings.frf && !settings.periodic && multisine.is_none() && !broadband {
        Some(sine_reduction(rec, (reference, response), settings)?)
    } else {
        None
    };
    let band = settings.band_hz;
    let opts = ValidateOptions {
        min_samples_per_period: settings.min_samples_per_period,
        window_s: settings.window_s,
        band_hz: band,
        reduction,
        periodic: settings.periodic,
        input: settings.input,
        acquisition: fit.acquisition.clone(),
    };
    // a multisine is judged at the lines of its period where two steady
    // periods or more (after the first, the replay's start from rest) give
    // the noise to judge it by; the replay's lines made as it comes
    let spectra = match multisine.filter(|_| !settings.periodic) {
        Some(period) => steady_spectra(name, rec, response, period)?,
        None => None,
    };
    let mut lines = spectra.as_ref().map(|s| s.replayed_lines());
    // a periodic record is one period (short): its replay kept for the
    // error at the period's lines
    let mut v = validate_view(
        &fit.model,
        (
            fit.response_sign,
            keep_replay || settings.periodic || broadband,
        ),
        rec,
        response,
        &opts,
        observer,
        &mut WithLines {
            tap,
            lines: lines.as_mut(),
        },
    )?;
    if let (Some(spectra), Some(lines)) = (&spectra, lines) {
        v.lines = Some(crate::extract::lines::validate_lines(
            spectra,
            &lines.finish()?,
        ));
    }
    if broadband {
        let n = v.simulated.len();
        v.h1 = crate::validate::compare_h1(
            &rec.channels[reference].range(0..n.min(rec.channels[reference].len())),
            (
                &rec.channels[response].range(0..n.min(rec.channels[response].len())),
                &v.simulated,
            ),
            rec.meta.sample_rate_hz,
            settings.band_hz,
        )?;
        v.assumed = Some(broadband_words(rec, v.h1.as_ref()));
        if !keep_replay {
            v.simulated = Vec::new();
        }
    }
    if settings.periodic {
        let n = v.simulated.len();
        v.line_spectrum = crate::extract::lines::line_spectrum(
            &rec.channels[reference].range(0..n.min(rec.channels[reference].len())),
            &rec.channels[response].range(0..n.min(rec.channels[response].len())),
            &v.simulated,
            rec.meta.sample_rate_hz,
        );
        if !keep_replay {
            v.simulated = Vec::new();
        }
    }
    Ok(v)
}

/// A model fitted with one reference quantity is not validated on
/// recordings driven by another: a model fitted in newtons driven by volts
/// (or the reverse) gives figures that mean nothing.
fn check_reference_quantity(fit: &FitModel, channel: &crate::signals::Channel) -> Result<()> {
    if let Some(fitted) = fit.reference_quantity
        && channel.quantity != fitted
    {
        return Err(Error::input(
            format!("reference channel `{}`", channel.name),
            format!(
                "is a {}, but the model was fitted with a {fitted} as its reference: validate \
                 it on recordings driven as the fit's were (`--reference` names another \
                 channel)",
                channel.quantity
            ),
        ));
    }
    Ok(())
}

/// How a sine test's recording is reduced to the FRFs it is compared at:
/// stepped or swept as stated (or as found).
fn sine_reduction(
    rec: &RecordingView,
    (reference, response): (usize, usize),
    settings: &ValidationSettings,
) -> Result<Reduction> {
    Ok(
        match excitation_of(rec.meta, settings.reduction.excitation) {
            SineTest::Stepped => Reduction::Stepped(stepped_options(&settings.reduction)),
            SineTest::Swept => Reduction::Swept(super::recording::sweep_options(
                &mut InMemoryFrames::pair(
                    rec.channels[reference],
                    rec.channels[response],
                    rec.meta.sample_rate_hz,
                )?,
                0,
                1,
                &settings.reduction,
            )?),
        },
    )
}

/// What a broadband drive's validation assumed and found, in one line.
fn broadband_words(rec: &RecordingView, h1: Option<&crate::validate::H1Comparison>) -> String {
    let why = if rec.meta.excitation.kind == crate::signals::ExcitationKind::Random {
        "the recording states a random excitation"
    } else {
        "no sine dwell was found in the reference and the recording states no excitation: taken \
         as a broadband drive"
    };
    match h1 {
        Some(c) => format!(
            "{why}: compared in the time domain and by H1 ({} Welch segments of {} samples): \
             H1 error {:.1} % over {} lines of coherence >= {}",
            c.averages,
            c.segment,
            100.0 * c.relative_error,
            c.frequency_hz.len(),
            crate::validate::MIN_COHERENCE
        ),
        None => format!(
            "{why}: compared in the time domain only (no line in the band has a coherence >= {})",
            crate::validate::MIN_COHERENCE
        ),
    }
}

/// Whether a recording's drive is broadband, its FRF compared by H1 rather
/// than by its harmonics: stated `random`, or nobody said (excitation
/// unknown, no steps, no reduction chosen) and its reference holds no sine
/// dwell.
fn drive_is_broadband(
    rec: &RecordingView,
    reference: usize,
    settings: &ValidationSettings,
) -> Result<bool> {
    use crate::signals::ExcitationKind;
    if settings.reduction.excitation.is_some() || !rec.meta.excitation.steps.is_empty() {
        return Ok(false);
    }
    if rec.meta.excitation.kind == ExcitationKind::Random {
        return Ok(true);
    }
    if rec.meta.excitation.kind != ExcitationKind::Unknown {
        return Ok(false);
    }
    match crate::extract::find_dwells(
        &mut InMemoryFrames::single(rec.channels[reference], rec.meta.sample_rate_hz),
        0,
        &stepped_options(&settings.reduction).dwell,
        &crate::observe::Silent,
    ) {
        Ok(_) => Ok(false),
        Err(Error::NoDwell { .. }) => Ok(true),
        Err(e) => Err(e),
    }
}

/// The spectra of a multisine recording's steady periods of `period`
/// samples (all whole ones after the first), read from the channels as
/// they are held; `None` where fewer than two follow the first.
fn steady_spectra(
    name: &str,
    rec: &RecordingView,
    response: usize,
    period: usize,
) -> Result<Option<crate::extract::lines::PeriodicSpectra>> {
    let reference = rec
        .meta
        .reference_channel()
        .ok_or_else(|| Error::input("recording", "no reference channel"))?;
    let (u, y) = (rec.channels[reference], rec.channels[response]);
    let periods = u.len().min(y.len()) / period.max(1);
    if period == 0 || periods < 3 {
        return Ok(None);
    }
    crate::extract::lines::PeriodicSpectra::of_channels(
        name,
        (
            rec.meta.channels[reference].quantity,
            rec.meta.sample_rate_hz,
        ),
        (u, y),
        (1..periods).map(|k| k * period..(k + 1) * period).collect(),
    )
    .map(Some)
}

/// A replay tap that also hands the replay to a multisine's lines.
struct WithLines<'t, 'l, 's> {
    tap: &'t mut dyn ReplayTap,
    lines: Option<&'l mut crate::extract::lines::ReplayedLines<'s>>,
}

impl ReplayTap for WithLines<'_, '_, '_> {
    fn begin(&mut self, samples: usize, window: Option<std::ops::Range<usize>>) {
        self.tap.begin(samples, window);
    }

    fn stretch(&mut self, at: usize, measured: &[f64], simulated: &[f64]) {
        if let Some(lines) = &mut self.lines {
            lines.push(at, simulated);
        }
        self.tap.stretch(at, measured, simulated);
    }
}

/// The time figures' traces, made as the replay comes: the whole record's
/// and the window's, measured, simulated and their difference.
struct Traces<'a> {
    measured: SamplesView<'a>,
    sample_rate_hz: f64,
    whole: Option<[TimeTraceBuilder; 3]>,
    window: Option<(std::ops::Range<usize>, [TimeTraceBuilder; 3])>,
}

impl Traces<'_> {
    fn builders(&self, range: std::ops::Range<usize>) -> [TimeTraceBuilder; 3] {
        let (n, t0, fs) = (
            range.len(),
            range.start as f64 / self.sample_rate_hz,
            self.sample_rate_hz,
        );
        let mut measured = TimeTraceBuilder::new("measured", n, t0, fs);
        self.measured
            .for_each_stretch(range, |_, w| measured.push(w));
        [
            measured,
            TimeTraceBuilder::new("simulated", n, t0, fs),
            TimeTraceBuilder::new("difference", n, t0, fs),
        ]
    }

    fn finish(b: [TimeTraceBuilder; 3]) -> [TimeTrace; 3] {
        b.map(TimeTraceBuilder::finish)
    }
}

impl ReplayTap for Traces<'_> {
    fn begin(&mut self, samples: usize, window: Option<std::ops::Range<usize>>) {
        self.whole = Some(self.builders(0..samples));
        self.window = window.map(|w| (w.clone(), self.builders(w)));
    }

    fn stretch(&mut self, at: usize, measured: &[f64], simulated: &[f64]) {
        let difference: Vec<f64> = measured.iter().zip(simulated).map(|(a, b)| a - b).collect();
        if let Some([_, s, d]) = &mut self.whole {
            s.push(simulated);
            d.push(&difference);
        }
        if let Some((w, [_, s, d])) = &mut self.window {
            // the part of the stretch inside the window
            let (a, b) = (at.max(w.start), (at + simulated.len()).min(w.end));
            if a < b {
                s.push(&simulated[a - at..b - at]);
                d.push(&difference[a - at..b - at]);
            }
        }
    }
}

/// Validates `fit` on the recording `rec` (its response channel `response`)
/// loaded from `path`, and writes its figures into `dir` as
/// `{stem}_time`, `{stem}_time_window`, `{stem}_frf`: the replay is never
/// held whole where the recording's dwells can be read one at a time (see
/// [`crate::validate::validate_view`]). A replay that does not converge
/// (the model runs away under this drive) is the entry's
/// `replay_failed`, with no figures; other errors are errors.
#[allow(clippy::too_many_arguments)]
pub fn validate_on(
    fit: &FitModel,
    path: &Path,
    (rec, response): (&RecordingView, usize),
    settings: &ValidationSettings,
    dir: &Path,
    stem: &str,
    observer: &dyn crate::observe::Observer,
) -> Result<(RecordingValidation, Vec<PathBuf>)> {
    let shown = path.display().to_string();
    let fs = rec.meta.sample_rate_hz;
    let mut traces = Traces {
        measured: rec.channels[response],
        sample_rate_hz: fs,
        whole: None,
        window: None,
    };
    let v = match validate_held(
        fit,
        &shown,
        (rec, response),
        settings,
        false,
        observer,
        &mut traces,
    )
    .map_err(|e| Error::context(format!("validating on {}", path.display()), e))
    {
        Ok(v) => v,
        // the model ran away under this recording's drive: that is this
        // recording's result (no figures, and why), not the end of the
        // others'
        Err(e) if matches!(e.root(), Error::NotConverged { .. }) => {
            let entry = RecordingValidation {
                recording: path.display().to_string(),
                response: rec.meta.channels[response].name.clone(),
                validation: None,
                replay_failed: Some(crate::error::one_line(&e)),
            };
            return Ok((entry, Vec::new()));
        }
        Err(e) => return Err(e),
    };
    let band = settings.band_hz;
    let mut files = Vec::new();
    let name = path.file_name().map_or_else(
        || path.display().to_string(),
        |n| n.to_string_lossy().into_owned(),
    );
    let channel = &rec.meta.channels[response];
    let y_label = format!("{} [{}]", channel.name, channel.unit.replace("^2", "²"));
    if let Some(whole) = traces.whole.take() {
        let [m, s, d] = Traces::finish(whole);
        files.extend(plot::write_time_overlay_traced(
            &dir.join(format!("{stem}_time")),
            &format!(
                "{name}: measured and simulated ({} model), e_RMS {:.3e} {} ({:.1} % of the RMS)",
                fit.kind,
                v.whole.e_rms,
                channel.unit,
                100.0 * v.whole.relative
            ),
            &y_label,
            [&m, &s, &d],
        )?);
    }
    if let (Some(w), Some((_, window))) = (&v.window, traces.window.take()) {
        let [m, s, d] = Traces::finish(window);
        files.extend(plot::write_time_overlay_traced(
            &dir.join(format!("{stem}_time_window")),
            &format!(
                "{name}: {:.1}-{:.1} s, e_RMS {:.3e} {} ({:.1} % of the RMS)",
                w.start_s,
                w.end_s,
                w.e_rms,
                channel.unit,
                100.0 * w.relative
            ),
            &y_label,
            [&m, &s, &d],
        )?);
    }
    if let Some(c) = &v.frf
        && let (Some(m), Some(s)) = (&c.measured, &c.simulated)
    {
        let mut series = Vec::new();
        for (g, (lm, ls)) in m.levels.iter().zip(&s.levels).enumerate() {
            let keep = |f: f64| band.is_none_or(|(lo, hi)| f >= lo && f <= hi);
            let pick = |l: &crate::extract::FrfLevel| -> (Vec<f64>, Vec<Complex64>) {
                l.points
                    .iter()
                    .filter(|p| keep(p.frequency_hz))
                    .map(|p| (p.frequency_hz, p.h[1]))
                    .unzip()
            };
            let (fm, hm) = pick(lm);
            let (fs_, hs) = pick(ls);
            if fm.is_empty() {
                continue;
            }
            let label = plot::level_label(lm.level, m.reference.si_unit());
            series.push(FrfSeries {
                label: format!("{label} measured"),
                group: g,
                frequency_hz: fm,
                h: hm,
                std_error: None,
                style: SeriesStyle::Measured,
            });
            series.push(FrfSeries {
                label: format!("{label} simulated"),
                group: g,
                frequency_hz: fs_,
                h: hs,
                std_error: None,
                style: SeriesStyle::Model,
            });
        }
        if !series.is_empty() {
            files.extend(plot::write_frf_plot(
                &dir.join(format!("{stem}_frf")),
                &format!(
                    "{name}: H1 measured (markers), simulated ({} model)",
                    fit.kind
                ),
                &plot::frf_magnitude_label(m, 1),
                &series,
            )?);
        }
    }
    if let Some(c) = &v.h1 {
        let label = format!(
            "|H1| [{}/{}]",
            channel.unit.replace("^2", "²"),
            rec.meta.channels[rec.meta.reference_channel().unwrap_or(0)].unit
        );
        files.extend(plot::write_frf_plot(
            &dir.join(format!("{stem}_h1")),
            &format!(
                "{name}: H1 of a broadband drive, measured and simulated ({} model), error {:.1} %",
                fit.kind,
                100.0 * c.relative_error
            ),
            &label,
            &[
                FrfSeries {
                    label: "measured".into(),
                    group: 0,
                    frequency_hz: c.frequency_hz.clone(),
                    h: c.measured.clone(),
                    std_error: None,
                    style: SeriesStyle::Measured,
                },
                FrfSeries {
                    label: "simulated".into(),
                    group: 0,
                    frequency_hz: c.frequency_hz.clone(),
                    h: c.simulated.clone(),
                    std_error: None,
                    style: SeriesStyle::Model,
                },
            ],
        )?);
    }
    if let Some(l) = &v.lines {
        // one series per class of line, as a multisine user reads them
        let series = [
            LineClass::Excited,
            LineClass::OddNotExcited,
            LineClass::EvenNotExcited,
        ]
        .into_iter()
        .enumerate()
        .filter_map(|(g, class)| {
            // joined along neighbouring lines only: a gap (NaN) where the
            // class skips lines
            let (mut frequency_hz, mut residual) = (Vec::new(), Vec::new());
            let mut last = None;
            for (i, p) in l.per_line.iter().enumerate().filter(|(_, p)| p.2 == class) {
                if last.is_some_and(|j| j + 1 != i) {
                    frequency_hz.push(p.0);
                    residual.push(f64::NAN);
                }
                frequency_hz.push(p.0);
                residual.push(p.1);
                last = Some(i);
            }
            (!frequency_hz.is_empty()).then(|| plot::ResidualSeries {
                label: format!("{} lines", class.words()),
                group: g,
                frequency_hz,
                residual,
            })
        })
        .collect();
        files.extend(plot::write_residual_plot(
            &dir.join(format!("{stem}_lines")),
            &format!(
                "{name}: residual at the lines of the period ({} model), chi2 per line {:.3}",
                fit.kind, l.residual.chi2_per_line
            ),
            "|Y - Y_model| / noise",
            &[plot::ResidualPanel {
                heading: format!(
                    "{} steady periods of {} samples, the noise from their scatter",
                    l.steady_periods, l.period_samples
                ),
                series,
            }],
            Some(&plot::NoiseLevel {
                value: 2.0,
                label: "2x the noise".into(),
            }),
        )?);
    }
    if let Some(l) = &v.line_spectrum {
        // measured, simulated and their difference along the lines
        let series = ["measured", "simulated", "difference"]
            .into_iter()
            .enumerate()
            .map(|(g, label)| plot::ResidualSeries {
                label: label.into(),
                group: g,
                frequency_hz: l.per_line.iter().map(|p| p.0).collect(),
                residual: l.per_line.iter().map(|p| p.2[g]).collect(),
            })
            .collect();
        let excited = l
            .by_class
            .iter()
            .find(|c| c.class == LineClass::Excited)
            .map_or(f64::NAN, |c| c.relative);
        files.extend(plot::write_residual_plot(
            &dir.join(format!("{stem}_lines")),
            &format!(
                "{name}: lines of the period ({} model), difference {:.2} % at the excited",
                fit.kind,
                100.0 * excited
            ),
            &format!("{} at the line ({})", v.quantity, v.quantity.si_unit()),
            &[plot::ResidualPanel {
                heading: format!(
                    "one period of {} samples, {} lines",
                    l.period_samples, l.lines
                ),
                series,
            }],
            None,
        )?);
    }
    let entry = RecordingValidation {
        recording: path.display().to_string(),
        response: channel.name.clone(),
        validation: Some(v),
        replay_failed: None,
    };
    Ok((entry, files))
}

#[cfg(test)]
mod tests {
    use super::*;

    const MODEL: &str = "[system]\nmass = 1.0\ndamping = 2.0\nstiffness = 4.0e5\n";

    /// A model written down predicts the response as recorded unless it
    /// says `response_sign = -1`; any other sign names the file and field.
    #[test]
    fn a_model_file_may_carry_its_response_sign() {
        let dir = tempfile::tempdir().unwrap();
        let read = |name: &str, head: &str| {
            let p = dir.path().join(name);
            std::fs::write(&p, format!("{head}{MODEL}")).unwrap();
            read_fit(&p, false)
        };
        let plain = read("plain.toml", "").unwrap();
        assert_eq!(plain.response_sign, 1.0);
        let flipped = read("flipped.toml", "response_sign = -1\n").unwrap();
        assert_eq!(flipped.response_sign, -1.0);
        assert_eq!(flipped.model, plain.model);
        let Err(err) = read("bad.toml", "response_sign = 2\n") else {
            panic!("a sign of 2 was taken");
        };
        let err = err.to_string();
        assert!(
            err.contains("bad.toml") && err.contains("response_sign") && err.contains("1 or -1"),
            "{err}"
        );
    }
}
