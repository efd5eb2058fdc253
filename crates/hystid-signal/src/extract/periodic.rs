//! Periodic excitation (a multisine played several times): its period, and
//! the FRF at the lines it excites.
//!
//! A multisine repeated `P` times over `L` samples each is periodic in `L`,
//! so the reference's normalised autocorrelation
//! `ρ(ℓ) = Σ u[i] u[i+ℓ] / √(Σ u[i]² · Σ u[i+ℓ]²)` (over the overlap) comes
//! back to 1 at `ℓ = L` after dropping away from its zero-lag lobe. Over a
//! steady-state period the response's spectrum is a sum of lines at the
//! same frequencies, and the H1 estimate per line,
//! `H_l = Σ_p Y_pl U_pl* / Σ_p |U_pl|²` over the periods `p` after the
//! first (its transient), is the linear FRF a best linear approximation of
//! the structure gives (Pintelon & Schoukens, *System Identification*, ch. 3).

use super::blocks::{BLOCKS, PairSource, frame_pair, frame_reference};
use crate::error::Result;
use crate::signals::FrameSource;
use num_complex::Complex64;
use rustfft::FftPlanner;

/// The FRF at one excited line.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Line {
    /// Frequency, Hz.
    pub frequency_hz: f64,
    /// The response per reference.
    pub h: Complex64,
    /// Standard error of `h` from the scatter of the periods (0 with one).
    pub std_error: f64,
    /// The reference's amplitude spectrum there, per period (the FFT's
    /// unnormalised `|U_l|`, averaged over the periods used).
    pub reference: f64,
}

/// The smallest autocorrelation `ρ` accepted as a repeat of the reference.
pub const PERIODIC_CORRELATION: f64 = 0.98;

/// Lines within this fraction of the strongest one's amplitude (20 dB) count
/// as excited.
pub const EXCITED_LINE: f64 = 0.1;

/// The reference's period in samples, from its autocorrelation over the
/// whole of `reference` at once: the smallest lag past the
/// autocorrelation's zero-lag lobe where it returns above
/// [`PERIODIC_CORRELATION`] (at its local maximum there); `None` when it
/// never does within half the record (no two whole periods) or the record
/// is silent.
fn period_of(reference: &[f64]) -> Option<usize> {
    let n = reference.len();
    if n < 32 || reference.iter().any(|v| !v.is_finite()) {
        return None;
    }
    // the autocorrelation through a zero-padded FFT: r[ℓ] = Σ u[i] u[i+ℓ]
    let size = (2 * n).next_power_of_two();
    let mut planner = FftPlanner::<f64>::new();
    let mut b: Vec<Complex64> = reference
        .iter()
        .map(|&v| Complex64::new(v, 0.0))
        .chain(std::iter::repeat(Complex64::new(0.0, 0.0)))
        .take(size)
        .collect();
    planner.plan_fft_forward(size).process(&mut b);
    for v in &mut b {
        *v = Complex64::new(v.norm_sqr(), 0.0);
    }
    planner.plan_fft_inverse(size).process(&mut b);
    // energies of the head u[..n-ℓ] and the tail u[ℓ..], from prefix sums
    let mut prefix = Vec::with_capacity(n + 1);
    prefix.push(0.0);
    for v in reference {
        prefix.push(prefix.last().unwrap() + v * v);
    }
    let total = prefix[n];
    if total <= 0.0 {
        return None;
    }
    let rho = |l: usize| -> f64 {
        let (head, tail) = (prefix[n - l], total - prefix[l]);
        let d = (head * tail).sqrt();
        if d > 0.0 {
            b[l].re / size as f64 / d
        } else {
            0.0
        }
    };
    let half = n / 2;
    // past the zero-lag lobe: a smooth signal correlates with itself at a
    // small shift, which is not a period
    let mut l = 1;
    while l <= half && rho(l) > 0.5 {
        l += 1;
    }
    while l <= half {
        let r = rho(l);
        if r >= PERIODIC_CORRELATION {
            // climb to the local maximum
            while l < half && rho(l + 1) > rho(l) {
                l += 1;
            }
            return Some(l);
        }
        l += 1;
    }
    None
}

/// Frames of a long reference in which [`find_period`] looks for its
/// period (the autocorrelation's FFT over them holds 32 MiB): periods up to
/// half of it are found.
pub const PERIOD_SEARCH: usize = 1 << 20;

/// The period in samples of channel `reference` of `source` (a held
/// channel: [`crate::signals::InMemoryFrames::single`]), without holding
/// more than [`PERIOD_SEARCH`] of its samples: the smallest lag past the
/// autocorrelation's zero-lag lobe where it returns above
/// [`PERIODIC_CORRELATION`] (at its local maximum there), `None` when it
/// never does within half the record (no two whole periods) or the record
/// is silent. A reference up to [`PERIOD_SEARCH`] long is searched whole;
/// a longer one in its first [`PERIOD_SEARCH`] frames, the period found
/// there kept only if the whole record repeats at it (its autocorrelation
/// `ρ` at that lag, over the whole record, read a stretch at a time, at
/// least [`PERIODIC_CORRELATION`]): a record whose later part is another
/// signal has no period.
///
/// Errors: the channel out of range, a read that fails.
pub fn find_period(source: &mut impl FrameSource, reference: usize) -> Result<Option<usize>> {
    let n = source.frames();
    let mut x = frame_reference(source, reference, &BLOCKS)?;
    let Some(period) = period_of(x.pair(0, n.min(PERIOD_SEARCH))?.0) else {
        return Ok(None);
    };
    if n <= PERIOD_SEARCH {
        return Ok(Some(period));
    }
    let rho = correlation_at(&mut x, period)?;
    Ok(rho
        .is_some_and(|r| r >= PERIODIC_CORRELATION)
        .then_some(period))
}

/// The normalised autocorrelation `ρ(ℓ)` of `x` over the whole record (see
/// the module docs), read in stretches of [`STRETCH`] and the lag beyond;
/// `None` where a sample is not finite or an overlap is silent.
fn correlation_at(x: &mut dyn PairSource, lag: usize) -> Result<Option<f64>> {
    let n = x.frames();
    let (mut cross, mut head, mut tail) = (0.0, 0.0, 0.0);
    let mut a = 0;
    while a < n {
        let b = (a + STRETCH).min(n);
        let v = x.pair(a, (b + lag).min(n))?.0;
        if v.iter().any(|v| !v.is_finite()) {
            return Ok(None);
        }
        for i in 0..b - a {
            if a + i + lag < n {
                cross += v[i] * v[i + lag];
                head += v[i] * v[i];
            }
            if a + i >= lag {
                tail += v[i] * v[i];
            }
        }
        a = b;
    }
    let d = (head * tail).sqrt();
    Ok((d > 0.0).then(|| cross / d))
}

/// Samples read at a time from a held channel.
const STRETCH: usize = 1 << 16;

/// The FRF of `response` per `reference` at the excited lines of a periodic
/// excitation of `period` samples, over the whole periods after the first
/// (the transient's): H1 per line with its standard error from the scatter
/// of the periods (0 with a single period), at `k · fs / period` Hz. Empty
/// when fewer than two whole periods are recorded. The channels are those
/// of `source` (held ones: [`crate::signals::InMemoryFrames::pair`]), read
/// a period at a time (each period's spectra made twice, for the sums and
/// then for the scatter about their estimate), so that a record of any
/// length holds a period's samples and one spectrum per line.
///
/// Errors: a channel out of range or the reference itself, a read that
/// fails.
pub fn periodic_frf(
    source: &mut impl FrameSource,
    reference: usize,
    response: usize,
    period: usize,
) -> Result<Vec<Line>> {
    let sample_rate_hz = source.meta().sample_rate_hz;
    let n = source.frames();
    let mut pair = frame_pair(source, reference, response, &BLOCKS)?;
    if period < 4 || n < 2 * period {
        return Ok(Vec::new());
    }
    let periods = n / period;
    let mut planner = FftPlanner::<f64>::new();
    let fft = planner.plan_fft_forward(period);
    let spectrum = |x: &[f64]| {
        let mut b: Vec<Complex64> = x.iter().map(|&v| Complex64::new(v, 0.0)).collect();
        fft.process(&mut b);
        b
    };
    // each steady period's spectra, in order, handed to `each`
    let mut each_period = |each: &mut dyn FnMut(&[Complex64], &[Complex64])| -> Result<()> {
        for p in 1..periods {
            let (u, y) = pair.pair(p * period, (p + 1) * period)?;
            each(&spectrum(u), &spectrum(y));
        }
        Ok(())
    };
    let lines = period / 2;
    let zero = Complex64::new(0.0, 0.0);
    let (mut power, mut cross) = (vec![0.0; lines], vec![zero; lines]);
    each_period(&mut |u, y| {
        for l in 0..lines {
            power[l] += u[l].norm_sqr();
            cross[l] += y[l] * u[l].conj();
        }
    })?;
    let strongest = power[1..].iter().copied().fold(0.0, f64::max);
    let excited: Vec<usize> = (1..lines)
        .filter(|&l| strongest > 0.0 && power[l] >= EXCITED_LINE * EXCITED_LINE * strongest)
        .collect();
    let h: Vec<Complex64> = excited.iter().map(|&l| cross[l] / power[l]).collect();
    let mut scatter = vec![0.0; excited.len()];
    each_period(&mut |u, y| {
        for (i, &l) in excited.iter().enumerate() {
            scatter[i] += (y[l] - h[i] * u[l]).norm_sqr();
        }
    })?;
    let used = (periods - 1) as f64;
    Ok(excited
        .iter()
        .enumerate()
        .map(|(i, &l)| {
            let std_error = if used > 1.0 {
                (scatter[i] / ((used - 1.0) * power[l])).sqrt()
            } else {
                0.0
            };
            Line {
                frequency_hz: l as f64 * sample_rate_hz / period as f64,
                h: h[i],
                std_error,
                reference: (power[l] / used).sqrt(),
            }
        })
        .collect())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::signals::{InMemoryFrames, SamplesView};
    use std::f64::consts::PI;

    /// [`find_period`] of `x` held in memory.
    fn period_in(x: SamplesView) -> Option<usize> {
        find_period(&mut InMemoryFrames::single(x, 1000.0), 0).unwrap()
    }

    /// [`periodic_frf`] of `u` and `y` held in memory.
    fn lines_of(u: SamplesView, y: SamplesView, fs: f64, period: usize) -> Vec<Line> {
        let mut pair = InMemoryFrames::pair(u, y, fs).unwrap();
        periodic_frf(&mut pair, 0, 1, period).unwrap()
    }

    /// A multisine of odd lines 3..61 with Schroeder phases, `periods`
    /// times over `period` samples.
    fn multisine(period: usize, periods: usize) -> Vec<f64> {
        let lines: Vec<usize> = (3..62).step_by(2).collect();
        let k = lines.len() as f64;
        (0..period * periods)
            .map(|i| {
                lines
                    .iter()
                    .enumerate()
                    .map(|(j, &l)| {
                        let phase = -PI * (j * (j + 1)) as f64 / k;
                        (2.0 * PI * l as f64 * (i % period) as f64 / period as f64 + phase).cos()
                    })
                    .sum()
            })
            .collect()
    }

    #[test]
    fn a_repeated_multisine_has_its_period_and_noise_has_none() {
        for (period, periods) in [(1000, 3), (4096, 2), (777, 5)] {
            assert_eq!(
                period_in((&multisine(period, periods)).into()),
                Some(period)
            );
        }
        // a deterministic pseudo-random record: no period
        let mut s = 12345u64;
        let noise: Vec<f64> = (0..8000)
            .map(|_| {
                s = s
                    .wrapping_mul(6364136223846793005)
                    .wrapping_add(1442695040888963407);
                (s >> 11) as f64 / (1u64 << 53) as f64 - 0.5
            })
            .collect();
        assert_eq!(period_in((&noise).into()), None);
        // one period only: none
        assert_eq!(period_in((&multisine(1000, 1)).into()), None);
    }

    /// A reference longer than [`PERIOD_SEARCH`] has the period its first
    /// frames show where the whole record repeats at it, and none where its
    /// later part is another signal; the FRF at the lines of channels held
    /// in scratch files is the one of the channels in memory, to the bit.
    #[test]
    fn a_long_held_reference_has_its_period_and_its_lines() {
        let period = 1000;
        let long = multisine(period, PERIOD_SEARCH / period + 50);
        assert_eq!(period_in((&long).into()), Some(period));
        // as long again of noise as loud after the search: no period over
        // the whole (ρ about 0.5)
        let mut changed = multisine(period, 2 * PERIOD_SEARCH / period);
        let rms = (long.iter().map(|v| v * v).sum::<f64>() / long.len() as f64).sqrt();
        let mut state = 12345u64;
        for v in &mut changed[PERIOD_SEARCH + 7..] {
            state = state
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            *v = rms * 3.46 * ((state >> 11) as f64 / (1u64 << 53) as f64 - 0.5);
        }
        assert_eq!(period_of(&changed[..PERIOD_SEARCH]), Some(period));
        assert_eq!(period_in((&changed).into()), None);
        // spilled: the same lines, to the bit
        let spilled = |x: &[f64]| {
            let mut b = crate::signals::SamplesBuilder::new(x.len(), &[]).spilling_above(5_000);
            x.chunks(4_321).for_each(|c| b.extend(c).unwrap());
            b.finish().unwrap()
        };
        let short = &long[..20 * period];
        let response: Vec<f64> = short.iter().map(|v| 0.3 * v + 1e-3 * v * v).collect();
        let (u, y) = (spilled(short), spilled(&response));
        assert!(u.is_spilled() && y.is_spilled());
        let held = lines_of(u.view(), y.view(), 1000.0, period);
        let whole = lines_of(short.into(), (&response).into(), 1000.0, period);
        assert_eq!(held.len(), 30);
        assert_eq!(held, whole);
        assert_eq!(period_in(u.view()), Some(period));
    }

    /// A known linear filter's FRF at the lines: the response is the
    /// circular convolution of one period with an exponential impulse
    /// response (steady state), written in closed form per line.
    #[test]
    fn the_frf_at_the_lines_is_the_filters() {
        let (period, periods, fs) = (1024, 4, 1000.0);
        let u = multisine(period, periods);
        // y[i] = a y[i-1] + u[i]: H(z) = 1/(1 - a z^-1)
        let a = 0.9;
        let mut y = vec![0.0; u.len()];
        let mut prev = 0.0;
        for (i, v) in u.iter().enumerate() {
            prev = a * prev + v;
            y[i] = prev;
        }
        let frf = lines_of((&u).into(), (&y).into(), fs, period);
        assert_eq!(frf.len(), 30);
        for p in &frf {
            let w = 2.0 * PI * p.frequency_hz / fs;
            let want = 1.0 / (1.0 - a * Complex64::from_polar(1.0, -w));
            // the first period's transient decays as 0.9^1024: gone
            assert!((p.h - want).norm() < 1e-9 * want.norm(), "{p:?} vs {want}");
            assert!(p.std_error < 1e-9 * want.norm());
        }
    }
}
