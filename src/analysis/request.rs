//! What a command is asked to do, checked before it runs.
//!
//! Each command is one request type (e.g.
//! [`IdentifyRequest`](super::identify::IdentifyRequest)): its options as
//! the library's own types, and `validate`, which holds every rule that
//! refuses an option out of range or one that does not go with the others.
//! The command line and the Python package only translate their arguments
//! into a request, so both refuse alike. A refusal is an
//! [`Error::InvalidOption`] naming the request's field; each front end
//! names it as its users write it. The parsers here read an option's text
//! form (`LO:HI`, a joint law's name) for both front ends.

use crate::diagnose::Effect;
use crate::error::{Error, Result};
use crate::fit::{FitOptions, TimeFitOptions};
use crate::model::ElementKind;
use serde::{Deserialize, Serialize};

/// What a model is fitted to.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum FitDomain {
    /// The nonlinear FRFs, by harmonic balance.
    #[default]
    Frf,
    /// The FRFs, then the recorded time histories.
    Time,
}

/// Most modes of a fit's linear part.
pub const MAX_MODES: usize = 4;

/// Most starts a time-domain fit descends from.
pub const MAX_STARTS: usize = 64;

/// Fewest samples a time-domain fit may be told to judge.
pub const MIN_JUDGED_SAMPLES: usize = 1000;

/// A range `LO:HI` (e.g. `120:200`), `0 <= LO < HI`, in `unit`.
pub fn parse_range(text: &str, option: &str, unit: &str) -> Result<(f64, f64)> {
    let (a, b) = text
        .split_once(':')
        .ok_or_else(|| Error::option(option, format!("expected LO:HI in {unit}, got `{text}`")))?;
    let number = |x: &str| -> Result<f64> {
        x.trim()
            .parse()
            .map_err(|e| Error::option(option, format!("`{x}` is not a number: {e}")))
    };
    let range = (number(a)?, number(b)?);
    check_range(range, option)?;
    Ok(range)
}

/// A range `(LO, HI)` with `0 <= LO < HI`.
pub fn check_range((a, b): (f64, f64), option: &str) -> Result<()> {
    if !(a.is_finite() && b.is_finite() && 0.0 <= a && a < b) {
        return Err(Error::option(
            option,
            format!("need 0 <= LO < HI, got {a}:{b}"),
        ));
    }
    Ok(())
}

/// The joint law a fit identifies, by name (`masing`, `jenkins`, ...).
pub fn parse_joint(name: &str) -> Result<ElementKind> {
    match ElementKind::from_name(name) {
        Some(k) if k.description().is_fitted_joint() => Ok(k),
        _ => {
            let joints: Vec<&str> = ElementKind::fitted_joints()
                .map(ElementKind::name)
                .collect();
            Err(Error::option(
                "element",
                format!(
                    "expected a joint law ({}), got `{name}`",
                    joints.join(" or ")
                ),
            ))
        }
    }
}

/// Candidate effects by name, `all` for every one, `default` for the
/// default set (see [`Effect::parse_list`]).
pub fn parse_candidates(names: &[String]) -> Result<Vec<Effect>> {
    Effect::parse_list(names).map_err(|e| match e {
        Error::InvalidPlan { message, .. } => Error::option("candidates", message),
        e => e,
    })
}

/// The fit options every fitting command takes: at most [`MAX_MODES`]
/// modes, then [`FitOptions::validate`].
pub fn check_fit_options(options: &FitOptions) -> Result<()> {
    if !(1..=MAX_MODES).contains(&options.modes) {
        return Err(Error::option(
            "modes",
            format!("expected 1 to {MAX_MODES}, got {}", options.modes),
        ));
    }
    options.validate()
}

/// The time-domain fit's options that hold whatever the command: the
/// starts, the samples judged, the acquisition chain, and several
/// recordings to refit each alone.
pub fn check_time_options(time: &TimeFitOptions, recordings: usize) -> Result<()> {
    if !(1..=MAX_STARTS).contains(&time.starts) {
        return Err(Error::option(
            "starts",
            format!("expected 1 to {MAX_STARTS}, got {}", time.starts),
        ));
    }
    if time.max_judged_samples < MIN_JUDGED_SAMPLES {
        return Err(Error::option(
            "max_judged_samples",
            format!(
                "expected at least {MIN_JUDGED_SAMPLES}, got {}",
                time.max_judged_samples
            ),
        ));
    }
    if time.each_alone && recordings < 2 {
        return Err(Error::option(
            "each_alone",
            "refits each of several recordings alone; give two or more",
        ));
    }
    if let Some(chain) = &time.acquisition {
        chain
            .check()
            .map_err(|e| Error::option("acquisition", e.to_string()))?;
    }
    Ok(())
}

/// Refuses a time-domain option given to a fit in the FRFs: `(option,
/// why)` for each that is not at its default, the first refused.
pub fn refuse_unless_time(domain: FitDomain, given: &[(&str, bool, &str)]) -> Result<()> {
    if domain == FitDomain::Time {
        return Ok(());
    }
    match given.iter().find(|(_, set, _)| *set) {
        Some((option, _, why)) => Err(Error::TimeDomainOnly {
            option: option.to_string(),
            why: why.to_string(),
        }),
        None => Ok(()),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn message(r: Result<impl std::fmt::Debug>) -> String {
        r.expect_err("refused").to_string()
    }

    #[test]
    fn a_range_is_lo_colon_hi() {
        assert_eq!(parse_range(" 1:2.5", "band_hz", "Hz").unwrap(), (1.0, 2.5));
        assert_eq!(
            message(parse_range("12", "band_hz", "Hz")),
            "band_hz: expected LO:HI in Hz, got `12`"
        );
        assert_eq!(
            message(parse_range("a:2", "window_s", "s")),
            "window_s: `a` is not a number: invalid float literal"
        );
        assert_eq!(
            message(parse_range("3:2", "band_hz", "Hz")),
            "band_hz: need 0 <= LO < HI, got 3:2"
        );
    }

    #[test]
    fn a_joint_law_is_named() {
        assert_eq!(parse_joint("jenkins").unwrap(), ElementKind::Jenkins);
        let m = message(parse_joint("cubic_stiffness"));
        assert!(
            m.starts_with("element: expected a joint law (")
                && m.ends_with("got `cubic_stiffness`"),
            "{m}"
        );
    }

    #[test]
    fn a_compensation_is_auto_off_or_seconds() {
        use crate::analysis::Compensation;
        assert_eq!("auto".parse::<Compensation>().unwrap(), Compensation::Auto);
        assert_eq!("0".parse::<Compensation>().unwrap(), Compensation::Off);
        assert_eq!(
            " 2.5".parse::<Compensation>().unwrap(),
            Compensation::Seconds(2.5)
        );
        assert_eq!(
            message("x".parse::<Compensation>()),
            "compensation: expected auto, 0 or seconds, got `x`: invalid float literal"
        );
        assert_eq!(
            message("-1".parse::<Compensation>()),
            "compensation: must be auto or seconds >= 0, got -1"
        );
    }

    #[test]
    fn candidates_are_named() {
        assert_eq!(
            parse_candidates(&["default".into()]).unwrap(),
            Effect::defaults()
        );
        assert!(
            message(parse_candidates(&["friction".into()]))
                .starts_with("candidates: unknown effect `friction` (known: ")
        );
        assert_eq!(
            message(parse_candidates(&[])),
            "candidates: give at least one effect"
        );
    }

    #[test]
    fn fit_options_hold_one_to_four_modes() {
        let mut o = FitOptions::default();
        assert!(check_fit_options(&o).is_ok());
        o.modes = 5;
        assert_eq!(
            message(check_fit_options(&o)),
            "modes: expected 1 to 4, got 5"
        );
    }

    #[test]
    fn time_options_are_refused_out_of_range() {
        let ok = TimeFitOptions::default();
        assert!(check_time_options(&ok, 1).is_ok());
        let cases = [
            (
                TimeFitOptions {
                    starts: 0,
                    ..ok.clone()
                },
                "starts: expected 1 to 64, got 0",
            ),
            (
                TimeFitOptions {
                    max_judged_samples: 999,
                    ..ok.clone()
                },
                "max_judged_samples: expected at least 1000, got 999",
            ),
            (
                TimeFitOptions {
                    each_alone: true,
                    ..ok.clone()
                },
                "each_alone: refits each of several recordings alone; give two or more",
            ),
        ];
        for (t, expected) in cases {
            assert_eq!(message(check_time_options(&t, 1)), expected);
        }
        let chain = crate::validate::acquisition::Acquisition {
            decimated_by: vec![1],
            taps: 31,
        };
        let t = TimeFitOptions {
            acquisition: Some(chain),
            ..ok
        };
        assert!(message(check_time_options(&t, 1)).starts_with("acquisition: invalid model: "));
    }
}
