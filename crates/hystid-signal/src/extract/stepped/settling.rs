//! Where a dwell has settled: the transient at its start told from the steady
//! response by blocks of whole periods.

use super::DwellOptions;
use crate::error::{Error, Result};
use crate::extract::lsq::HarmonicLsq;
use crate::extract::noncoherent::{block_bounds, fit_range, whole_periods};
use num_complex::Complex64;
use serde::{Deserialize, Serialize};

/// Where a dwell has settled.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct Settling {
    /// Samples to skip from the start of the dwell.
    pub settle: usize,
    /// False when fewer than `min_dwell_periods` settled periods remain.
    pub settled: bool,
}

pub(in crate::extract) fn check_rate(sample_rate_hz: f64) -> Result<()> {
    if sample_rate_hz.is_finite() && sample_rate_hz > 0.0 {
        Ok(())
    } else {
        Err(Error::input(
            "sample_rate_hz",
            format!("must be finite and > 0, got {sample_rate_hz}"),
        ))
    }
}

/// The settling test of one dwell at frequency `frequency_hz`.
///
/// The dwell is cut into blocks of `settle_block_periods` whole periods, and
/// again into blocks of 2, 4, … times that as long as 6 blocks fit: short
/// blocks resolve a fast transient, long ones see a small slow one through
/// the noise; the latest settle found counts. Per block, harmonics
/// `0..=settle_max_harmonic` are fitted by least squares and normalised for
/// the block's time shift (harmonic `k` rotated by `−k·arg F_1`, so that a
/// small frequency error does not look like a transient). With a `response`
/// the compared quantity is the response's harmonics over the force
/// fundamental's magnitude (the block FRFs); without, the reference's own
/// harmonics.
///
/// The settled state is the mean of the dwell's second half. The dwell is
/// settled from the first block from which every block agrees with it,
/// harmonic by harmonic, within `settle_tolerance` relative to the
/// fundamental or 4 times the block-to-block RMS scatter of the second half,
/// whichever is larger, so that noise does not read as a transient.
/// Comparing with the settled state rather than with the next block bounds
/// the remaining transient itself: a lightly damped mode's transient decays
/// little from one block to the next. The settle found is then doubled, up
/// to half the dwell: a transient that decayed from its initial size `T` to
/// the detection limit `L` is then another factor `L/T` smaller. (With 10 %
/// response noise, a single block length of 2 periods without doubling left
/// transient biases up to 2.6 standard errors at resonance.)
///
/// `settled` is false when fewer than `min_dwell_periods` periods remain.
pub fn settling(
    reference: &[f64],
    response: Option<&[f64]>,
    sample_rate_hz: f64,
    frequency_hz: f64,
    options: &DwellOptions,
) -> Result<Settling> {
    check_rate(sample_rate_hz)?;
    if let Some(r) = response
        && r.len() != reference.len()
    {
        return Err(Error::input(
            "response",
            "must have as many samples as the reference",
        ));
    }
    let periods = whole_periods(reference.len(), sample_rate_hz, frequency_hz);
    let settled_if = |remaining_periods: usize| remaining_periods >= options.min_dwell_periods;
    let k = (1..=options.settle_max_harmonic.max(1))
        .take_while(|&h| 2.0 * h as f64 * frequency_hz < sample_rate_hz)
        .last()
        .unwrap_or(1);
    let channels: Vec<&[f64]> = match response {
        Some(r) => vec![reference, r],
        None => vec![reference],
    };
    let mut lsq = HarmonicLsq::new(k, channels.len());
    // blocks of q, 2q, 4q, … periods (at least 4 blocks): short blocks
    // resolve a fast transient, long ones see a small slow one through the
    // noise
    let mut detected = 0;
    let q0 = options.settle_block_periods.max(1);
    let mut q = q0;
    // the finest level's noise, scaled as 1/√length, is a floor for the
    // coarser levels' own estimates, which rest on few blocks
    let mut noise_floor: Option<Vec<f64>> = None;
    loop {
        let nblocks = periods / q;
        if nblocks < 2 || (nblocks < 6 && q > q0) {
            break;
        }
        let floor = noise_floor.as_ref().map(|n| {
            n.iter()
                .map(|v| v * (q0 as f64 / q as f64).sqrt())
                .collect::<Vec<_>>()
        });
        let (d, noise) = settle_blocks(
            &mut lsq,
            &channels,
            sample_rate_hz,
            frequency_hz,
            q,
            nblocks,
            floor.as_deref(),
            options,
        )?;
        detected = detected.max(d);
        noise_floor.get_or_insert(noise);
        q *= 2;
    }
    // double it: a transient that decayed from its initial size T to the
    // detection limit L over the detected settle is then another factor L/T
    // smaller, where the limit alone would leave a bias of the order of the
    // standard error under noise
    // (but the doubling never takes more than half of the dwell: a slow
    // drift, unlike a decaying transient, does not end)
    let settle_periods = detected
        .max((2 * detected).min(periods / 2))
        .min(periods.saturating_sub(1));
    Ok(Settling {
        settle: ((settle_periods as f64) * sample_rate_hz / frequency_hz + 1e-9).floor() as usize,
        settled: settled_if(periods - settle_periods),
    })
}

/// One resolution of the settling test: periods from the dwell's start to
/// the first of `nblocks` blocks of `q` periods from which every block agrees
/// with the second half's mean (see [`settling`]), and the block-to-block
/// RMS noise per harmonic (at least `noise_floor`).
#[allow(clippy::too_many_arguments)]
fn settle_blocks(
    lsq: &mut HarmonicLsq,
    channels: &[&[f64]],
    sample_rate_hz: f64,
    frequency_hz: f64,
    q: usize,
    nblocks: usize,
    noise_floor: Option<&[f64]>,
    options: &DwellOptions,
) -> Result<(usize, Vec<f64>)> {
    let width = lsq.unknowns().div_ceil(2);
    let with_response = channels.len() == 2;
    let bounds = block_bounds(nblocks * q, sample_rate_hz, frequency_hz, nblocks);
    let cps = frequency_hz / sample_rate_hz;
    let mut v = vec![Complex64::default(); nblocks * width];
    let mut f = vec![Complex64::default(); width];
    let mut y = vec![Complex64::default(); width];
    for b in 0..nblocks {
        let range = bounds[b]..bounds[b + 1];
        let ok = if with_response {
            fit_range(lsq, channels, range, cps, &mut [&mut f, &mut y])
        } else {
            fit_range(lsq, channels, range, cps, &mut [&mut f])
        };
        if !ok {
            return Err(Error::input(
                format!("dwell at {frequency_hz} Hz"),
                "the settling test's harmonic fit is singular (too few samples per period?)",
            ));
        }
        let f1 = f[1];
        let rot = if f1.norm() > 0.0 {
            f1.conj() / f1.norm()
        } else {
            Complex64::new(1.0, 0.0)
        };
        let (src, scale) = if with_response {
            (&y, 1.0 / f1.norm().max(f64::MIN_POSITIVE))
        } else {
            (&f, 1.0)
        };
        let mut r = Complex64::new(1.0, 0.0);
        for kk in 0..width {
            v[b * width + kk] = src[kk] * r * scale;
            r *= rot;
        }
    }
    // the reference state: the mean of the dwell's second half, with the
    // block-to-block noise there
    let tail = (nblocks / 2).min(nblocks - 2);
    let count = (nblocks - tail) as f64;
    let mut mean = vec![Complex64::default(); width];
    for b in tail..nblocks {
        for kk in 0..width {
            mean[kk] += v[b * width + kk] / count;
        }
    }
    let mut limit = vec![0.0; width];
    let mut noise = vec![0.0; width];
    for kk in 0..width {
        let var = (tail..nblocks)
            .map(|b| (v[b * width + kk] - mean[kk]).norm_sqr())
            .sum::<f64>()
            / (count - 1.0);
        noise[kk] = var.sqrt().max(noise_floor.map_or(0.0, |n| n[kk]));
        limit[kk] = (options.settle_tolerance * mean[1].norm()).max(4.0 * noise[kk]);
    }
    let agrees = |b: usize| {
        (0..width).all(|kk| {
            let d = (v[b * width + kk] - mean[kk]).norm();
            d.is_finite() && d <= limit[kk]
        })
    };
    let first_ok = (0..nblocks)
        .rev()
        .find(|&b| !agrees(b))
        .map_or(0, |b| b + 1);
    Ok((first_ok.min(nblocks - 1) * q, noise))
}
