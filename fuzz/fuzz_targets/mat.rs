//! MAT v5: index the file, then read every variable and its signals, as
//! `import` does.
#![no_main]
use hystid::import::mat::MatFile;
use libfuzzer_sys::fuzz_target;

mod common;

#[global_allocator]
static ALLOC: common::Counting = common::Counting;
use std::path::Path;

fuzz_target!(|data: &[u8]| {
    common::bounded(data.len(), || {
        let path = Path::new("fuzz.mat");
        let Ok(file) = MatFile::from_bytes(path, data.to_vec()) else {
            return;
        };
        let _ = file.listing();
        for v in file.variables() {
            let _ = v.describe();
            if let Ok(a) = file.read(&v.name) {
                for index in [None, Some(1), Some(2)] {
                    let _ = a.signal(index, path);
                }
            }
        }
    });
});
