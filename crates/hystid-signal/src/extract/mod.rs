//! Harmonic extraction: from sampled force and response to nonlinear FRFs.
//!
//! The same code reduces a virtual test and a real recording (paper
//! section 3). Conventions are those of [`crate::harmonics`]:
//! `H_h = Y_h / F_1` with the measured force fundamental.
//!
//! * [`HarmonicAnalyser::coherent`]: the virtual bench's dwells, sampled with
//!   whole periods per block, one FFT per block (no leakage).
//! * [`noncoherent`]: a dwell of a real recording at a known frequency, by a
//!   least-squares fit of the harmonics over blocks of whole periods;
//!   [`estimate_frequency`] finds the frequency.
//! * [`reduce_stepped`]: a stepped-sine [`Recording`](crate::signals::Recording),
//!   with its stated steps or with dwells found in the reference
//!   ([`find_dwells_whole`]); [`combine`] merges single-dwell recordings;
//!   [`reduce_stepped_by_dwell`] reduces a recording too large for memory one
//!   dwell at a time from a [`FrameSource`](crate::signals::FrameSource).
//!
//! This stage reads samples, never files: the file formats are
//! [`crate::record`]'s, which provides the readers.
//! * [`reduce_sweep`]: a swept sine, following the reference's phase;
//!   [`choose_compensation`] picks its sweep-distortion compensation.
//! * [`find_period`] and [`periodic_frf`]: a periodic excitation (a
//!   multisine played several times), its period and the FRF at its lines;
//!   [`lines`]: the response's mean and noise at the lines of its period, and
//!   a replay's residual there (what a validation and a diagnosis judge).
//! * [`subharmonic`]: a dwell's response at `f/2` or `f/3` (a
//!   period-doubled contact), which harmonic balance at the drive's period
//!   cannot describe.
//! * [`welch_h1`]: a broadband (random) drive's FRF and coherence by
//!   Welch averaging.
//! * [`naive`]: direct-sum references for tests and benchmarks.
//!
//! All dwell estimates use the H1 estimator over blocks,
//! `H_k = Σ_b Y_bk F_b1* / Σ_b |F_b1|²`, which is unbiased under response
//! noise (it averages out of the cross-spectrum; noise on the force would
//! bias it low), with the standard error of
//! [`DwellHarmonics::std_error`].

pub(crate) mod analytic;
pub use analytic::next_smooth;
mod blocks;
mod coherent;
mod compensation;
mod dwell_blocks;
mod estimator;
pub mod lines;
mod lsq;
pub mod naive;
mod noncoherent;
mod periodic;
mod stepped;
mod streaming;
mod subharmonic;
mod sweep;
mod sweep_blocks;
mod sweep_reduce;
mod welch;

pub use blocks::WHOLE_RECORD_FRAMES;
pub use coherent::{HarmonicAnalyser, harmonics_agree};
pub use compensation::{TIME_CONSTANTS, choose_compensation, resonance_time_constant};
pub use dwell_blocks::{FINDING, find_dwells};
pub use noncoherent::{estimate_frequency, noncoherent};
pub use periodic::{
    EXCITED_LINE, Line, PERIOD_SEARCH, PERIODIC_CORRELATION, find_period, periodic_frf,
};
pub use stepped::{
    DwellOptions, DwellReport, ReduceOptions, Settling, SteppedReduction, below_resolution,
    combine, combine_with, find_dwells_whole, reduce_stepped, reduce_stepped_report, settling,
};
pub use streaming::reduce_stepped_by_dwell;
pub use subharmonic::{SUBHARMONIC_RATIO, SUBHARMONIC_SIGNIFICANCE, Subharmonic, subharmonic};
pub use sweep::{
    MAX_SWEEP_POINTS, SweepFit, SweepLaw, SweepOptions, SweepReduction, find_sweep_whole,
};
pub use sweep_blocks::find_sweep;
pub use sweep_reduce::{reduce_sweep, reduce_sweep_recording};
pub use welch::{DEFAULT_SEGMENT, MIN_AVERAGES, WelchFrf, welch_h1};

use crate::harmonics::Quantity;
use num_complex::Complex64;
use serde::{Deserialize, Serialize};

/// Sweep direction of a series of points.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Direction {
    /// Increasing frequency.
    #[default]
    Up,
    /// Decreasing frequency.
    Down,
}

/// The harmonics of one analysed dwell (or sweep window).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct DwellHarmonics {
    /// Force harmonics `F_0..F_K` (single-sided, [`crate::harmonics`]).
    pub force: Vec<Complex64>,
    /// Response harmonics `Y_0..Y_K`.
    pub response: Vec<Complex64>,
    /// `H_k = Y_k/F_1`, `k = 0..K` (H1 estimator over blocks).
    pub h: Vec<Complex64>,
    /// Standard error of each `H_k`: the RMS of the complex estimation error,
    /// `sqrt(E|Ĥ_k − H_k|²)`, from the block-to-block scatter.
    pub std_error: Vec<f64>,
    /// Blocks averaged.
    pub blocks: usize,
}

/// One point of a nonlinear FRF.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct FrfPoint {
    /// Excitation frequency, Hz.
    pub frequency_hz: f64,
    /// Measured force fundamental amplitude `|F_1|`, in the reference unit.
    pub force_amplitude: f64,
    /// `H_k = Y_k/F_1`, `k = 0..K`.
    pub h: Vec<Complex64>,
    /// Standard error of each `H_k` (see [`DwellHarmonics::std_error`]).
    pub std_error: Vec<f64>,
    /// Force harmonics relative to the fundamental, `F_k/F_1` (distortion of
    /// the drive; `[1] = 1`).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub force_distortion: Vec<Complex64>,
    /// Blocks averaged.
    pub blocks: usize,
    /// Periods spent settling before the measurement.
    #[serde(default)]
    pub settle_periods: usize,
    /// False when the settling cap was reached before the harmonics agreed.
    #[serde(default = "yes")]
    pub settled: bool,
    /// The response repeated only every 2 or 3 drive periods (see
    /// [`subharmonic`]): harmonic balance at the drive's period cannot
    /// describe the dwell, and its fits leave it out.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub subharmonic: Option<Subharmonic>,
}

/// Force and response must be sampled together: an error naming `field`
/// when their lengths differ.
pub(crate) fn check_paired(
    force: &[f64],
    response: &[f64],
    field: impl Into<String>,
) -> crate::error::Result<()> {
    if force.len() != response.len() {
        return Err(crate::error::Error::input(
            field,
            format!(
                "has {} samples but the force has {}: they must be sampled together",
                response.len(),
                force.len()
            ),
        ));
    }
    Ok(())
}

fn yes() -> bool {
    true
}

/// The FRF points measured at one excitation level, in measurement order.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct FrfLevel {
    /// Nominal level, in the reference channel's unit.
    pub level: f64,
    /// Sweep direction of the series.
    pub direction: Direction,
    /// Points in measurement order.
    pub points: Vec<FrfPoint>,
}

/// Nonlinear FRFs: per level, per frequency, per harmonic.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct NonlinearFrf {
    /// Quantity of the response (`H` is receptance, mobility or accelerance).
    pub response: Quantity,
    /// Quantity of the reference (force, or voltage for an amplifier drive).
    pub reference: Quantity,
    /// Highest harmonic `K`.
    pub max_harmonic: usize,
    /// The levels.
    pub levels: Vec<FrfLevel>,
}
