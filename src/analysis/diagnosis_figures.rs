//! A diagnosis's figures: the H1 residual in units of the measured
//! standard error per level, before and after the effects were added, and
//! the measured FRFs with the baseline's and the final model's: what the
//! effects added change (`final_frf` shows the final model alone).

use super::figures::Drawn;
use crate::diagnose::Diagnosis;
use crate::error::Result;
use crate::extract::NonlinearFrf;
use crate::fit::{FitData, FrfPredictor, HbPredictor};
use crate::plot::{self, NoiseLevel, ResidualPanel, ResidualSeries};
use std::path::{Path, PathBuf};

/// |H1_meas − H1_model|/σ per level, before and after, and the measured
/// FRFs with the baseline's and the final model's on a fine grid.
pub fn residual_plots(
    dir: &Path,
    frf: &NonlinearFrf,
    d: &Diagnosis,
    predictor: &HbPredictor,
) -> Result<Vec<PathBuf>> {
    let data = FitData::from_frf(frf, &[1], d.band_hz, None)?.with_sign(d.response_sign);
    let before = predictor.predict(&d.baseline_model, &data)?;
    let after = predictor.predict(&d.model, &data)?;
    let panel = |pred: &crate::fit::Prediction, heading: &str| -> ResidualPanel {
        let series = data
            .series
            .iter()
            .zip(&pred.h)
            .enumerate()
            .map(|(g, (s, ps))| ResidualSeries {
                label: crate::plot::level_label(s.level, frf.reference.si_unit()),
                group: g,
                frequency_hz: s.points.iter().map(|p| p.frequency_hz).collect(),
                residual: s
                    .points
                    .iter()
                    .zip(ps)
                    .map(|(p, m)| {
                        m.as_ref().map_or(f64::NAN, |m| {
                            (p.h[0] - m[0]).norm() / p.std_error[0].max(f64::MIN_POSITIVE)
                        })
                    })
                    .collect(),
            })
            .collect();
        ResidualPanel {
            heading: heading.to_string(),
            series,
        }
    };
    let mut files = plot::write_residual_plot(
        &dir.join("residual"),
        "H1 residual / measured standard error, before and after",
        "|H1 meas − H1 model| / σ",
        &[
            panel(
                &before,
                &format!("baseline: error {:.2} %", 100.0 * d.baseline.error_relative),
            ),
            panel(
                &after,
                &format!(
                    "with {}: error {:.2} %",
                    effects_label(d),
                    100.0 * d.final_fit.error_relative
                ),
            ),
        ],
        Some(&NoiseLevel {
            value: 2.0,
            label: "2σ".into(),
        }),
    )?;
    files.extend(super::figures::write_models_overlay(
        &dir.join("diagnosis_frf"),
        &models_title(d),
        frf,
        d.band_hz,
        &[
            Drawn {
                model: &d.baseline_model,
                response_sign: d.response_sign,
            },
            Drawn {
                model: &d.model,
                response_sign: d.response_sign,
            },
        ],
        predictor,
    )?);
    Ok(files)
}

/// The FRF figure's title: what its two kinds of line are.
fn models_title(d: &Diagnosis) -> String {
    if d.selected.is_empty() {
        "Measured, the baseline (grey) and the final model: no effect added, the baseline refitted"
            .into()
    } else {
        format!(
            "Measured, the baseline (grey) and the final model with {} (solid)",
            effects_label(d)
        )
    }
}

/// The added effects, `a + b`, or `no added effect`.
pub fn effects_label(d: &Diagnosis) -> String {
    if d.selected.is_empty() {
        "no added effect".into()
    } else {
        d.selected
            .iter()
            .map(|s| s.effect.name())
            .collect::<Vec<_>>()
            .join(" + ")
    }
}
