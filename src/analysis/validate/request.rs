//! `validate`'s request: the model, the recordings, how they are compared,
//! and the rules that refuse options out of range.

use super::ValidationSettings;
use crate::analysis::request::check_range;
use crate::error::{Error, Result};
use crate::validate::acquisition::Acquisition;
use serde::{Deserialize, Serialize};
use std::path::PathBuf;

/// How `validate` is asked to compare a model with recordings (`hystid
/// validate`, and the Python package's `validate`).
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct ValidateRequest {
    /// The model: a fit.json or a model written down; or the name the
    /// caller gives it.
    pub fit: PathBuf,
    /// The fit's linear model instead of the whole.
    pub linear: bool,
    /// The recordings validated on: their files, or the names the caller
    /// gives them.
    pub recordings: Vec<PathBuf>,
    /// The recorded response's decimation, in place of the model's.
    pub acquisition: Option<Acquisition>,
    /// How each recording is replayed and compared.
    pub settings: ValidationSettings,
}

impl ValidateRequest {
    /// Refuses what cannot be done as asked, naming the first option at
    /// fault.
    pub fn validate(&self) -> Result<()> {
        if let Some(chain) = &self.acquisition {
            chain
                .check()
                .map_err(|e| Error::option("acquisition", e.to_string()))?;
        }
        if let Some(band) = self.settings.band_hz {
            check_range(band, "band_hz")?;
        }
        if let Some(window) = self.settings.window_s {
            check_range(window, "window_s")?;
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::analysis::ReductionOptions;

    fn valid() -> ValidateRequest {
        ValidateRequest {
            fit: "fit.json".into(),
            linear: false,
            recordings: vec!["a.json".into()],
            acquisition: None,
            settings: ValidationSettings {
                band_hz: Some((10.0, 20.0)),
                window_s: Some((0.0, 1.0)),
                min_samples_per_period: 20.0,
                frf: true,
                reduction: ReductionOptions::default(),
                periodic: false,
                input: crate::validate::DriveInput::BandLimited,
            },
        }
    }

    fn refused(r: ValidateRequest) -> String {
        r.validate().expect_err("refused").to_string()
    }

    #[test]
    fn a_valid_request_passes() {
        valid().validate().unwrap();
    }

    #[test]
    fn a_band_and_a_window_run_upwards_from_zero() {
        let mut r = valid();
        r.settings.band_hz = Some((20.0, 10.0));
        assert_eq!(refused(r), "band_hz: need 0 <= LO < HI, got 20:10");
        let mut r = valid();
        r.settings.window_s = Some((-1.0, 1.0));
        assert_eq!(refused(r), "window_s: need 0 <= LO < HI, got -1:1");
    }

    #[test]
    fn an_acquisition_chain_is_checked() {
        let mut r = valid();
        r.acquisition = Some(Acquisition {
            decimated_by: vec![2],
            taps: 4,
        });
        assert_eq!(
            refused(r),
            "acquisition: invalid model: `acquisition.taps`: expected an odd number of taps, at least 3, got 4"
        );
    }
}
