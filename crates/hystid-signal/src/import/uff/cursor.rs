//! The reading of a UFF file's bytes: a cursor over its lines, fixed-column
//! fields, where a message points, a binary dataset's header and the skipping
//! of a dataset.

use crate::{Error, Result};
use std::path::Path;

/// The bytes of a file, walked line by line (any of CRLF, LF, CR ends a line)
/// or byte by byte (binary data).
pub(super) struct Cursor<'a> {
    pub(super) bytes: &'a [u8],
    pub(super) pos: usize,
    /// Line number of the line starting at `pos`, from 1.
    pub(super) line: usize,
}

impl<'a> Cursor<'a> {
    /// The next line without its end, and its number.
    pub(super) fn next_line(&mut self) -> Option<(&'a [u8], usize)> {
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
    pub(super) fn skip_bytes(&mut self, n: usize) {
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
pub(super) fn text(bytes: &[u8]) -> String {
    let s = match std::str::from_utf8(bytes) {
        Ok(s) => s.to_string(),
        Err(_) => bytes.iter().map(|&b| b as char).collect(),
    };
    s.trim().to_string()
}

/// Columns `a..b` of a line (from 0), clamped to the line.
pub(super) fn cols(line: &[u8], a: usize, b: usize) -> &[u8] {
    let n = line.len();
    &line[a.min(n)..b.min(n)]
}

pub(super) fn is_blank(line: &[u8]) -> bool {
    line.iter().all(|b| b.is_ascii_whitespace())
}

pub(super) fn is_delimiter(line: &[u8]) -> bool {
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

pub(super) fn parse_int(field: &[u8]) -> Option<i64> {
    let t = text(field);
    if t.is_empty() {
        // a blank Fortran I field reads as zero
        return Some(0);
    }
    t.parse().ok()
}

/// Half a unit in the last printed digit of a number's text.
pub(super) fn resolution(s: &str) -> f64 {
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
pub(super) struct Where<'p> {
    pub(super) path: &'p Path,
    pub(super) index: usize,
    pub(super) number: u32,
    pub(super) binary: bool,
    pub(super) line: usize,
    pub(super) id1: Option<String>,
}

impl Where<'_> {
    pub(super) fn name(&self) -> String {
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

    pub(super) fn err(&self, line: usize, message: impl std::fmt::Display) -> Error {
        Error::format(self.path, self.name(), format!("line {line}: {message}"))
    }
}

/// A line for a message: at most 40 characters, control bytes escaped.
pub(super) fn shown(line: &[u8]) -> String {
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
pub(super) struct BinaryHeader {
    pub(super) big_endian: bool,
    pub(super) ascii_lines: usize,
    pub(super) bytes: u64,
}

pub(super) fn binary_header(w: &Where, rest: &str) -> Result<BinaryHeader> {
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
pub(super) fn skip_dataset(
    cur: &mut Cursor,
    w: &Where,
    header: Option<BinaryHeader>,
) -> Result<()> {
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

pub(super) fn bytes_left(cur: &Cursor) -> usize {
    cur.bytes.len().saturating_sub(cur.pos)
}

/// Whether the closing `-1` follows `at`, after blanks and line ends.
pub(super) fn closes_at(bytes: &[u8], at: usize) -> bool {
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
pub(super) fn skip_to_delimiter(cur: &mut Cursor) {
    while let Some((l, _)) = cur.next_line() {
        if !is_blank(l) {
            return;
        }
    }
}
