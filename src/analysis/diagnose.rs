//! A fit's residual traced to a missing effect, added and refitted
//! ([`crate::diagnose`]), and its files: `diagnosis.json`, `diagnosis.md`
//! and the residual figures.

use super::write_json;
use crate::diagnose::{DiagnoseOptions, Diagnosis, Verdict, diagnose_observed};
use crate::error::Result;
use crate::extract::NonlinearFrf;
use crate::fit::time::{RecordError, TimeProblem, time_parameters};
use crate::fit::{
    FitData, FitResult, FrfPredictor, HbPredictor, TimeFitOptions, TimeFitResult, TimeRecord,
    identify_time,
};
use crate::observe::Observer;
use crate::plot::{self, FrfSeries, NoiseLevel, ResidualPanel, ResidualSeries, SeriesStyle};
use serde::Serialize;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

/// Diagnoses `fit` of `frf`, telling `observer` of the progress; returns the
/// diagnosis with the predictor it used (for the figures).
pub fn run_diagnosis(
    frf: &NonlinearFrf,
    fit: &FitResult,
    options: &DiagnoseOptions,
    observer: &dyn Observer,
) -> Result<(Diagnosis, HbPredictor)> {
    let predictor = HbPredictor::default();
    let d = diagnose_observed(frf, fit, options, &predictor, observer)?;
    Ok((d, predictor))
}

/// The diagnosis's final model refined in the time domain on the
/// recordings themselves (`diagnose --domain time`).
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct TimeRefinement {
    /// The baseline model's error on each recording (the joint alone, as
    /// the FRF fit left it).
    pub baseline: Vec<RecordError>,
    /// The final model refitted in the time domain (`before`: the FRF
    /// diagnosis's final model).
    pub refit: TimeFitResult,
}

/// What `diagnose --domain time` got: the refinement, or why there is
/// none (the FRF diagnosis stands either way).
#[derive(Clone, Debug, PartialEq, Serialize)]
#[serde(untagged)]
pub enum TimeOutcome {
    /// The final model refitted.
    Refined(Box<TimeRefinement>),
    /// The recordings could not be replayed or the refit failed.
    Failed {
        /// Why.
        failed: String,
    },
}

/// Refines `d`'s final model in the time domain on `records`: every
/// parameter free (the linear part's as the diagnosis saw `band_hz`),
/// started from the diagnosis. The effects stay those the FRF diagnosis
/// selected; what the replay adds is the history the harmonic balance does
/// not carry (where a joint settles under a static load) and no steady-state
/// assumption.
pub fn refine_in_time(
    d: &Diagnosis,
    records: &[TimeRecord],
    options: &TimeFitOptions,
    band_hz: Option<(f64, f64)>,
    observer: &dyn Observer,
) -> Result<TimeRefinement> {
    let params = time_parameters(&d.model, options.refine_linear, band_hz);
    let refit = identify_time(
        &d.model,
        params.clone(),
        d.response_sign,
        records,
        options,
        Some(observer),
    )?;
    let baseline = TimeProblem::new(
        d.baseline_model.clone(),
        params,
        records,
        d.response_sign,
        options.clone(),
        None,
    )?
    .errors(&d.baseline_model)?;
    Ok(TimeRefinement { baseline, refit })
}

/// `diagnosis.json`: the diagnosis with the command and its wall time.
#[derive(Serialize)]
pub struct DiagnosisReport<'a> {
    /// `diagnose`.
    pub command: &'static str,
    /// Tool version.
    pub version: &'static str,
    /// Wall time, s.
    pub seconds: f64,
    /// The diagnosis.
    #[serde(flatten)]
    pub diagnosis: &'a Diagnosis,
    /// Its final model refitted in the time domain (`--domain time`).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub time_domain: Option<&'a TimeOutcome>,
    /// The final model as reported: every parameter with its interval and
    /// flags, the first fit as the "before" (`diagnose`; `run` puts it in
    /// `run.json`).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub final_model: Option<&'a super::run::FinalModel>,
}

impl<'a> DiagnosisReport<'a> {
    /// The report of `d`, made in `seconds`.
    pub fn new(d: &'a Diagnosis, seconds: f64) -> Self {
        DiagnosisReport {
            command: "diagnose",
            version: super::VERSION,
            seconds,
            diagnosis: d,
            time_domain: None,
            final_model: None,
        }
    }
}

/// Writes `diagnosis.json`, `diagnosis.md` and the residual plots.
pub fn write_diagnosis(
    dir: &Path,
    frf: &NonlinearFrf,
    d: &Diagnosis,
    predictor: &HbPredictor,
    seconds: f64,
) -> Result<Vec<PathBuf>> {
    write_diagnosis_with(dir, frf, d, predictor, seconds, None, None)
}

/// [`write_diagnosis`], with the time-domain refinement when there is one
/// (`time_domain` in `diagnosis.json`, a section in `diagnosis.md`) and the
/// final model as reported, with its flags (`final_model`, and a section
/// after the explanation).
pub fn write_diagnosis_with(
    dir: &Path,
    frf: &NonlinearFrf,
    d: &Diagnosis,
    predictor: &HbPredictor,
    seconds: f64,
    time: Option<&TimeOutcome>,
    final_model: Option<&super::run::FinalModel>,
) -> Result<Vec<PathBuf>> {
    let mut files = vec![dir.join("diagnosis.json"), dir.join("diagnosis.md")];
    write_json(
        &files[0],
        &DiagnosisReport {
            time_domain: time,
            final_model,
            ..DiagnosisReport::new(d, seconds)
        },
    )?;
    files.extend(residual_plots(dir, frf, d, predictor)?);
    let mut md = markdown(d, seconds);
    if let Some(f) = final_model {
        md += "\n";
        md += &super::run::final_markdown(f);
    }
    match time {
        Some(TimeOutcome::Refined(t)) => md += &time_markdown(t),
        Some(TimeOutcome::Failed { failed }) => {
            md += &format!("\n## In the time domain\n\nNo refit: {failed}\n")
        }
        None => {}
    }
    crate::atomic::write_bytes(&files[1], md.as_bytes())?;
    Ok(files)
}

/// The time-domain refinement as a section of `diagnosis.md`.
pub fn time_markdown(t: &TimeRefinement) -> String {
    let mut s = String::new();
    let _ = writeln!(
        s,
        "\n## In the time domain\n\nThe final model refitted on the recorded time histories \
         ({} samples, {:?}): each dwell's relative e_RMS, root mean square over the dwells.\n",
        t.refit.samples, t.refit.status
    );
    let _ = writeln!(
        s,
        "| recording | baseline (joint alone) | final, as the FRF diagnosis fitted it | final, refitted in time |"
    );
    let _ = writeln!(s, "|---|---|---|---|");
    for ((b, f), a) in t.baseline.iter().zip(&t.refit.before).zip(&t.refit.after) {
        let _ = writeln!(
            s,
            "| {} | {:.2} % | {:.2} % | {:.2} % |",
            a.recording,
            100.0 * b.segment_relative,
            100.0 * f.segment_relative,
            100.0 * a.segment_relative
        );
    }
    let _ = writeln!(s, "\n| parameter | value | 95 % interval |\n|---|---|---|");
    for (name, e) in &t.refit.parameters {
        let _ = writeln!(
            s,
            "| {name} | {:.6e} | [{:.4e}, {:.4e}]{} |",
            e.value,
            e.ci95[0],
            e.ci95[1],
            if e.identifiable {
                ""
            } else {
                " (not identifiable)"
            }
        );
    }
    for n in &t.refit.notes {
        let _ = writeln!(s, "\nNote: {n}");
    }
    s
}

/// |H1_meas − H1_model|/σ per level, before and after, and the FRF overlay
/// of the final model.
pub fn residual_plots(
    dir: &Path,
    frf: &NonlinearFrf,
    d: &Diagnosis,
    predictor: &HbPredictor,
) -> Result<Vec<PathBuf>> {
    let data = FitData::from_frf(frf, &[1], d.band_hz, None)?.with_sign(d.response_sign);
    let before = predictor.predict(&d.baseline_model, &data)?;
    let after = predictor.predict(&d.model, &data)?;
    let panel = |pred: &crate::fit::Prediction, heading: &str| -> ResidualPanel {
        let series = data
            .series
            .iter()
            .zip(&pred.h)
            .enumerate()
            .map(|(g, (s, ps))| ResidualSeries {
                label: crate::plot::level_label(s.level, frf.reference.si_unit()),
                group: g,
                frequency_hz: s.points.iter().map(|p| p.frequency_hz).collect(),
                residual: s
                    .points
                    .iter()
                    .zip(ps)
                    .map(|(p, m)| {
                        m.as_ref().map_or(f64::NAN, |m| {
                            (p.h[0] - m[0]).norm() / p.std_error[0].max(f64::MIN_POSITIVE)
                        })
                    })
                    .collect(),
            })
            .collect();
        ResidualPanel {
            heading: heading.to_string(),
            series,
        }
    };
    let mut files = plot::write_residual_plot(
        &dir.join("residual"),
        "H1 residual / measured standard error, before and after",
        "|H1 meas − H1 model| / σ",
        &[
            panel(
                &before,
                &format!("baseline: error {:.2} %", 100.0 * d.baseline.error_relative),
            ),
            panel(
                &after,
                &format!(
                    "with {}: error {:.2} %",
                    effects_label(d),
                    100.0 * d.final_fit.error_relative
                ),
            ),
        ],
        Some(&NoiseLevel {
            value: 2.0,
            label: "2σ".into(),
        }),
    )?;
    let mut series = Vec::new();
    for (g, (s, ps)) in data.series.iter().zip(&after.h).enumerate() {
        let f: Vec<f64> = s.points.iter().map(|p| p.frequency_hz).collect();
        series.push(FrfSeries {
            label: crate::plot::level_label(s.level, frf.reference.si_unit()),
            group: g,
            frequency_hz: f.clone(),
            h: s.points.iter().map(|p| p.h[0] * d.response_sign).collect(),
            std_error: None,
            style: SeriesStyle::Measured,
        });
        series.push(FrfSeries {
            label: format!(
                "{} (model)",
                crate::plot::level_label(s.level, frf.reference.si_unit())
            ),
            group: g,
            frequency_hz: f,
            h: ps
                .iter()
                .map(|m| {
                    m.as_ref()
                        .map_or(num_complex::Complex64::new(f64::NAN, f64::NAN), |m| {
                            m[0] * d.response_sign
                        })
                })
                .collect(),
            std_error: None,
            style: SeriesStyle::Model,
        });
    }
    files.extend(plot::write_frf_plot(
        &dir.join("diagnosis_frf"),
        &format!("Measured and the diagnosed model ({})", effects_label(d)),
        &plot::frf_magnitude_label(frf, 1),
        &series,
    )?);
    Ok(files)
}

/// The added effects, `a + b`, or `no added effect`.
pub fn effects_label(d: &Diagnosis) -> String {
    if d.selected.is_empty() {
        "no added effect".into()
    } else {
        d.selected
            .iter()
            .map(|s| s.effect.name())
            .collect::<Vec<_>>()
            .join(" + ")
    }
}

/// `diagnosis.md`: the candidates, what was kept and why.
pub fn markdown(d: &Diagnosis, seconds: f64) -> String {
    let mut s = String::new();
    let _ = writeln!(s, "# Diagnosis: what the fitted joint model lacks\n");
    let _ = writeln!(s, "{}\n", d.explanation);
    let _ = writeln!(
        s,
        "| candidate | round | feature rank | Δχ² | threshold (BIC) | kept | error H1 | χ²/dof | parameters |"
    );
    let _ = writeln!(s, "|---|---|---|---|---|---|---|---|---|");
    for c in &d.candidates {
        let p: Vec<String> = c
            .effect_parameters
            .iter()
            .map(|(n, v)| format!("{n} = {v:.4e}"))
            .collect();
        let _ = writeln!(
            s,
            "| {} | {} | {} | {:.1} | {:.1} | {} | {:.3} % | {:.3} | {} |",
            c.effect.name(),
            c.round,
            c.rank,
            c.delta_chi2,
            c.threshold,
            match c.verdict {
                Verdict::Kept => "**yes**",
                Verdict::DroppedLater => "no: dropped later",
                Verdict::SizeNotResolved => "no: size not resolved",
                Verdict::AnotherDidBetter => "no: another did better",
                Verdict::BelowCriterion => "no",
                Verdict::NotConfirmedInTime => "no: not confirmed in the time domain",
            },
            100.0 * c.fit.error_relative,
            c.fit.chi2_per_dof,
            p.join(", ")
        );
    }
    for f in &d.failed {
        let _ = writeln!(
            s,
            "| {} | {} | | | | failed | | | {} |",
            f.effect.name(),
            f.round,
            f.reason.replace('|', "/")
        );
    }
    let notes: Vec<String> = d
        .candidates
        .iter()
        .filter_map(|c| {
            c.note
                .as_ref()
                .map(|n| format!("- {} (round {}): {n}", c.effect.name(), c.round))
        })
        .collect();
    if !notes.is_empty() {
        let _ = writeln!(s, "\nWhy a candidate was not kept:\n\n{}", notes.join("\n"));
    }
    let _ = writeln!(
        s,
        "\nBaseline error {:.3} % → final {:.3} % (H1); χ²/dof {:.3} → {:.3} ({}). Harmonics judged: {:?}. {:.1} s.\n",
        100.0 * d.baseline.error_relative,
        100.0 * d.final_fit.error_relative,
        d.baseline.chi2_per_dof,
        d.final_fit.chi2_per_dof,
        if d.consistent_with_noise {
            "consistent with the noise"
        } else {
            "above the noise"
        },
        d.harmonics,
        seconds
    );
    let _ = writeln!(
        s,
        "![residual before and after](residual.png)\n\n![the diagnosed model](diagnosis_frf.png)"
    );
    s
}
