//! Universal File Format (UFF) dataset 58, "function at nodal DOF": ASCII
//! `58` and binary `58b`.
//!
//! A UFF file is a sequence of datasets, each framed by lines holding `-1`
//! (`    -1`, columns 1-6) and opened by a line with the dataset number.
//! Dataset 58 holds one function of one abscissa: a time record (function
//! type 1), an FRF (type 4), a spectrum... Its eleven header records are read
//! here in full:
//!
//! * records 1-5: five ID lines (free text; line 1 is the description);
//! * record 6: function type, function ID, version, load case, response
//!   entity/node/direction, reference entity/node/direction;
//! * record 7: ordinate data type (2 real single, 4 real double, 5 complex
//!   single, 6 complex double), number of values, abscissa spacing (1 even:
//!   start and increment given; 0 uneven: an abscissa value stored with each
//!   ordinate), z-axis value;
//! * records 8-11: abscissa, ordinate (numerator), ordinate denominator and
//!   z-axis characteristics: specific data type (8 displacement, 9 reaction
//!   force, 11 velocity, 12 acceleration, 13 excitation force, 17 time, 18
//!   frequency, ...), unit exponents, axis label and units label;
//! * record 12: the values, as text in the fixed formats of the UFF
//!   specification (`6E13.5`, `4E20.12`, `2(E13.5,E20.12)`, `E13.5,2E20.12`)
//!   or, in `58b`, as raw IEEE 754 bytes (little- or big-endian, as the `58b`
//!   line says) right after the header.
//!
//! All eight data cases are read (real/complex, single/double, even/uneven);
//! other datasets (151 header, 164 units, 2411 nodes, ...) are skipped and
//! listed. [`write()`] writes dataset 58 as ASCII (what hystid's FRF export
//! uses).
//!
//! What real exporters do that the specification does not, and is accepted
//! here (several broke pyuff: its issues 38, 61, 88 and 103, Simcenter
//! Testlab's binary export among them): CRLF, LF or CR line ends; trailing
//! blanks and blank lines; header lines shorter or longer than 80 columns;
//! values run together in their fixed columns (`-1.23457E-100-2.0...`) or
//! separated by any blanks; Fortran `D` exponents; in `58b`, a line end
//! between the binary data and the closing `-1`, and a header byte count that
//! disagrees with the values record 7 declares (the layout whose end meets the
//! closing `-1` is taken; an uneven double-precision abscissa may be stored in
//! 4 or 8 bytes). Not supported: binary floating-point formats other than
//! IEEE 754 (DEC VMS, IBM/370), which are reported as such.
//!
//! Errors name the file, the dataset (its position in the file, from 1, its
//! type and the line it starts on, and its ID line 1 once read), the line and
//! what was expected. No byte sequence makes the reader panic.

use super::{ChannelSpec, ImportSpec, Loaded, SampleRateSource, Source};
use crate::atomic::write_atomic;
use crate::harmonics::Quantity;
use crate::{Error, Result};
use num_complex::Complex64;
use std::io::Write;
use std::path::Path;

/// A UFF file: its datasets in file order.
#[derive(Clone, Debug, PartialEq)]
pub struct UffFile {
    /// The datasets; only dataset 58 is decoded ([`Dataset::function`]).
    pub datasets: Vec<Dataset>,
}

/// One dataset of a UFF file.
#[derive(Clone, Debug, PartialEq)]
pub struct Dataset {
    /// Position in the file, counted from 1.
    pub index: usize,
    /// Line of its dataset-number line, from 1 (bytes of binary data count
    /// their line-feed bytes, as an editor would).
    pub line: usize,
    /// The dataset number (58, 151, 164, 2411, ...).
    pub number: u32,
    /// Whether it is a binary variant (`58b`).
    pub binary: bool,
    /// The decoded content of a dataset 58; `None` for other datasets.
    pub function: Option<Function>,
}

impl Dataset {
    /// How messages name it: `dataset 3 (58b at line 120, "Force 1+Z")`.
    pub fn describe(&self) -> String {
        let b = if self.binary { "b" } else { "" };
        match &self.function {
            Some(f) if !f.id_lines[0].is_empty() && f.id_lines[0] != "NONE" => format!(
                "dataset {} ({}{b} at line {}, \"{}\")",
                self.index, self.number, self.line, f.id_lines[0]
            ),
            _ => format!(
                "dataset {} ({}{b} at line {})",
                self.index, self.number, self.line
            ),
        }
    }
}

/// A response or reference degree of freedom (record 6).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Dof {
    /// Entity name (`NONE` if unused).
    pub entity: String,
    /// Node number.
    pub node: i64,
    /// Direction: 0 scalar, ±1..±3 translation X/Y/Z, ±4..±6 rotation.
    pub direction: i64,
}

impl Dof {
    /// `1+Z`, `12-RX`, `7` (scalar).
    pub fn label(&self) -> String {
        let axis = match self.direction.abs() {
            1 => "X",
            2 => "Y",
            3 => "Z",
            4 => "RX",
            5 => "RY",
            6 => "RZ",
            _ => "",
        };
        if axis.is_empty() {
            format!("{}", self.node)
        } else {
            let sign = if self.direction < 0 { '-' } else { '+' };
            format!("{}{sign}{axis}", self.node)
        }
    }
}

/// Precision of the stored values (record 7 field 1).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Precision {
    /// 4-byte floats, `E13.5` text.
    Single,
    /// 8-byte floats, `E20.12` text.
    Double,
}

/// The abscissa (record 7 fields 3-5, and the stored values when uneven).
#[derive(Clone, Debug, PartialEq)]
pub enum Abscissa {
    /// Evenly spaced: `start + k increment`.
    Even {
        /// First abscissa value.
        start: f64,
        /// Spacing.
        increment: f64,
        /// Half a unit in the last digit the file printed the increment
        /// with (`1.52588E-05` gives 5e-11): how well the file knows it.
        increment_resolution: f64,
    },
    /// One stored value per ordinate value.
    Uneven(Vec<f64>),
}

/// The ordinate values.
#[derive(Clone, Debug, PartialEq)]
pub enum Ordinate {
    /// Real values (ordinate data type 2 or 4).
    Real(Vec<f64>),
    /// Complex values (type 5 or 6).
    Complex(Vec<Complex64>),
}

impl Ordinate {
    /// Number of values.
    pub fn len(&self) -> usize {
        match self {
            Ordinate::Real(v) => v.len(),
            Ordinate::Complex(v) => v.len(),
        }
    }

    /// Whether there are no values.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }
}

/// Data characteristics of one axis (records 8-11).
#[derive(Clone, Debug, PartialEq)]
pub struct Axis {
    /// Specific data type: 0 unknown, 1 general, 8 displacement, 9 reaction
    /// force, 11 velocity, 12 acceleration, 13 excitation force, 17 time,
    /// 18 frequency, ...
    pub data_type: i64,
    /// Length units exponent.
    pub length_exponent: i64,
    /// Force units exponent.
    pub force_exponent: i64,
    /// Temperature units exponent.
    pub temperature_exponent: i64,
    /// Axis label (`NONE` if unused).
    pub label: String,
    /// Axis units label (`NONE` if unused).
    pub units: String,
}

impl Axis {
    /// An axis of `data_type` with a label and units label, exponents 0.
    pub fn new(data_type: i64, label: &str, units: &str) -> Axis {
        Axis {
            data_type,
            length_exponent: 0,
            force_exponent: 0,
            temperature_exponent: 0,
            label: label.to_string(),
            units: units.to_string(),
        }
    }

    /// An unused axis (type 0, `NONE`).
    pub fn unused() -> Axis {
        Axis::new(0, "NONE", "NONE")
    }
}

/// How a `58b` dataset stored its values.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct BinaryLayout {
    /// Byte order: record 1 field 3 = 2.
    pub big_endian: bool,
    /// Bytes the `58b` line declares (field 6).
    pub declared_bytes: u64,
    /// Bytes actually read (the layout record 7 implies).
    pub data_bytes: u64,
    /// Whether an uneven abscissa was stored as 4-byte floats beside
    /// 8-byte ordinates (the Fortran layout) rather than as 8-byte ones.
    pub single_abscissa: bool,
}

/// The content of a dataset 58.
#[derive(Clone, Debug, PartialEq)]
pub struct Function {
    /// ID lines 1-5 (records 1-5), trailing blanks removed.
    pub id_lines: [String; 5],
    /// Function type: 0 general, 1 time response, 2 auto spectrum, 3 cross
    /// spectrum, 4 frequency response function, ...
    pub function_type: i64,
    /// Function identification number.
    pub function_id: i64,
    /// Version or sequence number.
    pub version: i64,
    /// Load case identification number (0: single-point excitation).
    pub load_case: i64,
    /// Response DOF.
    pub response: Dof,
    /// Reference DOF.
    pub reference: Dof,
    /// Precision of the values.
    pub precision: Precision,
    /// The abscissa.
    pub abscissa: Abscissa,
    /// Z-axis value (record 7 field 6).
    pub z_axis_value: f64,
    /// Abscissa characteristics (record 8).
    pub abscissa_axis: Axis,
    /// Ordinate (numerator) characteristics (record 9).
    pub ordinate_axis: Axis,
    /// Ordinate denominator characteristics (record 10).
    pub denominator_axis: Axis,
    /// Z-axis characteristics (record 11).
    pub z_axis: Axis,
    /// The values.
    pub ordinate: Ordinate,
    /// For `58b`: how the values were stored.
    pub binary: Option<BinaryLayout>,
}

impl Function {
    /// The ordinate data type code of record 7 (2, 4, 5 or 6).
    pub fn ordinate_data_type(&self) -> i64 {
        match (&self.ordinate, self.precision) {
            (Ordinate::Real(_), Precision::Single) => 2,
            (Ordinate::Real(_), Precision::Double) => 4,
            (Ordinate::Complex(_), Precision::Single) => 5,
            (Ordinate::Complex(_), Precision::Double) => 6,
        }
    }

    /// The function type's name (`time response`, `frequency response
    /// function`, ...).
    pub fn function_type_name(&self) -> &'static str {
        function_type_name(self.function_type)
    }
}

/// The name of a record 6 function type.
pub fn function_type_name(t: i64) -> &'static str {
    match t {
        0 => "general or unknown",
        1 => "time response",
        2 => "auto spectrum",
        3 => "cross spectrum",
        4 => "frequency response function",
        5 => "transmissibility",
        6 => "coherence",
        7 => "auto correlation",
        8 => "cross correlation",
        9 => "power spectral density",
        10 => "energy spectral density",
        11 => "probability density function",
        12 => "spectrum",
        _ => "other function",
    }
}

impl UffFile {
    /// Reads and parses a file.
    pub fn open(path: &Path) -> Result<UffFile> {
        let bytes = std::fs::read(path).map_err(|e| Error::io(path, e))?;
        parse(path, &bytes)
    }

    /// The datasets 58.
    pub fn functions(&self) -> impl Iterator<Item = (&Dataset, &Function)> {
        self.datasets
            .iter()
            .filter_map(|d| d.function.as_ref().map(|f| (d, f)))
    }

    /// One line per dataset, for messages: `#1 58 "Force" time response
    /// 1+Z, excitation force [N], 4096 values`.
    pub fn listing(&self) -> String {
        let mut out = Vec::new();
        for d in &self.datasets {
            let b = if d.binary { "b" } else { "" };
            match &d.function {
                Some(f) => out.push(format!(
                    "#{} {}{b} \"{}\" {} {}, data type {} [{}], {} values",
                    d.index,
                    d.number,
                    f.id_lines[0],
                    f.function_type_name(),
                    f.response.label(),
                    f.ordinate_axis.data_type,
                    f.ordinate_axis.units,
                    f.ordinate.len()
                )),
                None => out.push(format!("#{} {}{b} (skipped)", d.index, d.number)),
            }
        }
        out.join("; ")
    }
}

// ---------------------------------------------------------------------------
// Reading

/// The bytes of a file, walked line by line (any of CRLF, LF, CR ends a line)
/// or byte by byte (binary data).
struct Cursor<'a> {
    bytes: &'a [u8],
    pos: usize,
    /// Line number of the line starting at `pos`, from 1.
    line: usize,
}

impl<'a> Cursor<'a> {
    /// The next line without its end, and its number.
    fn next_line(&mut self) -> Option<(&'a [u8], usize)> {
        if self.pos >= self.bytes.len() {
            return None;
        }
        let start = self.pos;
        let rest = &self.bytes[start..];
        let (len, end) = match rest.iter().position(|&b| b == b'\n' || b == b'\r') {
            Some(i) if rest[i] == b'\r' && rest.get(i + 1) == Some(&b'\n') => (i, i + 2),
            Some(i) => (i, i + 1),
            None => (rest.len(), rest.len()),
        };
        self.pos = start + end;
        let number = self.line;
        self.line += 1;
        Some((&rest[..len], number))
    }

    /// Advances over `n` bytes of binary data, counting their line feeds.
    fn skip_bytes(&mut self, n: usize) {
        let end = (self.pos + n).min(self.bytes.len());
        self.line += self.bytes[self.pos..end]
            .iter()
            .filter(|&&b| b == b'\n')
            .count();
        self.pos = end;
    }
}

/// Text of a field: UTF-8 when valid, else Latin-1 (`µm` from old
/// exporters); surrounding blanks removed.
fn text(bytes: &[u8]) -> String {
    let s = match std::str::from_utf8(bytes) {
        Ok(s) => s.to_string(),
        Err(_) => bytes.iter().map(|&b| b as char).collect(),
    };
    s.trim().to_string()
}

/// Columns `a..b` of a line (from 0), clamped to the line.
fn cols(line: &[u8], a: usize, b: usize) -> &[u8] {
    let n = line.len();
    &line[a.min(n)..b.min(n)]
}

fn is_blank(line: &[u8]) -> bool {
    line.iter().all(|b| b.is_ascii_whitespace())
}

fn is_delimiter(line: &[u8]) -> bool {
    line.trim_ascii() == b"-1"
}

/// A Fortran real: `1.5`, `-2.5E+03`, `2.5D-03`, `0.12345-100` (an `E`
/// format with a three-digit exponent drops the letter), `NaN`, `inf`.
pub fn parse_real(s: &str) -> Option<f64> {
    let s = s.trim();
    if s.is_empty() {
        return None;
    }
    if let Ok(v) = s.parse::<f64>() {
        return Some(v);
    }
    let fixed: String = s
        .chars()
        .map(|c| if c == 'D' || c == 'd' { 'E' } else { c })
        .collect();
    if let Ok(v) = fixed.parse::<f64>() {
        return Some(v);
    }
    // mantissa then a signed exponent without its letter (`0.12345-100`)
    let b = fixed.as_bytes();
    let at = (1..b.len()).rev().find(|&i| {
        (b[i] == b'+' || b[i] == b'-') && (b[i - 1].is_ascii_digit() || b[i - 1] == b'.')
    })?;
    let (m, e) = fixed.split_at(at);
    if m.contains(['E', 'e']) || e.len() < 2 || !e[1..].bytes().all(|c| c.is_ascii_digit()) {
        return None;
    }
    m.parse::<f64>().ok()?;
    format!("{m}E{e}").parse().ok()
}

fn parse_int(field: &[u8]) -> Option<i64> {
    let t = text(field);
    if t.is_empty() {
        // a blank Fortran I field reads as zero
        return Some(0);
    }
    t.parse().ok()
}

/// Half a unit in the last printed digit of a number's text.
fn resolution(s: &str) -> f64 {
    let s = s.trim();
    let (mantissa, exponent) = match s.find(['E', 'e', 'D', 'd']) {
        Some(i) => (&s[..i], s[i + 1..].parse::<i32>().unwrap_or(0)),
        None => (s, 0),
    };
    let decimals = mantissa
        .split_once('.')
        .map_or(0, |(_, d)| d.bytes().filter(u8::is_ascii_digit).count()) as i32;
    0.5 * 10f64.powi(exponent - decimals)
}

/// Context for the messages of one dataset.
struct Where<'p> {
    path: &'p Path,
    index: usize,
    number: u32,
    binary: bool,
    line: usize,
    id1: Option<String>,
}

impl Where<'_> {
    fn name(&self) -> String {
        let b = if self.binary { "b" } else { "" };
        match &self.id1 {
            Some(id) if !id.is_empty() && id != "NONE" => format!(
                "dataset {} ({}{b} at line {}, \"{id}\")",
                self.index, self.number, self.line
            ),
            _ => format!(
                "dataset {} ({}{b} at line {})",
                self.index, self.number, self.line
            ),
        }
    }

    fn err(&self, line: usize, message: impl std::fmt::Display) -> Error {
        Error::format(self.path, self.name(), format!("line {line}: {message}"))
    }
}

/// Parses a whole UFF file held in memory. `path` names it in messages.
pub fn parse(path: &Path, bytes: &[u8]) -> Result<UffFile> {
    let mut cur = Cursor {
        bytes,
        pos: 0,
        line: 1,
    };
    let mut datasets = Vec::new();
    loop {
        // the opening -1
        let (line, n) = loop {
            match cur.next_line() {
                None => return finish(path, datasets),
                Some((l, _)) if is_blank(l) => continue,
                Some(x) => break x,
            }
        };
        let index = datasets.len() + 1;
        if !is_delimiter(line) {
            return Err(Error::format(
                path,
                format!("dataset {index}"),
                format!(
                    "line {n}: expected `    -1` (the start of a dataset), found `{}`",
                    shown(line)
                ),
            ));
        }
        // a stray extra `-1` (an empty dataset) is passed over
        let (id_line, id_n) = loop {
            match cur.next_line() {
                Some((l, _)) if is_delimiter(l) || is_blank(l) => continue,
                Some(x) => break x,
                None => {
                    return Err(Error::format(
                        path,
                        format!("dataset {index}"),
                        format!("line {n}: the file ends after `-1`: expected a dataset number"),
                    ));
                }
            }
        };
        let t = text(id_line);
        let digits = t.bytes().take_while(u8::is_ascii_digit).count();
        let number: Option<u32> = t[..digits].parse().ok();
        let Some(number) = number else {
            return Err(Error::format(
                path,
                format!("dataset {index}"),
                format!(
                    "line {id_n}: expected a dataset number (`    58`, `    58b`, ...), found `{}`",
                    shown(id_line)
                ),
            ));
        };
        let rest = &t[digits..];
        let binary = rest.starts_with(['b', 'B']);
        let w = Where {
            path,
            index,
            number,
            binary,
            line: id_n,
            id1: None,
        };
        let header = if binary {
            Some(binary_header(&w, &rest[1..])?)
        } else {
            None
        };
        let function = if number == 58 {
            Some(read_58(&mut cur, w, header)?)
        } else {
            skip_dataset(&mut cur, &w, header)?;
            None
        };
        datasets.push(Dataset {
            index,
            line: id_n,
            number,
            binary,
            function,
        });
    }
}

fn finish(path: &Path, datasets: Vec<Dataset>) -> Result<UffFile> {
    if datasets.is_empty() {
        return Err(Error::format(
            path,
            "UFF",
            "holds no dataset (expected `    -1`, a dataset number such as `    58`, its records, `    -1`)",
        ));
    }
    Ok(UffFile { datasets })
}

/// A line for a message: at most 40 characters, control bytes escaped.
fn shown(line: &[u8]) -> String {
    let t = String::from_utf8_lossy(&line[..line.len().min(40)]).to_string();
    let t: String = t
        .chars()
        .map(|c| if c.is_control() { '?' } else { c })
        .collect();
    if line.len() > 40 {
        format!("{}...", t.trim_end())
    } else {
        t.trim_end().to_string()
    }
}

/// The `58b` line's fields after the `b`: byte order, floating-point format,
/// ASCII lines, bytes.
struct BinaryHeader {
    big_endian: bool,
    ascii_lines: usize,
    bytes: u64,
}

fn binary_header(w: &Where, rest: &str) -> Result<BinaryHeader> {
    let f: Vec<&str> = rest.split_whitespace().collect();
    let expect = "(I6,1A1,I6,I6,I12,I12,...): byte order (1 little-endian, 2 big-endian), \
                  floating-point format (2 IEEE 754), ASCII lines, bytes";
    let field = |k: usize, what: &str| -> Result<i64> {
        f.get(k).and_then(|s| s.parse::<i64>().ok()).ok_or_else(|| {
            w.err(
                w.line,
                format!(
                    "the binary header's {what} is `{}`; expected {expect}",
                    f.get(k).copied().unwrap_or("")
                ),
            )
        })
    };
    let order = field(0, "byte order")?;
    let format = field(1, "floating-point format")?;
    let lines = field(2, "number of ASCII lines")?;
    let bytes = field(3, "number of bytes")?;
    let big_endian = match order {
        1 => false,
        2 => true,
        o => {
            return Err(w.err(
                w.line,
                format!("byte order {o}: expected 1 (little-endian) or 2 (big-endian)"),
            ));
        }
    };
    match format {
        2 => {}
        1 | 3 => {
            return Err(w.err(
                w.line,
                format!(
                    "floating-point format {format} ({}) is not supported: only 2 (IEEE 754)",
                    if format == 1 { "DEC VMS" } else { "IBM 5/370" }
                ),
            ));
        }
        o => {
            return Err(w.err(
                w.line,
                format!("floating-point format {o}: expected 2 (IEEE 754)"),
            ));
        }
    }
    if !(0..=10_000).contains(&lines) || bytes < 0 {
        return Err(w.err(
            w.line,
            format!("{lines} ASCII lines and {bytes} bytes: expected counts >= 0"),
        ));
    }
    Ok(BinaryHeader {
        big_endian,
        ascii_lines: lines as usize,
        bytes: bytes as u64,
    })
}

/// Skips a dataset hystid does not read.
fn skip_dataset(cur: &mut Cursor, w: &Where, header: Option<BinaryHeader>) -> Result<()> {
    if let Some(h) = header {
        for k in 0..h.ascii_lines {
            if cur.next_line().is_none() {
                return Err(w.err(
                    cur.line,
                    format!(
                        "the file ends in the header ({k} of {} ASCII lines)",
                        h.ascii_lines
                    ),
                ));
            }
        }
        let start = cur.pos;
        let need = usize::try_from(h.bytes).unwrap_or(usize::MAX);
        if bytes_left(cur) < need {
            return Err(w.err(
                cur.line,
                format!(
                    "the file ends {} bytes into {} bytes of binary data",
                    bytes_left(cur),
                    h.bytes
                ),
            ));
        }
        cur.skip_bytes(need);
        if !closes_at(cur.bytes, start + need) {
            return Err(w.err(
                cur.line,
                format!("expected the closing `-1` after {} bytes of data", h.bytes),
            ));
        }
        skip_to_delimiter(cur);
        return Ok(());
    }
    loop {
        match cur.next_line() {
            Some((l, _)) if is_delimiter(l) => return Ok(()),
            Some(_) => {}
            None => {
                return Err(w.err(
                    cur.line.saturating_sub(1).max(w.line),
                    "the file ends inside the dataset: expected its closing `    -1`",
                ));
            }
        }
    }
}

fn bytes_left(cur: &Cursor) -> usize {
    cur.bytes.len().saturating_sub(cur.pos)
}

/// Whether the closing `-1` follows `at`, after blanks and line ends.
fn closes_at(bytes: &[u8], at: usize) -> bool {
    let Some(rest) = bytes.get(at..) else {
        return false;
    };
    let skip = rest
        .iter()
        .position(|b| !b.is_ascii_whitespace())
        .unwrap_or(rest.len());
    let rest = &rest[skip..];
    rest.starts_with(b"-1") && rest.get(2).is_none_or(|b| b.is_ascii_whitespace())
}

/// Moves past the closing `-1` line (after [`closes_at`] said it is there:
/// blank lines, then the `-1`).
fn skip_to_delimiter(cur: &mut Cursor) {
    while let Some((l, _)) = cur.next_line() {
        if !is_blank(l) {
            return;
        }
    }
}

/// The layouts of record 12 for each ordinate data type and spacing.
#[derive(Clone, Copy)]
struct Case {
    complex: bool,
    precision: Precision,
    even: bool,
}

impl Case {
    /// Values per point in the file: ordinate (1 or 2) plus abscissa.
    fn per_point(self) -> usize {
        (if self.complex { 2 } else { 1 }) + usize::from(!self.even)
    }

    /// The fixed columns of the ASCII format, repeated along a line.
    fn widths(self) -> &'static [usize] {
        match (self.precision, self.even, self.complex) {
            (Precision::Single, _, _) => &[13; 6],
            (Precision::Double, true, _) => &[20; 4],
            (Precision::Double, false, false) => &[13, 20, 13, 20],
            (Precision::Double, false, true) => &[13, 20, 20],
        }
    }

    fn format(self) -> &'static str {
        match (self.precision, self.even, self.complex) {
            (Precision::Single, _, _) => "6E13.5",
            (Precision::Double, true, _) => "4E20.12",
            (Precision::Double, false, false) => "2(E13.5,E20.12)",
            (Precision::Double, false, true) => "E13.5,2E20.12",
        }
    }

    fn describe(self) -> String {
        format!(
            "{} {}, {} abscissa",
            if self.complex { "complex" } else { "real" },
            match self.precision {
                Precision::Single => "single",
                Precision::Double => "double",
            },
            if self.even { "even" } else { "uneven" }
        )
    }
}

const RECORD_NAMES: [&str; 11] = [
    "ID line 1",
    "ID line 2",
    "ID line 3",
    "ID line 4",
    "ID line 5",
    "record 6 (DOF identification)",
    "record 7 (data form)",
    "record 8 (abscissa characteristics)",
    "record 9 (ordinate characteristics)",
    "record 10 (ordinate denominator characteristics)",
    "record 11 (z-axis characteristics)",
];

fn read_58(cur: &mut Cursor, mut w: Where, header: Option<BinaryHeader>) -> Result<Function> {
    if let Some(h) = &header
        && h.ascii_lines != 11
    {
        return Err(w.err(
            w.line,
            format!(
                "the binary header says {} ASCII lines; dataset 58 has 11",
                h.ascii_lines
            ),
        ));
    }
    let mut lines: Vec<(&[u8], usize)> = Vec::with_capacity(11);
    for name in RECORD_NAMES {
        match cur.next_line() {
            Some(l) => lines.push(l),
            None => {
                return Err(w.err(
                    cur.line.saturating_sub(1).max(w.line),
                    format!("the file ends in the header: expected {name}"),
                ));
            }
        }
    }
    let id_lines: [String; 5] = std::array::from_fn(|k| text(lines[k].0));
    w.id1 = Some(id_lines[0].clone());
    let (response, reference, function_type, function_id, version, load_case) =
        record_6(&w, lines[5])?;
    let (case, n, start, increment, increment_resolution, z_axis_value) = record_7(&w, lines[6])?;
    let axes: Vec<Axis> = (7..11)
        .map(|k| axis_record(&w, lines[k], RECORD_NAMES[k]))
        .collect::<Result<_>>()?;
    let [abscissa_axis, ordinate_axis, denominator_axis, z_axis]: [Axis; 4] =
        axes.try_into().map_err(|_| w.err(w.line, "records 8-11"))?;
    let record_7_line = lines[6].1;
    let (values, binary) = match header {
        Some(h) => {
            let (v, layout) = binary_values(cur, &w, &h, case, n, record_7_line)?;
            (v, Some(layout))
        }
        None => (ascii_values(cur, &w, case, n, record_7_line)?, None),
    };
    let per = case.per_point();
    let (abscissa, ordinate) = {
        let x = if case.even {
            Abscissa::Even {
                start,
                increment,
                increment_resolution,
            }
        } else {
            Abscissa::Uneven(values.iter().step_by(per).copied().collect())
        };
        let skip = usize::from(!case.even);
        let y = if case.complex {
            Ordinate::Complex(
                values
                    .chunks_exact(per)
                    .map(|c| Complex64::new(c[skip], c[skip + 1]))
                    .collect(),
            )
        } else {
            Ordinate::Real(values.chunks_exact(per).map(|c| c[skip]).collect())
        };
        (x, y)
    };
    Ok(Function {
        id_lines,
        function_type,
        function_id,
        version,
        load_case,
        response,
        reference,
        precision: case.precision,
        abscissa,
        z_axis_value,
        abscissa_axis,
        ordinate_axis,
        denominator_axis,
        z_axis,
        ordinate,
        binary,
    })
}

type Record6 = (Dof, Dof, i64, i64, i64, i64);

fn record_6(w: &Where, (line, n): (&[u8], usize)) -> Result<Record6> {
    // Format(2(I5,I10),2(1X,10A1,I10,I4))
    let ints = [
        (0, 5),
        (5, 15),
        (15, 20),
        (20, 30),
        (41, 51),
        (51, 55),
        (66, 76),
        (76, 80),
    ]
    .map(|(a, b)| parse_int(cols(line, a, b)));
    if let [
        Some(ft),
        Some(id),
        Some(ver),
        Some(lc),
        Some(rn),
        Some(rd),
        Some(fn_),
        Some(fd),
    ] = ints
    {
        // a record 6 cut short by a trimming editor has blank reference fields
        let name = |a, b| {
            let t = text(cols(line, a, b));
            if t.is_empty() { "NONE".to_string() } else { t }
        };
        return Ok((
            Dof {
                entity: name(31, 41),
                node: rn,
                direction: rd,
            },
            Dof {
                entity: name(56, 66),
                node: fn_,
                direction: fd,
            },
            ft,
            id,
            ver,
            lc,
        ));
    }
    // written without the fixed columns: ten blank-separated fields
    let t = text(line);
    let f: Vec<&str> = t.split_whitespace().collect();
    let int = |k: usize| f.get(k).and_then(|s| s.parse::<i64>().ok());
    if f.len() == 10
        && let [
            Some(ft),
            Some(id),
            Some(ver),
            Some(lc),
            Some(rn),
            Some(rd),
            Some(fn_),
            Some(fd),
        ] = [0, 1, 2, 3, 5, 6, 8, 9].map(int)
    {
        return Ok((
            Dof {
                entity: f[4].to_string(),
                node: rn,
                direction: rd,
            },
            Dof {
                entity: f[7].to_string(),
                node: fn_,
                direction: fd,
            },
            ft,
            id,
            ver,
            lc,
        ));
    }
    Err(w.err(
        n,
        format!(
            "record 6 (DOF identification) `{}`: expected Format(2(I5,I10),2(1X,10A1,I10,I4)): \
             function type, function ID, version, load case, response entity, node, direction, \
             reference entity, node, direction",
            shown(line)
        ),
    ))
}

type Record7 = (Case, usize, f64, f64, f64, f64);

fn record_7(w: &Where, (line, n): (&[u8], usize)) -> Result<Record7> {
    // Format(3I10,3E13.5); blank-separated fields are accepted too
    let t = text(line);
    let tokens: Vec<&str> = t.split_whitespace().collect();
    let free = (3..=6).contains(&tokens.len())
        && tokens[..3].iter().all(|s| s.parse::<i64>().is_ok())
        && tokens[3..].iter().all(|s| parse_real(s).is_some());
    let fields: Vec<String> = if free {
        tokens.iter().map(|s| s.to_string()).collect()
    } else {
        [(0, 10), (10, 20), (20, 30), (30, 43), (43, 56), (56, 69)]
            .iter()
            .map(|&(a, b)| text(cols(line, a, b)))
            .collect()
    };
    let bad = |what: &str| {
        w.err(
            n,
            format!(
                "record 7 (data form) `{}`: {what}; expected Format(3I10,3E13.5): ordinate data \
                 type (2, 4, 5, 6), number of values, abscissa spacing (0 uneven, 1 even), \
                 abscissa start, increment, z-axis value",
                shown(line)
            ),
        )
    };
    let int = |k: usize| -> Option<i64> {
        match fields.get(k).map(String::as_str) {
            Some("") | None => None,
            Some(s) => s.parse().ok(),
        }
    };
    let real = |k: usize| -> Option<f64> {
        match fields.get(k).map(String::as_str) {
            Some("") | None => Some(0.0),
            Some(s) => parse_real(s),
        }
    };
    let ty = int(0).ok_or_else(|| bad("no ordinate data type"))?;
    let count = int(1).ok_or_else(|| bad("no number of values"))?;
    let spacing = int(2).ok_or_else(|| bad("no abscissa spacing"))?;
    let (complex, precision) = match ty {
        2 => (false, Precision::Single),
        4 => (false, Precision::Double),
        5 => (true, Precision::Single),
        6 => (true, Precision::Double),
        _ => return Err(bad(&format!("ordinate data type {ty} is not 2, 4, 5 or 6"))),
    };
    let even = match spacing {
        0 => false,
        1 => true,
        s => return Err(bad(&format!("abscissa spacing {s} is not 0 or 1"))),
    };
    let count = usize::try_from(count).map_err(|_| bad(&format!("{count} values")))?;
    let start = real(3).ok_or_else(|| bad("the abscissa start is not a number"))?;
    let increment = real(4).ok_or_else(|| bad("the abscissa increment is not a number"))?;
    let z = real(5).ok_or_else(|| bad("the z-axis value is not a number"))?;
    let res = fields.get(4).map_or(f64::INFINITY, |s| resolution(s));
    Ok((
        Case {
            complex,
            precision,
            even,
        },
        count,
        start,
        increment,
        res,
        z,
    ))
}

fn axis_record(w: &Where, (line, n): (&[u8], usize), name: &str) -> Result<Axis> {
    // Format(I10,3I5,2(1X,20A1))
    let fixed = [(0, 10), (10, 15), (15, 20), (20, 25)].map(|(a, b)| parse_int(cols(line, a, b)));
    let label = |a, b| {
        let t = text(cols(line, a, b));
        if t.is_empty() { "NONE".to_string() } else { t }
    };
    if let [Some(ty), Some(l), Some(f), Some(t)] = fixed {
        return Ok(Axis {
            data_type: ty,
            length_exponent: l,
            force_exponent: f,
            temperature_exponent: t,
            label: label(26, 46),
            units: label(47, usize::MAX),
        });
    }
    // the four integers blank-separated without their columns
    let s = text(line);
    let f: Vec<&str> = s.split_whitespace().collect();
    if f.len() >= 4
        && let [Some(ty), Some(l), Some(fe), Some(t)] = [0, 1, 2, 3].map(|k| f[k].parse().ok())
    {
        return Ok(Axis {
            data_type: ty,
            length_exponent: l,
            force_exponent: fe,
            temperature_exponent: t,
            label: f.get(4).map_or("NONE".into(), |s| s.to_string()),
            units: f.get(5).map_or("NONE".into(), |s| s.to_string()),
        });
    }
    Err(w.err(
        n,
        format!(
            "{name} `{}`: expected Format(I10,3I5,2(1X,20A1)): specific data type, length, force \
             and temperature unit exponents, axis label, units label",
            shown(line)
        ),
    ))
}

/// The values of an ASCII record 12, counted from record 7.
fn ascii_values(
    cur: &mut Cursor,
    w: &Where,
    case: Case,
    n: usize,
    record_7_line: usize,
) -> Result<Vec<f64>> {
    let need = n.checked_mul(case.per_point()).ok_or_else(|| {
        w.err(
            record_7_line,
            format!("record 7 declares {n} values: too many"),
        )
    })?;
    // a value takes at least two bytes of text: never reserve beyond the file
    let mut values = Vec::with_capacity(need.min(bytes_left(cur) / 2));
    let mut tokens: Vec<&str> = Vec::new();
    let widths = case.widths();
    let what = || {
        format!(
            "record 7 declares {n} values ({}: {need} numbers in {})",
            case.describe(),
            case.format()
        )
    };
    while values.len() < need {
        let Some((line, k)) = cur.next_line() else {
            return Err(w.err(
                cur.line.saturating_sub(1),
                format!(
                    "the file ends after {} of {need} numbers: {}",
                    values.len(),
                    what()
                ),
            ));
        };
        if is_blank(line) {
            continue;
        }
        if is_delimiter(line) {
            return Err(w.err(
                k,
                format!(
                    "the dataset closes (`-1`) after {} of {need} numbers: {}",
                    values.len(),
                    what()
                ),
            ));
        }
        let s = match std::str::from_utf8(line) {
            Ok(s) => s,
            Err(_) => {
                return Err(w.err(
                    k,
                    format!(
                        "`{}` is not text: expected numbers in {}",
                        shown(line),
                        case.format()
                    ),
                ));
            }
        };
        let before = values.len();
        tokens.clear();
        tokens.extend(s.split_whitespace());
        let bad = tokens.iter().position(|t| parse_real(t).is_none());
        match bad {
            None => values.extend(tokens.iter().filter_map(|t| parse_real(t))),
            Some(i) => match fixed_columns(s.trim_end(), widths) {
                // values run together in their fixed columns
                Some(v) => values.extend(v),
                None => {
                    return Err(w.err(
                        k,
                        format!(
                            "`{}` is not a number (value {} of {need}; expected {} in {})",
                            tokens[i],
                            before + i + 1,
                            case.describe(),
                            case.format()
                        ),
                    ));
                }
            },
        }
        if values.len() > need {
            return Err(w.err(
                k,
                format!(
                    "{} numbers so far, more than the {need} that record 7 declares ({} values, {})",
                    values.len(),
                    n,
                    case.describe()
                ),
            ));
        }
    }
    // the closing -1
    loop {
        match cur.next_line() {
            Some((l, _)) if is_blank(l) => continue,
            Some((l, _)) if is_delimiter(l) => return Ok(values),
            Some((l, k)) => {
                return Err(w.err(
                    k,
                    format!(
                        "expected the closing `    -1` after the {need} numbers record 7 \
                         declares ({n} values, {}), found `{}`",
                        case.describe(),
                        shown(l)
                    ),
                ));
            }
            None => {
                return Err(w.err(
                    cur.line.saturating_sub(1),
                    "the file ends before the dataset's closing `    -1`",
                ));
            }
        }
    }
}

/// A line of numbers in fixed columns of `widths` (repeated), for values
/// that run together (`-1.23457E-100-2.00000E+00`): `None` unless every
/// field is one number and no column boundary cuts a number (a boundary
/// falls next to a blank, or before the sign of a number that follows a
/// digit).
fn fixed_columns(line: &str, widths: &[usize]) -> Option<Vec<f64>> {
    let b = line.as_bytes();
    let mut out = Vec::new();
    let mut at = 0;
    for &width in widths.iter().cycle() {
        if at >= b.len() {
            return Some(out);
        }
        if at > 0 {
            let (l, r) = (b[at - 1], b[at]);
            let clean = l.is_ascii_whitespace()
                || r.is_ascii_whitespace()
                || ((r == b'+' || r == b'-') && (l.is_ascii_digit() || l == b'.'));
            if !clean {
                return None;
            }
        }
        let end = (at + width).min(b.len());
        let field = std::str::from_utf8(&b[at..end]).ok()?.trim();
        if field.contains(char::is_whitespace) {
            return None;
        }
        out.push(parse_real(field)?);
        at = end;
    }
    Some(out)
}

/// The values of a binary record 12: the layout record 7 implies, with the
/// byte count whose end meets the closing `-1`.
fn binary_values(
    cur: &mut Cursor,
    w: &Where,
    h: &BinaryHeader,
    case: Case,
    n: usize,
    record_7_line: usize,
) -> Result<(Vec<f64>, BinaryLayout)> {
    let start = cur.pos;
    let data_line = cur.line;
    let width = match case.precision {
        Precision::Single => 4usize,
        Precision::Double => 8,
    };
    let y_per = if case.complex { 2 } else { 1 };
    // (bytes per point, abscissa width)
    let mut layouts: Vec<(usize, usize)> = Vec::new();
    if case.even {
        layouts.push((width * y_per, 0));
    } else {
        layouts.push((width * (y_per + 1), width));
        if case.precision == Precision::Double {
            layouts.push((width * y_per + 4, 4));
        }
    }
    let sized: Vec<(usize, usize)> = layouts
        .iter()
        .filter_map(|&(per, xw)| n.checked_mul(per).map(|b| (b, xw)))
        .collect();
    let declared = usize::try_from(h.bytes).unwrap_or(usize::MAX);
    let left = bytes_left(cur);
    let fits = |b: usize| b <= left && closes_at(cur.bytes, start + b);
    let chosen = sized
        .iter()
        .find(|&&(b, _)| b == declared && fits(b))
        .or_else(|| sized.iter().find(|&&(b, _)| fits(b)))
        .copied();
    let Some((bytes, x_width)) = chosen else {
        let expected: Vec<String> = sized.iter().map(|(b, _)| b.to_string()).collect();
        let smallest = sized.iter().map(|s| s.0).min().unwrap_or(usize::MAX);
        let why = if smallest > left {
            format!("the file ends {left} bytes into the data")
        } else {
            let at = start.saturating_add(smallest);
            let after = cur.bytes.get(at..).unwrap_or(&[]);
            // the values in the other precision would close it: say so
            let other = match case.precision {
                Precision::Single => sized.iter().map(|s| s.0.saturating_mul(2)).min(),
                Precision::Double => sized.iter().map(|s| s.0 / 2).min(),
            }
            .filter(|&b| b <= left && closes_at(cur.bytes, start + b));
            let per_point = sized.first().map_or(0, |s| s.0 / n.max(1));
            let by_header = (declared <= left
                && closes_at(cur.bytes, start + declared)
                && per_point > 0
                && declared % per_point == 0)
                .then(|| declared / per_point);
            let hint = match (by_header, other) {
                (Some(count), _) => format!(
                    "; it follows the 58b line's {declared} bytes, {count} values of this type: \
                     record 7's number of values does not match the data"
                ),
                (None, Some(b)) => format!(
                    "; it follows {b} bytes, these values' size in {} precision: record 7's \
                     data type does not match the data (pyuff 2.5 writes single-precision 58b \
                     this way)",
                    match case.precision {
                        Precision::Single => "double",
                        Precision::Double => "single",
                    }
                ),
                (None, None) => String::new(),
            };
            format!(
                "no closing `-1` follows them (bytes after the data: {}){hint}",
                hex(&after[..after.len().min(8)])
            )
        };
        return Err(w.err(
            data_line,
            format!(
                "binary data (byte offset {start}): record 7 (line {record_7_line}) declares {n} \
                 values ({}), {} bytes, and the 58b line {} bytes, but {why}",
                case.describe(),
                expected.join(" or "),
                h.bytes
            ),
        ));
    };
    let data = &cur.bytes[start..start + bytes];
    let mut values = Vec::with_capacity(n * case.per_point());
    let f32_at = |b: &[u8]| -> f64 {
        let a = [b[0], b[1], b[2], b[3]];
        (if h.big_endian {
            f32::from_be_bytes(a)
        } else {
            f32::from_le_bytes(a)
        }) as f64
    };
    let f64_at = |b: &[u8]| -> f64 {
        let a = [b[0], b[1], b[2], b[3], b[4], b[5], b[6], b[7]];
        if h.big_endian {
            f64::from_be_bytes(a)
        } else {
            f64::from_le_bytes(a)
        }
    };
    let read = |b: &[u8], size: usize| if size == 4 { f32_at(b) } else { f64_at(b) };
    let per = bytes.checked_div(n).unwrap_or(0);
    if per > 0 {
        for point in data.chunks_exact(per) {
            let mut at = 0;
            if x_width > 0 {
                values.push(read(&point[..x_width], x_width));
                at = x_width;
            }
            for _ in 0..y_per {
                values.push(read(&point[at..at + width], width));
                at += width;
            }
        }
    }
    cur.skip_bytes(bytes);
    skip_to_delimiter(cur);
    Ok((
        values,
        BinaryLayout {
            big_endian: h.big_endian,
            declared_bytes: h.bytes,
            data_bytes: bytes as u64,
            single_abscissa: x_width == 4 && case.precision == Precision::Double,
        },
    ))
}

fn hex(b: &[u8]) -> String {
    if b.is_empty() {
        return "none, end of file".into();
    }
    b.iter()
        .map(|x| format!("{x:02x}"))
        .collect::<Vec<_>>()
        .join(" ")
}

// ---------------------------------------------------------------------------
// Writing

/// A Fortran `Ew.d` field: `d` digits after the point, a signed exponent of
/// at least two digits, right-aligned in `w` columns.
pub fn fortran_e(x: f64, w: usize, d: usize) -> String {
    if !x.is_finite() {
        let s = if x.is_nan() {
            "NaN"
        } else if x > 0.0 {
            "inf"
        } else {
            "-inf"
        };
        return format!("{s:>w$}");
    }
    let s = format!("{x:.d$e}");
    let (m, e) = s.split_once('e').unwrap_or((&s, "0"));
    let e: i32 = e.parse().unwrap_or(0);
    let sign = if e < 0 { '-' } else { '+' };
    format!("{:>w$}", format!("{m}E{sign}{:02}", e.abs()))
}

/// At most 80 characters of `s` on one line, `NONE` when empty.
fn id_text(s: &str) -> String {
    let t: String = s
        .chars()
        .map(|c| if c.is_control() { ' ' } else { c })
        .take(80)
        .collect();
    let t = t.trim_end().to_string();
    if t.is_empty() { "NONE".into() } else { t }
}

fn name_field(s: &str, n: usize) -> String {
    let t: String = s
        .chars()
        .filter(|c| !c.is_control())
        .take(n)
        .collect::<String>()
        .trim()
        .to_string();
    if t.is_empty() { "NONE".into() } else { t }
}

/// Writes one dataset 58 as ASCII (LF line ends) in the formats of the UFF
/// specification. The ordinate data type follows `f.precision` and the
/// ordinate's kind; an uneven abscissa must have one value per ordinate
/// value.
pub fn write_ascii(out: &mut impl Write, f: &Function) -> std::io::Result<()> {
    let even = matches!(f.abscissa, Abscissa::Even { .. });
    let case = Case {
        complex: matches!(f.ordinate, Ordinate::Complex(_)),
        precision: f.precision,
        even,
    };
    let n = f.ordinate.len();
    if let Abscissa::Uneven(x) = &f.abscissa
        && x.len() != n
    {
        return Err(std::io::Error::new(
            std::io::ErrorKind::InvalidInput,
            format!("{} abscissa values for {n} ordinate values", x.len()),
        ));
    }
    writeln!(out, "    -1")?;
    writeln!(out, "    58")?;
    for id in &f.id_lines {
        writeln!(out, "{}", id_text(id))?;
    }
    writeln!(
        out,
        "{:5}{:10}{:5}{:10} {:>10}{:10}{:4} {:>10}{:10}{:4}",
        f.function_type,
        f.function_id,
        f.version,
        f.load_case,
        name_field(&f.response.entity, 10),
        f.response.node,
        f.response.direction,
        name_field(&f.reference.entity, 10),
        f.reference.node,
        f.reference.direction
    )?;
    let (start, increment) = match f.abscissa {
        Abscissa::Even {
            start, increment, ..
        } => (start, increment),
        Abscissa::Uneven(_) => (0.0, 0.0),
    };
    writeln!(
        out,
        "{:10}{:10}{:10}{}{}{}",
        f.ordinate_data_type(),
        n,
        u8::from(even),
        fortran_e(start, 13, 5),
        fortran_e(increment, 13, 5),
        fortran_e(f.z_axis_value, 13, 5)
    )?;
    for a in [
        &f.abscissa_axis,
        &f.ordinate_axis,
        &f.denominator_axis,
        &f.z_axis,
    ] {
        writeln!(
            out,
            "{:10}{:5}{:5}{:5} {:<20} {:<20}",
            a.data_type,
            a.length_exponent,
            a.force_exponent,
            a.temperature_exponent,
            name_field(&a.label, 20),
            name_field(&a.units, 20)
        )?;
    }
    // the numbers in file order, each with its field width
    let widths = case.widths();
    let per_line = widths.len();
    let mut line = String::with_capacity(80);
    let mut k = 0;
    let mut push = |out: &mut dyn Write, v: f64, line: &mut String| -> std::io::Result<()> {
        let w = widths[k % per_line];
        let d = if w == 13 { 5 } else { 12 };
        line.push_str(&fortran_e(v, w, d));
        k += 1;
        if k % per_line == 0 {
            writeln!(out, "{line}")?;
            line.clear();
        }
        Ok(())
    };
    for i in 0..n {
        if let Abscissa::Uneven(x) = &f.abscissa {
            push(out, x[i], &mut line)?;
        }
        match &f.ordinate {
            Ordinate::Real(y) => push(out, y[i], &mut line)?,
            Ordinate::Complex(y) => {
                push(out, y[i].re, &mut line)?;
                push(out, y[i].im, &mut line)?;
            }
        }
    }
    if !line.is_empty() {
        writeln!(out, "{line}")?;
    }
    writeln!(out, "    -1")
}

/// Writes datasets 58 to `path` as one ASCII UFF file, atomically.
pub fn write(path: &Path, functions: &[Function]) -> Result<()> {
    write_atomic(path, |w| {
        for f in functions {
            write_ascii(w, f).map_err(|e| Error::io(path, e))?;
        }
        Ok(())
    })
}

// ---------------------------------------------------------------------------
// Time records into a recording

/// Why a dataset 58 does not become a recording channel.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum NotAChannel {
    /// Not a time response.
    #[error("function type {0} ({name}), not a time response (1)", name = function_type_name(*.0))]
    NotTimeResponse(i64),
    /// A complex ordinate.
    #[error("a complex ordinate (data type 5 or 6): a time record must be real")]
    Complex,
    /// Record 9 names no quantity hystid knows.
    #[error(
        "ordinate data type {data_type} with units label `{units}`: not force (13, 9), \
         displacement (8), velocity (11), acceleration (12) or voltage (units V)"
    )]
    Quantity {
        /// Record 9 field 1.
        data_type: i64,
        /// Record 9 field 6.
        units: String,
    },
    /// A units label that is not a unit of the quantity.
    #[error("units label `{units}` is not a unit of {quantity} (known: {known})")]
    Units {
        /// The quantity record 9 gives.
        quantity: Quantity,
        /// The label.
        units: String,
        /// The labels understood for that quantity.
        known: String,
    },
}

/// A time record as a recording channel: its quantity and the factor from
/// its units to SI.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TimeChannel {
    /// The quantity.
    pub quantity: Quantity,
    /// SI value = value in the file × scale.
    pub scale: f64,
    /// The units label was `NONE` or blank, so SI was assumed.
    pub si_assumed: bool,
}

/// Units labels understood, per quantity, with their factor to SI. Labels
/// are compared after [`unit_key`].
const UNITS: [(Quantity, &[(&str, f64)]); 5] = [
    (
        Quantity::Force,
        &[
            ("N", 1.0),
            ("kN", 1e3),
            ("mN", 1e-3),
            ("lbf", 4.448_221_615_260_5),
            ("lb", 4.448_221_615_260_5),
            ("kgf", 9.806_65),
        ],
    ),
    (
        Quantity::Acceleration,
        &[
            ("m/s2", 1.0),
            ("g", 9.806_65),
            ("gn", 9.806_65),
            ("mm/s2", 1e-3),
            ("in/s2", 0.0254),
            ("ft/s2", 0.3048),
        ],
    ),
    (
        Quantity::Velocity,
        &[
            ("m/s", 1.0),
            ("mm/s", 1e-3),
            ("um/s", 1e-6),
            ("in/s", 0.0254),
            ("ft/s", 0.3048),
        ],
    ),
    (
        Quantity::Displacement,
        &[
            ("m", 1.0),
            ("mm", 1e-3),
            ("um", 1e-6),
            ("nm", 1e-9),
            ("in", 0.0254),
            ("mil", 2.54e-5),
            ("ft", 0.3048),
        ],
    ),
    (Quantity::Voltage, &[("V", 1.0), ("mV", 1e-3)]),
];

/// A units label in the spelling [`UNITS`] uses: brackets, blanks dropped,
/// `²`, `^2`, `**2`, `/s/s` as `2` and `/s2`, `µ` as `u`.
fn unit_key(label: &str) -> String {
    let mut s: String = label
        .chars()
        .filter(|c| !c.is_whitespace() && !matches!(c, '[' | ']' | '(' | ')'))
        .map(|c| match c {
            'µ' | 'μ' => 'u',
            '²' => '2',
            c => c,
        })
        .collect();
    for (from, to) in [("**2", "2"), ("^2", "2"), ("/s/s", "/s2")] {
        s = s.replace(from, to);
    }
    s
}

fn is_none(label: &str) -> bool {
    label.is_empty() || label.eq_ignore_ascii_case("NONE")
}

/// The quantity and scale of a time record, from record 9's specific data
/// type (13 excitation force, 9 reaction force, 8 displacement, 11
/// velocity, 12 acceleration; for 0 unknown and 1 general the units label
/// alone) and its units label.
pub fn time_channel(f: &Function) -> std::result::Result<TimeChannel, NotAChannel> {
    if f.function_type != 1 {
        return Err(NotAChannel::NotTimeResponse(f.function_type));
    }
    if matches!(f.ordinate, Ordinate::Complex(_)) {
        return Err(NotAChannel::Complex);
    }
    let axis = &f.ordinate_axis;
    let key = unit_key(&axis.units);
    let by_units = || {
        let found: Vec<Quantity> = UNITS
            .iter()
            .filter(|(_, table)| table.iter().any(|(u, _)| *u == key))
            .map(|(q, _)| *q)
            .collect();
        (found.len() == 1).then(|| found[0])
    };
    let quantity = match axis.data_type {
        13 | 9 => Quantity::Force,
        8 => Quantity::Displacement,
        11 => Quantity::Velocity,
        12 => Quantity::Acceleration,
        0 | 1 => by_units().ok_or_else(|| NotAChannel::Quantity {
            data_type: axis.data_type,
            units: axis.units.clone(),
        })?,
        t => {
            return Err(NotAChannel::Quantity {
                data_type: t,
                units: axis.units.clone(),
            });
        }
    };
    if is_none(&axis.units) {
        return Ok(TimeChannel {
            quantity,
            scale: 1.0,
            si_assumed: true,
        });
    }
    let table = UNITS
        .iter()
        .find(|(q, _)| *q == quantity)
        .map_or(&[][..], |(_, t)| *t);
    match table.iter().find(|(u, _)| *u == key) {
        Some(&(_, scale)) => Ok(TimeChannel {
            quantity,
            scale,
            si_assumed: false,
        }),
        None => Err(NotAChannel::Units {
            quantity,
            units: axis.units.clone(),
            known: table.iter().map(|(u, _)| *u).collect::<Vec<_>>().join(", "),
        }),
    }
}

/// The channel name a time record gets by default: `force_1+Z`,
/// `acceleration_12-X`; for a scalar DOF at node 0 its entity name, else
/// `QUANTITY_K` (K the dataset's position).
pub fn default_name(d: &Dataset, f: &Function, q: Quantity) -> String {
    if f.response.node != 0 || f.response.direction != 0 {
        format!("{}_{}", q.name(), f.response.label())
    } else if !is_none(&f.response.entity) {
        f.response.entity.clone()
    } else {
        format!("{}_{}", q.name(), d.index)
    }
}

/// The channels of a file, as an import spec would name them: every real
/// time record whose quantity record 9 gives, excitation forces first (the
/// recording's reference is its first force), then the rest in file order;
/// each with its unit's scale. Returns them with a note for each dataset
/// left out.
pub fn channels(path: &Path, file: &UffFile) -> Result<(Vec<ChannelSpec>, Vec<String>)> {
    let mut notes = Vec::new();
    let mut found: Vec<(bool, ChannelSpec)> = Vec::new();
    let mut names: Vec<String> = Vec::new();
    for d in &file.datasets {
        let Some(f) = &d.function else {
            notes.push(format!(
                "{} skipped: hystid reads dataset 58 only",
                d.describe()
            ));
            continue;
        };
        match time_channel(f) {
            Ok(c) => {
                let mut name = default_name(d, f, c.quantity);
                if names.contains(&name) {
                    name = format!("{name}_{}", d.index);
                }
                names.push(name.clone());
                if c.si_assumed {
                    notes.push(format!(
                        "{}: no units label, SI ({}) assumed",
                        d.describe(),
                        c.quantity.si_unit()
                    ));
                }
                let spec = ChannelSpec::new(Source::Index(d.index), c.quantity)
                    .name(name)
                    .scale(c.scale);
                found.push((f.ordinate_axis.data_type == 13, spec));
            }
            Err(e) => notes.push(format!("{} skipped: {e}", d.describe())),
        }
    }
    if found.is_empty() {
        return Err(Error::format(
            path,
            "UFF",
            format!(
                "no time record (dataset 58, function type 1) of force, displacement, velocity, \
                 acceleration or voltage: {}; datasets: {}",
                notes.join("; "),
                file.listing()
            ),
        ));
    }
    // a stable sort: excitation forces first
    found.sort_by_key(|(excitation, _)| !excitation);
    Ok((found.into_iter().map(|(_, c)| c).collect(), notes))
}

/// The dataset a channel spec names: `#K` (its position in the file), or a
/// name: the default channel name, the response entity name, `NODE±DIR` or
/// ID line 1.
fn resolve<'a>(
    path: &Path,
    file: &'a UffFile,
    c: &ChannelSpec,
    k: usize,
) -> Result<(&'a Dataset, &'a Function)> {
    let field = format!("channels[{k}].source");
    if c.row.is_some() {
        return Err(Error::plan(
            format!("channels[{k}].row"),
            "a UFF dataset holds one signal: no row",
        ));
    }
    match &c.source {
        Source::Index(i) => {
            let d = file.datasets.get(i.wrapping_sub(1)).ok_or_else(|| {
                Error::plan(
                    &field,
                    format!(
                        "dataset #{i}: {} holds {} datasets ({})",
                        path.display(),
                        file.datasets.len(),
                        file.listing()
                    ),
                )
            })?;
            match &d.function {
                Some(f) => Ok((d, f)),
                None => Err(Error::plan(
                    field,
                    format!(
                        "{} of {} is not a dataset 58 ({})",
                        d.describe(),
                        path.display(),
                        file.listing()
                    ),
                )),
            }
        }
        Source::Name(name) => {
            let hits: Vec<(&Dataset, &Function)> = file
                .functions()
                .filter(|(d, f)| {
                    let q = time_channel(f).map(|t| t.quantity);
                    q.is_ok_and(|q| default_name(d, f, q) == *name)
                        || f.response.entity == *name
                        || f.response.label() == *name
                        || f.id_lines[0] == *name
                })
                .collect();
            match hits.as_slice() {
                [one] => Ok(*one),
                [] => Err(Error::plan(
                    field,
                    format!(
                        "no dataset 58 of {} is named `{name}` (by channel name, response \
                         entity, NODE+DIR or ID line 1); use #K for the K-th dataset: {}",
                        path.display(),
                        file.listing()
                    ),
                )),
                many => Err(Error::plan(
                    field,
                    format!(
                        "`{name}` names datasets {} of {}: use #K",
                        many.iter()
                            .map(|(d, _)| format!("#{}", d.index))
                            .collect::<Vec<_>>()
                            .join(", "),
                        path.display()
                    ),
                )),
            }
        }
    }
}

/// The sample rate an even abscissa gives: `1/increment`, or the whole
/// number of Hz whose period the file's printed increment is (within half
/// its last digit: `1.52588E-05` is 65536 Hz, not 65536.1).
pub fn rate_of(increment: f64, resolution: f64) -> f64 {
    let fs = 1.0 / increment;
    let whole = fs.round();
    if whole >= 1.0 && (1.0 / whole - increment).abs() <= resolution {
        whole
    } else {
        fs
    }
}

/// The recording's channels from the datasets `spec` names (all time
/// records when it names none: see [`channels`]); the rate from the
/// abscissa. Returns the completed spec with what the reader loaded.
pub(crate) fn load(path: &Path, file: &UffFile, spec: &ImportSpec) -> Result<(ImportSpec, Loaded)> {
    let mut spec = spec.clone();
    let mut notes = Vec::new();
    if spec.channels.is_empty() {
        let (c, n) = channels(path, file)?;
        spec.channels = c;
        notes = n;
    }
    let mut chosen = Vec::with_capacity(spec.channels.len());
    for k in 0..spec.channels.len() {
        let (d, f) = resolve(path, file, &spec.channels[k], k)?;
        let c = &mut spec.channels[k];
        if c.name.is_none() && matches!(c.source, Source::Index(_)) {
            // `#3` would read `column_3`: the dataset's own name instead
            c.name = Some(default_name(d, f, c.quantity));
        }
        let c = &spec.channels[k];
        if f.function_type != 1 {
            return Err(Error::format(
                path,
                d.describe(),
                format!(
                    "channel `{}`: {}",
                    c.channel_name(),
                    NotAChannel::NotTimeResponse(f.function_type)
                ),
            ));
        }
        let Ordinate::Real(y) = &f.ordinate else {
            return Err(Error::format(
                path,
                d.describe(),
                format!("channel `{}`: {}", c.channel_name(), NotAChannel::Complex),
            ));
        };
        if y.is_empty() {
            return Err(Error::format(path, d.describe(), "holds no values"));
        }
        chosen.push((d, f, y));
    }
    let (d0, f0, _) = chosen[0];
    let period0 = |f: &Function| match &f.abscissa {
        Abscissa::Even { increment, .. } => *increment,
        Abscissa::Uneven(x) => {
            if x.len() > 1 {
                (x[x.len() - 1] - x[0]) / (x.len() - 1) as f64
            } else {
                f64::NAN
            }
        }
    };
    for &(d, f, _) in &chosen[1..] {
        let mismatch = |what: String| {
            Error::format(
                path,
                d.describe(),
                format!(
                    "{what}; a recording's channels are sampled together (choose datasets \
                     with --channel #K)"
                ),
            )
        };
        if f.ordinate.len() != f0.ordinate.len() {
            return Err(mismatch(format!(
                "{} values, but {} has {}",
                f.ordinate.len(),
                d0.describe(),
                f0.ordinate.len()
            )));
        }
        match (&f.abscissa, &f0.abscissa) {
            (
                Abscissa::Even {
                    start,
                    increment,
                    increment_resolution: r,
                },
                Abscissa::Even {
                    start: s0,
                    increment: i0,
                    increment_resolution: r0,
                },
            ) => {
                if (increment - i0).abs() > r.max(*r0) + 1e-12 * i0.abs() {
                    return Err(mismatch(format!(
                        "sample spacing {increment} s, but {} has {i0} s",
                        d0.describe()
                    )));
                }
                if (start - s0).abs() > 0.5 * i0.abs() {
                    return Err(mismatch(format!(
                        "starts at {start} s, but {} at {s0} s",
                        d0.describe()
                    )));
                }
            }
            (Abscissa::Uneven(x), Abscissa::Uneven(x0)) => {
                let tol = 0.01 * period0(f0).abs();
                if let Some(i) = (0..x.len()).find(|&i| {
                    let d = (x[i] - x0[i]).abs();
                    d.is_nan() || d > tol
                }) {
                    return Err(mismatch(format!(
                        "abscissa value {} is {} s, but {} has {} s",
                        i + 1,
                        x[i],
                        d0.describe(),
                        x0[i]
                    )));
                }
            }
            _ => {
                return Err(mismatch(format!(
                    "its abscissa is {} but that of {} is not",
                    if matches!(f.abscissa, Abscissa::Even { .. }) {
                        "even"
                    } else {
                        "uneven"
                    },
                    d0.describe()
                )));
            }
        }
    }
    let mut time = None;
    let (rate, origin, declared) = match (&spec.sample_rate, &f0.abscissa) {
        (
            SampleRateSource::Auto,
            Abscissa::Even {
                increment,
                increment_resolution,
                ..
            },
        ) => {
            if !(increment.is_finite() && *increment > 0.0) {
                return Err(Error::format(
                    path,
                    d0.describe(),
                    format!("abscissa increment {increment}: expected a sample spacing > 0 s"),
                ));
            }
            let fs = rate_of(*increment, *increment_resolution);
            let whole = if fs != 1.0 / increment {
                format!(": {fs} Hz within its printed digits")
            } else {
                String::new()
            };
            (
                fs,
                format!(
                    "abscissa increment {increment:e} s of dataset {} (record 7){whole}",
                    d0.index
                ),
                true,
            )
        }
        (SampleRateSource::Auto, Abscissa::Uneven(x)) => {
            let fs = super::quality::rate_from_time(x)
                .map_err(|e| Error::format(path, d0.describe(), format!("uneven abscissa: {e}")))?;
            time = Some((format!("abscissa of dataset {}", d0.index), x.clone()));
            (
                fs,
                format!(
                    "uneven abscissa of dataset {} (least-squares spacing)",
                    d0.index
                ),
                false,
            )
        }
        (SampleRateSource::Value(v), x) => {
            if let Abscissa::Uneven(x) = x {
                time = Some((format!("abscissa of dataset {}", d0.index), x.clone()));
            }
            (*v, format!("given: {v} Hz"), true)
        }
        (other, _) => {
            return Err(Error::plan(
                "sample_rate",
                format!(
                    "{other:?}: a UFF file gives its rate in record 7; use auto or a value in Hz"
                ),
            ));
        }
    };
    let mut per_channel = serde_json::Map::new();
    let mut sources = Vec::new();
    let mut values = Vec::new();
    for (c, &(d, f, y)) in spec.channels.iter().zip(&chosen) {
        values.push(y.clone());
        let layout = f.binary.map(|b| {
            format!(
                "58b {}-endian {}",
                if b.big_endian { "big" } else { "little" },
                match f.precision {
                    Precision::Single => "single",
                    Precision::Double => "double",
                }
            )
        });
        sources.push(format!("dataset {} ({})", d.index, f.response.label()));
        per_channel.insert(
            c.channel_name(),
            serde_json::json!({
                "dataset": d.index,
                "line": d.line,
                "id_lines": f.id_lines,
                "function_id": f.function_id,
                "version": f.version,
                "response": {"entity": f.response.entity, "node": f.response.node,
                             "direction": f.response.direction, "label": f.response.label()},
                "reference": {"entity": f.reference.entity, "node": f.reference.node,
                              "direction": f.reference.direction},
                "ordinate_data_type": f.ordinate_axis.data_type,
                "ordinate_label": f.ordinate_axis.label,
                "units_label": f.ordinate_axis.units,
                "scale": c.scale,
                "storage": layout.unwrap_or_else(|| format!("58 ASCII {}",
                    match f.precision { Precision::Single => "single", Precision::Double => "double" })),
            }),
        );
    }
    let mut meta = serde_json::Map::new();
    meta.insert("format".into(), "UFF dataset 58".into());
    meta.insert("datasets".into(), per_channel.into());
    if !notes.is_empty() {
        meta.insert("skipped".into(), notes.clone().into());
    }
    Ok((
        spec,
        Loaded {
            values,
            sample_rate_hz: rate,
            rate_origin: origin,
            rate_declared: declared,
            time,
            metadata: meta,
            source_texts: sources,
            notes,
        },
    ))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn p() -> &'static Path {
        Path::new("t.uff")
    }

    fn time_record(values: Vec<f64>, precision: Precision) -> Function {
        Function {
            id_lines: [
                "Force".into(),
                "run 1".into(),
                "NONE".into(),
                "".into(),
                "".into(),
            ],
            function_type: 1,
            function_id: 7,
            version: 0,
            load_case: 0,
            response: Dof {
                entity: "drive".into(),
                node: 12,
                direction: -3,
            },
            reference: Dof {
                entity: "NONE".into(),
                node: 0,
                direction: 0,
            },
            precision,
            abscissa: Abscissa::Even {
                start: 0.0,
                increment: 1.0 / 4096.0,
                increment_resolution: 0.0,
            },
            z_axis_value: 0.0,
            abscissa_axis: Axis::new(17, "Time", "s"),
            ordinate_axis: Axis::new(13, "Force", "N"),
            denominator_axis: Axis::unused(),
            z_axis: Axis::unused(),
            ordinate: Ordinate::Real(values),
            binary: None,
        }
    }

    fn written(f: &Function) -> Vec<u8> {
        let mut v = Vec::new();
        write_ascii(&mut v, f).unwrap();
        v
    }

    #[test]
    fn fortran_fields() {
        assert_eq!(fortran_e(0.0, 13, 5), "  0.00000E+00");
        assert_eq!(fortran_e(-1.5e-5, 13, 5), " -1.50000E-05");
        assert_eq!(fortran_e(-1.25e-100, 13, 5), "-1.25000E-100");
        assert_eq!(fortran_e(1.0 / 3.0, 20, 12), "  3.333333333333E-01");
        for s in [
            "1.5",
            "-2.5E+03",
            "2.5D-03",
            "0.12345-100",
            " 7 ",
            "1.0e5",
            "-0.5+07",
        ] {
            assert!(parse_real(s).is_some(), "{s}");
        }
        assert_eq!(parse_real("0.12345-100"), Some(0.12345e-100));
        assert_eq!(parse_real("-0.5+07"), Some(-0.5e7));
        assert_eq!(parse_real("2.5D-03"), Some(2.5e-3));
        for s in ["", "1.0e5-2.0e5", "abc", "1-", "--1", "1.0E+00-2.0E+00"] {
            assert_eq!(parse_real(s), None, "{s}");
        }
        assert_eq!(resolution("1.52588E-05"), 0.5e-10);
        assert_eq!(resolution("3.125e-4"), 0.5e-7);
        assert_eq!(resolution("0.001"), 0.5e-3);
    }

    #[test]
    fn ascii_round_trip_every_case() {
        let y: Vec<f64> = (0..13)
            .map(|k| (k as f64 * 0.7).sin() * 10f64.powi(k - 6))
            .collect();
        for precision in [Precision::Single, Precision::Double] {
            for even in [true, false] {
                for complex in [false, true] {
                    let mut f = time_record(y.clone(), precision);
                    if !even {
                        f.abscissa = Abscissa::Uneven((0..13).map(|k| 100.0 + k as f64).collect());
                    }
                    if complex {
                        f.ordinate = Ordinate::Complex(
                            y.iter().map(|&v| Complex64::new(v, -2.0 * v)).collect(),
                        );
                    }
                    let bytes = written(&f);
                    let back = parse(p(), &bytes).unwrap();
                    let g = back.datasets[0].function.as_ref().unwrap();
                    assert_eq!(g.id_lines, f.id_lines.clone().map(|s| id_text(&s)));
                    assert_eq!(g.response, f.response);
                    assert_eq!(g.ordinate_axis, f.ordinate_axis);
                    assert_eq!(g.function_id, 7);
                    let tol = if precision == Precision::Single {
                        5e-6
                    } else {
                        5e-13
                    };
                    let (a, b): (Vec<f64>, Vec<f64>) = match (&f.ordinate, &g.ordinate) {
                        (Ordinate::Real(a), Ordinate::Real(b)) => (a.clone(), b.clone()),
                        (Ordinate::Complex(a), Ordinate::Complex(b)) => (
                            a.iter().flat_map(|c| [c.re, c.im]).collect(),
                            b.iter().flat_map(|c| [c.re, c.im]).collect(),
                        ),
                        _ => panic!("kind changed"),
                    };
                    for (x, y) in a.iter().zip(&b) {
                        assert!((x - y).abs() <= tol * x.abs(), "{x} {y}");
                    }
                    if let (Abscissa::Uneven(a), Abscissa::Uneven(b)) = (&f.abscissa, &g.abscissa) {
                        assert_eq!(a, b);
                    }
                    // written again from what was read: the same bytes
                    assert_eq!(written(g), bytes);
                }
            }
        }
    }

    #[test]
    fn crlf_blank_lines_and_run_together_values() {
        let text = "\r\n    -1\r\n    58\r\nF\r\nNONE\r\nNONE\r\nNONE\r\nNONE\r\n\
            \x20   1         0    0         0      drive        12  -3       NONE         0   0\r\n\
            \x20        2         4         1  0.00000E+00  1.00000E-03  0.00000E+00\r\n\
            \x20       17    0    0    0 Time                 s\r\n\
            \x20       13    0    0    0 Force                N  \r\n\
            \x20        0    0    0    0 NONE                 NONE\r\n\
            \x20        0    0    0    0\r\n\
            -1.25000E-100-2.00000E+00\r\n\r\n  3.0 4.0D0   \r\n    -1\r\n";
        let f = parse(p(), text.as_bytes()).unwrap();
        let g = f.datasets[0].function.as_ref().unwrap();
        assert_eq!(g.ordinate, Ordinate::Real(vec![-1.25e-100, -2.0, 3.0, 4.0]));
        assert_eq!(g.ordinate_axis.units, "N");
        assert_eq!(g.z_axis.label, "NONE");
        assert_eq!(g.response.label(), "12-Z");
    }

    #[test]
    fn errors_name_dataset_line_and_expectation() {
        let good = written(&time_record(vec![1.0, 2.0, 3.0], Precision::Double));
        let s = String::from_utf8(good).unwrap();
        let cases = [
            (
                s.replace("2.000000000000E+00", "2.0000000000x0E+00"),
                "line 14",
            ),
            (
                s.replace("         3         1", "         5         1"),
                "after 3 of 5",
            ),
            (
                s.replace("         4         3", "         9         3"),
                "ordinate data type 9",
            ),
        ];
        for (text, want) in cases {
            let e = parse(p(), text.as_bytes()).unwrap_err().to_string();
            assert!(
                e.contains("t.uff") && e.contains("dataset 1") && e.contains(want),
                "{e}"
            );
            assert!(e.contains("\"Force\""), "{e}");
        }
    }

    #[test]
    fn every_truncation_is_an_error_not_a_panic() {
        let first = written(&time_record(
            vec![1.0, -2.0, 3.5, 4.0, 5.0],
            Precision::Single,
        ));
        let mut bytes = first.clone();
        bytes.extend(written(&time_record(vec![0.5; 9], Precision::Double)));
        let n1 = first.len();
        for cut in 0..bytes.len() - 7 {
            // only cuts that leave the first dataset whole (and at most the
            // blanks of the next `    -1`) are a valid, shorter file
            if let Ok(f) = parse(p(), &bytes[..cut]) {
                assert!((n1 - 1..=n1 + 4).contains(&cut), "cut {cut} of {n1}");
                assert_eq!(f.datasets.len(), 1);
            }
        }
    }
}
