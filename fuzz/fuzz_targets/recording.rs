//! A WAV + JSON recording: the sidecar's bytes, a NUL (which JSON text never
//! holds), then the WAV file's bytes. Reads it whole, then again block by
//! block with seeks, as the streaming reduction does.
#![no_main]
use hystid::record::{RecordingReader, read_recording_bytes};
use libfuzzer_sys::fuzz_target;

mod common;

#[global_allocator]
static ALLOC: common::Counting = common::Counting;
use std::path::Path;

fuzz_target!(|data: &[u8]| {
    common::bounded(data.len(), || {
        let (json, wav) = match data.iter().position(|&b| b == 0) {
            Some(i) => (&data[..i], &data[i + 1..]),
            None => (data, &[][..]),
        };
        let path = Path::new("fuzz");
        let _ = read_recording_bytes(path, json, wav.to_vec());
        let Ok(mut r) = RecordingReader::from_bytes(path, json, wav.to_vec()) else {
            return;
        };
        let mut out = vec![Vec::new(); r.meta().channels.len()];
        let frames = r.frames();
        let _ = r.seek_frame(frames / 2);
        while let Ok(n) = r.read_frames(1000, &mut out) {
            if n == 0 {
                break;
            }
        }
        let _ = r.seek_frame(frames + 1);
    });
});
