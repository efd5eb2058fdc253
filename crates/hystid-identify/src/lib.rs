//! # hystid-identify
//!
//! The identification layer of hystid, over [`hystid_signal`] and
//! [`hystid_core`]: a model fitted to recordings, checked against them and
//! diagnosed.
//!
//! * [`fit`]: the paper's estimation loop (eq. 9), in the frequency and the
//!   time domain, with uncertainty.
//! * [`validate`]: a fitted model driven by a recording's measured force in
//!   the time domain and compared with the measured response (e_RMS).
//! * [`diagnose`]: the residual traced to a missing effect, added and
//!   refitted.
//!
//! The lower layers' modules are re-exported under the same names.

#![deny(missing_docs)]

pub use hystid_core::{Error, Result, atomic, error, harmonics, hb, model, observe, signals, sim};
pub use hystid_signal::{extract, import, plot, record, testbench};

pub mod diagnose;
pub mod fit;
pub mod validate;
