//! Data-quality checks of a recording before it is identified.
//!
//! Each check looks for one way measured data goes wrong and reports it as
//! a [`Finding`] naming the channel and the sample positions:
//!
//! * **Non-finite samples** (NaN, ±Inf): an [`Severity::Error`]; every
//!   later stage (harmonic extraction, fitting) would turn them into garbage,
//!   so the caller should stop.
//! * **Clipping**: runs of at least `clip_min_run` consecutive samples at
//!   the channel's extreme value (an ADC rail holds the same code), or at or
//!   beyond a declared full scale. A clipped force makes the measured
//!   fundamental, and so every FRF `H_h = Y_h / F_1`, wrong.
//! * **Dropouts**: runs of at least `dropout_min_run` exactly repeated values
//!   (zeros included) inside a stretch where the signal is otherwise active,
//!   i.e. where the RMS deviation from the mean, in windows on both sides,
//!   exceeds `active_fraction` of the channel's AC RMS. A real, noisy analogue
//!   signal never repeats a value that often; a lost packet or a stuck
//!   converter does. Constant stretches at the very start or end (e.g. before
//!   the excitation began) are reported as information only.
//! * **DC offset**: the mean above `dc_offset_ratio` times the RMS of the AC
//!   part (standard deviation). An offset leaks into the `h = 0` term and,
//!   through a window, into low harmonics.
//! * **Sample-rate mismatch**: a declared rate against the spacing of a time
//!   column ([`check_time_axis`], with jitter and gaps), or the dominant
//!   frequency of the reference channel against a nominal excitation
//!   frequency (whole record, or each stepped-sine dwell): a wrong rate
//!   scales every frequency by the same factor.
//!
//! NaN/Inf and a broken time axis are errors; the other findings are
//! warnings (the data may still be usable, the user decides) or
//! information.

use crate::record::Recording;
use realfft::RealFftPlanner;
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;

/// How bad a finding is.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Severity {
    /// Worth knowing, no action needed.
    Info,
    /// The data may be unreliable here; look before identifying.
    Warning,
    /// The data cannot be used as it is (NaN/Inf, broken time axis).
    Error,
}

impl std::fmt::Display for Severity {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            Severity::Info => "info",
            Severity::Warning => "warning",
            Severity::Error => "error",
        })
    }
}

/// Which check produced a finding.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum FindingKind {
    /// NaN or infinite samples.
    NonFinite,
    /// Runs at the extreme value or at full scale.
    Clipping,
    /// Runs of repeated values inside active signal.
    Dropout,
    /// A constant stretch at the start or end of a channel.
    ConstantSection,
    /// The whole channel is constant.
    Constant,
    /// Mean large against the AC RMS.
    DcOffset,
    /// Declared rate disagrees with the time column or the excitation.
    SampleRate,
    /// Irregular time-column spacing.
    TimeJitter,
    /// Missing samples (a jump) in the time column.
    TimeGap,
}

/// A stretch of samples: `start..start + len` (frame indices from 0).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct Span {
    /// First sample (frame index, from 0).
    pub start: usize,
    /// Number of samples.
    pub len: usize,
}

impl std::fmt::Display for Span {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        if self.len <= 1 {
            write!(f, "{}", self.start)
        } else {
            write!(f, "{}-{}", self.start, self.start + self.len - 1)
        }
    }
}

/// One finding.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Finding {
    /// How bad.
    pub severity: Severity,
    /// Which check.
    pub kind: FindingKind,
    /// The channel, or `None` for the whole recording (time axis).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub channel: Option<String>,
    /// The first affected stretches (at most `max_listed`), in order.
    pub spans: Vec<Span>,
    /// How many stretches in all.
    pub span_count: usize,
    /// How many samples are affected in all.
    pub samples: usize,
    /// Plain-English description naming the channel and positions.
    pub message: String,
}

/// Per-channel figures.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ChannelStats {
    /// Channel name.
    pub name: String,
    /// Unit of the figures.
    pub unit: String,
    /// NaN or infinite samples.
    pub non_finite: usize,
    /// Mean of the finite samples.
    pub mean: f64,
    /// RMS of the AC part (standard deviation) of the finite samples.
    pub ac_rms: f64,
    /// Smallest finite sample.
    pub min: f64,
    /// Largest finite sample.
    pub max: f64,
}

/// Figures of a checked time axis.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct TimeAxisSummary {
    /// The time column or variable.
    pub column: String,
    /// Sample rate from a least-squares line through the time stamps, Hz.
    pub rate_hz: f64,
    /// RMS deviation of the time stamps from that line, in sample periods.
    pub jitter_rms_periods: f64,
    /// Largest deviation, in sample periods.
    pub jitter_max_periods: f64,
    /// Where the largest deviation is (sample index).
    pub jitter_max_at: usize,
    /// Jumps longer than 1.5 periods.
    pub gaps: usize,
}

/// A time-axis check: figures and findings.
#[derive(Clone, Debug, PartialEq)]
pub struct TimeAxisCheck {
    /// Figures.
    pub summary: TimeAxisSummary,
    /// Rate mismatch, jitter and gap findings.
    pub findings: Vec<Finding>,
}

/// The data-quality report of a recording.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct QualityReport {
    /// Frames per channel.
    pub frames: usize,
    /// Sample rate used, Hz.
    pub sample_rate_hz: f64,
    /// Per-channel figures, in channel order.
    pub channels: Vec<ChannelStats>,
    /// The time axis, if the data had one.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub time_axis: Option<TimeAxisSummary>,
    /// Findings, errors first.
    pub findings: Vec<Finding>,
}

impl QualityReport {
    /// Whether any finding is an error (NaN/Inf, broken time axis).
    pub fn has_errors(&self) -> bool {
        self.findings.iter().any(|f| f.severity == Severity::Error)
    }

    /// The findings of one severity.
    pub fn with_severity(&self, s: Severity) -> impl Iterator<Item = &Finding> {
        self.findings.iter().filter(move |f| f.severity == s)
    }

    /// The findings of one kind.
    pub fn of_kind(&self, k: FindingKind) -> impl Iterator<Item = &Finding> {
        self.findings.iter().filter(move |f| f.kind == k)
    }

    /// The worst severity found, if any finding.
    pub fn worst(&self) -> Option<Severity> {
        self.findings.iter().map(|f| f.severity).max()
    }

    /// Orders findings: errors first, then warnings, then information;
    /// otherwise in the order found (stable).
    pub fn sort(&mut self) {
        self.findings.sort_by_key(|f| std::cmp::Reverse(f.severity));
    }
}

impl std::fmt::Display for QualityReport {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let count = |s| self.with_severity(s).count();
        writeln!(
            f,
            "{} channels x {} samples at {} Hz: {} errors, {} warnings, {} notes",
            self.channels.len(),
            self.frames,
            self.sample_rate_hz,
            count(Severity::Error),
            count(Severity::Warning),
            count(Severity::Info)
        )?;
        for c in &self.channels {
            writeln!(
                f,
                "  {}: mean {:.4e} {u}, AC RMS {:.4e} {u}, range [{:.4e}, {:.4e}] {u}",
                c.name,
                c.mean,
                c.ac_rms,
                c.min,
                c.max,
                u = c.unit
            )?;
        }
        if let Some(t) = &self.time_axis {
            writeln!(
                f,
                "  time column `{}`: {:.6} Hz, jitter RMS {:.2e} / max {:.2e} periods, {} gaps",
                t.column, t.rate_hz, t.jitter_rms_periods, t.jitter_max_periods, t.gaps
            )?;
        }
        for x in &self.findings {
            writeln!(f, "{}: {}", x.severity, x.message)?;
        }
        Ok(())
    }
}

/// Thresholds of the checks (all have defaults; TOML table `[quality]`).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct QualityOptions {
    /// Shortest run at the extreme value or full scale counted as clipping
    /// (at least 2). Default 4: a sine quantised to 100 codes, 57 samples a
    /// period, sits about 3 samples on its peak code; a rail holds longer.
    pub clip_min_run: usize,
    /// Full scale per channel name, physical units (filled from
    /// `ChannelSpec::full_scale` by `import`).
    pub full_scale: BTreeMap<String, f64>,
    /// Shortest run of identical values counted as a dropout (at least 2).
    pub dropout_min_run: usize,
    /// A side of a run is "active" when its RMS deviation from the channel
    /// mean exceeds this fraction of the channel's AC RMS.
    pub active_fraction: f64,
    /// DC offset warning threshold: |mean| / AC RMS.
    pub dc_offset_ratio: f64,
    /// Nominal excitation frequency of the whole record, Hz, if known (a
    /// single-frequency test); stepped-sine dwells in the recording's
    /// excitation are checked one by one without it.
    pub nominal_excitation_hz: Option<f64>,
    /// Relative tolerance between the dominant and the nominal frequency
    /// (never tighter than two FFT bins).
    pub frequency_tolerance: f64,
    /// Relative tolerance between a declared rate and the time column's.
    pub rate_tolerance: f64,
    /// Largest time-stamp deviation from uniform spacing, in sample periods,
    /// before jitter is reported.
    pub jitter_tolerance: f64,
    /// Stretches listed per finding.
    pub max_listed: usize,
}

impl Default for QualityOptions {
    fn default() -> Self {
        QualityOptions {
            clip_min_run: 4,
            full_scale: BTreeMap::new(),
            dropout_min_run: 10,
            active_fraction: 0.1,
            dc_offset_ratio: 0.1,
            nominal_excitation_hz: None,
            frequency_tolerance: 0.01,
            rate_tolerance: 1e-4,
            jitter_tolerance: 0.01,
            max_listed: 10,
        }
    }
}

/// Collects stretches, keeping the first `max` and counting all.
struct Spans {
    list: Vec<Span>,
    count: usize,
    samples: usize,
    max: usize,
}

impl Spans {
    fn new(max: usize) -> Spans {
        Spans {
            list: Vec::new(),
            count: 0,
            samples: 0,
            max,
        }
    }
    fn push(&mut self, s: Span) {
        if self.list.len() < self.max {
            self.list.push(s);
        }
        self.count += 1;
        self.samples += s.len;
    }
    fn text(&self, what: &str) -> String {
        let list: Vec<String> = self.list.iter().map(|s| s.to_string()).collect();
        let more = if self.count > self.list.len() {
            format!(", ... ({} more)", self.count - self.list.len())
        } else {
            String::new()
        };
        format!("{what} {}{more}", list.join(", "))
    }
    fn finding(
        self,
        severity: Severity,
        kind: FindingKind,
        channel: &str,
        message: String,
    ) -> Finding {
        Finding {
            severity,
            kind,
            channel: Some(channel.to_string()),
            spans: self.list,
            span_count: self.count,
            samples: self.samples,
            message,
        }
    }
}

fn percent(part: usize, whole: usize) -> f64 {
    100.0 * part as f64 / whole.max(1) as f64
}

/// Runs every check on every channel of `rec`.
pub fn check_quality(rec: &Recording, opts: &QualityOptions) -> QualityReport {
    let mut report = QualityReport {
        frames: rec.frames(),
        sample_rate_hz: rec.meta.sample_rate_hz,
        channels: Vec::with_capacity(rec.channels.len()),
        time_axis: None,
        findings: Vec::new(),
    };
    for (c, x) in rec.channels.iter().enumerate() {
        let (name, unit) = rec
            .meta
            .channels
            .get(c)
            .map_or((format!("channel {c}"), String::new()), |m| {
                (m.name.clone(), m.unit.clone())
            });
        let stats = channel_checks(&name, &unit, x, opts, &mut report.findings);
        report.channels.push(stats);
    }
    excitation_check(rec, opts, &mut report.findings);
    report.sort();
    report
}

/// Statistics of the finite samples: count, mean, AC RMS, min, max.
fn finite_stats(x: &[f64]) -> (usize, f64, f64, f64, f64) {
    let (mut n, mut sum, mut lo, mut hi) = (0usize, 0.0, f64::INFINITY, f64::NEG_INFINITY);
    for &v in x.iter().filter(|v| v.is_finite()) {
        n += 1;
        sum += v;
        lo = lo.min(v);
        hi = hi.max(v);
    }
    if n == 0 {
        return (0, f64::NAN, f64::NAN, f64::NAN, f64::NAN);
    }
    let mean = sum / n as f64;
    // Two passes: the variance of a signal with a large offset stays accurate.
    let var = x
        .iter()
        .filter(|v| v.is_finite())
        .map(|&v| (v - mean) * (v - mean))
        .sum::<f64>()
        / n as f64;
    (n, mean, var.sqrt(), lo, hi)
}

fn channel_checks(
    name: &str,
    unit: &str,
    x: &[f64],
    opts: &QualityOptions,
    out: &mut Vec<Finding>,
) -> ChannelStats {
    let n = x.len();
    let (finite, mean, ac_rms, lo, hi) = finite_stats(x);
    let stats = ChannelStats {
        name: name.to_string(),
        unit: unit.to_string(),
        non_finite: n - finite,
        mean,
        ac_rms,
        min: lo,
        max: hi,
    };
    // Non-finite samples, merged into stretches.
    if finite < n {
        let mut spans = Spans::new(opts.max_listed);
        let mut i = 0;
        while i < n {
            if x[i].is_finite() {
                i += 1;
                continue;
            }
            let s = i;
            while i < n && !x[i].is_finite() {
                i += 1;
            }
            spans.push(Span {
                start: s,
                len: i - s,
            });
        }
        let nan = x.iter().filter(|v| v.is_nan()).count();
        let msg = format!(
            "channel `{name}`: {} of {n} samples are not finite ({nan} NaN, {} infinite), {}; \
             the channel cannot be identified as it is",
            n - finite,
            n - finite - nan,
            spans.text("at samples")
        );
        out.push(spans.finding(Severity::Error, FindingKind::NonFinite, name, msg));
    }
    if finite == 0 {
        return stats;
    }
    if ac_rms.is_nan() || ac_rms <= 0.0 || lo == hi {
        out.push(Finding {
            severity: Severity::Warning,
            kind: FindingKind::Constant,
            channel: Some(name.to_string()),
            spans: vec![Span { start: 0, len: n }],
            span_count: 1,
            samples: finite,
            message: format!(
                "channel `{name}` is constant ({lo} {unit}) over all {n} samples: no signal"
            ),
        });
        return stats;
    }
    clipping_check(name, unit, x, lo, hi, opts, out);
    dropout_check(name, x, mean, ac_rms, lo, hi, opts, out);
    if mean.abs() > opts.dc_offset_ratio * ac_rms {
        out.push(Finding {
            severity: Severity::Warning,
            kind: FindingKind::DcOffset,
            channel: Some(name.to_string()),
            spans: Vec::new(),
            span_count: 0,
            samples: 0,
            message: format!(
                "channel `{name}`: DC offset {mean:.4e} {unit} is {:.1} % of the AC RMS \
                 {ac_rms:.4e} {unit} (threshold {:.1} %)",
                100.0 * mean.abs() / ac_rms,
                100.0 * opts.dc_offset_ratio
            ),
        });
    }
    stats
}

fn clipping_check(
    name: &str,
    unit: &str,
    x: &[f64],
    lo: f64,
    hi: f64,
    opts: &QualityOptions,
    out: &mut Vec<Finding>,
) {
    let k = opts.clip_min_run.max(2);
    let full = opts.full_scale.get(name).copied();
    let at_rail =
        |v: f64| v.is_finite() && (v == hi || v == lo || full.is_some_and(|f| v.abs() >= f));
    let mut spans = Spans::new(opts.max_listed);
    let (mut at_hi, mut at_lo, mut at_full) = (false, false, false);
    let n = x.len();
    let mut i = 0;
    while i < n {
        if !at_rail(x[i]) {
            i += 1;
            continue;
        }
        let s = i;
        while i < n && at_rail(x[i]) {
            i += 1;
        }
        if i - s >= k {
            spans.push(Span {
                start: s,
                len: i - s,
            });
            at_hi |= x[s] == hi;
            at_lo |= x[s] == lo;
            at_full |= full.is_some_and(|f| x[s].abs() >= f);
        }
    }
    if spans.count == 0 {
        return;
    }
    let mut levels = Vec::new();
    if at_hi {
        levels.push(format!("the maximum {hi:.6e} {unit}"));
    }
    if at_lo {
        levels.push(format!("the minimum {lo:.6e} {unit}"));
    }
    if let (true, Some(f)) = (at_full, full) {
        levels.push(format!("the full scale ±{f} {unit}"));
    }
    let msg = format!(
        "channel `{name}` looks clipped: {} runs of >= {k} samples at {} ({}; {:.3} % of the samples)",
        spans.count,
        levels.join(" / "),
        spans.text("samples"),
        percent(spans.samples, n)
    );
    out.push(spans.finding(Severity::Warning, FindingKind::Clipping, name, msg));
}

/// RMS deviation of `x` from `mean`, finite samples only; 0 when empty.
fn rms_about(x: &[f64], mean: f64) -> f64 {
    let (mut s, mut n) = (0.0, 0usize);
    for &v in x.iter().filter(|v| v.is_finite()) {
        s += (v - mean) * (v - mean);
        n += 1;
    }
    if n == 0 { 0.0 } else { (s / n as f64).sqrt() }
}

#[allow(clippy::too_many_arguments)]
fn dropout_check(
    name: &str,
    x: &[f64],
    mean: f64,
    ac_rms: f64,
    lo: f64,
    hi: f64,
    opts: &QualityOptions,
    out: &mut Vec<Finding>,
) {
    let m = opts.dropout_min_run.max(2);
    let full = opts.full_scale.get(name).copied();
    // Long enough to span a good part of a low-frequency period, so a zero
    // crossing of the signal itself does not look inactive.
    let w = (4 * m).max(64);
    let active =
        |seg: &[f64]| !seg.is_empty() && rms_about(seg, mean) > opts.active_fraction * ac_rms;
    let n = x.len();
    let mut inner = Spans::new(opts.max_listed);
    let mut edge = Spans::new(opts.max_listed);
    let mut zeros = 0usize;
    let mut i = 0;
    while i < n {
        let v = x[i];
        let s = i;
        i += 1;
        while i < n && x[i] == v {
            i += 1;
        }
        let len = i - s;
        // Runs at an extreme or full scale belong to the clipping check.
        if len < m || !v.is_finite() || v == hi || v == lo || full.is_some_and(|f| v.abs() >= f) {
            continue;
        }
        let before = &x[s.saturating_sub(w)..s];
        let after = &x[i..(i + w).min(n)];
        let span = Span { start: s, len };
        if s > 0 && i < n {
            if active(before) && active(after) {
                inner.push(span);
                zeros += usize::from(v == 0.0);
            }
        } else if active(before) || active(after) {
            edge.push(span);
        }
    }
    if inner.count > 0 {
        let zero_text = if zeros == inner.count {
            " (all zeros)".to_string()
        } else if zeros > 0 {
            format!(" ({zeros} of them zeros)")
        } else {
            String::new()
        };
        let msg = format!(
            "channel `{name}`: {} dropouts{zero_text}, runs of >= {m} identical samples inside active signal \
             ({}; {:.3} % of the samples)",
            inner.count,
            inner.text("samples"),
            percent(inner.samples, n)
        );
        out.push(inner.finding(Severity::Warning, FindingKind::Dropout, name, msg));
    }
    if edge.count > 0 {
        let msg = format!(
            "channel `{name}`: constant at the start or end of the record ({}), e.g. before \
             the excitation started or after it stopped",
            edge.text("samples")
        );
        out.push(edge.finding(Severity::Info, FindingKind::ConstantSection, name, msg));
    }
}

/// The frequency of the largest spectral peak of `x` (Hann window, mean
/// removed, log-parabolic interpolation between bins), Hz. `None` for fewer
/// than 16 samples, non-finite samples or a flat spectrum.
pub fn dominant_frequency(
    x: &[f64],
    sample_rate_hz: f64,
    planner: &mut RealFftPlanner<f64>,
) -> Option<f64> {
    let n = x.len();
    if n < 16 || x.iter().any(|v| !v.is_finite()) {
        return None;
    }
    let mean = x.iter().sum::<f64>() / n as f64;
    let fft = planner.plan_fft_forward(n);
    let mut input = fft.make_input_vec();
    let step = 2.0 * std::f64::consts::PI / n as f64;
    for (k, (o, &v)) in input.iter_mut().zip(x).enumerate() {
        *o = (v - mean) * (0.5 - 0.5 * (step * k as f64).cos());
    }
    let mut spec = fft.make_output_vec();
    fft.process(&mut input, &mut spec).ok()?;
    let mag: Vec<f64> = spec.iter().map(|c| c.norm_sqr()).collect();
    // Skip bin 0 (and the DC leakage of the window into bin 1).
    let (k, &peak) = mag
        .iter()
        .enumerate()
        .skip(2)
        .max_by(|a, b| a.1.total_cmp(b.1))?;
    if peak.is_nan() || peak <= 0.0 {
        return None;
    }
    let mut kf = k as f64;
    if k + 1 < mag.len() && mag[k - 1] > 0.0 && mag[k + 1] > 0.0 {
        let (a, b, c) = (mag[k - 1].ln(), peak.ln(), mag[k + 1].ln());
        let den = a - 2.0 * b + c;
        if den < 0.0 {
            kf += 0.5 * (a - c) / den;
        }
    }
    Some(kf * sample_rate_hz / n as f64)
}

/// Compares the reference channel's dominant frequency with the nominal
/// excitation (whole record, or each dwell of a stepped sine).
fn excitation_check(rec: &Recording, opts: &QualityOptions, out: &mut Vec<Finding>) {
    let Some(c) = rec.reference_channel().or(if rec.channels.is_empty() {
        None
    } else {
        Some(0)
    }) else {
        return;
    };
    let x = &rec.channels[c];
    let name = &rec.meta.channels[c].name;
    let fs = rec.meta.sample_rate_hz;
    let mut windows: Vec<(usize, usize, f64)> = Vec::new();
    if let Some(f) = opts.nominal_excitation_hz {
        windows.push((0, x.len(), f));
    } else {
        for st in &rec.meta.excitation.steps {
            let (a, b) = (st.start + st.settle, (st.start + st.length).min(x.len()));
            if a < b {
                windows.push((a, b, st.frequency_hz));
            }
        }
    }
    let mut planner = RealFftPlanner::new();
    let mut spans = Spans::new(opts.max_listed);
    let mut details = Vec::new();
    for &(a, b, f_nom) in &windows {
        let Some(f_dom) = dominant_frequency(&x[a..b], fs, &mut planner) else {
            continue;
        };
        let tol = (opts.frequency_tolerance * f_nom).max(2.0 * fs / (b - a) as f64);
        if (f_dom - f_nom).abs() > tol {
            if details.len() < opts.max_listed {
                details.push(format!(
                    "samples {a}-{}: {f_dom:.4} Hz against {f_nom} Hz (the data would fit {:.6} Hz)",
                    b - 1,
                    fs * f_nom / f_dom
                ));
            }
            spans.push(Span {
                start: a,
                len: b - a,
            });
        }
    }
    if spans.count > 0 {
        let msg = format!(
            "channel `{name}`: the dominant frequency differs from the nominal excitation by more \
             than {:.2} %: {}{}; the sample rate {fs} Hz may be wrong, or the excitation differs \
             from what was declared",
            100.0 * opts.frequency_tolerance,
            details.join("; "),
            if spans.count > details.len() {
                format!("; ... ({} more)", spans.count - details.len())
            } else {
                String::new()
            }
        );
        out.push(spans.finding(Severity::Warning, FindingKind::SampleRate, name, msg));
    }
}

/// Why a time axis gives no sample rate.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum TimeAxisError {
    /// Fewer than two stamps.
    #[error("a time axis needs at least 2 samples, got {samples}")]
    TooShort {
        /// Stamps present.
        samples: usize,
    },
    /// A stamp is NaN or infinite.
    #[error("time stamp at sample {sample} is {value}")]
    NotFinite {
        /// The sample.
        sample: usize,
        /// Its stamp.
        value: f64,
    },
    /// A stamp is not after the one before it.
    #[error("time does not increase at sample {sample}: {before} then {value}")]
    NotIncreasing {
        /// The sample.
        sample: usize,
        /// The stamp before it, s.
        before: f64,
        /// Its stamp, s.
        value: f64,
    },
}

/// The sample rate of uniformly spaced time stamps (seconds), from a
/// least-squares line through them. `Err` (naming the sample) when there
/// are fewer than 2 stamps, a stamp is not finite, or the stamps do not
/// strictly increase.
pub fn rate_from_time(t: &[f64]) -> std::result::Result<f64, TimeAxisError> {
    if t.len() < 2 {
        return Err(TimeAxisError::TooShort { samples: t.len() });
    }
    if let Some(i) = t.iter().position(|v| !v.is_finite()) {
        return Err(TimeAxisError::NotFinite {
            sample: i,
            value: t[i],
        });
    }
    if let Some(i) = t.windows(2).position(|w| w[1] <= w[0]) {
        return Err(TimeAxisError::NotIncreasing {
            sample: i + 1,
            before: t[i],
            value: t[i + 1],
        });
    }
    let (_, slope) = line_fit(t);
    Ok(1.0 / slope)
}

/// Least-squares line `t_k = a + b (k - k̄)`: returns (a, b).
fn line_fit(t: &[f64]) -> (f64, f64) {
    let n = t.len() as f64;
    let kbar = (n - 1.0) / 2.0;
    let tbar = t.iter().sum::<f64>() / n;
    let sxy: f64 = t
        .iter()
        .enumerate()
        .map(|(k, &v)| (k as f64 - kbar) * (v - tbar))
        .sum();
    // Σ (k - k̄)² = n (n² - 1) / 12.
    let sxx = n * (n * n - 1.0) / 12.0;
    (tbar, sxy / sxx)
}

/// Checks a time axis: its rate against a declared one (`declared` = rate and
/// where it came from), gaps longer than 1.5 periods, and the deviation of
/// the stamps from uniform spacing. A time axis that is not finite or not
/// increasing is an error finding.
pub fn check_time_axis(
    column: &str,
    t: &[f64],
    declared: Option<(f64, &str)>,
    opts: &QualityOptions,
) -> TimeAxisCheck {
    let mut findings = Vec::new();
    let broken = |msg: String| TimeAxisCheck {
        summary: TimeAxisSummary {
            column: column.to_string(),
            rate_hz: f64::NAN,
            jitter_rms_periods: f64::NAN,
            jitter_max_periods: f64::NAN,
            jitter_max_at: 0,
            gaps: 0,
        },
        findings: vec![Finding {
            severity: Severity::Error,
            kind: FindingKind::TimeJitter,
            channel: None,
            spans: Vec::new(),
            span_count: 0,
            samples: 0,
            message: format!("time column `{column}`: {msg}"),
        }],
    };
    let rate = match rate_from_time(t) {
        Ok(r) => r,
        Err(m) => return broken(m.to_string()),
    };
    let period = 1.0 / rate;
    let (jitter_rms, jitter_max, worst_at) = spacing_deviation(t, period);
    let gaps = time_gaps(t, period, opts.max_listed);
    let gap_count = gaps.count;
    if let Some((d, origin)) = declared {
        let rel = rate / d - 1.0;
        if rel.abs() > opts.rate_tolerance {
            findings.push(Finding {
                severity: Severity::Warning,
                kind: FindingKind::SampleRate,
                channel: None,
                spans: Vec::new(),
                span_count: 0,
                samples: 0,
                message: format!(
                    "sample rate {d} Hz ({origin}) disagrees with the time column `{column}`, \
                     whose spacing gives {rate:.6} Hz ({:+.4} %); the declared rate is used",
                    100.0 * rel
                ),
            });
        }
    }
    if gap_count > 0 {
        let msg = format!(
            "time column `{column}`: {gap_count} jumps longer than 1.5 sample periods ({} s), \
             before {}: samples are missing",
            period,
            gaps.text("samples")
        );
        findings.push(Finding {
            severity: Severity::Warning,
            kind: FindingKind::TimeGap,
            channel: None,
            spans: gaps.list,
            span_count: gaps.count,
            samples: gaps.samples,
            message: msg,
        });
    } else if jitter_max > opts.jitter_tolerance {
        findings.push(Finding {
            severity: Severity::Warning,
            kind: FindingKind::TimeJitter,
            channel: None,
            spans: vec![Span {
                start: worst_at,
                len: 1,
            }],
            span_count: 1,
            samples: 1,
            message: format!(
                "time column `{column}`: time stamps deviate from uniform spacing by up to \
                 {jitter_max:.3} sample periods (at sample {worst_at}; RMS {jitter_rms:.3}), \
                 more than {}: the spacing is irregular",
                opts.jitter_tolerance
            ),
        });
    }
    TimeAxisCheck {
        summary: TimeAxisSummary {
            column: column.to_string(),
            rate_hz: rate,
            jitter_rms_periods: jitter_rms,
            jitter_max_periods: jitter_max,
            jitter_max_at: worst_at,
            gaps: gap_count,
        },
        findings,
    }
}

/// How far the time stamps `t` stray from the straight line through them,
/// in sample periods: the RMS, the largest, and where.
fn spacing_deviation(t: &[f64], period: f64) -> (f64, f64, usize) {
    let (a, b) = line_fit(t);
    let kbar = (t.len() as f64 - 1.0) / 2.0;
    let (mut ss, mut worst, mut worst_at) = (0.0, 0.0f64, 0usize);
    for (k, &v) in t.iter().enumerate() {
        let r = (v - a - b * (k as f64 - kbar)).abs();
        ss += r * r;
        if r > worst {
            worst = r;
            worst_at = k;
        }
    }
    (
        (ss / t.len() as f64).sqrt() / period,
        worst / period,
        worst_at,
    )
}

/// The samples after a jump longer than 1.5 sample periods.
fn time_gaps(t: &[f64], period: f64, max_listed: usize) -> Spans {
    let mut gaps = Spans::new(max_listed);
    for (k, w) in t.windows(2).enumerate() {
        if w[1] - w[0] > 1.5 * period {
            gaps.push(Span {
                start: k + 1,
                len: 1,
            });
        }
    }
    gaps
}
