//! `--check-hb`: harmonic balance of a model against the steady state a time
//! simulation of the same model reached at a series of dwells.
//!
//! Here rather than in the test bench so that the bench (which simulates)
//! does not depend on harmonic balance: the caller hands over each dwell's
//! frequency and simulated receptance as plain data.

use super::{HbOptions, HbSolver, SampledReceptance, all_harmonics, odd_harmonics};
use crate::error::Result;
use crate::model::Model;
use num_complex::Complex64;
use serde::{Deserialize, Serialize};

/// One simulated dwell's steady state, as the check needs it.
#[derive(Clone, Copy, Debug)]
pub struct SteadyDwell<'a> {
    /// Dwell number, copied into the [`HbCheck`].
    pub index: usize,
    /// Frequency, Hz.
    pub frequency_hz: f64,
    /// Simulated steady-state receptance `X_k/F_1`, `k = 0..K` (noise free).
    pub receptance: &'a [Complex64],
}

/// Harmonic balance against the simulated steady state at one dwell.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct HbCheck {
    /// Dwell number.
    pub index: usize,
    /// Frequency, Hz.
    pub frequency_hz: f64,
    /// Force amplitude, N.
    pub level: f64,
    /// Whether the harmonic-balance point converged.
    pub converged: bool,
    /// `|H1_sim − H1_hb| / |H1_hb|` (receptance).
    pub h1_relative_difference: f64,
    /// `(k, |Hk_sim − Hk_hb| / |H1_hb|)` for the higher odd harmonics.
    pub higher: Vec<(usize, f64)>,
}

/// Harmonic balance of `model` at every dwell of one force `level`, in the
/// dwells' order (warm-started as a sweep), on the receptance the
/// ramp-invariant filter realises at `sample_rate_hz` (`sinc²(f/fs)`),
/// against each dwell's simulated steady state, up to `max_harmonic`.
///
/// Errors: those of [`HbSolver::new`], [`Model::element_set`] and
/// [`HbSolver::sweep`] (bad options or frequencies); a point that does not
/// converge is reported with `converged = false` and NaN differences.
pub fn check_hb(
    model: &Model,
    sample_rate_hz: f64,
    level: f64,
    dwells: &[SteadyDwell<'_>],
    max_harmonic: usize,
) -> Result<Vec<HbCheck>> {
    if dwells.is_empty() {
        return Ok(Vec::new());
    }
    let top = (2 * max_harmonic + 1).max(15);
    let harmonics = if model.is_asymmetric() {
        all_harmonics(top)
    } else {
        odd_harmonics(top)
    };
    let opts = HbOptions {
        harmonics,
        samples_per_period: 1024,
        ..HbOptions::default()
    };
    // the model's uncoupled parts (the point structure, each hysteretic
    // mode) are swept apart; their harmonics add
    let freqs: Vec<f64> = dwells.iter().map(|d| d.frequency_hz).collect();
    let mut sweeps = Vec::new();
    for (sign, part) in model.parts() {
        let mut solver = HbSolver::new(&opts)?;
        let linear = SampledReceptance {
            linear: &part.linear,
            sample_rate_hz,
        };
        let mut elements = part.element_set()?;
        sweeps.push((sign, solver.sweep(&linear, &mut elements, &freqs, level)?));
    }
    Ok(dwells
        .iter()
        .enumerate()
        .map(|(i, d)| {
            let converged = sweeps.iter().all(|(_, s)| s.points[i].converged);
            let frf = |k: usize| -> Option<Complex64> {
                let mut sum: Option<Complex64> = None;
                for (sign, s) in &sweeps {
                    let z = sign * s.points[i].frf(k)?;
                    sum = Some(sum.map_or(z, |a| a + z));
                }
                sum
            };
            let h1 = frf(1).unwrap_or_default();
            let rel = |k: usize| -> f64 {
                (d.receptance[k] - frf(k).unwrap_or_default()).norm() / h1.norm()
            };
            HbCheck {
                index: d.index,
                frequency_hz: d.frequency_hz,
                level,
                converged,
                h1_relative_difference: if converged { rel(1) } else { f64::NAN },
                higher: (2..=max_harmonic.min(d.receptance.len() - 1))
                    .filter(|k| frf(*k).is_some() && (k % 2 == 1 || model.is_asymmetric()))
                    .map(|k| (k, if converged { rel(k) } else { f64::NAN }))
                    .collect(),
            }
        })
        .collect())
}
