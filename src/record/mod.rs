//! Recordings: the WAV + JSON interchange format and MCAP run files.
//!
//! A [`Recording`] is a multi-channel sampled measurement plus what its
//! samples mean (`../shared/spec/recording-format.md`, "hystid.recording.v1"):
//! channel quantities, units and calibration, and the excitation (stepped-sine
//! dwells or a sweep). Virtual tests write one; `import` converts real data
//! into one; `extract` reduces one into nonlinear FRFs.
//!
//! * [`read_recording`] / [`write_recording`]: the WAV + JSON pair (float 32
//!   or integer PCM 16/24/32), validated field by field; [`RecordingReader`]
//!   streams a file of any size block by block.
//! * [`McapRecorder`] / [`read_run`]: a run's full record in one MCAP file
//!   (signal blocks in ROS 2 CDR, a decimated preview, dwell and fit messages,
//!   the test definition), viewable in Foxglove and readable by the official
//!   MCAP libraries; [`McapRun::to_recording`] turns it back into a
//!   [`Recording`].
//!
//! This module only serialises: it knows nothing of benches or analysis.

use crate::harmonics::Quantity;
use serde::{Deserialize, Serialize};

mod cdr;
mod run;
mod sidecar;
mod wav;

pub use run::{
    McapRecorder, McapRun, RUN_FORMAT, RUN_METADATA, RunInfo, SIGNAL_BLOCK_FRAMES, StepSignals,
    TEST_ATTACHMENT, TOPIC_DWELL, TOPIC_FIT, TOPIC_PREVIEW, TOPIC_SIGNALS, read_run,
};
pub use wav::{RecordingReader, RecordingWriter, SampleFormat, read_recording, write_recording};

/// The format tag of recording format v1.
pub const FORMAT_V1: &str = "hystid.recording.v1";

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
    /// Exactly [`FORMAT_V1`].
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

    /// Index of the reference (input) channel: the first `force` channel, else
    /// the first `voltage` channel.
    pub fn reference_channel(&self) -> Option<usize> {
        let q = |want| self.meta.channels.iter().position(|c| c.quantity == want);
        q(Quantity::Force).or_else(|| q(Quantity::Voltage))
    }

    /// Index of a channel by name.
    pub fn channel_index(&self, name: &str) -> Option<usize> {
        self.meta.channels.iter().position(|c| c.name == name)
    }

    /// The default response channel: the first channel that is not the
    /// reference.
    pub fn default_response_channel(&self) -> Option<usize> {
        let r = self.reference_channel();
        (0..self.meta.channels.len()).find(|&i| Some(i) != r)
    }
}

/// Index of the first sample whose magnitude is not `<= limit` (NaN, ±Inf or
/// beyond the limit). Checks blocks without branching so the common all-good
/// case vectorises; only a bad block is searched sample by sample.
pub(crate) fn first_out_of_range(x: &[f64], limit: f64) -> Option<usize> {
    const BLOCK: usize = 256;
    for (k, block) in x.chunks(BLOCK).enumerate() {
        if !block.iter().fold(true, |ok, v| ok & (v.abs() <= limit)) {
            return block
                .iter()
                .position(|v| !(v.abs() <= limit))
                .map(|i| k * BLOCK + i);
        }
    }
    None
}
