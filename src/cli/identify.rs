//! `hystid identify`: fit a hysteresis element to a recording's nonlinear
//! FRFs (paper Figures 2.2 and 3.3).

use super::args::{ExcitationArg, IdentifyArgs, IdentifyOptionsArgs, ReductionArgs};
use super::{create_out_dir, progress, reduction_options, refused, write_json};
use anyhow::{Context, Result};
use hystid::analysis::identify::IdentifyRequest;
use hystid::analysis::request::{FitDomain, parse_joint, parse_range};
use hystid::analysis::{
    FitReport, Reduced, SineTest, band_limited, reference_joint, write_fit_plots,
};
use hystid::extract::NonlinearFrf;
use hystid::fit::{FitOptions, FitResult, HbPredictor, TimeFitOptions, Weighting};
use std::path::{Path, PathBuf};
use std::sync::Mutex;

/// Prints what a reduction found.
pub fn print_reduced(path: &Path, r: &Reduced) {
    let points: usize = r.frf.levels.iter().map(|l| l.points.len()).sum();
    let levels: Vec<String> = r
        .frf
        .levels
        .iter()
        .map(|l| format!("{:.4}", l.level))
        .collect();
    say_part!(
        "{}: `{}` {} {} point(s) at level(s) {} {}",
        path.display(),
        r.response_name,
        match r.excitation {
            SineTest::Stepped => "stepped sine,",
            SineTest::Swept => "swept sine,",
        },
        points,
        levels.join(", "),
        r.frf.reference.si_unit()
    );
    if let Some(reading) = &r.sweep {
        let s = &reading.sweep;
        say_part!(
            "; sweep {:.4} -> {:.4} Hz at {:.5} Hz/s, compensation {}",
            s.f_start_hz,
            s.f_end_hz,
            s.rate_hz_per_s,
            reading
                .compensation_s
                .map_or("off".to_string(), |c| format!("{c:.2} s"))
        );
        if reading.hop_periods > reading.hop_asked {
            say_part!(
                "; read every {:.2} periods, not {}: at most {} points per sweep",
                reading.hop_periods,
                reading.hop_asked,
                hystid::extract::MAX_SWEEP_POINTS
            );
        }
    }
    if r.streamed {
        say_part!(" (streamed)");
    }
    say!();
}

/// Fit options from the command line, their text forms read by the
/// library's parsers; checked with the request they go into.
pub fn fit_options(a: &IdentifyOptionsArgs) -> Result<FitOptions> {
    Ok(FitOptions {
        element: parse_joint(&a.element).map_err(refused)?,
        harmonics: a.harmonics.clone(),
        weighting: if a.weighted {
            Weighting::StandardError
        } else {
            Weighting::None
        },
        refine_linear: a.refine_linear.parse().map_err(refused)?,
        linear_start: a.linear_start.parse().map_err(refused)?,
        modes: a.modes,
        second_optimiser: a.lm,
        bootstrap: a.bootstrap,
        seed: a.seed,
        band_hz: a
            .band
            .as_deref()
            .map(|b| parse_range(b, "band_hz", "Hz"))
            .transpose()
            .map_err(refused)?,
        transfer: a.transfer,
        ..FitOptions::default()
    })
}

/// The request `identify`'s flags make.
fn identify_request(args: &IdentifyArgs) -> Result<IdentifyRequest> {
    Ok(IdentifyRequest {
        recordings: args.recordings.clone(),
        domain: args.domain.into(),
        options: fit_options(&args.fit)?,
        start: args.start.clone(),
        response_sign: None,
        refined_fit: None,
        fix: args.fix.clone(),
        window_s: args
            .window
            .as_deref()
            .map(|w| parse_range(w, "window_s", "s"))
            .transpose()
            .map_err(refused)?,
        time: TimeFitOptions {
            min_samples_per_period: args.min_samples_per_period,
            input: args.replay.into(),
            starts: args.starts,
            max_judged_samples: args.max_judged_samples,
            acquisition: args.acquisition.given(),
            each_alone: args.each_alone,
            ..TimeFitOptions::default()
        },
    })
}

/// Prints the fit in a few lines.
pub fn print_fit(report: &FitReport) {
    let fit = &report.fit;
    say!(
        "fitted {} element: relative error {:.4} (chi2/dof {:.3}), {} evaluations in {:.2} s",
        fit.element.name(),
        fit.error.relative,
        fit.error.chi2_per_dof,
        fit.effort.evaluations,
        fit.effort.seconds
    );
    for line in report.parameter_lines() {
        say!("{line}");
    }
    // on a voltage reference the model's forces are volts: its units too
    let unit = |name| hystid::analysis::flags::parameter_unit(name, &fit.model, report.drive());
    say!(
        "  linear: m = {:.5} {}, c = {:.4} {}, k = {:.6e} {}; stick k_low = {:.6e} {}",
        fit.linear.mass,
        unit("mass"),
        fit.linear.damping,
        unit("damping"),
        fit.linear.stiffness,
        unit("stiffness"),
        fit.linear.stick.stiffness,
        unit("stiffness")
    );
    for n in &fit.notes {
        say!("  note: {n}");
    }
}

/// Runs the fit with a progress line and an optional MCAP fit channel.
pub fn run_fit(
    frf: &NonlinearFrf,
    options: &FitOptions,
    quiet: bool,
    mcap: Option<&Mutex<&mut hystid::record::McapRecorder>>,
) -> hystid::Result<(FitResult, HbPredictor)> {
    let pb = progress::spinner("fitting", quiet);
    let out = hystid::analysis::run_fit(frf, options, &progress::BarObserver(&pb), mcap)?;
    pb.finish_and_clear();
    Ok(out)
}

/// Reduces every recording (printing each unless `quiet`) and combines
/// them into one FRF set; also returns the first reduction.
pub fn reduce_recordings(
    recordings: &[PathBuf],
    channels: hystid::analysis::ChannelChoice,
    reduction: &ReductionArgs,
    quiet: bool,
) -> Result<(NonlinearFrf, Reduced)> {
    let options = reduction_options(reduction)?;
    // a long sweep takes tens of seconds to reduce: a spinner names the
    // recording being read
    let reducing = |i: usize| {
        recordings
            .get(i)
            .map(|p| format!("reducing {}", p.display()))
            .unwrap_or_default()
    };
    let pb = progress::spinner(&reducing(0), quiet);
    pb.enable_steady_tick(std::time::Duration::from_millis(150));
    // the recording being read, for the progress of its stages
    let current = std::sync::atomic::AtomicUsize::new(0);
    let mut on_reduced = |path: &Path, red: &Reduced| {
        pb.suspend(|| {
            if red.truncated {
                eprintln!(
                    "warning: {} is truncated; analysing the complete chunks",
                    path.display()
                );
            }
            for q in &red.quality {
                eprintln!("warning: {q}");
            }
            if !quiet {
                print_reduced(path, red);
            }
        });
        let done = current.fetch_add(1, std::sync::atomic::Ordering::Relaxed) + 1;
        pb.set_message(reducing(done));
    };
    let stages = |event: hystid::observe::Event<'_>| {
        if let hystid::observe::Event::Progress { task, done, total } = event {
            let i = current.load(std::sync::atomic::Ordering::Relaxed);
            // `reducing x.wav 42 %`, `reducing x.wav: finding dwells 42 %`
            let stage = progress::progress_message(task, done, total);
            pb.set_message(match stage.strip_prefix("reducing") {
                Some(pct) => format!("{}{pct}", reducing(i)),
                None => format!("{}: {stage}", reducing(i)),
            });
        }
    };
    let reduced = hystid::analysis::reduce_recordings(
        recordings,
        channels,
        &options,
        &mut on_reduced,
        &stages,
    );
    pb.finish_and_clear();
    Ok(reduced?)
}

/// `hystid identify --start MODEL` (a model written down, a fit.json or a
/// diagnosis.json): fitted to the nonlinear FRFs, or with `--domain time`
/// to the time histories.
fn identify_from_start(
    args: &IdentifyArgs,
    req: &IdentifyRequest,
    path: &Path,
    quiet: bool,
) -> Result<u8> {
    let start = hystid::analysis::validate::read_fit(path, false)
        .with_context(|| format!("--start: reading {}", path.display()))?;
    if req.domain != FitDomain::Time {
        // said, not silently dropped: harmonic balance predicts the
        // continuous response's harmonics
        if start.acquisition.is_some() {
            eprintln!(
                "warning: {}: its acquisition chain is put through by the time-domain fit only \
                 (add --domain time); the FRF fit compares the harmonics as recorded",
                path.display()
            );
        }
        return identify_declared(args, req, &start.model, start.response_sign, quiet);
    }
    let records = hystid::analysis::time_records_in(
        &args.recordings,
        args.channels(),
        req.window_s,
        req.options.band_hz,
    )?;
    // the flag in place of the model file's own
    let acquisition = req.time.acquisition.clone().or(start.acquisition);
    fit_in_time(
        args,
        req,
        (&start.model, start.response_sign, acquisition),
        &records,
        None,
        quiet,
    )
}

/// The response channel fitted to: `--response`, else the one the first
/// recording's channels give by default, named in fit.json so that
/// `validate` compares the model with that channel, not another recording's
/// first response.
fn fitted_response(args: &IdentifyArgs) -> Result<String> {
    match (&args.response, args.recordings.first()) {
        (Some(r), _) => Ok(r.clone()),
        (None, Some(path)) => Ok(hystid::analysis::recording::response_channel_name(
            path,
            args.channels(),
        )?),
        (None, None) => Ok(String::new()),
    }
}

/// Fits the model written down to the recordings' nonlinear FRFs and
/// writes fit.json (see [`hystid::diagnose::fit_declared`]).
fn identify_declared(
    args: &IdentifyArgs,
    req: &IdentifyRequest,
    model: &hystid::model::Model,
    response_sign: f64,
    quiet: bool,
) -> Result<u8> {
    let (frf, _) = reduce_recordings(&args.recordings, args.channels(), &args.reduction, quiet)?;
    let names: Vec<String> = args
        .recordings
        .iter()
        .map(|p| p.display().to_string())
        .collect();
    let pb = progress::spinner("fitting the model written down to the FRFs", quiet);
    let mut report = hystid::analysis::identify::DeclaredFitReport::fit(
        &frf,
        model,
        response_sign,
        &req.options,
        names,
        fitted_response(args)?,
        &progress::BarObserver(&pb),
    )?;
    pb.finish_and_clear();
    let _out = create_out_dir(&args.out)?;
    report.files = vec![args.out.join("fit.json")];
    report.reference_channel = args.reference.clone();
    write_json(&args.out.join("fit.json"), &report)?;
    if !quiet {
        let f = &report.frequency_domain;
        say!(
            "hystid identify: the model written down, fitted to the FRFs: H1 error {:.2} % -> {:.2} %, chi2/dof {:.2} -> {:.2}",
            100.0 * f.start_error.relative,
            100.0 * f.error.relative,
            f.start_error.chi2_per_dof,
            f.error.chi2_per_dof
        );
        for line in report.parameter_lines() {
            say!("{line}");
        }
        say!("  wrote {}", args.out.join("fit.json").display());
    }
    Ok(super::EXIT_OK)
}

/// Fits `model` to `records` in the time domain and writes fit.json: a
/// start written down, or `origin` (how the start was found, a note).
fn fit_in_time(
    args: &IdentifyArgs,
    req: &IdentifyRequest,
    (model, response_sign, acquisition): (
        &hystid::model::Model,
        f64,
        Option<hystid::validate::acquisition::Acquisition>,
    ),
    records: &[hystid::fit::TimeRecord],
    origin: Option<String>,
    quiet: bool,
) -> Result<u8> {
    let names: Vec<String> = args
        .recordings
        .iter()
        .map(|p| p.display().to_string())
        .collect();
    let options = TimeFitOptions {
        acquisition,
        ..req.time.clone()
    };
    let pb = progress::spinner("fitting in the time domain", quiet);
    let mut report = hystid::analysis::run_time_fit_from_start_signed(
        names,
        fitted_response(args)?,
        model,
        response_sign,
        &req.fix,
        records,
        &options,
        &progress::BarObserver(&pb),
    )?;
    pb.finish_and_clear();
    if let Some(o) = origin {
        report.time_domain.notes.insert(0, o);
    }
    let _out = create_out_dir(&args.out)?;
    report.files = vec![args.out.join("fit.json")];
    report.reference_channel = args.reference.clone();
    write_json(&args.out.join("fit.json"), &report)?;
    if !quiet {
        print_time_fit(&report.time_domain, records[0].quantity.si_unit());
        for line in report.parameter_lines() {
            say!("{line}");
        }
        for n in &report.time_domain.notes {
            say!("  note: {n}");
        }
        say!("  wrote {}", args.out.join("fit.json").display());
    }
    Ok(super::fit_exit_code(report.time_domain.status))
}

/// The import's quality warnings into fit.json's notes: the FRF fit's, and
/// the time fit's, which is read on its own.
fn carry_quality(report: &mut FitReport, quality: &[String]) {
    report.fit.notes.extend(quality.iter().cloned());
    if let Some(t) = &mut report.time_domain {
        t.notes.extend(quality.iter().cloned());
    }
}

/// `hystid identify`.
pub fn identify_command(args: &IdentifyArgs, quiet: bool) -> Result<u8> {
    // refused before anything is read or written
    let req = identify_request(args)?;
    req.validate().map_err(refused)?;
    if req.domain == FitDomain::Time {
        super::return_large_blocks();
    }
    if let Some(start) = &req.start {
        return identify_from_start(args, &req, start, quiet);
    }
    // multisines, which no FRF reduction reads: the start from their
    // linear estimate
    if req.domain == FitDomain::Time
        && args.reduction.excitation == ExcitationArg::Auto
        && let Some(p) = hystid::analysis::periodic_start(
            &args.recordings,
            args.channels(),
            req.options.element,
            req.options.modes,
        )?
    {
        let acquisition = req.time.acquisition.clone();
        return fit_in_time(
            args,
            &req,
            (&p.start, 1.0, acquisition),
            &p.records,
            Some(p.note),
            quiet,
        );
    }
    identify_frf(args, &req, quiet)
}

/// `hystid identify` of the joint law: the FRF fit, and with `--domain
/// time` its model refined on the time histories.
fn identify_frf(args: &IdentifyArgs, req: &IdentifyRequest, quiet: bool) -> Result<u8> {
    let options = &req.options;
    let (frf, first) =
        reduce_recordings(&args.recordings, args.channels(), &args.reduction, quiet)?;
    let recording_names: Vec<String> = args
        .recordings
        .iter()
        .map(|p| p.display().to_string())
        .collect();
    let _out = create_out_dir(&args.out)?;
    let info = hystid::record::RunInfo {
        tool_version: format!("hystid {}", env!("CARGO_PKG_VERSION")),
        test_definition: String::new(),
        seed: options.seed,
        sample_rate_hz: first.sample_rate_hz,
        channels: hystid::testbench::recorded_channels(frf.reference),
        metadata: [("recording".to_string(), recording_names.join(", "))].into(),
    };
    let mut mcap = hystid::record::McapRecorder::create(&args.out.join("fit.mcap"), &info)?;
    let (fit, predictor) = run_fit(&frf, options, quiet, Some(&Mutex::new(&mut mcap)))?;
    mcap.finish()?;
    let reference = reference_joint(first.truth.as_ref());
    let mut files = vec![args.out.join("fit.json"), args.out.join("fit.mcap")];
    files.extend(write_fit_plots(
        &args.out,
        &band_limited(&frf, options.band_hz),
        &fit,
        reference.as_ref(),
        &predictor,
    )?);
    let time_domain = match req.domain {
        FitDomain::Frf => None,
        FitDomain::Time => {
            let records =
                hystid::analysis::time_records(&args.recordings, args.channels(), options.band_hz)?;
            let pb = progress::spinner("fitting in the time domain", quiet);
            let t = hystid::analysis::run_time_fit(
                &fit,
                &records,
                // the upsampling threshold is a start's and a
                // multisine's only
                &TimeFitOptions {
                    min_samples_per_period: TimeFitOptions::default().min_samples_per_period,
                    ..req.time.clone()
                },
                options.band_hz,
                &progress::BarObserver(&pb),
            )?;
            pb.finish_and_clear();
            Some(t)
        }
    };
    let mut report = FitReport::new(
        recording_names.clone(),
        first.response_name.clone(),
        fit,
        reference,
        files,
    );
    report.set_time_domain(time_domain);
    carry_quality(&mut report, &first.quality);
    // the shaker's coil, from the first recording that holds its voltage
    // beside its force
    for path in &args.recordings {
        if let Some(c) = hystid::analysis::recording::coil_of_path(path)? {
            report.coil = Some(c);
            break;
        }
    }
    report.reference_channel = args.reference.clone();
    write_json(&args.out.join("fit.json"), &report)?;
    if !quiet {
        print_identified(&report);
    }
    let status = report
        .time_domain
        .as_ref()
        .map_or(report.fit.status, |t| t.status);
    Ok(super::fit_exit_code(status))
}

/// Prints what `identify` fitted: the fit, the shaker's coil, the time
/// domain's refinement and the files written.
fn print_identified(report: &FitReport) {
    print_fit(report);
    if let Some(c) = &report.coil {
        say!(
            "  shaker coil (`{}` / `{}` / `{}`, {} dwells): R = {:.4} ohm, L = {:.4e} H, Bl = {:.4} N/A (ce {:.4} N s/m, te {:.4e} s, gain {:.4} N/V; residual {:.2} % of the force)",
            c.channels[0],
            c.channels[1],
            c.channels[2],
            c.dwells,
            c.r,
            c.l,
            c.bl,
            c.ce,
            c.te,
            c.gain,
            100.0 * c.residual
        );
    }
    if let Some(t) = &report.time_domain {
        let unit =
            hystid::harmonics::Quantity::from_name(&report.response).map_or("", |q| q.si_unit());
        print_time_fit(t, unit);
        for line in report.time_domain_lines() {
            say!("{line}");
        }
        for n in &t.notes {
            say!("  note: {n}");
        }
    }
    for f in &report.files {
        say!("  wrote {}", f.display());
    }
}

/// Prints the time-domain refinement in a few lines.
fn print_time_fit(t: &hystid::fit::TimeFitResult, unit: &str) {
    say!(
        "refined in the time domain on {} samples ({} evaluations, {:?}):",
        t.samples,
        t.optimiser.evaluations,
        t.status
    );
    for (b, a) in t.before.iter().zip(&t.after) {
        say!(
            "  {}: e_RMS {:.4e} -> {:.4e} {unit} ({:.2} % -> {:.2} % of the RMS); over its {} segment(s) {:.2} % -> {:.2} %",
            a.recording,
            b.window.e_rms,
            a.window.e_rms,
            100.0 * b.window.relative,
            100.0 * a.window.relative,
            a.segments,
            100.0 * b.segment_relative,
            100.0 * a.segment_relative
        );
        super::validate::print_by_frequency(&a.window);
    }
    print_each_alone(&t.each_alone);
}

/// Each recording refitted alone (`--each-alone`), a line each.
pub fn print_each_alone(alone: &[hystid::fit::time::AloneFit]) {
    for a in alone {
        match (a.alone, &a.failed) {
            (Some(x), _) => say!(
                "  {} refitted alone: {:.2} % -> {:.2} % of the RMS ({:?})",
                a.recording,
                100.0 * a.together,
                100.0 * x,
                a.status
            ),
            (None, why) => say!(
                "  {} refitted alone: failed ({})",
                a.recording,
                why.as_deref().unwrap_or("no error given")
            ),
        }
    }
}
