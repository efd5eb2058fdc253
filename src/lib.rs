//! # hystid
//!
//! Testing and identification of friction joints in vibrating structures,
//! after Magnevall, Josefsson & Ahlin, *Parameter estimation of hysteresis
//! elements using harmonic input* (IMAC).
//!
//! The pipeline, one module per stage:
//!
//! ```text
//! model ──► sim ──► testbench ──► extract ──► fit ◄── hb ◄── model
//!                                     │          │
//!                                     ▼          ▼
//!                                  record     diagnose ──► (model + effect) ──► fit again
//! ```
//!
//! * [`model`]: the underlying linear modes and the [`model::Element`]s (Jenkins,
//!   eq. (10) Masing, effects), one trait used by both solvers.
//! * [`sim`]: the digital-filter time simulation (ramp-invariant sections, the
//!   element force fed back by an implicit per-sample solve).
//! * [`extract`]: harmonics and nonlinear FRFs from sampled signals.
//! * [`testbench`]: the virtual stepped-sine test (dwells, settling, noise).
//! * [`signals`]: a recording in memory (channels, samples, excitation), shared
//!   by the stages that produce and reduce one without the file format.
//! * [`record`]: the WAV + JSON recording format and MCAP run files.
//! * [`import`]: MAT, CSV and UFF 58 files converted into recordings, with data
//!   checks (and the UFF 58 writer the FRF export uses).
//! * [`validate`]: a fitted model driven by a recording's measured force in
//!   the time domain and compared with the measured response (e_RMS).
//!
//! * [`hb`]: harmonic balance with alternating frequency–time for the same elements.
//! * [`fit`]: the paper's estimation loop (eq. 9), uncertainty, and optimisers.
//! * [`diagnose`]: the residual traced to a missing effect, added and refitted.
//! * [`import`], [`plot`]: real data in, figures out.
//! * [`analysis`]: the stages over files, as the command-line tool runs
//!   them: recordings loaded and reduced, fits and diagnoses written with
//!   their figures and reports.
//!
//! Conventions (Fourier, units, FRF definition) are fixed once in
//! [`harmonics`].

#![deny(missing_docs)]

pub use hystid_core::{Error, Result, atomic, error, harmonics, hb, model, observe, signals, sim};
pub use hystid_identify::{diagnose, fit, validate};
pub use hystid_signal::{extract, import, plot, record, testbench};

pub mod analysis;
