//! Non-coherent extraction for real recordings: a fixed sample rate and an
//! arbitrary excitation frequency, so a period is not a whole number of
//! samples and FFT bins do not fall on the harmonics.
//!
//! The harmonics are fitted by least squares (a mean plus `cos/sin(h·2πft)`,
//! `h = 1..K`) over blocks of whole periods, which is exact for a periodic
//! signal whatever the number of samples per period (the "sine-fit" of IEEE
//! Std 1057 extended to harmonics), then combined by the same H1 estimator as
//! the coherent path. The frequency itself can be estimated from the
//! reference channel ([`estimate_frequency`]).

use super::DwellHarmonics;
use super::estimator::{check_finite, h1_from_blocks};
use super::lsq::HarmonicLsq;
use crate::error::{Error, Result};
use num_complex::Complex64;
use realfft::RealFftPlanner;
use std::f64::consts::PI;

/// Phase `2π·frac(n·f/fs)` of sample `n`, reduced before the multiplication
/// by 2π so that long records keep full precision.
#[inline]
pub(crate) fn sample_phase(n: usize, cycles_per_sample: f64) -> f64 {
    2.0 * PI * (n as f64 * cycles_per_sample).fract()
}

pub(crate) fn check_rate_and_frequency(
    sample_rate_hz: f64,
    frequency_hz: f64,
    max_harmonic: usize,
    what: &str,
) -> Result<()> {
    if !(sample_rate_hz.is_finite() && sample_rate_hz > 0.0) {
        return Err(Error::input(
            "sample_rate_hz",
            format!("must be finite and > 0, got {sample_rate_hz}"),
        ));
    }
    if !(frequency_hz.is_finite() && frequency_hz > 0.0) {
        return Err(Error::input(
            format!("{what}: frequency_hz"),
            format!("must be finite and > 0, got {frequency_hz}"),
        ));
    }
    if max_harmonic == 0 {
        return Err(Error::input(
            "max_harmonic",
            "must be at least 1: the FRF is taken relative to the force fundamental",
        ));
    }
    if 2.0 * max_harmonic as f64 * frequency_hz >= sample_rate_hz {
        return Err(Error::input(
            format!("{what}: max_harmonic"),
            format!(
                "harmonic {max_harmonic} of {frequency_hz} Hz is at {} Hz, at or above the \
                 Nyquist frequency {} Hz; at most harmonic {} is resolvable",
                max_harmonic as f64 * frequency_hz,
                sample_rate_hz / 2.0,
                ((sample_rate_hz / 2.0 / frequency_hz).ceil() as usize).saturating_sub(1)
            ),
        ));
    }
    Ok(())
}

/// Whole periods of `frequency_hz` in `len` samples (a hair of tolerance so
/// that an exact whole number is not lost to rounding).
pub(crate) fn whole_periods(len: usize, sample_rate_hz: f64, frequency_hz: f64) -> usize {
    (len as f64 * frequency_hz / sample_rate_hz * (1.0 + 1e-12)).floor() as usize
}

/// Harmonics `0..=K` of each channel over samples `range` of the record, with
/// the phase counted from sample 0 of the record (so blocks share one time
/// origin). `false` if the fit is singular.
pub(crate) fn fit_range(
    lsq: &mut HarmonicLsq,
    channels: &[&[f64]],
    range: std::ops::Range<usize>,
    cycles_per_sample: f64,
    out: &mut [&mut [Complex64]],
) -> bool {
    lsq.reset();
    let mut values = [0.0; 4];
    let nch = channels.len();
    for n in range {
        for (v, c) in values.iter_mut().zip(channels) {
            *v = c[n];
        }
        lsq.add(sample_phase(n, cycles_per_sample), &values[..nch]);
    }
    if !lsq.solve() {
        return false;
    }
    for (c, o) in out.iter_mut().enumerate() {
        lsq.harmonics(c, o);
    }
    true
}

/// Block boundaries: `blocks` equal parts of the largest window of whole
/// periods (whole periods each when the period count divides evenly).
pub(crate) fn block_bounds(
    periods: usize,
    sample_rate_hz: f64,
    frequency_hz: f64,
    blocks: usize,
) -> Vec<usize> {
    let period = sample_rate_hz / frequency_hz;
    (0..=blocks)
        .map(|b| ((b * periods) as f64 * period / blocks as f64 + 1e-9).floor() as usize)
        .collect()
}

/// Harmonics and H1 FRFs of one dwell at a known frequency, for records that
/// are not coherently sampled.
///
/// Uses the largest window of whole periods from the start of the record
/// (`floor(periods · fs/f)` samples) split into `blocks` equal parts (of
/// whole periods when the period count divides evenly), fits a mean and
/// harmonics `1..=K` by least squares per block with the phase `2πf·n/fs`
/// counted from the first sample, and combines the blocks with the H1
/// estimator and the block-scatter standard error of
/// [`DwellHarmonics::std_error`].
///
/// Errors: bad rate or frequency, harmonic `K` at or above Nyquist, lengths
/// differ, a non-finite sample, fewer than 2 blocks or fewer whole periods
/// than blocks, zero force fundamental.
pub fn noncoherent(
    force: &[f64],
    response: &[f64],
    sample_rate_hz: f64,
    frequency_hz: f64,
    max_harmonic: usize,
    blocks: usize,
) -> Result<DwellHarmonics> {
    noncoherent_named(
        force,
        response,
        sample_rate_hz,
        frequency_hz,
        max_harmonic,
        blocks,
        "dwell",
    )
}

/// [`noncoherent`] with `what` naming the dwell in errors.
pub(crate) fn noncoherent_named(
    force: &[f64],
    response: &[f64],
    sample_rate_hz: f64,
    frequency_hz: f64,
    max_harmonic: usize,
    blocks: usize,
    what: &str,
) -> Result<DwellHarmonics> {
    check_rate_and_frequency(sample_rate_hz, frequency_hz, max_harmonic, what)?;
    super::check_paired(force, response, format!("{what}: response"))?;
    if blocks < 2 {
        return Err(Error::input(
            format!("{what}: blocks"),
            format!(
                "{blocks}: at least 2 blocks are needed to estimate the standard error from \
                 the block-to-block scatter"
            ),
        ));
    }
    let periods = whole_periods(force.len(), sample_rate_hz, frequency_hz);
    if periods < blocks {
        return Err(Error::input(
            what,
            format!(
                "{} samples hold {periods} whole period(s) of {frequency_hz} Hz at {sample_rate_hz} \
                 Hz: at least one period per block ({blocks}) is needed",
                force.len()
            ),
        ));
    }
    let bounds = block_bounds(periods, sample_rate_hz, frequency_hz, blocks);
    let used = bounds[blocks];
    check_finite(&force[..used], &format!("{what}: force"))?;
    check_finite(&response[..used], &format!("{what}: response"))?;
    let width = max_harmonic + 1;
    let mut fb = vec![Complex64::default(); blocks * width];
    let mut yb = vec![Complex64::default(); blocks * width];
    let mut lsq = HarmonicLsq::new(max_harmonic, 2);
    let cps = frequency_hz / sample_rate_hz;
    for b in 0..blocks {
        let range = bounds[b]..bounds[b + 1];
        let (f, y) = (&mut fb[b * width..][..width], &mut yb[b * width..][..width]);
        if range.len() < lsq.unknowns()
            || !fit_range(&mut lsq, &[force, response], range, cps, &mut [f, y])
        {
            return Err(Error::input(
                format!("{what}: block {b}"),
                format!(
                    "the least-squares fit of harmonics 0..={max_harmonic} is singular over \
                     samples {}..{} (too few samples per block?)",
                    bounds[b],
                    bounds[b + 1]
                ),
            ));
        }
    }
    h1_from_blocks(&fb, &yb, max_harmonic, what)
}

/// Estimates the frequency of a (nearly) sinusoidal signal, in Hz.
///
/// A Hann-windowed, zero-padded FFT locates the peak and a Gaussian
/// interpolation of the log magnitudes refines it to a small fraction of a
/// bin; Gauss–Newton on the frequency and the coefficients of a mean plus
/// harmonics 1–3 (those below 0.45·fs) then converges to the least-squares
/// frequency, the maximum-likelihood estimate under white noise (exact to
/// rounding on a clean periodic signal).
///
/// Errors: a non-finite sample, fewer than 16 samples, a constant signal, or
/// fewer than 2 periods in the record.
pub fn estimate_frequency(signal: &[f64], sample_rate_hz: f64) -> Result<f64> {
    estimate_frequency_named(signal, sample_rate_hz, "signal")
}

pub(crate) fn estimate_frequency_named(
    signal: &[f64],
    sample_rate_hz: f64,
    what: &str,
) -> Result<f64> {
    if !(sample_rate_hz.is_finite() && sample_rate_hz > 0.0) {
        return Err(Error::input(
            "sample_rate_hz",
            format!("must be finite and > 0, got {sample_rate_hz}"),
        ));
    }
    let n = signal.len();
    if n < 16 {
        return Err(Error::input(
            what,
            format!("{n} samples: at least 16 are needed to estimate a frequency"),
        ));
    }
    check_finite(signal, what)?;
    let coarse = coarse_frequency(signal, sample_rate_hz, what)?;
    refine_frequency(signal, sample_rate_hz, coarse, what)
}

/// FFT peak with Gaussian interpolation (Hann window, 4× zero padding).
fn coarse_frequency(signal: &[f64], sample_rate_hz: f64, what: &str) -> Result<f64> {
    let n = signal.len();
    let nfft = (4 * n).next_power_of_two().max(64);
    let mean = signal.iter().sum::<f64>() / n as f64;
    let mut planner = RealFftPlanner::<f64>::new();
    let plan = planner.plan_fft_forward(nfft);
    let mut input = plan.make_input_vec();
    let mut spectrum = plan.make_output_vec();
    for (i, (a, s)) in input.iter_mut().zip(signal).enumerate() {
        let w = 0.5 - 0.5 * (2.0 * PI * (i as f64 + 0.5) / n as f64).cos();
        *a = (s - mean) * w;
    }
    plan.process(&mut input, &mut spectrum)
        .map_err(|e| Error::input(what, e.to_string()))?;
    let mag: Vec<f64> = spectrum.iter().map(|c| c.norm()).collect();
    // skip the Hann main lobe around DC (2 bins of the unpadded record)
    let skip = 2 * nfft / n + 1;
    let (k, peak) =
        mag.iter()
            .enumerate()
            .take(nfft / 2)
            .skip(skip)
            .fold(
                (0, 0.0),
                |acc, (i, &m)| if m > acc.1 { (i, m) } else { acc },
            );
    if peak.is_nan() || peak <= 0.0 || k == 0 {
        return Err(Error::input(
            what,
            "no spectral peak above DC: the signal is constant or shorter than 2 periods",
        ));
    }
    let (a, b, c) = (
        mag[k - 1].max(1e-300).ln(),
        peak.ln(),
        mag[k + 1].max(1e-300).ln(),
    );
    let denom = 2.0 * b - a - c;
    let delta = if denom > 0.0 {
        0.5 * (c - a) / denom
    } else {
        0.0
    };
    let f = (k as f64 + delta.clamp(-0.5, 0.5)) * sample_rate_hz / nfft as f64;
    if f * n as f64 / sample_rate_hz < 2.0 {
        return Err(Error::input(
            what,
            format!(
                "the record holds {:.2} periods of its peak frequency {f:.6} Hz: at least 2 are \
                 needed",
                f * n as f64 / sample_rate_hz
            ),
        ));
    }
    Ok(f)
}

/// Gauss–Newton on `(c, ν)` of `y = c_0 + Σ a_h cos(hνu) + b_h sin(hνu)` with
/// the time scaled to `u ∈ [−1, 1]` for conditioning.
fn refine_frequency(signal: &[f64], sample_rate_hz: f64, f0: f64, what: &str) -> Result<f64> {
    let n = signal.len();
    let half = 0.5 * (n - 1) as f64; // samples from the centre to an end
    let k = (1..=3)
        .take_while(|&h| h as f64 * f0 < 0.45 * sample_rate_hz)
        .last()
        .unwrap_or(1);
    let m = 2 * k + 1;
    let p = m + 1;
    let u = |i: usize| (i as f64 - half) / half;
    // ν: phase per unit u
    let mut nu = 2.0 * PI * f0 * half / sample_rate_hz;
    // linear fit at the starting frequency
    let mut lsq = HarmonicLsq::new(k, 1);
    for (i, &y) in signal.iter().enumerate() {
        lsq.add(nu * u(i), &[y]);
    }
    if !lsq.solve() {
        return Err(Error::input(what, "singular harmonic fit at the FFT peak"));
    }
    let mut coef = lsq.coefficients(0).to_vec();
    let mut basis = vec![0.0; m];
    let mut jtj = vec![0.0; p * p];
    let mut jtr = vec![0.0; p];
    let mut row = vec![0.0; p];
    let mut cost = f64::INFINITY;
    let mut previous_nu = nu;
    for _ in 0..40 {
        jtj.iter_mut().for_each(|v| *v = 0.0);
        jtr.iter_mut().for_each(|v| *v = 0.0);
        let mut rss = 0.0;
        for (i, &y) in signal.iter().enumerate() {
            let ui = u(i);
            let th = nu * ui;
            let (s1, c1) = th.sin_cos();
            basis[0] = 1.0;
            let (mut c, mut s) = (c1, s1);
            let mut dnu = 0.0;
            for h in 1..=k {
                basis[2 * h - 1] = c;
                basis[2 * h] = s;
                dnu += h as f64 * ui * (-coef[2 * h - 1] * s + coef[2 * h] * c);
                (c, s) = (c * c1 - s * s1, s * c1 + c * s1);
            }
            let model: f64 = basis.iter().zip(&coef).map(|(b, c)| b * c).sum();
            let r = y - model;
            rss += r * r;
            row[..m].copy_from_slice(&basis);
            row[m] = dnu;
            for a in 0..p {
                jtr[a] += row[a] * r;
                for b in a..p {
                    jtj[a * p + b] += row[a] * row[b];
                }
            }
        }
        if rss > cost * (1.0 + 1e-12) && cost.is_finite() {
            // a step that increased the residual: Gauss–Newton is in its
            // quadratic basin after the FFT start, so this only happens at
            // convergence (rounding); keep the better point and stop
            nu = previous_nu;
            break;
        }
        cost = rss;
        previous_nu = nu;
        for a in 0..p {
            for b in 0..a {
                jtj[a * p + b] = jtj[b * p + a];
            }
        }
        let step = match solve_dense(&mut jtj, &mut jtr, p) {
            Some(s) => s,
            None => return Err(Error::input(what, "singular frequency refinement")),
        };
        for (c, d) in coef.iter_mut().zip(&step) {
            *c += d;
        }
        nu += step[m];
        if step[m].abs() <= 1e-15 * nu.abs() {
            break;
        }
    }
    let f = nu * sample_rate_hz / (2.0 * PI * half);
    if !(f.is_finite() && f > 0.0) || (f - f0).abs() > 2.0 * sample_rate_hz / n as f64 {
        return Err(Error::NotConverged {
            stage: "frequency estimate",
            reason: format!(
                "{what}: the least-squares frequency {f} Hz left the FFT peak {f0} Hz by more \
                 than 2 bins"
            ),
        });
    }
    Ok(f)
}

/// Gaussian elimination with partial pivoting on a small dense system
/// (`a` is `n × n` row-major, destroyed); `None` when singular.
pub(crate) fn solve_dense(a: &mut [f64], b: &mut [f64], n: usize) -> Option<Vec<f64>> {
    let scale = a.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    for col in 0..n {
        let piv =
            (col..n).max_by(|&i, &j| a[i * n + col].abs().total_cmp(&a[j * n + col].abs()))?;
        let pivot = a[piv * n + col].abs();
        if pivot.is_nan() || pivot <= 1e-300 + 1e-15 * scale {
            return None;
        }
        if piv != col {
            for j in 0..n {
                a.swap(piv * n + j, col * n + j);
            }
            b.swap(piv, col);
        }
        for i in col + 1..n {
            let f = a[i * n + col] / a[col * n + col];
            if f != 0.0 {
                for j in col..n {
                    a[i * n + j] -= f * a[col * n + j];
                }
                b[i] -= f * b[col];
            }
        }
    }
    let mut x = vec![0.0; n];
    for i in (0..n).rev() {
        let mut v = b[i];
        for j in i + 1..n {
            v -= a[i * n + j] * x[j];
        }
        x[i] = v / a[i * n + i];
    }
    Some(x)
}

/// Frequency check by phase slope: fits the fundamental at `f_guess` on the
/// two halves of `signal` and returns the frequency implied by the phase
/// advance between them, or `None` when the signal does not look like a sine
/// near `f_guess` (fundamental below half the signal's RMS-equivalent
/// amplitude), in which case a full estimate is needed.
pub(crate) fn phase_slope_frequency(
    signal: &[f64],
    sample_rate_hz: f64,
    f_guess: f64,
) -> Option<f64> {
    let n = signal.len();
    let half = n / 2;
    let cps = f_guess / sample_rate_hz;
    if (half as f64) * cps < 1.0 {
        return None;
    }
    let mut lsq = HarmonicLsq::new(1, 1);
    let mut out = [[Complex64::default(); 2]; 2];
    for (i, r) in [0..half, half..2 * half].into_iter().enumerate() {
        let (a, rest) = out.split_at_mut(1);
        let o = if i == 0 { &mut a[0] } else { &mut rest[0] };
        if !fit_range(&mut lsq, &[signal], r, cps, &mut [&mut o[..]]) {
            return None;
        }
    }
    let mean = signal.iter().sum::<f64>() / n as f64;
    let rms = (signal.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / n as f64).sqrt();
    let amp = 0.5 * (out[0][1].norm() + out[1][1].norm());
    if amp.is_nan() || amp <= 0.5 * std::f64::consts::SQRT_2 * rms {
        return None;
    }
    let dphi = (out[1][1] / out[0][1]).arg();
    let dt = half as f64 / sample_rate_hz;
    Some(f_guess + dphi / (2.0 * PI * dt))
}
