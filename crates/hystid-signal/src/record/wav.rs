//! WAV + JSON recordings (format v1): a streaming reader and an atomic writer.
//!
//! The WAV header is parsed by `hound` (RIFF, `fmt `, WAVE_FORMAT_EXTENSIBLE,
//! skipped chunks); the samples are then read in bulk straight from the data
//! chunk, so memory stays bounded by one block whatever the file size.

use super::sidecar;
use super::{Recording, RecordingMeta};
use crate::atomic::PendingFile;
use crate::error::{Error, Result};
use std::fs::File;
use std::io::{BufReader, BufWriter, Read, Seek, SeekFrom, Write};
use std::path::{Path, PathBuf};

/// How [`write_recording`] stores the samples.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum SampleFormat {
    /// IEEE float, 32-bit; each channel's `scale` is kept as given, so the
    /// stored value is `physical / scale` rounded to f32.
    Float32,
    /// Integer PCM, 16-bit; `scale` chosen so the channel's peak maps just
    /// below full scale.
    Pcm16,
    /// Integer PCM, 24-bit (packed, 3 bytes a sample); scale as for `Pcm16`.
    Pcm24,
    /// Integer PCM, 32-bit; scale as for `Pcm16`.
    Pcm32,
}

impl SampleFormat {
    fn bits(self) -> u16 {
        match self {
            SampleFormat::Float32 | SampleFormat::Pcm32 => 32,
            SampleFormat::Pcm16 => 16,
            SampleFormat::Pcm24 => 24,
        }
    }
}

/// The two files of a recording, from `NAME.wav`, `NAME.json` or the stem
/// `NAME` (a stem may itself contain dots).
pub(crate) fn recording_paths(path: &Path) -> (PathBuf, PathBuf) {
    let ext = path.extension().and_then(|e| e.to_str());
    let stem = match ext {
        Some(e) if e.eq_ignore_ascii_case("wav") || e.eq_ignore_ascii_case("json") => {
            path.with_extension("")
        }
        _ => path.to_path_buf(),
    };
    let with = |suffix: &str| {
        let mut s = stem.clone().into_os_string();
        s.push(suffix);
        PathBuf::from(s)
    };
    (with(".wav"), with(".json"))
}

/// How the samples of a data chunk are laid out.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Encoding {
    Pcm16,
    Pcm24,
    Pcm32,
    Float32,
}

impl Encoding {
    fn bytes(self) -> usize {
        match self {
            Encoding::Pcm16 => 2,
            Encoding::Pcm24 => 3,
            Encoding::Pcm32 | Encoding::Float32 => 4,
        }
    }
    /// Physical value per stored unit for a channel of scale `scale`:
    /// `scale / 2^(bits-1)` for integers (exact, a power of two), `scale`
    /// for floats.
    fn factor(self, scale: f64) -> f64 {
        match self {
            Encoding::Pcm16 => scale / 32768.0,
            Encoding::Pcm24 => scale / 8_388_608.0,
            Encoding::Pcm32 => scale / 2_147_483_648.0,
            Encoding::Float32 => scale,
        }
    }
}

/// Frames decoded per bulk read: bounds the raw buffer (at most 16384 ×
/// channels × 4 bytes).
const BLOCK_FRAMES: usize = 16384;

/// Where the samples come from: a file, or bytes already in memory (the
/// fuzz targets and tests read the same code without writing files).
trait Samples: Read + Seek + Send {}
impl<T: Read + Seek + Send> Samples for T {}

/// Reads a recording's samples block by block, in physical units.
///
/// Memory is one block of raw bytes plus what the caller asks for, so a
/// recording of any size can be reduced in a single pass.
pub struct RecordingReader {
    wav_path: PathBuf,
    meta: RecordingMeta,
    file: BufReader<Box<dyn Samples>>,
    encoding: Encoding,
    data_start: u64,
    frames: usize,
    position: usize,
    factors: Vec<f64>,
    raw: Vec<u8>,
}

impl std::fmt::Debug for RecordingReader {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("RecordingReader")
            .field("wav_path", &self.wav_path)
            .field("encoding", &self.encoding)
            .field("frames", &self.frames)
            .field("position", &self.position)
            .finish_non_exhaustive()
    }
}

impl RecordingReader {
    /// Opens `NAME.wav` + `NAME.json` (`path` is either file or the stem),
    /// reads the header and the sidecar and checks them against each other
    /// and against format v1.
    pub fn open(path: &Path) -> Result<Self> {
        let (wav_path, json_path) = recording_paths(path);
        let json = std::fs::read(&json_path).map_err(|e| Error::io(&json_path, e))?;
        let file = File::open(&wav_path).map_err(|e| Error::io(&wav_path, e))?;
        let file_len = file.metadata().map_err(|e| Error::io(&wav_path, e))?.len();
        Self::from_source(wav_path, json_path, &json, Box::new(file), file_len)
    }

    /// [`RecordingReader::open`] on a recording already in memory: `json`
    /// and `wav` are the two files' bytes, `path` (file or stem) names them
    /// in messages.
    pub fn from_bytes(path: &Path, json: &[u8], wav: Vec<u8>) -> Result<Self> {
        let (wav_path, json_path) = recording_paths(path);
        let len = wav.len() as u64;
        Self::from_source(
            wav_path,
            json_path,
            json,
            Box::new(std::io::Cursor::new(wav)),
            len,
        )
    }

    fn from_source(
        wav_path: PathBuf,
        json_path: PathBuf,
        json: &[u8],
        source: Box<dyn Samples>,
        file_len: u64,
    ) -> Result<Self> {
        let text = std::str::from_utf8(json)
            .map_err(|e| Error::format(&json_path, "JSON", format!("not UTF-8 text: {e}")))?;
        // Some Windows tools start UTF-8 text with a byte-order mark.
        let meta = sidecar::parse(&json_path, text.trim_start_matches('\u{feff}'))?;

        let mut file = BufReader::with_capacity(1 << 16, source);
        let (spec, samples) = {
            let header = hound::WavReader::new(&mut file).map_err(|e| {
                Error::format(
                    &wav_path,
                    "WAV header",
                    format!(
                        "expected RIFF/WAVE with a `fmt ` chunk then a `data` chunk \
                         (the header is corrupted or truncated): {e}"
                    ),
                )
            })?;
            (header.spec(), header.len() as u64)
        };
        // hound leaves the file at the first sample; the data chunk's size
        // sits just before it and gives the container size hound keeps private.
        let data_start = file
            .stream_position()
            .map_err(|e| Error::io(&wav_path, e))?;
        let mut chunk = [0u8; 8];
        file.seek(SeekFrom::Start(data_start - 8))
            .and_then(|_| file.read_exact(&mut chunk))
            .map_err(|e| Error::io(&wav_path, e))?;
        if &chunk[..4] != b"data" {
            return Err(Error::format(
                &wav_path,
                "data chunk",
                "expected the `data` tag",
            ));
        }
        let data_len = u32::from_le_bytes([chunk[4], chunk[5], chunk[6], chunk[7]]) as u64;
        let container = match samples {
            0 => spec.bits_per_sample.div_ceil(8) as u64,
            n => data_len / n,
        };
        let encoding = encoding_of(&wav_path, &spec, container)?;
        let channels = spec.channels as usize;
        let block_align = channels * encoding.bytes();
        let available = file_len.saturating_sub(data_start);
        if data_len > available {
            return Err(Error::format(
                &wav_path,
                "data chunk",
                format!(
                    "the header declares {data_len} bytes of samples ({} frames) but the file holds only {available}: truncated",
                    data_len / block_align as u64
                ),
            ));
        }
        let frames = usize::try_from(data_len / block_align as u64).map_err(|_| {
            Error::format(&wav_path, "data chunk", "too many frames for this platform")
        })?;

        if meta.sample_rate_hz != spec.sample_rate as f64 {
            return Err(Error::format(
                &json_path,
                "sample_rate_hz",
                format!(
                    "{} Hz differs from the WAV header's {} Hz ({})",
                    meta.sample_rate_hz,
                    spec.sample_rate,
                    wav_path.display()
                ),
            ));
        }
        if meta.channels.len() != channels {
            return Err(Error::format(
                &json_path,
                "channels",
                format!(
                    "{} channels described but the WAV header has {channels} ({})",
                    meta.channels.len(),
                    wav_path.display()
                ),
            ));
        }
        sidecar::check(&json_path, &meta, Some(frames as u64))?;
        let factors = meta
            .channels
            .iter()
            .map(|c| encoding.factor(c.scale))
            .collect();
        Ok(RecordingReader {
            wav_path,
            meta,
            file,
            encoding,
            data_start,
            frames,
            position: 0,
            factors,
            raw: Vec::new(),
        })
    }

    /// The sidecar.
    pub fn meta(&self) -> &RecordingMeta {
        &self.meta
    }

    /// Frames in the recording.
    pub fn frames(&self) -> usize {
        self.frames
    }

    /// The next frame [`RecordingReader::read_frames`] returns.
    pub fn position(&self) -> usize {
        self.position
    }

    /// Reads up to `max_frames` frames from the current position into `out`
    /// (one `Vec` per channel, each cleared first), in physical units (scale
    /// applied). Returns the number of frames read, 0 at the end.
    ///
    /// Errors if `out.len()` is not the channel count, if the file ends early
    /// or if a sample is not finite.
    pub fn read_frames(&mut self, max_frames: usize, out: &mut [Vec<f64>]) -> Result<usize> {
        for o in out.iter_mut() {
            o.clear();
        }
        self.append_frames(max_frames, out)
    }

    /// Moves to frame `frame` (`0..=frames()`).
    pub fn seek_frame(&mut self, frame: usize) -> Result<()> {
        if frame > self.frames {
            return Err(Error::input(
                format!("{} frame {frame}", self.wav_path.display()),
                format!("beyond the recording's {} frames", self.frames),
            ));
        }
        let block_align = (self.factors.len() * self.encoding.bytes()) as u64;
        let offset = self.data_start + frame as u64 * block_align;
        self.file
            .seek(SeekFrom::Start(offset))
            .map_err(|e| Error::io(&self.wav_path, e))?;
        self.position = frame;
        Ok(())
    }

    /// Skips `n` frames forward.
    pub fn skip_frames(&mut self, n: usize) -> Result<()> {
        self.seek_frame(self.position.saturating_add(n))
    }

    fn append_frames(&mut self, max_frames: usize, out: &mut [Vec<f64>]) -> Result<usize> {
        let channels = self.factors.len();
        if out.len() != channels {
            return Err(Error::input(
                "read_frames output",
                format!(
                    "expected one buffer per channel ({channels}), got {}",
                    out.len()
                ),
            ));
        }
        let n = max_frames.min(self.frames - self.position);
        for o in out.iter_mut() {
            o.reserve(n);
        }
        let bytes = self.encoding.bytes();
        let block_align = channels * bytes;
        let mut done = 0;
        while done < n {
            let m = (n - done).min(BLOCK_FRAMES);
            self.raw.resize(m * block_align, 0);
            self.file.read_exact(&mut self.raw).map_err(|e| {
                if e.kind() == std::io::ErrorKind::UnexpectedEof {
                    Error::format(
                        &self.wav_path,
                        "data chunk",
                        format!(
                            "the file ends inside frames {}..{} (truncated while being read?)",
                            self.position,
                            self.position + m
                        ),
                    )
                } else {
                    Error::io(&self.wav_path, e)
                }
            })?;
            for (c, o) in out.iter_mut().enumerate() {
                let k = self.factors[c];
                let start = o.len();
                let frames = self.raw.chunks_exact(block_align);
                match self.encoding {
                    Encoding::Pcm16 => o.extend(frames.map(|f| {
                        let s = &f[c * 2..c * 2 + 2];
                        i16::from_le_bytes([s[0], s[1]]) as f64 * k
                    })),
                    Encoding::Pcm24 => o.extend(frames.map(|f| {
                        let s = &f[c * 3..c * 3 + 3];
                        // Sign-extend by placing the 24 bits at the top of an i32.
                        (i32::from_le_bytes([0, s[0], s[1], s[2]]) >> 8) as f64 * k
                    })),
                    Encoding::Pcm32 => o.extend(frames.map(|f| {
                        let s = &f[c * 4..c * 4 + 4];
                        i32::from_le_bytes([s[0], s[1], s[2], s[3]]) as f64 * k
                    })),
                    Encoding::Float32 => o.extend(frames.map(|f| {
                        let s = &f[c * 4..c * 4 + 4];
                        f32::from_le_bytes([s[0], s[1], s[2], s[3]]) as f64 * k
                    })),
                }
                if let Some(i) = o[start..].iter().position(|x| !x.is_finite()) {
                    return Err(Error::format(
                        &self.wav_path,
                        format!(
                            "{}[frame {}]",
                            self.meta.channels[c].name,
                            self.position + i
                        ),
                        format!("sample is {} (samples must be finite)", o[start + i]),
                    ));
                }
            }
            self.position += m;
            done += m;
        }
        Ok(n)
    }
}

/// The reader is the file glue of the streaming reduction
/// ([`crate::extract::reduce_stepped_by_dwell`]), which knows no files.
impl super::FrameSource for RecordingReader {
    fn meta(&self) -> &RecordingMeta {
        &self.meta
    }

    fn frames(&self) -> usize {
        self.frames
    }

    fn source_name(&self) -> String {
        self.wav_path.display().to_string()
    }

    fn read_at(&mut self, start: usize, count: usize, out: &mut [Vec<f64>]) -> Result<usize> {
        self.seek_frame(start)?;
        self.read_frames(count, out)
    }
}

/// Reads a whole recording (`NAME.wav` + `NAME.json`; `path` is either file
/// or the stem) into memory, samples in physical units.
pub fn read_recording(path: &Path) -> Result<Recording> {
    read_all(RecordingReader::open(path)?)
}

/// [`read_recording`] on a recording already in memory (see
/// [`RecordingReader::from_bytes`]).
pub fn read_recording_bytes(path: &Path, json: &[u8], wav: Vec<u8>) -> Result<Recording> {
    read_all(RecordingReader::from_bytes(path, json, wav)?)
}

fn read_all(mut reader: RecordingReader) -> Result<Recording> {
    let frames = reader.frames();
    let mut channels = vec![Vec::with_capacity(frames); reader.factors.len()];
    while reader.append_frames(frames, &mut channels)? > 0 {}
    Ok(Recording {
        meta: reader.meta,
        channels,
    })
}

/// The samples' encoding from the `fmt` chunk and the data's container size
/// in bytes: IEEE float 32 or packed integer PCM 16/24/32.
fn encoding_of(wav_path: &Path, spec: &hound::WavSpec, container: u64) -> Result<Encoding> {
    Ok(
        match (spec.sample_format, container, spec.bits_per_sample) {
            (hound::SampleFormat::Int, 2, 16) => Encoding::Pcm16,
            (hound::SampleFormat::Int, 3, 24) => Encoding::Pcm24,
            (hound::SampleFormat::Int, 4, 32) => Encoding::Pcm32,
            (hound::SampleFormat::Float, 4, 32) => Encoding::Float32,
            (f, bytes, bits) => {
                return Err(Error::format(
                    wav_path,
                    "fmt chunk",
                    format!(
                        "{bits}-bit {} samples in {bytes}-byte containers are not supported; \
                     expected IEEE float 32 or packed integer PCM 16/24/32",
                        if f == hound::SampleFormat::Int {
                            "integer"
                        } else {
                            "float"
                        }
                    ),
                ));
            }
        },
    )
}

/// Writes `NAME.wav` + `NAME.json` (`path` is either file or the stem).
///
/// For the PCM formats each channel's `scale` is chosen so that its peak maps
/// to ±(2^(bits-1) − 1); a channel whose given scale already puts its peak
/// there (e.g. one just read from such a file) keeps it, so write → read →
/// write is byte-identical. `Float32` keeps the scales as given. Both files
/// go to temporary names first and are renamed only when both are complete.
pub fn write_recording(path: &Path, rec: &Recording, format: SampleFormat) -> Result<()> {
    let (wav_path, json_path) = recording_paths(path);
    let meta = &rec.meta;
    let frames = rec.frames();
    sidecar::check(&json_path, meta, Some(frames as u64))?;
    check_samples(rec, frames)?;
    let fs = meta.sample_rate_hz;
    if fs.fract() != 0.0 || fs > u32::MAX as f64 {
        return Err(Error::format(
            &json_path,
            "sample_rate_hz",
            format!(
                "a WAV file needs a whole number of Hz up to {}, got {fs}",
                u32::MAX
            ),
        ));
    }
    let bytes = (format.bits() / 8) as u64;
    let data_bytes = frames as u64 * meta.channels.len() as u64 * bytes;
    if data_bytes > u32::MAX as u64 - 128 {
        return Err(Error::input(
            wav_path.display().to_string(),
            format!("{data_bytes} bytes of samples exceed the WAV size limit of 4 GiB"),
        ));
    }

    let out_meta = stored_meta(rec, format)?;

    let spec = hound::WavSpec {
        channels: u16::try_from(meta.channels.len()).map_err(|_| {
            Error::input(
                "recording channels",
                "a WAV file holds at most 65535 channels",
            )
        })?,
        sample_rate: fs as u32,
        bits_per_sample: format.bits(),
        sample_format: if format == SampleFormat::Float32 {
            hound::SampleFormat::Float
        } else {
            hound::SampleFormat::Int
        },
    };
    let (wav_pending, wav_file) = PendingFile::create(&wav_path)?;
    let (json_pending, json_file) = PendingFile::create(&json_path)?;
    let tmp = wav_pending.temporary().to_path_buf();
    let hound_err = |e: hound::Error| match e {
        hound::Error::IoError(e) => Error::io(&tmp, e),
        e => Error::format(&tmp, "WAV", e.to_string()),
    };
    let mut w = BufWriter::with_capacity(1 << 16, wav_file);
    {
        let mut wav = hound::WavWriter::new(&mut w, spec).map_err(hound_err)?;
        let full = 2f64.powi(format.bits() as i32 - 1);
        for f in 0..frames {
            for (c, x) in rec.channels.iter().enumerate() {
                let v = x[f];
                let r = match format {
                    SampleFormat::Float32 => {
                        wav.write_sample((v / out_meta.channels[c].scale) as f32)
                    }
                    _ => wav.write_sample(quantise(v, out_meta.channels[c].scale, full)),
                };
                r.map_err(hound_err)?;
            }
        }
        wav.finalize().map_err(hound_err)?;
    }
    let wav_file = w
        .into_inner()
        .map_err(|e| Error::io(&tmp, e.into_error()))?;
    wav_file.sync_all().map_err(|e| Error::io(&tmp, e))?;

    let mut text = serde_json::to_vec_pretty(&out_meta)
        .map_err(|e| Error::format(&json_path, "(root)", e.to_string()))?;
    text.push(b'\n');
    let json_tmp = json_pending.temporary().to_path_buf();
    let mut json_file = json_file;
    json_file
        .write_all(&text)
        .and_then(|_| json_file.sync_all())
        .map_err(|e| Error::io(&json_tmp, e))?;

    wav_pending.commit()?;
    if let Err(e) = json_pending.commit() {
        // The new WAV must not sit beside an old sidecar.
        let _ = std::fs::remove_file(&wav_path);
        return Err(e);
    }
    Ok(())
}

/// Every described channel has its samples, as many as the first's, all
/// finite.
fn check_samples(rec: &Recording, frames: usize) -> Result<()> {
    let meta = &rec.meta;
    if rec.channels.len() != meta.channels.len() {
        return Err(Error::input(
            "recording channels",
            format!(
                "{} sample vectors for {} described channels",
                rec.channels.len(),
                meta.channels.len()
            ),
        ));
    }
    for (c, x) in rec.channels.iter().enumerate() {
        let name = &meta.channels[c].name;
        if x.len() != frames {
            return Err(Error::input(
                format!("channel `{name}`"),
                format!("{} samples where the first channel has {frames}", x.len()),
            ));
        }
        if let Some(i) = super::first_out_of_range(x, f64::MAX) {
            return Err(Error::input(
                format!("{name}[frame {i}]"),
                format!("sample is {}; samples must be finite", x[i]),
            ));
        }
    }
    Ok(())
}

/// The sidecar as stored: each channel's scale chosen for `format` (a
/// float channel checked against float32's range).
fn stored_meta(rec: &Recording, format: SampleFormat) -> Result<RecordingMeta> {
    let meta = &rec.meta;
    let mut out_meta = meta.clone();
    for (c, x) in rec.channels.iter().enumerate() {
        let scale = stored_scale(x, meta.channels[c].scale, format);
        if !scale.is_finite() {
            return Err(Error::input(
                format!("channel `{}`", meta.channels[c].name),
                "peak too large to give a finite PCM scale",
            ));
        }
        out_meta.channels[c].scale = scale;
        let overflow = |v: &f64| !((v / scale) as f32).is_finite();
        if format == SampleFormat::Float32
            && let Some(i) = x.iter().position(overflow)
        {
            return Err(Error::input(
                format!("{}[frame {i}]", meta.channels[c].name),
                format!(
                    "{} / scale {scale} exceeds the float32 range; give the channel a larger scale",
                    x[i]
                ),
            ));
        }
    }
    Ok(out_meta)
}

/// The integer stored for physical value `v` at scale `scale`, full scale
/// `full = 2^(bits-1)`.
#[inline]
fn quantise(v: f64, scale: f64, full: f64) -> i32 {
    (v / scale * full).round().clamp(-full, full - 1.0) as i32
}

/// The scale a channel is stored with.
fn stored_scale(x: &[f64], given: f64, format: SampleFormat) -> f64 {
    if format == SampleFormat::Float32 {
        return given;
    }
    let full = 2f64.powi(format.bits() as i32 - 1);
    // Keep the given scale when it already uses the full range: then every
    // sample read from such a file quantises back to its own integer.
    let mut fits = true;
    let mut peak_code = 0.0f64;
    let mut peak = 0.0f64;
    for &v in x {
        let k = (v / given * full).round();
        fits &= k >= -full && k <= full - 1.0;
        peak_code = peak_code.max(k.abs());
        peak = peak.max(v.abs());
    }
    if peak == 0.0 || (fits && peak_code >= full - 1.0) {
        return given;
    }
    peak * full / (full - 1.0)
}

/// A recording written as it is produced (IEEE float 32), for runs too long
/// to hold in memory: frames go straight to a temporary WAV, the sidecar is
/// written at [`RecordingWriter::finish`], and only then are both renamed
/// into place. Dropped without `finish`, it leaves nothing behind.
pub struct RecordingWriter {
    wav_path: PathBuf,
    json_path: PathBuf,
    wav_pending: PendingFile,
    writer: Option<hound::WavWriter<BufWriter<File>>>,
    meta: RecordingMeta,
    frames: u64,
}

impl std::fmt::Debug for RecordingWriter {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("RecordingWriter")
            .field("wav", &self.wav_path)
            .field("frames", &self.frames)
            .finish()
    }
}

impl RecordingWriter {
    /// Starts `NAME.wav` (`path` is the WAV, the JSON or the stem); `meta`
    /// describes the channels and sample rate (its excitation may be
    /// completed before `finish`).
    pub fn create(path: &Path, meta: RecordingMeta) -> Result<RecordingWriter> {
        let (wav_path, json_path) = recording_paths(path);
        sidecar::check(&json_path, &meta, None)?;
        let fs = meta.sample_rate_hz;
        if fs.fract() != 0.0 || fs > u32::MAX as f64 {
            return Err(Error::format(
                &json_path,
                "sample_rate_hz",
                format!("a WAV file needs a whole number of Hz, got {fs}"),
            ));
        }
        let spec = hound::WavSpec {
            channels: u16::try_from(meta.channels.len()).map_err(|_| {
                Error::input(
                    "recording channels",
                    "a WAV file holds at most 65535 channels",
                )
            })?,
            sample_rate: fs as u32,
            bits_per_sample: 32,
            sample_format: hound::SampleFormat::Float,
        };
        let (wav_pending, file) = PendingFile::create(&wav_path)?;
        let tmp = wav_pending.temporary().to_path_buf();
        let writer = hound::WavWriter::new(BufWriter::with_capacity(1 << 16, file), spec)
            .map_err(|e| Error::format(&tmp, "WAV", e.to_string()))?;
        Ok(RecordingWriter {
            wav_path,
            json_path,
            wav_pending,
            writer: Some(writer),
            meta,
            frames: 0,
        })
    }

    /// Appends frames: one slice per channel, physical units (divided by the
    /// channel's scale on the way out), all the same length.
    pub fn write_frames(&mut self, channels: &[&[f32]]) -> Result<()> {
        if channels.len() != self.meta.channels.len() {
            return Err(Error::input(
                "recording channels",
                format!(
                    "{} slices for {} channels",
                    channels.len(),
                    self.meta.channels.len()
                ),
            ));
        }
        let n = channels.first().map_or(0, |c| c.len());
        for (c, x) in channels.iter().enumerate() {
            if x.len() != n {
                return Err(Error::input(
                    format!("channel `{}`", self.meta.channels[c].name),
                    "slices differ in length",
                ));
            }
            if let Some(i) = x.iter().position(|v| !v.is_finite()) {
                return Err(Error::input(
                    format!(
                        "{}[frame {}]",
                        self.meta.channels[c].name,
                        self.frames + i as u64
                    ),
                    format!("sample is {}; samples must be finite", x[i]),
                ));
            }
        }
        let tmp = self.wav_pending.temporary().to_path_buf();
        let w = self.writer.as_mut().expect("writer open until finish");
        let scales: Vec<f32> = self.meta.channels.iter().map(|c| c.scale as f32).collect();
        for f in 0..n {
            for (c, x) in channels.iter().enumerate() {
                let v = if scales[c] == 1.0 {
                    x[f]
                } else {
                    x[f] / scales[c]
                };
                w.write_sample(v)
                    .map_err(|e| Error::format(&tmp, "WAV", e.to_string()))?;
            }
        }
        self.frames += n as u64;
        Ok(())
    }

    /// Frames written so far.
    pub fn frames(&self) -> u64 {
        self.frames
    }

    /// The sidecar, to complete (e.g. the dwells) before `finish`.
    pub fn meta_mut(&mut self) -> &mut RecordingMeta {
        &mut self.meta
    }

    /// Finalises the WAV, writes the sidecar, and renames both into place.
    pub fn finish(mut self) -> Result<()> {
        let tmp = self.wav_pending.temporary().to_path_buf();
        self.writer
            .take()
            .expect("writer open until finish")
            .finalize()
            .map_err(|e| Error::format(&tmp, "WAV", e.to_string()))?;
        File::open(&tmp)
            .and_then(|f| f.sync_all())
            .map_err(|e| Error::io(&tmp, e))?;
        sidecar::check(&self.json_path, &self.meta, Some(self.frames))?;
        let mut text = serde_json::to_vec_pretty(&self.meta)
            .map_err(|e| Error::format(&self.json_path, "(root)", e.to_string()))?;
        text.push(b'\n');
        let (json_pending, mut json_file) = PendingFile::create(&self.json_path)?;
        json_file
            .write_all(&text)
            .and_then(|_| json_file.sync_all())
            .map_err(|e| Error::io(json_pending.temporary(), e))?;
        let wav_path = self.wav_path.clone();
        let RecordingWriter { wav_pending, .. } = self;
        wav_pending.commit()?;
        if let Err(e) = json_pending.commit() {
            let _ = std::fs::remove_file(&wav_path);
            return Err(e);
        }
        Ok(())
    }
}
