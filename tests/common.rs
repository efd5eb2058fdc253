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

/// The numbers of the README's line that starts with `start` (trimmed),
/// after `start`, in order, each with half a unit of its last printed digit:
/// what a figure pinned to the README may differ by from the value it was
/// printed from. `None` when no line starts so (a README edit the test must
/// follow).
pub fn readme_figures(start: &str) -> Option<Vec<(f64, f64)>> {
    let text =
        std::fs::read_to_string(Path::new(env!("CARGO_MANIFEST_DIR")).join("README.md")).ok()?;
    let line = text
        .lines()
        .find_map(|l| l.trim_start().strip_prefix(start))?;
    // tokens of the characters a figure is written with; words leave
    // tokens that do not parse (`-` of `->`, `e` of `degree`), and a token
    // glued to a word is part of its name (`k3`, `H1`, `m^3`)
    let out = line
        .split(|c: char| !(c.is_ascii_digit() || "+-.e".contains(c)))
        .filter(|t| {
            let at = t.as_ptr() as usize - line.as_ptr() as usize;
            !line[..at]
                .chars()
                .next_back()
                .is_some_and(|c| c.is_alphabetic() || c == '^' || c == '_')
        })
        .map(|t| t.trim_end_matches('.'))
        .filter_map(|t| {
            let value: f64 = t.parse().ok()?;
            let (mantissa, exponent) = t.split_once('e').unwrap_or((t, "0"));
            let decimals = mantissa.split_once('.').map_or(0, |(_, d)| d.len()) as i32;
            let exponent: i32 = exponent.parse().ok()?;
            Some((value, 0.5 * 10f64.powi(exponent - decimals)))
        })
        .collect();
    Some(out)
}

/// Asserts `value` prints as the README's `figure` (within half a unit of
/// its last digit, and a relative 1e-9 for the rounding of the value).
///
/// With `HYSTID_README_REPORT=1` a mismatch is printed instead, so that one
/// run lists every figure to re-pin after a change that moves them.
pub fn assert_readme_figure(what: &str, value: f64, figure: (f64, f64)) {
    let (shown, half) = figure;
    let holds = (value - shown).abs() <= half * (1.0 + 1e-9) + 1e-12 * shown.abs();
    let message =
        format!("README says {what} = {shown}, the test measures {value}: update the README");
    if !holds && std::env::var_os("HYSTID_README_REPORT").is_some() {
        eprintln!("{message}");
        return;
    }
    assert!(holds, "{message}");
}

/// The paper's jointed SDOF beside a hysteretic mode (240 Hz bare, 339 Hz
/// stuck, 50 kg, Jenkins 1.137e8 N/m slipping at 300 N): the README's
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
