//! A broadband (random) drive's FRFs compared: the measured response and
//! the replayed one, each by H1 against the measured reference over the
//! same Welch segments ([`crate::extract::welch_h1`]). A nonlinear model
//! under a random drive has no harmonics to compare; H1 is its best linear
//! approximation under that drive (Bendat & Piersol, *Random Data*,
//! section 6.1), the same for the measurement and the model when the
//! model is right.

use crate::error::Result;
use crate::extract::{DEFAULT_SEGMENT, welch_h1};
use num_complex::Complex64;
use serde::{Deserialize, Serialize};

/// Lines compared are those where the measured coherence is at least this:
/// below it, the measured H1 is mostly noise (its random error exceeds
/// 1/√(2 n_d) of |H|, Bendat & Piersol eq. 9.52).
pub const MIN_COHERENCE: f64 = 0.5;

/// Measured and replayed H1 of a broadband drive.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct H1Comparison {
    /// Samples per Welch segment (Hann, overlapping by half).
    pub segment: usize,
    /// Segments averaged.
    pub averages: usize,
    /// √(Σ|H_sim − H_meas|² / Σ|H_meas|²) over the lines compared.
    pub relative_error: f64,
    /// The measured coherence's mean over the lines compared.
    pub mean_coherence: f64,
    /// The lines compared, Hz: in the band (if given) with a measured
    /// coherence of at least [`MIN_COHERENCE`].
    pub frequency_hz: Vec<f64>,
    /// Measured H1 at those lines.
    pub measured: Vec<Complex64>,
    /// Replayed H1 at those lines.
    pub simulated: Vec<Complex64>,
    /// Measured coherence at those lines.
    pub coherence: Vec<f64>,
}

/// H1 of `measured` and `simulated` against `reference`, compared over the
/// lines of `band_hz` (all if `None`) the measurement resolves; `None` when
/// no line is resolved.
pub fn compare_h1(
    reference: &[f64],
    (measured, simulated): (&[f64], &[f64]),
    sample_rate_hz: f64,
    band_hz: Option<(f64, f64)>,
) -> Result<Option<H1Comparison>> {
    let w = welch_h1(
        reference,
        &[measured, simulated],
        sample_rate_hz,
        DEFAULT_SEGMENT,
    )?;
    let keep: Vec<usize> = (1..w.frequency_hz.len())
        .filter(|&l| {
            let f = w.frequency_hz[l];
            band_hz.is_none_or(|(lo, hi)| f >= lo && f <= hi) && w.coherence[0][l] >= MIN_COHERENCE
        })
        .collect();
    if keep.is_empty() {
        return Ok(None);
    }
    let pick = |v: &[Complex64]| keep.iter().map(|&l| v[l]).collect::<Vec<_>>();
    let (hm, hs) = (pick(&w.h1[0]), pick(&w.h1[1]));
    let (num, den) = hm.iter().zip(&hs).fold((0.0, 0.0), |(n, d), (m, s)| {
        (n + (s - m).norm_sqr(), d + m.norm_sqr())
    });
    let coherence: Vec<f64> = keep.iter().map(|&l| w.coherence[0][l]).collect();
    Ok(Some(H1Comparison {
        segment: w.segment,
        averages: w.averages,
        relative_error: (num / den).sqrt(),
        mean_coherence: coherence.iter().sum::<f64>() / coherence.len() as f64,
        frequency_hz: keep.iter().map(|&l| w.frequency_hz[l]).collect(),
        measured: hm,
        simulated: hs,
        coherence,
    }))
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::SeedableRng;
    use rand_distr::{Distribution, StandardNormal};

    /// A replay 10 % too strong at every line is 10 % off, and the band
    /// keeps only its lines.
    #[test]
    fn a_replay_ten_percent_strong_is_ten_percent_off() {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(7);
        let x: Vec<f64> = (0..1 << 15)
            .map(|_| StandardNormal.sample(&mut rng))
            .collect();
        let y: Vec<f64> = (0..x.len())
            .map(|i| x[i] - if i > 1 { 0.3 * x[i - 2] } else { 0.0 })
            .collect();
        let s: Vec<f64> = y.iter().map(|v| 1.1 * v).collect();
        let c = compare_h1(&x, (&y, &s), 8192.0, Some((100.0, 200.0)))
            .unwrap()
            .unwrap();
        assert!(
            (c.relative_error - 0.1).abs() < 1e-9,
            "{}",
            c.relative_error
        );
        assert_eq!(c.frequency_hz.len(), 51);
        assert!(c.frequency_hz.iter().all(|f| (100.0..=200.0).contains(f)));
    }
}
