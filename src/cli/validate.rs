//! `hystid validate`: a fitted model driven by recordings' measured force,
//! its simulated response compared with the measured one (e_RMS, `H1`).

use super::args::ValidateArgs;
use super::{EXIT_DEGRADED, EXIT_OK, create_out_dir, progress, reduction_options, write_json};
use anyhow::Result;
use hystid::analysis::load_held_reference_and_response;
use hystid::analysis::request::parse_range;
use hystid::analysis::validate::{
    ValidateReport, ValidateRequest, ValidationSettings, read_fit, unique_stem, validate_on,
};
use hystid::validate::Validation;
use std::path::Path;

/// The request `validate`'s flags make.
fn validate_request(args: &ValidateArgs) -> Result<ValidateRequest> {
    Ok(ValidateRequest {
        fit: args.fit.clone(),
        linear: args.linear,
        recordings: args.recordings.clone(),
        acquisition: args.acquisition.given(),
        settings: ValidationSettings {
            input: args.replay.into(),
            band_hz: args
                .band
                .as_deref()
                .map(|b| parse_range(b, "band_hz", "Hz"))
                .transpose()
                .map_err(super::refused)?,
            window_s: args
                .window
                .as_deref()
                .map(|w| parse_range(w, "window_s", "s"))
                .transpose()
                .map_err(super::refused)?,
            min_samples_per_period: args.min_samples_per_period,
            frf: !args.no_frf,
            periodic: args.periodic,
            reduction: reduction_options(&args.reduction)?,
        },
    })
}

/// `hystid validate`.
pub fn validate_command(args: &ValidateArgs, quiet: bool) -> Result<u8> {
    super::return_large_blocks();
    // refused before anything is read or written
    let req = validate_request(args)?;
    req.validate().map_err(super::refused)?;
    let mut fit = read_fit(&req.fit, req.linear)?;
    if let Some(chain) = &req.acquisition {
        fit.acquisition = Some(chain.clone());
    }
    let settings = &req.settings;
    let _out = create_out_dir(&args.out)?;
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
    // a long recording is read, replayed and reduced for seconds: a
    // spinner names it
    let pb = progress::spinner("", quiet);
    pb.enable_steady_tick(std::time::Duration::from_millis(150));
    for path in &args.recordings {
        pb.set_message(format!("validating on {}", path.display()));
        // `--response`, else the channel the model was fitted to where this
        // recording holds it: another recording's first response is another
        // point of the structure, compared with the wrong motion
        let fitted = match (args.response.as_deref(), fit.response.as_deref()) {
            (None, Some(name)) => {
                let held = hystid::analysis::recording::channel_names(path)?
                    .iter()
                    .any(|n| n == name);
                if !held && !quiet {
                    pb.suspend(|| {
                        say!(
                            "{}: no channel `{name}`, the response the model was fitted to; \
                             comparing with the recording's own response",
                            path.display()
                        )
                    });
                }
                held.then_some(name)
            }
            _ => None,
        };
        let channels = hystid::analysis::ChannelChoice {
            response: args.response.as_deref().or(fitted),
            reference: args.reference.as_deref().or(fit.reference.as_deref()),
        };
        // only the reference and the response are replayed and compared,
        // held as the file stored them
        let loaded = load_held_reference_and_response(path, channels)?;
        if loaded.truncated {
            pb.suspend(|| {
                eprintln!(
                    "warning: {} is truncated; analysing the complete chunks",
                    path.display()
                )
            });
        }
        let stem = unique_stem(path, &mut used);
        let shown = path.display().to_string();
        let observer = |e: hystid::observe::Event<'_>| {
            if let hystid::observe::Event::Progress { task, done, total } = e {
                pb.set_message(format!(
                    "validating on {shown}: {}",
                    progress::progress_message(task, done, total)
                ));
            }
        };
        let (entry, written) = validate_on(
            &fit,
            path,
            (&loaded.view(), loaded.response),
            settings,
            &args.out,
            &stem,
            &observer,
        )?;
        files.extend(written);
        if let Some(why) = &entry.replay_failed {
            pb.suspend(|| eprintln!("warning: {why}"));
        } else if !quiet && let Some(v) = &entry.validation {
            pb.suspend(|| print_validation(path, &entry.response, fitted.is_some(), v));
        }
        entries.push(entry);
    }
    let failed = entries.iter().filter(|e| e.replay_failed.is_some()).count();
    pb.finish_and_clear();
    let report = ValidateReport {
        command: "validate",
        version: env!("CARGO_PKG_VERSION"),
        fit: args.fit.display().to_string(),
        model_kind: fit.kind,
        model: &fit.model,
        response_sign: fit.response_sign,
        acquisition: fit.acquisition.as_ref(),
        recordings: entries,
        files,
    };
    write_json(&args.out.join("validate.json"), &report)?;
    if !quiet {
        for f in &report.files {
            say!("  wrote {}", f.display());
        }
    }
    if failed > 0 {
        if !quiet {
            say!(
                "{failed} of {} recordings could not be replayed (validate.json says why)",
                report.recordings.len()
            );
        }
        return Ok(EXIT_DEGRADED);
    }
    Ok(EXIT_OK)
}

/// Where in frequency an error figure's residual lies (with `--band`).
pub(crate) fn print_by_frequency(e: &hystid::validate::ErrorMetrics) {
    let Some(b) = &e.by_frequency else {
        return;
    };
    let (lo, hi) = b.band_hz;
    let pc = |x: f64| format!("{:.1} %", 100.0 * x);
    let top = 2.0 * hi;
    say!(
        "    by frequency, as shares of the measured RMS: error {} below {lo} Hz, {} in {lo}-{hi} Hz, {} in {hi}-{top} Hz, {} above \
         {top} Hz, where the measured response holds {} of its RMS and the model {}",
        pc(b.below.error),
        pc(b.inside.error),
        pc(b.above.error),
        pc(b.beyond.error),
        pc(b.beyond.measured),
        pc(b.beyond.simulated)
    );
}

fn print_validation(path: &Path, response: &str, fitted: bool, v: &Validation) {
    // the unit of the quantity compared, whatever the channel is called
    let unit = v.quantity.si_unit();
    say!(
        "{}: `{response}`{} simulated at {} Hz{}: e_RMS {:.4e} {unit} ({:.1} % of the measured RMS {:.4e} {unit})",
        path.display(),
        if fitted {
            " (the response the model was fitted to)"
        } else {
            ""
        },
        v.sample_rate_hz * v.upsampling as f64,
        if v.upsampling >= hystid::validate::resample::MAX_FACTOR {
            // capped: the model's top mode lies far above what was recorded
            format!(
                " (upsampled x{}, the most: {:.1} samples per period of its highest linearised \
                 frequency {:.4} Hz, which the recording does not show; its flexibility in the \
                 band is kept)",
                v.upsampling,
                v.sample_rate_hz * v.upsampling as f64 / v.highest_frequency_hz,
                v.highest_frequency_hz
            )
        } else if v.upsampling > 1 {
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
    print_by_frequency(&v.whole);
    if let Some(assumed) = &v.assumed {
        say!("  note: {assumed}");
    }
    if let Some(w) = &v.window {
        say!(
            "  window {:.2}-{:.2} s: e_RMS {:.4e} {unit} ({:.1} % of {:.4e} {unit})",
            w.start_s,
            w.end_s,
            w.e_rms,
            100.0 * w.relative,
            w.measured_rms
        );
        print_by_frequency(w);
    }
    if let Some(l) = &v.lines {
        let r = &l.residual;
        let classes: Vec<String> = r
            .by_class
            .iter()
            .map(|c| format!("{} {:.2}", c.class.words(), c.chi2_per_line))
            .collect();
        say!(
            "  at the lines of its period ({} steady periods, the noise from their scatter): chi2 per \
             line {:.3} over {} lines ({}; about 1 where only noise is left)",
            l.steady_periods,
            r.chi2_per_line,
            r.lines,
            classes.join(", ")
        );
        if let Some(s) = r.strongest.first() {
            say!(
                "    largest at {:.4} Hz ({}), {:.1}x the noise",
                s.frequency_hz,
                s.class.words(),
                s.in_noise
            );
        }
    }
    if let Some(l) = &v.line_spectrum {
        let classes: Vec<String> = l
            .by_class
            .iter()
            .map(|c| format!("{} {:.2} %", c.class.words(), 100.0 * c.relative))
            .collect();
        say!(
            "  at the lines of its period (one period: no noise to judge by): the difference {} of \
             the measured there; {:.4e} RMS over its {} lines",
            classes.join(", "),
            l.error_rms_at_lines,
            l.lines
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
