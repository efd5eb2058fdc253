//! Helpers shared by the integration tests.
#![allow(dead_code)]

use std::path::PathBuf;

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
            eprintln!("SKIPPED: data set `{name}` not found (looked in $HYSTID_DATASETS or ../shared/datasets)");
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
