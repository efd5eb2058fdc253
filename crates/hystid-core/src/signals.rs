//! A recording in memory: channels of samples and what they mean.
//!
//! The content of "hystid.recording.v1" (`docs/src/reference/recording-format.md`)
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
    /// Broadband random: no harmonics to reduce; validated in the time
    /// domain and by H1.
    Random,
    /// A period of several sines, played repeatedly: judged at the lines of
    /// its period.
    Multisine,
    /// Not stated.
    #[default]
    Unknown,
}

impl ExcitationKind {
    /// Whether a recording of this kind may be a periodic multisine (found
    /// by its period when the kind is not stated).
    pub fn may_be_multisine(self) -> bool {
        matches!(self, ExcitationKind::Multisine | ExcitationKind::Unknown)
    }
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

/// The format tag of recording format v1 (a sidecar's `format`).
pub const FORMAT_V1: &str = "hystid.recording.v1";

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
    /// A v1 description of `channels` sampled at `sample_rate_hz`, driven
    /// as `excitation` says, with nothing else stated.
    pub fn new(
        sample_rate_hz: f64,
        channels: Vec<Channel>,
        excitation: Excitation,
    ) -> RecordingMeta {
        RecordingMeta {
            format: FORMAT_V1.into(),
            sample_rate_hz,
            channels,
            excitation,
            description: String::new(),
            metadata: Default::default(),
            extra: Default::default(),
            chosen_reference: None,
        }
    }

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

/// A recording's description and its channels borrowed, however they are
/// held (a [`Recording`]'s `f64`s, or the [`Samples`] a file stored).
#[derive(Clone, Debug)]
pub struct RecordingView<'a> {
    /// What the samples mean.
    pub meta: &'a RecordingMeta,
    /// `channels[c]`, one per channel of `meta`.
    pub channels: Vec<SamplesView<'a>>,
}

impl Recording {
    /// The recording borrowed as a [`RecordingView`].
    pub fn view(&self) -> RecordingView<'_> {
        RecordingView {
            meta: &self.meta,
            channels: self.channels.iter().map(Into::into).collect(),
        }
    }
}

impl RecordingView<'_> {
    /// The channels `keep` (in that order) copied into a [`Recording`] of
    /// `f64`s, with `meta` trimmed to them: for the stages that read a
    /// recording whole (finding dwells, following a sweep).
    pub fn to_recording(&self, keep: &[usize]) -> Recording {
        let mut meta = self.meta.clone();
        meta.channels = keep
            .iter()
            .map(|&c| self.meta.channels[c].clone())
            .collect();
        Recording {
            meta,
            channels: keep
                .iter()
                .map(|&c| self.channels[c].values().into_owned())
                .collect(),
        }
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
/// hands over, say), and channels held however they are (in memory, in
/// scratch files; slices through `.into()`) handed to those stages as a
/// recording ([`InMemoryFrames::pair`], [`InMemoryFrames::single`]).
pub struct InMemoryFrames<'a> {
    meta: std::borrow::Cow<'a, RecordingMeta>,
    channels: Vec<SamplesView<'a>>,
    name: String,
}

impl<'a> InMemoryFrames<'a> {
    /// `recording`, named `name` in errors.
    pub fn new(recording: &'a Recording, name: impl Into<String>) -> InMemoryFrames<'a> {
        let channels = recording.channels.iter().map(Into::into).collect();
        InMemoryFrames::of_channels(&recording.meta, channels, name)
    }

    /// The recording `meta` describes whose channels are `channels` (a
    /// replay beside the reference a time record holds, say).
    pub fn of_channels(
        meta: &'a RecordingMeta,
        channels: Vec<SamplesView<'a>>,
        name: impl Into<String>,
    ) -> InMemoryFrames<'a> {
        InMemoryFrames {
            meta: std::borrow::Cow::Borrowed(meta),
            channels,
            name: name.into(),
        }
    }

    /// A force (channel 0) and a response (channel 1) sampled together at
    /// `sample_rate_hz`.
    ///
    /// Errors: their lengths differ.
    pub fn pair(
        force: SamplesView<'a>,
        response: SamplesView<'a>,
        sample_rate_hz: f64,
    ) -> Result<InMemoryFrames<'a>> {
        if force.len() != response.len() {
            return Err(Error::input(
                "response",
                format!(
                    "has {} samples but the force has {}: they must be sampled together",
                    response.len(),
                    force.len()
                ),
            ));
        }
        let channels = [
            ("force", Quantity::Force, "N"),
            ("response", Quantity::Displacement, "m"),
        ];
        Ok(InMemoryFrames::held(
            &channels,
            vec![force, response],
            sample_rate_hz,
        ))
    }

    /// A reference alone (channel 0), sampled at `sample_rate_hz`.
    pub fn single(reference: SamplesView<'a>, sample_rate_hz: f64) -> InMemoryFrames<'a> {
        let channels = [("reference", Quantity::Force, "N")];
        InMemoryFrames::held(&channels, vec![reference], sample_rate_hz)
    }

    /// `channels` described as `described` (name, quantity, unit), with no
    /// excitation stated.
    fn held(
        described: &[(&str, Quantity, &str)],
        channels: Vec<SamplesView<'a>>,
        sample_rate_hz: f64,
    ) -> InMemoryFrames<'a> {
        let described = described.iter().map(|&(name, quantity, unit)| Channel {
            name: name.into(),
            quantity,
            unit: unit.into(),
            scale: 1.0,
        });
        let meta = RecordingMeta::new(sample_rate_hz, described.collect(), Excitation::default());
        InMemoryFrames {
            meta: std::borrow::Cow::Owned(meta),
            channels,
            name: "channels".into(),
        }
    }
}

impl FrameSource for InMemoryFrames<'_> {
    fn meta(&self) -> &RecordingMeta {
        &self.meta
    }
    fn frames(&self) -> usize {
        self.channels.first().map_or(0, SamplesView::len)
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
        for (o, c) in out.iter_mut().zip(&self.channels) {
            o.clear();
            o.extend_from_slice(&c.range(start..end));
        }
        Ok(end - start)
    }
}

/// One channel's samples, held at the precision they were recorded in.
///
/// A file stores each sample as a 32-bit float or a 16/24-bit integer times
/// the channel's `scale` (and a run file as a 32-bit float): in physical
/// units as `f64` that is twice the memory the information needs, and a
/// time-domain fit holds its recordings' reference and response whole for
/// as long as it runs (they are replayed). Where every sample is exactly an
/// `f32` times one unit, [`Samples::recorded`] keeps the `f32`s and the
/// unit; each sample read back is then the same `f64` to the bit (`unit ·
/// stored`, as the readers compute it). Anything else (a binding's
/// `float64` array, a sum of channels) is kept as it is.
///
/// A channel longer than a loader's bound ([`SamplesBuilder::spilling_above`])
/// is not held in memory at all but in an unnamed scratch file (see
/// [`Spilled`]): what a replay or a fit reads of it is read back a stretch
/// at a time, the same values to the bit, and a recording's length no
/// longer sets what the process holds.
#[derive(Clone, Debug)]
pub struct Samples(Held);

/// Equal where the values are, however they are held.
impl PartialEq for Samples {
    fn eq(&self, other: &Samples) -> bool {
        match (&self.0, &other.0) {
            (Held::Exact(a), Held::Exact(b)) => a == b,
            _ => {
                let (mut a, mut b) = (self.view().cursor(), other.view().cursor());
                self.len() == other.len() && (0..self.len()).all(|i| a.get(i) == b.get(i))
            }
        }
    }
}

#[derive(Clone, Debug)]
enum Held {
    Exact(Vec<f64>),
    Units { stored: Vec<f32>, unit: f64 },
    Spilled(std::sync::Arc<Spilled>),
}

/// Samples held in a scratch file: `f32`s of a unit where every sample is
/// one (as [`Samples`] holds them in memory), else `f64`s, little-endian.
/// The file, in [`scratch_dir`], has no name (it is gone when the last
/// clone of the samples is dropped, or the process ends, however it ends);
/// reads are positioned, so threads replaying the same channel read it at
/// once without a lock. The operating system's page cache keeps what is
/// read often; the process holds only the stretch it is reading.
#[derive(Debug)]
pub struct Spilled {
    file: std::fs::File,
    len: usize,
    /// `Some(unit)`: stored as `f32`s of `unit`; `None`: as `f64`s.
    unit: Option<f64>,
}

impl Spilled {
    fn width(&self) -> usize {
        if self.unit.is_some() { 4 } else { 8 }
    }

    /// Samples `range` in physical units, appended to `out`.
    ///
    /// Panics if the scratch file cannot be read back (a failing disk, as
    /// an allocation that fails aborts: the file is the process's own).
    fn read_into(&self, range: std::ops::Range<usize>, out: &mut Vec<f64>) {
        let w = self.width();
        let mut bytes = vec![0u8; w * range.len()];
        if let Err(e) = read_exact_at(&self.file, &mut bytes, (w * range.start) as u64) {
            panic!(
                "reading back samples {}..{} of a channel held in a scratch file: {e}",
                range.start, range.end
            );
        }
        match self.unit {
            Some(unit) => out.extend(
                bytes
                    .chunks_exact(4)
                    .map(|b| f32::from_le_bytes([b[0], b[1], b[2], b[3]]) as f64 * unit),
            ),
            None => out.extend(
                bytes
                    .chunks_exact(8)
                    .map(|b| f64::from_le_bytes(b.try_into().expect("8 bytes"))),
            ),
        }
    }
}

#[cfg(unix)]
fn read_exact_at(file: &std::fs::File, buf: &mut [u8], offset: u64) -> std::io::Result<()> {
    std::os::unix::fs::FileExt::read_exact_at(file, buf, offset)
}

#[cfg(windows)]
fn read_exact_at(file: &std::fs::File, mut buf: &mut [u8], mut offset: u64) -> std::io::Result<()> {
    use std::os::windows::fs::FileExt;
    while !buf.is_empty() {
        match file.seek_read(buf, offset) {
            Ok(0) => return Err(std::io::ErrorKind::UnexpectedEof.into()),
            Ok(n) => {
                buf = &mut buf[n..];
                offset += n as u64;
            }
            Err(e) if e.kind() == std::io::ErrorKind::Interrupted => {}
            Err(e) => return Err(e),
        }
    }
    Ok(())
}

/// A channel being written to its scratch file (see [`Spilled`]).
#[derive(Debug)]
struct SpillWriter {
    out: std::io::BufWriter<std::fs::File>,
    len: usize,
    unit: Option<f64>,
}

/// Where scratch files go: `TMPDIR` where it is set, else `/var/tmp` where
/// there is one (on disk by convention, where `/tmp` is often a file system
/// in memory: a channel spilled there would only move out of the process,
/// not out of memory), else the system's temporary directory.
pub fn scratch_dir() -> std::path::PathBuf {
    if std::env::var_os("TMPDIR").is_some_and(|d| !d.is_empty()) {
        return std::env::temp_dir();
    }
    let var_tmp = std::path::Path::new("/var/tmp");
    if cfg!(unix) && var_tmp.is_dir() {
        return var_tmp.to_path_buf();
    }
    std::env::temp_dir()
}

/// A scratch file that cannot be made or written: where, and why.
fn scratch_error(e: std::io::Error) -> Error {
    Error::input(
        format!(
            "scratch file in {} (TMPDIR sets where)",
            scratch_dir().display()
        ),
        format!("a channel too long to hold in memory is held there, but: {e}"),
    )
}

impl SpillWriter {
    /// A new scratch file holding `held`.
    fn of(held: Held) -> Result<SpillWriter> {
        let file = tempfile::tempfile_in(scratch_dir()).map_err(scratch_error)?;
        let mut w = SpillWriter {
            out: std::io::BufWriter::with_capacity(1 << 16, file),
            len: 0,
            unit: None,
        };
        match held {
            Held::Exact(v) => w.write_exact(&v)?,
            Held::Units { stored, unit } => {
                w.unit = Some(unit);
                w.write_stored(&stored)?;
            }
            Held::Spilled(_) => unreachable!("a builder never holds a spilled channel"),
        }
        Ok(w)
    }

    /// Appends samples given as their little-endian bytes.
    fn write<const N: usize>(&mut self, x: impl ExactSizeIterator<Item = [u8; N]>) -> Result<()> {
        use std::io::Write;
        let n = x.len();
        for b in x {
            self.out.write_all(&b).map_err(scratch_error)?;
        }
        self.len += n;
        Ok(())
    }

    fn write_stored(&mut self, x: &[f32]) -> Result<()> {
        self.write(x.iter().map(|v| v.to_le_bytes()))
    }

    fn write_exact(&mut self, x: &[f64]) -> Result<()> {
        self.write(x.iter().map(|v| v.to_le_bytes()))
    }

    /// Appends `x`: as `f32`s of the unit while every sample is one, else
    /// every sample as it is from the start (the file rewritten once).
    fn extend(&mut self, x: &[f64]) -> Result<()> {
        if let Some(unit) = self.unit {
            let stored: Vec<f32> = x.iter().map_while(|&v| stored_as(v, unit)).collect();
            if stored.len() == x.len() {
                return self.write_stored(&stored);
            }
            let old =
                std::mem::replace(self, SpillWriter::of(Held::Exact(Vec::new()))?).finish()?;
            let mut v = Vec::with_capacity(STRETCH);
            let mut at = 0;
            while at < old.len {
                let end = (at + STRETCH).min(old.len);
                v.clear();
                old.read_into(at..end, &mut v);
                self.write_exact(&v)?;
                at = end;
            }
        }
        self.write_exact(x)
    }

    fn finish(self) -> Result<Spilled> {
        let file = self
            .out
            .into_inner()
            .map_err(|e| scratch_error(e.into_error()))?;
        Ok(Spilled {
            file,
            len: self.len,
            unit: self.unit,
        })
    }
}

/// Samples converted to `f64` at a time by [`SamplesView::for_each_stretch`].
const STRETCH: usize = 1 << 14;

impl Samples {
    /// `values` held as stored `f32`s of one of `units` (tried in order)
    /// where that gives back every sample to the bit, else as they are.
    pub fn recorded(values: Vec<f64>, units: &[f64]) -> Samples {
        let mut b = SamplesBuilder::new(values.len(), units);
        b.extend_held(&values);
        Samples(b.held.unwrap_or(Held::Exact(Vec::new())))
    }

    /// The samples, borrowed.
    pub fn view(&self) -> SamplesView<'_> {
        match &self.0 {
            Held::Exact(v) => SamplesView::Exact(v),
            Held::Units { stored, unit } => SamplesView::Units(stored, *unit),
            Held::Spilled(s) => SamplesView::Spilled(s),
        }
    }

    /// Whether the samples are held in a scratch file, not in memory.
    pub fn is_spilled(&self) -> bool {
        matches!(self.0, Held::Spilled(_))
    }

    /// Number of samples.
    pub fn len(&self) -> usize {
        self.view().len()
    }

    /// Whether there are none.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Sample `i`, in physical units.
    #[inline]
    pub fn get(&self, i: usize) -> f64 {
        self.view().get(i)
    }

    /// See [`SamplesView::range`].
    pub fn range(&self, range: std::ops::Range<usize>) -> std::borrow::Cow<'_, [f64]> {
        self.view().range(range)
    }

    /// See [`SamplesView::values`].
    pub fn values(&self) -> std::borrow::Cow<'_, [f64]> {
        self.view().values()
    }

    /// See [`SamplesView::for_each_stretch`].
    pub fn for_each_stretch(&self, range: std::ops::Range<usize>, f: impl FnMut(usize, &[f64])) {
        self.view().for_each_stretch(range, f)
    }

    /// The samples in physical units, taken over.
    pub fn into_values(self) -> Vec<f64> {
        match self.0 {
            Held::Exact(v) => v,
            Held::Units { stored, unit } => stored.iter().map(|&s| s as f64 * unit).collect(),
            Held::Spilled(s) => {
                let mut v = Vec::with_capacity(s.len);
                s.read_into(0..s.len, &mut v);
                v
            }
        }
    }

    /// Bytes the samples take in memory (none when spilled to a scratch
    /// file).
    pub fn bytes(&self) -> usize {
        match &self.0 {
            Held::Exact(v) => 8 * v.len(),
            Held::Units { stored, .. } => 4 * stored.len(),
            Held::Spilled(_) => 0,
        }
    }
}

/// Samples borrowed: physical values, or [`Samples`]' stored units.
#[derive(Clone, Copy, Debug)]
pub enum SamplesView<'a> {
    /// Physical values.
    Exact(&'a [f64]),
    /// Stored values and the unit each is of.
    Units(&'a [f32], f64),
    /// Held in a scratch file (read a stretch at a time: see
    /// [`SamplesView::cursor`] for reading sample by sample).
    Spilled(&'a Spilled),
}

impl<'a> SamplesView<'a> {
    /// Number of samples.
    pub fn len(&self) -> usize {
        match self {
            SamplesView::Exact(v) => v.len(),
            SamplesView::Units(s, _) => s.len(),
            SamplesView::Spilled(s) => s.len,
        }
    }

    /// Whether there are none.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Sample `i`, in physical units (a read of the file where the samples
    /// are spilled: a loop over samples reads them through
    /// [`SamplesView::cursor`]).
    #[inline]
    pub fn get(&self, i: usize) -> f64 {
        match self {
            SamplesView::Exact(v) => v[i],
            SamplesView::Units(s, unit) => s[i] as f64 * unit,
            SamplesView::Spilled(s) => {
                let mut v = Vec::with_capacity(1);
                s.read_into(i..i + 1, &mut v);
                v[0]
            }
        }
    }

    /// A reader of samples one at a time, in any order but best in runs
    /// (a spilled channel is read back a stretch at a time around the
    /// sample asked for).
    pub fn cursor(&self) -> SampleCursor<'a> {
        SampleCursor {
            view: *self,
            at: 0,
            buffer: Vec::new(),
        }
    }

    /// Samples `range` in physical units: borrowed where they are held as
    /// such, else converted.
    pub fn range(&self, range: std::ops::Range<usize>) -> std::borrow::Cow<'a, [f64]> {
        match *self {
            SamplesView::Exact(v) => std::borrow::Cow::Borrowed(&v[range]),
            SamplesView::Units(s, unit) => {
                std::borrow::Cow::Owned(s[range].iter().map(|&s| s as f64 * unit).collect())
            }
            SamplesView::Spilled(s) => {
                assert!(range.end <= s.len, "samples {range:?} of {}", s.len);
                let mut v = Vec::with_capacity(range.len());
                s.read_into(range, &mut v);
                std::borrow::Cow::Owned(v)
            }
        }
    }

    /// Every sample in physical units (a copy where they are held as
    /// stored units: for what needs the whole channel at once).
    pub fn values(&self) -> std::borrow::Cow<'a, [f64]> {
        self.range(0..self.len())
    }

    /// `f` on `range` a stretch at a time, in order, each stretch in
    /// physical units with the index of its first sample (no copy of the
    /// whole range).
    pub fn for_each_stretch(
        &self,
        range: std::ops::Range<usize>,
        mut f: impl FnMut(usize, &[f64]),
    ) {
        match self {
            SamplesView::Exact(v) => f(range.start, &v[range]),
            SamplesView::Units(..) | SamplesView::Spilled(_) => {
                let mut at = range.start;
                while at < range.end {
                    let end = (at + STRETCH).min(range.end);
                    f(at, &self.range(at..end));
                    at = end;
                }
            }
        }
    }
}

/// Samples read one at a time (see [`SamplesView::cursor`]): directly
/// where they are held in memory, else from a stretch read around the one
/// asked for.
#[derive(Debug)]
pub struct SampleCursor<'a> {
    view: SamplesView<'a>,
    /// The first sample in `buffer`.
    at: usize,
    buffer: Vec<f64>,
}

/// Samples a [`SampleCursor`] reads back at once from a spilled channel.
const CURSOR_STRETCH: usize = 1 << 16;

impl SampleCursor<'_> {
    /// Sample `i`, in physical units.
    #[inline]
    pub fn get(&mut self, i: usize) -> f64 {
        let SamplesView::Spilled(s) = self.view else {
            return self.view.get(i);
        };
        if !(self.at..self.at + self.buffer.len()).contains(&i) {
            // from a little before: a loop may step back a few samples
            self.at = i.saturating_sub(CURSOR_STRETCH / 16);
            self.buffer.clear();
            s.read_into(
                self.at..(self.at + CURSOR_STRETCH).min(s.len),
                &mut self.buffer,
            );
        }
        self.buffer[i - self.at]
    }
}

impl<'a> From<&'a [f64]> for SamplesView<'a> {
    fn from(v: &'a [f64]) -> SamplesView<'a> {
        SamplesView::Exact(v)
    }
}

impl<'a> From<&'a Vec<f64>> for SamplesView<'a> {
    fn from(v: &'a Vec<f64>) -> SamplesView<'a> {
        SamplesView::Exact(v)
    }
}

impl<'a> From<&'a Samples> for SamplesView<'a> {
    fn from(s: &'a Samples) -> SamplesView<'a> {
        s.view()
    }
}

/// Samples of a channel a loader holds in memory (16 MiB as `f32`s); the
/// rest of a longer channel is held in a scratch file ([`Spilled`],
/// [`SamplesBuilder::spilling_above`]), so that the replays and time-domain
/// fits of a recording of any length hold a bounded part of it.
pub const SAMPLES_HELD_IN_MEMORY: usize = 1 << 22;

/// [`Samples`] made as they are read, a stretch at a time: held as stored
/// `f32`s of the first of the units that gives back every sample of the
/// first stretch, until a sample that unit does not give back (then as
/// they are, from the start).
#[derive(Debug)]
pub struct SamplesBuilder {
    units: Vec<f64>,
    capacity: usize,
    held: Option<Held>,
    /// Whether a sample was not zero.
    nonzero: bool,
    /// More samples than this go to a scratch file.
    spill_above: Option<usize>,
    spilling: Option<SpillWriter>,
}

/// `v` as an `f32` of `unit`, where that gives it back to the bit.
fn stored_as(v: f64, unit: f64) -> Option<f32> {
    let s = (v / unit) as f32;
    (s as f64 * unit == v).then_some(s)
}

impl SamplesBuilder {
    /// A builder for about `capacity` samples trying `units` in order.
    pub fn new(capacity: usize, units: &[f64]) -> SamplesBuilder {
        SamplesBuilder {
            units: units
                .iter()
                .copied()
                .filter(|u| u.is_finite() && *u != 0.0)
                .collect(),
            capacity,
            held: None,
            nonzero: false,
            spill_above: None,
            spilling: None,
        }
    }

    /// The builder holding the samples in a scratch file (see [`Spilled`])
    /// once there are more than `samples`: a loader's bound on what a
    /// channel holds in memory, whatever the recording's length.
    pub fn spilling_above(self, samples: usize) -> SamplesBuilder {
        SamplesBuilder {
            spill_above: Some(samples),
            capacity: self.capacity.min(samples.saturating_add(1)),
            ..self
        }
    }

    /// Appends `x`.
    ///
    /// Errors: a scratch file that cannot be made or written (only where
    /// the builder spills).
    pub fn extend(&mut self, x: &[f64]) -> Result<()> {
        self.nonzero = self.nonzero || x.iter().any(|&v| v != 0.0);
        if let Some(w) = &mut self.spilling {
            return w.extend(x);
        }
        self.extend_held(x);
        let held = match &self.held {
            Some(Held::Exact(v)) => v.len(),
            Some(Held::Units { stored, .. }) => stored.len(),
            _ => 0,
        };
        if self.spill_above.is_some_and(|n| held > n) {
            let held = self.held.take().expect("samples held");
            self.spilling = Some(SpillWriter::of(held)?);
        }
        Ok(())
    }

    /// Appends `x` to the samples held in memory.
    fn extend_held(&mut self, x: &[f64]) {
        let held = self.held.get_or_insert_with(|| {
            let fits = |u: f64| x.iter().all(|&v| stored_as(v, u).is_some());
            match self.units.iter().copied().find(|&u| fits(u)) {
                Some(unit) => Held::Units {
                    stored: Vec::with_capacity(self.capacity),
                    unit,
                },
                None => Held::Exact(Vec::with_capacity(self.capacity)),
            }
        });
        if let Held::Units { stored, unit } = held {
            let at = stored.len();
            stored.extend(x.iter().map_while(|&v| stored_as(v, *unit)));
            if stored.len() == at + x.len() {
                return;
            }
            // a sample the unit does not give back: every sample as it is
            let mut exact = Vec::with_capacity(self.capacity.max(at + x.len()));
            exact.extend(stored[..at].iter().map(|&s| s as f64 * *unit));
            *held = Held::Exact(exact);
        }
        if let Held::Exact(v) = held {
            v.extend_from_slice(x);
        }
    }

    /// Whether every sample so far is zero.
    pub fn all_zero(&self) -> bool {
        !self.nonzero
    }

    /// The samples.
    ///
    /// Errors: a scratch file that cannot be written (only where the
    /// builder spills).
    pub fn finish(self) -> Result<Samples> {
        if let Some(w) = self.spilling {
            return Ok(Samples(Held::Spilled(std::sync::Arc::new(w.finish()?))));
        }
        Ok(Samples(self.held.unwrap_or(Held::Exact(Vec::new()))))
    }
}

impl From<Vec<f64>> for Samples {
    /// Held as they are.
    fn from(values: Vec<f64>) -> Samples {
        Samples(Held::Exact(values))
    }
}

#[cfg(test)]
mod samples_tests {
    use super::Samples;

    /// A channel longer than its builder's bound is held in a scratch file
    /// and read back to the bit, whichever way it is read: as `f32`s of its
    /// unit, and as `f64`s from the start once a sample no `f32` of the
    /// unit gives back arrives after it was spilled; a channel within the
    /// bound stays in memory.
    #[test]
    fn a_long_channel_is_held_in_a_scratch_file_and_read_back_to_the_bit() {
        let unit = 3.7e-4 / 8_388_608.0;
        let pcm24: Vec<f64> = (0..200_000)
            .map(|i| (((i * 7919) % 16_777_216) as f64 - 8_388_608.0) * unit)
            .collect();
        let mut late = pcm24.clone();
        late[150_000] = 0.1; // after the spill: not an f32 of the unit
        for (values, held_as) in [(&pcm24, 4), (&late, 8)] {
            let mut b = super::SamplesBuilder::new(values.len(), &[unit]).spilling_above(5_000);
            values.chunks(3_001).for_each(|c| b.extend(c).unwrap());
            let s = b.finish().unwrap();
            assert!(s.is_spilled());
            assert_eq!(s.bytes(), 0);
            let super::Held::Spilled(f) = &s.0 else {
                unreachable!()
            };
            assert_eq!(f.width(), held_as);
            assert_eq!(s.len(), values.len());
            let bits = |v: &[f64]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
            assert_eq!(bits(&s.values()), bits(values));
            assert_eq!(
                bits(&s.range(70_000..140_003)),
                bits(&values[70_000..140_003])
            );
            let mut seen = Vec::new();
            s.for_each_stretch(11..values.len() - 5, |at, x| {
                assert_eq!(at, 11 + seen.len());
                seen.extend_from_slice(x);
            });
            assert_eq!(bits(&seen), bits(&values[11..values.len() - 5]));
            // sample by sample: in runs, backwards, and jumping about
            let view = s.view();
            let mut cursor = view.cursor();
            let order = (0..values.len())
                .step_by(7)
                .chain((0..values.len()).rev().step_by(13))
                .chain((0..5000).map(|k| (k * 104_729) % values.len()));
            for i in order {
                assert_eq!(cursor.get(i).to_bits(), values[i].to_bits(), "{i}");
            }
            assert_eq!(s.get(123_457).to_bits(), values[123_457].to_bits());
            assert!(s == Samples::from(values.clone()));
            // the clone shares the file
            assert_eq!(bits(&s.clone().into_values()), bits(values));
        }
        let mut b = super::SamplesBuilder::new(5_000, &[unit]).spilling_above(5_000);
        b.extend(&pcm24[..5_000]).unwrap();
        let s = b.finish().unwrap();
        assert!(!s.is_spilled());
        assert_eq!(s.bytes(), 4 * 5_000);
    }

    /// 24-bit integers times a scale, float32 values times another, and a
    /// run file's floats: each held as `f32`s (half the bytes) and read
    /// back to the bit; a value no `f32` of the unit gives keeps the
    /// channel as it is.
    #[test]
    fn recorded_samples_are_held_as_stored_and_read_back_to_the_bit() {
        let pcm24: Vec<f64> = (0..5000)
            .map(|i| ((i * 7919) % 16_777_216) as f64 - 8_388_608.0)
            .map(|k| k * (3.7e-4 / 8_388_608.0))
            .collect();
        let float32: Vec<f64> = (0..5000)
            .map(|i| ((i as f32 * 0.37).sin() * 1.3e-3) as f64 * 1000.0)
            .collect();
        for (values, scale) in [(pcm24, 3.7e-4), (float32, 1000.0)] {
            let s = Samples::recorded(values.clone(), &[scale, 1.0]);
            assert_eq!(s.bytes(), 4 * values.len());
            assert!((0..values.len()).all(|i| s.get(i).to_bits() == values[i].to_bits()));
            assert_eq!(*s.values(), values[..]);
            let mut seen = Vec::new();
            s.for_each_stretch(3..values.len() - 2, |at, x| {
                assert_eq!(at, 3 + seen.len());
                seen.extend_from_slice(x);
            });
            assert_eq!(seen, values[3..values.len() - 2]);
            assert_eq!(s.into_values(), values);
        }
        // read a stretch at a time, a sample no f32 of the unit gives back
        // late in the channel: every sample kept as it is
        let mut late: Vec<f64> = (0..1000).map(|i| i as f64 * 0.5).collect();
        late[900] = 0.1;
        let mut b = super::SamplesBuilder::new(1000, &[1.0]);
        late.chunks(64).for_each(|c| b.extend(c).unwrap());
        let s = b.finish().unwrap();
        assert_eq!(s.bytes(), 8 * late.len());
        // equal by value, however held
        late[900] = 450.0;
        assert!(s != Samples::recorded(late.clone(), &[1.0]));
        assert!(Samples::recorded(late.clone(), &[1.0]) == Samples::from(late.clone()));
        late[900] = 0.1;
        assert_eq!(s.into_values(), late);
        let mut doubles: Vec<f64> = (0..100).map(|i| i as f64 * 0.25).collect();
        doubles[57] = 0.1; // not an f32
        let s = Samples::recorded(doubles.clone(), &[1.0]);
        assert_eq!(s.bytes(), 8 * doubles.len());
        assert_eq!(s.into_values(), doubles);
    }
}
