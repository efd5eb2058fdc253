//! Delimited text (CSV, TSV, whitespace-separated) with a header row.
//!
//! Layout accepted: optional comment lines starting with `#` and blank lines,
//! then one header row naming the columns, then one row of numbers per
//! sample. Comment and blank lines are skipped wherever they are. Fields may
//! be quoted (`"time, s"`); every row must have as many fields as the
//! header. Numbers use a decimal point (`1.5e-3`, `NaN` and `inf` are read as
//! such and then reported by the quality checks); a decimal comma is not
//! supported. Only the columns asked for are parsed, so other columns may
//! hold text.
//!
//! The separator is detected from the header and the first rows: the first
//! of tab, comma, semicolon and `|` that splits them all into the same number
//! (more than one) of fields, else runs of whitespace (`.tsv` files try tab
//! first either way).
//!
//! The sample rate may be read from a comment (`# fs = 1024 Hz`, as the
//! UNESP BERT and Bouc-Wen CSVs have; also `sample rate: 2 kHz`,
//! `sampling frequency = ...`) or derived from a time column.

use super::{Column, Delimiter, ImportSpec, Loaded, SampleRateSource};
use crate::import::quality;
use crate::{Error, Result};
use std::path::Path;

/// A comment line before or between the data.
#[derive(Clone, Debug, PartialEq)]
pub struct Comment {
    /// Line number in the file, from 1.
    pub line: usize,
    /// The text after `#`, trimmed.
    pub text: String,
}

/// The requested columns of a delimited text file.
#[derive(Clone, Debug, PartialEq)]
pub struct TextTable {
    /// Column names, in file order.
    pub header: Vec<String>,
    /// Line number of the header, from 1.
    pub header_line: usize,
    /// The comment lines.
    pub comments: Vec<Comment>,
    /// The separator used.
    pub delimiter: Delimiter,
    /// Line number of each data row, from 1.
    pub lines: Vec<usize>,
    /// The requested columns' values, in request order.
    pub columns: Vec<Vec<f64>>,
    /// The requested columns' 0-based positions in the header.
    pub positions: Vec<usize>,
}

impl TextTable {
    /// `time_s, shaker_amp_V, ...`: the header for messages.
    pub fn header_text(&self) -> String {
        header_listing(&self.header)
    }
}

fn header_listing(h: &[String]) -> String {
    h.iter()
        .enumerate()
        .map(|(k, n)| format!("{} `{n}`", k + 1))
        .collect::<Vec<_>>()
        .join(", ")
}

/// Splits one line into fields (quote-aware for a character separator).
fn split<'a>(line: &'a str, d: Delimiter, out: &mut Vec<&'a str>) {
    out.clear();
    let Delimiter::Char(d) = d else {
        out.extend(line.split_whitespace());
        return;
    };
    let b = line.as_bytes();
    let mut i = 0;
    loop {
        let mut j = i;
        while j < b.len() && (b[j] == b' ' || b[j] == b'\t') && b[j] != d {
            j += 1;
        }
        if j < b.len() && b[j] == b'"' {
            // A quoted field: the separator may appear inside ("" is a quote).
            j += 1;
            while j < b.len() {
                if b[j] == b'"' {
                    if j + 1 < b.len() && b[j + 1] == b'"' {
                        j += 2;
                        continue;
                    }
                    break;
                }
                j += 1;
            }
        }
        while j < b.len() && b[j] != d {
            j += 1;
        }
        out.push(&line[i..j]);
        if j >= b.len() {
            break;
        }
        i = j + 1;
    }
}

/// A field without surrounding blanks and quotes.
fn clean(f: &str) -> &str {
    let f = f.trim();
    if f.len() >= 2 && f.starts_with('"') && f.ends_with('"') {
        f[1..f.len() - 1].trim()
    } else {
        f
    }
}

fn is_skipped(line: &str) -> bool {
    let t = line.trim_start();
    t.is_empty() || t.starts_with('#')
}

fn field_count(line: &str, d: Delimiter) -> usize {
    let mut buf = Vec::new();
    split(line, d, &mut buf);
    buf.len()
}

/// Chooses the separator from the header and a few data rows.
fn detect(header: &str, rows: &[&str], tab_first: bool) -> Delimiter {
    let mut cands: Vec<u8> = vec![b',', b'\t', b';', b'|'];
    if tab_first {
        cands.swap(0, 1);
    }
    let consistent = |d: Delimiter| {
        let n = field_count(header, d);
        n > 1 && rows.iter().all(|r| field_count(r, d) == n)
    };
    for &c in &cands {
        if consistent(Delimiter::Char(c)) {
            return Delimiter::Char(c);
        }
    }
    if consistent(Delimiter::Whitespace) {
        return Delimiter::Whitespace;
    }
    // No consistent choice: the first one splitting the header most (the
    // row check then reports the ragged line), else a single column.
    let mut best = (1, Delimiter::Char(b','));
    for &c in &cands {
        let n = field_count(header, Delimiter::Char(c));
        if n > best.0 {
            best = (n, Delimiter::Char(c));
        }
    }
    if best.0 == 1 && field_count(header, Delimiter::Whitespace) > 1 {
        return Delimiter::Whitespace;
    }
    best.1
}

/// Finds a column: by exact header name, or by number from 1.
fn resolve(path: &Path, header: &[String], src: &Column) -> Result<usize> {
    match src {
        Column::Index(i) => {
            if *i == 0 || *i > header.len() {
                Err(Error::format(
                    path,
                    src.to_string(),
                    format!(
                        "out of range: the header has {} columns (counted from 1): {}",
                        header.len(),
                        header_listing(header)
                    ),
                ))
            } else {
                Ok(i - 1)
            }
        }
        Column::Name(n) => {
            let hits: Vec<usize> = (0..header.len()).filter(|&k| header[k] == *n).collect();
            match hits.as_slice() {
                [k] => Ok(*k),
                [] => Err(Error::format(
                    path,
                    n,
                    format!("no such column; the header is: {}", header_listing(header)),
                )),
                _ => Err(Error::format(
                    path,
                    n,
                    format!(
                        "the header names {} columns `{n}` (columns {}); choose one by number",
                        hits.len(),
                        hits.iter()
                            .map(|k| (k + 1).to_string())
                            .collect::<Vec<_>>()
                            .join(", ")
                    ),
                )),
            }
        }
    }
}

/// A text file split into comments, header and data lines (not yet parsed).
struct Layout<'a> {
    header: Vec<String>,
    header_line: usize,
    comments: Vec<Comment>,
    delimiter: Delimiter,
    body: Vec<(usize, &'a str)>,
}

/// `bytes` as text, or an error naming the line of the first bad byte.
fn as_text<'a>(path: &Path, bytes: &'a [u8]) -> Result<&'a str> {
    std::str::from_utf8(bytes).map_err(|e| {
        let valid = e.valid_up_to();
        let line = bytes[..valid].iter().filter(|&&b| b == b'\n').count() + 1;
        Error::format(
            path,
            format!("line {line}"),
            format!("not UTF-8 text (byte {valid})"),
        )
    })
}

fn layout<'a>(path: &Path, text: &'a str, delimiter: Option<Delimiter>) -> Result<Layout<'a>> {
    let text = text.strip_prefix('\u{feff}').unwrap_or(text);
    let mut lines = text
        .split('\n')
        .map(|l| l.strip_suffix('\r').unwrap_or(l))
        .enumerate()
        .map(|(k, l)| (k + 1, l));
    let mut comments = Vec::new();
    let (header_line, header_text) = loop {
        match lines.next() {
            None => {
                return Err(Error::format(
                    path,
                    "header",
                    if comments.is_empty() {
                        "the file is empty: expected a header row naming the columns, then rows of numbers"
                    } else {
                        "the file holds only comments: expected a header row naming the columns, then rows of numbers"
                    },
                ));
            }
            Some((k, l)) if is_skipped(l) => {
                if let Some(c) = l.trim_start().strip_prefix('#') {
                    comments.push(Comment {
                        line: k,
                        text: c.trim().to_string(),
                    });
                }
            }
            Some(h) => break h,
        }
    };
    let body: Vec<(usize, &str)> = lines.collect();
    let d = delimiter.unwrap_or_else(|| {
        let sample: Vec<&str> = body
            .iter()
            .filter(|(_, l)| !is_skipped(l))
            .take(20)
            .map(|&(_, l)| l)
            .collect();
        let tsv = path
            .extension()
            .is_some_and(|e| e.eq_ignore_ascii_case("tsv"));
        detect(header_text, &sample, tsv)
    });
    let mut fields = Vec::new();
    split(header_text, d, &mut fields);
    let header: Vec<String> = fields.iter().map(|f| clean(f).to_string()).collect();
    if header.iter().all(|h| h.parse::<f64>().is_ok()) {
        return Err(Error::format(
            path,
            format!("line {header_line}"),
            "the first line that is not a comment holds only numbers: a header row naming the columns is needed",
        ));
    }
    Ok(Layout {
        header,
        header_line,
        comments,
        delimiter: d,
        body,
    })
}

/// Parses the columns `wanted` of a laid-out file.
fn extract(path: &Path, lay: Layout<'_>, wanted: &[Column]) -> Result<TextTable> {
    let Layout {
        header,
        header_line,
        comments,
        delimiter: d,
        body,
    } = lay;
    let positions: Vec<usize> = wanted
        .iter()
        .map(|s| resolve(path, &header, s))
        .collect::<Result<_>>()?;
    let mut columns: Vec<Vec<f64>> = vec![Vec::with_capacity(body.len()); wanted.len()];
    let mut row_lines = Vec::with_capacity(body.len());
    let mut fields = Vec::new();
    for &(k, l) in &body {
        if is_skipped(l) {
            continue;
        }
        split(l, d, &mut fields);
        if fields.len() != header.len() {
            return Err(Error::format(
                path,
                format!("line {k}"),
                format!(
                    "ragged row: {} fields, but the header (line {header_line}) has {} ({})",
                    fields.len(),
                    header.len(),
                    header_listing(&header)
                ),
            ));
        }
        for (col, &p) in columns.iter_mut().zip(&positions) {
            let cell = clean(fields[p]);
            match cell.parse::<f64>() {
                Ok(v) => col.push(v),
                Err(_) => {
                    return Err(Error::format(
                        path,
                        format!("line {k}, column {} `{}`", p + 1, header[p]),
                        if cell.is_empty() {
                            "empty cell, expected a number".to_string()
                        } else {
                            format!("`{cell}` is not a number")
                        },
                    ));
                }
            }
        }
        row_lines.push(k);
    }
    if row_lines.is_empty() {
        return Err(Error::format(
            path,
            "data",
            format!("the header (line {header_line}) is followed by no data rows"),
        ));
    }
    Ok(TextTable {
        header,
        header_line,
        comments,
        delimiter: d,
        lines: row_lines,
        columns,
        positions,
    })
}

/// Reads the header of `path` and the columns `wanted`.
///
/// Errors (naming the file and the column or line): not UTF-8, empty (no
/// header), a numeric first line (no header), an unknown column (the
/// message lists the header), a row with a different number of fields than
/// the header, an empty or non-numeric cell, no data rows.
pub fn read_columns(
    path: &Path,
    delimiter: Option<Delimiter>,
    wanted: &[Column],
) -> Result<TextTable> {
    let bytes = std::fs::read(path).map_err(|e| Error::io(path, e))?;
    parse_columns(path, &bytes, delimiter, wanted)
}

/// [`read_columns`] on a file already in memory; `path` names it in messages
/// (and its extension `.tsv` prefers tabs, as for a file).
pub fn parse_columns(
    path: &Path,
    bytes: &[u8],
    delimiter: Option<Delimiter>,
    wanted: &[Column],
) -> Result<TextTable> {
    let text = as_text(path, bytes)?;
    extract(path, layout(path, text, delimiter)?, wanted)
}

/// Reads a number at the start of `s` (after blanks): `(value, rest)`.
fn leading_number(s: &str) -> Option<(f64, &str)> {
    let s = s.trim_start();
    let b = s.as_bytes();
    let mut i = 0;
    if i < b.len() && (b[i] == b'+' || b[i] == b'-') {
        i += 1;
    }
    let digits_start = i;
    while i < b.len() && (b[i].is_ascii_digit() || b[i] == b'.') {
        i += 1;
    }
    if i == digits_start {
        return None;
    }
    // An exponent only if digits follow it (so `750 Hz` or `2e` stop early).
    if i < b.len() && (b[i] == b'e' || b[i] == b'E') {
        let mut j = i + 1;
        if j < b.len() && (b[j] == b'+' || b[j] == b'-') {
            j += 1;
        }
        if j < b.len() && b[j].is_ascii_digit() {
            while j < b.len() && b[j].is_ascii_digit() {
                j += 1;
            }
            i = j;
        }
    }
    s[..i].parse().ok().map(|v| (v, &s[i..]))
}

/// Sample-rate statements in comments: `fs = 1024 Hz`, `sample rate: 2 kHz`,
/// `sampling frequency = 750`. Returns every `(rate in Hz, line)` found.
pub fn rates_in_comments(comments: &[Comment]) -> Vec<(f64, usize)> {
    const KEYS: [&str; 6] = [
        "fs",
        "sample rate",
        "sample_rate",
        "samplerate",
        "sampling rate",
        "sampling frequency",
    ];
    let mut found = Vec::new();
    for c in comments {
        let low = c.text.to_ascii_lowercase();
        for key in KEYS {
            let mut from = 0;
            while let Some(p) = low[from..].find(key) {
                let at = from + p;
                from = at + key.len();
                // Whole words only: `fs` in `offset` does not count.
                let before_ok = low[..at]
                    .chars()
                    .next_back()
                    .is_none_or(|ch| !ch.is_ascii_alphanumeric() && ch != '_');
                if !before_ok {
                    continue;
                }
                let rest = low[from..].trim_start();
                let Some(rest) = rest.strip_prefix('=').or_else(|| rest.strip_prefix(':')) else {
                    continue;
                };
                let Some((v, tail)) = leading_number(rest) else {
                    continue;
                };
                let tail = tail.trim_start();
                let v = if tail.starts_with("khz") {
                    v * 1e3
                } else if tail.starts_with("mhz") {
                    v * 1e6
                } else {
                    v
                };
                if v.is_finite() && v > 0.0 && !found.contains(&(v, c.line)) {
                    found.push((v, c.line));
                }
            }
        }
    }
    found
}

/// The time column's stamps must increase; say where they do not, by line.
fn require_increasing(path: &Path, name: &str, t: &[f64], lines: &[usize]) -> Result<f64> {
    if let Some(i) = t.windows(2).position(|w| w[1] <= w[0] || w[1].is_nan()) {
        return Err(Error::format(
            path,
            format!("line {}, column `{name}`", lines[i + 1]),
            format!(
                "time does not increase: {} after {} (line {})",
                t[i + 1],
                t[i],
                lines[i]
            ),
        ));
    }
    quality::rate_from_time(t).map_err(|m| Error::format(path, name, m.to_string()))
}

/// Loads the spec's channels from a delimited text file.
pub(crate) fn load(path: &Path, spec: &ImportSpec) -> Result<Loaded> {
    check_text_spec(path, spec)?;
    // First pass: the header, to find the time column by name.
    let mut wanted: Vec<Column> = spec.channels.iter().map(|c| c.source.clone()).collect();
    let explicit_time = match &spec.sample_rate {
        SampleRateSource::Time(s) => Some(s.clone()),
        _ => spec.time_column.clone(),
    };
    let bytes = std::fs::read(path).map_err(|e| Error::io(path, e))?;
    let lay = layout(path, as_text(path, &bytes)?, spec.delimiter)?;
    let time_src = explicit_time.or_else(|| {
        lay.header
            .iter()
            .find(|h| {
                let l = h.to_ascii_lowercase();
                l.starts_with("time") || l == "t"
            })
            .map(|h| Column::Name(h.clone()))
    });
    if let Some(t) = &time_src {
        wanted.push(t.clone());
    }
    let mut table = extract(path, lay, &wanted)?;
    let time = if time_src.is_some() {
        let p = *table.positions.last().expect("time column requested");
        Some((
            table.header[p].clone(),
            table.columns.pop().expect("time column"),
        ))
    } else {
        None
    };
    let from_comment = || rate_in_comments(path, &table.comments);
    let derive = |(name, t): &(String, Vec<f64>)| -> Result<(f64, String)> {
        let r = require_increasing(path, name, t, &table.lines)?;
        Ok((r, format!("time column `{name}`")))
    };
    let (rate, origin, declared) = match &spec.sample_rate {
        SampleRateSource::Value(v) => (*v, format!("given: {v} Hz"), true),
        SampleRateSource::Comment => match from_comment()? {
            Some((v, o)) => (v, o, true),
            None => {
                return Err(Error::format(
                    path,
                    "comments",
                    format!(
                        "no sample rate (`fs = ... Hz`, `sample rate: ...`) in the {} comment lines",
                        table.comments.len()
                    ),
                ));
            }
        },
        SampleRateSource::Time(_) => {
            let (r, o) = derive(time.as_ref().expect("time column requested"))?;
            (r, o, false)
        }
        SampleRateSource::Auto => match (from_comment()?, &time) {
            (Some((v, o)), _) => (v, o, true),
            (None, Some(t)) => {
                let (r, o) = derive(t)?;
                (r, o, false)
            }
            (None, None) => {
                return Err(Error::format(
                    path,
                    "sample rate",
                    format!(
                        "not found: no `# fs = ... Hz` comment and no time column (header: {}); \
                         give sample_rate = {{ value = ... }} or {{ time = \"column\" }}",
                        table.header_text()
                    ),
                ));
            }
        },
        SampleRateSource::Variable(_) => unreachable!("refused above"),
    };
    let mut meta = serde_json::Map::new();
    meta.insert("format".into(), "delimited text".into());
    meta.insert("delimiter".into(), String::from(table.delimiter).into());
    meta.insert("header_line".into(), table.header_line.into());
    if !table.comments.is_empty() {
        let c: Vec<serde_json::Value> = table
            .comments
            .iter()
            .map(|c| c.text.clone().into())
            .collect();
        meta.insert("comments".into(), c.into());
    }
    Ok(Loaded {
        values: std::mem::take(&mut table.columns),
        sample_rate_hz: rate,
        rate_origin: origin,
        rate_declared: declared,
        time,
        metadata: meta,
        source_texts: Vec::new(),
        notes: Vec::new(),
    })
}

/// What a text file cannot take: rows (of MAT-file matrices) and a
/// sample-rate variable.
fn check_text_spec(path: &Path, spec: &ImportSpec) -> Result<()> {
    for (k, c) in spec.channels.iter().enumerate() {
        if let Some(r) = c.row {
            return Err(Error::plan(
                format!("channels[{k}].row"),
                format!(
                    "row {r} applies to MAT-file matrices; in {} choose columns by name or number",
                    path.display()
                ),
            ));
        }
    }
    if let SampleRateSource::Variable(v) = &spec.sample_rate {
        return Err(Error::plan(
            "sample_rate.variable",
            format!(
                "`{v}`: a sample-rate variable applies to MAT-files; for {} give \
                 {{ value = ... }}, {{ time = \"column\" }} or \"comment\"",
                path.display()
            ),
        ));
    }
    Ok(())
}

/// The sample rate the comments state, and where; none where they state
/// none, an error where they state two.
fn rate_in_comments(path: &Path, comments: &[Comment]) -> Result<Option<(f64, String)>> {
    let rates = rates_in_comments(comments);
    match rates.as_slice() {
        [] => Ok(None),
        [(v, line)] => Ok(Some((*v, format!("comment on line {line}: {v} Hz")))),
        [(v, line), rest @ ..] => {
            if let Some((w, l2)) = rest.iter().find(|(w, _)| w != v) {
                Err(Error::format(
                    path,
                    format!("line {l2}"),
                    format!(
                        "the comments state two sample rates, {v} Hz (line {line}) and {w} Hz \
                         (line {l2}): give sample_rate = {{ value = ... }}"
                    ),
                ))
            } else {
                Ok(Some((*v, format!("comment on line {line}: {v} Hz"))))
            }
        }
    }
}
