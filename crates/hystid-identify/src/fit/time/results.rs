//! What a time-domain fit reports: each recording's error, each start's
//! outcome, and what the recordings refitted alone say.

use crate::error::Error;
use crate::fit::identify::Estimate;
use crate::fit::optimise::{FitStatus, OptimiserRun};
use crate::harmonics::Quantity;
use crate::model::Model;
use crate::validate::ErrorMetrics;
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;

/// The error of a model on one recording.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct RecordError {
    /// The recording.
    pub recording: String,
    /// Over its judged window.
    pub window: ErrorMetrics,
    /// Segments judged (dwells of a stepped sine).
    pub segments: usize,
    /// The root mean square over segments of each one's relative `e_RMS`
    /// (what the fit minimises, per recording).
    pub segment_relative: f64,
}

/// A time-domain fit.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct TimeFitResult {
    /// The fitted model.
    pub model: Model,
    /// The model predicts `response_sign × measured`.
    pub response_sign: f64,
    /// The free parameters by name.
    pub parameters: BTreeMap<String, Estimate>,
    /// Each recording's error with the starting model.
    pub before: Vec<RecordError>,
    /// Each recording's error with the fitted model.
    pub after: Vec<RecordError>,
    /// The optimiser's run.
    pub optimiser: OptimiserRun,
    /// How it ended.
    pub status: FitStatus,
    /// Samples judged, over all recordings.
    pub samples: usize,
    /// Notes for the user.
    pub notes: Vec<String>,
    /// The parameters that ended at (within 1 % of) a bound of the fit.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub at_bound: Vec<String>,
    /// Where the fit descended from more than one start
    /// ([`TimeFitOptions::starts`]): how each ended.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub starts: Vec<StartOutcome>,
    /// The quantity of the recordings' reference (a force or a voltage):
    /// `validate` refuses a recording driven by the other.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub reference_quantity: Option<Quantity>,
    /// The response's acquisition chain the replays were put through
    /// ([`TimeFitOptions::acquisition`]): `validate` puts its replays
    /// through it too.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub acquisition: Option<crate::validate::acquisition::Acquisition>,
    /// With [`TimeFitOptions::each_alone`]: each recording refitted alone
    /// from the fitted model.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub each_alone: Vec<AloneFit>,
}

/// One recording of a fit over several, refitted alone from the fit's
/// model ([`TimeFitOptions::each_alone`]).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct AloneFit {
    /// The recording.
    pub recording: String,
    /// Its relative `e_RMS` over its judged window in the fit of every
    /// recording (its `after` figure).
    pub together: f64,
    /// The same figure refitted alone (`None`: the refit failed).
    pub alone: Option<f64>,
    /// How the refit ended.
    pub status: FitStatus,
    /// Why it failed.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub failed: Option<String>,
}

impl AloneFit {
    /// How many times closer the recording comes alone (`None`: its refit
    /// failed, or it is exact either way).
    pub fn closer(&self) -> Option<f64> {
        self.alone.filter(|a| *a > 0.0).map(|a| self.together / a)
    }
}

/// How much closer than together a recording must come alone, at the
/// median, before the fit is said to miss what changes between them.
/// A model that holds every recording leaves each the same residual alone
/// or together but for the few parameters an alone fit adapts to thousands
/// of samples' noise (the consistent case of
/// `tests::recordings_fitted_alone_tell_a_wrong_dependence_on_level`:
/// 1.00x); a quarter is far outside that and well inside what a level
/// dependence the model lacks gives (a stick stiffness that changed
/// between the runs there: 9.7x; the UNESP beam's chirps: 2.4x).
pub const CLOSER_ALONE: f64 = 1.25;

/// What the recordings refitted alone say ([`TimeFitOptions::each_alone`]):
/// a note for the user, `None` without two refits that ended.
pub fn level_consistency(alone: &[AloneFit]) -> Option<String> {
    let mut closer: Vec<f64> = alone.iter().filter_map(AloneFit::closer).collect();
    if closer.len() < 2 {
        return None;
    }
    closer.sort_by(f64::total_cmp);
    let median = if closer.len() % 2 == 1 {
        closer[closer.len() / 2]
    } else {
        0.5 * (closer[closer.len() / 2 - 1] + closer[closer.len() / 2])
    };
    let each: Vec<String> = alone
        .iter()
        .map(|a| match a.alone {
            Some(x) => format!(
                "{} {:.2} % -> {:.2} %",
                a.recording,
                100.0 * a.together,
                100.0 * x
            ),
            None => format!("{} (its refit failed)", a.recording),
        })
        .collect();
    let each = each.join(", ");
    Some(if median >= CLOSER_ALONE {
        format!(
            "refitted alone, the recordings come {median:.2}x closer at the median ({each}, of \
             the RMS): the model reaches each recording but not all of them at once, so what it \
             lacks changes from one to the next (the joint law's dependence on level, or a \
             structure that changed between the runs), not a shape they share"
        )
    } else {
        format!(
            "refitted alone, the recordings come {median:.2}x closer at the median ({each}, of \
             the RMS): what the model misses is shared by every recording (a mode, a law's \
             shape, the noise), not its dependence on level"
        )
    })
}

/// How one start of a fit ended.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct StartOutcome {
    /// 0 for the given start, `k` for the `k`-th spread about it.
    pub start: usize,
    /// The cost it descended to (`None`: it failed).
    pub cost: Option<f64>,
    /// Its misfit, the cost without the bounds' penalty, on the grid the
    /// last start ended on: what the starts are compared by.
    pub misfit: Option<f64>,
    /// How it ended.
    pub status: FitStatus,
    /// Why it failed.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub failed: Option<String>,
}

impl StartOutcome {
    pub(super) fn of(
        start: usize,
        run: std::result::Result<&OptimiserRun, &Error>,
        misfit: Option<f64>,
    ) -> StartOutcome {
        match run {
            Ok(r) => StartOutcome {
                start,
                cost: Some(r.cost),
                misfit,
                status: r.status,
                failed: None,
            },
            Err(e) => StartOutcome {
                start,
                cost: None,
                misfit: None,
                status: FitStatus::Stopped,
                failed: Some(e.to_string()),
            },
        }
    }
}
