//! # hystid-core
//!
//! The lowest layer of hystid: what every stage shares and what needs no
//! recording or fit to exist.
//!
//! * [`error`]: the typed errors and the library's `Result`.
//! * [`harmonics`]: the Fourier, unit and FRF conventions, fixed once.
//! * [`signals`]: a recording in memory (channels, samples, excitation).
//! * [`model`]: the underlying linear modes and the [`model::Element`]s
//!   (Jenkins, eq. (10) Masing, Iwan, Bouc-Wen, effects), one trait used by
//!   both solvers.
//! * [`sim`]: the digital-filter time simulation (ramp-invariant sections,
//!   the element force fed back by an implicit per-sample solve).
//! * [`hb`]: harmonic balance with alternating frequency-time for the same
//!   elements.
//! * [`observe`]: the observer every long stage reports its progress to.
//! * [`atomic`]: files written whole or not at all.

#![deny(missing_docs)]

pub mod atomic;
pub mod error;
pub mod harmonics;
pub mod hb;
pub mod model;
pub mod observe;
pub mod signals;
pub mod sim;

pub use error::{Error, Result};
