//! `hystid run`: the paper end to end in one command. Simulate the test
//! bench, identify the element from the recorded FRFs, and write a short
//! report that sets the result beside the paper's Table 3.1.

use super::args::{RunArgs, WavFormat};
use super::identify::{fit_options, print_fit, run_fit};
use super::simulate::simulate_into;
use super::{EXIT_DEGRADED, read_test, write_json};
use anyhow::Result;
use hystid::analysis::run::{DiagnosisSummary, RunSummary, diagnosis_markdown, report_markdown};
use hystid::analysis::{FitReport, reference_joint, write_fit_plots};
use hystid::fit::{FitResult, HbPredictor};
use std::sync::Mutex;

/// `hystid run`.
pub fn run_command(args: &RunArgs, quiet: bool) -> Result<u8> {
    let t0 = std::time::Instant::now();
    let options = fit_options(&args.fit)?;
    let (def, text) = read_test(args.test.as_deref())?;
    let _out = super::create_out_dir(&args.out)?;
    let mut fit_out: Option<(FitResult, HbPredictor)> = None;
    let (run, sim) = simulate_into(
        &def,
        &text,
        &args.out,
        quiet,
        WavFormat::Float32,
        false,
        &mut |run: &hystid::testbench::BenchRun, mcap: &mut hystid::record::McapRecorder| {
            fit_out = Some(run_fit(&run.frf, &options, quiet, Some(&Mutex::new(mcap)))?);
            Ok(())
        },
    )?;
    let (fit, predictor) = fit_out.expect("the fit ran");
    let reference = reference_joint(Some(&def));
    let mut files = sim.files.clone();
    files.extend(write_fit_plots(
        &args.out,
        &run.frf,
        &fit,
        reference.as_ref(),
        &predictor,
    )?);
    files.push(args.out.join("fit.json"));
    let report = FitReport::new(
        args.out.join("run.mcap").display().to_string(),
        def.test.response.quantity().name().to_string(),
        fit,
        reference,
        Vec::new(),
    );
    write_json(&args.out.join("fit.json"), &report)?;
    let mut diagnosis_md = String::new();
    let mut diagnosis = None;
    if !args.no_diagnose {
        let t = std::time::Instant::now();
        let (d, p) = super::diagnose::run_diagnosis(
            &run.frf,
            &report.fit,
            // the candidates re-identify (one more mode) with the user's fit
            // options: the same element, band and linear start as the baseline
            &hystid::diagnose::DiagnoseOptions {
                band_hz: options.band_hz,
                fit: options.clone(),
                ..Default::default()
            },
            quiet,
        )?;
        let secs = t.elapsed().as_secs_f64();
        files.extend(hystid::analysis::diagnose::write_diagnosis(
            &args.out, &run.frf, &d, &p, secs,
        )?);
        diagnosis_md = diagnosis_markdown(&d, secs);
        if !quiet {
            say!("diagnosis ({secs:.1} s): {}", d.explanation);
        }
        diagnosis = Some(DiagnosisSummary::of(&d, secs));
    }
    let md = report_markdown(&sim, &report) + &diagnosis_md;
    hystid::atomic::write_bytes(&args.out.join("report.md"), md.as_bytes())?;
    files.push(args.out.join("report.md"));
    files.push(args.out.join("run.json"));
    let summary = RunSummary {
        command: "run",
        version: env!("CARGO_PKG_VERSION"),
        simulate: &sim,
        fit: &report,
        diagnosis,
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
        print_fit(&report.fit, &report.comparison);
        say!("  report: {}", args.out.join("report.md").display());
    }
    Ok(if sim.unsettled.is_empty() {
        super::fit_exit_code(report.fit.status)
    } else {
        EXIT_DEGRADED
    })
}
