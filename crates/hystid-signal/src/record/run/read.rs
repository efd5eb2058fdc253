//! A run file read back: scanned linearly, every chunk's CRC checked, a file
//! cut short recovered up to its last complete chunk.

use super::checked_slots;
use super::{
    RUN_FORMAT, RUN_METADATA, RunInfo, SLOTS, StepSignals, TEST_ATTACHMENT, TOPIC_DWELL, TOPIC_FIT,
    TOPIC_SIGNALS, check_info, mcap_error,
};
use crate::error::{Error, Result};
use crate::record::cdr;
use crate::record::{
    Channel, Excitation, ExcitationKind, FORMAT_V1, Recording, RecordingMeta, Step,
};
use mcap::McapError;
use mcap::sans_io::{LinearReadEvent, LinearReader, LinearReaderOptions};
use serde_json::Value;
use std::collections::{BTreeMap, HashMap};
use std::fs::File;
use std::io::Read;
use std::path::Path;

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
pub(in crate::record) fn read_run_layout(path: &Path) -> Result<(McapRun, Vec<Stretch>)> {
    let file = File::open(path).map_err(|e| Error::io(path, e))?;
    let len = file.metadata().map_err(|e| Error::io(path, e))?.len();
    scan_run(path, file, len, false)
}

/// What [`RunScanner::next`] found.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(in crate::record) enum Scanned {
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
pub(in crate::record) struct RunScanner<R> {
    path: std::path::PathBuf,
    file: R,
    len: u64,
    reader: LinearReader,
}

impl<R: Read> RunScanner<R> {
    pub(in crate::record) fn new(path: &Path, file: R, len: u64) -> Result<Self> {
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
            .add_decompressor(crate::record::zstd_window::BoundedZstd::new(
                crate::record::zstd_window::window_log_for(limit),
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
    pub(in crate::record) fn next(
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
pub(in crate::record) struct Stretch {
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
    pub(in crate::record) fn recording_meta(
        &self,
        stretches: &[Stretch],
    ) -> Result<(RecordingMeta, usize)> {
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
        crate::record::sidecar::check(Path::new("MCAP run"), &meta, Some(frames as u64))?;
        Ok((meta, frames))
    }
}
