//! One recording as the time-domain fit sees it: its force and response, its
//! segments and its window.

use crate::error::{Error, Result};
use crate::extract::lines::PeriodicSpectra;
use crate::harmonics::Quantity;
use crate::signals::{Samples, SamplesView};
use crate::validate::sum_start;
use std::ops::Range;

/// One recording as the time-domain fit sees it.
#[derive(Clone, Debug, PartialEq)]
pub struct TimeRecord {
    /// A name for reports (the file).
    pub name: String,
    /// The measured force driving the model, N (or the voltage driving a
    /// shaker), held as recorded (see [`Samples`]).
    pub reference: Samples,
    /// What the reference is: a force, or a voltage.
    pub reference_quantity: Quantity,
    /// The measured response, in `quantity`, held as recorded.
    pub response: Samples,
    /// Samples per second.
    pub sample_rate_hz: f64,
    /// The response's quantity (a motion).
    pub quantity: Quantity,
    /// The samples judged.
    pub window: Range<usize>,
    /// The stretches of the window each judged on its own RMS (see the
    /// module docs): ordered, not overlapping.
    pub segments: Vec<Range<usize>>,
    /// The band judged, Hz (`--band`), about which the fit's final error is
    /// split by frequency ([`TimeProblem::errors_by_frequency`]).
    pub band_hz: Option<(f64, f64)>,
    /// The segments are the steady periods of a periodic excitation (see
    /// [`TimeRecord::steady_periods`]): alike, so a fit that judges the
    /// record only in part judges its first periods whole and replays no
    /// further (see [`TimeFitOptions::max_judged_samples`]).
    pub periodic: bool,
}

impl TimeRecord {
    /// The spectra of the record, whose segments are its steady periods (as
    /// a multisine's time fit judges it): at least two, of equal length.
    pub fn periodic_spectra(&self) -> Result<PeriodicSpectra> {
        PeriodicSpectra::of_channels(
            &self.name,
            (self.reference_quantity, self.sample_rate_hz),
            (self.reference.view(), self.response.view()),
            self.segments.clone(),
        )
    }

    /// Checks the record: equal lengths, a motion response, a window inside
    /// the samples that holds some, a finite measured RMS above zero there.
    pub fn check(&self) -> Result<()> {
        let at = |f: &str| format!("{}: {f}", self.name);
        if self.reference.len() != self.response.len() {
            return Err(Error::input(
                at("response"),
                format!(
                    "{} samples against the force's {}",
                    self.response.len(),
                    self.reference.len()
                ),
            ));
        }
        if !self.quantity.is_motion() {
            return Err(Error::input(
                at("response quantity"),
                format!("{} is not a motion", self.quantity),
            ));
        }
        if self.window.start >= self.window.end || self.window.end > self.response.len() {
            return Err(Error::input(
                at("window"),
                format!(
                    "samples {}..{} are not inside the {} recorded",
                    self.window.start,
                    self.window.end,
                    self.response.len()
                ),
            ));
        }
        if self.segments.is_empty() {
            return Err(Error::input(
                at("segments"),
                "none: no stretch of the response to judge",
            ));
        }
        let mut next = self.window.start;
        for s in &self.segments {
            if s.start < next || s.end <= s.start || s.end > self.window.end {
                return Err(Error::input(
                    at("segments"),
                    format!(
                        "must be ordered, non-empty stretches inside the window {}..{}; {}..{} is not",
                        self.window.start, self.window.end, s.start, s.end
                    ),
                ));
            }
            next = s.end;
            let rms = self.measured_rms(s.clone());
            if !(rms.is_finite() && rms > 0.0) {
                return Err(Error::input(
                    at("response"),
                    format!(
                        "its RMS over samples {}..{} is {rms}: nothing to fit",
                        s.start, s.end
                    ),
                ));
            }
        }
        Ok(())
    }

    /// The window cut at the starts of `steps` that fall inside it, but for
    /// the first step's: the few samples before the first dwell (silence
    /// and noise) belong to it (one segment when no step does).
    pub fn segments_at(window: Range<usize>, steps: &[crate::signals::Step]) -> Vec<Range<usize>> {
        let mut cuts: Vec<usize> = steps.iter().map(|s| s.start).collect();
        cuts.sort_unstable();
        cuts.dedup();
        let cuts: Vec<usize> = cuts
            .into_iter()
            .skip(1)
            .filter(|&c| c > window.start && c < window.end)
            .collect();
        let mut out = Vec::with_capacity(cuts.len() + 1);
        let mut a = window.start;
        for c in cuts {
            out.push(a..c);
            a = c;
        }
        out.push(a..window.end);
        out
    }

    /// A recording's reference driving the model and its `response`
    /// channel, judged over samples `window` (the whole record if `None`),
    /// cut at its dwells: the stated `steps`, else for a stepped or unknown
    /// excitation the dwells found in the reference (none: one segment).
    ///
    /// With `band_hz`, only what the band holds is judged: a stepped record's
    /// dwells at frequencies inside it, a swept record's stretch where the
    /// sweep (its law fitted to the reference's phase) is inside it. The
    /// model is still driven from the record's first sample, so the joint
    /// reaches the band with the history the structure had.
    pub fn from_recording(
        name: &str,
        rec: &crate::signals::Recording,
        response: usize,
        window: Option<Range<usize>>,
        band_hz: Option<(f64, f64)>,
    ) -> Result<TimeRecord> {
        let reference = Self::reference_of(name, &rec.meta, response)?;
        let channels = (
            rec.channels[reference].clone(),
            rec.channels[response].clone(),
        );
        Self::from_values(name, &rec.meta, response, channels, window, band_hz)
    }

    /// [`TimeRecord::from_recording`] taking the recording's reference and
    /// response channels over, not copying them (a long recording's
    /// channels are the largest thing a time fit holds).
    pub fn from_owned_recording(
        name: &str,
        mut rec: crate::signals::Recording,
        response: usize,
        window: Option<Range<usize>>,
        band_hz: Option<(f64, f64)>,
    ) -> Result<TimeRecord> {
        let reference = Self::reference_of(name, &rec.meta, response)?;
        let measured = if response == reference {
            rec.channels[response].clone()
        } else {
            std::mem::take(&mut rec.channels[response])
        };
        let channels = (std::mem::take(&mut rec.channels[reference]), measured);
        Self::from_values(name, &rec.meta, response, channels, window, band_hz)
    }

    /// A periodic record (a multisine played several times) judged over
    /// its steady periods of `period` samples: its whole periods after the
    /// first (the model's replay starts from rest), one segment each, as a
    /// multisine's time fit, its diagnosis and its validation judge it.
    /// `None` when it holds fewer than two. No dwell is looked for: a
    /// multisine has none.
    pub fn steady_periods(
        name: &str,
        meta: &crate::signals::RecordingMeta,
        response_channel: usize,
        (reference, response): (Samples, Samples),
        period: usize,
    ) -> Result<Option<TimeRecord>> {
        let reference_channel = Self::reference_of(name, meta, response_channel)?;
        let periods = reference.len().min(response.len()) / period.max(1);
        if period == 0 || periods < 2 {
            return Ok(None);
        }
        let r = TimeRecord {
            name: name.to_string(),
            reference,
            reference_quantity: meta.channels[reference_channel].quantity,
            response,
            sample_rate_hz: meta.sample_rate_hz,
            quantity: meta.channels[response_channel].quantity,
            window: period..periods * period,
            segments: (1..periods).map(|k| k * period..(k + 1) * period).collect(),
            band_hz: None,
            periodic: true,
        };
        r.check()?;
        Ok(Some(r))
    }

    /// The record of values in physical units, held as the file stored
    /// them where they are its values (half the bytes, the same values).
    fn from_values(
        name: &str,
        meta: &crate::signals::RecordingMeta,
        response: usize,
        (reference, measured): (Vec<f64>, Vec<f64>),
        window: Option<Range<usize>>,
        band_hz: Option<(f64, f64)>,
    ) -> Result<TimeRecord> {
        let reference_channel = meta.reference_channel().expect("checked by reference_of");
        let held = |samples, channel: usize| {
            Samples::recorded(samples, &[meta.channels[channel].scale, 1.0])
        };
        let channels = (held(reference, reference_channel), held(measured, response));
        Self::from_channels(name, meta, response, channels, window, band_hz)
    }

    /// The reference channel of a recording described by `meta`, checked
    /// with its `response` channel.
    fn reference_of(
        name: &str,
        meta: &crate::signals::RecordingMeta,
        response: usize,
    ) -> Result<usize> {
        let reference = meta.reference_channel().ok_or_else(|| {
            Error::input(
                format!("{name}: channels"),
                "no force or voltage channel to drive the model with",
            )
        })?;
        if response >= meta.channels.len() {
            return Err(Error::input(
                format!("{name}: response channel"),
                format!("{response} is not one of the {}", meta.channels.len()),
            ));
        }
        Ok(reference)
    }

    /// [`TimeRecord::from_recording`] of a recording described by `meta`
    /// whose reference and response (channel `response_channel`) are
    /// already held, `(reference, response)`, and are taken over (see
    /// [`crate::analysis::load_time_record`]).
    pub fn from_channels(
        name: &str,
        meta: &crate::signals::RecordingMeta,
        response_channel: usize,
        (reference, response): (Samples, Samples),
        window: Option<Range<usize>>,
        band_hz: Option<(f64, f64)>,
    ) -> Result<TimeRecord> {
        let reference_channel = Self::reference_of(name, meta, response_channel)?;
        let n = reference.len();
        let mut window = window.unwrap_or(0..n);
        let fs = meta.sample_rate_hz;
        let stated = &meta.excitation.steps;
        let swept = meta.excitation.kind == crate::signals::ExcitationKind::SweptSine;
        if let (Some(band), true, true) = (band_hz, swept, stated.is_empty()) {
            let sweep = crate::extract::find_sweep(
                &mut crate::signals::InMemoryFrames::single(reference.view(), fs),
                0,
                &crate::extract::SweepOptions::default(),
            )
            .map_err(|e| Error::context(format!("{name}: the sweep"), e))?;
            let inside = sweep.samples_in(band);
            let (a, b) = (inside.start.max(window.start), inside.end.min(window.end));
            if b <= a {
                return Err(Error::input(
                    format!("{name}: band"),
                    format!(
                        "the sweep ({:.4}-{:.4} Hz) is never inside {}-{} Hz within the window",
                        sweep.f_start_hz, sweep.f_end_hz, band.0, band.1
                    ),
                ));
            }
            window = a..b;
        }
        let steps = if !stated.is_empty() {
            stated.clone()
        } else if swept {
            Vec::new()
        } else {
            crate::extract::find_dwells(
                &mut crate::signals::InMemoryFrames::single(reference.view(), fs),
                0,
                &crate::extract::DwellOptions::default(),
                &crate::observe::Silent,
            )
            .unwrap_or_default()
        };
        let mut segments = TimeRecord::segments_at(window.clone(), &steps);
        if let (Some((lo, hi)), false) = (band_hz, steps.is_empty()) {
            // each segment is judged as the dwell it starts in
            let mut by_start: Vec<&crate::signals::Step> = steps.iter().collect();
            by_start.sort_by_key(|s| s.start);
            segments.retain(|seg| {
                let k = by_start.partition_point(|s| s.start <= seg.start);
                let f = by_start[k.saturating_sub(1)].frequency_hz;
                (lo..=hi).contains(&f)
            });
            if segments.is_empty() {
                return Err(Error::input(
                    format!("{name}: band"),
                    format!("no dwell of the record is inside {lo}-{hi} Hz"),
                ));
            }
        }
        // a dwell whose response the converter resolved to a few steps (a
        // quiet level in a 16-bit file) has no scale to be judged on: left
        // out, as the FRF reduction leaves it out
        segments.retain(|s| {
            rms_of(response.view(), s.clone()) > 0.0
                && !crate::extract::below_resolution(&response.range(s.clone()))
        });
        let r = TimeRecord {
            name: name.to_string(),
            reference,
            reference_quantity: meta.channels[reference_channel].quantity,
            response,
            sample_rate_hz: fs,
            quantity: meta.channels[response_channel].quantity,
            segments,
            window,
            band_hz,
            periodic: false,
        };
        r.check()?;
        Ok(r)
    }

    /// RMS of the measured response over `range` (about zero: the model's
    /// response has the same static part to match).
    pub(super) fn measured_rms(&self, range: Range<usize>) -> f64 {
        rms_of(self.response.view(), range)
    }
}

/// RMS of `x` over `range`, about zero.
fn rms_of(x: SamplesView, range: Range<usize>) -> f64 {
    let n = range.len() as f64;
    let mut sum = sum_start();
    x.for_each_stretch(range, |_, w| sum = w.iter().fold(sum, |acc, v| acc + v * v));
    (sum / n).sqrt()
}
