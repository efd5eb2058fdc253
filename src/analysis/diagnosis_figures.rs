//! A diagnosis's figures: the H1 residual in units of the measured
//! standard error per level, before and after the effects were added, and
//! the measured FRFs beside the diagnosed model's.

use crate::diagnose::Diagnosis;
use crate::error::Result;
use crate::extract::NonlinearFrf;
use crate::fit::{FitData, FrfPredictor, HbPredictor};
use crate::plot::{self, FrfSeries, NoiseLevel, ResidualPanel, ResidualSeries, SeriesStyle};
use std::path::{Path, PathBuf};

/// |H1_meas − H1_model|/σ per level, before and after, and the FRF overlay
/// of the final model.
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
    let mut series = Vec::new();
    for (g, (s, ps)) in data.series.iter().zip(&after.h).enumerate() {
        let f: Vec<f64> = s.points.iter().map(|p| p.frequency_hz).collect();
        series.push(FrfSeries {
            label: crate::plot::level_label(s.level, frf.reference.si_unit()),
            group: g,
            frequency_hz: f.clone(),
            h: s.points.iter().map(|p| p.h[0] * d.response_sign).collect(),
            std_error: None,
            style: SeriesStyle::Measured,
        });
        series.push(FrfSeries {
            label: format!(
                "{} (model)",
                crate::plot::level_label(s.level, frf.reference.si_unit())
            ),
            group: g,
            frequency_hz: f,
            h: ps
                .iter()
                .map(|m| {
                    m.as_ref()
                        .map_or(num_complex::Complex64::new(f64::NAN, f64::NAN), |m| {
                            m[0] * d.response_sign
                        })
                })
                .collect(),
            std_error: None,
            style: SeriesStyle::Model,
        });
    }
    files.extend(plot::write_frf_plot(
        &dir.join("diagnosis_frf"),
        &format!("Measured and the diagnosed model ({})", effects_label(d)),
        &plot::frf_magnitude_label(frf, 1),
        &series,
    )?);
    Ok(files)
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
