//! Recordings on disk loaded: an MCAP run file or WAV + JSON, the response and
//! reference channels chosen, the virtual test's definition read.

use crate::error::{Error, Result};
use crate::harmonics::Quantity;
use crate::record::{ExcitationKind, FrameSource, Recording, RecordingMeta};
use crate::signals::{RecordingView, SAMPLES_HELD_IN_MEMORY, SamplesBuilder};
use crate::testbench::TestDefinition;
use std::path::Path;

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
pub(super) fn recorded_truth(meta: &RecordingMeta) -> Option<String> {
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

pub(super) fn is_mcap(path: &Path) -> bool {
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
pub(super) const LOAD_STRETCH: usize = 1 << 16;

/// How a loader keeps a channel's samples as it reads them.
pub(super) trait Keep {
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
    crate::fit::TimeRecord::from_channels(
        &path.display().to_string(),
        &kept.meta,
        kept.response,
        (reference_samples, response),
        window,
        band_hz,
    )
}

/// The error for a reference channel `name` of `path` that is all zero.
pub(super) fn flat_reference(path: &Path, name: &str) -> Error {
    Error::format(
        path,
        name,
        "the reference channel is flat (all zero): nothing drove the structure",
    )
}
