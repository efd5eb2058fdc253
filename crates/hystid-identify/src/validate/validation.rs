//! A recording validated against a model: the replay beside the measurement,
//! their errors and, for a stepped sine, their FRFs compared level by level.

use super::metrics::in_band;
use super::replay::settling_periods;
use super::{
    DriveInput, ErrorMetrics, Peak, PreparedDrive, Reduction, Replay, ValidateOptions, h1_peak,
    tally, upsampling_factor,
};
use crate::error::{Error, Result};
use crate::extract::reduce_stepped_by_dwell;
use crate::extract::{NonlinearFrf, ReduceOptions, SweepFit, SweepOptions, reduce_sweep};
use crate::harmonics::Quantity;
use crate::model::Model;
use crate::observe::{Observer, Silent};
use crate::record::{Recording, Step};
use crate::signals::{FrameSource, InMemoryFrames, RecordingMeta, RecordingView, SamplesView};
use serde::{Deserialize, Serialize};
/// One level of the FRF comparison.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct LevelComparison {
    /// Nominal level of the measured series, reference unit.
    pub level: f64,
    /// Points compared (within the band).
    pub points: usize,
    /// `‖H1_sim − H1_meas‖ / ‖H1_meas‖` over those points.
    pub relative_h1_error: f64,
    /// The measured `|H1|` peak in the band.
    pub measured_peak: Option<Peak>,
    /// The simulated `|H1|` peak in the band.
    pub simulated_peak: Option<Peak>,
}

/// Both signals reduced the same way.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct FrfComparison {
    /// Per level of the measured reduction.
    pub levels: Vec<LevelComparison>,
    /// The sweep fitted to the reference (swept sine only).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub sweep: Option<SweepFit>,
    /// The measured nonlinear FRFs.
    #[serde(skip)]
    pub measured: Option<NonlinearFrf>,
    /// The simulated ones, on the same dwells or sweep windows.
    #[serde(skip)]
    pub simulated: Option<NonlinearFrf>,
}

/// The validation of one recording.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Validation {
    /// The recording's sample rate, Hz.
    pub sample_rate_hz: f64,
    /// The response quantity compared.
    pub quantity: Quantity,
    /// The simulation's upsampling factor (1: at the recording's rate).
    pub upsampling: usize,
    /// The model's highest linearised frequency, Hz.
    pub highest_frequency_hz: f64,
    /// How the model was replayed (`--replay`: what the reference and the
    /// joint's force are between samples).
    #[serde(default)]
    pub replay: DriveInput,
    /// Over the whole record.
    pub whole: ErrorMetrics,
    /// Over the window (given, or from the band through the sweep law).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub window: Option<ErrorMetrics>,
    /// The FRF comparison, if asked for.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub frf: Option<FrfComparison>,
    /// What was assumed of the drive where the recording did not say, e.g.
    /// that a reference with no sine dwell is broadband (written, not read
    /// back).
    #[serde(default, skip_deserializing, skip_serializing_if = "Option::is_none")]
    pub assumed: Option<String>,
    /// On a broadband (random) drive: the measured and replayed H1
    /// compared (written, not read back).
    #[serde(default, skip_deserializing, skip_serializing_if = "Option::is_none")]
    pub h1: Option<super::H1Comparison>,
    /// On a multisine of at least two steady periods: the residual at the
    /// lines of its period, in units of the noise (written, not read back).
    #[serde(default, skip_deserializing, skip_serializing_if = "Option::is_none")]
    pub lines: Option<crate::extract::lines::LineValidation>,
    /// On a record of one period of a periodic steady state (`periodic`):
    /// the error at the lines of that period, relative to what was
    /// measured there (written, not read back).
    #[serde(default, skip_deserializing, skip_serializing_if = "Option::is_none")]
    pub line_spectrum: Option<crate::extract::lines::LineSpectrum>,
    /// The simulated response, at the recording's samples, where it was
    /// asked to be kept (see [`validate_view`]); else empty.
    #[serde(skip)]
    pub simulated: Vec<f64>,
}

/// What a validation hands on of the replay as it is made (the figures of
/// a recording too long to hold its replay, say): the samples compared and
/// the window of the second error figure, then every stretch of the
/// simulated response in order. Both do nothing by default.
pub trait ReplayTap {
    /// Before the first stretch: the samples compared and the window.
    fn begin(&mut self, _samples: usize, _window: Option<std::ops::Range<usize>>) {}
    /// The simulated response from sample `at` on, beside the measured one
    /// there (as long).
    fn stretch(&mut self, _at: usize, _measured: &[f64], _simulated: &[f64]) {}
}

impl ReplayTap for () {}

/// Validates `model` on a recording: simulates the response channel
/// `response_channel` from the reference channel (see the module docs) and
/// compares.
///
/// `response_sign` is the fit's (the model predicts `sign × H_measured`, so
/// the simulated response is multiplied by it). Errors name the channel:
/// no reference, a response that is not a motion or is the reference, a
/// window outside the record, and those of [`simulate_response`] and of the
/// reductions.
///
/// `observer` is told how the replay and the FRF comparison progress
/// ([`REDUCING`] 0 and 1 of 2 around the measured response's reduction,
/// `simulating` as the replay is made and reduced, then [`REDUCING`] 2 of
/// 2), and the validation stops where it asks ([`Error::Cancelled`]). The
/// replay is kept ([`Validation::simulated`]).
pub fn validate_recording(
    model: &Model,
    response_sign: f64,
    rec: &Recording,
    response_channel: usize,
    options: &ValidateOptions,
    observer: &dyn Observer,
) -> Result<Validation> {
    validate_view(
        model,
        (response_sign, true),
        &rec.view(),
        response_channel,
        options,
        observer,
        &mut (),
    )
}

/// [`validate_recording`] on a recording however its channels are
/// held, `keep_replay` saying whether the simulated response is kept whole
/// ([`Validation::simulated`]) and `tap` handed it a stretch at a time.
///
/// Without `keep_replay`, a stepped recording whose dwells are stated (or
/// found on the measured reference) is replayed once and never held: the
/// error figures are tallied as the replay comes (the same bits as the
/// whole signals' figures), and the simulated response is reduced a dwell
/// at a time beside the reference. A swept one is held (the sweep is
/// followed over the record whole), and so is a periodic one (it is short).
pub fn validate_view(
    model: &Model,
    (response_sign, keep_replay): (f64, bool),
    rec: &RecordingView,
    response_channel: usize,
    options: &ValidateOptions,
    observer: &dyn Observer,
    tap: &mut dyn ReplayTap,
) -> Result<Validation> {
    let (reference, quantity) = replayed_channels(model, rec, response_channel)?;
    let fs = rec.meta.sample_rate_hz;
    let force = rec.channels[reference];
    let measured = rec.channels[response_channel];
    // a periodic recording drives the model repeated until it has settled;
    // the last period is compared
    let n = force.len();
    let repeats = if options.periodic {
        settling_periods(model, n as f64 / fs)
    } else {
        1
    };
    let repeated = (repeats > 1).then(|| force.values().repeat(repeats));
    let drive = PreparedDrive::for_one_replay(
        repeated.as_ref().map_or(force, SamplesView::from),
        options.input,
    );
    let factor = upsampling_factor(model, fs, options.min_samples_per_period)?;
    let report = |task, done, total| crate::observe::progress(observer, task, done, total);
    // the measured FRFs first: a sweep's law sets the window in a band
    let measured_frfs = measured_frfs(
        rec,
        (reference, response_channel),
        options.reduction.as_ref(),
        observer,
    )?;
    let compared = n.min(measured.len());
    let window = compared_window(options, fs, measured.len(), measured_frfs.as_ref())?;
    let tally = |range| tally::RangeTally::new(measured, compared, fs, range, options.band_hz);
    let mut pass = Pass {
        measured,
        skip: (repeats - 1) * n,
        compared,
        made: 0,
        whole: tally(0..compared)?,
        window: window.clone().map(tally).transpose()?,
        kept: replay_store(compared, keep_replay),
        // a sweep is followed over the record whole (held in scratch
        // files where it is long)
        keep: keep_replay || measured_frfs.as_ref().is_some_and(|m| m.dwells.is_none()),
        floor: usize::MAX,
        pending: Vec::new(),
        pending_from: 0,
        tap,
    };
    pass.tap
        .begin(compared, pass.window.as_ref().map(|w| w.range()));
    let mut replay = Replay::new(model, &drive, (fs, factor), quantity, response_sign)?
        .with_acquisition(options.acquisition.as_ref())?;
    let simulated_stepped = replayed_dwells(
        measured_frfs.as_ref(),
        force,
        &mut replay,
        &mut pass,
        observer,
    )?;
    pass.floor = usize::MAX;
    while let Some(stretch) = replay.next_stretch(observer)? {
        pass.take(stretch)?;
    }
    let top = replay.highest_frequency_hz();
    let Pass {
        whole,
        window,
        kept,
        ..
    } = pass;
    let kept = kept.finish()?;
    let frf = match measured_frfs {
        None => None,
        Some(m) => {
            let simulated = match (simulated_stepped, &options.reduction) {
                (Some(s), _) => s,
                (None, Some(Reduction::Swept(opts))) => {
                    replayed_sweep(rec, (reference, response_channel), kept.view(), opts)?
                }
                (None, _) => unreachable!("a measured reduction is stepped or swept"),
            };
            report(REDUCING, 2, 2)?;
            Some(m.compared_with(simulated, options.band_hz))
        }
    };
    Ok(Validation {
        sample_rate_hz: fs,
        quantity,
        upsampling: factor,
        highest_frequency_hz: top,
        replay: options.input,
        whole: whole.finish(measured, fs),
        window: window.map(|w| w.finish(measured, fs)),
        frf,
        assumed: None,
        h1: None,
        lines: None,
        line_spectrum: None,
        simulated: if keep_replay {
            kept.into_values()
        } else {
            Vec::new()
        },
    })
}

/// Where the replay is kept: in memory (when the caller keeps it), or
/// spilling to scratch files past what is held in memory.
fn replay_store(compared: usize, keep_replay: bool) -> crate::signals::SamplesBuilder {
    let held = crate::signals::SAMPLES_HELD_IN_MEMORY;
    let b = crate::signals::SamplesBuilder::new(compared.min(held), &[]);
    if keep_replay {
        b
    } else {
        b.spilling_above(held)
    }
}

/// A stepped recording's replay reduced a dwell at a time as it comes
/// (none for another recording).
fn replayed_dwells<'r, 'p, 'a, 'd>(
    measured_frfs: Option<&'r MeasuredFrfs>,
    reference: SamplesView<'a>,
    replay: &'r mut Replay<'d, 'a>,
    pass: &'r mut Pass<'p, 'a>,
    observer: &'r dyn Observer,
) -> Result<Option<NonlinearFrf>> {
    let Some(MeasuredFrfs {
        dwells: Some((meta, opts)),
        ..
    }) = measured_frfs
    else {
        return Ok(None);
    };
    let mut frames = ReplayFrames {
        meta,
        reference,
        replay,
        pass,
        observer,
    };
    Ok(Some(
        reduce_stepped_by_dwell(&mut frames, 1, opts, &Silent)?.frf,
    ))
}

/// A swept recording's replay `simulated` reduced as the recording was.
fn replayed_sweep(
    rec: &RecordingView,
    (reference, response): (usize, usize),
    simulated: SamplesView<'_>,
    opts: &SweepOptions,
) -> Result<NonlinearFrf> {
    let q = rec.meta.channels[response].quantity;
    let r = rec.meta.channels[reference].quantity;
    let mut pair =
        InMemoryFrames::pair(rec.channels[reference], simulated, rec.meta.sample_rate_hz)?;
    Ok(reduce_sweep(&mut pair, 0, 1, opts)?.into_frf(q, r))
}

/// The recording's FRFs as measured, reduced as `reduction` says (none
/// without one): the first two of the three steps reported.
fn measured_frfs(
    rec: &RecordingView,
    channels: (usize, usize),
    reduction: Option<&Reduction>,
    observer: &dyn Observer,
) -> Result<Option<MeasuredFrfs>> {
    let Some(r) = reduction else {
        return Ok(None);
    };
    crate::observe::progress(observer, REDUCING, 0, 2)?;
    let m = MeasuredFrfs::of(rec, channels, r)?;
    crate::observe::progress(observer, REDUCING, 1, 2)?;
    Ok(Some(m))
}

/// The reference channel, which the model can be driven by, and the
/// response's quantity, a motion on another channel.
fn replayed_channels(
    model: &Model,
    rec: &RecordingView,
    response_channel: usize,
) -> Result<(usize, crate::harmonics::Quantity)> {
    let reference = rec.meta.reference_channel().ok_or_else(|| {
        Error::input(
            "recording",
            "has no force or voltage channel to drive the model with",
        )
    })?;
    model.check_reference(
        rec.meta.channels[reference].quantity,
        &format!(
            "the reference channel `{}`",
            rec.meta.channels[reference].name
        ),
    )?;
    let nch = rec.channels.len().min(rec.meta.channels.len());
    if response_channel >= nch || response_channel == reference {
        return Err(Error::input(
            format!("response channel {response_channel}"),
            format!("must be one of the {nch} channels other than the reference {reference}"),
        ));
    }
    let channel = &rec.meta.channels[response_channel];
    let quantity = channel.quantity;
    if !quantity.is_motion() {
        return Err(Error::input(
            format!("channel `{}`", channel.name),
            format!("is a {quantity} channel; a motion response is needed"),
        ));
    }
    Ok((reference, quantity))
}

/// The samples judged apart (`window_s`, or a sweep's stretch inside the
/// band), if any.
fn compared_window(
    options: &ValidateOptions,
    fs: f64,
    measured_len: usize,
    measured_frfs: Option<&MeasuredFrfs>,
) -> Result<Option<std::ops::Range<usize>>> {
    Ok(match (options.window_s, options.band_hz, measured_frfs) {
        (Some((t0, t1)), _, _) => {
            if !(t0.is_finite() && t1.is_finite() && 0.0 <= t0 && t0 < t1) {
                return Err(Error::plan(
                    "window_s",
                    format!("need 0 <= start < end, got {t0}:{t1} s"),
                ));
            }
            let a = (t0 * fs).round() as usize;
            let b = ((t1 * fs).round() as usize).min(measured_len);
            Some(a..b)
        }
        (None, Some(band), Some(MeasuredFrfs { sweep: Some(s), .. })) => {
            let (a, b) = sweep_window(s, band);
            (a < b).then_some(a..b)
        }
        _ => None,
    })
}

/// A validation's pass over the replay: the error tallies, the replay kept
/// where asked, the tap, and the samples a reduction reading it a dwell at
/// a time still needs.
struct Pass<'p, 'a> {
    measured: SamplesView<'a>,
    /// Samples of the replay before the one compared first (a periodic
    /// recording's settling periods).
    skip: usize,
    compared: usize,
    /// Replayed samples taken so far (the skipped ones too).
    made: usize,
    whole: tally::RangeTally,
    window: Option<tally::RangeTally>,
    keep: bool,
    /// The replay kept (held in a scratch file once it is longer than
    /// [`crate::signals::SAMPLES_HELD_IN_MEMORY`] where the caller does not
    /// take it).
    kept: crate::signals::SamplesBuilder,
    /// The first compared sample a reduction still reads (`usize::MAX`:
    /// none), and those held for it from `pending_from` on.
    floor: usize,
    pending: Vec<f64>,
    pending_from: usize,
    tap: &'p mut dyn ReplayTap,
}

impl Pass<'_, '_> {
    /// The next stretch of the replay.
    fn take(&mut self, stretch: &[f64]) -> Result<()> {
        let first = self.made;
        self.made += stretch.len();
        // the compared samples of the stretch, and the first one's index
        let (a, b) = (
            first.max(self.skip).min(self.made),
            self.made.min(self.skip + self.compared),
        );
        if a >= b {
            return Ok(());
        }
        let at = a - self.skip;
        let simulated = &stretch[a - first..b - first];
        let measured = self.measured.range(at..at + simulated.len());
        self.whole.push(at, &measured, simulated)?;
        if let Some(w) = &mut self.window {
            w.push(at, &measured, simulated)?;
        }
        if self.keep {
            self.kept.extend(simulated)?;
        }
        self.tap.stretch(at, &measured, simulated);
        let end = at + simulated.len();
        if end > self.floor {
            let from = at.max(self.floor);
            if self.pending.is_empty() {
                self.pending_from = from;
            }
            self.pending.extend_from_slice(&simulated[from - at..]);
        }
        Ok(())
    }

    /// Compared samples taken so far.
    fn compared_made(&self) -> usize {
        self.made.saturating_sub(self.skip).min(self.compared)
    }
}

/// A model's replay beside the reference that drives it, read as a
/// recording of `meta`'s two channels (the reference, and the replay in the
/// response's place) a stretch at a time in increasing order (a stepped
/// reduction's dwells, stated in order): the replay is made as far as each
/// read needs, and only what the reads may still ask for is held (from the
/// last read's first frame on). What a time-domain diagnosis reduces its
/// model's replay with, as the measured recording was reduced, whatever the
/// recording's length.
pub struct ReplayBeside<'r, 'd, 'a> {
    meta: &'r RecordingMeta,
    /// The reference's and the response's channels in `meta`.
    channels: (usize, usize),
    reference: SamplesView<'a>,
    replay: Replay<'d, 'a>,
    /// Replayed samples made so far, and those held from `held_from` on.
    made: usize,
    held: Vec<f64>,
    held_from: usize,
    observer: &'r dyn Observer,
}

impl<'r, 'd, 'a> ReplayBeside<'r, 'd, 'a> {
    /// `replay` (of a drive made from `reference`) beside `reference`, as
    /// the recording `meta` of two channels (`reference`, `response`).
    pub fn new(
        meta: &'r RecordingMeta,
        (reference_channel, response): (usize, usize),
        reference: SamplesView<'a>,
        replay: Replay<'d, 'a>,
        observer: &'r dyn Observer,
    ) -> Result<ReplayBeside<'r, 'd, 'a>> {
        if meta.channels.len() != 2
            || reference_channel == response
            || reference_channel.max(response) > 1
        {
            return Err(Error::input(
                "the replay",
                format!(
                    "read beside its reference as a recording of two channels, not {} \
                     (reference {reference_channel}, response {response})",
                    meta.channels.len()
                ),
            ));
        }
        Ok(ReplayBeside {
            meta,
            channels: (reference_channel, response),
            reference,
            replay,
            made: 0,
            held: Vec::new(),
            held_from: 0,
            observer,
        })
    }
}

impl FrameSource for ReplayBeside<'_, '_, '_> {
    fn meta(&self) -> &RecordingMeta {
        self.meta
    }
    fn frames(&self) -> usize {
        self.reference.len()
    }
    fn source_name(&self) -> String {
        "the replay".into()
    }
    fn read_at(&mut self, start: usize, count: usize, out: &mut [Vec<f64>]) -> Result<usize> {
        let frames = self.frames();
        if start < self.held_from || start > frames {
            return Err(Error::input(
                "the replay",
                format!(
                    "frame {start} is behind the {} let go, or beyond its {frames} frames: it \
                     is read in increasing order",
                    self.held_from
                ),
            ));
        }
        // what lies before `start` is not read again
        let drop = (start - self.held_from).min(self.held.len());
        self.held.drain(..drop);
        self.held_from += drop;
        let end = start.saturating_add(count).min(frames);
        while self.made < end {
            let Some(stretch) = self.replay.next_stretch(self.observer)? else {
                break;
            };
            let first = self.made;
            self.made += stretch.len();
            let from = first.max(start);
            if self.held.is_empty() {
                self.held_from = from.min(self.made);
            }
            if from < self.made {
                self.held.extend_from_slice(&stretch[from - first..]);
            }
        }
        let end = end.min(self.made);
        let (reference, response) = self.channels;
        out[reference].clear();
        out[reference].extend_from_slice(&self.reference.range(start..end));
        out[response].clear();
        out[response].extend_from_slice(&self.held[start - self.held_from..end - self.held_from]);
        Ok(end - start)
    }
}

/// The reference beside the replay, read as a two-channel recording a
/// stretch at a time in increasing order (a stepped reduction's dwells):
/// the replay is made as far as each read needs, and only what the reads
/// still ask for is held.
struct ReplayFrames<'r, 'p, 'a, 'd> {
    meta: &'r RecordingMeta,
    reference: SamplesView<'a>,
    replay: &'r mut Replay<'d, 'a>,
    pass: &'r mut Pass<'p, 'a>,
    observer: &'r dyn Observer,
}

impl FrameSource for ReplayFrames<'_, '_, '_, '_> {
    fn meta(&self) -> &RecordingMeta {
        self.meta
    }
    fn frames(&self) -> usize {
        self.pass.compared
    }
    fn source_name(&self) -> String {
        "the replay".into()
    }
    fn read_at(&mut self, start: usize, count: usize, out: &mut [Vec<f64>]) -> Result<usize> {
        let frames = self.frames();
        let pass = &mut *self.pass;
        // what was made before `start` is not read again
        if !pass.pending.is_empty() {
            let drop = start
                .saturating_sub(pass.pending_from)
                .min(pass.pending.len());
            pass.pending.drain(..drop);
            pass.pending_from += drop;
        }
        let held_from = if pass.pending.is_empty() {
            pass.compared_made()
        } else {
            pass.pending_from
        };
        if start > frames || start < held_from {
            return Err(Error::input(
                "the replay",
                format!(
                    "frame {start} is behind the {held_from} made and let go, or beyond its \
                     {frames} frames: it is read in increasing order"
                ),
            ));
        }
        let end = start.saturating_add(count).min(frames);
        pass.floor = start;
        if pass.pending.is_empty() {
            pass.pending_from = start;
        }
        while pass.compared_made() < end {
            let Some(stretch) = self.replay.next_stretch(self.observer)? else {
                break;
            };
            pass.take(stretch)?;
        }
        let (a, b) = (start - pass.pending_from, end - pass.pending_from);
        out[0].clear();
        out[0].extend_from_slice(&self.reference.range(start..end));
        out[1].clear();
        out[1].extend_from_slice(&pass.pending[a..b]);
        Ok(end - start)
    }
}

/// The measured response's nonlinear FRFs, and how the simulated one is
/// reduced the same way.
struct MeasuredFrfs {
    frf: NonlinearFrf,
    /// The sweep fitted to the reference (swept sine).
    sweep: Option<SweepFit>,
    /// A stepped sine's two-channel description (the reference, then the
    /// response) with the dwells reduced and the options: the simulated
    /// response is reduced on exactly those dwells, a dwell at a time as
    /// it is made.
    dwells: Option<(RecordingMeta, ReduceOptions)>,
}

impl MeasuredFrfs {
    /// Reduces the measured response `channels.1` against the reference
    /// `channels.0` of `rec` as `reduction` says.
    fn of(rec: &RecordingView, channels: (usize, usize), reduction: &Reduction) -> Result<Self> {
        let (reference, response) = channels;
        let fs = rec.meta.sample_rate_hz;
        match reduction {
            Reduction::Swept(opts) => {
                let mut pair =
                    InMemoryFrames::pair(rec.channels[reference], rec.channels[response], fs)?;
                let m = reduce_sweep(&mut pair, 0, 1, opts)?;
                let sweep = m.sweep;
                Ok(MeasuredFrfs {
                    frf: m.into_frf(
                        rec.meta.channels[response].quantity,
                        rec.meta.channels[reference].quantity,
                    ),
                    sweep: Some(sweep),
                    dwells: None,
                })
            }
            Reduction::Stepped(opts) => {
                let opts = ReduceOptions {
                    reference_channel: Some(0),
                    ..opts.clone()
                };
                let mut meta = rec.meta.clone();
                meta.channels = vec![
                    rec.meta.channels[reference].clone(),
                    rec.meta.channels[response].clone(),
                ];
                let pair = vec![rec.channels[reference], rec.channels[response]];
                // the dwells, stated or found (a stretch at a time where
                // the record is long), are read one at a time
                let first = reduce_stepped_by_dwell(
                    &mut InMemoryFrames::of_channels(&meta, pair.clone(), "recording"),
                    1,
                    &opts,
                    &Silent,
                )?;
                // the simulated response on exactly the measured dwells
                let steps: Vec<Step> = first.dwells.iter().map(|d| d.step).collect();
                let frf = if steps == meta.excitation.steps {
                    first.frf
                } else {
                    meta.excitation.steps = steps;
                    reduce_stepped_by_dwell(
                        &mut InMemoryFrames::of_channels(&meta, pair, "recording"),
                        1,
                        &opts,
                        &Silent,
                    )?
                    .frf
                };
                Ok(MeasuredFrfs {
                    frf,
                    sweep: None,
                    dwells: Some((meta, opts)),
                })
            }
        }
    }

    /// The comparison with `simulated`, reduced the same way, within
    /// `band_hz`.
    fn compared_with(self, simulated: NonlinearFrf, band_hz: Option<(f64, f64)>) -> FrfComparison {
        let levels = self
            .frf
            .levels
            .iter()
            .zip(&simulated.levels)
            .map(|(m, s)| {
                let (mut num, mut den, mut n) = (0.0, 0.0, 0);
                for (a, b) in m.points.iter().zip(&s.points) {
                    if in_band(a.frequency_hz, band_hz) {
                        num += (b.h[1] - a.h[1]).norm_sqr();
                        den += a.h[1].norm_sqr();
                        n += 1;
                    }
                }
                LevelComparison {
                    level: m.level,
                    points: n,
                    relative_h1_error: if den > 0.0 {
                        (num / den).sqrt()
                    } else {
                        f64::NAN
                    },
                    measured_peak: h1_peak(&m.points, band_hz),
                    simulated_peak: h1_peak(&s.points, band_hz),
                }
            })
            .collect();
        FrfComparison {
            levels,
            sweep: self.sweep,
            measured: Some(self.frf),
            simulated: Some(simulated),
        }
    }
}

/// Samples `a..b` where the fitted sweep's frequency lies inside `band`.
pub fn sweep_window(sweep: &SweepFit, band: (f64, f64)) -> (usize, usize) {
    let r = sweep.samples_in(band);
    (r.start, r.end)
}

/// The task the FRF comparison reports: both signals reduced.
const REDUCING: &str = "reducing the measured and simulated responses";
