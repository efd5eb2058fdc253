//! One observer for every long stage.
//!
//! The test bench, the fit and the diagnosis report what they are doing to
//! an [`Observer`] (a progress bar, a trace writer, a log), with an
//! [`Event`] saying which stage and what happened. Nothing in the library
//! prints; the command line draws its progress from these events. An
//! observer is called from worker threads (dwells and candidates run in
//! parallel), so it is `Sync`; what it sees does not change the results.

use serde::{Deserialize, Serialize};

/// What a stage just did.
#[derive(Clone, Copy, Debug)]
pub enum Event<'a> {
    /// The test bench finished a dwell.
    Dwell {
        /// Its level's index.
        level_index: usize,
        /// Its frequency, Hz.
        frequency_hz: f64,
    },
    /// The fit evaluated its cost at one parameter set.
    Cost(&'a TraceEntry),
    /// The diagnosis moved on.
    Diagnosis(&'a DiagnoseEvent),
    /// A stage that works through a known amount moved on: `done` of
    /// `total` (samples simulated, dwells or sweep stages reduced).
    Progress {
        /// What the stage is doing (`simulating`, `reducing`, and a
        /// validation's `reducing the measured and simulated responses`).
        task: &'static str,
        /// How much of it is done.
        done: u64,
        /// How much there is.
        total: u64,
    },
}

/// One cost evaluation of a fit, for traces and progress.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct TraceEntry {
    /// Evaluation number.
    pub evaluation: usize,
    /// Cost (sum of squared residuals, plus any bound penalty).
    pub cost: f64,
    /// Physical parameter values.
    pub parameters: Vec<f64>,
}

/// What a diagnosis is doing, for progress displays.
#[derive(Clone, Debug, PartialEq)]
pub enum DiagnoseEvent {
    /// The baseline refit on the judged harmonics is done.
    Baseline {
        /// Its `χ²/dof`.
        chi2_per_dof: f64,
    },
    /// A round starts with this many candidates.
    Round {
        /// The round (1 = on the baseline).
        round: usize,
        /// Candidates tried in it.
        candidates: usize,
    },
    /// One candidate's refit is done (or failed).
    Candidate {
        /// The round.
        round: usize,
        /// The effect.
        effect: EffectName,
    },
    /// The best candidate's resolution is being checked.
    Checking {
        /// The effect.
        effect: EffectName,
    },
}

/// An effect a diagnosis works on, by its contract name (`cubic_stiffness`):
/// the diagnosis's effects are its own, and the observer sits below it.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct EffectName(pub &'static str);

impl EffectName {
    /// The contract name.
    pub fn name(self) -> &'static str {
        self.0
    }
}

/// Samples a long simulation runs between two [`Event::Progress`] reports
/// (and checks for [`Observer::cancelled`]): a few tens of milliseconds.
pub const SAMPLES_PER_REPORT: usize = 1 << 18;

/// Told of every [`Event`] of the stages it is handed to.
pub trait Observer: Sync {
    /// One event (from any thread).
    fn observe(&self, event: Event<'_>);
    /// Whether the caller wants the work stopped (a user's interrupt, seen
    /// by a binding that cannot kill its host process). The test bench
    /// checks it after each dwell, the fits before each evaluation, the
    /// diagnosis before each candidate, a simulation every
    /// [`SAMPLES_PER_REPORT`] samples and a reduction after each dwell or
    /// stage of a sweep, and they return
    /// [`crate::error::Error::Cancelled`]; what a stage returns then is
    /// not a result.
    fn cancelled(&self) -> bool {
        false
    }
}

impl<F: Fn(Event<'_>) + Sync> Observer for F {
    fn observe(&self, event: Event<'_>) {
        self(event)
    }
}

/// Tells `observer` that `task` has done `done` of `total`, then
/// [`crate::Error::Cancelled`] if it asks the work to stop there.
pub fn progress(
    observer: &dyn Observer,
    task: &'static str,
    done: u64,
    total: u64,
) -> crate::Result<()> {
    observer.observe(Event::Progress { task, done, total });
    if observer.cancelled() {
        return Err(crate::Error::Cancelled);
    }
    Ok(())
}

/// An observer that ignores everything.
#[derive(Clone, Copy, Debug, Default)]
pub struct Silent;

impl Observer for Silent {
    fn observe(&self, _: Event<'_>) {}
}
