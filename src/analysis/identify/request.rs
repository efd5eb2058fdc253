//! `identify`'s request: what to fit, to what, from where, and the rules
//! that refuse options that do not go together.

use crate::analysis::request::{
    FitDomain, check_fit_options, check_time_options, refuse_unless_time,
};
use crate::error::{Error, Result};
use crate::fit::{FitOptions, TimeFitOptions};
use crate::validate::DriveInput;
use serde::{Deserialize, Serialize};
use std::path::PathBuf;

/// How `identify` is asked to fit (`hystid identify`, and the Python
/// package's `identify`, `identify_time`).
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct IdentifyRequest {
    /// The recordings fitted to: their files, or the names the caller
    /// gives them.
    pub recordings: Vec<PathBuf>,
    /// The FRFs, or the FRFs then the time histories.
    pub domain: FitDomain,
    /// The FRF fit's options (with `start`: its band and settings only).
    pub options: FitOptions,
    /// A model written down to fit instead of identifying the joint law
    /// (`--start`): its file, or the name the caller gives it.
    pub start: Option<PathBuf>,
    /// The start's response sign where the caller holds the model (1, or
    /// -1 for a transfer of negative modal constant); a file states its
    /// own.
    pub response_sign: Option<f64>,
    /// An FRF fit given to be refined in time (the Python package's
    /// `fit=`; the command fits the FRFs itself).
    pub refined_fit: Option<PathBuf>,
    /// Parameters held at the start's values.
    pub fix: Vec<String>,
    /// The time window judged in every recording, seconds.
    pub window_s: Option<(f64, f64)>,
    /// The time-domain fit's options.
    pub time: TimeFitOptions,
}

impl IdentifyRequest {
    /// A request to fit `recordings`' FRFs with `options`, every other
    /// option at its default.
    pub fn new(recordings: Vec<PathBuf>, options: FitOptions) -> Self {
        IdentifyRequest {
            recordings,
            domain: FitDomain::Frf,
            options,
            start: None,
            response_sign: None,
            refined_fit: None,
            fix: Vec::new(),
            window_s: None,
            time: TimeFitOptions::default(),
        }
    }

    /// Refuses what cannot be done as asked, naming the first option at
    /// fault.
    pub fn validate(&self) -> Result<()> {
        check_fit_options(&self.options)?;
        let t = &self.time;
        refuse_unless_time(
            self.domain,
            &[
                (
                    "starts",
                    t.starts > 1,
                    "the time-domain fit descends from several starts",
                ),
                (
                    "replay",
                    t.input != DriveInput::BandLimited,
                    "only the time-domain fit replays the model",
                ),
                (
                    "max_judged_samples",
                    t.max_judged_samples != crate::fit::time::MAX_JUDGED_SAMPLES,
                    "only the time-domain fit judges samples",
                ),
                (
                    "acquisition",
                    t.acquisition.is_some(),
                    "only the time-domain fit replays the model",
                ),
                (
                    "each_alone",
                    t.each_alone,
                    "the recordings are refitted alone in the time domain",
                ),
            ],
        )?;
        check_time_options(t, self.recordings.len())?;
        if let Some(sign) = self.response_sign
            && sign != 1.0
            && sign != -1.0
        {
            return Err(Error::option(
                "response_sign",
                format!("expected 1 or -1, got {sign}"),
            ));
        }
        if self.start.is_some() && self.refined_fit.is_some() {
            return Err(Error::option("", "give fit= or start=, not both"));
        }
        if self.refined_fit.is_some() && self.window_s.is_some() {
            return Err(Error::option(
                "window_s",
                "applies to a start written down or a multisine's start, not to an FRF fit's refinement",
            ));
        }
        if self.start.is_some() && self.domain == FitDomain::Frf && !self.fix.is_empty() {
            return Err(Error::TimeDomainOnly {
                option: "fix".into(),
                why: "parameters are held only by the time-domain fit from a start".into(),
            });
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn valid() -> IdentifyRequest {
        IdentifyRequest::new(
            vec!["a.json".into(), "b.json".into()],
            FitOptions::default(),
        )
    }

    fn refused(r: IdentifyRequest) -> String {
        r.validate().expect_err("refused").to_string()
    }

    #[test]
    fn a_valid_request_passes() {
        valid().validate().unwrap();
        let time = IdentifyRequest {
            domain: FitDomain::Time,
            start: Some("model.toml".into()),
            fix: vec!["beta".into()],
            window_s: Some((1.0, 2.0)),
            time: TimeFitOptions {
                starts: 3,
                input: DriveInput::Continuous,
                each_alone: true,
                ..TimeFitOptions::default()
            },
            ..valid()
        };
        time.validate().unwrap();
    }

    /// Each time-domain option without `--domain time`.
    #[test]
    fn time_options_need_the_time_domain() {
        let with = |time: TimeFitOptions| IdentifyRequest { time, ..valid() };
        let d = TimeFitOptions::default;
        let cases = [
            (
                with(TimeFitOptions { starts: 3, ..d() }),
                "starts: the time-domain fit descends from several starts; it applies to the time domain only",
            ),
            (
                with(TimeFitOptions {
                    input: DriveInput::Continuous,
                    ..d()
                }),
                "replay: only the time-domain fit replays the model; it applies to the time domain only",
            ),
            (
                with(TimeFitOptions {
                    acquisition: Some(crate::validate::acquisition::Acquisition {
                        decimated_by: vec![2],
                        taps: 31,
                    }),
                    ..d()
                }),
                "acquisition: only the time-domain fit replays the model; it applies to the time domain only",
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
            assert_eq!(refused(r), expected);
        }
    }

    #[test]
    fn each_alone_needs_two_recordings() {
        let r = IdentifyRequest {
            recordings: vec!["a.json".into()],
            domain: FitDomain::Time,
            time: TimeFitOptions {
                each_alone: true,
                ..TimeFitOptions::default()
            },
            ..valid()
        };
        assert_eq!(
            refused(r),
            "each_alone: refits each of several recordings alone; give two or more"
        );
    }

    #[test]
    fn starts_and_judged_samples_are_in_range() {
        let time = |time: TimeFitOptions| IdentifyRequest {
            domain: FitDomain::Time,
            time,
            ..valid()
        };
        let d = TimeFitOptions::default;
        assert_eq!(
            refused(time(TimeFitOptions { starts: 65, ..d() })),
            "starts: expected 1 to 64, got 65"
        );
        assert_eq!(
            refused(time(TimeFitOptions {
                max_judged_samples: 10,
                ..d()
            })),
            "max_judged_samples: expected at least 1000, got 10"
        );
    }

    #[test]
    fn modes_are_one_to_four() {
        let mut r = valid();
        r.options.modes = 0;
        assert_eq!(refused(r), "modes: expected 1 to 4, got 0");
    }

    #[test]
    fn a_response_sign_is_one_or_minus_one() {
        let r = IdentifyRequest {
            start: Some("start".into()),
            response_sign: Some(0.5),
            ..valid()
        };
        assert_eq!(refused(r), "response_sign: expected 1 or -1, got 0.5");
    }

    #[test]
    fn one_start_at_a_time() {
        let r = IdentifyRequest {
            domain: FitDomain::Time,
            start: Some("start".into()),
            refined_fit: Some("fit".into()),
            ..valid()
        };
        assert_eq!(refused(r), "give fit= or start=, not both");
    }

    #[test]
    fn a_window_is_not_for_an_frf_fits_refinement() {
        let r = IdentifyRequest {
            domain: FitDomain::Time,
            refined_fit: Some("fit".into()),
            window_s: Some((1.0, 2.0)),
            ..valid()
        };
        assert_eq!(
            refused(r),
            "window_s: applies to a start written down or a multisine's start, not to an FRF fit's refinement"
        );
    }

    #[test]
    fn parameters_are_held_only_in_time() {
        let r = IdentifyRequest {
            start: Some("model.toml".into()),
            fix: vec!["beta".into()],
            ..valid()
        };
        assert_eq!(
            refused(r),
            "fix: parameters are held only by the time-domain fit from a start; it applies to the time domain only"
        );
    }
}
