//! The analysis stage: what the command-line tool does with files, as
//! library calls.
//!
//! A recording on disk (MCAP run file or WAV + JSON) is loaded with the test
//! definition it recorded, its response channel chosen, and reduced into
//! nonlinear FRFs ([`recording`]), which are written as JSON, CSV and UFF
//! ([`frf_uff`]); the FRFs are fitted and the fit written as
//! `fit.json` with its figures ([`identify`]); a fit is validated by
//! simulation on recordings ([`validate`]); a virtual test is run into its
//! files ([`simulate`]); a fit's residual is diagnosed ([`diagnose`]); and the
//! whole run is summarised in `run.json` and `report.md` ([`run`]).
//!
//! Nothing here prints: progress reaches the caller through observer
//! callbacks, and every report is returned as data.

pub mod diagnose;
pub mod diagnosis_figures;
pub mod figures;
pub mod flags;
pub mod frf_uff;
pub mod identify;
pub mod import;
pub mod multisine;
pub mod paths;
pub mod points;
pub mod recording;
pub mod request;
pub mod run;
pub mod simulate;
pub mod validate;

pub use flags::{Flag, flag_estimates, flag_words, flags_of};
pub use identify::{
    Comparison, FitReport, PeriodicStart, TimeFitReport, compare, periodic_start,
    periodic_start_of, reference_joint, run_fit, run_time_fit, run_time_fit_from_start,
    run_time_fit_from_start_signed, time_records, time_records_in, write_fit_plots,
};
pub use recording::{
    ChannelChoice, Compensation, HeldRecording, Loaded, MULTISINE_LINES, Reduced, ReductionOptions,
    SineTest, band_limited, combine_recordings, excitation_of, load_held_reference_and_response,
    load_recording, load_reference_and_response, load_time_record, reduce, reduce_path,
    reduce_recordings, response_channel, sweep_options,
};

use crate::error::{Error, Result};
use std::path::Path;

/// The tool version written into every report.
pub const VERSION: &str = env!("CARGO_PKG_VERSION");

/// Writes a value as pretty JSON, atomically.
pub fn write_json(path: &Path, value: &impl serde::Serialize) -> Result<()> {
    let bytes = serde_json::to_vec_pretty(value)
        .map_err(|e| Error::format(path, "JSON", format!("cannot serialise: {e}")))?;
    crate::atomic::write_bytes(path, &bytes)
}
