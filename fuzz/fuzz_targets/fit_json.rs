//! fit.json, as `validate` and `diagnose` read it.
#![no_main]
use hystid::analysis::FitReport;
use libfuzzer_sys::fuzz_target;

mod common;

#[global_allocator]
static ALLOC: common::Counting = common::Counting;
use std::path::Path;

fuzz_target!(|data: &[u8]| {
    common::bounded(data.len(), || {
        if let Ok(r) = FitReport::parse(Path::new("fit.json"), data) {
            let _ = r.final_model();
        }
    });
});
