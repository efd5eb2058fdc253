//! `hystid validate`: a fitted model driven by recordings' measured force,
//! its simulated response compared with the measured one (e_RMS, `H1`).

use super::args::ValidateArgs;
use super::identify::{Excitation, excitation_of, load_recording, sweep_options};
use super::{EXIT_OK, create_out_dir, write_json};
use anyhow::{Context, Result, bail};
use hystid::extract::ReduceOptions;
use hystid::fit::SdofEstimate;
use hystid::model::{ModalModel, Model};
use hystid::plot::{self, FrfSeries, SeriesStyle, TimeSignal};
use hystid::validate::{Reduction, ValidateOptions, Validation, validate_recording};
use num_complex::Complex64;
use serde::Serialize;
use std::path::{Path, PathBuf};

/// The model to validate, from a fit.json.
pub struct FitModel {
    /// The model.
    pub model: Model,
    /// The model predicts `sign × H_measured`.
    pub response_sign: f64,
    /// The response channel the fit used, if recorded.
    pub response: Option<String>,
    /// `fitted` or `linear`.
    pub kind: &'static str,
}

/// Reads the model of a fit.json: its `model` (or, with `linear`, the SDOF
/// of `linear.stick` with no element) and `response_sign`.
pub fn read_fit(path: &Path, linear: bool) -> Result<FitModel> {
    let text = std::fs::read_to_string(path)
        .with_context(|| format!("cannot read the fit {}", path.display()))?;
    let v: serde_json::Value = serde_json::from_str(&text)
        .with_context(|| format!("{}: not valid JSON", path.display()))?;
    let response = v.get("response").and_then(|r| r.as_str()).map(String::from);
    let sign = match v.get("response_sign") {
        None => 1.0,
        Some(s) => s
            .as_f64()
            .filter(|s| *s == 1.0 || *s == -1.0)
            .with_context(|| format!("{}: `response_sign` must be 1 or -1", path.display()))?,
    };
    if linear {
        let stick = v
            .get("linear")
            .and_then(|l| l.get("stick"))
            .with_context(|| format!("{}: no `linear.stick` for --linear", path.display()))?;
        let s: SdofEstimate = serde_json::from_value(stick.clone())
            .with_context(|| format!("{}: `linear.stick`", path.display()))?;
        let model = Model::new(
            ModalModel::sdof(s.mass, s.damping, s.stiffness)?,
            Vec::new(),
        )
        .with_context(|| format!("{}: `linear.stick`", path.display()))?;
        return Ok(FitModel {
            model,
            response_sign: s.sign,
            response,
            kind: "linear",
        });
    }
    let m = v
        .get("model")
        .with_context(|| format!("{}: no `model` field", path.display()))?;
    let model: Model = serde_json::from_value(m.clone())
        .with_context(|| format!("{}: `model`", path.display()))?;
    model
        .validate()
        .with_context(|| format!("{}: `model`", path.display()))?;
    Ok(FitModel {
        model,
        response_sign: sign,
        response,
        kind: "fitted",
    })
}

fn parse_range(text: &str, flag: &str, unit: &str) -> Result<(f64, f64)> {
    let (a, b) = text
        .split_once(':')
        .with_context(|| format!("{flag}: expected LO:HI in {unit}, got `{text}`"))?;
    let p = |x: &str| -> Result<f64> {
        x.trim()
            .parse()
            .with_context(|| format!("{flag}: `{x}` is not a number"))
    };
    let (a, b) = (p(a)?, p(b)?);
    if !(a.is_finite() && b.is_finite() && 0.0 <= a && a < b) {
        bail!("{flag}: need 0 <= LO < HI, got {a}:{b}");
    }
    Ok((a, b))
}

/// One recording's entry in validate.json.
#[derive(Serialize)]
pub struct RecordingValidation {
    /// The recording.
    pub recording: String,
    /// The response channel.
    pub response: String,
    /// The figures.
    #[serde(flatten)]
    pub validation: Validation,
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
    /// Per recording.
    pub recordings: Vec<RecordingValidation>,
    /// Files written.
    pub files: Vec<PathBuf>,
}

fn stem_of(path: &Path, used: &mut Vec<String>) -> String {
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

/// `hystid validate`.
pub fn validate_command(args: &ValidateArgs, quiet: bool) -> Result<u8> {
    let fit = read_fit(&args.fit, args.linear)?;
    let band = args
        .band
        .as_deref()
        .map(|b| parse_range(b, "--band", "Hz"))
        .transpose()?;
    let window = args
        .window
        .as_deref()
        .map(|w| parse_range(w, "--window", "s"))
        .transpose()?;
    create_out_dir(&args.out)?;
    let mut entries = Vec::new();
    let mut files = vec![args.out.join("validate.json")];
    let mut used = Vec::new();
    if !quiet {
        say!(
            "{} model: highest linearised frequency {:.4} Hz, response sign {:+}",
            fit.kind,
            fit.model.highest_linearised_frequency_hz(),
            fit.response_sign
        );
    }
    for path in &args.recordings {
        let response = args.response.as_deref().or(fit.response.as_deref());
        let loaded = load_recording(path, response)?;
        let rec = &loaded.recording;
        let reference = rec.reference_channel().context("no reference channel")?;
        let excitation = excitation_of(&rec.meta, args.reduction.excitation);
        let reduction = if args.no_frf {
            None
        } else {
            Some(match excitation {
                Excitation::Stepped => Reduction::Stepped(ReduceOptions {
                    max_harmonic: args.reduction.max_harmonic.unwrap_or(7),
                    blocks: 16,
                    ..ReduceOptions::default()
                }),
                Excitation::Swept => Reduction::Swept(sweep_options(
                    &rec.channels[reference],
                    &rec.channels[loaded.response],
                    rec.meta.sample_rate_hz,
                    &args.reduction,
                )?),
            })
        };
        let opts = ValidateOptions {
            min_samples_per_period: args.min_samples_per_period,
            window_s: window,
            band_hz: band,
            reduction,
        };
        let v = validate_recording(&fit.model, fit.response_sign, rec, loaded.response, &opts)
            .with_context(|| format!("validating on {}", path.display()))?;
        let stem = stem_of(path, &mut used);
        let name = path.file_name().map_or_else(
            || path.display().to_string(),
            |n| n.to_string_lossy().into_owned(),
        );
        let channel = &rec.meta.channels[loaded.response];
        let y_label = format!("{} [{}]", channel.name, channel.unit.replace("^2", "²"));
        let fs = rec.meta.sample_rate_hz;
        let measured = &rec.channels[loaded.response];
        let signal = |label: &str, values: &[f64], start: usize| TimeSignal {
            label: label.into(),
            start_s: start as f64 / fs,
            sample_rate_hz: fs,
            values: values.to_vec(),
        };
        files.extend(plot::write_time_overlay(
            &args.out.join(format!("{stem}_time")),
            &format!(
                "{name}: measured and simulated ({} model), e_RMS {:.4e}",
                fit.kind, v.whole.e_rms
            ),
            &y_label,
            &signal("measured", measured, 0),
            &signal("simulated", &v.simulated, 0),
        )?);
        if let Some(w) = &v.window {
            let a = (w.start_s * fs).round() as usize;
            let b = a + w.samples;
            files.extend(plot::write_time_overlay(
                &args.out.join(format!("{stem}_time_window")),
                &format!(
                    "{name}: {:.1}-{:.1} s, e_RMS {:.4e}",
                    w.start_s, w.end_s, w.e_rms
                ),
                &y_label,
                &signal("measured", &measured[a..b], a),
                &signal("simulated", &v.simulated[a..b], a),
            )?);
        }
        if let Some(c) = &v.frf
            && let (Some(m), Some(s)) = (&c.measured, &c.simulated)
        {
            let mut series = Vec::new();
            for (g, (lm, ls)) in m.levels.iter().zip(&s.levels).enumerate() {
                let keep = |f: f64| band.is_none_or(|(lo, hi)| f >= lo && f <= hi);
                let pick = |l: &hystid::extract::FrfLevel| -> (Vec<f64>, Vec<Complex64>) {
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
                let label = format!("{:.4} {}", lm.level, m.reference.si_unit());
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
                    &args.out.join(format!("{stem}_frf")),
                    &format!(
                        "{name}: H1 measured (markers), simulated ({} model)",
                        fit.kind
                    ),
                    &plot::frf_magnitude_label(m, 1),
                    &series,
                )?);
            }
        }
        if !quiet {
            print_validation(path, &channel.name, &v);
        }
        entries.push(RecordingValidation {
            recording: path.display().to_string(),
            response: channel.name.clone(),
            validation: v,
        });
    }
    let report = ValidateReport {
        command: "validate",
        version: env!("CARGO_PKG_VERSION"),
        fit: args.fit.display().to_string(),
        model_kind: fit.kind,
        model: &fit.model,
        response_sign: fit.response_sign,
        recordings: entries,
        files,
    };
    write_json(&args.out.join("validate.json"), &report)?;
    if !quiet {
        for f in &report.files {
            say!("  wrote {}", f.display());
        }
    }
    Ok(EXIT_OK)
}

fn print_validation(path: &Path, response: &str, v: &Validation) {
    say!(
        "{}: `{response}` simulated at {} Hz{}: e_RMS {:.4e} ({:.1} % of the measured RMS {:.4e})",
        path.display(),
        v.sample_rate_hz * v.upsampling as f64,
        if v.upsampling > 1 {
            format!(
                " (upsampled x{}: {:.1} samples per period of {:.4} Hz at the recording's rate)",
                v.upsampling,
                v.sample_rate_hz / v.highest_frequency_hz,
                v.highest_frequency_hz
            )
        } else {
            String::new()
        },
        v.whole.e_rms,
        100.0 * v.whole.relative,
        v.whole.measured_rms
    );
    if let Some(w) = &v.window {
        say!(
            "  window {:.2}-{:.2} s: e_RMS {:.4e} ({:.1} % of {:.4e})",
            w.start_s,
            w.end_s,
            w.e_rms,
            100.0 * w.relative,
            w.measured_rms
        );
    }
    if let Some(c) = &v.frf {
        for l in &c.levels {
            let peak = |p: &Option<hystid::validate::Peak>| {
                p.map_or("-".to_string(), |p| {
                    format!("{:.4} Hz ({:.4e})", p.frequency_hz, p.magnitude)
                })
            };
            say!(
                "  level {:.4}: H1 error {:.1} % over {} points; |H1| peak measured {}, simulated {}",
                l.level,
                100.0 * l.relative_h1_error,
                l.points,
                peak(&l.measured_peak),
                peak(&l.simulated_peak)
            );
        }
    }
}
