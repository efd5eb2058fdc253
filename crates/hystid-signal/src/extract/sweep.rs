//! Swept-sine reduction: following the reference's phase like a shaker
//! controller's sine data reduction.
//!
//! 1. The reference's instantaneous phase is taken from its analytic signal
//!    (FFT Hilbert transform) over the active part of the record (envelope
//!    above `amplitude_threshold` of its median over the driven part),
//!    leaving `edge_periods` out
//!    at each end where the Hilbert transform is not local.
//! 2. A smooth phase law is fitted to it by least squares: a quadratic
//!    `φ(t) = p0 + p1 t + p2 t²` for a linear sweep, `φ(t) = c0 + c1 e^{λt}`
//!    for a logarithmic one (automatic choice by the smaller residual), with
//!    one refit without gross outliers (force drop-outs). The sweep found
//!    (start, end, rate) is reported.
//! 3. Over sliding windows of `window_periods` whole periods of the fitted
//!    phase (hop `hop_periods`), a mean and `cos/sin(hφ(t))`, `h = 1..K`, are
//!    fitted by least squares to the reference and the response together;
//!    `H_k = Y_k/F_1` per window, with standard errors from the residual
//!    variance, `E|ΔH_k|² = (σ_y²·v_k + |H_k|² σ_f²·v_1)/|F_1|²` with
//!    `v_k` the sum of the `cos` and `sin` diagonal terms of `(AᵀA)⁻¹` (white
//!    residuals assumed; force and response residuals taken independent).
//!
//! **Sweep distortion.** Step 3 is quasi-steady: it takes the response at
//! time `t` for the steady response at `f(t)`. Through a lightly damped
//! resonance at rate `α = dω/dt` this fails unless `α τ²` is small
//! (`τ = 1/(ζω_n)`): the response lags, its peak is lowered, delayed along
//! the sweep and followed by ringing at the natural frequency. At the F-16
//! benchmark's rate through its torsion mode (−0.05 Hz/s, 7.3 Hz,
//! ζ = 0.7 %, `α τ² ≈ 3`) the plain windows of a simulated linear mode show
//! the peak 24 % low and 0.14 Hz late, errors above 100 % within ±0.5 Hz of
//! the mode, and below 0.5 % only more than 1.5 Hz away from it; on the real
//! F-16 level 1 they put the peak at 7.16 Hz instead of 7.33 Hz
//! (`tests/extract.rs`). No choice of window helps: the response itself is
//! not the steady one.
//!
//! With `compensation_s = Some(σ)` (linear sweeps only) each harmonic is
//! instead estimated by a Gaussian-windowed Fourier transform at `h·f(t)` of
//! the signal cleaned of the other harmonics (their plain-window model
//! subtracted): for a linear chirp this is the demodulated signal convolved
//! with the kernel `e^{jhα m²/2} e^{−m²/2σ²}`, which undoes the sweep's own
//! chirp convolution of the response (the exact linear relation
//! `Y(ω) = H(ω)F(ω)`, localised; the force is treated the same way, so a
//! varying force amplitude is allowed). What remains is a Gaussian smoothing
//! of `H` over `1/σ` rad/s, about `(τ/σ)²` relative at a resonance, so `σ`
//! should be several time constants: with σ = 40 s the simulated F-16 mode
//! is within 0.4 % away from the resonance and 0.6 % at it, and the real
//! level 1 peak comes out at 7.32 Hz with σ = 12 s. The standard errors
//! propagate the plain windows' residual variance through the kernel. For a
//! nonlinear structure the compensation mixes the response over about `±2σ`
//! of the sweep, which a friction joint's amplitude dependence does not
//! strictly allow; without compensation the result is what a shaker
//! controller reports.
//!
//! **Long records.** Steps 1 and the compensation transform the record
//! whole; a record longer than [`super::WHOLE_RECORD_FRAMES`] is reduced a
//! block at a time instead, and read from its source a stretch at a time
//! ([`super::reduce_sweep`]), so that memory does not grow with its
//! length (see `sweep_blocks`).

use super::analytic::{Analytic, analytic};
use super::blocks::PairSource;
use super::lsq::HarmonicLsq;
use super::noncoherent::solve_dense;
use super::{FrfLevel, NonlinearFrf};
use crate::error::{Error, Result};
use crate::harmonics::Quantity;
use num_complex::Complex64;
use rustfft::FftPlanner;
use serde::{Deserialize, Serialize};
use std::f64::consts::PI;

/// The frequency law of a sweep.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum SweepLaw {
    /// `f(t) = f_0 + r t`.
    Linear,
    /// `f(t) = f_0 e^{λt}` (constant octaves per minute).
    Logarithmic,
}

/// Options of [`reduce_sweep`].
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct SweepOptions {
    /// Highest harmonic `K`.
    pub max_harmonic: usize,
    /// Window length, whole periods of the fitted phase.
    pub window_periods: usize,
    /// Hop between windows, periods (at least 0.05).
    pub hop_periods: f64,
    /// The sweep law; `None` chooses the better fit.
    pub law: Option<SweepLaw>,
    /// The active sweep is where the reference's envelope exceeds this
    /// fraction of its median over the driven part (where it exceeds 1 % of
    /// its maximum).
    pub amplitude_threshold: f64,
    /// Periods at each end of the active sweep left out of the phase fit
    /// (the Hilbert transform is not local at the ends).
    pub edge_periods: f64,
    /// Sweep-distortion compensation: the Gaussian window's standard
    /// deviation in seconds (linear sweeps only; see the module docs).
    pub compensation_s: Option<f64>,
    /// At most this many points: a sweep of more than `max_points ×
    /// hop_periods` periods is read at the hop that gives this many, so
    /// that the points (about half a kilobyte each, with their windows) and
    /// a fit's cost, which grow with them, stay bounded whatever the
    /// record's length (see [`SweepReduction::hop_periods`]).
    pub max_points: usize,
}

/// [`SweepOptions::max_points`] by default: 32 768 points, 16 MB, one per
/// period of a 10-200 Hz sweep of 5 minutes (a slower sweep is read at a
/// longer hop).
pub const MAX_SWEEP_POINTS: usize = 1 << 15;

impl Default for SweepOptions {
    fn default() -> Self {
        SweepOptions {
            max_harmonic: 5,
            window_periods: 4,
            hop_periods: 1.0,
            law: None,
            amplitude_threshold: 0.1,
            edge_periods: 5.0,
            compensation_s: None,
            max_points: MAX_SWEEP_POINTS,
        }
    }
}

/// The sweep found in the reference channel.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct SweepFit {
    /// The law fitted.
    pub law: SweepLaw,
    /// Frequency at the start of the active sweep, Hz.
    pub f_start_hz: f64,
    /// Frequency at its end, Hz.
    pub f_end_hz: f64,
    /// Sweep rate, Hz/s (negative downwards): the constant rate of a linear
    /// sweep, the mean rate `(f_end − f_start)/duration` of a logarithmic one.
    pub rate_hz_per_s: f64,
    /// Octaves per minute of a logarithmic sweep (`None` for linear).
    pub octaves_per_minute: Option<f64>,
    /// First sample of the active sweep.
    pub start: usize,
    /// One past its last sample.
    pub end: usize,
    /// RMS of the measured phase about the fitted law, rad.
    pub phase_rms_rad: f64,
}

/// The result of [`reduce_sweep`].
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct SweepReduction {
    /// The sweep found.
    pub sweep: SweepFit,
    /// The points in time order; `level` is the median force amplitude,
    /// `blocks` of each point is 1 (one window).
    pub level: FrfLevel,
    /// The hop the windows were read at, periods: the one asked, or a
    /// longer one where the sweep holds more than
    /// [`SweepOptions::max_points`] of those.
    pub hop_periods: f64,
}

impl SweepReduction {
    /// The reduction as a one-level [`NonlinearFrf`].
    pub fn into_frf(self, response: Quantity, reference: Quantity) -> NonlinearFrf {
        let max_harmonic = self
            .level
            .points
            .first()
            .map_or(0, |p| p.h.len().saturating_sub(1));
        NonlinearFrf {
            response,
            reference,
            max_harmonic,
            levels: vec![self.level],
        }
    }
}

/// A fitted phase law in samples: `θ(n)`, `dθ/dn`.
#[derive(Clone, Copy, Debug)]
pub(super) enum PhaseLaw {
    /// `p0 + p1 u + p2 u²`, `u = (n − mid)/half`.
    Quadratic { mid: f64, half: f64, p: [f64; 3] },
    /// `c0 + c1 e^{λ(n − mid)}`, λ per sample.
    Exponential { mid: f64, c: [f64; 2], lambda: f64 },
}

impl PhaseLaw {
    #[inline]
    pub(super) fn phase(&self, n: f64) -> f64 {
        match *self {
            PhaseLaw::Quadratic { mid, half, p } => {
                let u = (n - mid) / half;
                p[0] + u * (p[1] + u * p[2])
            }
            PhaseLaw::Exponential { mid, c, lambda } => c[0] + c[1] * (lambda * (n - mid)).exp(),
        }
    }

    /// The chirp rate `α` of a quadratic law, rad/sample² (the
    /// compensation's; callers have checked the law is quadratic).
    pub(super) fn chirp_rate(&self) -> f64 {
        match *self {
            PhaseLaw::Quadratic { half, p, .. } => 2.0 * p[2] / (half * half),
            PhaseLaw::Exponential { .. } => unreachable!("checked by the caller"),
        }
    }

    /// rad per sample.
    pub(super) fn rate(&self, n: f64) -> f64 {
        match *self {
            PhaseLaw::Quadratic { mid, half, p } => {
                let u = (n - mid) / half;
                (p[1] + 2.0 * p[2] * u) / half
            }
            PhaseLaw::Exponential { mid, c, lambda } => c[1] * lambda * (lambda * (n - mid)).exp(),
        }
    }
}

/// Least-squares fit of the phase law to `phase[i]` for samples `n = i + offset`
/// over `range` (excluding `mask`ed samples); returns the law and the RMS.
fn fit_quadratic(
    phase: &[f64],
    range: std::ops::Range<usize>,
    keep: &[bool],
    stride: usize,
) -> Option<(PhaseLaw, f64)> {
    let mid = 0.5 * (range.start + range.end - 1) as f64;
    let half = (0.5 * (range.end - range.start) as f64).max(1.0);
    let mut a = [0.0; 9];
    let mut b = [0.0; 3];
    for n in range.clone().step_by(stride) {
        if !keep[n] {
            continue;
        }
        let u = (n as f64 - mid) / half;
        let row = [1.0, u, u * u];
        for i in 0..3 {
            b[i] += row[i] * phase[n];
            for j in 0..3 {
                a[i * 3 + j] += row[i] * row[j];
            }
        }
    }
    let p = solve_dense(&mut a, &mut b, 3)?;
    let law = PhaseLaw::Quadratic {
        mid,
        half,
        p: [p[0], p[1], p[2]],
    };
    Some((law, rms(phase, range, keep, stride, &law)))
}

fn rms(
    phase: &[f64],
    range: std::ops::Range<usize>,
    keep: &[bool],
    stride: usize,
    law: &PhaseLaw,
) -> f64 {
    let (mut s, mut c) = (0.0, 0usize);
    for n in range.step_by(stride) {
        if keep[n] {
            s += (phase[n] - law.phase(n as f64)).powi(2);
            c += 1;
        }
    }
    (s / c.max(1) as f64).sqrt()
}

/// For fixed λ, the linear fit of `c0 + c1 e^{λ(n−mid)}`.
fn fit_exponential_at(
    phase: &[f64],
    range: std::ops::Range<usize>,
    keep: &[bool],
    stride: usize,
    lambda: f64,
) -> Option<(PhaseLaw, f64)> {
    let mid = 0.5 * (range.start + range.end - 1) as f64;
    let mut a = [0.0; 4];
    let mut b = [0.0; 2];
    for n in range.clone().step_by(stride) {
        if !keep[n] {
            continue;
        }
        let e = (lambda * (n as f64 - mid)).exp();
        a[0] += 1.0;
        a[1] += e;
        a[3] += e * e;
        b[0] += phase[n];
        b[1] += e * phase[n];
    }
    a[2] = a[1];
    let c = solve_dense(&mut a, &mut b, 2)?;
    let law = PhaseLaw::Exponential {
        mid,
        c: [c[0], c[1]],
        lambda,
    };
    Some((law, rms(phase, range, keep, stride, &law)))
}

/// Golden-section search of λ for the exponential law, bracketed around the
/// log-rate implied by the mean frequencies of the first and last tenth of
/// the range (measured phase advance over each).
fn fit_exponential(
    phase: &[f64],
    range: std::ops::Range<usize>,
    keep: &[bool],
    stride: usize,
) -> Option<(PhaseLaw, f64)> {
    let tenth = (range.end - range.start) / 10;
    if tenth < 2 {
        return None;
    }
    let (a0, a1) = (range.start, range.start + tenth);
    let (b0, b1) = (range.end - 1 - tenth, range.end - 1);
    let (f0, f1) = (
        (phase[a1] - phase[a0]) / tenth as f64,
        (phase[b1] - phase[b0]) / tenth as f64,
    );
    if !(f0 > 0.0 && f1 > 0.0) || (f1 / f0 - 1.0).abs() < 1e-6 {
        return None;
    }
    let l0 = (f1 / f0).ln() / (0.5 * (b0 + b1) as f64 - 0.5 * (a0 + a1) as f64);
    let (mut lo, mut hi) = if l0 > 0.0 {
        (0.2 * l0, 5.0 * l0)
    } else {
        (5.0 * l0, 0.2 * l0)
    };
    let g = 0.5 * (5f64.sqrt() - 1.0);
    let cost = |l: f64| {
        fit_exponential_at(phase, range.clone(), keep, stride, l).map_or(f64::INFINITY, |r| r.1)
    };
    let (mut x1, mut x2) = (hi - g * (hi - lo), lo + g * (hi - lo));
    let (mut c1, mut c2) = (cost(x1), cost(x2));
    for _ in 0..60 {
        if c1 < c2 {
            hi = x2;
            (x2, c2) = (x1, c1);
            x1 = hi - g * (hi - lo);
            c1 = cost(x1);
        } else {
            lo = x1;
            (x1, c1) = (x2, c2);
            x2 = lo + g * (hi - lo);
            c2 = cost(x2);
        }
        if (hi - lo).abs() < 1e-12 * l0.abs() {
            break;
        }
    }
    fit_exponential_at(phase, range, keep, stride, 0.5 * (lo + hi))
}

/// The driven stretch `start..end` of an envelope: runs above `threshold`
/// joined across gaps shorter than a twentieth of the record (drop-outs),
/// the one holding the most samples above it. A silent stretch (a chirp's
/// free decay) ends the sweep; the Hilbert transform's wrap-around at the
/// record's ends, which can lift the envelope of a silent end above the
/// threshold for a few samples, does not extend it.
fn driven_stretch(envelope: &[f64], threshold: f64) -> Option<(usize, usize)> {
    let max_gap = envelope.len() / 20;
    // (start, end, samples above the threshold)
    let mut best: Option<(usize, usize, usize)> = None;
    let mut current: Option<(usize, usize, usize)> = None;
    for (n, &v) in envelope.iter().enumerate() {
        if v <= threshold {
            continue;
        }
        current = match current {
            Some((s, e, c)) if n - e <= max_gap => Some((s, n + 1, c + 1)),
            other => {
                if let Some(run) = other
                    && best.is_none_or(|b| run.2 > b.2)
                {
                    best = Some(run);
                }
                Some((n, n + 1, 1))
            }
        };
    }
    if let Some(run) = current
        && best.is_none_or(|b| run.2 > b.2)
    {
        best = Some(run);
    }
    best.map(|(s, e, _)| (s, e))
}

/// Active sweep, phase-law fit and the sweep's figures.
pub(super) fn fit_sweep(
    reference: &[f64],
    sample_rate_hz: f64,
    options: &SweepOptions,
) -> Result<(PhaseLaw, SweepFit)> {
    fit_phase(&analytic(reference), sample_rate_hz, options)
}

/// [`fit_sweep`] from the reference's instantaneous phase and envelope
/// sampled at `sample_rate_hz` (every sample of the record, or every `D`-th
/// of a long one at `fs/D`: see [`super::sweep_blocks`]).
pub(super) fn fit_phase(
    a: &Analytic,
    sample_rate_hz: f64,
    options: &SweepOptions,
) -> Result<(PhaseLaw, SweepFit)> {
    let median = median_driven_amplitude(&a.amplitude);
    let threshold = options.amplitude_threshold * median;
    let active = |v: &f64| *v > threshold;
    let Some((mut start, mut end)) = driven_stretch(&a.amplitude, threshold) else {
        return Err(Error::input("reference", "is zero: no sweep to follow"));
    };
    // a first fit over the active part gives the period for the edge margins
    let all = vec![true; a.phase.len()];
    // the phase is smooth: about 20 000 samples fix the law as well as all
    let stride = ((end - start) / 20_000).max(1);
    let (rough, _) = fit_quadratic(&a.phase, start..end, &all, stride)
        .ok_or_else(|| Error::input("reference", "too short to fit a sweep's phase"))?;
    let (fit_start, fit_end) = fit_range(&rough, start..end, options.edge_periods);
    if fit_end <= fit_start + 16 {
        return Err(Error::input(
            "reference",
            format!(
                "the active sweep (samples {start}..{end}) is too short for a phase fit after \
                 leaving {} periods at each end",
                options.edge_periods
            ),
        ));
    }
    // fit, then refit without gross outliers (force drop-outs, glitches)
    let mut keep: Vec<bool> = a.amplitude.iter().map(active).collect();
    let (mut quad, mut qrms) = fit_quadratic(&a.phase, fit_start..fit_end, &keep, stride)
        .ok_or_else(|| Error::input("reference", "singular phase fit"))?;
    for (n, k) in keep.iter_mut().enumerate().take(fit_end).skip(fit_start) {
        if (a.phase[n] - quad.phase(n as f64)).abs() > 5.0 * qrms + 1e-9 {
            *k = false;
        }
    }
    if let Some(r) = fit_quadratic(&a.phase, fit_start..fit_end, &keep, stride) {
        (quad, qrms) = r;
    }
    let (law, fitted, phase_rms) = match options.law {
        Some(SweepLaw::Linear) => (SweepLaw::Linear, quad, qrms),
        Some(SweepLaw::Logarithmic) => {
            let (l, r) =
                fit_exponential(&a.phase, fit_start..fit_end, &keep, stride).ok_or_else(|| {
                    Error::input(
                        "reference",
                        "no logarithmic sweep: the frequency does not change",
                    )
                })?;
            (SweepLaw::Logarithmic, l, r)
        }
        None => match fit_exponential(&a.phase, fit_start..fit_end, &keep, stride) {
            Some((l, r)) if r < qrms => (SweepLaw::Logarithmic, l, r),
            _ => (SweepLaw::Linear, quad, qrms),
        },
    };
    let f_at = |n: f64| fitted.rate(n) * sample_rate_hz / (2.0 * PI);
    let (mut f_start, mut f_end) = (f_at(start as f64), f_at((end - 1) as f64));
    // a sweep from or to 0 Hz: its fitted law may cross zero by a hair at
    // that end; the sweep is taken from (to) where it passes 1 % of its top
    let top = f_start.abs().max(f_end.abs());
    let low = 0.01 * top;
    if f_start <= 0.0 && f_start > -low && f_end > low {
        start = (start..end)
            .find(|&n| f_at(n as f64) >= low)
            .unwrap_or(start);
        f_start = f_at(start as f64);
    } else if f_end <= 0.0 && f_end > -low && f_start > low {
        end = (start..end)
            .rev()
            .find(|&n| f_at(n as f64) >= low)
            .map_or(end, |n| n + 1);
        f_end = f_at((end - 1) as f64);
    }
    if !(f_start > 0.0 && f_end > 0.0) {
        return Err(Error::input(
            "reference",
            format!(
                "the fitted sweep law goes through zero frequency ({f_start} Hz at sample {start}, \
                 {f_end} Hz at sample {})",
                end - 1
            ),
        ));
    }
    let duration = (end - 1 - start) as f64 / sample_rate_hz;
    let (rate, octaves) = sweep_rate(&fitted, (f_start, f_end), duration, sample_rate_hz);
    Ok((
        fitted,
        SweepFit {
            law,
            f_start_hz: f_start,
            f_end_hz: f_end,
            rate_hz_per_s: rate,
            octaves_per_minute: octaves,
            start,
            end,
            phase_rms_rad: phase_rms,
        },
    ))
}

/// The median amplitude of the driven part (above 1 % of the peak): a
/// record that is silent for half its length (a chirp followed by a free
/// decay) still has a sweep.
fn median_driven_amplitude(amplitude: &[f64]) -> f64 {
    let peak = amplitude.iter().copied().fold(0.0, f64::max);
    let mut env: Vec<f64> = amplitude
        .iter()
        .copied()
        .filter(|&v| v > 0.01 * peak)
        .collect();
    env.sort_by(f64::total_cmp);
    env.get(env.len() / 2).copied().unwrap_or(0.0)
}

/// The samples of `range` the phase is fitted on: `edge_periods` periods
/// in from each end (by the rough law's rate), or, for a sweep from (nearly)
/// 0 Hz, `edge_periods` cycles of phase.
fn fit_range(rough: &PhaseLaw, range: std::ops::Range<usize>, edge_periods: f64) -> (usize, usize) {
    let edge = |n: usize| {
        (edge_periods * 2.0 * PI / rough.rate(n as f64).abs().max(1e-12)).ceil() as usize
    };
    let (start, end) = (range.start, range.end);
    let (mut fit_start, mut fit_end) = (start + edge(start), end.saturating_sub(edge(end - 1)));
    if fit_end <= fit_start + 16 {
        // a sweep from (nearly) 0 Hz has no period at its start: leave its
        // first and last `edge_periods` cycles of phase instead
        let cycles = edge_periods * 2.0 * PI;
        let turned =
            |n: usize, from: usize| (rough.phase(n as f64) - rough.phase(from as f64)).abs();
        fit_start = (start..end)
            .find(|&n| turned(n, start) >= cycles)
            .unwrap_or(end);
        fit_end = (start..end)
            .rev()
            .find(|&n| turned(end - 1, n) >= cycles)
            .map_or(start, |n| n + 1);
    }
    (fit_start, fit_end)
}

/// The sweep's rate, Hz/s, and for a logarithmic one its octaves per
/// minute.
fn sweep_rate(
    fitted: &PhaseLaw,
    (f_start, f_end): (f64, f64),
    duration: f64,
    sample_rate_hz: f64,
) -> (f64, Option<f64>) {
    match *fitted {
        PhaseLaw::Quadratic { half, p, .. } => (
            2.0 * p[2] / (half * half) * sample_rate_hz * sample_rate_hz / (2.0 * PI),
            None,
        ),
        PhaseLaw::Exponential { lambda, .. } => (
            (f_end - f_start) / duration,
            Some(lambda * sample_rate_hz * 60.0 / std::f64::consts::LN_2),
        ),
    }
}

/// The sweep in `reference` (its active stretch and fitted frequency law),
/// its phase fitted over the whole record at once, without reducing a
/// response (what [`super::find_sweep`] does with a record of at most
/// [`super::WHOLE_RECORD_FRAMES`] frames).
pub fn find_sweep_whole(
    reference: &[f64],
    sample_rate_hz: f64,
    options: &SweepOptions,
) -> Result<SweepFit> {
    check_sweep_rate(sample_rate_hz)?;
    if let Some(i) = reference.iter().position(|v| !v.is_finite()) {
        return Err(Error::input(
            "reference",
            format!("sample {i} is not finite"),
        ));
    }
    fit_sweep(reference, sample_rate_hz, options).map(|(_, s)| s)
}

/// A sweep's sample rate: finite and positive.
pub(super) fn check_sweep_rate(sample_rate_hz: f64) -> Result<()> {
    if !(sample_rate_hz.is_finite() && sample_rate_hz > 0.0) {
        return Err(Error::input(
            "sample rate",
            format!("must be finite and > 0, got {sample_rate_hz}"),
        ));
    }
    Ok(())
}

impl SweepFit {
    /// Samples `a..b` where the fitted law's frequency lies inside `band`
    /// (clamped to the active sweep; empty when the sweep does not move).
    pub fn samples_in(&self, band: (f64, f64)) -> std::ops::Range<usize> {
        let (n0, n1) = (self.start as f64, self.end as f64);
        let (f0, f1) = (self.f_start_hz, self.f_end_hz);
        if n1 <= n0 || f0 == f1 {
            return 0..0;
        }
        // sample at which the law reaches frequency f
        let at = |f: f64| -> f64 {
            let u = match self.law {
                SweepLaw::Linear => (f - f0) / (f1 - f0),
                SweepLaw::Logarithmic => (f / f0).ln() / (f1 / f0).ln(),
            };
            n0 + u.clamp(0.0, 1.0) * (n1 - n0)
        };
        let (x, y) = (at(band.0), at(band.1));
        x.min(y).floor() as usize..x.max(y).ceil() as usize
    }
}

/// One plain window's result.
pub(super) struct WindowFit {
    pub(super) center: f64,
    pub(super) harmonics: Harmonics,
    /// Residual variances of the force and the response fits.
    pub(super) residual_var: [f64; 2],
}

/// Harmonics `0..=K` of the force (channel 0) and the response (channel 1)
/// at one window, with `E|ΔF_k|²` and `E|ΔY_k|²`: two allocations a window,
/// as a long sweep has tens of thousands of them.
pub(super) struct Harmonics {
    width: usize,
    /// The force's, then the response's.
    values: Vec<Complex64>,
    variances: Vec<f64>,
}

impl Harmonics {
    pub(super) fn new(width: usize) -> Harmonics {
        Harmonics {
            width,
            values: vec![Complex64::default(); 2 * width],
            variances: vec![0.0; 2 * width],
        }
    }
    /// Channel `ch`'s harmonics.
    pub(super) fn of(&self, ch: usize) -> &[Complex64] {
        &self.values[ch * self.width..][..self.width]
    }
    fn of_mut(&mut self, ch: usize) -> &mut [Complex64] {
        &mut self.values[ch * self.width..][..self.width]
    }
    /// Channel `ch`'s variances.
    pub(super) fn variances(&self, ch: usize) -> &[f64] {
        &self.variances[ch * self.width..][..self.width]
    }
    /// Harmonic `h` of channel `ch` and its variance.
    pub(super) fn set(&mut self, ch: usize, h: usize, value: Complex64, variance: f64) {
        self.values[ch * self.width + h] = value;
        self.variances[ch * self.width + h] = variance;
    }
}

/// Samples either side of a window centre the compensation's kernel
/// reaches: four standard deviations, at most the active sweep.
pub(super) fn reach(sigma_samples: f64, sweep: &SweepFit) -> usize {
    ((4.0 * sigma_samples).ceil() as usize).min(sweep.end - sweep.start)
}

/// The plain (quasi-steady) windows.
pub(super) fn plain_windows(
    src: &mut dyn PairSource,
    law: &PhaseLaw,
    sweep: &SweepFit,
    options: &SweepOptions,
) -> Result<Vec<WindowFit>> {
    let k = options.max_harmonic;
    let width = k + 1;
    let mut lsq = HarmonicLsq::new(k, 2);
    let m = lsq.unknowns();
    let mut diag = vec![0.0; m];
    let theta0 = law.phase(sweep.start as f64);
    // sin/cos of the phase once per sample (windows overlap), kept from the
    // current window on
    let mut phasors = Phasors::default();
    let mut model = [0.0; 2];
    let mut out = Vec::new();
    let (mut na, mut nb) = (sweep.start, sweep.start);
    for i in 0.. {
        let ta = theta0 + 2.0 * PI * options.hop_periods * i as f64;
        let tb = ta + 2.0 * PI * options.window_periods as f64;
        while na < sweep.end && law.phase(na as f64) < ta {
            na += 1;
        }
        nb = nb.max(na);
        while nb < sweep.end && law.phase(nb as f64) < tb {
            nb += 1;
        }
        if nb >= sweep.end {
            break;
        }
        let sc = phasors.over(law, na, nb);
        let (force, response) = src.pair(na, nb)?;
        lsq.reset();
        for ((&(s1, c1), &f), &y) in sc.iter().zip(force).zip(response) {
            lsq.add_sc(s1, c1, &[f, y]);
        }
        if nb - na <= m || !lsq.solve() {
            return Err(Error::input(
                format!("sweep window {i} (samples {na}..{nb})"),
                format!(
                    "the harmonic fit is singular: {} samples for {m} unknowns per channel",
                    nb - na
                ),
            ));
        }
        let mut harmonics = Harmonics::new(width);
        lsq.harmonics(0, harmonics.of_mut(0));
        lsq.harmonics(1, harmonics.of_mut(1));
        // residual variances by a second pass (the cheap Σy² − cᵀAᵀy loses
        // precision on clean data)
        let (mut rf, mut ry) = (0.0, 0.0);
        for ((&(s1, c1), &f), &y) in sc.iter().zip(force).zip(response) {
            lsq.model_sc(s1, c1, &mut model);
            rf += (f - model[0]).powi(2);
            ry += (y - model[1]).powi(2);
        }
        let dof = (nb - na - m) as f64;
        let (sf, sy) = (rf / dof, ry / dof);
        lsq.inverse_diagonal(&mut diag);
        for (ch, s) in [sf, sy].into_iter().enumerate() {
            for h in 0..width {
                let v = if h == 0 {
                    s * diag[0]
                } else {
                    s * (diag[2 * h - 1] + diag[2 * h])
                };
                harmonics.variances[ch * width + h] = v;
            }
        }
        out.push(WindowFit {
            center: 0.5 * (na + nb - 1) as f64,
            harmonics,
            residual_var: [sf, sy],
        });
    }
    Ok(out)
}

/// `(sin θ(n), cos θ(n))` of the fitted phase over a stretch of samples
/// that only moves forward: each sample's computed once, and only the
/// current window's kept (a long record's would be 16 bytes a sample).
#[derive(Default)]
struct Phasors {
    start: usize,
    sc: Vec<(f64, f64)>,
}

impl Phasors {
    fn over(&mut self, law: &PhaseLaw, a: usize, b: usize) -> &[(f64, f64)] {
        let end = self.start + self.sc.len();
        if a < self.start || a > end {
            self.start = a;
            self.sc.clear();
        } else {
            self.sc.drain(..a - self.start);
            self.start = a;
        }
        let from = self.start + self.sc.len();
        self.sc
            .extend((from..b).map(|n| law.phase(n as f64).sin_cos()));
        &self.sc[..b - a]
    }
}

/// The compensated harmonics at each window centre (see the module docs):
/// per harmonic `h`, the signal minus the plain-window model of its other
/// harmonics is demodulated by `e^{−jhθ(n)}` and convolved with
/// `c_h(m) = e^{jhα m²/2} e^{−m²/2σ²}` (FFT convolution), then normalised by
/// the same kernel applied to the record's support, so that a constant
/// envelope is returned unchanged, also near the record's ends.
pub(super) fn compensated(
    force: &[f64],
    response: &[f64],
    law: &PhaseLaw,
    sweep: &SweepFit,
    windows: &[WindowFit],
    sigma_samples: f64,
    k: usize,
) -> Vec<Harmonics> {
    let alpha = law.chirp_rate();
    let (start, end) = (sweep.start, sweep.end);
    let len = end - start;
    let width = k + 1;
    let reach = reach(sigma_samples, sweep);
    let nfft = super::analytic::next_smooth(len + 2 * reach + 1);
    let mut planner = FftPlanner::<f64>::new();
    let fwd = planner.plan_fft_forward(nfft);
    let inv = planner.plan_fft_inverse(nfft);
    let scale = 1.0 / nfft as f64;
    // Nothing of the record's length is kept but the FFT buffers (three of
    // them at a time): the unit phasors `e^{jθ(n)}`, their powers and the
    // plain envelopes are recomputed per pass (`Demodulated`), in the same
    // order of operations as a stored copy would have been, so the same bits.
    // the record's support, for the normalisation, and Σ|c|² over it, both
    // kept at the window centres only
    let mut support = vec![Complex64::default(); nfft];
    support[reach..reach + len]
        .iter_mut()
        .for_each(|v| *v = Complex64::new(1.0, 0.0));
    fwd.process(&mut support);
    let s2 = sigma_samples * sigma_samples;
    let centers: Vec<usize> = window_centres(windows, sweep).map(|c| reach + c).collect();
    let energy: Vec<f64> = {
        let mut g2 = kernel(nfft, reach, |m| gaussian_squared(m, s2));
        fwd.process(&mut g2);
        let energy = convolve(&*inv, &support, g2, scale);
        centers.iter().map(|&c| energy[c].re).collect()
    };
    let mut out: Vec<Harmonics> = windows.iter().map(|_| Harmonics::new(width)).collect();
    let signals = [force, response];
    for h in 0..width {
        let hf = h as f64;
        let mut ker = kernel(nfft, reach, |m| chirp_kernel(m, s2, hf * alpha));
        fwd.process(&mut ker);
        let norm: Vec<Complex64> = {
            let norm = convolve(&*inv, &ker, support.clone(), scale);
            centers.iter().map(|&c| norm[c]).collect()
        };
        for (ch, signal) in signals.iter().enumerate() {
            // this harmonic alone: the signal minus the other harmonics' model
            let demodulated = Demodulated {
                law,
                start,
                windows,
                width,
                ch,
                h,
            };
            let mut d = vec![Complex64::default(); nfft];
            let mut j = 0;
            for i in 0..len {
                d[reach + i] = demodulated.at(i, signal[start + i], &mut j);
            }
            fwd.process(&mut d);
            let conv = convolve(&*inv, &ker, d, scale);
            for (w, &c) in centers.iter().enumerate() {
                store(
                    &mut out[w],
                    &windows[w],
                    (ch, h),
                    conv[c],
                    norm[w],
                    energy[w],
                );
            }
        }
    }
    out
}

/// Each window's centre as a sample of the active sweep, counted from its
/// start.
pub(super) fn window_centres<'a>(
    windows: &'a [WindowFit],
    sweep: &SweepFit,
) -> impl Iterator<Item = usize> + 'a {
    let (start, end) = (sweep.start, sweep.end);
    windows
        .iter()
        .map(move |w| (w.center.round() as usize).clamp(start, end - 1) - start)
}

/// The compensation's Gaussian squared, `e^{−m²/σ²}` (`s2 = σ²`): the
/// noise's propagation through the kernel.
pub(super) fn gaussian_squared(m: f64, s2: f64) -> Complex64 {
    Complex64::new((-(m * m) / s2).exp(), 0.0)
}

/// The compensation's kernel for harmonic `h`, `e^{jhα m²/2} e^{−m²/2σ²}`
/// (`h_alpha = hα`, `s2 = σ²`).
pub(super) fn chirp_kernel(m: f64, s2: f64, h_alpha: f64) -> Complex64 {
    Complex64::from_polar((-(m * m) / (2.0 * s2)).exp(), 0.5 * h_alpha * m * m)
}

/// Harmonic `h` of channel `ch` at a window from the kernel's sum over the
/// window's neighbourhood `conv`, normalised by the kernel's sum over the
/// record's support `norm`; its variance from the plain window's residual
/// variance `σ²` as white noise, `E|ΔA|² = factor² σ² Σ|c|² / |N|²`
/// (`energy = Σ|c|²` over the support; `factor` 2 for a harmonic, 1 for
/// the mean).
pub(super) fn store(
    out: &mut Harmonics,
    window: &WindowFit,
    (ch, h): (usize, usize),
    conv: Complex64,
    norm: Complex64,
    energy: f64,
) {
    let factor = if h == 0 { 1.0 } else { 2.0 };
    let value = conv / norm * factor;
    let var = window.residual_var[ch] * factor * factor * energy / norm.norm_sqr();
    out.set(ch, h, value, var);
}

/// The compensation's input for harmonic `h` of channel `ch` (0 the force,
/// 1 the response): the signal less the other harmonics' plain-window
/// model (interpolated linearly between window centres, held beyond the
/// first and the last), demodulated by `e^{−jhθ(n)}`.
pub(super) struct Demodulated<'a> {
    pub(super) law: &'a PhaseLaw,
    /// The active sweep's first sample; `i` counts from it.
    pub(super) start: usize,
    pub(super) windows: &'a [WindowFit],
    pub(super) width: usize,
    pub(super) ch: usize,
    pub(super) h: usize,
}

impl Demodulated<'_> {
    /// At sample `start + i`, whose value is `sample`; `j` is a cursor over
    /// the windows that only moves forward (start it at 0, or at the first
    /// window whose centre is after the sample).
    #[inline]
    pub(super) fn at(&self, i: usize, sample: f64, j: &mut usize) -> Complex64 {
        let (windows, h, ch) = (self.windows, self.h, self.ch);
        let n = (self.start + i) as f64;
        let (s, c) = self.law.phase(n).sin_cos();
        let u = Complex64::new(c, s);
        while *j < windows.len() && windows[*j].center <= n {
            *j += 1;
        }
        let (a, b, t) = if *j == 0 {
            (0, 0, 0.0)
        } else if *j == windows.len() {
            (*j - 1, *j - 1, 0.0)
        } else {
            let (a, b) = (&windows[*j - 1], &windows[*j]);
            (*j - 1, *j, (n - a.center) / (b.center - a.center))
        };
        let plain = |hh: usize| {
            let get = |w: &WindowFit| w.harmonics.of(ch)[hh];
            get(&windows[a]) * (1.0 - t) + get(&windows[b]) * t
        };
        // the other harmonics' model, and `e^{jhθ}` as `h` successive
        // products on the way
        let (mut full, mut pw, mut pw_h) =
            (0.0, Complex64::new(1.0, 0.0), Complex64::new(1.0, 0.0));
        for hh in 0..self.width {
            let v = plain(hh);
            full += if hh == 0 { v.re } else { (v * pw).re };
            if hh == h {
                pw_h = pw;
            }
            pw *= u;
        }
        let v = plain(h);
        let own = if h == 0 { v.re } else { (v * pw_h).re };
        pw_h.conj() * (sample - full + own)
    }
}

/// A kernel laid out for circular convolution: `m = 0..reach` at the start,
/// negative `m` at the end.
pub(super) fn kernel(nfft: usize, reach: usize, f: impl Fn(f64) -> Complex64) -> Vec<Complex64> {
    let mut k = vec![Complex64::default(); nfft];
    for m in 0..=reach {
        let v = f(m as f64);
        k[m] = v;
        if m > 0 {
            k[nfft - m] = v;
        }
    }
    k
}

/// Inverse FFT of `a · b` (both spectra), scaled.
pub(super) fn convolve(
    inv: &dyn rustfft::Fft<f64>,
    a: &[Complex64],
    mut b: Vec<Complex64>,
    scale: f64,
) -> Vec<Complex64> {
    for (x, y) in b.iter_mut().zip(a) {
        *x *= y * scale;
    }
    inv.process(&mut b);
    b
}
