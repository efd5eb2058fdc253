//! The options of a time-domain fit.

use super::judging::MAX_JUDGED_SAMPLES;
use crate::validate::DriveInput;
use serde::{Deserialize, Serialize};

/// Options of [`identify_time`].
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct TimeFitOptions {
    /// Samples per period of the model's highest linearised frequency below
    /// which the replay is upsampled (see [`crate::validate`]). Default 40,
    /// twice validation's: at 20 the filter's error at a stick mode (about
    /// 1 % in the response) is as large as a fit's whole residual can be
    /// on a good recording, and the fit would bend the parameters to it.
    pub min_samples_per_period: f64,
    /// Levenberg–Marquardt's patience: at most `patience·(n+1)` residual
    /// evaluations.
    pub patience: usize,
    /// Whether the linear part's parameters are refined with the elements'.
    pub refine_linear: bool,
    /// What the force is between its samples (see [`DriveInput`]).
    pub input: DriveInput,
    /// How many starts the fit descends from: the given one and `starts −
    /// 1` others spread about it (see [`spread_start`]); the one with the
    /// lowest misfit (the cost without the bounds' penalty) is kept. A
    /// time fit over several modes, a joint and a shaker has more than one
    /// basin, and which one Levenberg–Marquardt settles in depends on where
    /// it starts.
    #[serde(default = "one")]
    pub starts: usize,
    /// Most samples the fit judges, over all its recordings. Levenberg–
    /// Marquardt holds a Jacobian of a row per judged sample and a column
    /// per parameter, and each residual vector a value per sample: judged
    /// at every one of the default test's 8.2 M frames, 66 MB a vector and
    /// 330 MB a Jacobian of five parameters. A fit that would judge more
    /// judges its recordings at `1/k` of their rate, `k` the smallest
    /// factor that brings it within this (never one that leaves fewer than
    /// [`MIN_JUDGED_PER_PERIOD`] samples a period of the start model's
    /// highest linearised frequency): the measured and simulated responses
    /// low-passed alike (a windowed sinc) and kept at every `k`-th sample.
    /// What the model makes lies well inside the pass band, so the misfit
    /// is the same but for the measurement noise above it, which carries
    /// no information on the model. Where that floor (or the largest
    /// factor) leaves more than this, each segment is judged on its share
    /// of it, in stretches spread over the segment (see
    /// [`judged_stretches`]): the Jacobian stays within this whatever the
    /// recording's length. The replays, and every error reported, are
    /// still over every sample.
    #[serde(default = "max_judged")]
    pub max_judged_samples: usize,
    /// How the recorded response was decimated to the recording's rate
    /// (see [`crate::validate::acquisition`]): every replay is put through
    /// the same chain before it is compared, so that the fit does not bend
    /// the parameters to the chain's droop near the recording's Nyquist
    /// frequency. None: the response as recorded.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub acquisition: Option<crate::validate::acquisition::Acquisition>,
    /// After a fit of several recordings, refit each alone from the fitted
    /// model (the same free parameters) and report how much closer each
    /// comes ([`TimeFitResult::each_alone`], [`level_consistency`]): what
    /// tells a model that lacks something every recording shares from one
    /// whose dependence on level is wrong. Costs a fit per recording.
    #[serde(default, skip_serializing_if = "std::ops::Not::not")]
    pub each_alone: bool,
}

fn max_judged() -> usize {
    MAX_JUDGED_SAMPLES
}

fn one() -> usize {
    1
}

impl Default for TimeFitOptions {
    fn default() -> Self {
        TimeFitOptions {
            min_samples_per_period: 40.0,
            patience: 40,
            refine_linear: true,
            input: DriveInput::BandLimited,
            starts: 1,
            max_judged_samples: MAX_JUDGED_SAMPLES,
            acquisition: None,
            each_alone: false,
        }
    }
}
