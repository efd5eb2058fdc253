//! Recordings: the WAV + JSON interchange format and MCAP run files.
//!
//! A [`Recording`] is a multi-channel sampled measurement plus what its
//! samples mean (`docs/src/reference/recording-format.md`, "hystid.recording.v1"):
//! channel quantities, units and calibration, and the excitation (stepped-sine
//! dwells or a sweep). Virtual tests write one; `import` converts real data
//! into one; `extract` reduces one into nonlinear FRFs.
//!
//! * [`read_recording`] / [`write_recording`]: the WAV + JSON pair (float 32
//!   or integer PCM 16/24/32), validated field by field; [`RecordingReader`]
//!   streams a file of any size block by block.
//! * [`McapRecorder`] / [`read_run`]: a run's full record in one MCAP file
//!   (signal blocks in ROS 2 CDR, a decimated preview, dwell and fit messages,
//!   the test definition), viewable in Foxglove and readable by the official
//!   MCAP libraries; [`McapRun::to_recording`] turns it back into a
//!   [`Recording`]; [`McapRunReader`] reads it frame by frame without
//!   holding its samples.
//!
//! This module only serialises: it knows nothing of benches or analysis.
//! The in-memory types ([`Recording`], [`RecordingMeta`], …) are defined in
//! [`crate::signals`] and re-exported here, so that the analysis stages use
//! them without depending on the format; [`RecordingReader`] is also a
//! [`FrameSource`] for the streaming reduction.

mod cdr;
mod run;
mod run_reader;
mod sidecar;
mod wav;
mod zstd_window;

pub use run::{
    McapRecorder, McapRun, RUN_FORMAT, RUN_METADATA, RunInfo, SIGNAL_BLOCK_FRAMES, StepSignals,
    TEST_ATTACHMENT, TOPIC_DWELL, TOPIC_FIT, TOPIC_PREVIEW, TOPIC_SIGNALS, read_run,
    read_run_bytes,
};
pub use run_reader::McapRunReader;
pub use wav::{
    RecordingReader, RecordingWriter, SampleFormat, read_recording, read_recording_bytes,
    write_recording,
};
// The in-memory types are the format's content but not the format: they live
// in `signals` so that the analysis stages can use them without the file code.
pub use crate::signals::{
    Channel, Excitation, ExcitationKind, FORMAT_V1, FrameSource, Recording, RecordingMeta, Step,
    Sweep,
};

/// Index of the first sample whose magnitude is not `<= limit` (NaN, ±Inf or
/// beyond the limit). Checks blocks without branching so the common all-good
/// case vectorises; only a bad block is searched sample by sample.
pub(crate) fn first_out_of_range(x: &[f64], limit: f64) -> Option<usize> {
    const BLOCK: usize = 256;
    for (k, block) in x.chunks(BLOCK).enumerate() {
        if !block.iter().fold(true, |ok, v| ok & (v.abs() <= limit)) {
            return block
                .iter()
                .position(|v| !(v.abs() <= limit))
                .map(|i| k * BLOCK + i);
        }
    }
    None
}
