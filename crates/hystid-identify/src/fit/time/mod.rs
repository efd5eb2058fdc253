//! Output-error identification in the time domain: the model driven by the
//! measured force, its simulated response matched to the measured one sample
//! by sample.
//!
//! The FRF fit (paper eq. 9) matches steady-state harmonics, one dwell at a
//! time, each started from a virgin joint. A recording is more than that: the
//! joint carries its state from one dwell to the next (where it settles under
//! a static load depends on the loads before), a sweep is never steady, and
//! a transient holds information a steady state hides. Here the recording is
//! replayed whole through the digital-filter simulator (the same replay as
//! [`crate::validate`]), and the parameters minimise
//!
//! `Σ_s Σ_{i ∈ s} (y_sim(i) − y_meas(i))² / (N_s · RMS_s²)`,
//!
//! the sum over segments `s` of the recordings of each segment's squared
//! relative `e_RMS` (`N_s` samples, `RMS_s` the measured response's RMS
//! there). A swept or unknown record is one segment; a stepped sine is cut
//! at its dwells' starts (stated in the recording, else found from the
//! reference), so each dwell counts as much as any other, as each point does
//! in the FRF fit: levels span decades, and one RMS over the record would
//! judge the loudest level only. The simulation starts from rest; a
//! recording that does not is given a window that starts after its
//! transient.
//!
//! The optimiser is Levenberg–Marquardt on those residuals (a forward
//! difference Jacobian, one replay per free parameter, in parallel), in the
//! bounded coordinates of [`super::params`]; a model the simulator rejects
//! (unstable, beyond the resampling limit) is a bad point whose residual is
//! twice the measured response, never an error. Confidence intervals take the
//! residual as white noise (`cov = s² (JᵀJ)⁻¹`, `s²` its mean square): right
//! for measurement noise, optimistic where model error dominates (it is
//! correlated in time), which the reported relative error shows.

mod driver;
mod folded;
mod intervals;
mod judging;
mod options;
mod problem;
mod records;
mod results;
mod starts;
mod streamed;

pub use driver::{identify_time, refit_each_alone, time_parameters};
pub use judging::{MAX_JUDGED_SAMPLES, MIN_JUDGED_PER_PERIOD, judging_factors};
pub use options::TimeFitOptions;
pub use problem::{JACOBIAN_HELD_UP_TO, TimeProblem};
pub use records::TimeRecord;
pub use results::{
    AloneFit, CLOSER_ALONE, RecordError, StartOutcome, TimeFitResult, level_consistency,
};
pub use starts::{
    START_DAMPING, START_JOINT, START_JUDGED_SAMPLES, START_SLIP_RMS, START_STRUCTURE, StartShape,
    closest_start, linear_modes_at_lines, periodic_starts, periodic_starts_modal, spread_start,
};

#[cfg(test)]
mod tests;
