//! A plain WAV file: one without hystid's JSON sidecar (an audio
//! interface's or a data logger's export). The file says how many channels
//! it holds and at what rate, not what they measure: the spec's channels
//! say that, each chosen by number (`#K`, from 1).
//!
//! Integer samples are read as fractions of full scale (-1 to 1), as
//! MATLAB's `audioread` and Python's `soundfile` read them; float samples as
//! stored. A channel's `scale` turns either into physical units.

use super::{Column, ImportSpec, Loaded, SampleRateSource};
use crate::{Error, Result};
use std::path::Path;

/// Whether `path` is a WAV file, there, without its JSON sidecar
/// (`NAME.json` beside `NAME.wav`): not a hystid recording, so
/// [`super::import`] reads it as a plain WAV.
pub fn is_plain_wav(path: &Path) -> bool {
    let is_wav = path
        .extension()
        .and_then(|e| e.to_str())
        .is_some_and(|e| e.eq_ignore_ascii_case("wav"));
    is_wav && path.is_file() && !path.with_extension("json").exists()
}

/// What a plain WAV's header says: channels and sample rate.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct WavShape {
    /// Interleaved channels.
    pub channels: u16,
    /// Whole Hz.
    pub sample_rate_hz: u32,
}

fn open(path: &Path) -> Result<hound::WavReader<std::io::BufReader<std::fs::File>>> {
    hound::WavReader::open(path).map_err(|e| match e {
        hound::Error::IoError(io) => Error::io(path, io),
        e => Error::format(
            path,
            "WAV header",
            format!("expected RIFF/WAVE with a `fmt ` chunk then a `data` chunk: {e}"),
        ),
    })
}

/// The channels and rate in `path`'s header.
pub fn shape(path: &Path) -> Result<WavShape> {
    let s = open(path)?.spec();
    Ok(WavShape {
        channels: s.channels,
        sample_rate_hz: s.sample_rate,
    })
}

pub(crate) fn load(path: &Path, spec: &ImportSpec) -> Result<Loaded> {
    let mut reader = open(path)?;
    let header = reader.spec();
    let n = header.channels as usize;
    let columns = wav_columns(path, spec, n)?;
    let frames = reader.duration() as usize;
    let mut all: Vec<Vec<f64>> = vec![Vec::with_capacity(frames); n];
    let bad = |e: hound::Error| match e {
        hound::Error::IoError(io) => Error::io(path, io),
        e => Error::format(path, "data chunk", e.to_string()),
    };
    match header.sample_format {
        hound::SampleFormat::Float => {
            for (i, s) in reader.samples::<f32>().enumerate() {
                all[i % n].push(f64::from(s.map_err(bad)?));
            }
        }
        hound::SampleFormat::Int => {
            let full = 2f64.powi(i32::from(header.bits_per_sample) - 1);
            for (i, s) in reader.samples::<i32>().enumerate() {
                all[i % n].push(f64::from(s.map_err(bad)?) / full);
            }
        }
    }
    let header_rate = f64::from(header.sample_rate);
    let mut notes = Vec::new();
    let (rate, origin) = wav_rate(path, spec, header_rate, &mut notes)?;
    let mut meta = serde_json::Map::new();
    meta.insert("format".into(), "plain WAV".into());
    meta.insert("wav_channels".into(), n.into());
    meta.insert("bits_per_sample".into(), header.bits_per_sample.into());
    meta.insert(
        "sample_format".into(),
        match header.sample_format {
            hound::SampleFormat::Float => "float",
            hound::SampleFormat::Int => "integer, read as a fraction of full scale",
        }
        .into(),
    );
    let values = columns.iter().map(|&c| all[c].clone()).collect();
    Ok(Loaded {
        values,
        sample_rate_hz: rate,
        rate_origin: origin,
        rate_declared: true,
        time: None,
        metadata: meta,
        source_texts: spec
            .channels
            .iter()
            .map(|c| match c.source {
                Column::Index(i) => format!("WAV channel {i}"),
                Column::Name(_) => unreachable!("refused above"),
            })
            .collect(),
        notes,
    })
}

/// The WAV channel (from 0) of each channel of `spec`: chosen by number, #1
/// to #`n`, never by name or row.
fn wav_columns(path: &Path, spec: &ImportSpec, n: usize) -> Result<Vec<usize>> {
    let mut columns = Vec::with_capacity(spec.channels.len());
    for (k, c) in spec.channels.iter().enumerate() {
        let field = format!("channels[{k}].source");
        match (&c.source, c.row) {
            (Column::Index(i), None) if (1..=n).contains(i) => columns.push(i - 1),
            (Column::Index(i), None) => {
                return Err(Error::format(
                    path,
                    field,
                    format!("channel #{i}: the WAV holds {n} channel(s), #1 to #{n}"),
                ));
            }
            (_, Some(_)) => {
                return Err(Error::format(
                    path,
                    format!("channels[{k}].row"),
                    "a WAV's channels have no rows: choose each by number, #1 to #{n}",
                ));
            }
            (Column::Name(name), None) => {
                return Err(Error::format(
                    path,
                    field,
                    format!(
                        "`{name}`: a WAV's channels have no names: choose each by number, \
                         #1 to #{n} (e.g. -c {name}=#1:force)"
                    ),
                ));
            }
        }
    }
    Ok(columns)
}

/// The sample rate and where it comes from: the header's, or the one given
/// (a note says it replaces the header's); no other source applies.
fn wav_rate(
    path: &Path,
    spec: &ImportSpec,
    header_rate: f64,
    notes: &mut Vec<String>,
) -> Result<(f64, String)> {
    Ok(match &spec.sample_rate {
        SampleRateSource::Auto => (header_rate, format!("WAV header: {header_rate} Hz")),
        SampleRateSource::Value(v) => {
            if *v != header_rate {
                notes.push(format!(
                    "sample rate {v} Hz as given, in place of the WAV header's {header_rate} Hz"
                ));
            }
            (*v, format!("given: {v} Hz"))
        }
        other => {
            let text = match other {
                SampleRateSource::Comment => "comment".to_string(),
                SampleRateSource::Variable(v) => format!("variable:{v}"),
                _ => "time:...".to_string(),
            };
            return Err(Error::format(
                path,
                "sample_rate",
                format!(
                    "`{text}` does not apply to a WAV file (its header says {header_rate} Hz): \
                     leave --rate out, or give a number of Hz"
                ),
            ));
        }
    })
}
