//! A virtual test end to end, summarised: `run.json` and `report.md`.
//!
//! What a run reports is one model, the *final* one: the diagnosis's when
//! it ran (the fitted joint with the effects it added, every parameter
//! refitted, with 95 % intervals), else the fit's. The first fit is shown
//! as the "before". Both are judged by one error figure on the same data
//! ([`crate::fit::identify::error_report`]: the relative error of the
//! fundamental `‖H1_meas − H1_model‖/‖H1_meas‖` over every measured point
//! of the band, and `χ²` per degree of freedom with the measured standard
//! errors over the harmonics judged), so the report's, the terminal's and
//! `run.json`'s figures are the same numbers. Every reported parameter at a
//! bound of its fit, outside its physical domain, or not resolved by the
//! data carries a [`Flag`], in words in `report.md` and as a list in
//! `run.json`. The paper's Table 3.1 is set beside the result only when
//! the test is of the paper's system (the embedded default's structure).

pub use super::flags::{Flag, flags_of};

mod request;
pub use request::RunRequest;

use super::flags::{describe, flag_words, parameter_unit};
use super::identify::FitReport;
use super::simulate::SimulateSummary;
use crate::diagnose::{Diagnosis, model_parameters};
use crate::error::Result;
use crate::extract::NonlinearFrf;
use crate::fit::identify::{ErrorReport, confidence, error_report};
use crate::fit::{
    Estimate, FitData, FitProblem, FitResult, FrfPredictor, HbPredictor, ParameterSet, Prediction,
    Weighting,
};
use crate::model::Model;
use crate::testbench::TestDefinition;
use serde::Serialize;
use std::collections::BTreeMap;
use std::fmt::Write as _;
use std::path::PathBuf;

/// `run.json`.
#[derive(Serialize)]
pub struct RunSummary<'a> {
    /// `run`.
    pub command: &'static str,
    /// Tool version.
    pub version: &'static str,
    /// The virtual test.
    pub simulate: &'a SimulateSummary,
    /// The model the run reports: the diagnosis's when it ran, else the
    /// fit's; with the first fit as its "before".
    #[serde(rename = "final")]
    pub final_model: &'a FinalModel,
    /// The first fit (the "before").
    pub fit: &'a FitReport,
    /// The diagnosis, unless skipped.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub diagnosis: Option<DiagnosisSummary>,
    /// Wall time, s.
    pub seconds: f64,
    /// Files written.
    pub files: Vec<PathBuf>,
}

/// The diagnosis in `run.json` (fields in alphabetical order, the layout
/// readers of `run.json` rely on).
#[derive(Serialize)]
pub struct DiagnosisSummary {
    /// The baseline's relative error.
    pub baseline_error_relative: f64,
    /// The final model's `χ²` per degree of freedom.
    pub final_chi2_per_dof: f64,
    /// The final model's relative error.
    pub final_error_relative: f64,
    /// Wall time, s.
    pub seconds: f64,
    /// The effects added.
    pub selected: Vec<&'static str>,
}

impl DiagnosisSummary {
    /// The summary of `d`, diagnosed in `seconds`.
    pub fn of(d: &Diagnosis, seconds: f64) -> Self {
        DiagnosisSummary {
            baseline_error_relative: d.baseline.error_relative,
            final_chi2_per_dof: d.final_fit.chi2_per_dof,
            final_error_relative: d.final_fit.error_relative,
            seconds,
            selected: d.selected.iter().map(|s| s.effect.name()).collect(),
        }
    }
}

/// One parameter of the reported model.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Reported {
    /// The estimate with its 95 % interval.
    #[serde(flatten)]
    pub estimate: Estimate,
    /// Its SI unit, where known.
    #[serde(skip_serializing_if = "str::is_empty")]
    pub unit: &'static str,
    /// The value the data were simulated with, when known.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub reference: Option<f64>,
    /// What makes it less than a plain result (empty: nothing).
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub flags: Vec<Flag>,
}

/// The first fit, as the final model's "before".
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Before {
    /// The fitted law alone.
    pub model: Model,
    /// Its parameters.
    pub parameters: BTreeMap<String, f64>,
    /// Its error, on the final model's data.
    pub error: ErrorFigures,
}

/// The error figures of a model: one definition for fit, diagnosis and
/// report.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct ErrorFigures {
    /// `‖H1_meas − H1_model‖/‖H1_meas‖` over every point judged.
    pub relative: f64,
    /// The same per harmonic judged.
    pub per_harmonic: BTreeMap<usize, f64>,
    /// `χ²` per degree of freedom with the measured standard errors.
    pub chi2_per_dof: f64,
}

impl From<ErrorReport> for ErrorFigures {
    fn from(e: ErrorReport) -> Self {
        ErrorFigures {
            relative: e.relative,
            per_harmonic: e.per_harmonic,
            chi2_per_dof: e.chi2_per_dof,
        }
    }
}

/// Where the final model comes from.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum ModelSource {
    /// The fit (no diagnosis ran).
    Fit,
    /// The diagnosis: the fitted law, the effects it added, every parameter
    /// refitted.
    Diagnosis,
}

/// The model a run reports.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct FinalModel {
    /// Where it comes from.
    pub source: ModelSource,
    /// The joint law.
    pub joint: Option<&'static str>,
    /// The effects the diagnosis added (not one that replaced the joint).
    pub added_effects: Vec<&'static str>,
    /// The joint law the first fit assumed, when the diagnosis replaced it
    /// (by `joint`).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub replaced_joint: Option<&'static str>,
    /// The model.
    pub model: Model,
    /// The sign its `H` carry against the measured ones.
    pub response_sign: f64,
    /// Its parameters with 95 % intervals, references and flags.
    pub parameters: BTreeMap<String, Reported>,
    /// Its error.
    pub error: ErrorFigures,
    /// The harmonics the error's `χ²` judges.
    pub harmonics: Vec<usize>,
    /// The first fit, judged on the same data (absent when it is the final
    /// model itself).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub before: Option<Before>,
    /// The diagnosis's baseline (the first fit's law refitted with the
    /// measured standard errors on the harmonics judged), judged on the same
    /// data: the figure the diagnosis's text starts from.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub baseline: Option<ErrorFigures>,
}

impl FinalModel {
    /// The flagged parameters, by name.
    pub fn flagged(&self) -> impl Iterator<Item = (&String, &Reported)> {
        self.parameters.iter().filter(|(_, r)| !r.flags.is_empty())
    }

    /// The first fit as the final model: its parameters flagged and judged
    /// against the truth where known.
    fn of_fit(
        fit: &FitResult,
        fit_harmonics: &[usize],
        band_hz: Option<(f64, f64)>,
        judged: &Judged<'_>,
    ) -> FinalModel {
        let set = model_parameters(&fit.model, band_hz);
        let parameters = fit
            .parameters
            .iter()
            .map(|(name, e)| {
                let r = reported(name, e.clone(), &fit.model, &set, &fit.at_bound, judged);
                (name.clone(), r)
            })
            .collect();
        FinalModel {
            source: ModelSource::Fit,
            joint: fit.model.joint.as_ref().map(|j| j.kind().name()),
            added_effects: Vec::new(),
            replaced_joint: None,
            model: fit.model.clone(),
            response_sign: fit.response_sign,
            parameters,
            error: ErrorFigures {
                relative: fit.error.relative,
                per_harmonic: fit.error.per_harmonic.clone(),
                chi2_per_dof: fit.error.chi2_per_dof,
            },
            harmonics: fit_harmonics.to_vec(),
            before: None,
            baseline: None,
        }
    }

    /// The final model of a run: `diagnosis`'s when given (its joint and
    /// linear part with intervals at the final model, its effects as the
    /// diagnosis reported them), else `fit`'s. `truth` is the model the data
    /// were simulated with.
    pub fn of(
        frf: &NonlinearFrf,
        fit: &FitResult,
        fit_harmonics: &[usize],
        band_hz: Option<(f64, f64)>,
        diagnosis: Option<&Diagnosis>,
        truth: Option<&Model>,
        predictor: &HbPredictor,
    ) -> Result<FinalModel> {
        let reference = truth.map(reference_values).unwrap_or_default();
        let judged = Judged {
            truth: &reference,
            transfer: fit.transfer,
            drive: super::flags::force_drive(&fit.model, frf.reference),
        };
        let Some(d) = diagnosis else {
            return Ok(Self::of_fit(fit, fit_harmonics, band_hz, &judged));
        };
        let data =
            FitData::from_frf(frf, &d.harmonics, d.band_hz, None)?.with_sign(d.response_sign);
        let set = model_parameters(&d.model, data.band_hz());
        let pred = predictor.predict_from(&d.model, &data, d.final_prediction.as_ref())?;
        let error = error_report(&data, &pred, f64::NAN, set.len());
        let parameters = diagnosis_parameters(d, &data, &set, &pred, predictor, &judged)?;
        let replaces = |s: &&crate::diagnose::SelectedEffect| s.effect.candidate().replaces_joint();
        let before_pred = predictor.predict(&fit.model, &data)?;
        let before_set = model_parameters(&fit.model, data.band_hz());
        let before = Before {
            model: fit.model.clone(),
            parameters: fit
                .parameters
                .iter()
                .map(|(n, e)| (n.clone(), e.value))
                .collect(),
            error: error_report(&data, &before_pred, f64::NAN, before_set.len()).into(),
        };
        Ok(FinalModel {
            source: ModelSource::Diagnosis,
            joint: d.model.joint.as_ref().map(|j| j.kind().name()),
            added_effects: (d.selected.iter())
                .filter(|s| !replaces(s))
                .map(|s| s.effect.name())
                .collect(),
            replaced_joint: if d.selected.iter().any(|s| replaces(&s)) {
                fit.model.joint.as_ref().map(|j| j.kind().name())
            } else {
                None
            },
            model: d.model.clone(),
            response_sign: d.response_sign,
            parameters,
            error: error.into(),
            harmonics: d.harmonics.clone(),
            before: Some(before),
            baseline: Some(ErrorFigures {
                relative: d.baseline.error_relative,
                per_harmonic: d.baseline.error_relative_per_harmonic.clone(),
                chi2_per_dof: d.baseline.chi2_per_dof,
            }),
        })
    }

    /// The model in a few words: `masing joint + cubic_stiffness`.
    pub fn name(&self) -> String {
        let mut parts: Vec<String> = (self.joint.iter())
            .map(|j| match self.replaced_joint {
                Some(r) => format!("{j} joint (in place of the {r} joint)"),
                None => format!("{j} joint"),
            })
            .collect();
        parts.extend(self.added_effects.iter().map(|e| e.to_string()));
        if parts.is_empty() {
            "linear".into()
        } else {
            parts.join(" + ")
        }
    }

    /// The terminal's account of the final model: a heading line, one line
    /// per parameter, the error before and after.
    pub fn summary_lines(&self) -> Vec<String> {
        let mut out = vec![format!(
            "final model ({}): {}",
            match self.source {
                ModelSource::Diagnosis => "after the diagnosis",
                ModelSource::Fit => "the fit; no diagnosis",
            },
            self.name()
        )];
        for (name, r) in &self.parameters {
            let e = &r.estimate;
            let mut line = format!(
                "  {name:>28} = {:>12}  95 % [{}, {}] {}",
                fmt(e.value),
                fmt(e.ci95[0]),
                fmt(e.ci95[1]),
                if r.unit == "1" { "" } else { r.unit }
            );
            if let Some(v) = r.reference {
                let _ = write!(
                    line,
                    "  (simulated with {}: {})",
                    fmt(v),
                    relative(e.value, v)
                );
            }
            line.push_str(&flag_words(&r.flags));
            out.push(line);
        }
        match &self.before {
            Some(b) => out.push(format!(
                "  error in H1 (one definition, same points): first fit {} -> final {}; chi2/dof {:.3} -> {:.3} over H{:?}",
                percent(b.error.relative),
                percent(self.error.relative),
                b.error.chi2_per_dof,
                self.error.chi2_per_dof,
                self.harmonics
            )),
            None => out.push(format!(
                "  error in H1 {}; chi2/dof {:.3} over H{:?}",
                percent(self.error.relative),
                self.error.chi2_per_dof,
                self.harmonics
            )),
        }
        out
    }
}

/// Writes the final model's figures into `dir`: its FRF overlay on a fine
/// grid (`final_frf`, when it is not the first fit, whose `fit_frf` shows
/// it) and its joint's loops at the amplitudes the test reached (`loops`),
/// over `truth`'s joint when the data were simulated.
pub fn write_final_figures(
    dir: &std::path::Path,
    frf: &NonlinearFrf,
    f: &FinalModel,
    band_hz: Option<(f64, f64)>,
    truth: Option<&crate::model::ElementSpec>,
    predictor: &HbPredictor,
) -> Result<Vec<PathBuf>> {
    let mut files = Vec::new();
    if f.before.is_some() {
        files.extend(super::figures::write_frf_overlay(
            &dir.join("final_frf"),
            &format!(
                "Measured (markers) and the final model, {} (lines)",
                f.name()
            ),
            frf,
            band_hz,
            super::figures::Drawn {
                model: &f.model,
                response_sign: f.response_sign,
            },
            predictor,
        )?);
    }
    files.extend(super::identify::write_fit_loops(
        dir,
        frf,
        &f.model,
        f.response_sign,
        truth,
    )?);
    Ok(files)
}

/// The reported form of estimate `e` of parameter `name` of `model` (fitted
/// as `set` says, or at a bound of its fit by `fit_at_bound`), with its
/// reference and flags.
fn reported(
    name: &str,
    e: Estimate,
    model: &Model,
    set: &ParameterSet,
    fit_at_bound: &[String],
    judged: &Judged<'_>,
) -> Reported {
    // the one test of a bound (the fit's own, within 1 %)
    let at_bound = fit_at_bound.iter().any(|n| n == name)
        || set
            .parameters
            .iter()
            .find(|p| p.name == name)
            .is_some_and(|p| {
                ParameterSet {
                    parameters: vec![p.clone()],
                }
                .at_bounds(&[e.value])[0]
            });
    let domain = describe(name, model).1;
    let mut e = e;
    // as fit.json: `identifiable` and the flags say one thing
    e.identifiable = super::flags::determined(&e);
    let flags = flags_of(name, &e, at_bound, domain, judged.transfer);
    Reported {
        unit: parameter_unit(name, model, judged.drive),
        reference: judged.truth.get(name).copied(),
        flags,
        estimate: e,
    }
}

/// The final model's parameters: the joint's and the linear part's with
/// intervals at the final model (an added effect's own parameters left to
/// the effect; a further mode the diagnosis added told from the user's by
/// the mode it added), then each effect's as the diagnosis reported them.
fn diagnosis_parameters(
    d: &Diagnosis,
    data: &FitData,
    set: &ParameterSet,
    pred: &Prediction,
    predictor: &HbPredictor,
    judged: &Judged<'_>,
) -> Result<BTreeMap<String, Reported>> {
    let problem = FitProblem::new(
        d.model.clone(),
        set.clone(),
        data,
        predictor,
        Weighting::StandardError,
        None,
    )
    .with_warm_start(pred.clone());
    let theta = set.theta_of(&d.model)?;
    let conf = confidence(&problem, &theta, pred)?;
    let mut parameters = BTreeMap::new();
    // the joint and the linear part: intervals at the final model (an
    // added effect's own parameters are reported below; a further mode
    // the diagnosis added is told from the user's by the mode it added)
    let replaces = |s: &&crate::diagnose::SelectedEffect| s.effect.candidate().replaces_joint();
    for (p, e) in set.parameters.iter().zip(conf.estimates) {
        let own = d.selected.iter().filter(|s| !replaces(s)).any(|s| {
            s.effect
                .candidate()
                .own_parameter(s.effect.name(), &d.model, &p.name)
                .is_some()
        });
        if own {
            continue;
        }
        let r = reported(&p.name, e, &d.model, set, &[], judged);
        parameters.insert(p.name.clone(), r);
    }
    // the effects as the diagnosis reported them (a further mode by its
    // modal mass, say), so the numbers agree with `diagnosis.md`; a law
    // that replaced the joint is the joint above
    for s in d.selected.iter().filter(|s| !replaces(s)) {
        let label = s.effect.candidate().label(s.effect.name(), &d.model);
        for (name, e) in &s.parameters {
            let full = format!("{label}.{name}");
            let r = reported(&full, e.clone(), &d.model, set, &[], judged);
            parameters.insert(full, r);
        }
    }
    Ok(parameters)
}

/// What a reported parameter is judged against: the values the data were
/// simulated with (by name), whether the response is a transfer, and the
/// drive's quantity (the model's forces are in its unit).
struct Judged<'a> {
    truth: &'a BTreeMap<String, f64>,
    transfer: bool,
    drive: crate::harmonics::Quantity,
}

/// The parameters of `truth` by the names a fit gives them: the joint's and
/// effects' own, the first mode as `mass`, `damping`, `stiffness`, a further
/// mode's frequency, damping ratio, modal constant and modal mass.
pub fn reference_values(truth: &Model) -> BTreeMap<String, f64> {
    let set = model_parameters(truth, None);
    // read from the model, not through the fit's coordinates (a round trip
    // through a logarithm is not exact)
    let mut out: BTreeMap<String, f64> = set
        .parameters
        .iter()
        .filter_map(|p| Some((p.name.clone(), p.read(truth).ok()?)))
        .collect();
    let residues: Vec<(String, f64)> = out
        .iter()
        .filter_map(|(n, v)| {
            n.strip_suffix(".residue")
                .map(|m| (format!("{m}.modal_mass"), 1.0 / v))
        })
        .collect();
    out.extend(residues);
    out
}

/// Whether `def` tests the paper's system: the embedded default's
/// structure (linear part and joint, no effects), whatever the test plan.
pub fn is_papers_case(def: &TestDefinition) -> bool {
    match (def.model(), TestDefinition::embedded_default().model()) {
        (Ok(a), Ok(b)) => a == b,
        _ => false,
    }
}

fn fmt(v: f64) -> String {
    if !v.is_finite() {
        return if v > 0.0 {
            "∞".into()
        } else {
            "−∞".into()
        };
    }
    if v == 0.0 {
        return "0".into();
    }
    if v.abs() >= 1e4 || v.abs() < 1e-2 {
        format!("{v:.4e}")
    } else {
        format!("{v:.5}")
    }
}

/// A value as given in a test definition: `10`, `246.048`, `2.4e7`.
fn short(v: f64) -> String {
    if v != 0.0 && (v.abs() >= 1e5 || v.abs() < 1e-3) {
        format!("{v:e}")
    } else {
        format!("{v}")
    }
}

fn percent(x: f64) -> String {
    format!("{:.3} %", 100.0 * x)
}

fn relative(v: f64, reference: f64) -> String {
    if reference == 0.0 {
        "–".into()
    } else {
        format!("{:+.2} %", 100.0 * (v / reference - 1.0))
    }
}

/// The test that ran, in a sentence or two: the system, the joint and
/// effects it was simulated with, levels, frequencies, sweep, the noise
/// asked for and measured.
pub fn test_markdown(def: &TestDefinition, sim: &SimulateSummary) -> String {
    let mut s = String::new();
    let structure = match (&def.system, def.model()) {
        (Some(sys), _) => format!(
            "an SDOF, m = {} kg, c = {} N s/m, k = {} N/m",
            short(sys.mass),
            short(sys.damping),
            short(sys.stiffness)
        ),
        (None, Ok(m)) => {
            let modes: Vec<String> = m
                .linear
                .modes
                .iter()
                .map(|q| {
                    format!(
                        "{} Hz (ζ = {}, modal mass {} kg)",
                        q.frequency_hz,
                        q.damping_ratio,
                        short(1.0 / q.residue)
                    )
                })
                .collect();
            format!("modes at {}", modes.join(", "))
        }
        (None, Err(_)) => "(a structure that does not build)".into(),
    };
    let laws = |model: &Model| -> String {
        let mut parts = Vec::new();
        for (at, e) in model.placed_all() {
            let params: Vec<String> = e
                .parameters()
                .iter()
                .map(|(n, v)| format!("{n} = {}", short(*v)))
                .collect();
            let place = match at {
                crate::model::ElementAt::Joint => "joint".to_string(),
                crate::model::ElementAt::Effect(_) => "effect".to_string(),
                crate::model::ElementAt::ModeJoint(i) => format!(
                    "mode {} Hz's own joint",
                    short(model.linear.modes[i].frequency_hz)
                ),
            };
            parts.push(format!(
                "{place} `{}` ({})",
                e.kind().name(),
                params.join(", ")
            ));
        }
        if parts.is_empty() {
            "no joint".into()
        } else {
            parts.join(", ")
        }
    };
    let elements = def.model().map(|m| laws(&m)).unwrap_or_default();
    let freqs = def.frequencies().unwrap_or_default();
    let (lo, hi) = freqs
        .iter()
        .fold((f64::INFINITY, 0.0f64), |(a, b), &f| (a.min(f), b.max(f)));
    let levels: Vec<String> = def.test.levels_n.iter().map(|l| format!("{l}")).collect();
    // a shaker is driven in volts; a gauge's force is then the reference
    let drive = def.model().map_or(crate::harmonics::Quantity::Force, |m| {
        crate::testbench::reference_quantity(&m)
    });
    let gauge = if def.test.force_gauge {
        format!(
            ", the shaker's force recorded by a force gauge ({} % noise) and the FRFs taken against it",
            100.0 * def.test.force_noise
        )
    } else {
        String::new()
    };
    let _ = writeln!(
        s,
        "Virtual stepped-sine test of {structure} with {elements}: {} levels ({} {}) × {} frequencies {lo}–{hi} Hz ({} sweep){gauge}, {} Hz sampling, {} % response noise asked, {:.1} % response noise (measured, RMS); {} frames in {:.2} s.\n",
        def.test.levels_n.len(),
        levels.join(", "),
        drive.si_unit(),
        freqs.len(),
        format!("{:?}", def.test.sweep).to_lowercase(),
        sim.sample_rate_hz,
        100.0 * def.test.noise,
        100.0 * sim.mean_noise_ratio,
        sim.frames,
        sim.seconds,
    );
    s
}

/// The shaker's coil found from the voltage, the gauge's force and the
/// motion, against the shaker simulated (its coil, when its gain is
/// physical).
pub fn coil_markdown(c: &crate::fit::coil::CoilFit, def: &TestDefinition) -> String {
    let simulated = def
        .model()
        .ok()
        .and_then(|m| m.laws().find_map(crate::model::ElementSpec::drive_load))
        .map(|d| {
            let s = crate::model::Shaker::with_gain(d.back_emf, d.time_constant, d.gain);
            s.coil()
        });
    let against = |got: f64, unit: &str, truth: Option<f64>| match truth {
        Some(t) => format!(
            "{} {unit} ({} against the simulated {})",
            fmt(got),
            relative(got, t),
            short(t)
        ),
        None => format!("{} {unit}", fmt(got)),
    };
    format!(
        "The shaker's coil, from the voltage `{}`, the force `{}` and the motion `{}` at {} dwells (`coil` in fit.json): R = {}, L = {}, Bl = {}; the dwells' equations fit to {} of the force.\n\n",
        c.channels[0],
        c.channels[1],
        c.channels[2],
        c.dwells,
        against(c.r, "ohm", simulated.map(|s| s.0)),
        against(c.l, "H", simulated.map(|s| s.1)),
        against(c.bl, "N/A", simulated.map(|s| s.2)),
        percent(c.residual),
    )
}

/// The final model as a section of `report.md`: the parameters with their
/// intervals, references and flags; the error before and after.
pub fn final_markdown(f: &FinalModel) -> String {
    let mut s = String::new();
    let _ = writeln!(s, "## The model: {}\n", f.name());
    let _ = writeln!(s, "{}\n", final_origin(f));
    final_parameter_table(&mut s, f);
    final_flag_notes(&mut s, f);
    final_error_table(&mut s, f);
    s
}

/// Where the final model comes from: the fit, or what the diagnosis changed.
fn final_origin(f: &FinalModel) -> String {
    match (f.source, f.added_effects.is_empty(), f.replaced_joint) {
        (ModelSource::Fit, _, _) => "The fitted model (the diagnosis did not run).".to_string(),
        (ModelSource::Diagnosis, true, None) => "The model after the diagnosis, which added no effect: the fitted law, every parameter refitted with the measured standard errors on the harmonics judged.".to_string(),
        (ModelSource::Diagnosis, _, replaced) => {
            let mut changes: Vec<String> = replaced
                .map(|r| format!("replaced the joint law {r} by {}", f.joint.unwrap_or("another")))
                .into_iter()
                .collect();
            if !f.added_effects.is_empty() {
                changes.push(format!("added {}", f.added_effects.join(" and ")));
            }
            format!(
                "The model after the diagnosis, which {}: every parameter refitted with the measured standard errors on the harmonics judged. The first fit (the joint alone) is the \"before\" below.",
                changes.join(" and ")
            )
        }
    }
}

/// The parameters with their 95 % intervals, the simulated values when the
/// model is known, and their flags.
fn final_parameter_table(s: &mut String, f: &FinalModel) {
    let has_reference = f.parameters.values().any(|r| r.reference.is_some());
    let _ = writeln!(
        s,
        "| parameter | value | 95 % interval |{} flags |",
        if has_reference {
            " simulated with |"
        } else {
            ""
        }
    );
    let _ = writeln!(
        s,
        "|---|---|---|{}---|",
        if has_reference { "---|" } else { "" }
    );
    for (name, r) in &f.parameters {
        let e = &r.estimate;
        let unit = if r.unit.is_empty() || r.unit == "1" {
            String::new()
        } else {
            format!(" {}", r.unit)
        };
        let reference = if has_reference {
            match r.reference {
                Some(v) => format!(" {} ({}) |", fmt(v), relative(e.value, v)),
                None => " |".into(),
            }
        } else {
            String::new()
        };
        let flags: Vec<&str> = r.flags.iter().map(|f| f.words()).collect();
        let _ = writeln!(
            s,
            "| {name} | {}{unit} | [{}, {}] |{reference} {} |",
            fmt(e.value),
            fmt(e.ci95[0]),
            fmt(e.ci95[1]),
            if flags.is_empty() {
                String::new()
            } else {
                format!("**{}**", flags.join("; "))
            }
        );
    }
}

/// What each flagged parameter's flags mean.
fn final_flag_notes(s: &mut String, f: &FinalModel) {
    let flagged: Vec<String> = f
        .flagged()
        .map(|(n, r)| {
            let words: Vec<&str> = r.flags.iter().map(|f| f.words()).collect();
            let note = r
                .estimate
                .note
                .as_deref()
                .map(|n| format!(" ({n})"))
                .unwrap_or_default();
            format!("- **{n}**: {}{note}.", words.join("; "))
        })
        .collect();
    if !flagged.is_empty() {
        let _ = writeln!(
            s,
            "\nNot plain results: their values are not measurements of the structure.\n\n{}",
            flagged.join("\n")
        );
    }
}

/// The error of the first fit, the diagnosis's baseline and the final
/// model.
fn final_error_table(s: &mut String, f: &FinalModel) {
    let _ = writeln!(
        s,
        "\nError (one definition for fit, diagnosis and this report): the relative error of the fundamental, ‖H1_meas − H1_model‖/‖H1_meas‖ over every measured point, and χ² per degree of freedom with the measured standard errors over harmonics {:?}.\n",
        f.harmonics
    );
    let _ = writeln!(s, "| model | error H1 | χ²/dof |\n|---|---|---|");
    if let Some(b) = &f.before {
        let joint = b.model.joint.as_ref().map_or("no joint".to_string(), |j| {
            format!("{} joint alone", j.kind().name())
        });
        let _ = writeln!(
            s,
            "| before: the first fit ({joint}) | {} | {:.3} |",
            percent(b.error.relative),
            b.error.chi2_per_dof
        );
    }
    if let Some(b) = &f.baseline {
        let _ = writeln!(
            s,
            "| the diagnosis's baseline: the first fit's law refitted with the measured standard errors | {} | {:.3} |",
            percent(b.relative),
            b.chi2_per_dof
        );
    }
    let _ = writeln!(
        s,
        "| **final: {}** | **{}** | **{:.3}** |\n",
        f.name(),
        percent(f.error.relative),
        f.error.chi2_per_dof
    );
}

/// `report.md`: the test that ran, the final model (with the first fit
/// as "before"), the paper's Table 3.1 for the paper's case, the fit's and
/// the diagnosis's accounts, the figures.
pub fn report_markdown(
    def: &TestDefinition,
    sim: &SimulateSummary,
    report: &FitReport,
    final_model: &FinalModel,
    diagnosis: Option<(&Diagnosis, f64)>,
) -> String {
    let fit = &report.fit;
    let mut s = String::new();
    let _ = writeln!(
        s,
        "# hystid run: a friction joint identified from a virtual stepped-sine test\n"
    );
    s += &test_markdown(def, sim);
    if let Some(c) = &report.coil {
        s += &coil_markdown(c, def);
    }
    s += &final_markdown(final_model);
    if is_papers_case(def) {
        s += &paper_table(report, final_model);
    }
    let _ = writeln!(s, "## The first fit\n");
    let _ = writeln!(
        s,
        "The `{}` element fitted by harmonic balance and Nelder–Mead on eq. (9) (the fundamental, unweighted), {} evaluations in {:.2} s: error H1 {} (χ²/dof {:.3} over the fitted harmonics {:?}). \
         Linear system from the largest level: m = {:.5} kg, c = {:.4} N s/m, k = {:.6e} N/m; after the fit: \
         m = {:.5} kg, c = {:.4} N s/m, k = {:.6e} N/m. Stick stiffness from the smallest level k_low = {:.6e} N/m, \
         initial kd = k_low − k = {:.4e} N/m.\n",
        fit.element.name(),
        fit.effort.evaluations,
        fit.effort.seconds,
        percent(fit.error.relative),
        fit.error.chi2_per_dof,
        fit.error.per_harmonic.keys().collect::<Vec<_>>(),
        fit.linear.underlying.mass,
        fit.linear.underlying.damping,
        fit.linear.underlying.stiffness,
        fit.linear.mass,
        fit.linear.damping,
        fit.linear.stiffness,
        fit.linear.stick.stiffness,
        fit.linear.kd_initial
    );
    for (name, e) in &fit.parameters {
        if let Some(n) = &e.note {
            let _ = writeln!(s, "On {name}: {n}.\n");
        }
    }
    for note in &fit.notes {
        let _ = writeln!(s, "Note: {note}\n");
    }
    if let Some((d, seconds)) = diagnosis {
        let _ = writeln!(
            s,
            "## Diagnosis: what the first fit lacked\n\n{}\n\n(its baseline is the first fit's law refitted with the measured standard errors on harmonics {:?}; all candidates refitted in {seconds:.1} s; every candidate in `diagnosis.md`)\n\n![residual before and after](residual.png)\n",
            d.explanation, d.harmonics
        );
    }
    let _ = writeln!(s, "## Figures\n");
    let _ = writeln!(s, "Measured nonlinear FRFs:\n\n![FRFs](frf.png)\n");
    if final_model.before.is_some() {
        let _ = writeln!(
            s,
            "Measured (markers) against the final model (lines, on a fine frequency grid):\n\n![final model](final_frf.png)\n"
        );
        let _ = writeln!(
            s,
            "Measured against the first fit (before the diagnosis):\n\n![first fit](fit_frf.png)\n"
        );
    } else {
        let _ = writeln!(
            s,
            "Measured (markers) against the fitted model (lines, on a fine frequency grid):\n\n![fit](fit_frf.png)\n"
        );
    }
    let _ = writeln!(
        s,
        "The final model's joint loops at the largest amplitude each level reached, over the simulated joint's:\n\n![loops](loops.png)\n"
    );
    let _ = writeln!(
        s,
        "The first fit's cost at each evaluation:\n\n![convergence](convergence.png)\n"
    );
    s
}

/// The paper's Table 3.1 beside this run's joint (before and after the
/// diagnosis), for the paper's case only.
fn paper_table(report: &FitReport, f: &FinalModel) -> String {
    let mut s = String::new();
    let _ = writeln!(s, "## Table 3.1, the paper and this run\n");
    let _ = writeln!(s, "| | Fd [N] | kd [N/m] | N |");
    let _ = writeln!(s, "|---|---|---|---|");
    let _ = writeln!(s, "| Reference parameters (paper) | 246.048 | 2.4e7 | |");
    let _ = writeln!(
        s,
        "| Estimated parameters (paper) | 242.05 (−1.6 %) | 2.33e7 (−2.9 %) | 22.55 |"
    );
    let cell = |name: &str| -> String {
        match f.parameters.get(name) {
            None => "–".into(),
            Some(r) => {
                let e = &r.estimate;
                let mut c = format!("{} [{}, {}]", fmt(e.value), fmt(e.ci95[0]), fmt(e.ci95[1]));
                if let Some(v) = r.reference {
                    let _ = write!(c, " ({})", relative(e.value, v));
                }
                if !r.flags.is_empty() {
                    let words: Vec<&str> = r.flags.iter().map(|f| f.words()).collect();
                    let _ = write!(c, ", {}", words.join("; "));
                }
                c
            }
        }
    };
    let first = |name: &str| -> String {
        report
            .fit
            .parameters
            .get(name)
            .map_or("–".into(), |e| fmt(e.value))
    };
    if f.before.is_some() {
        let _ = writeln!(
            s,
            "| hystid, first fit | {} | {} | {} |",
            first("fd"),
            first("kd"),
            first("n")
        );
    }
    let _ = writeln!(
        s,
        "| **hystid, {}**, 95 % interval | {} | {} | {} |\n",
        if f.before.is_some() {
            "final model"
        } else {
            "fit"
        },
        cell("fd"),
        cell("kd"),
        cell("n")
    );
    let _ = writeln!(
        s,
        "The paper's N = 22.55 most likely lies on a flat valley: eq. (10) tends to a Jenkins element (the simulated joint) as N → ∞ and the cost hardly changes once N is large, so bias and noise in a simulated measurement can settle the optimum at a finite N.\n"
    );
    s
}
