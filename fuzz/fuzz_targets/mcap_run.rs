//! An MCAP run file: read with CRC checks, then turned into a recording, as
//! `extract`/`identify` do.
#![no_main]
use hystid::record::read_run_bytes;
use libfuzzer_sys::fuzz_target;

mod common;

#[global_allocator]
static ALLOC: common::Counting = common::Counting;
use std::path::Path;

fuzz_target!(|data: &[u8]| {
    common::bounded(data.len(), || {
        if let Ok(run) = read_run_bytes(Path::new("fuzz.mcap"), data) {
            let _ = run.to_recording();
        }
    });
});
