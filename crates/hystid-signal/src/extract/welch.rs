//! The FRF of a broadband (random) drive by Welch averaging: the H1
//! estimator over Hann-windowed segments overlapping by half,
//! `H1(f) = G_xy(f) / G_xx(f)`, with the ordinary coherence
//! `γ²(f) = |G_xy|² / (G_xx G_yy)` (Bendat & Piersol, *Random Data*,
//! sections 9.2-9.3). Several responses to one reference share its
//! auto-spectrum, so a measured and a simulated response are compared at
//! the same lines from the same segments.

use crate::error::{Error, Result};
use num_complex::Complex64;
use realfft::RealFftPlanner;
use std::f64::consts::PI;

/// Samples per segment when the caller does not choose: fine enough to
/// resolve a lightly damped resonance on a record of a few seconds, coarse
/// enough for tens of averages.
pub const DEFAULT_SEGMENT: usize = 4096;

/// Fewest segments an estimate is made from: fewer leave the coherence at
/// one whatever the noise (a single segment's is one by construction).
pub const MIN_AVERAGES: usize = 4;

/// H1 estimates of several responses to one reference.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct WelchFrf {
    /// The lines, Hz (0 to Nyquist, `fs / segment` apart).
    pub frequency_hz: Vec<f64>,
    /// H1 of each response, at each line.
    pub h1: Vec<Vec<Complex64>>,
    /// Each response's ordinary coherence with the reference, at each line.
    pub coherence: Vec<Vec<f64>>,
    /// Samples per segment.
    pub segment: usize,
    /// Segments averaged.
    pub averages: usize,
}

/// H1 and coherence of `responses` to `reference`, sampled at
/// `sample_rate_hz`, from Hann segments of `segment` samples overlapping by
/// half (the segment is shortened to the record's length over
/// [`MIN_AVERAGES`] where the record is short). Lines where the reference
/// carries no power have H1 and coherence 0.
pub fn welch_h1(
    reference: &[f64],
    responses: &[&[f64]],
    sample_rate_hz: f64,
    segment: usize,
) -> Result<WelchFrf> {
    let n = responses
        .iter()
        .map(|r| r.len())
        .fold(reference.len(), usize::min);
    let segment = segment.min(2 * n / (MIN_AVERAGES + 1)) & !1;
    if segment < 16 {
        return Err(Error::input(
            "reference",
            format!(
                "{n} samples: too short for {MIN_AVERAGES} averaged segments of an H1 estimate"
            ),
        ));
    }
    let hop = segment / 2;
    let averages = (n - segment) / hop + 1;
    let window: Vec<f64> = (0..segment)
        .map(|i| 0.5 - 0.5 * (2.0 * PI * i as f64 / segment as f64).cos())
        .collect();
    let fft = RealFftPlanner::<f64>::new().plan_fft_forward(segment);
    let lines = segment / 2 + 1;
    let mut gxx = vec![0.0; lines];
    let mut gxy = vec![vec![Complex64::default(); lines]; responses.len()];
    let mut gyy = vec![vec![0.0; lines]; responses.len()];
    let spectrum = |x: &[f64], out: &mut Vec<Complex64>| -> Result<()> {
        let mean = x.iter().sum::<f64>() / x.len() as f64;
        let mut buf: Vec<f64> = x.iter().zip(&window).map(|(v, w)| (v - mean) * w).collect();
        out.resize(lines, Complex64::default());
        fft.process(&mut buf, out)
            .map_err(|e| Error::input("reference", format!("FFT: {e}")))
    };
    let (mut xs, mut ys) = (Vec::new(), Vec::new());
    for s in 0..averages {
        let range = s * hop..s * hop + segment;
        spectrum(&reference[range.clone()], &mut xs)?;
        for (l, x) in xs.iter().enumerate() {
            gxx[l] += x.norm_sqr();
        }
        for (r, y) in responses.iter().enumerate() {
            spectrum(&y[range.clone()], &mut ys)?;
            for l in 0..lines {
                gxy[r][l] += xs[l].conj() * ys[l];
                gyy[r][l] += ys[l].norm_sqr();
            }
        }
    }
    // a line the reference does not drive (below 1e-12 of its strongest)
    // holds no estimate, only rounding
    let floor = gxx.iter().cloned().fold(0.0, f64::max) * 1e-12;
    let h1 = gxy
        .iter()
        .map(|g| {
            g.iter()
                .zip(&gxx)
                .map(|(c, &x)| {
                    if x > floor {
                        c / x
                    } else {
                        Complex64::default()
                    }
                })
                .collect()
        })
        .collect();
    let coherence = gxy
        .iter()
        .zip(&gyy)
        .map(|(g, yy)| {
            (0..lines)
                .map(|l| {
                    let d = gxx[l] * yy[l];
                    if gxx[l] > floor && d > 0.0 {
                        (g[l].norm_sqr() / d).min(1.0)
                    } else {
                        0.0
                    }
                })
                .collect()
        })
        .collect();
    Ok(WelchFrf {
        frequency_hz: (0..lines)
            .map(|l| l as f64 * sample_rate_hz / segment as f64)
            .collect(),
        h1,
        coherence,
        segment,
        averages,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::SeedableRng;
    use rand_distr::{Distribution, StandardNormal};

    fn white(n: usize, seed: u64) -> Vec<f64> {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
        (0..n).map(|_| StandardNormal.sample(&mut rng)).collect()
    }

    /// A two-tap filter's H1 is its transfer function `1 + 0.5 e^{-jω}`,
    /// to the leakage of one sample's delay across a 1024-sample Hann
    /// segment (well below 1 %), with coherence one.
    #[test]
    fn the_h1_of_a_filter_is_its_transfer_function() {
        let x = white(1 << 16, 1);
        let y: Vec<f64> = (0..x.len())
            .map(|i| x[i] + if i > 0 { 0.5 * x[i - 1] } else { 0.0 })
            .collect();
        let w = welch_h1(&x, &[&y], 1000.0, 1024).unwrap();
        assert_eq!(w.averages, 127);
        for (l, h) in w.h1[0].iter().enumerate() {
            let omega = 2.0 * PI * l as f64 / 1024.0;
            let exact = Complex64::new(1.0, 0.0) + 0.5 * Complex64::from_polar(1.0, -omega);
            assert!(
                (h - exact).norm() < 0.01 * exact.norm(),
                "line {l}: {h} vs {exact}"
            );
            assert!(w.coherence[0][l] > 0.99, "line {l}");
        }
        assert!((w.frequency_hz[512] - 500.0).abs() < 1e-12);
    }

    /// Uncorrelated output noise of the same power as the response leaves
    /// H1 unbiased and the coherence at S/(S+N) = 1/2: the mean over the
    /// lines is 1/2 to within its scatter over 127 averages (about 0.01 a
    /// line, 0.001 over 500 lines; 0.02 leaves room for the bias of a
    /// finite average, (1-γ²)/n_d ≈ 0.004).
    #[test]
    fn output_noise_halves_the_coherence_and_leaves_h1_unbiased() {
        let x = white(1 << 16, 2);
        let noise = white(1 << 16, 3);
        let y: Vec<f64> = x
            .iter()
            .zip(&noise)
            .map(|(a, b)| 2.0 * a + 2.0 * b)
            .collect();
        let w = welch_h1(&x, &[&y], 1.0, 1024).unwrap();
        let inner = 1..512;
        let mean_coherence = w.coherence[0][inner.clone()].iter().sum::<f64>() / 511.0;
        assert!((mean_coherence - 0.5).abs() < 0.02, "{mean_coherence}");
        let mean_h = w.h1[0][inner].iter().sum::<Complex64>() / 511.0;
        assert!(
            (mean_h - Complex64::new(2.0, 0.0)).norm() < 0.02,
            "{mean_h}"
        );
    }

    #[test]
    fn a_record_too_short_to_average_is_refused() {
        let x = white(20, 4);
        let e = welch_h1(&x, &[&x], 1.0, 1024).unwrap_err();
        assert!(e.to_string().contains("too short"), "{e}");
    }
}
