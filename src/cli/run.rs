//! `hystid run`: a virtual test end to end in one command. Simulate the
//! test bench, identify the element from the recorded FRFs, diagnose what it
//! lacks, and report the final model (`report.md`, `run.json`).

use super::args::RunArgs;
use super::identify::{fit_options, run_fit};
use super::simulate::simulate_into;
use super::{EXIT_DEGRADED, write_json};
use anyhow::Result;
use hystid::analysis::identify::{write_convergence, write_fit_frf};
use hystid::analysis::run::{
    DiagnosisSummary, FinalModel, RunRequest, RunSummary, report_markdown, write_final_figures,
};
use hystid::analysis::simulate::TimeHistories;
use hystid::analysis::{FitReport, reference_joint};
use hystid::fit::{FitResult, HbPredictor};
use hystid::record::SampleFormat;
use std::sync::Mutex;

/// `hystid run`.
pub fn run_command(args: &RunArgs, quiet: bool) -> Result<u8> {
    let t0 = std::time::Instant::now();
    // refused before anything is simulated or written
    let mut req = RunRequest::new(
        args.test.clone(),
        fit_options(&args.fit)?,
        (!args.no_diagnose)
            .then(|| super::diagnose::candidates(&args.candidates))
            .transpose()?,
    );
    req.recording = !args.no_recording;
    req.validate().map_err(super::refused)?;
    let options = &req.options;
    let (def, text) =
        hystid::analysis::simulate::read_test(req.test.as_deref()).map_err(super::refused)?;
    let _out = super::create_out_dir(&args.out)?;
    let mut fit_out: Option<(FitResult, HbPredictor)> = None;
    let (run, sim) = simulate_into(
        &def,
        &text,
        &args.out,
        quiet,
        (
            if req.recording {
                TimeHistories::Written(SampleFormat::Float32)
            } else {
                TimeHistories::Skipped
            },
            false,
        ),
        &mut |run: &hystid::testbench::BenchRun,
              mcap: Option<&mut hystid::record::McapRecorder>| {
            let mcap = mcap.map(Mutex::new);
            fit_out = Some(run_fit(&run.frf, options, quiet, mcap.as_ref())?);
            Ok(())
        },
    )?;
    let (fit, predictor) = fit_out.expect("the fit ran");
    let reference = reference_joint(Some(&def));
    let mut files = sim.files.clone();
    files.extend(write_fit_frf(&args.out, &run.frf, &fit, &predictor)?);
    files.extend(write_convergence(&args.out, &fit)?);
    files.push(args.out.join("fit.json"));
    let report = FitReport::new(
        // none with --no-recording
        if !req.recording {
            Vec::new()
        } else {
            vec![args.out.join("run.mcap").display().to_string()]
        },
        def.test.response.quantity().name().to_string(),
        fit,
        reference,
        Vec::new(),
    );
    let mut report = report;
    // a gauge beside the shaker's voltage: its coil, from the run file
    if req.recording {
        report.coil = hystid::analysis::recording::coil_of_path(&args.out.join("run.mcap"))?;
    }
    write_json(&args.out.join("fit.json"), &report)?;
    let mut diagnosis = None;
    // the candidates re-identify (one more mode) with the user's fit
    // options: the same element, band and linear start as the baseline
    if let Some(diagnosis_options) = &req.diagnosis {
        let t = std::time::Instant::now();
        let (d, p) =
            super::diagnose::run_diagnosis(&run.frf, &report.fit, diagnosis_options, quiet)?;
        let secs = t.elapsed().as_secs_f64();
        let written =
            hystid::analysis::diagnose::write_diagnosis(&args.out, &run.frf, &d, &p, secs)?;
        if !quiet {
            for note in &written.notes {
                say!("  note: {note}");
            }
        }
        files.extend(written.files);
        diagnosis = Some((d, secs));
    }
    let truth = def.model().ok();
    let final_model = FinalModel::of(
        &run.frf,
        &report.fit,
        &options.harmonics,
        options.band_hz,
        diagnosis.as_ref().map(|(d, _)| d),
        truth.as_ref(),
        &predictor,
    )?;
    files.extend(write_final_figures(
        &args.out,
        &run.frf,
        &final_model,
        options.band_hz,
        reference.as_ref(),
        &predictor,
    )?);
    let md = report_markdown(
        &def,
        &sim,
        &report,
        &final_model,
        diagnosis.as_ref().map(|(d, s)| (d, *s)),
    );
    hystid::atomic::write_bytes(&args.out.join("report.md"), md.as_bytes())?;
    files.push(args.out.join("report.md"));
    files.push(args.out.join("run.json"));
    let summary = RunSummary {
        command: "run",
        version: env!("CARGO_PKG_VERSION"),
        simulate: &sim,
        final_model: &final_model,
        fit: &report,
        diagnosis: diagnosis.as_ref().map(|(d, s)| DiagnosisSummary::of(d, *s)),
        seconds: t0.elapsed().as_secs_f64(),
        files,
    };
    write_json(&args.out.join("run.json"), &summary)?;
    if !quiet {
        say!(
            "hystid run: simulated {} dwells in {:.2} s, fitted in {:.2} s, {:.2} s in all",
            sim.dwells,
            sim.seconds,
            report.fit.effort.seconds,
            summary.seconds
        );
        if let Some((d, secs)) = &diagnosis {
            say!("diagnosis ({secs:.1} s): {}", d.explanation);
        }
        for line in final_model.summary_lines() {
            say!("{line}");
        }
        say!("  report: {}", args.out.join("report.md").display());
    }
    Ok(if sim.unsettled.is_empty() {
        super::fit_exit_code(report.fit.status)
    } else {
        EXIT_DEGRADED
    })
}
