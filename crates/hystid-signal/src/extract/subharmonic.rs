//! Subharmonic response of a dwell: content at `f/2` or `f/3` (and their odd
//! multiples) that a response periodic at the drive's period cannot hold.
//!
//! A one-sided contact (a bilinear stiffness, a clearance) driven near twice
//! its natural frequency can settle into a period-doubled response, the
//! principal subharmonic resonance of a piecewise-linear oscillator (Shaw &
//! Holmes, J. Sound Vib. 90(1), 1983). Harmonic balance at the drive's period
//! has no term for it, so such a dwell says nothing a harmonic-balance fit
//! can use: [`crate::fit::usable_point`] leaves it out, and a time-domain
//! fit, which simulates the period-doubling, keeps it.
//!
//! The test: the response is fitted by least squares with a mean and the
//! harmonics of `f/q` over blocks of whole periods of `f/q`, the phase
//! counted from the dwell's first sample (a settled subharmonic keeps its
//! phase from block to block). The lines that are not multiples of `q` are
//! the subharmonic ones; their block means against their standard error
//! (the block scatter) say whether they stand above the noise, and their
//! amplitude against the fundamental's says whether they matter.

use super::lsq::HarmonicLsq;
use super::noncoherent::{block_bounds, fit_range, whole_periods};
use num_complex::Complex64;
use serde::{Deserialize, Serialize};

/// Subharmonic lines smaller than this fraction of the response's
/// fundamental are left to the fit: a harmonic-balance model misses them
/// by less than the noise of a typical stepped-sine test (a few %).
pub const SUBHARMONIC_RATIO: f64 = 0.05;

/// Subharmonic lines must stand this many standard errors above the block
/// scatter: noise alone measures about 1 (the tests check 400 dwells).
pub const SUBHARMONIC_SIGNIFICANCE: f64 = 5.0;

/// A dwell's response at a fraction of the drive frequency.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Subharmonic {
    /// `q`: the response repeats every `q` drive periods (2 or 3).
    pub order: usize,
    /// RMS amplitude of the subharmonic lines over the fundamental's.
    pub ratio: f64,
    /// That amplitude over its standard error.
    pub significance: f64,
}

/// The strongest subharmonic of `response` (a settled dwell at `frequency_hz`)
/// of order 2 or 3 that is both significant and at least
/// [`SUBHARMONIC_RATIO`] of the fundamental; `None` when there is none or
/// the dwell is too short to tell (fewer than 2 periods of `f/q`).
pub fn subharmonic(
    response: &[f64],
    sample_rate_hz: f64,
    frequency_hz: f64,
    max_harmonic: usize,
    blocks: usize,
) -> Option<Subharmonic> {
    [2, 3]
        .into_iter()
        .filter_map(|q| {
            of_order(
                response,
                sample_rate_hz,
                frequency_hz,
                q,
                max_harmonic,
                blocks,
            )
        })
        .filter(|s| s.ratio >= SUBHARMONIC_RATIO && s.significance >= SUBHARMONIC_SIGNIFICANCE)
        .max_by(|a, b| a.ratio.total_cmp(&b.ratio))
}

/// The subharmonic lines of order `q`, measured whatever their size.
pub(crate) fn of_order(
    response: &[f64],
    sample_rate_hz: f64,
    frequency_hz: f64,
    q: usize,
    max_harmonic: usize,
    blocks: usize,
) -> Option<Subharmonic> {
    let base = frequency_hz / q as f64;
    let periods = whole_periods(response.len(), sample_rate_hz, base);
    let blocks = blocks.min(periods);
    // lines of f/q up to the drive's highest harmonic, below 0.45·fs
    let top = (q * max_harmonic.max(1)).min((0.45 * sample_rate_hz / base).floor() as usize);
    if blocks < 2 || top < q {
        return None;
    }
    let bounds = block_bounds(periods, sample_rate_hz, base, blocks);
    let mut lsq = HarmonicLsq::new(top, 1);
    let width = top + 1;
    let mut lines = vec![Complex64::default(); blocks * width];
    for b in 0..blocks {
        let range = bounds[b]..bounds[b + 1];
        let out = &mut lines[b * width..][..width];
        if range.len() < lsq.unknowns()
            || !fit_range(
                &mut lsq,
                &[response],
                range,
                base / sample_rate_hz,
                &mut [out],
            )
        {
            return None;
        }
    }
    let (mut signal, mut noise) = (0.0, 0.0);
    let mut fundamental = 0.0;
    for j in 1..=top {
        let at = |b: usize| lines[b * width + j];
        let mean = (0..blocks).map(at).sum::<Complex64>() / blocks as f64;
        if j == q {
            fundamental = mean.norm();
        } else if j % q != 0 {
            let scatter: f64 = (0..blocks).map(|b| (at(b) - mean).norm_sqr()).sum();
            signal += mean.norm_sqr();
            noise += scatter / (blocks * (blocks - 1)) as f64;
        }
    }
    (fundamental > 0.0).then(|| Subharmonic {
        order: q,
        ratio: signal.sqrt() / fundamental,
        significance: (signal / noise.max(f64::MIN_POSITIVE)).sqrt(),
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f64::consts::TAU;

    fn noise(n: usize, seed: u64, sigma: f64) -> Vec<f64> {
        use rand::SeedableRng;
        use rand_distr::{Distribution, Normal};
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
        let d = Normal::new(0.0, sigma).unwrap();
        (0..n).map(|_| d.sample(&mut rng)).collect()
    }

    /// A period-2 response at a non-coherent rate: the ratio is the
    /// amplitude put in, and the drive's own harmonics are not counted.
    #[test]
    fn a_period_doubled_response_is_measured_at_its_ratio() {
        let (fs, f) = (10_000.0, 123.4);
        let e = noise(20_000, 3, 0.01);
        let y: Vec<f64> = (0..20_000)
            .map(|n| {
                let t = n as f64 / fs;
                (TAU * f * t).sin()
                    + 0.3 * (TAU * f * t).cos().powi(3)
                    + 0.4 * (TAU * f / 2.0 * t + 0.7).cos()
                    + 0.1 * (TAU * 1.5 * f * t).sin()
                    + e[n]
            })
            .collect();
        let s = subharmonic(&y, fs, f, 5, 8).expect("found");
        assert_eq!(s.order, 2);
        // lines 0.4 and 0.1 against the fundamental |1 − 0.225j| (cos³'s
        // first harmonic is 3/4 of its amplitude, in quadrature)
        let expected = (0.4f64.powi(2) + 0.1f64.powi(2)).sqrt() / 1.0f64.hypot(0.225);
        assert!((s.ratio - expected).abs() < 0.01 * expected, "{s:?}");
        assert!(s.significance > 100.0, "{s:?}");
    }

    /// Noise and the drive's harmonics alone: measured, small, and not named.
    #[test]
    fn noise_and_harmonics_are_not_a_subharmonic() {
        let (fs, f) = (10_000.0, 97.0);
        let e = noise(40_000, 5, 0.3);
        let y: Vec<f64> = (0..40_000)
            .map(|n| {
                let t = n as f64 / fs;
                (TAU * f * t).sin() + 0.2 * (TAU * 3.0 * f * t).sin() + e[n]
            })
            .collect();
        assert_eq!(subharmonic(&y, fs, f, 5, 8), None);
        let s = of_order(&y, fs, f, 3, 5, 8).unwrap();
        assert!(s.significance < SUBHARMONIC_SIGNIFICANCE, "{s:?}");
        assert!(s.ratio < 0.02, "{s:?}");
    }

    /// The significance of noise: 200 short dwells (16 periods, the
    /// shortest a found dwell keeps), each tested at both orders. Its
    /// statistic is near an F ratio of 2L over 2L(B−1) degrees of freedom
    /// (L lines, B blocks): mean about 1, and 4 is far in its tail.
    #[test]
    fn noise_alone_stays_near_one_standard_error() {
        let (fs, f) = (4_096.0, 101.3);
        let n = (16.0 * fs / f) as usize + 1;
        let mut all = Vec::new();
        for seed in 0..200 {
            let e = noise(n, 100 + seed, 0.5);
            let y: Vec<f64> = (0..n)
                .map(|i| (TAU * f * i as f64 / fs).sin() + e[i])
                .collect();
            for q in [2, 3] {
                all.push(of_order(&y, fs, f, q, 5, 8).unwrap().significance);
            }
        }
        let mean = all.iter().sum::<f64>() / all.len() as f64;
        let max = all.iter().copied().fold(0.0, f64::max);
        assert!((0.8..1.5).contains(&mean), "mean {mean}");
        assert!(max < 4.0, "max {max}");
    }
}
