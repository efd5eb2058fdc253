//! # hystid-signal
//!
//! The signal layer of hystid, over [`hystid_core`]: samples in, harmonics
//! and files out.
//!
//! * [`extract`]: harmonics and nonlinear FRFs from sampled signals.
//! * [`testbench`]: the virtual stepped-sine test (dwells, settling, noise).
//! * [`record`]: the WAV + JSON recording format and MCAP run files.
//! * [`import`]: MAT, CSV and UFF 58 files converted into recordings, with
//!   data checks (and the UFF 58 writer the FRF export uses).
//! * [`plot`]: the figures.
//!
//! The core's modules are re-exported under the same names, so that a path
//! reads the same in every layer.

#![deny(missing_docs)]

pub use hystid_core::{Error, Result, atomic, error, harmonics, hb, model, observe, signals, sim};

pub mod extract;
pub mod import;
pub mod plot;
pub mod record;
pub mod testbench;
