//! Helpers shared by the integration tests.
#![allow(dead_code)]

use std::path::{Path, PathBuf};

/// The shared data sets folder, if present: `$HYSTID_DATASETS`, else
/// `../shared/datasets` next to the crate.
pub fn datasets() -> Option<PathBuf> {
    let dir = std::env::var_os("HYSTID_DATASETS")
        .map(PathBuf::from)
        .unwrap_or_else(|| PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../shared/datasets"));
    dir.is_dir().then_some(dir)
}

/// A data set's folder, or `None` after printing why the test is skipped.
pub fn dataset(name: &str) -> Option<PathBuf> {
    match datasets().map(|d| d.join(name)) {
        Some(p) if p.is_dir() => Some(p),
        _ => {
            eprintln!(
                "SKIPPED: data set `{name}` not found (looked in $HYSTID_DATASETS or ../shared/datasets)"
            );
            None
        }
    }
}

/// Largest relative difference of two complex or real sequences, with the
/// index where it occurs (for readable failures).
pub fn worst_relative(a: &[f64], b: &[f64]) -> (usize, f64) {
    let mut worst = (0, 0.0);
    for (i, (x, y)) in a.iter().zip(b).enumerate() {
        let d = (x - y).abs() / y.abs().max(1e-300);
        if d > worst.1 {
            worst = (i, d);
        }
    }
    worst
}

/// The figures pinned under `key` in `docs/validation/figures.json`, each
/// with half a unit of its last printed digit: what a measured value may
/// differ by from the figure the validation pages print. `None` when no
/// entry has that key (a figure the test must have written first).
///
/// The validation pages are generated from that file (`docs_are_current`),
/// so the figures a test pins are the figures a reader sees; the prose
/// around them can be edited freely.
pub fn pinned_figures(key: &str) -> Option<Vec<(f64, f64)>> {
    let figures = pinned_table();
    let printed = figures.get(key)?.as_array()?;
    Some(
        printed
            .iter()
            .map(|p| printed_figure(p.as_str().expect("figures are printed as strings")))
            .collect(),
    )
}

/// `docs/validation/figures.json`: the key of each pinned line, and its
/// figures as printed.
pub fn pinned_table() -> serde_json::Map<String, serde_json::Value> {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("docs/validation/figures.json");
    let text = std::fs::read_to_string(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    serde_json::from_str(&text).unwrap_or_else(|e| panic!("{}: {e}", path.display()))
}

/// A printed figure's value and half a unit of its last digit.
pub fn printed_figure(t: &str) -> (f64, f64) {
    let value: f64 = t
        .parse()
        .unwrap_or_else(|_| panic!("`{t}` is not a figure"));
    let (mantissa, exponent) = t.split_once('e').unwrap_or((t, "0"));
    let decimals = mantissa.split_once('.').map_or(0, |(_, d)| d.len()) as i32;
    let exponent: i32 = exponent.parse().expect("an integer exponent");
    (value, 0.5 * 10f64.powi(exponent - decimals))
}

/// Asserts `value` prints as the pinned `figure` (within half a unit of
/// its last digit, and a relative 1e-9 for the rounding of the value).
///
/// With `HYSTID_FIGURES_REPORT=1` a mismatch is printed instead, so that one
/// run lists every figure to re-pin after a change that moves them.
pub fn assert_pinned_figure(what: &str, value: f64, figure: (f64, f64)) {
    let (shown, half) = figure;
    let holds = (value - shown).abs() <= half * (1.0 + 1e-9) + 1e-12 * shown.abs();
    let message = format!(
        "docs/validation/figures.json pins {what} = {shown}, the test measures {value}: \
         re-pin it there and regenerate the pages"
    );
    if !holds && std::env::var_os("HYSTID_FIGURES_REPORT").is_some() {
        eprintln!("{message}");
        return;
    }
    assert!(holds, "{message}");
}

/// The paper's jointed SDOF beside a hysteretic mode (240 Hz bare, 339 Hz
/// stuck, 50 kg, Jenkins 1.137e8 N/m slipping at 300 N): the validation pages'
/// virtual test of the hysteretic mode (its `--check-hb` and `run` lines).
pub const HYSTERETIC_MODE_TEST: &str = r#"
[[modes]]
frequency_hz = 159.1549430918953
damping_ratio = 0.01
modal_mass = 10.0
[[modes]]
frequency_hz = 240.0
damping_ratio = 0.01
modal_mass = 50.0
joint = { kind = "jenkins", kd = 1.137e8, fd = 300.0 }
[joint]
kind = "jenkins"
kd = 2.4e7
fd = 246.048
[test]
frequencies_hz = { start = 100.0, stop = 350.0, count = 21 }
levels_n = [5.0, 200.0, 1000.0, 30000.0]
noise = 0.10
seed = 1
measure_periods = 16
"#;

/// `force` and `response` sampled together at `fs`, as channels 0 and 1 of
/// the recording the sweep stages read.
pub fn pair<'a>(
    force: &'a [f64],
    response: &'a [f64],
    fs: f64,
) -> hystid::signals::InMemoryFrames<'a> {
    hystid::signals::InMemoryFrames::pair(force.into(), response.into(), fs).unwrap()
}
