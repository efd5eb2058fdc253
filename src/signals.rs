//! A recording in memory: channels of samples and what they mean.
//!
//! The content of "hystid.recording.v1" (`../shared/spec/recording-format.md`)
//! without the files: [`record`](crate::record) reads and writes these types
//! (and re-exports them), and [`extract`](crate::extract) reduces them
//! without knowing the format. [`FrameSource`] is a recording too large to
//! hold, read a stretch of frames at a time.

use crate::error::{Error, Result};
use crate::harmonics::Quantity;
use serde::{Deserialize, Serialize};

/// One channel's meaning.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Channel {
    /// Unique name.
    pub name: String,
    /// Physical quantity.
    pub quantity: Quantity,
    /// SI unit text (`N`, `m`, `m/s`, `m/s^2`, `V`).
    pub unit: String,
    /// Physical value = stored sample value × scale.
    #[serde(default = "one")]
    pub scale: f64,
}

fn one() -> f64 {
    1.0
}

/// One stepped-sine dwell.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Step {
    /// Excitation frequency, Hz.
    pub frequency_hz: f64,
    /// Nominal amplitude in the reference channel's unit.
    pub level: f64,
    /// First frame of the dwell.
    pub start: usize,
    /// Transient frames at the dwell's start, not to be analysed.
    #[serde(default)]
    pub settle: usize,
    /// Frames in the dwell, settle included.
    pub length: usize,
}

/// A sweep's known parameters.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Sweep {
    /// Start frequency, Hz.
    pub f_start_hz: f64,
    /// End frequency, Hz.
    pub f_end_hz: f64,
    /// Rate, Hz/s (negative for a down-sweep), if known.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub rate_hz_per_s: Option<f64>,
}

/// What drove the structure.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum ExcitationKind {
    /// Dwells at fixed frequencies.
    SteppedSine,
    /// A continuous sweep.
    SweptSine,
    /// Not stated.
    #[default]
    Unknown,
}

/// The excitation section of the sidecar.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Excitation {
    /// Kind.
    #[serde(default)]
    pub kind: ExcitationKind,
    /// Dwells, in time order (stepped sine).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub steps: Vec<Step>,
    /// Sweep parameters (swept sine).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub sweep: Option<Sweep>,
}

/// The JSON sidecar: everything but the samples.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct RecordingMeta {
    /// Exactly [`FORMAT_V1`](crate::record::FORMAT_V1) in a file.
    pub format: String,
    /// Sample rate, Hz (equals the WAV header's).
    pub sample_rate_hz: f64,
    /// One per WAV channel, in WAV order.
    pub channels: Vec<Channel>,
    /// The excitation.
    #[serde(default)]
    pub excitation: Excitation,
    /// Free text.
    #[serde(default)]
    pub description: String,
    /// Free-form metadata.
    #[serde(default)]
    pub metadata: serde_json::Map<String, serde_json::Value>,
    /// Unknown keys, preserved when the file is rewritten.
    #[serde(flatten)]
    pub extra: serde_json::Map<String, serde_json::Value>,
    /// The reference channel the user chose in place of the format's rule
    /// (an analysis's choice, never written to a file).
    #[serde(skip)]
    pub chosen_reference: Option<usize>,
}

impl RecordingMeta {
    /// Index of the reference (input) channel: the one chosen
    /// ([`RecordingMeta::choose_reference`]), else the first `force`
    /// channel, else the first `voltage` channel.
    pub fn reference_channel(&self) -> Option<usize> {
        let q = |want| self.channels.iter().position(|c| c.quantity == want);
        self.chosen_reference
            .or_else(|| q(Quantity::Force).or_else(|| q(Quantity::Voltage)))
    }

    /// Makes the channel `name` the reference: a voltage beside a force
    /// gauge, say, to analyse the whole drive (amplifier, shaker and
    /// structure) rather than the structure the gauge sees. `source` names
    /// the file in errors.
    ///
    /// Errors: no channel of that name, or one that is not a force or a
    /// voltage.
    pub fn choose_reference(&mut self, source: &str, name: &str) -> Result<usize> {
        let names = || {
            self.channels
                .iter()
                .map(|c| c.name.as_str())
                .collect::<Vec<_>>()
        };
        let i = self
            .channels
            .iter()
            .position(|c| c.name == name)
            .ok_or_else(|| {
                Error::format(
                    source,
                    "channels",
                    format!(
                        "no channel `{name}` to use as the reference (channels: {:?})",
                        names()
                    ),
                )
            })?;
        let q = self.channels[i].quantity;
        if !matches!(q, Quantity::Force | Quantity::Voltage) {
            return Err(Error::format(
                source,
                "channels",
                format!("the reference `{name}` is a {q}: a reference is a force or a voltage"),
            ));
        }
        self.chosen_reference = Some(i);
        Ok(i)
    }
}

/// A recording in memory: the sidecar and each channel's samples in physical
/// units (scale applied).
#[derive(Clone, Debug, PartialEq)]
pub struct Recording {
    /// What the samples mean.
    pub meta: RecordingMeta,
    /// `channels[c][frame]`, physical units.
    pub channels: Vec<Vec<f64>>,
}

impl Recording {
    /// Number of frames.
    pub fn frames(&self) -> usize {
        self.channels.first().map_or(0, Vec::len)
    }

    /// Index of the reference (input) channel
    /// ([`RecordingMeta::reference_channel`]).
    pub fn reference_channel(&self) -> Option<usize> {
        self.meta.reference_channel()
    }

    /// Index of a channel by name.
    pub fn channel_index(&self, name: &str) -> Option<usize> {
        self.meta.channels.iter().position(|c| c.name == name)
    }

    /// The default response channel: the first channel that is not the
    /// reference, passing over the drive's other channels (the voltage
    /// beside a force gauge's force) to the first motion when there is one.
    pub fn default_response_channel(&self) -> Option<usize> {
        let r = self.reference_channel();
        let others = || (0..self.meta.channels.len()).filter(move |&i| Some(i) != r);
        others()
            .find(|&i| self.meta.channels[i].quantity.is_motion())
            .or_else(|| others().next())
    }
}

/// A recording read one stretch of frames at a time (a file larger than
/// memory), for reductions that need one dwell at a time.
pub trait FrameSource {
    /// What the samples mean.
    fn meta(&self) -> &RecordingMeta;

    /// Frames in the recording.
    fn frames(&self) -> usize;

    /// Where the frames come from (a file name), for error messages.
    fn source_name(&self) -> String;

    /// Reads up to `count` frames from frame `start` into `out[c]`, one
    /// vector per channel in physical units (cleared first), and returns
    /// how many were read (fewer only at the end).
    ///
    /// Errors: `start` beyond the end, or the read fails.
    fn read_at(&mut self, start: usize, count: usize, out: &mut [Vec<f64>]) -> Result<usize>;
}

/// A recording in memory read as a file is ([`FrameSource`]), for the stages
/// that read one a stretch at a time (the coil's fit from arrays a binding
/// hands over, say).
pub struct InMemoryFrames<'a> {
    recording: &'a Recording,
    name: String,
}

impl<'a> InMemoryFrames<'a> {
    /// `recording`, named `name` in errors.
    pub fn new(recording: &'a Recording, name: impl Into<String>) -> InMemoryFrames<'a> {
        InMemoryFrames {
            recording,
            name: name.into(),
        }
    }
}

impl FrameSource for InMemoryFrames<'_> {
    fn meta(&self) -> &RecordingMeta {
        &self.recording.meta
    }
    fn frames(&self) -> usize {
        self.recording.frames()
    }
    fn source_name(&self) -> String {
        self.name.clone()
    }
    fn read_at(&mut self, start: usize, count: usize, out: &mut [Vec<f64>]) -> Result<usize> {
        let frames = self.frames();
        if start > frames {
            return Err(crate::error::Error::input(
                &self.name,
                format!("frame {start} is beyond its {frames} frames"),
            ));
        }
        let end = start.saturating_add(count).min(frames);
        for (o, c) in out.iter_mut().zip(&self.recording.channels) {
            o.clear();
            o.extend_from_slice(&c[start..end]);
        }
        Ok(end - start)
    }
}
