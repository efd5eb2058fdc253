//! `run`'s request: the virtual test, the fit, the diagnosis, and the rules
//! that refuse options out of range.

use crate::analysis::request::check_fit_options;
use crate::diagnose::{DiagnoseOptions, Effect};
use crate::error::Result;
use crate::fit::FitOptions;
use serde::{Deserialize, Serialize};
use std::path::PathBuf;

/// How `run` is asked to test, fit and diagnose (`hystid run`).
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct RunRequest {
    /// The test definition; `None`: the embedded default.
    pub test: Option<PathBuf>,
    /// The fit's options.
    pub options: FitOptions,
    /// The diagnosis's options (its candidates re-identify with the fit's
    /// options); `None`: no diagnosis.
    pub diagnosis: Option<DiagnoseOptions>,
    /// Whether the time histories are written (run.mcap, recording.wav).
    pub recording: bool,
}

impl RunRequest {
    /// A request to run `test`, fit with `options` and diagnose with
    /// `candidates` (`None`: no diagnosis), the time histories written.
    pub fn new(
        test: Option<PathBuf>,
        options: FitOptions,
        candidates: Option<Vec<Effect>>,
    ) -> Self {
        let diagnosis = candidates.map(|candidates| DiagnoseOptions {
            band_hz: options.band_hz,
            fit: options.clone(),
            candidates,
            ..DiagnoseOptions::default()
        });
        RunRequest {
            test,
            options,
            diagnosis,
            recording: true,
        }
    }

    /// Refuses what cannot be done as asked, naming the first option at
    /// fault.
    pub fn validate(&self) -> Result<()> {
        check_fit_options(&self.options)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_valid_request_passes() {
        RunRequest::new(None, FitOptions::default(), Some(Effect::defaults()))
            .validate()
            .unwrap();
    }

    #[test]
    fn the_fit_holds_one_to_four_modes() {
        let options = FitOptions {
            modes: 0,
            ..FitOptions::default()
        };
        let r = RunRequest::new(None, options, None);
        assert_eq!(
            r.validate().expect_err("refused").to_string(),
            "modes: expected 1 to 4, got 0"
        );
    }
}
