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

use super::cdr;
use super::{Channel, Excitation, ExcitationKind, FORMAT_V1, Recording, RecordingMeta, Step};
use crate::atomic::PendingFile;
use crate::error::{Error, Result};
use crate::harmonics::Quantity;
use mcap::McapError;
use mcap::records::{MessageHeader, Metadata};
use mcap::sans_io::{LinearReadEvent, LinearReader, LinearReaderOptions};
use serde::Serialize;
use serde_json::Value;
use std::borrow::Cow;
use std::collections::{BTreeMap, HashMap};
use std::fs::File;
use std::io::{BufWriter, Read};
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

/// Uncompressed chunk size target: bounds writer memory and what a crash
/// can lose.
const CHUNK_BYTES: u64 = 4 << 20;
/// Single-threaded zstd: its output does not depend on the host's CPU count
/// (the crate's default does), and on noisy samples it is also faster than
/// one worker thread (the worker's locking costs more than the overlap
/// gains).
const ZSTD_THREADS: u32 = 0;
/// zstd level 1: noisy float32 samples barely compress (level 3 saves
/// 3.5 % of the file but costs a third of the write rate).
const ZSTD_LEVEL: u32 = 1;
/// Target rate of the preview topic, Hz.
const PREVIEW_HZ: f64 = 1000.0;

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

/// Sample clock: frame index to log time in integer nanoseconds.
#[derive(Clone, Copy, Debug)]
struct Clock {
    fs: f64,
    /// The rate as an integer, when it is one: then times are exact
    /// `floor(frame * 1e9 / fs)`.
    whole: Option<u128>,
}

impl Clock {
    fn new(fs: f64) -> Self {
        let whole = (fs.fract() == 0.0 && fs <= 9.0e15).then_some(fs as u128);
        Clock { fs, whole }
    }
    fn ns(self, frame: u64) -> u64 {
        match self.whole {
            Some(f) => (frame as u128 * 1_000_000_000 / f) as u64,
            // One product and one quotient of the frame index, both
            // monotonic: no accumulated error, never out of order.
            None => (frame as f64 * 1e9 / self.fs).round() as u64,
        }
    }
}

/// The scalars of one preview message.
#[derive(Serialize)]
struct Preview {
    #[serde(skip_serializing_if = "Option::is_none")]
    force: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    displacement: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    velocity: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    acceleration: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    gauge_force: Option<f64>,
}

/// JSON schema of the preview topic.
const PREVIEW_SCHEMA: &str = r#"{"title":"hystid preview sample","type":"object","properties":{"force":{"type":"number","description":"N"},"displacement":{"type":"number","description":"m"},"velocity":{"type":"number","description":"m/s"},"acceleration":{"type":"number","description":"m/s^2"},"gauge_force":{"type":"number","description":"N"}}}"#;
/// JSON schema of the dwell topic.
const DWELL_SCHEMA: &str = r#"{"title":"hystid dwell","type":"object","properties":{"frequency_hz":{"type":"number"},"level":{"type":"number"},"start":{"type":"integer"},"settle":{"type":"integer"},"length":{"type":"integer"}}}"#;
/// JSON schema of the fit topic.
const FIT_SCHEMA: &str = r#"{"title":"hystid fit iteration","type":"object","properties":{"iteration":{"type":"integer"}}}"#;

/// Writes one run's MCAP file.
///
/// The file is written under a temporary name and renamed into place by
/// [`McapRecorder::finish`]; dropping the recorder without finishing removes
/// it.
pub struct McapRecorder {
    // Declared before `pending` so that it is dropped (and its file closed)
    // before the temporary is removed.
    writer: mcap::Writer<BufWriter<File>>,
    pending: PendingFile,
    clock: Clock,
    recorded: [bool; SLOTS],
    names: [String; SLOTS],
    /// Each channel's slot, in [`RunInfo::channels`]' order.
    slots: Vec<usize>,
    decimation: u64,
    ids: [u16; 4],
    sequences: [u32; 4],
    last_log_time: u64,
    signals_end: u64,
    buf: Vec<u8>,
}

impl std::fmt::Debug for McapRecorder {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("McapRecorder")
            .field("path", &self.pending.path())
            .field("last_log_time", &self.last_log_time)
            .finish_non_exhaustive()
    }
}

const SIGNALS: usize = 0;
const PREVIEW: usize = 1;
const DWELL: usize = 2;
const FIT: usize = 3;

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

/// The `run` metadata record of `info`.
fn run_record(info: &RunInfo) -> BTreeMap<String, String> {
    #[derive(Serialize)]
    struct Ch<'a> {
        name: &'a str,
        quantity: Quantity,
        unit: &'a str,
    }
    let channels: Vec<Ch> = info
        .channels
        .iter()
        .map(|c| Ch {
            name: &c.name,
            quantity: c.quantity,
            unit: &c.unit,
        })
        .collect();
    let mut m = info.metadata.clone();
    m.insert("format".into(), RUN_FORMAT.into());
    m.insert("tool_version".into(), info.tool_version.clone());
    m.insert("seed".into(), info.seed.to_string());
    // Rust prints the shortest text that parses back to the same f64.
    m.insert("sample_rate_hz".into(), info.sample_rate_hz.to_string());
    m.insert(
        "channels".into(),
        serde_json::to_string(&channels).expect("channel list serialises"),
    );
    m
}

impl McapRecorder {
    /// Starts the run file `path` (written as a temporary until
    /// [`McapRecorder::finish`]): header, schemas, channels, the `run`
    /// metadata record and the `test.toml` attachment.
    pub fn create(path: &Path, info: &RunInfo) -> Result<Self> {
        let by_slot = check_info(info)?;
        let (pending, file) = PendingFile::create(path)?;
        let tmp = pending.temporary().to_path_buf();
        let err = |e| mcap_error(&tmp, e);
        let mut writer = mcap::WriteOptions::new()
            .compression(Some(mcap::Compression::Zstd))
            .chunk_size(Some(CHUNK_BYTES))
            .compression_threads(ZSTD_THREADS)
            .compression_level(ZSTD_LEVEL)
            .profile("")
            .create(BufWriter::with_capacity(1 << 20, file))
            .map_err(err)?;

        let units: Vec<String> = info
            .channels
            .iter()
            .map(|c| format!("{}={}", c.quantity, c.unit))
            .collect();
        let signal_meta = BTreeMap::from([("units".to_string(), units.join(" "))]);
        let s = writer
            .add_schema(
                cdr::SIGNAL_BLOCK_NAME,
                "ros2msg",
                cdr::SIGNAL_BLOCK_SCHEMA.as_bytes(),
            )
            .map_err(err)?;
        let signals = writer
            .add_channel(s, TOPIC_SIGNALS, "cdr", &signal_meta)
            .map_err(err)?;
        let mut json_channel = |name: &str, schema: &str, topic: &str| {
            let s = writer
                .add_schema(name, "jsonschema", schema.as_bytes())
                .map_err(err)?;
            writer
                .add_channel(s, topic, "json", &BTreeMap::new())
                .map_err(err)
        };
        let preview = json_channel("hystid.Preview", PREVIEW_SCHEMA, TOPIC_PREVIEW)?;
        let dwell = json_channel("hystid.Dwell", DWELL_SCHEMA, TOPIC_DWELL)?;
        let fit = json_channel("hystid.FitIteration", FIT_SCHEMA, TOPIC_FIT)?;

        writer
            .write_metadata(&Metadata {
                name: RUN_METADATA.into(),
                metadata: run_record(info),
            })
            .map_err(err)?;
        writer
            .attach(&mcap::Attachment {
                log_time: 0,
                create_time: 0,
                name: TEST_ATTACHMENT.into(),
                media_type: "application/toml".into(),
                data: Cow::Borrowed(info.test_definition.as_bytes()),
            })
            .map_err(err)?;

        let names = std::array::from_fn(|s| {
            by_slot[s].map_or_else(String::new, |i| info.channels[i].name.clone())
        });
        Ok(McapRecorder {
            writer,
            pending,
            clock: Clock::new(info.sample_rate_hz),
            recorded: by_slot.map(|s| s.is_some()),
            names,
            slots: checked_slots(info),
            decimation: (info.sample_rate_hz / PREVIEW_HZ).ceil().max(1.0) as u64,
            ids: [signals, preview, dwell, fit],
            sequences: [0; 4],
            last_log_time: 0,
            signals_end: 0,
            buf: Vec::with_capacity(16 * SIGNAL_BLOCK_FRAMES + 64),
        })
    }

    fn write(&mut self, topic: usize, log_time: u64, data: Option<&[u8]>) -> Result<()> {
        let header = MessageHeader {
            channel_id: self.ids[topic],
            sequence: self.sequences[topic],
            log_time,
            publish_time: log_time,
        };
        self.sequences[topic] = self.sequences[topic].wrapping_add(1);
        let data = data.unwrap_or(&self.buf);
        self.writer
            .write_to_known_channel(&header, data)
            .map_err(|e| mcap_error(self.pending.temporary(), e))?;
        self.last_log_time = log_time;
        Ok(())
    }

    fn check_order(&self, what: &str, log_time: u64) -> Result<()> {
        if log_time < self.last_log_time {
            return Err(Error::input(
                what,
                format!(
                    "log time {log_time} ns is before the last message written ({} ns); \
                     messages must be written in time order",
                    self.last_log_time
                ),
            ));
        }
        Ok(())
    }

    /// Writes consecutive samples of dwell `step` starting at frame
    /// `first_frame`, in physical units, as signal blocks of at most
    /// [`SIGNAL_BLOCK_FRAMES`] frames plus the decimated preview.
    ///
    /// Every slice of a recorded quantity must have `force.len()` samples,
    /// all finite and within the f32 range; slices of quantities not in
    /// [`RunInfo::channels`] are ignored (pass `&[]`). Frames must follow
    /// those already written (no overlap). A force gauge's channel beside a
    /// voltage is written by [`Self::write_channels`].
    pub fn write_signals(
        &mut self,
        step: u32,
        first_frame: u64,
        force: &[f64],
        displacement: &[f64],
        velocity: &[f64],
        acceleration: &[f64],
    ) -> Result<()> {
        self.write_arrays(
            step,
            first_frame,
            [force, displacement, velocity, acceleration, &[]],
        )
    }

    /// [`Self::write_signals`] with one slice per channel, in
    /// [`RunInfo::channels`]' order (a gauge's force included).
    pub fn write_channels(
        &mut self,
        step: u32,
        first_frame: u64,
        channels: &[&[f64]],
    ) -> Result<()> {
        if channels.len() != self.slots.len() {
            return Err(Error::input(
                format!("signals at frame {first_frame}"),
                format!(
                    "{} channels given, the run has {}",
                    channels.len(),
                    self.slots.len()
                ),
            ));
        }
        let mut arrays: [&[f64]; SLOTS] = [&[]; SLOTS];
        for (&s, &c) in self.slots.iter().zip(channels) {
            arrays[s] = c;
        }
        self.write_arrays(step, first_frame, arrays)
    }

    fn write_arrays(
        &mut self,
        step: u32,
        first_frame: u64,
        mut arrays: [&[f64]; SLOTS],
    ) -> Result<()> {
        let n = arrays[0].len();
        for (s, a) in arrays.iter_mut().enumerate() {
            if !self.recorded[s] {
                *a = &[];
                continue;
            }
            let name = &self.names[s];
            if a.len() != n {
                return Err(Error::input(
                    format!("signals `{name}` at frame {first_frame}"),
                    format!("{} samples where the reference has {n}", a.len()),
                ));
            }
            if let Some(i) = super::first_out_of_range(a, f32::MAX as f64) {
                return Err(Error::input(
                    format!("{name}[frame {}]", first_frame + i as u64),
                    format!(
                        "sample is {}; samples must be finite and within the float32 range",
                        a[i]
                    ),
                ));
            }
        }
        if n == 0 {
            return Ok(());
        }
        let end_frame = first_frame.checked_add(n as u64).ok_or_else(|| {
            Error::input(
                format!("signals at frame {first_frame}"),
                "frame index overflows",
            )
        })?;
        if first_frame < self.signals_end {
            return Err(Error::input(
                format!("signals at frame {first_frame}"),
                format!(
                    "overlap frames already written (up to {})",
                    self.signals_end
                ),
            ));
        }
        self.check_order(
            &format!("signals at frame {first_frame}"),
            self.clock.ns(first_frame),
        )?;
        let fs = self.clock.fs;
        let mut json = Vec::with_capacity(128);
        for start in (0..n).step_by(SIGNAL_BLOCK_FRAMES) {
            let end = (start + SIGNAL_BLOCK_FRAMES).min(n);
            let frame0 = first_frame + start as u64;
            let block = arrays.map(|a| if a.is_empty() { a } else { &a[start..end] });
            cdr::encode_signal_block(&mut self.buf, step, frame0, frame0 as f64 / fs, fs, block);
            self.write(SIGNALS, self.clock.ns(frame0), None)?;
            // Preview frames are multiples of the decimation in absolute
            // frame numbers, so block boundaries do not shift them.
            let d = self.decimation;
            let mut f = frame0.div_ceil(d) * d;
            while f < first_frame + end as u64 {
                let i = (f - first_frame) as usize;
                let pick = |s: usize| self.recorded[s].then(|| arrays[s][i]);
                let p = Preview {
                    force: pick(0),
                    displacement: pick(1),
                    velocity: pick(2),
                    acceleration: pick(3),
                    gauge_force: pick(GAUGE),
                };
                json.clear();
                serde_json::to_writer(&mut json, &p).expect("finite scalars serialise");
                self.write(PREVIEW, self.clock.ns(f), Some(&json))?;
                f += d;
            }
        }
        self.signals_end = end_frame;
        Ok(())
    }

    /// Writes one dwell's JSON object (expected to hold at least
    /// `frequency_hz`, `level`, `start`, `settle`, `length` for
    /// [`McapRun::to_recording`]), logged at frame `log_frame` (e.g. the
    /// dwell's last frame + 1: it must not be earlier than what is already
    /// written). Non-finite numbers become JSON `null` (serde_json).
    pub fn write_dwell(&mut self, log_frame: u64, message: &impl Serialize) -> Result<()> {
        let what = format!("dwell message at frame {log_frame}");
        let t = self.clock.ns(log_frame);
        self.check_order(&what, t)?;
        let data = serde_json::to_vec(message).map_err(|e| Error::input(&what, e.to_string()))?;
        if data.first() != Some(&b'{') {
            return Err(Error::input(&what, "expected a JSON object"));
        }
        self.write(DWELL, t, Some(&data))
    }

    /// Writes one optimiser iteration's JSON object, with the key
    /// `iteration` set to `iteration`. Fit messages are logged at the end of
    /// the signals written so far (or at the last message, if later), so
    /// they never break the time order.
    pub fn write_fit_iteration(&mut self, iteration: u64, message: &impl Serialize) -> Result<()> {
        let what = format!("fit iteration {iteration}");
        let mut value =
            serde_json::to_value(message).map_err(|e| Error::input(&what, e.to_string()))?;
        let obj = value
            .as_object_mut()
            .ok_or_else(|| Error::input(&what, "expected a JSON object"))?;
        obj.insert("iteration".into(), iteration.into());
        let data = serde_json::to_vec(&value).map_err(|e| Error::input(&what, e.to_string()))?;
        let t = self.last_log_time.max(self.clock.ns(self.signals_end));
        self.write(FIT, t, Some(&data))
    }

    /// Writes the summary and indexes, flushes, syncs and renames the file
    /// into place.
    pub fn finish(self) -> Result<()> {
        let McapRecorder {
            mut writer,
            pending,
            ..
        } = self;
        let tmp = pending.temporary().to_path_buf();
        writer.finish().map_err(|e| mcap_error(&tmp, e))?;
        let file = writer
            .into_inner()
            .into_inner()
            .map_err(|e| Error::io(&tmp, e.into_error()))?;
        file.sync_all().map_err(|e| Error::io(&tmp, e))?;
        drop(file);
        pending.commit()
    }
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

/// A run file read back.
#[derive(Clone, Debug, PartialEq)]
pub struct McapRun {
    /// The run's description (from the `run` record and `test.toml`).
    pub info: RunInfo,
    /// Signals, one entry per contiguous stretch of one step, in file order.
    pub signals: Vec<StepSignals>,
    /// `/hystid/dwell` messages, in order.
    pub dwells: Vec<Value>,
    /// `/hystid/fit` messages, in order.
    pub fit_iterations: Vec<Value>,
    /// Messages per topic (all topics, also unknown ones).
    pub message_counts: BTreeMap<String, u64>,
    /// True when the file ended early (no complete footer): everything up to
    /// the last complete chunk was recovered.
    pub truncated: bool,
}

/// Largest record the reader accepts (a guard against corrupt lengths;
/// hystid's chunks are about 4 MiB).
const RECORD_LIMIT: u64 = 1 << 30;

/// A record, or a chunk once decompressed, may be at most this many times
/// the file's size: lengths are declared, and are checked before the reader
/// allocates for them (hystid's chunks of noisy signals compress by less
/// than 2).
const RECORD_PER_FILE_BYTE: u64 = 8;

/// Reads a run file, checking every chunk's CRC (and the data and summary
/// section CRCs of a complete file).
///
/// A file without its summary/footer (a run cut short) is read up to its
/// first incomplete record and returned with `truncated: true`.
pub fn read_run(path: &Path) -> Result<McapRun> {
    let file = File::open(path).map_err(|e| Error::io(path, e))?;
    let len = file.metadata().map_err(|e| Error::io(path, e))?.len();
    read_run_from(path, file, len)
}

/// [`read_run`] on a run file already in memory; `path` names it in
/// messages.
pub fn read_run_bytes(path: &Path, bytes: &[u8]) -> Result<McapRun> {
    read_run_from(path, bytes, bytes.len() as u64)
}

/// Reads a run of `len` bytes from `file`.
fn read_run_from(path: &Path, file: impl Read, len: u64) -> Result<McapRun> {
    Ok(scan_run(path, file, len, true)?.0)
}

/// One linear pass over a run of `len` bytes: its description and the
/// layout of its signals, with their samples when `keep_samples`.
fn scan_run(
    path: &Path,
    file: impl Read,
    len: u64,
    keep_samples: bool,
) -> Result<(McapRun, Vec<Stretch>)> {
    let mut scanner = RunScanner::new(path, file, len)?;
    let mut scan = Scan {
        keep_samples,
        ..Scan::default()
    };
    let truncated = loop {
        match scanner.next(|record| scan.record(path, record))? {
            Scanned::Record => {}
            Scanned::End => break false,
            Scanned::Truncated => break true,
        }
    };
    scan.finish(path, truncated)
}

/// A run file's description and the layout of its signals, without the
/// samples (memory independent of the run's length).
pub(super) fn read_run_layout(path: &Path) -> Result<(McapRun, Vec<Stretch>)> {
    let file = File::open(path).map_err(|e| Error::io(path, e))?;
    let len = file.metadata().map_err(|e| Error::io(path, e))?.len();
    scan_run(path, file, len, false)
}

/// What [`RunScanner::next`] found.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum Scanned {
    /// A record, handed to the visitor.
    Record,
    /// The end of a complete file.
    End,
    /// The end of a file cut short.
    Truncated,
}

/// A linear pass over a run file, one record at a time, every chunk's CRC
/// checked before its records are used and every declared length bounded
/// by the file's size before anything is allocated for it.
pub(super) struct RunScanner<R> {
    path: std::path::PathBuf,
    file: R,
    len: u64,
    reader: LinearReader,
}

impl<R: Read> RunScanner<R> {
    pub(super) fn new(path: &Path, file: R, len: u64) -> Result<Self> {
        let limit = len.saturating_mul(RECORD_PER_FILE_BYTE).min(RECORD_LIMIT);
        let mut reader = LinearReader::new_with_options(
            LinearReaderOptions::default()
                .with_prevalidate_chunk_crcs(true)
                .with_validate_data_section_crc(true)
                .with_validate_summary_section_crc(true)
                .with_record_length_limit(limit as usize),
        );
        // a zstd frame's declared window is allocated on its header alone:
        // bound it by what a chunk of this file may decompress to
        reader
            .add_decompressor(super::zstd_window::BoundedZstd::new(
                super::zstd_window::window_log_for(limit),
            ))
            .map_err(|e| mcap_error(path, e))?;
        Ok(RunScanner {
            path: path.to_path_buf(),
            file,
            len,
            reader,
        })
    }

    /// Reads on to the next record and hands it to `visit`.
    pub(super) fn next(
        &mut self,
        visit: impl FnOnce(mcap::records::Record<'_>) -> Result<()>,
    ) -> Result<Scanned> {
        let path = self.path.as_path();
        let len = self.len;
        let too_large = |what: &str, n: u64| {
            Error::format(
                path,
                "MCAP",
                format!(
                    "{what} declares {n} bytes, more than {RECORD_PER_FILE_BYTE} times the file's \
                     {len} (or 1 GiB): corrupted"
                ),
            )
        };
        loop {
            let request = match self.reader.next_event() {
                None => return Ok(Scanned::End),
                Some(Ok(LinearReadEvent::ReadRequest(n))) => n,
                Some(Ok(LinearReadEvent::Record { opcode, data })) => {
                    check_lengths(path, opcode, data)?;
                    let record =
                        mcap::parse_record(opcode, data).map_err(|e| mcap_error(path, e))?;
                    visit(record)?;
                    return Ok(Scanned::Record);
                }
                Some(Err(McapError::UnexpectedEof)) => return Ok(Scanned::Truncated),
                Some(Err(McapError::RecordTooLarge { opcode, len })) => {
                    return Err(too_large(&format!("a record (opcode {opcode:#04x})"), len));
                }
                Some(Err(McapError::ChunkTooLarge(n))) => return Err(too_large("a chunk", n)),
                Some(Err(e)) => return Err(mcap_error(path, e)),
            };
            let buf = self.reader.insert(request);
            let got = read_some(&mut self.file, buf).map_err(|e| Error::io(path, e))?;
            self.reader.notify_read(got);
        }
    }
}

/// Checks that every length-prefixed string and map of a record fits in the
/// record, before `mcap::parse_record` allocates what they declare (it reads
/// a string's declared length, up to 4 GiB, before checking it). Layouts from
/// the MCAP specification; records without such fields pass.
fn check_lengths(path: &Path, opcode: u8, data: &[u8]) -> Result<()> {
    let fail = |m: String| Error::format(path, format!("MCAP record (opcode {opcode:#04x})"), m);
    enum F {
        /// Fixed-size fields, bytes.
        Skip(usize),
        /// A string: u32 length, then bytes.
        Str,
        /// A map of strings: u32 byte length, then key and value strings.
        Strings,
        /// A map or array of fixed-size entries (bytes each): u32 byte
        /// length, a whole number of entries (mcap reads whole entries, so a
        /// partial one would shift every later field).
        Entries(usize),
    }
    use F::*;
    let fields: &[F] = match opcode {
        0x01 => &[Str, Str],                            // header
        0x03 => &[Skip(2), Str, Str],                   // schema (data checked by mcap)
        0x04 => &[Skip(4), Str, Str, Strings],          // channel
        0x06 => &[Skip(28), Str],                       // chunk (records checked by mcap)
        0x07 => &[Skip(2), Entries(16)],                // message index
        0x08 => &[Skip(32), Entries(10), Skip(8), Str], // chunk index
        0x09 => &[Skip(16), Str, Str, Skip(12)],        // attachment: then data length, crc
        0x0a => &[Skip(40), Str, Str],                  // attachment index
        0x0b => &[Skip(42), Entries(10)],               // statistics
        0x0c => &[Str, Strings],                        // metadata
        0x0d => &[Skip(16), Str],                       // metadata index
        _ => &[],
    };
    let mut at = 0usize;
    let take = |at: &mut usize, n: usize, what: &str| {
        if n > data.len() - *at {
            return Err(fail(format!(
                "{what} of {n} bytes at byte {} runs past the record's {} bytes",
                *at,
                data.len()
            )));
        }
        *at += n;
        Ok(())
    };
    let prefix = |at: &mut usize, what: &str| -> Result<usize> {
        let start = *at;
        take(at, 4, what)?;
        Ok(u32::from_le_bytes(data[start..start + 4].try_into().unwrap()) as usize)
    };
    for f in fields {
        match f {
            Skip(n) => take(&mut at, *n, "a field")?,
            Str => {
                let n = prefix(&mut at, "a string's length")?;
                take(&mut at, n, "a string")?;
            }
            Entries(size) => {
                let n = prefix(&mut at, "a map's length")?;
                if n % size != 0 {
                    return Err(fail(format!(
                        "a map of {n} bytes at byte {} is not a whole number of {size}-byte entries",
                        at - 4
                    )));
                }
                take(&mut at, n, "a map")?;
            }
            Strings => {
                let n = prefix(&mut at, "a map's length")?;
                let end = at;
                take(&mut at, n, "a map")?;
                {
                    let mut k = end;
                    while k < at {
                        for what in ["a key", "a value"] {
                            let start = k;
                            if at - k < 4 {
                                return Err(fail(format!(
                                    "{what} at byte {start} runs past its map"
                                )));
                            }
                            let len =
                                u32::from_le_bytes(data[k..k + 4].try_into().unwrap()) as usize;
                            k += 4;
                            if len > at - k {
                                return Err(fail(format!(
                                    "{what} of {len} bytes at byte {start} runs past its map"
                                )));
                            }
                            k += len;
                        }
                    }
                }
            }
        }
    }
    Ok(())
}

/// Reads until `buf` is full or the file ends (0 only at the end).
fn read_some(file: &mut impl Read, buf: &mut [u8]) -> std::io::Result<usize> {
    let mut n = 0;
    while n < buf.len() {
        match file.read(&mut buf[n..]) {
            Ok(0) => break,
            Ok(k) => n += k,
            Err(e) if e.kind() == std::io::ErrorKind::Interrupted => {}
            Err(e) => return Err(e),
        }
    }
    Ok(n)
}

/// Where a stretch of consecutive frames of one step lies in a run, and
/// which arrays it carries (force, displacement, velocity, acceleration).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) struct Stretch {
    pub step: u32,
    pub first_frame: u64,
    pub frames: u64,
    pub recorded: [bool; SLOTS],
}

/// What a linear scan has collected.
#[derive(Default)]
struct Scan {
    header: bool,
    topics: HashMap<u16, String>,
    counts_by_channel: BTreeMap<u16, u64>,
    counts: BTreeMap<String, u64>,
    statistics: Option<BTreeMap<u16, u64>>,
    run: Option<BTreeMap<String, String>>,
    test_definition: Option<String>,
    /// Samples are kept in `signals` (else only `stretches` is).
    keep_samples: bool,
    signals: Vec<StepSignals>,
    stretches: Vec<Stretch>,
    /// The `fs` field of the signal blocks (all equal).
    block_fs: Option<f64>,
    dwells: Vec<Value>,
    fit: Vec<Value>,
}

impl Scan {
    fn record(&mut self, path: &Path, record: mcap::records::Record<'_>) -> Result<()> {
        use mcap::records::Record;
        match record {
            Record::Header(_) => self.header = true,
            Record::Channel(c) => {
                self.topics.insert(c.id, c.topic);
            }
            Record::Message { header, data } => {
                let topic = self
                    .topics
                    .get(&header.channel_id)
                    .ok_or_else(|| {
                        Error::format(
                            path,
                            format!("message at {} ns", header.log_time),
                            format!("refers to unknown channel {}", header.channel_id),
                        )
                    })?
                    .clone();
                *self.counts_by_channel.entry(header.channel_id).or_default() += 1;
                *self.counts.entry(topic.clone()).or_default() += 1;
                let field = || format!("{topic} message {}", header.sequence);
                match topic.as_str() {
                    TOPIC_SIGNALS => {
                        let block = cdr::decode_signal_block(&data)
                            .map_err(|m| Error::format(path, field(), m.to_string()))?;
                        self.add_block(&block, path, &field())?;
                    }
                    TOPIC_DWELL | TOPIC_FIT => {
                        let v: Value = serde_json::from_slice(&data)
                            .map_err(|e| Error::format(path, field(), e.to_string()))?;
                        if topic == TOPIC_DWELL {
                            self.dwells.push(v);
                        } else {
                            self.fit.push(v);
                        }
                    }
                    _ => {}
                }
            }
            Record::Metadata(m) if m.name == RUN_METADATA => self.run = Some(m.metadata),
            Record::Attachment { header, data, .. } if header.name == TEST_ATTACHMENT => {
                let text = String::from_utf8(data.into_owned()).map_err(|_| {
                    Error::format(path, TEST_ATTACHMENT, "the attachment is not UTF-8 text")
                })?;
                self.test_definition = Some(text);
            }
            Record::Statistics(s) => self.statistics = Some(s.channel_message_counts),
            _ => {}
        }
        Ok(())
    }

    /// Appends a block to its step's stretch, or starts a new stretch.
    /// Errors name the file and the message (`field`).
    fn add_block(&mut self, b: &cdr::SignalBlock<'_>, path: &Path, field: &str) -> Result<()> {
        let bad = |message: String| Err(Error::format(path, field, message));
        if *self.block_fs.get_or_insert(b.fs) != b.fs {
            return bad(format!(
                "sample rate {} Hz differs from earlier blocks' {} Hz",
                b.fs,
                self.block_fs.unwrap_or_default()
            ));
        }
        let n = b.len(0);
        if (1..SLOTS).any(|s| b.len(s) != 0 && b.len(s) != n) {
            let lengths: Vec<String> = (0..SLOTS)
                .map(|s| format!("{} {}", cdr::ARRAY_NAMES[s], b.len(s)))
                .collect();
            return bad(format!("arrays of unequal length: {}", lengths.join(", ")));
        }
        let recorded = std::array::from_fn(|s| b.len(s) != 0);
        let cont = self
            .stretches
            .last()
            .is_some_and(|l| l.step == b.step && l.first_frame + l.frames == b.first_frame);
        if cont {
            let last = self.stretches.last_mut().expect("just checked");
            if let Some(s) =
                (1..SLOTS).find(|&s| last.frames > 0 && last.recorded[s] != recorded[s])
            {
                return bad(format!(
                    "{} recorded in some blocks of step {} but not in others",
                    cdr::ARRAY_NAMES[s],
                    b.step
                ));
            }
            last.frames += n as u64;
        } else {
            self.stretches.push(Stretch {
                step: b.step,
                first_frame: b.first_frame,
                frames: n as u64,
                recorded,
            });
            if self.keep_samples {
                self.signals.push(StepSignals {
                    step: b.step,
                    first_frame: b.first_frame,
                    force: Vec::new(),
                    displacement: Vec::new(),
                    velocity: Vec::new(),
                    acceleration: Vec::new(),
                    gauge_force: Vec::new(),
                });
            }
        }
        if self.keep_samples {
            let last = self.signals.last_mut().expect("pushed with its stretch");
            for s in 0..SLOTS {
                b.extend(s, last.array_mut(s));
            }
        }
        Ok(())
    }

    fn finish(self, path: &Path, truncated: bool) -> Result<(McapRun, Vec<Stretch>)> {
        if !self.header {
            return Err(Error::format(
                path,
                "header",
                "not an MCAP file (no complete header record)",
            ));
        }
        let cut = if truncated {
            " (the file is truncated before it)"
        } else {
            ""
        };
        let run = self
            .run
            .ok_or_else(|| Error::format(path, "metadata record run", format!("missing{cut}")))?;
        let test_definition = self
            .test_definition
            .ok_or_else(|| Error::format(path, "attachment test.toml", format!("missing{cut}")))?;
        if let Some(stats) = &self.statistics
            && *stats != self.counts_by_channel
        {
            return Err(Error::format(
                path,
                "statistics",
                format!(
                    "message counts per channel {stats:?} differ from the messages found {:?}",
                    self.counts_by_channel
                ),
            ));
        }
        let info = parse_run_record(path, run, test_definition)?;
        if let Some(fs) = self.block_fs.filter(|&f| f != info.sample_rate_hz) {
            return Err(Error::format(
                path,
                TOPIC_SIGNALS,
                format!(
                    "blocks sampled at {fs} Hz in a run at {} Hz",
                    info.sample_rate_hz
                ),
            ));
        }
        let recorded = checked_slots(&info);
        for st in &self.stretches {
            for (s, q) in cdr::ARRAY_NAMES.iter().enumerate() {
                let has = st.recorded[s];
                if has != recorded.contains(&s) {
                    return Err(Error::format(
                        path,
                        format!(
                            "{TOPIC_SIGNALS} step {} at frame {}",
                            st.step, st.first_frame
                        ),
                        format!(
                            "{q} is {}recorded here but {}listed in the run's channels",
                            if has { "" } else { "not " },
                            if has { "not " } else { "" }
                        ),
                    ));
                }
            }
        }
        let run = McapRun {
            info,
            signals: self.signals,
            dwells: self.dwells,
            fit_iterations: self.fit,
            message_counts: self.counts,
            truncated,
        };
        Ok((run, self.stretches))
    }
}

fn parse_run_record(
    path: &Path,
    mut run: BTreeMap<String, String>,
    test_definition: String,
) -> Result<RunInfo> {
    let mut take = |key: &str| {
        run.remove(key)
            .ok_or_else(|| Error::format(path, format!("run.{key}"), "missing"))
    };
    let format = take("format")?;
    if format != RUN_FORMAT {
        return Err(Error::format(
            path,
            "run.format",
            format!("expected \"{RUN_FORMAT}\", got \"{format}\""),
        ));
    }
    let tool_version = take("tool_version")?;
    let seed = take("seed")?;
    let seed = seed.parse().map_err(|_| {
        Error::format(
            path,
            "run.seed",
            format!("expected an integer, got `{seed}`"),
        )
    })?;
    let fs = take("sample_rate_hz")?;
    let sample_rate_hz = fs
        .parse::<f64>()
        .ok()
        .filter(|f| f.is_finite() && *f > 0.0)
        .ok_or_else(|| {
            Error::format(
                path,
                "run.sample_rate_hz",
                format!("expected a rate > 0, got `{fs}`"),
            )
        })?;
    let channels = take("channels")?;
    let channels: Vec<Channel> = serde_json::from_str(&channels)
        .map_err(|e| Error::format(path, "run.channels", e.to_string()))?;
    let info = RunInfo {
        tool_version,
        test_definition,
        seed,
        sample_rate_hz,
        channels,
        metadata: run,
    };
    check_info(&info).map_err(|e| Error::format(path, "run", e.to_string()))?;
    Ok(info)
}

impl McapRun {
    /// The run as a [`Recording`]: its channels (force first as listed in
    /// [`RunInfo::channels`]) over all signal blocks, which must be
    /// contiguous, and one stepped-sine step per dwell message (keys
    /// `frequency_hz`, `level`, `start`, `length`, optional `settle`; frames
    /// counted like `first_frame`). Tool version, seed, test definition and
    /// the run's metadata go to the recording's metadata.
    pub fn to_recording(&self) -> Result<Recording> {
        let stretches: Vec<Stretch> = self
            .signals
            .iter()
            .map(|s| Stretch {
                step: s.step,
                first_frame: s.first_frame,
                frames: s.frames() as u64,
                recorded: std::array::from_fn(|k| !s.array(k).is_empty()),
            })
            .collect();
        let (meta, frames) = self.recording_meta(&stretches)?;
        let mut channels = Vec::with_capacity(self.info.channels.len());
        for s in checked_slots(&self.info) {
            let mut x = Vec::with_capacity(frames);
            for st in &self.signals {
                x.extend_from_slice(st.array(s));
            }
            channels.push(x);
        }
        Ok(Recording { meta, channels })
    }

    /// The recording's description and its frame count, for signals laid
    /// out as `stretches`, which must be contiguous (see [`Self::to_recording`]).
    pub(super) fn recording_meta(&self, stretches: &[Stretch]) -> Result<(RecordingMeta, usize)> {
        let origin = stretches.first().map_or(0, |s| s.first_frame);
        let mut end = origin;
        for s in stretches {
            if s.first_frame != end {
                return Err(Error::input(
                    format!("run signals of step {} at frame {}", s.step, s.first_frame),
                    format!("not contiguous with the previous signals, which end at frame {end}"),
                ));
            }
            end += s.frames;
        }
        let frames = (end - origin) as usize;
        let meta_channels: Vec<Channel> = self
            .info
            .channels
            .iter()
            .map(|ch| Channel {
                scale: 1.0,
                ..ch.clone()
            })
            .collect();

        let mut steps = Vec::with_capacity(self.dwells.len());
        for (i, d) in self.dwells.iter().enumerate() {
            let field = |k: &str| format!("dwell[{i}].{k}");
            let number = |k: &str| {
                d.get(k)
                    .and_then(Value::as_f64)
                    .ok_or_else(|| Error::input(field(k), "expected a number"))
            };
            let frame = |k: &str, required: bool| -> Result<usize> {
                match d.get(k) {
                    None if !required => Ok(0),
                    v => v
                        .and_then(Value::as_u64)
                        .and_then(|f| usize::try_from(f).ok())
                        .ok_or_else(|| Error::input(field(k), "expected a frame index >= 0")),
                }
            };
            let start = frame("start", true)?;
            let start = start.checked_sub(origin as usize).ok_or_else(|| {
                Error::input(
                    field("start"),
                    format!("frame {start} is before the first recorded frame {origin}"),
                )
            })?;
            steps.push(Step {
                frequency_hz: number("frequency_hz")?,
                level: number("level")?,
                start,
                settle: frame("settle", false)?,
                length: frame("length", true)?,
            });
        }

        let mut metadata = serde_json::Map::new();
        metadata.insert("tool_version".into(), self.info.tool_version.clone().into());
        metadata.insert("seed".into(), self.info.seed.into());
        metadata.insert(
            "test_definition".into(),
            self.info.test_definition.clone().into(),
        );
        for (k, v) in &self.info.metadata {
            metadata.insert(k.clone(), v.clone().into());
        }
        let meta = RecordingMeta {
            format: FORMAT_V1.into(),
            sample_rate_hz: self.info.sample_rate_hz,
            channels: meta_channels,
            excitation: Excitation {
                kind: if steps.is_empty() {
                    ExcitationKind::Unknown
                } else {
                    ExcitationKind::SteppedSine
                },
                steps,
                sweep: None,
            },
            description: format!(
                "hystid run (tool {}, seed {}){}",
                self.info.tool_version,
                self.info.seed,
                if self.truncated { ", truncated" } else { "" }
            ),
            metadata,
            extra: serde_json::Map::new(),
            chosen_reference: None,
        };
        super::sidecar::check(Path::new("MCAP run"), &meta, Some(frames as u64))?;
        Ok((meta, frames))
    }
}
