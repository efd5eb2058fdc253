//! `diagnose`'s request: the baseline's fit, the candidates, the domain,
//! and the rules that refuse options that do not go together.

use crate::analysis::request::{
    FitDomain, check_fit_options, check_time_options, refuse_unless_time,
};
use crate::diagnose::{DiagnoseOptions, Effect};
use crate::error::{Error, Result};
use crate::fit::{FitOptions, TimeFitOptions};
use crate::validate::DriveInput;
use serde::{Deserialize, Serialize};
use std::path::PathBuf;

/// How `diagnose` is asked to diagnose (`hystid diagnose`, and the Python
/// package's `diagnose`, `diagnose_time`).
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct DiagnoseRequest {
    /// The recordings diagnosed: their files, or the names the caller
    /// gives them.
    pub recordings: Vec<PathBuf>,
    /// The FRFs, or the FRFs then the time histories.
    pub domain: FitDomain,
    /// The candidates, the baseline's fit options (which a candidate mode
    /// is identified with too), the band and the candidates put to the
    /// time histories.
    pub diagnosis: DiagnoseOptions,
    /// The time-domain refits' options.
    pub time: TimeFitOptions,
}

impl DiagnoseRequest {
    /// A request to diagnose `recordings`' FRFs from a baseline fitted with
    /// `fit`, trying `candidates`, every other option at its default.
    pub fn new(recordings: Vec<PathBuf>, fit: FitOptions, candidates: Vec<Effect>) -> Self {
        DiagnoseRequest {
            recordings,
            domain: FitDomain::Frf,
            diagnosis: DiagnoseOptions {
                candidates,
                band_hz: fit.band_hz,
                fit,
                ..DiagnoseOptions::default()
            },
            time: TimeFitOptions::default(),
        }
    }

    /// Refuses what cannot be done as asked, naming the first option at
    /// fault.
    pub fn validate(&self) -> Result<()> {
        check_fit_options(&self.diagnosis.fit)?;
        let t = &self.time;
        refuse_unless_time(
            self.domain,
            &[
                (
                    "time_proposals",
                    self.diagnosis.time_proposals > 0,
                    "the candidates are put to the time histories",
                ),
                (
                    "replay",
                    t.input != DriveInput::BandLimited,
                    "only the time-domain refit replays the models",
                ),
                (
                    "starts",
                    t.starts > 1,
                    "the time-domain fit descends from several starts",
                ),
                (
                    "max_judged_samples",
                    t.max_judged_samples != crate::fit::time::MAX_JUDGED_SAMPLES,
                    "only the time-domain fit judges samples",
                ),
                (
                    "acquisition",
                    t.acquisition.is_some(),
                    "only the time-domain refit replays the models",
                ),
                (
                    "each_alone",
                    t.each_alone,
                    "the recordings are refitted alone in the time domain",
                ),
            ],
        )?;
        check_time_options(t, self.recordings.len())
    }

    /// Refuses what cannot be done on multisines, which are diagnosed at
    /// the lines of their period: once the recordings are found to be ones.
    pub fn validate_on_multisines(&self) -> Result<()> {
        if self.time.each_alone {
            return Err(Error::option(
                "each_alone",
                "refits a swept or stepped diagnosis's recordings alone; \
                 multisines are diagnosed at the lines of their period",
            ));
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn valid() -> DiagnoseRequest {
        DiagnoseRequest::new(
            vec!["a.json".into(), "b.json".into()],
            FitOptions::default(),
            Effect::defaults(),
        )
    }

    fn refused(r: Result<()>) -> String {
        r.expect_err("refused").to_string()
    }

    #[test]
    fn a_valid_request_passes() {
        valid().validate().unwrap();
        let mut r = valid();
        r.domain = FitDomain::Time;
        r.diagnosis.time_proposals = 2;
        r.time = TimeFitOptions {
            starts: 2,
            input: DriveInput::Continuous,
            each_alone: true,
            ..TimeFitOptions::default()
        };
        r.validate().unwrap();
        valid().validate_on_multisines().unwrap();
    }

    /// Each time-domain option without `--domain time`.
    #[test]
    fn time_options_need_the_time_domain() {
        let with = |time: TimeFitOptions| DiagnoseRequest { time, ..valid() };
        let d = TimeFitOptions::default;
        let mut proposals = valid();
        proposals.diagnosis.time_proposals = 1;
        let cases = [
            (
                proposals,
                "time_proposals: the candidates are put to the time histories; it applies to the time domain only",
            ),
            (
                with(TimeFitOptions {
                    input: DriveInput::Continuous,
                    ..d()
                }),
                "replay: only the time-domain refit replays the models; it applies to the time domain only",
            ),
            (
                with(TimeFitOptions { starts: 2, ..d() }),
                "starts: the time-domain fit descends from several starts; it applies to the time domain only",
            ),
            (
                with(TimeFitOptions {
                    max_judged_samples: 1000,
                    ..d()
                }),
                "max_judged_samples: only the time-domain fit judges samples; it applies to the time domain only",
            ),
            (
                with(TimeFitOptions {
                    acquisition: Some(crate::validate::acquisition::Acquisition {
                        decimated_by: vec![2],
                        taps: 31,
                    }),
                    ..d()
                }),
                "acquisition: only the time-domain refit replays the models; it applies to the time domain only",
            ),
            (
                with(TimeFitOptions {
                    each_alone: true,
                    ..d()
                }),
                "each_alone: the recordings are refitted alone in the time domain; it applies to the time domain only",
            ),
        ];
        for (r, expected) in cases {
            assert_eq!(refused(r.validate()), expected);
        }
    }

    #[test]
    fn each_alone_needs_two_recordings_and_no_multisine() {
        let mut r = valid();
        r.domain = FitDomain::Time;
        r.time.each_alone = true;
        assert_eq!(
            refused(r.validate_on_multisines()),
            "each_alone: refits a swept or stepped diagnosis's recordings alone; \
             multisines are diagnosed at the lines of their period"
        );
        r.recordings.pop();
        assert_eq!(
            refused(r.validate()),
            "each_alone: refits each of several recordings alone; give two or more"
        );
    }

    #[test]
    fn the_baseline_holds_one_to_four_modes() {
        let mut r = valid();
        r.diagnosis.fit.modes = 5;
        assert_eq!(refused(r.validate()), "modes: expected 1 to 4, got 5");
    }

    #[test]
    fn starts_are_in_range() {
        let mut r = valid();
        r.domain = FitDomain::Time;
        r.time.starts = 0;
        assert_eq!(refused(r.validate()), "starts: expected 1 to 64, got 0");
    }
}
