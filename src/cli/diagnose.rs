//! `hystid diagnose`: trace a fit's residual to a missing effect, add it,
//! refit, and report the error before and after.

use super::args::DiagnoseArgs;
use super::identify::{fit_options, reduce_recordings, run_fit};
use super::{EXIT_OK, create_out_dir, progress};
use super::{reduction_options, refused};
use anyhow::Result;
use hystid::analysis::diagnose::{
    DiagnoseRequest, DiagnosisExtras, TimeOutcome, TimeRefinement, refine_in_time,
    write_diagnosis_with,
};
use hystid::analysis::recording::ReplayReduction;
use hystid::analysis::request::{FitDomain, parse_candidates};
use hystid::analysis::run::FinalModel;
use hystid::diagnose::{DiagnoseOptions, Diagnosis, Effect};
use hystid::extract::NonlinearFrf;
use hystid::fit::{FitResult, HbPredictor, TimeFitOptions};

/// The candidates named on the command line (none: the default set).
pub fn candidates(names: &[String]) -> Result<Vec<Effect>> {
    if names.is_empty() {
        return Ok(Effect::defaults());
    }
    parse_candidates(names).map_err(refused)
}

/// The request `diagnose`'s flags make.
fn diagnose_request(args: &DiagnoseArgs) -> Result<DiagnoseRequest> {
    let mut req = DiagnoseRequest::new(
        args.recordings.clone(),
        fit_options(&args.fit)?,
        candidates(&args.candidates)?,
    );
    req.domain = args.domain.into();
    req.diagnosis.time_proposals = args.time_proposals;
    req.time = TimeFitOptions {
        input: args.replay.into(),
        min_samples_per_period: args.min_samples_per_period,
        starts: args.starts,
        max_judged_samples: args.max_judged_samples,
        acquisition: args.acquisition.given(),
        each_alone: args.each_alone,
        ..TimeFitOptions::default()
    };
    Ok(req)
}

/// Runs the diagnosis with a progress line.
pub fn run_diagnosis(
    frf: &NonlinearFrf,
    fit: &FitResult,
    options: &DiagnoseOptions,
    quiet: bool,
) -> Result<(Diagnosis, HbPredictor)> {
    let pb = progress::bar(0, "diagnosing", quiet);
    pb.enable_steady_tick(std::time::Duration::from_millis(200));
    pb.set_message("baseline refit");
    let out =
        hystid::analysis::diagnose::run_diagnosis(frf, fit, options, &progress::BarObserver(&pb))?;
    pb.finish_and_clear();
    Ok(out)
}

/// `hystid diagnose`.
pub fn diagnose_command(args: &DiagnoseArgs, quiet: bool) -> Result<u8> {
    // refused before anything is read or written
    let req = diagnose_request(args)?;
    req.validate().map_err(refused)?;
    if req.domain == FitDomain::Time {
        super::return_large_blocks();
    }
    let fit_opts = &req.diagnosis.fit;
    // multisines, which no FRF reduction reads: diagnosed on their lines
    if req.domain == FitDomain::Time
        && args.reduction.excitation == super::args::ExcitationArg::Auto
        && let Some(p) = hystid::analysis::periodic_start(
            &args.recordings,
            args.channels(),
            fit_opts.element,
            fit_opts.modes,
        )?
    {
        req.validate_on_multisines().map_err(refused)?;
        return diagnose_multisine_command(args, &req, p, quiet);
    }
    let (frf, first) =
        reduce_recordings(&args.recordings, args.channels(), &args.reduction, quiet)?;
    let _out = create_out_dir(&args.out)?;
    let t0 = std::time::Instant::now();
    let (fit, _) = run_fit(&frf, fit_opts, quiet, None)?;
    // the candidates re-identify (one more mode) with the user's fit options:
    // the same element, band and linear start as the baseline
    let options = &req.diagnosis;
    let (mut d, predictor) = run_diagnosis(&frf, &fit, options, quiet)?;
    let time = match req.domain {
        FitDomain::Frf => None,
        FitDomain::Time => {
            // a refit that fails leaves the FRF diagnosis standing, with why
            let pb = progress::spinner("refitting in the time domain", quiet);
            let reduction = reduction_options(&args.reduction)?;
            // the recordings read once: the time records the refit replays,
            // and held to reduce the refitted model's replay as they were
            // reduced (its residual in the FRFs' plane)
            let t = ReplayReduction::new(&args.recordings, args.channels(), &reduction).and_then(
                |mut replays| {
                    let records = replays.take_time_records(options.band_hz)?;
                    refine_in_time(
                        &mut d,
                        &frf,
                        &records,
                        &req.time,
                        options.band_hz,
                        options,
                        &predictor,
                        Some(&replays),
                        &progress::BarObserver(&pb),
                    )
                },
            );
            pb.finish_and_clear();
            Some(match t {
                Ok(t) => TimeOutcome::Refined(Box::new(t)),
                Err(e) => {
                    eprintln!("warning: no refit in the time domain: {e}");
                    TimeOutcome::Failed {
                        failed: e.to_string(),
                    }
                }
            })
        }
    };
    let final_model = FinalModel::of(
        &frf,
        &fit,
        &fit_opts.harmonics,
        options.band_hz,
        Some(&d),
        None,
        &predictor,
    )?;
    let written = write_diagnosis_with(
        &args.out,
        &frf,
        &d,
        &predictor,
        t0.elapsed().as_secs_f64(),
        DiagnosisExtras {
            time: time.as_ref(),
            final_model: Some(&final_model),
            reference_channel: args.reference.as_deref(),
            quality: &first.quality,
        },
    )?;
    if !quiet {
        say!("hystid diagnose: {}", d.explanation);
        for line in final_model.summary_lines() {
            say!("{line}");
        }
        if let Some(TimeOutcome::Refined(t)) = &time {
            print_time_refinement(t);
        }
        for n in &written.notes {
            say!("  note: {n}");
        }
        for f in &written.files {
            say!("  wrote {}", f.display());
        }
    }
    Ok(EXIT_OK)
}

/// Prints the final model's refit in the time domain: the errors, each
/// recording alone, each kept effect's check, the time residual and the
/// candidates put to the time histories.
fn print_time_refinement(t: &TimeRefinement) {
    for ((b, f), a) in t.baseline.iter().zip(&t.refit.before).zip(&t.refit.after) {
        say!(
            "  in the time domain, {}: per-dwell relative e_RMS {:.2} % (baseline) -> {:.2} % (final) -> {:.2} % (final, refitted)",
            a.recording,
            100.0 * b.segment_relative,
            100.0 * f.segment_relative,
            100.0 * a.segment_relative
        );
        super::validate::print_by_frequency(&a.window);
    }
    super::identify::print_each_alone(&t.refit.each_alone);
    if let Some(note) = hystid::fit::time::level_consistency(&t.refit.each_alone) {
        say!("  {note}");
    }
    for c in &t.checks {
        match &c.failed {
            Some(why) => say!(
                "  {} kept: the refit without it failed ({why})",
                c.effect.name()
            ),
            None => say!(
                "  {} {} in the time domain: without it, refitted, the misfit rises {:+.2} %",
                c.effect.name(),
                if c.confirmed {
                    "confirmed"
                } else {
                    "not confirmed (dropped)"
                },
                100.0 * c.rise
            ),
        }
    }
    if let Some(r) = &t.residual {
        for line in hystid::analysis::diagnose::time_residual_lines(r) {
            say!("  {line}");
        }
    }
    if let Some(why) = &t.residual_failed {
        say!("  the time residual could not be reduced or traced: {why}");
    }
    for p in &t.proposals {
        match &p.failed {
            Some(why) => say!("  {} not tried in the time domain: {why}", p.effect.name()),
            None => say!(
                "  {} {} in the time domain: with it, refitted, the misfit is {:.2} % against {:.2} % without",
                p.effect.name(),
                if p.kept { "added" } else { "not needed" },
                100.0 * hystid::analysis::diagnose::misfit(&p.with),
                100.0 * hystid::analysis::diagnose::misfit(&p.with) * (1.0 + p.gain)
            ),
        }
    }
}

/// `hystid diagnose --domain time` on multisines (see
/// [`hystid::analysis::multisine`]).
fn diagnose_multisine_command(
    args: &DiagnoseArgs,
    req: &DiagnoseRequest,
    p: hystid::analysis::PeriodicStart,
    quiet: bool,
) -> Result<u8> {
    let _out = create_out_dir(&args.out)?;
    let t0 = std::time::Instant::now();
    let pb = progress::spinner("diagnosing on the multisine's lines", quiet);
    let time_options = &req.time;
    let mut d = hystid::analysis::multisine::diagnose_multisine(
        &p.start,
        &p.records,
        time_options,
        &req.diagnosis,
        &progress::BarObserver(&pb),
    )?;
    pb.finish_and_clear();
    d.start = p.note;
    let files = hystid::analysis::multisine::write_multisine_diagnosis(
        &args.out,
        &d,
        &p.records,
        t0.elapsed().as_secs_f64(),
        args.reference.as_deref(),
        time_options,
    )?;
    if !quiet {
        say!("hystid diagnose: {}", d.explanation);
        for (b, a) in d.baseline.after.iter().zip(&d.refit.after) {
            say!(
                "  {}: relative e_RMS {:.2} % (baseline) -> {:.2} % (final); per period {:.2} % -> {:.2} %",
                a.recording,
                100.0 * b.window.relative,
                100.0 * a.window.relative,
                100.0 * b.segment_relative,
                100.0 * a.segment_relative
            );
        }
        for r in &d.rounds {
            let shares: Vec<String> = r
                .traced
                .iter()
                .map(|t| match &t.failed {
                    None => format!("{} {:.1} %", t.effect.name(), 100.0 * t.share),
                    Some(_) => format!("{} not traced", t.effect.name()),
                })
                .collect();
            say!(
                "  round {}: chi2 per line {:.2}; traced: {}",
                r.round,
                r.residual.chi2_per_line,
                shares.join(", ")
            );
        }
        for f in files {
            say!("  wrote {}", f.display());
        }
    }
    Ok(EXIT_OK)
}
