//! A run file read frame by frame, without holding its samples.
//!
//! [`read_run`](super::read_run) decodes every signal block into memory:
//! four arrays of the run's length, then a second copy when the run becomes
//! a [`Recording`](super::Recording). A long stepped-sine run does not fit
//! in a small machine that way, and the stepped-sine reduction never needs
//! more than one dwell. [`McapRunReader`] first scans the file for its
//! description and the layout of its signal blocks (no samples kept), then
//! serves [`FrameSource::read_at`] from a forward scan that decodes blocks as
//! it passes them and keeps only the frames asked for. Reads in increasing
//! order (as the reduction makes them) cost one pass over the file; a read
//! behind the scan starts it again from the file's beginning.

use super::cdr;
use super::run::{RunScanner, Scanned, Stretch, checked_slots, read_run_layout};
use super::{McapRun, RecordingMeta, TOPIC_SIGNALS};
use crate::error::{Error, Result};
use crate::signals::FrameSource;
use std::collections::HashMap;
use std::fs::File;
use std::path::{Path, PathBuf};

/// A run file as a [`FrameSource`]: its channels as
/// [`McapRun::to_recording`] lists them, read without holding the run's
/// samples (see the module docs).
pub struct McapRunReader {
    path: PathBuf,
    run: McapRun,
    meta: RecordingMeta,
    frames: usize,
    /// Absolute frame index of the recording's frame 0.
    origin: u64,
    /// Per recording channel: which array of a signal block holds it.
    slots: Vec<usize>,
    scan: Option<ForwardScan>,
}

/// The forward scan serving reads: decoded frames `[start, start +
/// carry[c].len())`, absolute indices, not yet handed out or skipped.
struct ForwardScan {
    scanner: RunScanner<File>,
    topics: HashMap<u16, String>,
    start: u64,
    carry: Vec<Vec<f64>>,
    ended: bool,
}

impl McapRunReader {
    /// Scans the run file at `path` for its description and layout (every
    /// chunk's CRC checked, as [`read_run`](super::read_run) checks them).
    ///
    /// Errors: those of [`read_run`](super::read_run), and signals that are
    /// not contiguous (as [`McapRun::to_recording`]).
    pub fn open(path: &Path) -> Result<Self> {
        let (run, stretches) = read_run_layout(path)?;
        let (meta, frames) = run.recording_meta(&stretches).map_err(|e| {
            Error::context(format!("{}: rebuilding the recording", path.display()), e)
        })?;
        let origin = stretches.first().map_or(0, |s: &Stretch| s.first_frame);
        let slots = checked_slots(&run.info);
        Ok(McapRunReader {
            path: path.to_path_buf(),
            run,
            meta,
            frames,
            origin,
            slots,
            scan: None,
        })
    }

    /// The run's description, dwell and fit messages (its `signals` empty:
    /// the samples are read through [`FrameSource::read_at`]).
    pub fn run(&self) -> &McapRun {
        &self.run
    }

    fn restart(&mut self) -> Result<()> {
        let file = File::open(&self.path).map_err(|e| Error::io(&self.path, e))?;
        let len = file.metadata().map_err(|e| Error::io(&self.path, e))?.len();
        self.scan = Some(ForwardScan {
            scanner: RunScanner::new(&self.path, file, len)?,
            topics: HashMap::new(),
            start: self.origin,
            carry: vec![Vec::new(); self.slots.len()],
            ended: false,
        });
        Ok(())
    }
}

impl ForwardScan {
    fn end(&self) -> u64 {
        self.start + self.carry.first().map_or(0, |c| c.len() as u64)
    }

    /// Drops the decoded frames before `frame`.
    fn skip_to(&mut self, frame: u64) {
        let held = self.carry.first().map_or(0, Vec::len);
        let n = (frame.saturating_sub(self.start) as usize).min(held);
        for c in &mut self.carry {
            c.drain(..n);
        }
        self.start += n as u64;
    }

    /// Decodes the next signal block onto the carry; false at the file's
    /// end.
    fn pull_block(&mut self, path: &Path, slots: &[usize]) -> Result<bool> {
        while !self.ended {
            let mut got_block = false;
            let end = self.end();
            let topics = &mut self.topics;
            let carry = &mut self.carry;
            let scanned = self.scanner.next(|record| {
                use mcap::records::Record;
                match record {
                    Record::Channel(c) => {
                        topics.insert(c.id, c.topic);
                    }
                    Record::Message { header, data }
                        if topics.get(&header.channel_id).map(String::as_str)
                            == Some(TOPIC_SIGNALS) =>
                    {
                        let field = || format!("{TOPIC_SIGNALS} message {}", header.sequence);
                        let block = cdr::decode_signal_block(&data)
                            .map_err(|m| Error::format(path, field(), m.to_string()))?;
                        // the layout scan checked contiguity; a file changed
                        // since is caught here rather than read shifted
                        if block.first_frame != end {
                            return Err(Error::format(
                                path,
                                field(),
                                format!(
                                    "starts at frame {}, expected {end}: the file changed while \
                                     it was read",
                                    block.first_frame
                                ),
                            ));
                        }
                        for (c, &s) in carry.iter_mut().zip(slots) {
                            block.extend(s, c);
                        }
                        got_block = true;
                    }
                    _ => {}
                }
                Ok(())
            })?;
            if scanned != Scanned::Record {
                self.ended = true;
            }
            if got_block {
                return Ok(true);
            }
        }
        Ok(false)
    }
}

impl std::fmt::Debug for McapRunReader {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("McapRunReader")
            .field("path", &self.path)
            .field("frames", &self.frames)
            .field("truncated", &self.run.truncated)
            .finish_non_exhaustive()
    }
}

impl FrameSource for McapRunReader {
    fn meta(&self) -> &RecordingMeta {
        &self.meta
    }

    fn frames(&self) -> usize {
        self.frames
    }

    fn source_name(&self) -> String {
        self.path.display().to_string()
    }

    fn read_at(&mut self, start: usize, count: usize, out: &mut [Vec<f64>]) -> Result<usize> {
        if start > self.frames {
            return Err(Error::input(
                self.source_name(),
                format!(
                    "frame {start} is beyond the recording's {} frames",
                    self.frames
                ),
            ));
        }
        let want = self.origin + start as u64;
        let until = self.origin + (start + count).min(self.frames) as u64;
        if self.scan.as_ref().is_none_or(|s| s.start > want) {
            self.restart()?;
        }
        let scan = self.scan.as_mut().expect("just ensured");
        loop {
            scan.skip_to(want);
            if scan.end() >= until || !scan.pull_block(&self.path, &self.slots)? {
                break;
            }
        }
        let n = (scan.end().min(until).saturating_sub(want)) as usize;
        for (o, c) in out.iter_mut().zip(&scan.carry) {
            o.clear();
            o.extend_from_slice(&c[..n]);
        }
        Ok(n)
    }
}
