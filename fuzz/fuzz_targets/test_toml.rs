//! TOML: a test definition (checked, then everything `simulate` derives
//! from it), a structure definition, and an import spec.
#![no_main]
use hystid::import::ImportSpec;
use hystid::testbench::{StructureDefinition, TestDefinition};
use libfuzzer_sys::fuzz_target;

mod common;

#[global_allocator]
static ALLOC: common::Counting = common::Counting;

fuzz_target!(|data: &[u8]| {
    common::bounded(data.len(), || {
        let Ok(text) = std::str::from_utf8(data) else {
            return;
        };
        if let Ok(def) = TestDefinition::from_toml(text, "fuzz.toml") {
            let _ = def.sweeps();
            let _ = def.sample_rate_hz();
            let _ = def.oversample();
        }
        if let Ok(s) = StructureDefinition::from_toml(text, "fuzz.toml") {
            let _ = s.model();
        }
        let _ = toml::from_str::<ImportSpec>(text);
    });
});
