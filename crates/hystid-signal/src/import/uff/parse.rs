//! A whole UFF file parsed into its datasets.

use super::cursor::{
    Cursor, Where, binary_header, is_blank, is_delimiter, shown, skip_dataset, text,
};
use super::dataset58::read_58;
use super::types::{Dataset, UffFile};
use crate::{Error, Result};
use std::path::Path;

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

impl UffFile {
    /// Reads and parses a file.
    pub fn open(path: &Path) -> Result<UffFile> {
        let bytes = std::fs::read(path).map_err(|e| Error::io(path, e))?;
        parse(path, &bytes)
    }
}
