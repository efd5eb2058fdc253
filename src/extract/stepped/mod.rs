//! Stepped-sine reduction of a recording: dwells → FRF points → levels.
//!
//! With `excitation.steps` in the recording, each dwell after its `settle`
//! samples is reduced by the non-coherent least-squares fit at the stated
//! frequency (refined from the reference channel when the stated value is
//! off). Without steps, the dwells are found from the reference channel
//! ([`find_dwells`]). The reference is first divided by its local RMS, so
//! that the Hilbert transform's non-local tails (and the FFT's wrap of the
//! record's end onto its start) cannot bury a weak level under a strong one;
//! its phase is then cut into windows of whole periods, each with a
//! least-squares frequency and an amplitude and their standard errors. A
//! window joins the running dwell while both agree with the dwell's mean
//! within the tolerances or within 5 standard errors, whichever is wider, so
//! force noise and PCM quantisation do not split a dwell; neighbouring runs
//! of the same frequency and amplitude across a gap too short to be a dwell
//! are merged (a noisy window does not cut a dwell in two). The first and
//! last window of each dwell are dropped (either may hold the switch), the
//! level's settling at the start of a dwell (force amplitude ramping in) is
//! not taken for a dwell of its own, and the transient at the start of each
//! dwell is skipped by a settling test on consecutive blocks of whole
//! periods (how long a real structure rings is not known in advance; see
//! [`settling`]) run on the reference and then on the response. The points are
//! grouped into levels by nominal level, in measurement order, and split where
//! the frequency order reverses, which sets each level's [`Direction`]. Found
//! dwells have no nominal level: their measured reference amplitudes are
//! clustered (`level_tolerance`, 5 %), so a test whose force amplitude is not
//! controlled (force drop-out at resonance) should state its steps or widen
//! the tolerance.

use super::analytic::analytic;
use super::estimator::check_finite;
use super::lsq::HarmonicLsq;
use super::noncoherent::{
    block_bounds, estimate_frequency_named, fit_range, noncoherent_named, phase_slope_frequency,
    whole_periods,
};
use super::{Direction, FrfLevel, FrfPoint, NonlinearFrf};
use crate::error::{Error, Result};
use crate::harmonics::Quantity;
use crate::observe::{Observer, Silent};
use crate::signals::{Recording, Step};
use num_complex::Complex64;
use serde::{Deserialize, Serialize};

/// How dwells are found and when a dwell counts as settled.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct DwellOptions {
    /// Tracking window, in periods of the reference's own phase.
    pub window_periods: usize,
    /// Windows whose frequency differs from the running dwell mean by more
    /// than this (relative) or 5 standard errors, whichever is wider, start a
    /// new dwell. Both must be below the smallest relative frequency step.
    pub frequency_tolerance: f64,
    /// Same for the reference amplitude (relative).
    pub amplitude_tolerance: f64,
    /// Shortest usable dwell after settling, in periods.
    pub min_dwell_periods: usize,
    /// Block length of the settling test, in periods.
    pub settle_block_periods: usize,
    /// The settling test's tolerance, relative to the fundamental: a dwell is
    /// settled from the first block from which every block's harmonics agree
    /// with the dwell's settled state within it (or within the noise; see
    /// [`settling`]). The default 1e-3 suits real structures, whose FRFs
    /// drift slowly (the UNESP beam's |H1| moves 0.5 % over 40 s); a
    /// noise-free virtual test can ask for 1e-6.
    pub settle_tolerance: f64,
    /// Highest harmonic compared by the settling test.
    pub settle_max_harmonic: usize,
    /// Dwell amplitudes within this relative distance of each other form one
    /// level (found dwells; [`combine`] uses it to merge levels too).
    pub level_tolerance: f64,
}

impl Default for DwellOptions {
    fn default() -> Self {
        DwellOptions {
            window_periods: 4,
            frequency_tolerance: 2e-4,
            amplitude_tolerance: 0.02,
            min_dwell_periods: 16,
            settle_block_periods: 2,
            settle_tolerance: 1e-3,
            settle_max_harmonic: 3,
            level_tolerance: 0.05,
        }
    }
}

/// Options of [`reduce_stepped`].
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct ReduceOptions {
    /// Highest harmonic `K`.
    pub max_harmonic: usize,
    /// Blocks per dwell for the H1 estimator and its standard error (fewer
    /// when a dwell holds fewer whole periods, at least 2).
    pub blocks: usize,
    /// The stated frequency of a step is replaced by the one estimated from
    /// the reference when they differ by more than this (relative).
    pub frequency_tolerance: f64,
    /// The reference channel; default [`Recording::reference_channel`].
    pub reference_channel: Option<usize>,
    /// Dwell finding and settling.
    pub dwell: DwellOptions,
}

impl Default for ReduceOptions {
    fn default() -> Self {
        ReduceOptions {
            max_harmonic: 5,
            blocks: 8,
            frequency_tolerance: 1e-6,
            reference_channel: None,
            dwell: DwellOptions::default(),
        }
    }
}

/// What was done with one dwell.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct DwellReport {
    /// The dwell as analysed: `settle` covers every sample skipped.
    pub step: Step,
    /// The frequency stated by the recording's step (or by the dwell finder).
    pub stated_frequency_hz: f64,
    /// The frequency used: the stated one, or the estimate from the reference
    /// when they differed by more than the tolerance.
    pub frequency_hz: f64,
    /// Whether the frequency was replaced by the estimate.
    pub frequency_refined: bool,
    /// Index into `levels`, then into that level's `points`.
    pub level: usize,
    /// Index of the point within its level.
    pub point: usize,
}

/// The result of [`reduce_stepped_report`].
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct SteppedReduction {
    /// The FRFs.
    pub frf: NonlinearFrf,
    /// One report per dwell, in measurement order.
    pub dwells: Vec<DwellReport>,
    /// True when the dwells were found from the reference channel (the
    /// recording had no steps).
    pub dwells_found: bool,
}

/// Where a dwell has settled.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct Settling {
    /// Samples to skip from the start of the dwell.
    pub settle: usize,
    /// False when fewer than `min_dwell_periods` settled periods remain.
    pub settled: bool,
}

pub(super) fn check_rate(sample_rate_hz: f64) -> Result<()> {
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

/// One tracking window: fractional sample bounds, frequency and amplitude
/// with their standard errors.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) struct Window {
    end: f64,
    frequency: f64,
    frequency_se: f64,
    amplitude: f64,
    amplitude_se: f64,
}

/// Windows of `m` whole periods of the reference's own phase. A window's
/// frequency is the least-squares slope of the instantaneous phase over its
/// samples and its amplitude the mean envelope; their standard errors come
/// from the residual scatter about the line and the mean, so that the
/// segmentation can tell noise (force noise, PCM quantisation) from a step.
/// A least-squares slope is about `√(n/6)` times less noisy than the phase
/// advance between the window's ends.
///
/// The Hilbert transform is not local: the tail of a strong dwell reaches a
/// weak one as an error of about `A_strong/(2π·p)` at `p` periods, and the
/// FFT wraps the record's end onto its start. A test whose levels span
/// 0.02–60 units would lose the phase of its lowest levels that way, so the
/// reference is first divided by its local RMS over about two of its
/// longest periods ([`normalise`]) and the phase taken from that unit-level
/// signal; amplitudes are the normalised envelope times the local RMS.
pub(super) fn track(reference: &[f64], sample_rate_hz: f64, m: usize) -> Vec<Window> {
    let (unit, rms) = normalise(reference);
    let mut a = analytic(&unit);
    for (e, r) in a.amplitude.iter_mut().zip(&rms) {
        *e *= r;
    }
    let cycles: Vec<f64> = a
        .phase
        .iter()
        .map(|p| p / (2.0 * std::f64::consts::PI))
        .collect();
    let mut tracker = WindowTracker::new(sample_rate_hz, m);
    tracker.push(&cycles, &a.amplitude);
    tracker.windows
}

/// [`track`]'s windows cut as the phase (in cycles) and the envelope come,
/// a stretch at a time: holds the samples since the current window's start,
/// not the record (the same windows, to the bit, however the samples are
/// split).
pub(super) struct WindowTracker {
    sample_rate_hz: f64,
    m: usize,
    /// The first sample's phase, cycles.
    cycles0: Option<f64>,
    /// The samples held, from `from` on.
    cycles: Vec<f64>,
    amplitude: Vec<f64>,
    from: usize,
    /// The next sample whose phase may reach the next window's end.
    idx: usize,
    /// The last window's end (fractional sample).
    prev: f64,
    /// The next window's number (from 1).
    j: usize,
    /// The windows cut so far.
    pub windows: Vec<Window>,
}

impl WindowTracker {
    pub(super) fn new(sample_rate_hz: f64, m: usize) -> WindowTracker {
        WindowTracker {
            sample_rate_hz,
            m,
            cycles0: None,
            cycles: Vec::new(),
            amplitude: Vec::new(),
            from: 0,
            idx: 1,
            prev: 0.0,
            j: 1,
            windows: Vec::new(),
        }
    }

    /// Pushes the next samples' phase (cycles) and envelope, and cuts every
    /// window they complete.
    pub(super) fn push(&mut self, cycles: &[f64], amplitude: &[f64]) {
        if self.cycles0.is_none() {
            self.cycles0 = cycles.first().copied();
        }
        self.cycles.extend_from_slice(cycles);
        self.amplitude.extend_from_slice(amplitude);
        let Some(cycles0) = self.cycles0 else {
            return;
        };
        let (from, m) = (self.from, self.m);
        // samples received: a window ends at the first sample whose phase
        // reaches its target, which must have arrived
        let received = from + self.cycles.len();
        let c = |i: usize| self.cycles[i - from];
        let a = |i: usize| self.amplitude[i - from];
        loop {
            let target = cycles0 + (self.j * m) as f64;
            while self.idx < received && c(self.idx) < target {
                self.idx += 1;
            }
            if self.idx >= received {
                break;
            }
            let idx = self.idx;
            let (c0, c1) = (c(idx - 1), c(idx));
            let t = (idx - 1) as f64
                + if c1 > c0 {
                    (target - c0) / (c1 - c0)
                } else {
                    1.0
                };
            let lo = self.prev.ceil() as usize;
            let hi = t.floor() as usize;
            let mut w = Window {
                end: t,
                frequency: m as f64 * self.sample_rate_hz / (t - self.prev),
                frequency_se: f64::INFINITY,
                amplitude: a(hi.min(lo)),
                amplitude_se: f64::INFINITY,
            };
            if hi >= lo + 3 {
                let count = (hi - lo + 1) as f64;
                let mid = 0.5 * (lo + hi) as f64;
                let (mut sxx, mut sxy, mut sy, mut sa) = (0.0, 0.0, 0.0, 0.0);
                for i in lo..=hi {
                    let x = i as f64 - mid;
                    sxx += x * x;
                    sxy += x * c(i);
                    sy += c(i);
                    sa += a(i);
                }
                let (slope, mean_c, mean_a) = (sxy / sxx, sy / count, sa / count);
                let (mut rc, mut ra) = (0.0, 0.0);
                for i in lo..=hi {
                    rc += (c(i) - mean_c - slope * (i as f64 - mid)).powi(2);
                    ra += (a(i) - mean_a).powi(2);
                }
                w.frequency = slope * self.sample_rate_hz;
                w.frequency_se = (rc / (count - 2.0) / sxx).sqrt() * self.sample_rate_hz;
                w.amplitude = mean_a;
                w.amplitude_se = (ra / (count - 1.0) / count).sqrt();
            }
            self.windows.push(w);
            self.prev = t;
            self.j += 1;
        }
        // what no later window reads: before the sample the last window
        // ended in (a window shorter than a sample reads its envelope
        // there) and before the sample ahead of the search
        let keep = (self.prev.floor() as usize).min(self.idx - 1).max(from);
        self.cycles.drain(..keep - from);
        self.amplitude.drain(..keep - from);
        self.from = keep;
    }
}

/// The reference divided by its local RMS (mean removed), and that RMS:
/// the local RMS is taken over about two of the signal's longest periods,
/// found from the gaps between its zero crossings (the 90th percentile of
/// the half periods, so that noise crossings, which only shorten gaps, do
/// not matter).
pub(super) fn normalise(reference: &[f64]) -> (Vec<f64>, Vec<f64>) {
    let n = reference.len();
    let mean = reference.iter().sum::<f64>() / n as f64;
    let mut gaps: Vec<usize> = Vec::new();
    let mut last: Option<usize> = None;
    for i in 1..n {
        if (reference[i - 1] - mean < 0.0) != (reference[i] - mean < 0.0) {
            if let Some(l) = last {
                gaps.push(i - l);
            }
            last = Some(i);
        }
    }
    gaps.sort_unstable();
    let half_period = gaps
        .get(gaps.len() * 9 / 10)
        .copied()
        .unwrap_or(n / 4)
        .max(2);
    let half = (2 * half_period).min(n / 2).max(1); // a window of 4 half periods
    let mut cum = Vec::with_capacity(n + 1);
    cum.push(0.0);
    let mut acc = 0.0;
    for &v in reference {
        acc += (v - mean) * (v - mean);
        cum.push(acc);
    }
    let mut unit = Vec::with_capacity(n);
    let mut rms = Vec::with_capacity(n);
    for (i, &v) in reference.iter().enumerate() {
        let lo = i.saturating_sub(half);
        let hi = (i + half + 1).min(n);
        let r = ((cum[hi] - cum[lo]).max(0.0) / (hi - lo) as f64).sqrt();
        rms.push(r);
        unit.push(if r > 0.0 { (v - mean) / r } else { 0.0 });
    }
    (unit, rms)
}

/// Standard errors apart beyond which two tracking estimates differ.
const SEPARATION: f64 = 5.0;

/// A run of tracking windows taken for one dwell: first and last window,
/// the mean frequency and amplitude and their standard errors.
#[derive(Clone, Copy, Debug)]
struct Run {
    first: usize,
    last: usize,
    sum_f: f64,
    var_f: f64,
    sum_a: f64,
    var_a: f64,
}

impl Run {
    fn new(i: usize, w: &Window) -> Run {
        Run {
            first: i,
            last: i,
            sum_f: w.frequency,
            var_f: w.frequency_se.powi(2),
            sum_a: w.amplitude,
            var_a: w.amplitude_se.powi(2),
        }
    }
    fn count(&self) -> f64 {
        (self.last - self.first + 1) as f64
    }
    /// Mean frequency and its standard error.
    fn frequency(&self) -> (f64, f64) {
        (self.sum_f / self.count(), self.var_f.sqrt() / self.count())
    }
    fn amplitude(&self) -> (f64, f64) {
        (self.sum_a / self.count(), self.var_a.sqrt() / self.count())
    }
    /// Whether estimates `(f, se_f)` and `(a, se_a)` are those of this
    /// run's dwell: within the relative tolerances or within the noise.
    fn agrees(&self, f: (f64, f64), a: (f64, f64), options: &DwellOptions) -> bool {
        let ((mf, sf), (ma, sa)) = (self.frequency(), self.amplitude());
        let close = |x: f64, y: f64, se: f64, tol: f64| {
            (x - y).abs() <= (tol * y.abs()).max(SEPARATION * se)
        };
        close(f.0, mf, sf.hypot(f.1), options.frequency_tolerance)
            && close(a.0, ma, sa.hypot(a.1), options.amplitude_tolerance)
    }
    fn push(&mut self, i: usize, w: &Window) {
        self.last = i;
        self.sum_f += w.frequency;
        self.var_f += w.frequency_se.powi(2);
        self.sum_a += w.amplitude;
        self.var_a += w.amplitude_se.powi(2);
    }
    /// Absorbs `other`, which follows this run after a few rejected windows
    /// (`windows` gives their estimates).
    fn absorb(&mut self, other: &Run, windows: &[Window]) {
        for i in self.last + 1..other.first {
            self.push(i, &windows[i]);
        }
        self.last = other.last;
        self.sum_f += other.sum_f;
        self.var_f += other.var_f;
        self.sum_a += other.sum_a;
        self.var_a += other.var_a;
    }
}

/// The weakest dwell sought, relative to the strongest window: 80 dB. The
/// normalised phase follows any signal, so without a floor the hum and noise
/// after the excitation stops (a real recording's mains hum at 3e-5 of its
/// drive) would read as dwells; a stepped-sine test's levels span far less
/// (0.02–60 units is 70 dB), and 80 dB down a PCM16 channel holds 3 steps.
const DYNAMIC_RANGE: f64 = 1e-4;

/// Splits the windows into runs of constant frequency and amplitude, then
/// merges neighbouring runs that are one dwell cut by a noisy window.
fn segment(windows: &[Window], options: &DwellOptions) -> Vec<(usize, usize)> {
    let mut runs: Vec<Run> = Vec::new();
    let mut current: Option<Run> = None;
    let floor = DYNAMIC_RANGE
        * windows
            .iter()
            .map(|w| w.amplitude)
            .filter(|a| a.is_finite())
            .fold(0.0, f64::max);
    for (i, w) in windows.iter().enumerate() {
        let usable =
            w.frequency_se.is_finite() && w.amplitude_se.is_finite() && w.amplitude > floor;
        match current.as_mut() {
            Some(r)
                if usable
                    && r.agrees(
                        (w.frequency, w.frequency_se),
                        (w.amplitude, w.amplitude_se),
                        options,
                    ) =>
            {
                r.push(i, w)
            }
            _ => {
                if let Some(r) = current.take()
                    && r.count() >= 3.0
                {
                    runs.push(r);
                }
                current = usable.then(|| Run::new(i, w));
            }
        }
    }
    if let Some(r) = current
        && r.count() >= 3.0
    {
        runs.push(r);
    }
    // a gap shorter than a dwell cannot hide another dwell: neighbouring
    // runs of the same frequency and amplitude across it are one dwell
    let max_gap = options
        .min_dwell_periods
        .div_ceil(options.window_periods.max(1))
        .max(1);
    let mut merged: Vec<Run> = Vec::with_capacity(runs.len());
    for r in runs {
        match merged.last_mut() {
            Some(m)
                if r.first - m.last <= max_gap
                    && m.agrees(r.frequency(), r.amplitude(), options) =>
            {
                m.absorb(&r, windows)
            }
            _ => merged.push(r),
        }
    }
    merged.into_iter().map(|r| (r.first, r.last)).collect()
}

/// Finds the stepped-sine dwells of a recording from its reference channel.
///
/// The reference, divided by its local RMS, gives an instantaneous phase
/// (FFT Hilbert transform) that is cut into windows of `window_periods` whole
/// periods, each with a least-squares frequency and a mean amplitude and
/// their standard errors. A window joins the current dwell while its
/// frequency and amplitude agree with the dwell's running means within the
/// tolerances or within 5 standard errors (whichever is wider); neighbouring
/// runs that agree across a gap shorter than `min_dwell_periods` are one
/// dwell. Windows weaker than 1e-4 of the strongest (80 dB) are ignored. The
/// first and last window of each dwell are dropped (either may hold the
/// switch), and runs shorter than `min_dwell_periods` are discarded. Each
/// dwell's frequency is then estimated by least squares
/// ([`super::estimate_frequency`]) and its start transient found by
/// [`settling`] on the reference; a run followed by one at the same
/// frequency that has not settled or lies within `level_tolerance` of it is
/// that dwell's level moving in and is dropped; any other dwell whose
/// reference does not settle keeps its later half. Dwell amplitudes are
/// clustered into levels (`level_tolerance`), and each step's `level` is its
/// cluster's mean amplitude.
///
/// Errors: bad rate, a non-finite sample, no dwell found.
pub fn find_dwells(
    reference: &[f64],
    sample_rate_hz: f64,
    options: &DwellOptions,
) -> Result<Vec<Step>> {
    check_rate(sample_rate_hz)?;
    check_finite(reference, "reference")?;
    if reference.len() < 64 {
        return Err(Error::input(
            "reference",
            format!("{} samples: too short to find dwells", reference.len()),
        ));
    }
    let windows = track(reference, sample_rate_hz, options.window_periods.max(1));
    dwells_of_windows(
        &windows,
        reference.len(),
        sample_rate_hz,
        options,
        &mut |r| Ok(std::borrow::Cow::Borrowed(&reference[r])),
    )
}

/// A stretch of the reference, `frames` of it: borrowed where it is held,
/// read where it is not.
pub(super) type ReadReference<'a, 'r> =
    dyn FnMut(std::ops::Range<usize>) -> Result<std::borrow::Cow<'r, [f64]>> + 'a;

/// [`find_dwells`] from the reference's tracking windows: the dwells they
/// hold, each read (`read`) as it is examined, of a reference of `frames`
/// samples.
pub(super) fn dwells_of_windows<'r>(
    windows: &[Window],
    frames: usize,
    sample_rate_hz: f64,
    options: &DwellOptions,
    read: &mut ReadReference<'_, 'r>,
) -> Result<Vec<Step>> {
    let segments = segment(windows, options);
    // candidates: bounds, first frequency estimate, settling on the reference
    let mut candidates = Vec::with_capacity(segments.len());
    for (si, &(a, b)) in segments.iter().enumerate() {
        // drop the first and the last window: a window holding a switch
        // close to its end joins a run within the noise, so either may hold
        // samples of the neighbouring step
        let start = windows[a].end.ceil() as usize;
        let end = (windows[b - 1].end.floor() as usize + 1).min(frames);
        let what = format!("found dwell {si} (samples {start}..{end})");
        let segment = read(start..end)?;
        let segment = &segment[..];
        let Ok(f0) = estimate_frequency_named(segment, sample_rate_hz, &what) else {
            continue;
        };
        // a run shorter than a usable dwell is the remains of a switch
        let periods = whole_periods(segment.len(), sample_rate_hz, f0);
        if periods < options.min_dwell_periods {
            continue;
        }
        let s = settling(segment, None, sample_rate_hz, f0, options)?;
        let mean = segment.iter().sum::<f64>() / segment.len() as f64;
        let rms =
            (segment.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / segment.len() as f64).sqrt();
        candidates.push((start, end, f0, periods, s, what, rms));
    }
    let mut steps = Vec::new();
    for (ci, (start, end, f0, periods, mut s, what, rms)) in candidates.iter().cloned().enumerate()
    {
        // a run followed by a run at the same frequency, which either never
        // settles or lies within a level's tolerance of it, is that dwell's
        // level still moving (a force amplitude ramping up or drifting in):
        // not a dwell of its own
        if candidates.get(ci + 1).is_some_and(|next| {
            (next.2 - f0).abs() <= options.frequency_tolerance.max(1e-6) * f0
                && (!s.settled || (next.6 - rms).abs() <= options.level_tolerance * next.6)
        }) {
            continue;
        }
        if !s.settled {
            // otherwise a run of constant frequency and amplitude is a dwell
            // even if the settling test, run at the 4-sigma noise limit on
            // many blocks and harmonics, flags a short one: keep its later
            // half, as for a response that never settles
            s.settle = ((periods / 2) as f64 * sample_rate_hz / f0).floor() as usize;
        }
        let segment = read(start + s.settle..end)?;
        let settled = &segment[..];
        let f = if s.settle > 0 {
            estimate_frequency_named(settled, sample_rate_hz, &what).unwrap_or(f0)
        } else {
            f0
        };
        // measured amplitude of the fundamental over the settled part
        let mut lsq = HarmonicLsq::new(1, 1);
        let mut h = [Complex64::default(); 2];
        if !fit_range(
            &mut lsq,
            &[settled],
            0..settled.len(),
            f / sample_rate_hz,
            &mut [&mut h[..]],
        ) {
            continue;
        }
        steps.push(Step {
            frequency_hz: f,
            level: h[1].norm(),
            start,
            settle: s.settle,
            length: end - start,
        });
    }
    if steps.is_empty() {
        return Err(Error::input(
            "reference",
            format!(
                "no dwell of constant frequency (within {:e}) and amplitude (within {:e}) lasting \
                 {} settled periods was found in {} windows of {} periods",
                options.frequency_tolerance,
                options.amplitude_tolerance,
                options.min_dwell_periods,
                windows.len(),
                options.window_periods
            ),
        ));
    }
    // cluster the amplitudes into levels
    let mut order: Vec<usize> = (0..steps.len()).collect();
    order.sort_by(|&i, &j| steps[i].level.total_cmp(&steps[j].level));
    let mut clusters: Vec<Vec<usize>> = Vec::new();
    for &i in &order {
        match clusters.last_mut() {
            Some(c)
                if steps[i].level
                    <= steps[*c.last().expect("non-empty")].level
                        * (1.0 + options.level_tolerance) =>
            {
                c.push(i)
            }
            _ => clusters.push(vec![i]),
        }
    }
    for c in clusters {
        let mean = c.iter().map(|&i| steps[i].level).sum::<f64>() / c.len() as f64;
        for i in c {
            steps[i].level = mean;
        }
    }
    Ok(steps)
}

/// Distinct sample values below which a dwell's response is taken as below
/// the recording's resolution (5 bits' worth of steps).
pub const MIN_DISTINCT_VALUES: usize = 32;

/// Whether `samples` take fewer than [`MIN_DISTINCT_VALUES`] distinct values:
/// a response quantised to a few steps of an integer (PCM) recording. A float
/// recording, or any response a converter resolves, has thousands.
pub fn below_resolution(samples: &[f64]) -> bool {
    let mut seen: Vec<u64> = Vec::with_capacity(MIN_DISTINCT_VALUES);
    for v in samples {
        let b = v.to_bits();
        if !seen.contains(&b) {
            seen.push(b);
            if seen.len() >= MIN_DISTINCT_VALUES {
                return false;
            }
        }
    }
    !samples.is_empty()
}

fn same_level(a: f64, b: f64) -> bool {
    (a - b).abs() <= 1e-9 * a.abs().max(b.abs())
}

/// Groups points (with their nominal level) into levels in measurement
/// order: a new level starts where the nominal level changes or where the
/// frequency order reverses. Returns the levels and, per input point, its
/// `(level, point)` index.
pub(super) fn group_levels(points: Vec<(f64, FrfPoint)>) -> (Vec<FrfLevel>, Vec<(usize, usize)>) {
    let mut levels: Vec<FrfLevel> = Vec::new();
    let mut dir: Option<Direction> = None;
    let mut index = Vec::with_capacity(points.len());
    for (level, p) in points {
        let joins = match levels.last() {
            Some(l) if same_level(l.level, level) => {
                let last = l.points.last().expect("non-empty").frequency_hz;
                let step = if p.frequency_hz > last {
                    Some(Direction::Up)
                } else if p.frequency_hz < last {
                    Some(Direction::Down)
                } else {
                    None
                };
                match (dir, step) {
                    (None, s) => {
                        if s.is_some() {
                            dir = s;
                        }
                        true
                    }
                    (Some(d), Some(s)) => d == s,
                    (Some(_), None) => false,
                }
            }
            _ => false,
        };
        if !joins {
            if let (Some(l), Some(d)) = (levels.last_mut(), dir) {
                l.direction = d;
            }
            levels.push(FrfLevel {
                level,
                direction: Direction::Up,
                points: Vec::new(),
            });
            dir = None;
        }
        let li = levels.len() - 1;
        let l = &mut levels[li];
        index.push((li, l.points.len()));
        l.points.push(p);
    }
    if let (Some(l), Some(d)) = (levels.last_mut(), dir) {
        l.direction = d;
    }
    (levels, index)
}

/// Reduces a stepped-sine recording into nonlinear FRFs of one response
/// channel (see [`reduce_stepped_report`]).
pub fn reduce_stepped(
    rec: &Recording,
    response_channel: usize,
    options: &ReduceOptions,
) -> Result<NonlinearFrf> {
    reduce_stepped_report(rec, response_channel, options).map(|r| r.frf)
}

/// Reduces a stepped-sine recording into nonlinear FRFs of one response
/// channel, with a report per dwell.
///
/// Dwells come from `meta.excitation.steps` when present (each analysed
/// after its `settle` samples; the stated frequency is checked against the
/// reference by the phase advance between the dwell's halves and replaced by
/// the least-squares estimate when they differ by more than
/// `frequency_tolerance`), otherwise from [`find_dwells`], in which case the
/// [`settling`] test is also run on the response (the force of a virtual test
/// has no transient; the response has). Each dwell is reduced by
/// [`super::noncoherent`] with `blocks` blocks over its largest window of
/// whole periods. Points are grouped into levels in measurement order (a new
/// level where the nominal level changes or the frequency order reverses).
///
/// Errors name the channel or the step: no reference channel, a response
/// channel out of range or equal to the reference, a step outside the record,
/// a dwell too short for 2 blocks, a harmonic above Nyquist.
pub fn reduce_stepped_report(
    rec: &Recording,
    response_channel: usize,
    options: &ReduceOptions,
) -> Result<SteppedReduction> {
    reduce_stepped_observed(rec, response_channel, options, &Silent)
}

/// [`reduce_stepped_report`], telling `observer` after each dwell
/// (`reducing`, dwells done of all) and stopping there if it asks
/// ([`Error::Cancelled`]).
pub fn reduce_stepped_observed(
    rec: &Recording,
    response_channel: usize,
    options: &ReduceOptions,
    observer: &dyn Observer,
) -> Result<SteppedReduction> {
    reduce_stepped_as(rec, response_channel, options, observer, false)
}

/// [`reduce_stepped_observed`]; `as_found`: the steps the recording states
/// were found in its reference (by [`super::find_dwells_stream`]), and are
/// reduced as found ones are (the response's settling tested too).
pub(super) fn reduce_stepped_as(
    rec: &Recording,
    response_channel: usize,
    options: &ReduceOptions,
    observer: &dyn Observer,
    as_found: bool,
) -> Result<SteppedReduction> {
    let reference_channel = options
        .reference_channel
        .or_else(|| rec.reference_channel())
        .ok_or_else(|| {
            Error::input(
                "recording",
                "has no force or voltage channel to use as the reference",
            )
        })?;
    let nch = rec.channels.len().min(rec.meta.channels.len());
    for (what, c) in [
        ("reference", reference_channel),
        ("response", response_channel),
    ] {
        if c >= nch {
            return Err(Error::input(
                format!("{what} channel {c}"),
                format!("out of range: the recording has {nch} channels"),
            ));
        }
    }
    if response_channel == reference_channel {
        return Err(Error::input(
            format!("response channel {response_channel}"),
            "is the reference channel",
        ));
    }
    let fs = rec.meta.sample_rate_hz;
    check_rate(fs)?;
    let reference = &rec.channels[reference_channel];
    let response = &rec.channels[response_channel];
    let ref_name = &rec.meta.channels[reference_channel].name;
    let resp_name = &rec.meta.channels[response_channel].name;
    if reference.len() != response.len() {
        return Err(Error::input(
            format!("channel `{resp_name}`"),
            format!(
                "has {} frames but the reference `{ref_name}` has {}",
                response.len(),
                reference.len()
            ),
        ));
    }
    let ref_quantity = rec.meta.channels[reference_channel].quantity;
    if !matches!(ref_quantity, Quantity::Force | Quantity::Voltage) {
        return Err(Error::input(
            format!("reference channel `{ref_name}`"),
            format!("is a {ref_quantity} channel; a force or voltage is expected"),
        ));
    }
    check_finite(reference, &format!("channel `{ref_name}`"))?;
    check_finite(response, &format!("channel `{resp_name}`"))?;
    let frames = reference.len();
    let dwells_found = as_found || rec.meta.excitation.steps.is_empty();
    let steps = if rec.meta.excitation.steps.is_empty() {
        find_dwells(reference, fs, &options.dwell)?
    } else {
        rec.meta.excitation.steps.clone()
    };
    let mut points = Vec::with_capacity(steps.len());
    let mut reports = Vec::with_capacity(steps.len());
    for (i, step) in steps.iter().enumerate() {
        let what = format!("step {i} ({} Hz)", step.frequency_hz);
        let end = step.start.saturating_add(step.length);
        if end > frames || step.settle >= step.length {
            return Err(Error::input(
                format!("excitation.steps[{i}]"),
                format!(
                    "start {} + length {} (settle {}) must lie within the {frames} frames and \
                     settle must be shorter than the length",
                    step.start, step.length, step.settle
                ),
            ));
        }
        if !(step.frequency_hz.is_finite() && step.frequency_hz > 0.0) {
            return Err(Error::input(
                format!("excitation.steps[{i}].frequency_hz"),
                format!("must be finite and > 0, got {}", step.frequency_hz),
            ));
        }
        let mut start = step.start + step.settle;
        let mut settled = true;
        let stated = step.frequency_hz;
        let mut f = stated;
        if dwells_found {
            let s = settling(
                &reference[start..end],
                Some(&response[start..end]),
                fs,
                f,
                &options.dwell,
            )?;
            settled = s.settled;
            if s.settled {
                start += s.settle;
            } else {
                // never settled: use the later half, and say so
                start += (end - start) / 2;
            }
        }
        let mut refined = false;
        let check = phase_slope_frequency(&reference[start..end], fs, f);
        if check.is_none_or(|fc| (fc - f).abs() > options.frequency_tolerance * f) {
            f = estimate_frequency_named(&reference[start..end], fs, &what)?;
            refined = (f - stated).abs() > options.frequency_tolerance * stated;
            if !refined {
                f = stated;
            }
        }
        let periods = whole_periods(end - start, fs, f);
        let blocks = options.blocks.min(periods).max(2);
        let d = noncoherent_named(
            &reference[start..end],
            &response[start..end],
            fs,
            f,
            options.max_harmonic,
            blocks,
            &what,
        )?;
        let f1 = d.force[1];
        let settle = start - step.start;
        // a response within a few steps of an integer converter is not a
        // signal plus noise: its quantisation error follows the signal, so
        // the block scatter says nothing of it. Its standard error is unknown
        // (NaN), which leaves the point out of any fit.
        let std_error = if below_resolution(&response[start..end]) {
            vec![f64::NAN; d.std_error.len()]
        } else {
            d.std_error
        };
        points.push((
            step.level,
            FrfPoint {
                frequency_hz: f,
                force_amplitude: f1.norm(),
                h: d.h,
                std_error,
                force_distortion: d
                    .force
                    .iter()
                    .enumerate()
                    .map(|(k, fk)| crate::harmonics::referred_to_force(*fk, k, f1) / f1)
                    .collect(),
                blocks: d.blocks,
                settle_periods: (settle as f64 * f / fs).round() as usize,
                settled,
            },
        ));
        reports.push(DwellReport {
            step: Step {
                frequency_hz: f,
                level: step.level,
                start: step.start,
                settle,
                length: step.length,
            },
            stated_frequency_hz: stated,
            frequency_hz: f,
            frequency_refined: refined,
            level: 0,
            point: 0,
        });
        crate::observe::progress(observer, "reducing", i as u64 + 1, steps.len() as u64)?;
    }
    let (levels, index) = group_levels(points);
    for (r, (l, p)) in reports.iter_mut().zip(index) {
        r.level = l;
        r.point = p;
    }
    Ok(SteppedReduction {
        frf: NonlinearFrf {
            response: rec.meta.channels[response_channel].quantity,
            reference: ref_quantity,
            max_harmonic: options.max_harmonic,
            levels,
        },
        dwells: reports,
        dwells_found,
    })
}

/// Combines FRF sets (e.g. several single-sine recordings, one dwell each)
/// into one: levels within the default 5 % of each other are merged (see
/// [`combine_with`]).
pub fn combine(frfs: &[NonlinearFrf]) -> Result<NonlinearFrf> {
    combine_with(frfs, DwellOptions::default().level_tolerance)
}

/// Combines FRF sets into one.
///
/// All sets must have the same response and reference quantities and the
/// same `max_harmonic`. Levels of the same [`Direction`] whose nominal levels
/// lie within `level_tolerance` (relative, chained in ascending order) are
/// merged into one level at their mean nominal level; the merged points are
/// sorted by frequency (ascending for [`Direction::Up`], descending for
/// [`Direction::Down`], the order of a measurement in that direction).
/// Levels are returned in ascending nominal level, `Up` before `Down`.
pub fn combine_with(frfs: &[NonlinearFrf], level_tolerance: f64) -> Result<NonlinearFrf> {
    let first = frfs
        .first()
        .ok_or_else(|| Error::input("frfs", "nothing to combine: the list is empty"))?;
    for (i, f) in frfs.iter().enumerate() {
        if f.response != first.response
            || f.reference != first.reference
            || f.max_harmonic != first.max_harmonic
        {
            return Err(Error::input(
                format!("frfs[{i}]"),
                format!(
                    "is {}/{} up to harmonic {} but frfs[0] is {}/{} up to harmonic {}: only FRFs \
                     of the same quantities and harmonics combine",
                    f.response,
                    f.reference,
                    f.max_harmonic,
                    first.response,
                    first.reference,
                    first.max_harmonic
                ),
            ));
        }
    }
    let mut out = Vec::new();
    for dir in [Direction::Up, Direction::Down] {
        let mut levels: Vec<&FrfLevel> = frfs
            .iter()
            .flat_map(|f| &f.levels)
            .filter(|l| l.direction == dir)
            .collect();
        levels.sort_by(|a, b| a.level.total_cmp(&b.level));
        let mut groups: Vec<Vec<&FrfLevel>> = Vec::new();
        for l in levels {
            match groups.last_mut() {
                Some(g)
                    if (l.level - g.last().expect("non-empty").level).abs()
                        <= level_tolerance * l.level.abs() =>
                {
                    g.push(l)
                }
                _ => groups.push(vec![l]),
            }
        }
        for g in groups {
            let level = g.iter().map(|l| l.level).sum::<f64>() / g.len() as f64;
            let mut points: Vec<FrfPoint> = g.iter().flat_map(|l| l.points.clone()).collect();
            points.sort_by(|a, b| a.frequency_hz.total_cmp(&b.frequency_hz));
            if dir == Direction::Down {
                points.reverse();
            }
            out.push(FrfLevel {
                level,
                direction: dir,
                points,
            });
        }
    }
    out.sort_by(|a, b| a.level.total_cmp(&b.level));
    Ok(NonlinearFrf {
        response: first.response,
        reference: first.reference,
        max_harmonic: first.max_harmonic,
        levels: out,
    })
}
