//! Issue 10's timing target: `diagnose` on a 238-dwell, 7-level stepped
//! sine (34 frequencies per level) with every candidate, one diagnosis at a
//! time (so that it has both cores): `cargo bench --bench dwells`.
//!
//! The recordings come from the independent reference simulator in
//! `tests/independent/kit` (no hystid code): a smooth Masing joint (N = 3)
//! as a 24-bit file without `steps` (the dwells found by hystid), the same
//! with a cubic stiffness, and a Jenkins joint with a mode below the band.
//! Prints each case's wall time, what was selected and whether the issue's
//! criteria held; writes `target/dwells/report.json`.

#[path = "../tests/independent/kit/mod.rs"]
mod kit;

use kit::corpus::{CaseOptions, EffectKind, JointKind, SampleFormat, Sweep, case_with};
use kit::runner::{describe, run_cases};
use serde_json::json;
use std::path::PathBuf;
use std::time::Duration;

fn main() {
    let target = std::env::var_os("CARGO_TARGET_DIR")
        .map(PathBuf::from)
        .unwrap_or_else(|| PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("target"));
    let dir = target.join("dwells");
    std::fs::create_dir_all(&dir).expect("target/dwells");
    let o = |steps: bool| CaseOptions {
        levels: Some(7),
        frequencies: Some(34),
        format: Some(SampleFormat::Pcm24),
        quantity: None,
        sweep: Some(Sweep::Up),
        with_steps: Some(steps),
        broad: false,
    };
    let cases = vec![
        case_with(201, JointKind::Masing { n: 3.0 }, &[], &o(false)),
        case_with(
            202,
            JointKind::Masing { n: 3.0 },
            &[EffectKind::CubicStiffness],
            &o(false),
        ),
        case_with(203, JointKind::Jenkins, &[EffectKind::SecondMode], &o(true)),
    ];
    eprintln!(
        "dwells: {} cases of 7 x 34 dwells, one at a time",
        cases.len()
    );
    let scores = run_cases(&cases, &dir, 1, Duration::from_secs(900));
    let mut rows = Vec::new();
    for s in &scores {
        println!("{}\n", describe(s));
        rows.push(json!({
            "case": s.name,
            "seconds": s.seconds,
            "truth": s.truth,
            "selected": s.selected,
            "passed": s.passed(),
            "failures": s.failures,
        }));
    }
    let max = scores.iter().map(|s| s.seconds).fold(0.0, f64::max);
    println!(
        "diagnose wall time per 238-dwell recording: {} (max {max:.1} s; target <= 30 s on 2 cores)",
        scores
            .iter()
            .map(|s| format!("{:.1} s", s.seconds))
            .collect::<Vec<_>>()
            .join(", ")
    );
    let report = json!({ "cases": rows, "seconds_max": max });
    let path = dir.join("report.json");
    std::fs::write(&path, serde_json::to_vec_pretty(&report).unwrap()).expect("report");
    println!("report: {}", path.display());
}
