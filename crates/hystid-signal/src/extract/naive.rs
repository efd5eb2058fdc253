//! Slow reference implementations: direct-sum DFTs at the known harmonics.
//!
//! For tests and benchmarks only: `O(K·L)` per block with one `sin_cos` per
//! term, written the obvious way so that a fast path can be checked against
//! it (as RustFFT checks every algorithm against its naive `Dft`).

use super::DwellHarmonics;
use super::coherent::check_layout;
use super::estimator::{check_finite, h1_from_blocks};
use crate::error::{Error, Result};
use num_complex::Complex64;
use std::f64::consts::PI;

/// Harmonics `0..=max_harmonic` of one block holding exactly `periods`
/// periods: `Y_h = (2/L) Σ_n y[n] e^{−j2π h·periods·n/L}` (`1/L` for `h = 0`).
///
/// The angle is reduced modulo `L` in integers, so it is exact to rounding.
pub fn block_harmonics(block: &[f64], periods: usize, max_harmonic: usize) -> Vec<Complex64> {
    let len = block.len();
    (0..=max_harmonic)
        .map(|h| {
            let bin = h * periods;
            let mut acc = Complex64::default();
            for (n, &y) in block.iter().enumerate() {
                let idx = (bin * n) % len;
                let (s, c) = (-2.0 * PI * idx as f64 / len as f64).sin_cos();
                acc += Complex64::new(y * c, y * s);
            }
            let scale = if h == 0 { 1.0 } else { 2.0 } / len as f64;
            acc * scale
        })
        .collect()
}

/// [`super::HarmonicAnalyser::coherent`] by direct sums: same layout, same
/// estimator, same errors.
pub fn coherent(
    force: &[f64],
    response: &[f64],
    block_len: usize,
    periods_per_block: usize,
    max_harmonic: usize,
) -> Result<DwellHarmonics> {
    check_layout(block_len, periods_per_block, max_harmonic)?;
    if force.len() != response.len() {
        return Err(Error::input(
            "response",
            "must have as many samples as the force",
        ));
    }
    let blocks = force.len() / block_len;
    check_finite(&force[..blocks * block_len], "force")?;
    check_finite(&response[..blocks * block_len], "response")?;
    let mut fb = Vec::new();
    let mut yb = Vec::new();
    for b in 0..blocks {
        let r = b * block_len..(b + 1) * block_len;
        fb.extend(block_harmonics(
            &force[r.clone()],
            periods_per_block,
            max_harmonic,
        ));
        yb.extend(block_harmonics(
            &response[r],
            periods_per_block,
            max_harmonic,
        ));
    }
    h1_from_blocks(&fb, &yb, max_harmonic, "coherent dwell")
}
