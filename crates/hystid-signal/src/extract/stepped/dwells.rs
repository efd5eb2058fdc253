//! Dwells found in a stepped sine's reference: tracking windows of whole
//! periods, segmented where frequency or amplitude steps.

use super::DwellOptions;
use super::settling::{check_rate, settling};
use crate::error::{Error, Result};
use crate::extract::analytic::analytic;
use crate::extract::estimator::check_finite;
use crate::extract::lsq::HarmonicLsq;
use crate::extract::noncoherent::{estimate_frequency_named, fit_range, whole_periods};
use crate::signals::Step;
use num_complex::Complex64;

/// One tracking window: fractional sample bounds, frequency and amplitude
/// with their standard errors.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(in crate::extract) struct Window {
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
pub(in crate::extract) fn track(reference: &[f64], sample_rate_hz: f64, m: usize) -> Vec<Window> {
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
pub(in crate::extract) struct WindowTracker {
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
    pub(in crate::extract) fn new(sample_rate_hz: f64, m: usize) -> WindowTracker {
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
    pub(in crate::extract) fn push(&mut self, cycles: &[f64], amplitude: &[f64]) {
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
pub(in crate::extract) fn normalise(reference: &[f64]) -> (Vec<f64>, Vec<f64>) {
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
pub fn find_dwells_whole(
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
pub(in crate::extract) type ReadReference<'a, 'r> =
    dyn FnMut(std::ops::Range<usize>) -> Result<std::borrow::Cow<'r, [f64]>> + 'a;

/// [`find_dwells_whole`] from the reference's tracking windows: the dwells
/// they hold, each read (`read`) as it is examined, of a reference of
/// `frames` samples.
pub(in crate::extract) fn dwells_of_windows<'r>(
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
        return Err(Error::NoDwell {
            message: format!(
                "no dwell of constant frequency (within {:e}) and amplitude (within {:e}) lasting \
                 {} settled periods was found in {} windows of {} periods",
                options.frequency_tolerance,
                options.amplitude_tolerance,
                options.min_dwell_periods,
                windows.len(),
                options.window_periods
            ),
        });
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

pub(super) fn same_level(a: f64, b: f64) -> bool {
    (a - b).abs() <= 1e-9 * a.abs().max(b.abs())
}
