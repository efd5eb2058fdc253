//! Choosing the sweep-distortion compensation from the data.
//!
//! The compensated swept-sine reduction ([`super::reduce_sweep`] with
//! `compensation_s = Some(σ)`) leaves a Gaussian smoothing of `H` of about
//! `(τ/σ)²` relative at a resonance of time constant `τ = 1/(ζω)` (module
//! docs of the sweep reduction), and mixes the response over about `±2σ` of
//! the sweep, which a nonlinear structure's amplitude dependence does not
//! strictly allow. `σ = 4τ` balances the two: about 6 % smoothing at the
//! peak.

use super::blocks::{BLOCKS, frame_pair};
use super::sweep_reduce::reduce_sweep_from;
use super::{FrfPoint, SweepOptions, SweepReduction};
use crate::error::Result;
use crate::signals::FrameSource;
use std::f64::consts::PI;

/// Time constants of the resonance per compensation window `σ`.
pub const TIME_CONSTANTS: f64 = 4.0;

/// The time constant `1/(ζω)` of the largest `|H1|` peak of `points`, `ζ`
/// from its half-power width (crossings interpolated linearly); `None`
/// without a crossing on both sides.
pub fn resonance_time_constant(points: &[FrfPoint]) -> Option<f64> {
    let mut pts: Vec<(f64, f64)> = points
        .iter()
        .filter_map(|p| Some((p.frequency_hz, p.h.get(1)?.norm())))
        .filter(|(f, a)| f.is_finite() && a.is_finite())
        .collect();
    pts.sort_by(|a, b| a.0.total_cmp(&b.0));
    let (i, &(fp, ap)) = pts
        .iter()
        .enumerate()
        .max_by(|a, b| a.1.1.total_cmp(&b.1.1))?;
    let half = ap / std::f64::consts::SQRT_2;
    let crossing = |range: &mut dyn Iterator<Item = usize>| -> Option<f64> {
        let mut prev = i;
        for j in range {
            if pts[j].1 < half {
                let ((f0, a0), (f1, a1)) = (pts[prev], pts[j]);
                return Some(f0 + (half - a0) * (f1 - f0) / (a1 - a0));
            }
            prev = j;
        }
        None
    };
    let lo = crossing(&mut (0..i).rev())?;
    let hi = crossing(&mut (i + 1..pts.len()))?;
    let zeta = (hi - lo) / (2.0 * fp);
    (zeta > 0.0).then(|| 1.0 / (zeta * 2.0 * PI * fp))
}

/// A compensation window for a swept-sine record: [`TIME_CONSTANTS`] times
/// the largest resonance's time constant, capped at a sixth of the active
/// sweep (so the kernel fits in the record). When no resonance shows (no
/// half-power crossing on one side of the peak), [`TIME_CONSTANTS`] times
/// the sweep's own time scale `1/√|α|` (`α` the sweep rate in rad/s²), at
/// most half the cap: a mode whose `τ` is within it is swept nearly
/// quasi-steadily (`ατ² ≤ 1`), and a mode swept slower would show as a
/// resonance. (Half the cap alone would grow with the sweep's duration:
/// 50 s on a 10-minute sweep, mixing the response over
/// minutes and holding a kernel of 8 M frames at 20 kHz.) The sweep
/// broadens the plain (uncompensated) reduction's peak, which shortens `τ`,
/// so `τ` is measured again on the reduction compensated with the first
/// estimate, and the larger `σ` kept. `options` are those of the reductions
/// (their `compensation_s` is ignored). The record is channels `reference`
/// and `response` of `source`, each reduction reading it a stretch at a
/// time (see [`super::reduce_sweep`]).
pub fn choose_compensation(
    source: &mut impl FrameSource,
    reference: usize,
    response: usize,
    options: &SweepOptions,
) -> Result<f64> {
    let fs = source.meta().sample_rate_hz;
    let mut pair = frame_pair(source, reference, response, &BLOCKS)?;
    choose_compensation_by(fs, options, &mut |o| {
        reduce_sweep_from(&mut pair, fs, o, &BLOCKS)
    })
}

/// [`choose_compensation`] with the reductions made by `reduce` (of a
/// record in memory or read from disk a stretch at a time).
pub(crate) fn choose_compensation_by(
    sample_rate_hz: f64,
    options: &SweepOptions,
    reduce: &mut dyn FnMut(&SweepOptions) -> Result<SweepReduction>,
) -> Result<f64> {
    let plain_options = SweepOptions {
        compensation_s: None,
        ..options.clone()
    };
    let plain = reduce(&plain_options)?;
    let duration = (plain.sweep.end - plain.sweep.start) as f64 / sample_rate_hz;
    let cap = duration / 6.0;
    let alpha = 2.0 * PI * plain.sweep.rate_hz_per_s.abs();
    let no_resonance = (TIME_CONSTANTS / alpha.sqrt()).min(cap / 2.0);
    let sigma = |points: &[FrfPoint]| {
        resonance_time_constant(points).map_or(no_resonance, |t| (TIME_CONSTANTS * t).min(cap))
    };
    let first = sigma(&plain.level.points);
    // a long sweep's points are many: not held through the second reduction
    drop(plain);
    let again = reduce(&SweepOptions {
        compensation_s: Some(first),
        ..plain_options
    })?;
    Ok(sigma(&again.level.points).max(first))
}
