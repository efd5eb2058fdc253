//! `hystid simulate`: a virtual stepped-sine test, recorded.

use super::args::SimulateArgs;
use super::import::sample_format;
use super::{EXIT_DEGRADED, EXIT_OK, progress, write_json};
use anyhow::Result;
use hystid::analysis::simulate::{SimulateRequest, SimulateSummary, TimeHistories};
use hystid::record::McapRecorder;
use hystid::testbench::{BenchRun, TestDefinition};
use std::path::Path;

/// Runs the bench into `dir` with a progress bar; shared by `simulate` and
/// `run`. `after_bench` runs with the MCAP recorder still open (none
/// without a recording).
pub fn simulate_into(
    def: &TestDefinition,
    toml_text: &str,
    dir: &Path,
    quiet: bool,
    (recording, check_hb): (TimeHistories, bool),
    after_bench: &mut dyn FnMut(&BenchRun, Option<&mut McapRecorder>) -> hystid::Result<()>,
) -> Result<(BenchRun, SimulateSummary)> {
    let total: usize =
        def.sweeps()?.iter().map(|(_, f)| f.len()).sum::<usize>() * def.test.levels_n.len();
    let pb = progress::bar(total as u64, "dwells", quiet);
    let out = hystid::analysis::simulate::simulate_into(
        def,
        toml_text,
        dir,
        recording,
        check_hb,
        &progress::BarObserver(&pb),
        &mut |run, mcap| {
            pb.finish_and_clear();
            after_bench(run, mcap)
        },
    )?;
    pb.finish_and_clear();
    Ok(out)
}

/// `hystid simulate`.
pub fn simulate(args: &SimulateArgs, quiet: bool) -> Result<u8> {
    let req = SimulateRequest {
        test: args.test.clone(),
        recording: if args.no_recording {
            TimeHistories::Skipped
        } else {
            TimeHistories::Written(sample_format(args.wav_format))
        },
        check_hb: args.check_hb,
    };
    let (def, text) = req.validate().map_err(super::refused)?;
    let _out = super::create_out_dir(&args.out)?;
    let (run, mut summary) = simulate_into(
        &def,
        &text,
        &args.out,
        quiet,
        (req.recording, req.check_hb),
        &mut |_, _| Ok(()),
    )?;
    let summary_path = args.out.join("summary.json");
    summary.files.push(summary_path.clone());
    write_json(&summary_path, &summary)?;
    if !quiet {
        print_summary(&def, &run, &summary);
    }
    Ok(if summary.unsettled.is_empty() {
        EXIT_OK
    } else {
        EXIT_DEGRADED
    })
}

fn print_summary(def: &TestDefinition, run: &BenchRun, s: &SimulateSummary) {
    say!(
        "hystid simulate: {} levels x {} frequencies, {:.0} Hz sampling, {:.2} s",
        s.levels,
        s.dwells / s.levels.max(1),
        s.sample_rate_hz,
        s.seconds
    );
    say!(
        "  {} frames recorded; mean settling {:.0} periods; response noise {:.1} % of the clean RMS",
        s.frames,
        s.mean_settle_periods,
        100.0 * s.mean_noise_ratio
    );
    for l in &run.frf.levels {
        let peak = l
            .points
            .iter()
            .max_by(|a, b| a.h[1].norm().total_cmp(&b.h[1].norm()));
        if let Some(p) = peak {
            say!(
                "  level {:>9} N ({:?}): peak |H1| {:.4e} at {:.2} Hz",
                l.level,
                l.direction,
                p.h[1].norm(),
                p.frequency_hz
            );
        }
    }
    if let Some(c) = &s.hb_check {
        say!(
            "  harmonic balance vs simulation over {} dwells: H1 differs by {:.2e} (median) / {:.2e} (max); higher harmonics (relative to |H1|): {}; {} HB points not converged",
            c.dwells,
            c.h1_median,
            c.h1_max,
            c.higher_max
                .iter()
                .map(|(k, d)| format!("H{k} {d:.1e}"))
                .collect::<Vec<_>>()
                .join(", "),
            c.not_converged
        );
    }
    if !s.unsettled.is_empty() {
        say!(
            "  WARNING: {} dwells hit the settling cap ({} periods): {:?}",
            s.unsettled.len(),
            def.test.max_settle_periods,
            s.unsettled
        );
    }
    for f in &s.files {
        say!("  wrote {}", f.display());
    }
}
