//! The H1 estimator over blocks and its standard error, shared by the
//! coherent (FFT) and non-coherent (least-squares) extractions.

use super::DwellHarmonics;
use crate::error::{Error, Result};
use crate::harmonics::referred_to_force;
use num_complex::Complex64;

/// Checks that every sample is finite; the error names the signal and the
/// first bad sample.
pub(crate) fn check_finite(signal: &[f64], what: &str) -> Result<()> {
    match signal.iter().position(|v| !v.is_finite()) {
        None => Ok(()),
        Some(i) => Err(Error::input(
            format!("{what}[{i}]"),
            format!("samples must be finite, got {}", signal[i]),
        )),
    }
}

/// Combines per-block harmonics into [`DwellHarmonics`].
///
/// `force` and `response` hold `blocks × (K+1)` harmonics, block-major. The
/// estimator is H1: `H_k = Σ_b Y'_bk F_b1* / Σ_b |F_b1|²`, with `Y'_bk` block
/// `b`'s response harmonic referred to its force phase
/// ([`referred_to_force`]). Its standard error
/// is the RMS of the complex error estimated from the block-to-block scatter
/// of `H_bk = Y_bk / F_b1`: `sqrt(Σ_b |H_bk − H_k|² / (B(B−1)))` (the
/// standard error of a mean of `B` independent block estimates; exact for the
/// H1 estimator when the force blocks have equal magnitude, as in a
/// stepped-sine dwell). `what` names the dwell in errors.
pub(crate) fn h1_from_blocks(
    force: &[Complex64],
    response: &[Complex64],
    max_harmonic: usize,
    what: &str,
) -> Result<DwellHarmonics> {
    let width = max_harmonic + 1;
    let blocks = force.len() / width;
    debug_assert_eq!(force.len(), response.len());
    if blocks < 2 {
        return Err(Error::input(
            what,
            format!(
                "{blocks} block(s): at least 2 blocks are needed to estimate the standard error \
                 from the block-to-block scatter"
            ),
        ));
    }
    // the force fundamental must be clearly present in every block
    let largest = force.iter().map(|f| f.norm()).fold(0.0, f64::max);
    for b in 0..blocks {
        let f1 = force[b * width + 1].norm();
        if f1.is_nan() || f1 <= 1e-9 * largest || f1 == 0.0 {
            return Err(Error::input(
                format!("{what}: force block {b}"),
                format!(
                    "the force fundamental is zero (|F_1| = {f1:e} against {largest:e} for the \
                     largest force harmonic): no force at this frequency, or the wrong frequency"
                ),
            ));
        }
    }
    let mut mean_f = vec![Complex64::default(); width];
    let mut mean_y = vec![Complex64::default(); width];
    let mut cross = vec![Complex64::default(); width];
    let mut power = 0.0;
    for b in 0..blocks {
        let f1 = force[b * width + 1];
        power += f1.norm_sqr();
        for k in 0..width {
            mean_f[k] += force[b * width + k];
            mean_y[k] += response[b * width + k];
            // referred to this block's force phase (the FRF convention of
            // `crate::harmonics`): H2, H3, ... do not depend on where the
            // block starts
            cross[k] += referred_to_force(response[b * width + k], k, f1) * f1.conj();
        }
    }
    let inv_b = 1.0 / blocks as f64;
    mean_f.iter_mut().for_each(|v| *v *= inv_b);
    mean_y.iter_mut().for_each(|v| *v *= inv_b);
    let h: Vec<Complex64> = cross.iter().map(|c| c / power).collect();
    let mut scatter = vec![0.0; width];
    for b in 0..blocks {
        let f1 = force[b * width + 1];
        for k in 0..width {
            scatter[k] +=
                (referred_to_force(response[b * width + k], k, f1) / f1 - h[k]).norm_sqr();
        }
    }
    let std_error = scatter
        .iter()
        .map(|s| (s / (blocks * (blocks - 1)) as f64).sqrt())
        .collect();
    Ok(DwellHarmonics {
        force: mean_f,
        response: mean_y,
        h,
        std_error,
        blocks,
    })
}
