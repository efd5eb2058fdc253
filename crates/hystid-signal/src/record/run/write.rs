//! A run written as it happens: the MCAP file's chunks, channels, schemas and
//! messages, signals, preview, dwells and fit iterations.

use super::checked_slots;
use super::{
    GAUGE, RUN_FORMAT, RUN_METADATA, RunInfo, SIGNAL_BLOCK_FRAMES, SLOTS, TEST_ATTACHMENT,
    TOPIC_DWELL, TOPIC_FIT, TOPIC_PREVIEW, TOPIC_SIGNALS, check_info, mcap_error,
};
use crate::atomic::PendingFile;
use crate::error::{Error, Result};
use crate::harmonics::Quantity;
use crate::record::cdr;
use mcap::records::{MessageHeader, Metadata};
use serde::Serialize;
use std::borrow::Cow;
use std::collections::BTreeMap;
use std::fs::File;
use std::io::BufWriter;
use std::path::Path;

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
            if let Some(i) = crate::record::first_out_of_range(a, f32::MAX as f64) {
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
