//! Recordings on disk into nonlinear FRFs: load (MCAP run file or WAV +
//! JSON, with the test definition a virtual test recorded), choose the
//! response channel, reduce (stepped or swept sine), combine several.

use crate::error::{Error, Result};
use crate::extract::{
    NonlinearFrf, ReduceOptions, SweepFit, SweepOptions, WHOLE_RECORD_FRAMES, choose_compensation,
    choose_compensation_stream, reduce_stepped_observed, reduce_stepped_stream,
    reduce_stepped_stream_observed, reduce_sweep_recording, reduce_sweep_stream,
};
use crate::harmonics::Quantity;
use crate::record::{ExcitationKind, FrameSource, Recording, RecordingMeta};
use crate::signals::{RecordingView, SAMPLES_HELD_IN_MEMORY, SamplesBuilder, SamplesView};
use crate::testbench::TestDefinition;
use std::path::{Path, PathBuf};

/// The channels a user names for an analysis; `None` where the default
/// applies (the response: the virtual test's, else the first motion; the
/// reference: the recording format's rule, the first force, else the first
/// voltage).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct ChannelChoice<'a> {
    /// The response channel's name.
    pub response: Option<&'a str>,
    /// The reference channel's name: a voltage beside a force gauge, say,
    /// to analyse the drive (amplifier, shaker and structure) as a whole.
    pub reference: Option<&'a str>,
}

impl<'a> ChannelChoice<'a> {
    /// The response by name, the reference by the format's rule.
    pub fn response(response: Option<&'a str>) -> Self {
        ChannelChoice {
            response,
            reference: None,
        }
    }

    /// Applies the reference chosen to `meta` (read from `path`).
    pub fn apply(&self, path: &Path, meta: &mut RecordingMeta) -> Result<()> {
        if let Some(name) = self.reference {
            meta.choose_reference(&path.display().to_string(), name)?;
        }
        Ok(())
    }
}

/// A recording loaded for analysis, with the test definition it came from
/// when it is a hystid virtual test (the truth, for comparison plots).
pub struct Loaded {
    /// The recording.
    pub recording: Recording,
    /// The response channel.
    pub response: usize,
    /// The virtual test's definition, if recorded.
    pub truth: Option<TestDefinition>,
    /// An MCAP run file cut short: only its complete chunks were read.
    pub truncated: bool,
}

impl Loaded {
    /// The recording with only its reference and response channels (in that
    /// order): all that a replay and its reduction read. A recording's other
    /// channels (the bench's displacement, velocity and acceleration beside
    /// the one analysed) are as long as these, and a time-domain diagnosis
    /// holds its recordings from the refit to the replays' reduction.
    pub fn with_only_reference_and_response(mut self) -> Loaded {
        let rec = &mut self.recording;
        let Some(reference) = rec.reference_channel() else {
            return self;
        };
        let response = self.response;
        if rec.channels.len() <= 2 || reference == response {
            return self;
        }
        let keep = [reference, response];
        rec.channels = keep
            .iter()
            .map(|&c| std::mem::take(&mut rec.channels[c]))
            .collect();
        rec.meta.channels = keep.iter().map(|&c| rec.meta.channels[c].clone()).collect();
        rec.meta.chosen_reference = Some(0);
        self.response = 1;
        self
    }

    /// A recording of a reference signal (`reference_quantity`: a force or
    /// a voltage) and one response (a motion), sampled at `sample_rate_hz`,
    /// as a script holds them: the channels named after their quantities,
    /// in SI units; `excitation` says what drove the structure (its `steps`
    /// the dwells, when known). Checked as [`load_recording`] checks a
    /// file: the same length, finite samples, a reference that is not flat.
    pub fn from_signals(
        reference: Vec<f64>,
        reference_quantity: Quantity,
        response: Vec<f64>,
        response_quantity: Quantity,
        sample_rate_hz: f64,
        excitation: crate::record::Excitation,
    ) -> Result<Loaded> {
        if !(sample_rate_hz.is_finite() && sample_rate_hz > 0.0) {
            return Err(Error::input(
                "sample_rate_hz",
                format!("must be finite and > 0, got {sample_rate_hz}"),
            ));
        }
        if !matches!(reference_quantity, Quantity::Force | Quantity::Voltage) {
            return Err(Error::input(
                "reference",
                format!("must be a force or a voltage, not a {reference_quantity}"),
            ));
        }
        if !response_quantity.is_motion() {
            return Err(Error::input(
                "response",
                format!("must be a motion, not a {response_quantity}"),
            ));
        }
        if reference.len() != response.len() || reference.is_empty() {
            return Err(Error::input(
                "signals",
                format!(
                    "the reference and the response must have the same, non-zero length; got {} and {} samples",
                    reference.len(),
                    response.len()
                ),
            ));
        }
        for (name, x) in [("reference", &reference), ("response", &response)] {
            if let Some(i) = x.iter().position(|v| !v.is_finite()) {
                return Err(Error::input(
                    format!("{name}[{i}]"),
                    format!("is {}: samples must be finite", x[i]),
                ));
            }
        }
        if reference.iter().all(|&v| v == 0.0) {
            return Err(Error::input(
                "reference",
                "is flat (all zero): nothing drove the structure",
            ));
        }
        let channel = |q: Quantity| crate::record::Channel {
            name: q.name().to_string(),
            quantity: q,
            unit: q.si_unit().to_string(),
            scale: 1.0,
        };
        let meta = RecordingMeta {
            format: crate::record::FORMAT_V1.into(),
            sample_rate_hz,
            channels: vec![channel(reference_quantity), channel(response_quantity)],
            excitation,
            description: String::new(),
            metadata: Default::default(),
            extra: Default::default(),
            chosen_reference: None,
        };
        Ok(Loaded {
            recording: Recording {
                meta,
                channels: vec![reference, response],
            },
            response: 1,
            truth: None,
            truncated: false,
        })
    }
}

/// The test definition a hystid virtual test keeps in its metadata.
fn recorded_truth(meta: &RecordingMeta) -> Option<String> {
    meta.metadata
        .get("test_definition")
        .and_then(|v| v.as_str())
        .map(str::to_string)
}

/// The response channel: `response` by name, else the virtual test's
/// response quantity, else the first channel that is not the reference;
/// it must be a motion and not the reference (`meta`'s, as chosen).
pub fn response_channel(
    path: &Path,
    meta: &RecordingMeta,
    response: Option<&str>,
    truth: Option<&TestDefinition>,
) -> Result<usize> {
    let probe = Recording {
        meta: meta.clone(),
        channels: Vec::new(),
    };
    let reference = probe.reference_channel().ok_or_else(|| {
        Error::format(
            path,
            "channels",
            "no force (or voltage) channel to use as the reference",
        )
    })?;
    let response = match response {
        Some(name) => probe.channel_index(name).ok_or_else(|| {
            let names: Vec<&str> = meta.channels.iter().map(|c| c.name.as_str()).collect();
            Error::format(
                path,
                "channels",
                format!("no channel `{name}` (channels: {names:?})"),
            )
        })?,
        None => {
            // a virtual test says which response its FRFs were of
            let wanted = truth.map(|t| t.test.response.quantity().name().to_string());
            wanted
                .and_then(|q| meta.channels.iter().position(|c| c.quantity.name() == q))
                .or_else(|| probe.default_response_channel())
                .ok_or_else(|| {
                    Error::format(
                        path,
                        "channels",
                        "no response channel besides the reference",
                    )
                })?
        }
    };
    if response == reference {
        return Err(Error::format(
            path,
            "channels",
            "the response channel is the reference channel",
        ));
    }
    let q = meta.channels[response].quantity;
    if !q.is_motion() {
        return Err(Error::format(
            path,
            "channels",
            format!(
                "the response channel `{}` is a {q}, not a motion",
                meta.channels[response].name
            ),
        ));
    }
    Ok(response)
}

fn is_mcap(path: &Path) -> bool {
    path.extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("mcap"))
}

/// Reads `run.mcap` or a WAV + JSON recording, with its reference and
/// response channels (as `choice` names them, else as
/// [`response_channel`] chooses).
pub fn load_recording(path: &Path, choice: ChannelChoice) -> Result<Loaded> {
    let (mut recording, toml_text, truncated) = if is_mcap(path) {
        let run = crate::record::read_run(path)?;
        let text = run.info.test_definition.clone();
        let rec = run.to_recording().map_err(|e| {
            Error::context(format!("{}: rebuilding the recording", path.display()), e)
        })?;
        (rec, Some(text), run.truncated)
    } else {
        let rec = crate::record::read_recording(path)?;
        let text = recorded_truth(&rec.meta);
        (rec, text, false)
    };
    let truth =
        toml_text.and_then(|t| TestDefinition::from_toml(&t, "recorded test definition").ok());
    choice.apply(path, &mut recording.meta)?;
    let response = response_channel(path, &recording.meta, choice.response, truth.as_ref())?;
    let reference = recording
        .reference_channel()
        .expect("checked by response_channel");
    let force = &recording.channels[reference];
    if force.iter().all(|&v| v == 0.0) {
        return Err(flat_reference(
            path,
            &recording.meta.channels[reference].name,
        ));
    }
    Ok(Loaded {
        recording,
        response,
        truth,
        truncated,
    })
}

/// [`load_recording`]`(path, choice)?`[`.with_only_reference_and_response()`](Loaded::with_only_reference_and_response),
/// the same to the bit, without the other channels ever read into memory:
/// the file is read a stretch at a time and only the reference and the
/// response are kept (a bench's recording holds four channels, and a time
/// fit or a replay reads two: read whole, 264 MB of a 8.2 M frame
/// recording for the 132 MB kept).
pub fn load_reference_and_response(path: &Path, choice: ChannelChoice) -> Result<Loaded> {
    let (kept, truncated) = open_kept::<Vec<f64>>(path, choice)?;
    Ok(Loaded {
        recording: Recording {
            meta: kept.meta,
            channels: kept.channels,
        },
        response: kept.response,
        truth: kept.truth,
        truncated,
    })
}

/// A recording's reference and response held as the file stored them
/// ([`crate::signals::Samples`]: 4 bytes a sample where the file's are
/// 32-bit floats or 16/24-bit integers), for the stages that replay a
/// recording beside its measurement without holding it in `f64`s.
pub struct HeldRecording {
    /// Trimmed to the channels held.
    pub meta: RecordingMeta,
    /// One per channel of `meta`.
    pub channels: Vec<crate::signals::Samples>,
    /// The response channel.
    pub response: usize,
    /// An MCAP run file cut short: only its complete chunks were read.
    pub truncated: bool,
}

impl HeldRecording {
    /// The recording borrowed.
    pub fn view(&self) -> RecordingView<'_> {
        RecordingView {
            meta: &self.meta,
            channels: self.channels.iter().map(Into::into).collect(),
        }
    }
}

/// [`load_reference_and_response`] into the precision the file stored them
/// in (half the memory of `f64`s).
pub fn load_held_reference_and_response(
    path: &Path,
    choice: ChannelChoice,
) -> Result<HeldRecording> {
    let (kept, truncated) = open_kept::<SamplesBuilder>(path, choice)?;
    Ok(HeldRecording {
        meta: kept.meta,
        channels: kept
            .channels
            .into_iter()
            .map(SamplesBuilder::finish)
            .collect::<Result<_>>()?,
        response: kept.response,
        truncated,
    })
}

/// [`read_kept`] of the recording at `path`, and whether it is a run file
/// cut short.
fn open_kept<K: Keep>(path: &Path, choice: ChannelChoice) -> Result<(Kept<K>, bool)> {
    if is_mcap(path) {
        let reader = crate::record::McapRunReader::open(path)?;
        let text = reader.run().info.test_definition.clone();
        let truncated = reader.run().truncated;
        Ok((read_kept(path, reader, Some(text), choice)?, truncated))
    } else {
        let reader = crate::record::RecordingReader::open(path)?;
        let text = recorded_truth(reader.meta());
        Ok((read_kept(path, reader, text, choice)?, false))
    }
}

/// The recording at `path`'s description (not its samples) and the test
/// definition it records, if any.
fn described(path: &Path) -> Result<(RecordingMeta, Option<TestDefinition>)> {
    let (meta, text) = if is_mcap(path) {
        let reader = crate::record::McapRunReader::open(path)?;
        let text = reader.run().info.test_definition.clone();
        (reader.meta().clone(), Some(text))
    } else {
        let reader = crate::record::RecordingReader::open(path)?;
        let text = recorded_truth(reader.meta());
        (reader.meta().clone(), text)
    };
    let truth = text.and_then(|t| TestDefinition::from_toml(&t, "recorded test definition").ok());
    Ok((meta, truth))
}

/// The names of the recording at `path`'s channels, its description read,
/// not its samples.
pub fn channel_names(path: &Path) -> Result<Vec<String>> {
    let (meta, _) = described(path)?;
    Ok(meta.channels.iter().map(|c| c.name.clone()).collect())
}

/// The name of the response channel `choice` takes in the recording at
/// `path` (see [`response_channel`]), its description read, not its
/// samples: what a fit was fitted to.
pub fn response_channel_name(path: &Path, choice: ChannelChoice) -> Result<String> {
    let (mut meta, truth) = described(path)?;
    choice.apply(path, &mut meta)?;
    let response = response_channel(path, &meta, choice.response, truth.as_ref())?;
    Ok(meta.channels[response].name.clone())
}

/// The excitation the recording at `path` states (its description read,
/// not its samples).
pub fn stated_excitation(path: &Path) -> Result<ExcitationKind> {
    Ok(if is_mcap(path) {
        crate::record::McapRunReader::open(path)?
            .meta()
            .excitation
            .kind
    } else {
        crate::record::RecordingReader::open(path)?
            .meta()
            .excitation
            .kind
    })
}

/// Frames read at a time by [`load_reference_and_response`].
const LOAD_STRETCH: usize = 1 << 16;

/// How a loader keeps a channel's samples as it reads them.
trait Keep {
    /// For `frames` samples of a channel of `scale`.
    fn for_channel(frames: usize, scale: f64) -> Self;
    /// Appends `x`.
    fn append(&mut self, x: &[f64]) -> Result<()>;
    /// Whether every sample is zero.
    fn all_zero(&self) -> bool;
}

impl Keep for Vec<f64> {
    fn for_channel(frames: usize, _: f64) -> Self {
        Vec::with_capacity(frames)
    }
    fn append(&mut self, x: &[f64]) -> Result<()> {
        self.extend_from_slice(x);
        Ok(())
    }
    fn all_zero(&self) -> bool {
        self.iter().all(|&v| v == 0.0)
    }
}

impl Keep for SamplesBuilder {
    fn for_channel(frames: usize, scale: f64) -> Self {
        // a WAV file's samples are f32s (or 16/24-bit integers) of its
        // scale, a run file's f32s
        SamplesBuilder::new(frames, &[scale, 1.0]).spilling_above(SAMPLES_HELD_IN_MEMORY)
    }
    fn append(&mut self, x: &[f64]) -> Result<()> {
        self.extend(x)
    }
    fn all_zero(&self) -> bool {
        SamplesBuilder::all_zero(self)
    }
}

/// A recording's reference and response as a loader kept them.
struct Kept<K> {
    /// Trimmed to the channels kept.
    meta: RecordingMeta,
    channels: Vec<K>,
    response: usize,
    truth: Option<TestDefinition>,
}

/// Reads `source` a stretch at a time keeping only its reference and
/// response (every channel where it has no more than those two).
fn read_kept<K: Keep>(
    path: &Path,
    mut source: impl FrameSource,
    toml_text: Option<String>,
    choice: ChannelChoice,
) -> Result<Kept<K>> {
    let truth =
        toml_text.and_then(|t| TestDefinition::from_toml(&t, "recorded test definition").ok());
    let mut meta = source.meta().clone();
    choice.apply(path, &mut meta)?;
    let response = response_channel(path, &meta, choice.response, truth.as_ref())?;
    let reference = meta
        .reference_channel()
        .expect("checked by response_channel");
    // as `Loaded::with_only_reference_and_response` keeps them
    let trimmed = meta.channels.len() > 2 && reference != response;
    let keep: Vec<usize> = if trimmed {
        vec![reference, response]
    } else {
        (0..meta.channels.len()).collect()
    };
    let frames = source.frames();
    let mut stretch = vec![Vec::new(); meta.channels.len()];
    let mut channels: Vec<K> = keep
        .iter()
        .map(|&c| K::for_channel(frames, meta.channels[c].scale))
        .collect();
    let mut at = 0;
    while at < frames {
        let got = source.read_at(at, LOAD_STRETCH, &mut stretch)?;
        if got == 0 {
            break;
        }
        for (kept, &c) in channels.iter_mut().zip(&keep) {
            kept.append(&stretch[c])?;
        }
        at += got;
    }
    if channels[keep.iter().position(|&c| c == reference).expect("kept")].all_zero() {
        return Err(flat_reference(path, &meta.channels[reference].name));
    }
    let mut response = response;
    if trimmed {
        meta.channels = keep.iter().map(|&c| meta.channels[c].clone()).collect();
        meta.chosen_reference = Some(0);
        response = 1;
    }
    Ok(Kept {
        meta,
        channels,
        response,
        truth,
    })
}

/// A time-domain fit's record of the recording at `path` (see
/// [`crate::fit::TimeRecord::from_recording`]), its reference and
/// response read a stretch at a time into the precision the file stored
/// them in ([`crate::signals::Samples`]): the fit holds them for as long as
/// it runs, and they were never held as `f64`s (8 MB a million frames,
/// not 16). Judged over `window_s` (seconds from the first sample) where
/// given.
pub fn load_time_record(
    path: &Path,
    choice: ChannelChoice,
    window_s: Option<(f64, f64)>,
    band_hz: Option<(f64, f64)>,
) -> Result<crate::fit::TimeRecord> {
    let (kept, _) = open_kept::<SamplesBuilder>(path, choice)?;
    let fs = kept.meta.sample_rate_hz;
    let window = window_s.map(|(a, b)| (a * fs).round() as usize..(b * fs).round() as usize);
    let mut channels: Vec<Option<SamplesBuilder>> = kept.channels.into_iter().map(Some).collect();
    let reference = kept.meta.reference_channel().expect("checked when read");
    let mut take = |c: usize| channels[c].take().map(SamplesBuilder::finish).transpose();
    let reference_samples = take(reference)?.expect("kept");
    let response = match take(kept.response)? {
        Some(r) => r,
        // the reference judged against itself
        None => reference_samples.clone(),
    };
    crate::fit::TimeRecord::from_held(
        &path.display().to_string(),
        &kept.meta,
        kept.response,
        (reference_samples, response),
        window,
        band_hz,
    )
}

/// How a recording is reduced.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Excitation {
    /// Dwells (stated or found).
    Stepped,
    /// A continuous sweep.
    Swept,
}

/// Swept sine: the sweep-distortion compensation.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Compensation {
    /// Chosen from the data ([`choose_compensation`]).
    Auto,
    /// None.
    Off,
    /// The Gaussian window's standard deviation, s (> 0).
    Seconds(f64),
}

/// How recordings are reduced into nonlinear FRFs.
#[derive(Clone, Debug, PartialEq)]
pub struct ReductionOptions {
    /// The reduction; `None`: the recording's `excitation.kind` (stepped
    /// when not stated).
    pub excitation: Option<Excitation>,
    /// Highest harmonic; `None`: 7 for stepped sine, 3 for swept.
    pub max_harmonic: Option<usize>,
    /// Swept sine: the compensation.
    pub compensation: Compensation,
    /// Swept sine: hop between analysis windows, periods of the sweep.
    pub hop_periods: f64,
    /// Swept sine: analysis window, whole periods.
    pub window_periods: usize,
}

impl Default for ReductionOptions {
    fn default() -> Self {
        ReductionOptions {
            excitation: None,
            max_harmonic: None,
            compensation: Compensation::Auto,
            hop_periods: 1.0,
            window_periods: 4,
        }
    }
}

/// The reduction a recording gets: the option, else its `excitation.kind`
/// (stepped when not stated).
pub fn excitation_of(meta: &RecordingMeta, choice: Option<Excitation>) -> Excitation {
    choice.unwrap_or(match meta.excitation.kind {
        ExcitationKind::SweptSine => Excitation::Swept,
        _ => Excitation::Stepped,
    })
}

/// One recording reduced into nonlinear FRFs.
pub struct Reduced {
    /// The FRFs.
    pub frf: NonlinearFrf,
    /// The response channel's name.
    pub response_name: String,
    /// The recording's sample rate, Hz.
    pub sample_rate_hz: f64,
    /// How it was reduced.
    pub excitation: Excitation,
    /// Swept sine: the sweep found, the compensation and the hop used.
    pub sweep: Option<SweptReading>,
    /// The virtual test's definition, if recorded.
    pub truth: Option<TestDefinition>,
    /// Reduced from disk one dwell at a time (memory bounded).
    pub streamed: bool,
    /// An MCAP run file cut short: only its complete chunks were reduced.
    pub truncated: bool,
    /// The warnings and errors of the quality report `hystid import` wrote
    /// beside the recording, one line each ([`quality_notes`]).
    pub quality: Vec<String>,
}

/// The highest harmonic for a reduction.
pub fn max_harmonic(r: &ReductionOptions, e: Excitation) -> usize {
    r.max_harmonic.unwrap_or(match e {
        Excitation::Stepped => 7,
        Excitation::Swept => 3,
    })
}

/// Stepped-sine reduction options.
pub fn stepped_options(r: &ReductionOptions) -> ReduceOptions {
    ReduceOptions {
        max_harmonic: max_harmonic(r, Excitation::Stepped),
        blocks: 16,
        ..ReduceOptions::default()
    }
}

/// Sweep options for `force`/`response`, the compensation resolved
/// ([`Compensation::Auto`]: [`choose_compensation`]).
pub fn sweep_options(
    force: &[f64],
    response: &[f64],
    sample_rate_hz: f64,
    r: &ReductionOptions,
) -> Result<SweepOptions> {
    sweep_options_by(r, &mut |opts| {
        choose_compensation(force, response, sample_rate_hz, opts)
    })
}

/// [`sweep_options`] of two held channels (in memory or in scratch files),
/// read a stretch at a time rather than copied whole: the same options.
pub fn sweep_options_held(
    force: crate::signals::SamplesView,
    response: crate::signals::SamplesView,
    sample_rate_hz: f64,
    r: &ReductionOptions,
) -> Result<SweepOptions> {
    sweep_options_by(r, &mut |opts| {
        crate::extract::choose_compensation_held(force, response, sample_rate_hz, opts)
    })
}

/// Sweep options, the automatic compensation chosen by `choose`.
fn sweep_options_by(
    r: &ReductionOptions,
    choose: &mut dyn FnMut(&SweepOptions) -> Result<f64>,
) -> Result<SweepOptions> {
    let mut opts = SweepOptions {
        max_harmonic: max_harmonic(r, Excitation::Swept),
        window_periods: r.window_periods,
        hop_periods: r.hop_periods,
        ..SweepOptions::default()
    };
    opts.compensation_s = match r.compensation {
        Compensation::Auto => Some(choose(&opts)?),
        Compensation::Off => None,
        Compensation::Seconds(s) => Some(s),
    };
    Ok(opts)
}

/// Fewest excited lines for a periodic record to count as a multisine (the
/// linear estimate's `m, c, k` need them; a single sine is periodic too).
pub const MULTISINE_LINES: usize = 3;

/// A recording that states no excitation, read as a periodic multisine:
/// its period (samples) and the excited lines (Hz, lowest and highest, and
/// how many), found in its first [`crate::extract::PERIOD_SEARCH`] frames; `None` where
/// its reference does not repeat with at least [`MULTISINE_LINES`]
/// excited lines (a stepped sine's repeats only within a dwell, at one
/// line).
pub(crate) fn multisine_period(
    rec: &RecordingView,
    response: usize,
) -> Option<(usize, f64, f64, usize)> {
    if rec.meta.excitation.kind != ExcitationKind::Unknown || !rec.meta.excitation.steps.is_empty()
    {
        return None;
    }
    let reference = rec.meta.reference_channel()?;
    let (u, y) = (&rec.channels[reference], &rec.channels[response]);
    // unequal lengths are the reduction's to refuse, naming the channels
    let n = u.len().min(y.len()).min(crate::extract::PERIOD_SEARCH);
    let (u, y) = (u.range(0..n), y.range(0..n));
    let u = &u[..];
    let period = crate::extract::find_period(u)?;
    let fs = rec.meta.sample_rate_hz;
    let lines = crate::extract::periodic_frf(u, &y[..n], fs, period);
    if lines.len() < MULTISINE_LINES {
        return None;
    }
    let (lo, hi) = lines.iter().fold((f64::INFINITY, 0.0f64), |(a, b), l| {
        (a.min(l.frequency_hz), b.max(l.frequency_hz))
    });
    Some((period, lo, hi, lines.len()))
}

/// An error when a recording is a periodic multisine
/// ([`multisine_period`]): a dwell search would cut it into meaningless
/// "dwells".
pub(crate) fn refuse_a_multisine(rec: &Recording, response: usize) -> Result<()> {
    let Some((period, lo, hi, lines)) = multisine_period(&rec.view(), response) else {
        return Ok(());
    };
    Err(Error::input(
        "recording",
        format!(
            "its reference is a multisine (a period of {period} samples repeated, {lines} excited \
             lines over {lo:.4}-{hi:.4} Hz), which nonlinear FRFs are not read from (they need \
             stepped or swept sines): fit it in the time domain (`identify --domain time`, \
             which starts from its linear FRF at the excited lines; `diagnose --domain time` \
             diagnoses it at the lines of its period), or state `--excitation \
             stepped` if it is one"
        ),
    ))
}

/// Nonlinear FRFs of a loaded recording.
pub fn reduce(loaded: &Loaded, r: &ReductionOptions) -> Result<Reduced> {
    reduce_observed(loaded, r, &crate::observe::Silent)
}

/// [`reduce`], telling `observer` how it progresses (`reducing`: a stepped
/// sine's dwells; a swept sine's whole reductions, three where the
/// compensation is chosen from the data) and stopping where it asks
/// ([`Error::Cancelled`]).
pub fn reduce_observed(
    loaded: &Loaded,
    r: &ReductionOptions,
    observer: &dyn crate::observe::Observer,
) -> Result<Reduced> {
    let rec = &loaded.recording;
    let excitation = excitation_of(&rec.meta, r.excitation);
    let response_name = rec.meta.channels[loaded.response].name.clone();
    let fs = rec.meta.sample_rate_hz;
    let (frf, sweep) = match excitation {
        Excitation::Stepped => {
            if r.excitation.is_none() {
                refuse_a_multisine(rec, loaded.response)?;
            }
            (
                reduce_stepped_observed(rec, loaded.response, &stepped_options(r), observer)?.frf,
                None,
            )
        }
        Excitation::Swept => {
            let reference = rec
                .reference_channel()
                .ok_or_else(|| Error::input("recording", "no reference channel"))?;
            let (total, report) = swept_stages(r, observer);
            report(0)?;
            let opts = sweep_options(
                &rec.channels[reference],
                &rec.channels[loaded.response],
                fs,
                r,
            )?;
            report(total - 1)?;
            let red = reduce_sweep_recording(rec, loaded.response, &opts)?;
            report(total)?;
            let reading = SweptReading {
                sweep: red.sweep,
                compensation_s: opts.compensation_s,
                hop_periods: red.hop_periods,
                hop_asked: opts.hop_periods,
            };
            let q = rec.meta.channels[loaded.response].quantity;
            let rq = rec.meta.channels[reference].quantity;
            (red.into_frf(q, rq), Some(reading))
        }
    };
    Ok(Reduced {
        frf,
        response_name,
        sample_rate_hz: fs,
        excitation,
        sweep,
        truth: loaded.truth.clone(),
        streamed: false,
        truncated: loaded.truncated,
        quality: Vec::new(),
    })
}

/// A swept reduction's stages, and how to tell `observer` that `done` of
/// them are (`reducing`): the automatic compensation is two reductions
/// more than the one kept.
fn swept_stages<'o>(
    r: &ReductionOptions,
    observer: &'o dyn crate::observe::Observer,
) -> (u64, impl Fn(u64) -> Result<()> + 'o) {
    let total = if r.compensation == Compensation::Auto {
        3
    } else {
        1
    };
    (total, move |done| {
        crate::observe::progress(observer, "reducing", done, total)
    })
}

/// How a swept-sine recording was read into FRF points.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SweptReading {
    /// The sweep found.
    pub sweep: SweepFit,
    /// The compensation's window, s (`None`: off).
    pub compensation_s: Option<f64>,
    /// The hop between windows, periods.
    pub hop_periods: f64,
    /// The hop asked (`hop_periods` is longer where the sweep holds more
    /// points than [`crate::extract::SweepOptions::max_points`]).
    pub hop_asked: f64,
}

/// Reduces the recording at `path`: a stepped-sine WAV + JSON recording
/// whose sidecar states its steps is reduced from disk one dwell at a time,
/// and a swept-sine one longer than [`WHOLE_RECORD_FRAMES`] a stretch at a
/// time (memory bounded whatever the file size); anything else is read
/// whole.
pub fn reduce_path(path: &Path, choice: ChannelChoice, r: &ReductionOptions) -> Result<Reduced> {
    reduce_path_observed(path, choice, r, &crate::observe::Silent)
}

/// [`reduce_path`], telling `observer` how it progresses (a dwell search's
/// `finding dwells`; `reducing`: a stepped sine's dwells, a swept sine's
/// whole reductions) and stopping where it asks ([`Error::Cancelled`]).
pub fn reduce_path_observed(
    path: &Path,
    choice: ChannelChoice,
    r: &ReductionOptions,
    observer: &dyn crate::observe::Observer,
) -> Result<Reduced> {
    if path
        .to_str()
        .is_some_and(|p| p.to_ascii_lowercase().ends_with(".quality.json"))
    {
        return Err(Error::input(
            path.display().to_string(),
            "this is the data-quality report `hystid import` writes beside a recording, not a recording (a glob such as `*.json` picks it up: name the recordings)",
        ));
    }
    let mut reduced = match reduce_path_streamed(path, choice, r, observer)? {
        Some(reduced) => reduced,
        None => reduce_observed(&load_recording(path, choice)?, r, observer)?,
    };
    reduced.quality = quality_notes(path);
    Ok(reduced)
}

/// The quality report `hystid import` writes beside `path` (NAME.wav or
/// NAME.json: NAME.quality.json), if there is one.
fn quality_report_path(path: &Path) -> Option<PathBuf> {
    let ext = path.extension()?.to_str()?.to_ascii_lowercase();
    if ext != "wav" && ext != "json" {
        return None;
    }
    let mut s = path.with_extension("").into_os_string();
    s.push(".quality.json");
    Some(PathBuf::from(s))
}

/// The warnings and errors of the import's quality report beside `path`,
/// one line each naming the recording, so that clipping found at import
/// reaches the fit and the diagnosis. No report: none; an unreadable one:
/// a line saying so (the analysis goes on, as it would without).
pub fn quality_notes(path: &Path) -> Vec<String> {
    use crate::import::quality::{QualityReport, Severity};
    let Some(report_path) = quality_report_path(path).filter(|p| p.is_file()) else {
        return Vec::new();
    };
    let name = path.display();
    let report = std::fs::read_to_string(&report_path)
        .map_err(|e| e.to_string())
        .and_then(|t| serde_json::from_str::<QualityReport>(&t).map_err(|e| e.to_string()));
    match report {
        Ok(r) => r
            .findings
            .iter()
            .filter(|f| f.severity != Severity::Info)
            .map(|f| {
                format!(
                    "{name}: {}: {} (import's quality report)",
                    f.severity, f.message
                )
            })
            .collect(),
        Err(e) => vec![format!(
            "{name}: the import's quality report {} could not be read ({e}); its warnings are not carried",
            report_path.display()
        )],
    }
}

/// [`reduce_path`] where it reads the file a stretch at a time (stated
/// dwells, a long sweep); `None` where it would read it whole.
fn reduce_path_streamed(
    path: &Path,
    choice: ChannelChoice,
    r: &ReductionOptions,
    observer: &dyn crate::observe::Observer,
) -> Result<Option<Reduced>> {
    // stepped sines whose steps are stated are reduced one dwell at a time
    // from disk (memory bounded whatever the file's size)
    Ok(if is_mcap(path) {
        let reader = crate::record::McapRunReader::open(path)?;
        let truth = TestDefinition::from_toml(
            &reader.run().info.test_definition,
            "recorded test definition",
        )
        .ok();
        let truncated = reader.run().truncated;
        reduce_streamed(path, reader, (truth, truncated), choice, r, observer)?
    } else {
        let reader = crate::record::RecordingReader::open(path)?;
        let truth = recorded_truth(reader.meta())
            .and_then(|t| TestDefinition::from_toml(&t, "recorded test definition").ok());
        reduce_streamed(path, reader, (truth, false), choice, r, observer)?
    })
}

/// The shaker's coil of the recording at `path` (a run file or a WAV
/// recording), when it holds a voltage, the force the shaker applies and
/// the drive point's motion at stated steps ([`crate::fit::coil`]); read
/// one dwell at a time.
pub fn coil_of_path(path: &Path) -> Result<Option<crate::fit::coil::CoilFit>> {
    if is_mcap(path) {
        crate::fit::coil::fit_coil(&mut crate::record::McapRunReader::open(path)?)
    } else {
        crate::fit::coil::fit_coil(&mut crate::record::RecordingReader::open(path)?)
    }
}

/// [`reduce_path`]'s streamed reduction of `source`, when its excitation is
/// stepped and its steps are stated; `None` otherwise.
fn reduce_streamed(
    path: &Path,
    mut source: impl FrameSource,
    (truth, truncated): (Option<TestDefinition>, bool),
    choice: ChannelChoice,
    r: &ReductionOptions,
    observer: &dyn crate::observe::Observer,
) -> Result<Option<Reduced>> {
    let mut meta = source.meta().clone();
    let excitation = excitation_of(&meta, r.excitation);
    let long = source.frames() > WHOLE_RECORD_FRAMES;
    let swept = excitation == Excitation::Swept && long;
    let stepped = excitation == Excitation::Stepped && (!meta.excitation.steps.is_empty() || long);
    if !swept && !stepped {
        return Ok(None);
    }
    choice.apply(path, &mut meta)?;
    let ch = response_channel(path, &meta, choice.response, truth.as_ref())?;
    let reference = meta
        .reference_channel()
        .expect("checked by response_channel");
    if stepped && meta.excitation.steps.is_empty() && r.excitation.is_none() {
        // a multisine's periods would be cut into "dwells": say what it is,
        // from its first frames as the whole path does
        let n = source.frames().min(crate::extract::PERIOD_SEARCH);
        let mut buffers = vec![Vec::new(); source.meta().channels.len()];
        source.read_at(0, n, &mut buffers)?;
        let probe = Recording {
            meta: meta.clone(),
            channels: buffers,
        };
        refuse_a_multisine(&probe, ch)?;
    }
    if swept {
        return reduce_swept_stream(
            path,
            source,
            (truth, truncated),
            &meta,
            (reference, ch),
            r,
            observer,
        )
        .map(Some);
    }
    let options = ReduceOptions {
        reference_channel: Some(reference),
        ..stepped_options(r)
    };
    let red = match reduce_stepped_stream_observed(&mut source, ch, &options, observer) {
        Ok(red) => red,
        Err(e) => return Err(why_failed(e, path, &mut source, &meta, reference)?),
    };
    Ok(Some(Reduced {
        frf: red.frf,
        response_name: meta.channels[ch].name.clone(),
        sample_rate_hz: meta.sample_rate_hz,
        excitation: Excitation::Stepped,
        sweep: None,
        truth,
        streamed: true,
        truncated,
        quality: Vec::new(),
    }))
}

/// [`reduce_streamed`]'s swept-sine reduction of a long recording, read a
/// stretch at a time (`channels`: the reference and the response).
fn reduce_swept_stream(
    path: &Path,
    mut source: impl FrameSource,
    (truth, truncated): (Option<TestDefinition>, bool),
    meta: &RecordingMeta,
    (reference, ch): (usize, usize),
    r: &ReductionOptions,
    observer: &dyn crate::observe::Observer,
) -> Result<Reduced> {
    let (total, report) = swept_stages(r, observer);
    let reduced = report(0)
        .and_then(|()| {
            sweep_options_by(r, &mut |opts| {
                choose_compensation_stream(&mut source, reference, ch, opts)
            })
        })
        .and_then(|opts| {
            report(total - 1)?;
            let red = reduce_sweep_stream(&mut source, reference, ch, &opts)?;
            report(total)?;
            Ok((red, opts.compensation_s, opts.hop_periods))
        });
    let (red, compensation, hop_asked) = match reduced {
        Ok(r) => r,
        Err(e) => return Err(why_failed(e, path, &mut source, meta, reference)?),
    };
    let reading = SweptReading {
        sweep: red.sweep,
        compensation_s: compensation,
        hop_periods: red.hop_periods,
        hop_asked,
    };
    Ok(Reduced {
        frf: red.into_frf(
            meta.channels[ch].quantity,
            meta.channels[reference].quantity,
        ),
        response_name: meta.channels[ch].name.clone(),
        sample_rate_hz: meta.sample_rate_hz,
        excitation: Excitation::Swept,
        sweep: Some(reading),
        truth,
        streamed: true,
        truncated,
        quality: Vec::new(),
    })
}

/// The error a streamed reduction of `path` failed with, said better where
/// its reference channel is all zero (which fails the first dwell or the
/// sweep's fit), as `load_recording` says it: read through once more, only
/// on failure, and not when the user stopped it.
fn why_failed(
    e: Error,
    path: &Path,
    source: &mut impl FrameSource,
    meta: &RecordingMeta,
    reference: usize,
) -> Result<Error> {
    if !matches!(e, Error::Cancelled) && is_flat(source, reference)? {
        return Ok(flat_reference(path, &meta.channels[reference].name));
    }
    Ok(e)
}

/// The error for a reference channel `name` of `path` that is all zero.
fn flat_reference(path: &Path, name: &str) -> Error {
    Error::format(
        path,
        name,
        "the reference channel is flat (all zero): nothing drove the structure",
    )
}

/// True when channel `c` of `source` is zero throughout (read a block at a
/// time).
fn is_flat(source: &mut impl FrameSource, c: usize) -> Result<bool> {
    const BLOCK: usize = 1 << 16;
    let mut buffers = vec![Vec::new(); source.meta().channels.len()];
    let mut start = 0;
    while start < source.frames() {
        let got = source.read_at(start, BLOCK, &mut buffers)?;
        if got == 0 {
            break;
        }
        if buffers[c].iter().any(|&v| v != 0.0) {
            return Ok(false);
        }
        start += got;
    }
    Ok(true)
}

/// Several recordings' FRFs as one set: single-dwell recordings (one point
/// each, e.g. steady single sines) are merged by level
/// ([`crate::extract::combine`]); otherwise each recording's levels are
/// kept as they are, in the order given (a swept recording is one level).
pub fn combine_recordings(sets: &[(PathBuf, NonlinearFrf)]) -> Result<NonlinearFrf> {
    let (first_path, first) = sets
        .first()
        .ok_or_else(|| Error::input("recordings", "none given"))?;
    for (p, f) in sets {
        if f.response != first.response || f.reference != first.reference {
            return Err(Error::input(
                p.display().to_string(),
                format!(
                    "its FRFs are {}/{} but {} gives {}/{}: recordings combine only with the \
                     same response and reference quantities",
                    f.response,
                    f.reference,
                    first_path.display(),
                    first.response,
                    first.reference
                ),
            ));
        }
    }
    let single = sets
        .iter()
        .all(|(_, f)| f.levels.iter().map(|l| l.points.len()).sum::<usize>() == 1);
    let k = sets.iter().map(|(_, f)| f.max_harmonic).min().unwrap_or(0);
    // a common harmonic count: drop what not every recording holds
    let trimmed: Vec<NonlinearFrf> = sets
        .iter()
        .map(|(_, f)| {
            let mut f = f.clone();
            f.max_harmonic = k;
            for l in &mut f.levels {
                for p in &mut l.points {
                    p.h.truncate(k + 1);
                    p.std_error.truncate(k + 1);
                    p.force_distortion.truncate(k + 1);
                }
            }
            f
        })
        .collect();
    if single && sets.len() > 1 {
        return crate::extract::combine(&trimmed);
    }
    let mut out = trimmed[0].clone();
    out.levels = trimmed.into_iter().flat_map(|f| f.levels).collect();
    Ok(out)
}

/// Reduces every recording and combines them into one FRF set (one level
/// per file, or the levels each holds); also returns the first reduction,
/// its `quality` holding every recording's. `on_reduced` sees each reduction as it is made, `observer` how each
/// progresses ([`reduce_path_observed`]).
pub fn reduce_recordings(
    recordings: &[PathBuf],
    choice: ChannelChoice,
    reduction: &ReductionOptions,
    on_reduced: &mut dyn FnMut(&Path, &Reduced),
    observer: &dyn crate::observe::Observer,
) -> Result<(NonlinearFrf, Reduced)> {
    let mut sets = Vec::with_capacity(recordings.len());
    let mut first: Option<Reduced> = None;
    let mut quality = Vec::new();
    for path in recordings {
        let red = reduce_path_observed(path, choice, reduction, observer)
            .map_err(|e| Error::context(format!("reducing {}", path.display()), e))?;
        on_reduced(path, &red);
        sets.push((path.clone(), red.frf.clone()));
        quality.extend(red.quality.iter().cloned());
        first.get_or_insert(red);
    }
    let mut first = first.ok_or_else(|| Error::input("recordings", "no recording given"))?;
    // the combined FRFs carry every recording's quality warnings
    first.quality = quality;
    Ok((combine_recordings(&sets)?, first))
}

/// Recordings held with the reduction each was given, so that a model's
/// replay of each is reduced exactly as the measured response was: the same
/// reduction of the same reference (the same windows, the same frequencies)
/// and the same sweep compensation, the automatic one resolved once on the
/// measured response. The difference of the two FRF sets is a time-domain
/// residual in the plane the FRFs live in
/// ([`crate::diagnose::time_residual`]).
///
/// What it holds does not grow with the recordings' length where their
/// dwells are stated in order: the measured response is reduced from the
/// file a dwell at a time ([`reduce_path`]), the reference and response are
/// held as the file stored them (a long channel in a scratch file, see
/// [`SAMPLES_HELD_IN_MEMORY`]) until the time records take them, and a model's replay
/// is reduced a dwell at a time as it is made
/// ([`ReplayReduction::replayed_as_made`]).
pub struct ReplayReduction {
    sources: Vec<ReplaySource>,
    measured: NonlinearFrf,
}

/// One recording of a [`ReplayReduction`].
struct ReplaySource {
    path: PathBuf,
    /// Trimmed to the channels held (the reference and the response).
    meta: RecordingMeta,
    response: usize,
    truncated: bool,
    /// The reduction, its excitation and sweep compensation settled.
    options: ReductionOptions,
    /// The channels of `meta`, until the time records take them.
    held: Option<Vec<crate::signals::Samples>>,
}

impl HeldRecording {
    /// `loaded`'s reference and response held as [`load_held_reference_and_response`]
    /// holds them.
    pub fn of_loaded(loaded: Loaded) -> Result<HeldRecording> {
        let loaded = loaded.with_only_reference_and_response();
        let Recording { meta, channels } = loaded.recording;
        let channels = channels
            .into_iter()
            .zip(&meta.channels)
            .map(|(values, channel)| {
                let mut b = SamplesBuilder::for_channel(values.len(), channel.scale);
                for x in values.chunks(LOAD_STRETCH) {
                    b.extend(x)?;
                }
                b.finish()
            })
            .collect::<Result<_>>()?;
        Ok(HeldRecording {
            meta,
            channels,
            response: loaded.response,
            truncated: loaded.truncated,
        })
    }
}

impl ReplayReduction {
    /// Reduces each recording and holds its reference and response: from
    /// the file a dwell at a time where [`reduce_path`] can (stated dwells,
    /// a long sweep), else loaded whole.
    pub fn new(
        recordings: &[PathBuf],
        choice: ChannelChoice,
        reduction: &ReductionOptions,
    ) -> Result<ReplayReduction> {
        let mut reduced = Vec::with_capacity(recordings.len());
        for path in recordings {
            let at = |e| Error::context(format!("reducing {}", path.display()), e);
            let one = match reduce_path_streamed(path, choice, reduction, &crate::observe::Silent)
                .map_err(at)?
            {
                Some(red) => (
                    red,
                    load_held_reference_and_response(path, choice).map_err(at)?,
                ),
                None => {
                    let loaded = load_reference_and_response(path, choice).map_err(at)?;
                    let red = reduce(&loaded, reduction).map_err(at)?;
                    (red, HeldRecording::of_loaded(loaded)?)
                }
            };
            reduced.push((path.clone(), one));
        }
        ReplayReduction::of_reduced(reduced, reduction)
    }

    /// [`ReplayReduction::new`] of recordings already loaded (from a
    /// library's arrays), each with the name its time record takes.
    pub fn from_loaded(
        recordings: Vec<(PathBuf, Loaded)>,
        reduction: &ReductionOptions,
    ) -> Result<ReplayReduction> {
        let mut reduced = Vec::with_capacity(recordings.len());
        for (path, loaded) in recordings {
            let at = |e| Error::context(format!("reducing {}", path.display()), e);
            let red = reduce(&loaded, reduction).map_err(at)?;
            reduced.push((path, (red, HeldRecording::of_loaded(loaded)?)));
        }
        ReplayReduction::of_reduced(reduced, reduction)
    }

    fn of_reduced(
        recordings: Vec<(PathBuf, (Reduced, HeldRecording))>,
        reduction: &ReductionOptions,
    ) -> Result<ReplayReduction> {
        let mut sources = Vec::with_capacity(recordings.len());
        let mut sets = Vec::with_capacity(recordings.len());
        for (path, (red, held)) in recordings {
            let options = ReductionOptions {
                excitation: Some(red.excitation),
                compensation: match red.sweep {
                    Some(SweptReading {
                        compensation_s: Some(s),
                        ..
                    }) => Compensation::Seconds(s),
                    Some(_) => Compensation::Off,
                    None => reduction.compensation,
                },
                // a replay is read at the measured recording's hop
                hop_periods: red.sweep.map_or(reduction.hop_periods, |s| s.hop_periods),
                ..reduction.clone()
            };
            sets.push((path.clone(), red.frf));
            sources.push(ReplaySource {
                path,
                meta: held.meta,
                response: held.response,
                truncated: held.truncated,
                options,
                held: Some(held.channels),
            });
        }
        Ok(ReplayReduction {
            measured: combine_recordings(&sets)?,
            sources,
        })
    }

    /// The measured FRFs, as [`reduce_recordings`] combines them.
    pub fn measured(&self) -> &NonlinearFrf {
        &self.measured
    }

    /// The held recordings as the time-domain fit takes them (as
    /// [`super::time_records`] reads them, without reading them again). The
    /// samples move to the records (a long recording's channels are the
    /// largest thing a time-domain diagnosis holds): the replays' reduction
    /// takes the references from them ([`ReplayReduction::replayed`]). Once
    /// only: a second call errors.
    pub fn take_time_records(
        &mut self,
        band_hz: Option<(f64, f64)>,
    ) -> Result<Vec<crate::fit::TimeRecord>> {
        self.sources
            .iter_mut()
            .map(|s| {
                let name = s.path.display().to_string();
                let Some(mut channels) = s.held.take() else {
                    return Err(Error::input(
                        format!("{name}: time records"),
                        "its samples were taken by an earlier call",
                    ));
                };
                let reference = s.meta.reference_channel().expect("checked when read");
                let measured = if s.response == reference {
                    channels[reference].clone()
                } else {
                    std::mem::replace(&mut channels[s.response], Vec::<f64>::new().into())
                };
                let reference_samples =
                    std::mem::replace(&mut channels[reference], Vec::<f64>::new().into());
                crate::fit::TimeRecord::from_held(
                    &name,
                    &s.meta,
                    s.response,
                    (reference_samples, measured),
                    None,
                    band_hz,
                )
            })
            .collect()
    }

    /// Checks that `record` is source `s`'s time record.
    fn check_record(
        s: &ReplaySource,
        record: &crate::fit::TimeRecord,
        samples: usize,
    ) -> Result<()> {
        let frames = record.reference.len();
        if record.name != s.path.display().to_string() || samples != frames {
            return Err(Error::input(
                format!("{}: replay", s.path.display()),
                format!(
                    "{samples} samples for the {frames} frames of the time record {}",
                    record.name
                ),
            ));
        }
        Ok(())
    }

    /// The options source `s`'s replay is reduced with (its excitation
    /// settled when the measured recording was reduced: not searched for
    /// again), and whether its dwells are stated (then a replay is reduced
    /// a dwell at a time as it is made, whatever order they are stated in).
    fn replay_options(s: &ReplaySource) -> (ReductionOptions, bool) {
        let options = ReductionOptions {
            excitation: Some(excitation_of(&s.meta, s.options.excitation)),
            ..s.options.clone()
        };
        let steps = &s.meta.excitation.steps;
        let by_dwell = options.excitation == Some(Excitation::Stepped)
            && !steps.is_empty()
            && s.meta.channels.len() == 2
            && s.meta.reference_channel().is_some_and(|r| r != s.response);
        (options, by_dwell)
    }

    /// The FRFs of `responses` (one per recording, in order, every sample:
    /// a model's replay, or any response to those references) reduced as
    /// the measured ones were, each recording's reference taken from its
    /// time record in `records` (the same recordings, in order:
    /// [`ReplayReduction::take_time_records`] moved the samples there).
    pub fn replayed(
        &self,
        records: &[crate::fit::TimeRecord],
        responses: Vec<Vec<f64>>,
    ) -> Result<NonlinearFrf> {
        self.check_counts(records.len(), responses.len())?;
        let mut sets = Vec::with_capacity(responses.len());
        for ((s, record), response) in self.sources.iter().zip(records).zip(responses) {
            Self::check_record(s, record, response.len())?;
            sets.push((s.path.clone(), Self::reduce_whole(s, record, response)?));
        }
        combine_recordings(&sets)
    }

    /// [`ReplayReduction::replayed`] of `model`'s replays of `problem`'s
    /// records (these recordings, in order), each reduced a dwell at a time
    /// as it is made where its dwells are stated (no replay held whole: the
    /// same FRFs to the bit), else replayed whole and reduced.
    pub fn replayed_as_made(
        &self,
        problem: &crate::fit::time::TimeProblem,
        model: &crate::model::Model,
    ) -> Result<NonlinearFrf> {
        let records = problem.records();
        self.check_counts(records.len(), records.len())?;
        let mut sets = Vec::with_capacity(records.len());
        for (i, (s, record)) in self.sources.iter().zip(records).enumerate() {
            let at = |e| Error::context(format!("reducing the replay of {}", s.path.display()), e);
            let (options, by_dwell) = Self::replay_options(s);
            let frf = if by_dwell {
                Self::check_record(s, record, record.response.len())?;
                let reference = s.meta.reference_channel().expect("checked");
                let mut frames = crate::validate::ReplayBeside::new(
                    &s.meta,
                    (reference, s.response),
                    record.reference.view(),
                    problem.replay_of(model, i)?,
                    &crate::observe::Silent,
                )?;
                let stepped = ReduceOptions {
                    reference_channel: Some(reference),
                    ..stepped_options(&options)
                };
                reduce_stepped_stream(&mut frames, s.response, &stepped)
                    .map_err(at)?
                    .frf
            } else {
                let response = problem.replay(model, i)?;
                Self::check_record(s, record, response.len())?;
                Self::reduce_whole(s, record, response)?
            };
            sets.push((s.path.clone(), frf));
        }
        combine_recordings(&sets)
    }

    fn check_counts(&self, records: usize, responses: usize) -> Result<()> {
        for (what, n) in [("replays", responses), ("time records", records)] {
            if n != self.sources.len() {
                return Err(Error::input(
                    what,
                    format!("{n} given for {} recordings", self.sources.len()),
                ));
            }
        }
        Ok(())
    }

    /// Source `s`'s `response` reduced as its measured response was,
    /// beside the reference its time record `record` holds.
    fn reduce_whole(
        s: &ReplaySource,
        record: &crate::fit::TimeRecord,
        response: Vec<f64>,
    ) -> Result<NonlinearFrf> {
        let at = |e| Error::context(format!("reducing the replay of {}", s.path.display()), e);
        let (options, by_dwell) = Self::replay_options(s);
        let reference = s.meta.reference_channel();
        let frames = response.len();
        // a stepped sine whose steps are stated is read a dwell at a time
        // from the record's reference as it holds it and the response (no
        // copy of the reference; the same FRFs as reduced whole)
        if let (true, Some(reference)) = (by_dwell, reference) {
            let mut channels: Vec<SamplesView> = vec![SamplesView::Exact(&[]); 2];
            channels[reference] = record.reference.view();
            channels[s.response] = (&response).into();
            if channels.iter().all(|c| c.len() == frames) {
                let mut source = crate::signals::InMemoryFrames::of_channels(
                    &s.meta,
                    channels,
                    format!("the replay of {}", s.path.display()),
                );
                let stepped = ReduceOptions {
                    reference_channel: Some(reference),
                    ..stepped_options(&options)
                };
                let red = reduce_stepped_stream(&mut source, s.response, &stepped).map_err(at)?;
                return Ok(red.frf);
            }
        }
        // the response taken over, the reference copied from the record
        let mut response = Some(response);
        let replay = Loaded {
            recording: Recording {
                meta: s.meta.clone(),
                channels: (0..s.meta.channels.len())
                    .map(|c| {
                        if c == s.response {
                            response.take().unwrap_or_default()
                        } else if Some(c) == reference {
                            record.reference.values().into_owned()
                        } else {
                            Vec::new()
                        }
                    })
                    .collect(),
            },
            response: s.response,
            truth: None,
            truncated: s.truncated,
        };
        Ok(reduce(&replay, &options).map_err(at)?.frf)
    }
}

/// Keeps the points inside `band` (all when `None`), dropping emptied levels.
pub fn band_limited(frf: &NonlinearFrf, band: Option<(f64, f64)>) -> NonlinearFrf {
    let mut out = frf.clone();
    if let Some((lo, hi)) = band {
        for l in &mut out.levels {
            l.points
                .retain(|p| p.frequency_hz >= lo && p.frequency_hz <= hi);
        }
        out.levels.retain(|l| !l.points.is_empty());
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::record::{Excitation as Sidecar, Step};

    /// Arrays as a recording: a stepped sine through the linear SDOF is
    /// reduced on its steps; bad arrays are errors that name them.
    #[test]
    fn signals_in_memory_reduce_as_a_recording() {
        let model = crate::model::Model::new(
            crate::model::ModalModel::sdof(10.0, 200.0, 1e7).unwrap(),
            Vec::new(),
        )
        .unwrap();
        let fs = 10_000.0;
        let (f, n) = (200.0, 20_000);
        let force: Vec<f64> = (0..n)
            .map(|i| 100.0 * (2.0 * std::f64::consts::PI * f * i as f64 / fs).cos())
            .collect();
        let x = crate::sim::simulate(&model, &force, fs, crate::sim::Output::Displacement).unwrap();
        let steps = vec![Step {
            frequency_hz: f,
            level: 100.0,
            start: 0,
            settle: 15_000,
            length: n,
        }];
        let excitation = Sidecar {
            kind: ExcitationKind::SteppedSine,
            steps,
            sweep: None,
        };
        let loaded = Loaded::from_signals(
            force.clone(),
            Quantity::Force,
            x.clone(),
            Quantity::Displacement,
            fs,
            excitation.clone(),
        )
        .unwrap();
        let red = reduce(&loaded, &ReductionOptions::default()).unwrap();
        assert_eq!(red.response_name, "displacement");
        let p = &red.frf.levels[0].points[0];
        let w = crate::harmonics::omega(f);
        let exact =
            model.linear.frf(Quantity::Displacement, w) * crate::harmonics::sinc(f / fs).powi(2);
        // the ramp-invariant filter's steady state, to its aliases (< 1e-6)
        assert!(
            (p.h[1] / exact - 1.0).norm() < 1e-6,
            "{} vs {exact}",
            p.h[1]
        );
        let err = |r: Result<Loaded>| r.err().unwrap().to_string();
        let mk = |a: Vec<f64>, qa, b: Vec<f64>, qb, fs| {
            Loaded::from_signals(a, qa, b, qb, fs, excitation.clone())
        };
        let d = Quantity::Displacement;
        assert!(
            err(mk(force.clone(), Quantity::Force, x[1..].to_vec(), d, fs))
                .contains("same, non-zero length")
        );
        assert!(err(mk(x.clone(), d, x.clone(), d, fs)).contains("a force or a voltage"));
        assert!(
            err(mk(
                force.clone(),
                Quantity::Force,
                force.clone(),
                Quantity::Force,
                fs
            ))
            .contains("must be a motion")
        );
        let mut bad = x.clone();
        bad[7] = f64::NAN;
        assert!(err(mk(force.clone(), Quantity::Force, bad, d, fs)).contains("response[7]"));
        assert!(err(mk(vec![0.0; n], Quantity::Force, x.clone(), d, fs)).contains("flat"));
        assert!(err(mk(force, Quantity::Force, x, d, 0.0)).contains("sample_rate_hz"));
    }
}
