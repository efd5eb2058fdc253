//! Import: the formats real data comes in, converted into a [`Recording`].
//!
//! Measured data rarely arrives as hystid's own WAV + JSON recording
//! (`docs/src/reference/recording-format.md`). This stage reads the two formats
//! the benchmark data sets use and turns the chosen signals into a
//! [`Recording`] in memory (samples in physical units, calibration, quantity
//! and unit kept per channel), plus a [`QualityReport`] of the data:
//!
//! * MATLAB level-5 MAT-files with numeric arrays ([`mat`]): the F-16 GVT
//!   benchmark (`Force` 1xN, `Acceleration` 3xN, `Fs`), the Bouc-Wen
//!   benchmark (`uval_sinesweep`, ...), compressed or not.
//! * Delimited text, CSV/TSV/whitespace ([`delimited`]): a header row after
//!   optional `#` comment lines, as the UNESP BERT CSVs have.
//! * Universal File Format dataset 58, ASCII and binary 58b ([`uff`]): the
//!   time records of Testlab, ME'scope or pyuff. Such a file says what its
//!   channels are (quantity, units, node and direction, sample spacing), so
//!   a spec without channels imports all of them ([`names_its_channels`]).
//!
//! What to take from the file is an [`ImportSpec`] (serde data, so the CLI
//! can build it from flags or a TOML table): which variables or columns
//! become channels, with quantity, unit and scale, where the sample rate
//! comes from, and what the excitation was. [`import`] dispatches on the file
//! extension, builds the recording and runs the data-quality checks of
//! [`quality`] on it.
//!
//! Indices in an [`ImportSpec`] count from 1, as MATLAB and spreadsheets do:
//! `row = 2` of the F-16 `Acceleration` is the benchmark's "acceleration 2",
//! and `column = 1` is the first column of a CSV file.
//!
//! ```toml
//! # F-16 level 1: force and the wing-side interface acceleration
//! sample_rate = { variable = "Fs" }
//! [[channels]]
//! variable = "Force"
//! name = "force"
//! quantity = "force"
//! [[channels]]
//! variable = "Acceleration"
//! row = 2
//! name = "acc2"
//! quantity = "acceleration"
//! ```

pub mod delimited;
pub mod mat;
pub mod quality;
pub mod uff;
pub mod wav;

pub use quality::{
    Finding, FindingKind, QualityOptions, QualityReport, Severity, Span, check_quality,
};

use crate::harmonics::Quantity;
use crate::record::{Channel, Excitation, ExcitationKind, FORMAT_V1, Recording, RecordingMeta};
use crate::{Error, Result};
use serde::{Deserialize, Serialize};
use std::path::Path;

/// Where a channel's samples are in the file: a name (MAT variable, CSV
/// header) or a 1-based column number (CSV only).
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(untagged)]
pub enum Column {
    /// Column number, counted from 1.
    Index(usize),
    /// Variable or column name, matched exactly.
    Name(String),
}

impl From<&str> for Column {
    fn from(s: &str) -> Column {
        Column::Name(s.to_string())
    }
}

impl From<String> for Column {
    fn from(s: String) -> Column {
        Column::Name(s)
    }
}

impl From<usize> for Column {
    fn from(i: usize) -> Column {
        Column::Index(i)
    }
}

impl std::fmt::Display for Column {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Column::Index(i) => write!(f, "column {i}"),
            Column::Name(n) => f.write_str(n),
        }
    }
}

/// One channel to import.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ChannelSpec {
    /// The MAT variable, or the CSV column (header name or number from 1).
    /// In TOML also spelled `variable` or `column`.
    #[serde(alias = "variable", alias = "column")]
    pub source: Column,
    /// MAT only: which signal of a 2-D variable, counted from 1 (the row of a
    /// `kxN` matrix, the column of an `Nxk` one).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub row: Option<usize>,
    /// Channel name in the recording; default: the source name (with
    /// `_<row>` for a matrix row, `column_<k>` for a numbered column).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub name: Option<String>,
    /// Physical quantity.
    pub quantity: Quantity,
    /// SI unit of the physical values; default and only accepted value: the
    /// quantity's SI unit (`N`, `m`, `m/s`, `m/s^2`, `V`). Data in other units
    /// is converted with `scale`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub unit: Option<String>,
    /// Calibration: physical value = value in the file × scale.
    #[serde(default = "one")]
    pub scale: f64,
    /// Full scale of the acquisition channel in physical units, if known:
    /// samples at or beyond it count as clipped.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub full_scale: Option<f64>,
}

fn one() -> f64 {
    1.0
}

impl ChannelSpec {
    /// A channel from `source` with the quantity's SI unit and scale 1.
    pub fn new(source: impl Into<Column>, quantity: Quantity) -> ChannelSpec {
        ChannelSpec {
            source: source.into(),
            row: None,
            name: None,
            quantity,
            unit: None,
            scale: 1.0,
            full_scale: None,
        }
    }

    /// Sets the 1-based row of a matrix variable.
    pub fn row(mut self, row: usize) -> ChannelSpec {
        self.row = Some(row);
        self
    }

    /// Sets the channel name.
    pub fn name(mut self, name: impl Into<String>) -> ChannelSpec {
        self.name = Some(name.into());
        self
    }

    /// Sets the calibration scale.
    pub fn scale(mut self, scale: f64) -> ChannelSpec {
        self.scale = scale;
        self
    }

    /// Sets the full scale (physical units).
    pub fn full_scale(mut self, full_scale: f64) -> ChannelSpec {
        self.full_scale = Some(full_scale);
        self
    }

    /// The channel's name in the recording.
    pub fn channel_name(&self) -> String {
        if let Some(n) = &self.name {
            return n.clone();
        }
        match (&self.source, self.row) {
            (Column::Name(n), Some(r)) => format!("{n}_{r}"),
            (Column::Name(n), None) => n.clone(),
            (Column::Index(i), _) => format!("column_{i}"),
        }
    }

    /// How the source reads in messages: `Acceleration(row 2)`, `laser`.
    pub fn source_text(&self) -> String {
        match self.row {
            Some(r) => format!("{}(row {r})", self.source),
            None => self.source.to_string(),
        }
    }
}

/// Where the sample rate comes from.
///
/// TOML: `sample_rate = { value = 400.0 }`, `{ variable = "Fs" }`,
/// `{ time = "time_s" }`, `"comment"` or `"auto"`.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum SampleRateSource {
    /// MAT: a scalar variable named `Fs` (or `fs`, `fsamp`, `sample_rate`,
    /// `samplerate`, `sampling_rate`, any case). Text: a comment such as
    /// `# fs = 1024 Hz`, else a time column (header starting with `time`, or
    /// `t`).
    #[default]
    Auto,
    /// Given, Hz.
    Value(f64),
    /// MAT: a positive scalar variable, Hz.
    Variable(String),
    /// Text: a `#` comment line before the header (`fs = 1024 Hz`,
    /// `sample rate: 2 kHz`, ...).
    Comment,
    /// A time column (text) or time vector (MAT) in seconds, uniformly spaced.
    Time(Column),
}

/// The compact command-line form of a channel:
/// `[NAME=]SOURCE[(ROW)]:QUANTITY[*SCALE]`, where `SOURCE` is a variable or
/// column name, or `#K` for column number `K` (from 1).
///
/// Examples: `force=Force:force`, `acc2=Acceleration(2):acceleration`,
/// `laser=#3:velocity*1e-3`. Names holding `=`, `:` or `(` need the TOML
/// form.
impl std::str::FromStr for ChannelSpec {
    type Err = Error;
    fn from_str(text: &str) -> Result<ChannelSpec> {
        let bad = |m: String| {
            Error::plan(
                "channel",
                format!("`{text}`: {m} (expected [NAME=]SOURCE[(ROW)]:QUANTITY[*SCALE])"),
            )
        };
        let (left, right) = text
            .rsplit_once(':')
            .ok_or_else(|| bad("no `:QUANTITY`".into()))?;
        let (quantity, scale) = match right.split_once('*') {
            Some((q, s)) => (
                q,
                s.trim()
                    .parse::<f64>()
                    .map_err(|_| bad(format!("scale `{s}` is not a number")))?,
            ),
            None => (right, 1.0),
        };
        let quantity = Quantity::from_name(quantity.trim()).ok_or_else(|| {
            bad(format!(
                "quantity `{quantity}` is not one of {}",
                Quantity::names()
            ))
        })?;
        let (name, source) = match left.split_once('=') {
            Some((n, s)) => (Some(n.trim().to_string()), s.trim()),
            None => (None, left.trim()),
        };
        let (source, row) = match source.strip_suffix(')').and_then(|s| s.split_once('(')) {
            Some((s, r)) => (
                s.trim(),
                Some(
                    r.trim()
                        .parse::<usize>()
                        .map_err(|_| bad(format!("row `{r}` is not a number")))?,
                ),
            ),
            None => (source, None),
        };
        let source = match source.strip_prefix('#') {
            Some(k) => Column::Index(
                k.parse()
                    .map_err(|_| bad(format!("column number `{k}` is not a number")))?,
            ),
            None if source.is_empty() => return Err(bad("no SOURCE".into())),
            None => Column::Name(source.to_string()),
        };
        Ok(ChannelSpec {
            source,
            row,
            name,
            quantity,
            unit: None,
            scale,
            full_scale: None,
        })
    }
}

/// The compact command-line form: `auto`, `comment`, a number of Hz
/// (`400`), `variable:NAME` or `time:COLUMN` (`time:#1` for a column
/// number).
impl std::str::FromStr for SampleRateSource {
    type Err = Error;
    fn from_str(text: &str) -> Result<SampleRateSource> {
        let t = text.trim();
        let hz = t
            .strip_suffix("Hz")
            .or_else(|| t.strip_suffix("hz"))
            .unwrap_or(t)
            .trim();
        Ok(match t {
            "auto" => SampleRateSource::Auto,
            "comment" => SampleRateSource::Comment,
            _ => {
                if let Ok(v) = hz.parse::<f64>() {
                    SampleRateSource::Value(v)
                } else if let Some(v) = t.strip_prefix("variable:") {
                    SampleRateSource::Variable(v.trim().to_string())
                } else if let Some(c) = t.strip_prefix("time:") {
                    let c = c.trim();
                    SampleRateSource::Time(match c.strip_prefix('#').map(str::parse) {
                        Some(Ok(k)) => Column::Index(k),
                        _ => Column::Name(c.to_string()),
                    })
                } else {
                    return Err(Error::plan(
                        "sample_rate",
                        format!(
                            "`{text}`: expected auto, comment, a rate in Hz, variable:NAME or time:COLUMN"
                        ),
                    ));
                }
            }
        })
    }
}

/// Column separator of a text file.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(try_from = "String", into = "String")]
pub enum Delimiter {
    /// One ASCII character (`,`, `;`, tab, `|`).
    Char(u8),
    /// Runs of spaces and tabs.
    Whitespace,
}

/// A delimiter text that names no delimiter (serde's `try_from` needs only
/// `Display`, so the reason stays typed).
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
#[error(
    "delimiter `{0}`: expected one ASCII character, `tab`, `comma`, `semicolon` or `whitespace`"
)]
pub struct UnknownDelimiter(pub String);

impl TryFrom<String> for Delimiter {
    type Error = UnknownDelimiter;
    fn try_from(s: String) -> std::result::Result<Delimiter, UnknownDelimiter> {
        Ok(match s.as_str() {
            "tab" | "\t" | "\\t" => Delimiter::Char(b'\t'),
            "comma" => Delimiter::Char(b','),
            "semicolon" => Delimiter::Char(b';'),
            "whitespace" | "space" | " " => Delimiter::Whitespace,
            c if c.len() == 1 && c.is_ascii() && c != "\"" && c != "#" => {
                Delimiter::Char(c.as_bytes()[0])
            }
            _ => return Err(UnknownDelimiter(s)),
        })
    }
}

impl From<Delimiter> for String {
    fn from(d: Delimiter) -> String {
        match d {
            Delimiter::Char(b'\t') => "tab".into(),
            Delimiter::Char(c) => (c as char).to_string(),
            Delimiter::Whitespace => "whitespace".into(),
        }
    }
}

/// What to import from a file.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ImportSpec {
    /// The channels, in recording order (put the force or drive first by
    /// convention; the reference channel is the first `force`, else the
    /// first `voltage` channel wherever it is).
    pub channels: Vec<ChannelSpec>,
    /// Where the sample rate comes from.
    #[serde(default)]
    pub sample_rate: SampleRateSource,
    /// A time column (text) or time vector (MAT), in seconds, to check the
    /// sample rate against when the rate is declared. Default for text: a
    /// column whose header starts with `time` (any case) or is `t`, if any;
    /// for MAT: none.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub time_column: Option<Column>,
    /// Text only: the separator; default: detected from the header and the
    /// first rows (tab, comma, semicolon, `|`, else whitespace).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub delimiter: Option<Delimiter>,
    /// What drove the structure, if known (kept in the recording).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub excitation: Option<Excitation>,
    /// Free text for the recording.
    #[serde(default)]
    pub description: String,
    /// Thresholds of the data-quality checks.
    #[serde(default)]
    pub quality: QualityOptions,
}

impl ImportSpec {
    /// A spec with these channels and sample-rate source, defaults elsewhere.
    pub fn new(channels: Vec<ChannelSpec>, sample_rate: SampleRateSource) -> ImportSpec {
        ImportSpec {
            channels,
            sample_rate,
            ..ImportSpec::default()
        }
    }
}

/// An imported recording and the quality of its data.
#[derive(Clone, Debug)]
pub struct Imported {
    /// The recording, samples in physical units.
    pub recording: Recording,
    /// Data-quality findings; `quality.has_errors()` means NaN/Inf (or a
    /// broken time axis) that an identification must not use.
    pub quality: QualityReport,
    /// What the reader left out or assumed (a UFF file's other datasets, a
    /// missing units label), one sentence each.
    pub notes: Vec<String>,
}

/// What a format reader hands back: raw channel values (file units, before
/// scale), the sample rate and where it came from, and a time axis to check.
pub(crate) struct Loaded {
    /// One vector per spec channel, in spec order, values as in the file.
    pub values: Vec<Vec<f64>>,
    /// Sample rate, Hz.
    pub sample_rate_hz: f64,
    /// Where the rate came from, for the metadata (`variable Fs`, ...).
    pub rate_origin: String,
    /// Whether the rate was declared (given, variable, comment) rather than
    /// derived from the time axis.
    pub rate_declared: bool,
    /// A time axis (seconds) to check, with its name.
    pub time: Option<(String, Vec<f64>)>,
    /// Format-specific metadata (`import` section).
    pub metadata: serde_json::Map<String, serde_json::Value>,
    /// How each channel's source reads in the metadata, where the spec's
    /// own text would mislead (a UFF `#3` is a dataset, not a column); empty:
    /// the spec's.
    pub source_texts: Vec<String>,
    /// Notes for [`Imported::notes`].
    pub notes: Vec<String>,
}

/// Imports `source` as `spec` says: dispatches on the extension (`.mat`;
/// `.csv`, `.tsv`, `.txt`, `.dat`; UFF: [`UFF_EXTENSIONS`]), applies
/// calibration, checks units and names, keeps the excitation in the
/// recording and runs
/// [`check_quality`] (plus, for a time column, the rate and jitter checks of
/// [`quality::check_time_axis`]).
///
/// Errors name the file and the variable, column or row at fault.
pub fn import(source: &Path, spec: &ImportSpec) -> Result<Imported> {
    let ext = extension(source);
    if UFF_EXTENSIONS.contains(&ext.as_str()) {
        let file = uff::UffFile::open(source)?;
        let (spec, loaded) = uff::load(source, &file, spec)?;
        validate_spec(source, &spec)?;
        return build(source, &spec, loaded);
    }
    validate_spec(source, spec)?;
    let loaded = match ext.as_str() {
        "mat" => mat_load(source, spec)?,
        "csv" | "tsv" | "txt" | "dat" => delimited::load(source, spec)?,
        "wav" if wav::is_plain_wav(source) => wav::load(source, spec)?,
        "wav" | "json" => {
            return Err(Error::format(
                source,
                "extension",
                "a WAV + JSON recording is already in hystid's format: use record::read_recording",
            ));
        }
        other => {
            return Err(Error::format(
                source,
                "extension",
                format!(
                    "`.{other}` is not a supported import format (expected .mat, .csv, .tsv, \
                     .txt, .dat, or UFF: .uff, .unv, .58, .bunv, .ufb)"
                ),
            ));
        }
    };
    build(source, spec, loaded)
}

/// Extensions read as Universal File Format ([`uff`]).
pub const UFF_EXTENSIONS: [&str; 5] = ["uff", "unv", "58", "bunv", "ufb"];

fn extension(path: &Path) -> String {
    path.extension()
        .and_then(|e| e.to_str())
        .map(|e| e.to_ascii_lowercase())
        .unwrap_or_default()
}

/// Extensions [`import`] reads besides UFF's ([`UFF_EXTENSIONS`]).
pub const EXTENSIONS: [&str; 6] = ["mat", "csv", "tsv", "txt", "dat", "wav"];

/// Whether [`import`] reads `path`, by its extension (a WAV only without
/// its JSON sidecar: with one it is already a recording).
pub fn reads(path: &Path) -> bool {
    let ext = extension(path);
    UFF_EXTENSIONS.contains(&ext.as_str())
        || (EXTENSIONS.contains(&ext.as_str()) && (ext != "wav" || wav::is_plain_wav(path)))
}

/// Whether the file says what its channels are, so that an [`ImportSpec`]
/// without channels imports them all (a UFF file's time records, by their
/// record 9), rather than being an error.
pub fn names_its_channels(path: &Path) -> bool {
    UFF_EXTENSIONS.contains(&extension(path).as_str())
}

/// Checks the parts of the spec that do not need the file.
fn validate_spec(path: &Path, spec: &ImportSpec) -> Result<()> {
    if spec.channels.is_empty() {
        return Err(Error::plan(
            "channels",
            format!(
                "no channels selected for {}: give at least one",
                path.display()
            ),
        ));
    }
    let mut names: Vec<String> = Vec::new();
    for (k, c) in spec.channels.iter().enumerate() {
        let field = format!("channels[{k}]");
        let name = c.channel_name();
        if name.trim().is_empty() {
            return Err(Error::plan(format!("{field}.name"), "must not be empty"));
        }
        if names.contains(&name) {
            return Err(Error::plan(
                format!("{field}.name"),
                format!("`{name}` is used twice; channel names must be unique"),
            ));
        }
        names.push(name);
        if !(c.scale.is_finite() && c.scale != 0.0) {
            return Err(Error::plan(
                format!("{field}.scale"),
                format!("must be a finite, non-zero number, got {}", c.scale),
            ));
        }
        if let Some(fs) = c.full_scale
            && !(fs.is_finite() && fs > 0.0)
        {
            return Err(Error::plan(
                format!("{field}.full_scale"),
                format!("must be a finite number > 0, got {fs}"),
            ));
        }
        if let Some(u) = &c.unit {
            let si = c.quantity.si_unit();
            if normalise_unit(u) != si {
                return Err(Error::plan(
                    format!("{field}.unit"),
                    format!(
                        "`{u}` for a {} channel: recordings hold SI units ({si}); \
                         convert with `scale` (e.g. scale = 9.80665 for g, 1e-3 for mm)",
                        c.quantity
                    ),
                ));
            }
        }
        if c.row == Some(0) {
            return Err(Error::plan(
                format!("{field}.row"),
                "rows are counted from 1, as in MATLAB",
            ));
        }
        if c.source == Column::Index(0) {
            return Err(Error::plan(
                format!("{field}.source"),
                "columns are counted from 1",
            ));
        }
    }
    if let SampleRateSource::Value(v) = spec.sample_rate
        && !(v.is_finite() && v > 0.0)
    {
        return Err(Error::plan(
            "sample_rate.value",
            format!("must be a finite number of Hz > 0, got {v}"),
        ));
    }
    if let Some(ex) = &spec.excitation {
        validate_excitation(ex)?;
    }
    Ok(())
}

fn normalise_unit(u: &str) -> &str {
    match u.trim() {
        "m/s²" | "m/s2" | "m/s/s" | "m s^-2" => "m/s^2",
        "m s^-1" => "m/s",
        other => other,
    }
}

fn validate_excitation(ex: &Excitation) -> Result<()> {
    if let Some(s) = &ex.sweep {
        for (f, v) in [
            ("excitation.sweep.f_start_hz", s.f_start_hz),
            ("excitation.sweep.f_end_hz", s.f_end_hz),
        ] {
            if !(v.is_finite() && v > 0.0) {
                return Err(Error::plan(
                    f,
                    format!("must be a finite frequency > 0, got {v}"),
                ));
            }
        }
        if let Some(r) = s.rate_hz_per_s
            && !(r.is_finite() && r != 0.0)
        {
            return Err(Error::plan(
                "excitation.sweep.rate_hz_per_s",
                format!("must be finite and non-zero, got {r}"),
            ));
        }
    }
    for (k, st) in ex.steps.iter().enumerate() {
        if !(st.frequency_hz.is_finite() && st.frequency_hz > 0.0) {
            return Err(Error::plan(
                format!("excitation.steps[{k}].frequency_hz"),
                format!("must be a finite frequency > 0, got {}", st.frequency_hz),
            ));
        }
        if st.length == 0 || st.settle >= st.length {
            return Err(Error::plan(
                format!("excitation.steps[{k}]"),
                format!(
                    "length {} must be > 0 and larger than settle {}",
                    st.length, st.settle
                ),
            ));
        }
    }
    Ok(())
}

/// Builds the recording, applies scale, runs the checks.
fn build(path: &Path, spec: &ImportSpec, loaded: Loaded) -> Result<Imported> {
    let Loaded {
        values,
        sample_rate_hz,
        rate_origin,
        rate_declared,
        time,
        mut metadata,
        source_texts,
        notes,
    } = loaded;
    if !(sample_rate_hz.is_finite() && sample_rate_hz > 0.0) {
        return Err(Error::format(
            path,
            "sample rate",
            format!("{rate_origin} gives {sample_rate_hz} Hz; expected a finite rate > 0"),
        ));
    }
    check_lengths(path, spec, &values)?;
    let channels: Vec<Channel> = spec
        .channels
        .iter()
        .map(|c| Channel {
            name: c.channel_name(),
            quantity: c.quantity,
            unit: c.quantity.si_unit().to_string(),
            scale: c.scale,
        })
        .collect();
    let samples: Vec<Vec<f64>> = values
        .into_iter()
        .zip(&spec.channels)
        .map(|(mut v, c)| {
            if c.scale != 1.0 {
                for x in &mut v {
                    *x *= c.scale;
                }
            }
            v
        })
        .collect();
    let file_name = path
        .file_name()
        .map(|f| f.to_string_lossy().into_owned())
        .unwrap_or_default();
    metadata.insert("source".into(), file_name.into());
    metadata.insert("sample_rate".into(), rate_origin.clone().into());
    let sources: serde_json::Map<String, serde_json::Value> = spec
        .channels
        .iter()
        .enumerate()
        .map(|(k, c)| {
            let text = source_texts
                .get(k)
                .cloned()
                .unwrap_or_else(|| c.source_text());
            (c.channel_name(), text.into())
        })
        .collect();
    metadata.insert("channels".into(), sources.into());
    let mut meta_map = serde_json::Map::new();
    meta_map.insert("import".into(), metadata.into());
    let excitation = spec.excitation.clone().unwrap_or(Excitation {
        kind: ExcitationKind::Unknown,
        steps: Vec::new(),
        sweep: None,
    });
    let recording = Recording {
        meta: RecordingMeta {
            format: FORMAT_V1.to_string(),
            sample_rate_hz,
            channels,
            excitation,
            description: spec.description.clone(),
            metadata: meta_map,
            extra: serde_json::Map::new(),
            chosen_reference: None,
        },
        channels: samples,
    };
    let mut opts = spec.quality.clone();
    for c in &spec.channels {
        if let Some(fs) = c.full_scale {
            opts.full_scale.entry(c.channel_name()).or_insert(fs);
        }
    }
    let mut quality = check_quality(&recording, &opts);
    if let Some((name, t)) = time {
        let declared = rate_declared.then_some((sample_rate_hz, rate_origin.as_str()));
        let axis = quality::check_time_axis(&name, &t, declared, &opts);
        quality.findings.extend(axis.findings);
        quality.time_axis = Some(axis.summary);
    }
    quality.sort();
    Ok(Imported {
        recording,
        quality,
        notes,
    })
}

/// The channels' lengths agree (a recording is a set of simultaneous
/// channels), none is empty, and every stated step lies inside them.
fn check_lengths(path: &Path, spec: &ImportSpec, values: &[Vec<f64>]) -> Result<()> {
    let n0 = values[0].len();
    for (k, v) in values.iter().enumerate() {
        if v.is_empty() {
            return Err(Error::format(
                path,
                spec.channels[k].source_text(),
                "holds no samples",
            ));
        }
        if v.len() != n0 {
            return Err(Error::format(
                path,
                spec.channels[k].source_text(),
                format!(
                    "has {} samples but `{}` (channel `{}`) has {n0}: channels must have equal lengths",
                    v.len(),
                    spec.channels[0].source_text(),
                    spec.channels[0].channel_name()
                ),
            ));
        }
    }
    if let Some(ex) = &spec.excitation {
        for (k, st) in ex.steps.iter().enumerate() {
            if st.start + st.length > n0 {
                return Err(Error::plan(
                    format!("excitation.steps[{k}]"),
                    format!(
                        "ends at frame {} but {} holds {n0} frames",
                        st.start + st.length,
                        path.display()
                    ),
                ));
            }
        }
    }
    Ok(())
}

/// Names a MAT-file sample-rate variable may have (compared in lower case).
const RATE_VARIABLES: [&str; 6] = [
    "fs",
    "fsamp",
    "sample_rate",
    "samplerate",
    "sampling_rate",
    "srate",
];

fn mat_load(path: &Path, spec: &ImportSpec) -> Result<Loaded> {
    let file = mat::MatFile::open(path)?;
    let mut values = Vec::with_capacity(spec.channels.len());
    for (k, c) in spec.channels.iter().enumerate() {
        let name = match &c.source {
            Column::Name(n) => n,
            Column::Index(i) => {
                return Err(Error::plan(
                    format!("channels[{k}].source"),
                    format!(
                        "column {i}: MAT-file variables are chosen by name; {}",
                        file.listing()
                    ),
                ));
            }
        };
        let array = file.read(name)?;
        values.push(array.signal(c.row, path)?);
    }
    let scalar = |name: &str| mat_rate_scalar(&file, path, name);
    let mut time = None;
    let (rate, origin, declared) = match &spec.sample_rate {
        SampleRateSource::Value(v) => (*v, format!("given: {v} Hz"), true),
        SampleRateSource::Variable(name) => (scalar(name)?, format!("variable `{name}`"), true),
        SampleRateSource::Auto => {
            let found = file
                .variables()
                .iter()
                .find(|v| RATE_VARIABLES.contains(&v.name.to_ascii_lowercase().as_str()));
            match found {
                Some(v) => (scalar(&v.name)?, format!("variable `{}`", v.name), true),
                None => {
                    return Err(Error::format(
                        path,
                        "sample rate",
                        format!(
                            "no sample-rate variable (looked for Fs, fsamp, sample_rate, ...): \
                             give sample_rate = {{ value = ... }} or {{ variable = ... }}; {}",
                            file.listing()
                        ),
                    ));
                }
            }
        }
        SampleRateSource::Comment => {
            return Err(Error::plan(
                "sample_rate",
                format!(
                    "`comment` applies to text files; {} is a MAT-file",
                    path.display()
                ),
            ));
        }
        SampleRateSource::Time(src) => {
            let Column::Name(name) = src else {
                return Err(Error::plan(
                    "sample_rate.time",
                    "MAT-file variables are chosen by name",
                ));
            };
            let t = file.read(name)?.signal(None, path)?;
            let rate = quality::rate_from_time(&t)
                .map_err(|m| Error::format(path, name, m.to_string()))?;
            time = Some((name.clone(), t));
            (rate, format!("time variable `{name}`"), false)
        }
    };
    if time.is_none() {
        time = mat_time_column(&file, path, spec)?;
    }
    let mut meta = serde_json::Map::new();
    meta.insert("format".into(), "MAT v5".into());
    meta.insert("header".into(), file.header_text().into());
    let skipped: Vec<serde_json::Value> = file
        .variables()
        .iter()
        .filter(|v| !v.class.is_numeric() || v.complex)
        .map(|v| v.describe().into())
        .collect();
    if !skipped.is_empty() {
        meta.insert("not_numeric".into(), skipped.into());
    }
    Ok(Loaded {
        values,
        sample_rate_hz: rate,
        rate_origin: origin,
        rate_declared: declared,
        time,
        metadata: meta,
        source_texts: Vec::new(),
        notes: Vec::new(),
    })
}

/// The time vector named as `time_column`, to check a declared rate
/// against.
fn mat_time_column(
    file: &mat::MatFile,
    path: &Path,
    spec: &ImportSpec,
) -> Result<Option<(String, Vec<f64>)>> {
    match &spec.time_column {
        Some(Column::Name(name)) => Ok(Some((name.clone(), file.read(name)?.signal(None, path)?))),
        Some(Column::Index(i)) => Err(Error::plan(
            "time_column",
            format!("column {i}: MAT-file variables are chosen by name"),
        )),
        None => Ok(None),
    }
}

/// A sample rate held in the MAT-file's variable `name`: one finite value
/// above zero.
fn mat_rate_scalar(file: &mat::MatFile, path: &Path, name: &str) -> Result<f64> {
    let a = file.read(name)?;
    if a.data.len() != 1 {
        return Err(Error::format(
            path,
            name,
            format!(
                "sample rate must be a positive scalar, but the variable is {}",
                a.shape()
            ),
        ));
    }
    let v = a.data[0];
    if !(v.is_finite() && v > 0.0) {
        return Err(Error::format(
            path,
            name,
            format!("sample rate must be a positive scalar, got {v}"),
        ));
    }
    Ok(v)
}
