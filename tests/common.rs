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
    let b = line.as_bytes();
    let mut out = Vec::new();
    let mut i = 0;
    while i < b.len() {
        let signed = (b[i] == b'+' || b[i] == b'-') && i + 1 < b.len() && b[i + 1].is_ascii_digit();
        // a digit that continues a word (e.g. `H1`, `kd2`) is not a figure
        let starts = (b[i].is_ascii_digit() || signed)
            && (i == 0 || !(b[i - 1].is_ascii_alphanumeric() || b[i - 1] == b'.'));
        if !starts {
            i += 1;
            continue;
        }
        let begin = i;
        i += signed as usize;
        while i < b.len() && b[i].is_ascii_digit() {
            i += 1;
        }
        let mut decimals = 0i32;
        if i + 1 < b.len() && b[i] == b'.' && b[i + 1].is_ascii_digit() {
            i += 1;
            while i < b.len() && b[i].is_ascii_digit() {
                i += 1;
                decimals += 1;
            }
        }
        let mut exponent = 0i32;
        let mantissa_end = i;
        if i + 1 < b.len() && b[i] == b'e' {
            let mut j = i + 1;
            if j < b.len() && (b[j] == b'+' || b[j] == b'-') {
                j += 1;
            }
            if j < b.len() && b[j].is_ascii_digit() {
                while j < b.len() && b[j].is_ascii_digit() {
                    j += 1;
                }
                exponent = line[mantissa_end + 1..j].parse().unwrap_or(0);
                i = j;
            }
        }
        if let Ok(v) = line[begin..i].parse::<f64>() {
            out.push((v, 0.5 * 10f64.powi(exponent - decimals)));
        }
    }
    Some(out)
}

/// Asserts `value` prints as the README's `figure` (within half a unit of
/// its last digit, and a relative 1e-9 for the rounding of the value).
pub fn assert_readme_figure(what: &str, value: f64, figure: (f64, f64)) {
    let (shown, half) = figure;
    assert!(
        (value - shown).abs() <= half * (1.0 + 1e-9) + 1e-12 * shown.abs(),
        "README says {what} = {shown}, the test measures {value}: update the README"
    );
}
