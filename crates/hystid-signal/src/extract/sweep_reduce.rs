//! The swept-sine reduction's entry points: a recording read a stretch at a
//! time from a [`FrameSource`] (a file, or channels held in memory or in
//! scratch files), reduced whole or a block at a time (the method:
//! [`super::sweep`]; long records: [`super::sweep_blocks`]).

use super::blocks::{BLOCKS, Blocks, PairSource, frame_pair};
use super::estimator::check_finite;
use super::sweep::{Harmonics, PhaseLaw, WindowFit, compensated, fit_sweep, plain_windows};
use super::sweep_blocks::{compensated_in_blocks, fit_sweep_in_blocks};
use super::{Direction, FrfLevel, FrfPoint, SweepOptions, SweepReduction};
use crate::error::{Error, Result};
use crate::signals::{FrameSource, InMemoryFrames, Recording};
use num_complex::Complex64;
use std::f64::consts::PI;

/// Checks the options and the rate of a swept-sine reduction.
fn check_options(sample_rate_hz: f64, options: &SweepOptions) -> Result<()> {
    if !(sample_rate_hz.is_finite() && sample_rate_hz > 0.0) {
        return Err(Error::input(
            "sample_rate_hz",
            format!("must be finite and > 0, got {sample_rate_hz}"),
        ));
    }
    if options.max_harmonic == 0 || options.window_periods == 0 || options.max_points == 0 {
        return Err(Error::plan(
            "sweep.max_harmonic / sweep.window_periods / sweep.max_points",
            "must be at least 1",
        ));
    }
    if !(options.hop_periods.is_finite() && options.hop_periods >= 0.05) {
        return Err(Error::plan(
            "sweep.hop_periods",
            format!(
                "must be finite and at least 0.05 periods, got {}",
                options.hop_periods
            ),
        ));
    }
    if let Some(s) = options.compensation_s
        && !(s.is_finite() && s > 0.0)
    {
        return Err(Error::plan(
            "sweep.compensation_s",
            format!("must be finite and > 0 seconds, got {s}"),
        ));
    }
    Ok(())
}

/// [`reduce_sweep`] of the force and response `src` reads: a record of at
/// most `blocks.whole` frames whole, as always; a longer one a block at a
/// time ([`super::sweep_blocks`]), whether it is in memory or on disk, so
/// both give the same bits.
pub(super) fn reduce_sweep_from(
    src: &mut dyn PairSource,
    sample_rate_hz: f64,
    options: &SweepOptions,
    blocks: &Blocks,
) -> Result<SweepReduction> {
    check_options(sample_rate_hz, options)?;
    let frames = src.frames();
    if frames < 64 {
        return Err(Error::input(
            "force",
            format!("{frames} samples: too short for a sweep"),
        ));
    }
    let (law, sweep) = if frames <= blocks.whole {
        let (force, response) = src.pair(0, frames)?;
        check_finite(force, "force")?;
        check_finite(response, "response")?;
        fit_sweep(force, sample_rate_hz, options)?
    } else {
        fit_sweep_in_blocks(src, sample_rate_hz, options, blocks)?
    };
    let k = options.max_harmonic;
    let f_top = sweep.f_start_hz.max(sweep.f_end_hz);
    if 2.0 * k as f64 * f_top >= sample_rate_hz {
        return Err(Error::input(
            "max_harmonic",
            format!(
                "harmonic {k} of the sweep's top frequency {f_top:.6} Hz is at or above the \
                 Nyquist frequency {} Hz",
                sample_rate_hz / 2.0
            ),
        ));
    }
    // a sweep of more periods than the points allow is read at a longer hop
    let periods =
        (law.phase((sweep.end - 1) as f64) - law.phase(sweep.start as f64)).abs() / (2.0 * PI);
    let hop_periods = options.hop_periods.max(periods / options.max_points as f64);
    let options = &SweepOptions {
        hop_periods,
        ..options.clone()
    };
    let windows = plain_windows(src, &law, &sweep, options)?;
    if windows.is_empty() {
        return Err(Error::input(
            "force",
            format!(
                "the active sweep (samples {}..{}) is shorter than one window of {} periods",
                sweep.start, sweep.end, options.window_periods
            ),
        ));
    }
    let points = match options.compensation_s {
        None => windows
            .iter()
            .map(|w| point(w, &law, sample_rate_hz, &w.harmonics))
            .collect(),
        Some(sigma) => {
            let PhaseLaw::Quadratic { .. } = law else {
                return Err(Error::plan(
                    "sweep.compensation_s",
                    "the sweep-distortion compensation needs a linear sweep; this one was fitted \
                     as logarithmic (set `law = linear` to force it)",
                ));
            };
            let sigma_samples = sigma * sample_rate_hz;
            let compensated = if frames <= blocks.whole {
                let (force, response) = src.pair(0, frames)?;
                compensated(force, response, &law, &sweep, &windows, sigma_samples, k)
            } else {
                compensated_in_blocks(src, &law, &sweep, &windows, sigma_samples, k, blocks)?
            };
            compensated
                .into_iter()
                .zip(&windows)
                .map(|(c, w)| point(w, &law, sample_rate_hz, &c))
                .collect()
        }
    };
    let points: Vec<FrfPoint> = points;
    let mut amps: Vec<f64> = points.iter().map(|p| p.force_amplitude).collect();
    amps.sort_by(f64::total_cmp);
    let level = amps[amps.len() / 2];
    Ok(SweepReduction {
        level: FrfLevel {
            level,
            direction: if sweep.f_end_hz < sweep.f_start_hz {
                Direction::Down
            } else {
                Direction::Up
            },
            points,
        },
        sweep,
        hop_periods,
    })
}

fn point(w: &WindowFit, law: &PhaseLaw, sample_rate_hz: f64, harmonics: &Harmonics) -> FrfPoint {
    let (force, response) = (harmonics.of(0), harmonics.of(1));
    let (force_var, response_var) = (harmonics.variances(0), harmonics.variances(1));
    let f1 = force[1];
    let p = f1.norm_sqr();
    // referred to the force's phase (the FRF convention of `crate::harmonics`)
    let h: Vec<Complex64> = response
        .iter()
        .enumerate()
        .map(|(k, y)| crate::harmonics::referred_to_force(*y, k, f1) / f1)
        .collect();
    let std_error = h
        .iter()
        .zip(response_var)
        .map(|(hk, vy)| ((vy + hk.norm_sqr() * force_var[1]) / p).sqrt())
        .collect();
    FrfPoint {
        frequency_hz: law.rate(w.center) * sample_rate_hz / (2.0 * PI),
        force_amplitude: f1.norm(),
        h,
        std_error,
        force_distortion: force
            .iter()
            .enumerate()
            .map(|(k, fk)| crate::harmonics::referred_to_force(*fk, k, f1) / f1)
            .collect(),
        blocks: 1,
        settle_periods: 0,
        settled: true,
        subharmonic: None,
    }
}

/// Reduces the swept-sine recording `source` into FRF points of channel
/// `response` against channel `reference` (see [`super::sweep`]), reading
/// it a stretch at a time: a record longer than
/// [`super::WHOLE_RECORD_FRAMES`] is reduced a block at a time, so memory
/// is set by the blocks and the compensation's window, not by the record's
/// length (module docs). Channels held in memory or in scratch files are
/// handed over as [`InMemoryFrames::pair`] (force 0, response 1); the
/// reduction is the same to the bit however the record is read.
///
/// Errors: bad rate or options, a channel out of range or the reference
/// itself, a non-finite sample (named), no sweep in the reference, a
/// harmonic above Nyquist at the sweep's top frequency, compensation
/// requested for a logarithmic sweep, and a read that fails.
pub fn reduce_sweep(
    source: &mut impl FrameSource,
    reference: usize,
    response: usize,
    options: &SweepOptions,
) -> Result<SweepReduction> {
    let fs = source.meta().sample_rate_hz;
    let mut pair = frame_pair(source, reference, response, &BLOCKS)?;
    reduce_sweep_from(&mut pair, fs, options, &BLOCKS)
}

/// Reduces a swept-sine recording (see [`reduce_sweep`]): the reference is
/// `rec.reference_channel()`.
pub fn reduce_sweep_recording(
    rec: &Recording,
    response_channel: usize,
    options: &SweepOptions,
) -> Result<SweepReduction> {
    let r = rec.reference_channel().ok_or_else(|| {
        Error::input(
            "recording",
            "has no force or voltage channel to use as the reference",
        )
    })?;
    let n = rec.channels.len();
    if response_channel >= n || response_channel == r {
        return Err(Error::input(
            format!("response channel {response_channel}"),
            format!("must be one of the {n} channels other than the reference {r}"),
        ));
    }
    let mut pair = InMemoryFrames::pair(
        (&rec.channels[r]).into(),
        (&rec.channels[response_channel]).into(),
        rec.meta.sample_rate_hz,
    )?;
    reduce_sweep(&mut pair, 0, 1, options)
}
