//! UFF 58/58b: parse, list, and turn every function into channels, as
//! `import` does.
#![no_main]
use hystid::import::uff;
use libfuzzer_sys::fuzz_target;

mod common;

#[global_allocator]
static ALLOC: common::Counting = common::Counting;
use std::path::Path;

fuzz_target!(|data: &[u8]| {
    common::bounded(data.len(), || {
        let path = Path::new("fuzz.uff");
        let Ok(file) = uff::parse(path, data) else {
            return;
        };
        let _ = file.listing();
        for (_, f) in file.functions() {
            let _ = uff::time_channel(f);
        }
        let _ = uff::channels(path, &file);
    });
});
