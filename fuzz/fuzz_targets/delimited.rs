//! CSV/TSV: the first byte picks the separator (or detection) and the file
//! name's extension; the rest is the file. Reads columns 1 and 2 and a column
//! named `time`, then the rates stated in comments.
#![no_main]
use hystid::import::delimited::{parse_columns, rates_in_comments};
use hystid::import::{Delimiter, Source};
use libfuzzer_sys::fuzz_target;

mod common;

#[global_allocator]
static ALLOC: common::Counting = common::Counting;
use std::path::Path;

fuzz_target!(|data: &[u8]| {
    common::bounded(data.len(), || {
        let Some((&mode, bytes)) = data.split_first() else {
            return;
        };
        let delimiter = match mode % 4 {
            0 => None,
            1 => Some(Delimiter::Char(b',')),
            2 => Some(Delimiter::Char(b'\t')),
            _ => Some(Delimiter::Whitespace),
        };
        let path = Path::new(if mode & 4 == 0 {
            "fuzz.csv"
        } else {
            "fuzz.tsv"
        });
        let wanted = [
            Source::Index(1),
            Source::Index(2),
            Source::Name("time".into()),
        ];
        for w in [&wanted[..1], &wanted[..2], &wanted[..]] {
            if let Ok(t) = parse_columns(path, bytes, delimiter, w) {
                let _ = rates_in_comments(&t.comments);
                let _ = t.header_text();
            }
        }
    });
});
