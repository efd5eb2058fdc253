//! How recordings are reduced: the reduction options as the bindings take
//! them, in JSON.

use super::fail;
use hystid::analysis::{Compensation, ReductionOptions, SineTest as Reduction};
use pyo3::prelude::*;
use serde::Deserialize;

/// How recordings are reduced (the command line's reduction flags).
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct ReductionJson {
    #[serde(default)]
    excitation: Option<String>,
    #[serde(default)]
    max_harmonic: Option<usize>,
    #[serde(default)]
    compensation: Option<serde_json::Value>,
    #[serde(default = "one")]
    hop_periods: f64,
    #[serde(default = "four")]
    window_periods: usize,
}

fn one() -> f64 {
    1.0
}
fn four() -> usize {
    4
}

impl ReductionJson {
    pub(super) fn options(&self) -> PyResult<ReductionOptions> {
        let excitation = match self.excitation.as_deref() {
            None | Some("auto") => None,
            Some("stepped") => Some(Reduction::Stepped),
            Some("swept") => Some(Reduction::Swept),
            Some(other) => {
                return Err(fail(format!(
                    "excitation: expected auto, stepped or swept, got `{other}`"
                )));
            }
        };
        let compensation = match &self.compensation {
            None => Compensation::Auto,
            Some(serde_json::Value::String(s)) if s == "auto" => Compensation::Auto,
            Some(v) => match v.as_f64() {
                Some(s) if s.is_finite() && s > 0.0 => Compensation::Seconds(s),
                Some(0.0) => Compensation::Off,
                _ => {
                    return Err(fail(format!(
                        "compensation: must be \"auto\" or seconds >= 0, got {v}"
                    )));
                }
            },
        };
        Ok(ReductionOptions {
            excitation,
            max_harmonic: self.max_harmonic,
            compensation,
            hop_periods: self.hop_periods,
            window_periods: self.window_periods,
        })
    }
}
