//! MCAP run files: everything a virtual or real test produced, in one
//! self-describing, Foxglove-viewable file (crates notes §3.3).
//!
//! Topics:
//! * `/hystid/signals`: full-rate samples in blocks of at most
//!   [`SIGNAL_BLOCK_FRAMES`], ROS 2 CDR `hystid_msgs/msg/SignalBlock`
//!   (`uint32 step, uint64 first_frame, float64 t0, float64 fs, float32[]
//!   force, displacement, velocity, acceleration`), logged at the block's
//!   first frame;
//! * `/hystid/preview`: every `ceil(fs / 1 kHz)`-th frame as a JSON object of
//!   scalars, for Foxglove's time-series plots;
//! * `/hystid/dwell`: one JSON object per dwell;
//! * `/hystid/fit`: one JSON object per optimiser iteration.
//!
//! A metadata record `run` (tool version, seed, sample rate, channels and
//! free metadata) and an attachment `test.toml` (the test definition) make the
//! file self-contained. Log times are integer nanoseconds computed from frame
//! indices, messages are written in log-time order, chunks are
//! zstd-compressed on a fixed number of threads so that equal inputs give
//! byte-identical files. The reader scans the file linearly, checking every
//! chunk's CRC before using it, and recovers a file cut short by a crash up
//! to its last complete chunk.

mod read;
mod write;

pub use read::{McapRun, read_run, read_run_bytes};
pub(super) use read::{RunScanner, Scanned, Stretch, read_run_layout};
pub use write::McapRecorder;

use super::Channel;
use super::cdr;
use crate::error::{Error, Result};
use crate::harmonics::Quantity;
use mcap::McapError;
use std::collections::BTreeMap;
use std::path::Path;

/// Topic of the full-rate signal blocks.
pub const TOPIC_SIGNALS: &str = "/hystid/signals";
/// Topic of the decimated per-sample preview.
pub const TOPIC_PREVIEW: &str = "/hystid/preview";
/// Topic of the per-dwell messages.
pub const TOPIC_DWELL: &str = "/hystid/dwell";
/// Topic of the per-iteration fit messages.
pub const TOPIC_FIT: &str = "/hystid/fit";
/// Most frames in one `/hystid/signals` message.
pub const SIGNAL_BLOCK_FRAMES: usize = 4096;
/// Name of the run metadata record.
pub const RUN_METADATA: &str = "run";
/// Name of the attachment holding the test definition.
pub const TEST_ATTACHMENT: &str = "test.toml";
/// Value of the `format` key of the run metadata.
pub const RUN_FORMAT: &str = "hystid.run.v1";

/// The signal arrays of a block (see [`cdr::ARRAY_NAMES`]).
const SLOTS: usize = cdr::ARRAYS;
/// The slot of a force gauge's channel beside a voltage reference.
const GAUGE: usize = 4;
/// Keys of the `run` metadata record that are not free metadata.
const RESERVED_KEYS: [&str; 5] = [
    "format",
    "tool_version",
    "seed",
    "sample_rate_hz",
    "channels",
];

/// What a run is, written once at the start of its MCAP file.
#[derive(Clone, Debug, PartialEq)]
pub struct RunInfo {
    /// Version of the tool that ran the test.
    pub tool_version: String,
    /// The test definition (TOML text), stored as the `test.toml` attachment.
    pub test_definition: String,
    /// Seed of the run's random numbers (noise).
    pub seed: u64,
    /// Sample rate, Hz.
    pub sample_rate_hz: f64,
    /// The recorded channels: the reference (one `force`, or one `voltage`
    /// driving a shaker, beside which one `force` may be a gauge's) and at
    /// most one each of `displacement`, `velocity`, `acceleration`, with SI
    /// units. Samples are stored in physical units, so `scale` is not used
    /// (read back as 1).
    pub channels: Vec<Channel>,
    /// Free metadata (must not use the keys `format`, `tool_version`, `seed`,
    /// `sample_rate_hz`, `channels`).
    pub metadata: BTreeMap<String, String>,
}

fn mcap_error(path: &Path, e: McapError) -> Error {
    match e {
        McapError::Io(e) => Error::io(path, e),
        e => Error::format(path, "MCAP", e.to_string()),
    }
}

/// Index of a recordable quantity in a signal block: the reference's slot
/// holds a force, or the voltage driving a shaker, beside which a force is a
/// gauge's.
fn slot(q: Quantity, beside_voltage: bool) -> usize {
    match q {
        Quantity::Voltage => 0,
        Quantity::Force if beside_voltage => GAUGE,
        Quantity::Force => 0,
        Quantity::Displacement => 1,
        Quantity::Velocity => 2,
        Quantity::Acceleration => 3,
    }
}

/// Each of `channels`' slot in a signal block.
fn channel_slots(channels: &[Channel]) -> Vec<usize> {
    let voltage = channels.iter().any(|c| c.quantity == Quantity::Voltage);
    channels.iter().map(|c| slot(c.quantity, voltage)).collect()
}

/// Each of a run's channels' slot in a signal block.
pub(super) fn checked_slots(info: &RunInfo) -> Vec<usize> {
    channel_slots(&info.channels)
}

fn check_info(info: &RunInfo) -> Result<[Option<usize>; SLOTS]> {
    let fs = info.sample_rate_hz;
    if !(fs.is_finite() && fs > 0.0) {
        return Err(Error::input(
            "run sample_rate_hz",
            format!("expected a finite rate > 0, got {fs}"),
        ));
    }
    let mut by_slot = [None; SLOTS];
    let mut names = std::collections::HashSet::new();
    let slots = channel_slots(&info.channels);
    for (i, ch) in info.channels.iter().enumerate() {
        let what = format!("run channels[{i}]");
        let s = slots[i];
        if by_slot[s].replace(i).is_some() {
            return Err(Error::input(
                &what,
                format!(
                    "a second {} channel; at most one of each (one reference, force or \
                     voltage, and beside a voltage one force)",
                    ch.quantity
                ),
            ));
        }
        if ch.unit != ch.quantity.si_unit() {
            return Err(Error::input(
                format!("{what}.unit"),
                format!(
                    "`{}` does not match {}: expected `{}`",
                    ch.unit,
                    ch.quantity,
                    ch.quantity.si_unit()
                ),
            ));
        }
        if ch.name.is_empty() || !names.insert(ch.name.as_str()) {
            return Err(Error::input(
                format!("{what}.name"),
                format!("`{}`: names must be non-empty and unique", ch.name),
            ));
        }
    }
    if by_slot[0].is_none() {
        // (a force alone is the reference, so this is a run without either)
        return Err(Error::input(
            "run channels",
            "a force or voltage channel is required (the reference)",
        ));
    }
    if let Some(k) = info
        .metadata
        .keys()
        .find(|k| RESERVED_KEYS.contains(&k.as_str()))
    {
        return Err(Error::input(
            format!("run metadata `{k}`"),
            "this key is reserved for the run record itself",
        ));
    }
    Ok(by_slot)
}

/// Consecutive samples of one dwell, as read back.
#[derive(Clone, Debug, PartialEq)]
pub struct StepSignals {
    /// The step (dwell) number given to [`McapRecorder::write_signals`].
    pub step: u32,
    /// Frame index of the first sample.
    pub first_frame: u64,
    /// Force, N (f32 precision).
    pub force: Vec<f64>,
    /// Displacement, m; empty if not recorded.
    pub displacement: Vec<f64>,
    /// Velocity, m/s; empty if not recorded.
    pub velocity: Vec<f64>,
    /// Acceleration, m/s²; empty if not recorded.
    pub acceleration: Vec<f64>,
    /// A force gauge's force beside a voltage reference, N; empty if not
    /// recorded.
    pub gauge_force: Vec<f64>,
}

impl StepSignals {
    /// Frames held.
    pub fn frames(&self) -> usize {
        self.force.len()
    }

    fn array(&self, s: usize) -> &Vec<f64> {
        [
            &self.force,
            &self.displacement,
            &self.velocity,
            &self.acceleration,
            &self.gauge_force,
        ][s]
    }

    fn array_mut(&mut self, s: usize) -> &mut Vec<f64> {
        match s {
            0 => &mut self.force,
            1 => &mut self.displacement,
            2 => &mut self.velocity,
            3 => &mut self.acceleration,
            _ => &mut self.gauge_force,
        }
    }
}
