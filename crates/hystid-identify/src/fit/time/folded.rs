//! The time-domain fit's Jacobian folded into its R factor as its rows are
//! made, and the fit's objective.

use super::problem::TimeProblem;
use super::streamed::{ModelResiduals, StreamFailure};
use crate::error::{Error, Result};
use crate::fit::optimise::{self, Objective};
use std::sync::atomic::Ordering;

/// Judged rows of a Jacobian made and folded at a time
/// ([`TimeProblem::jacobian_r_factor`]).
pub(super) const FOLDED_ROWS: usize = 4096;

impl TimeProblem<'_> {
    /// The upper-triangular R factor of `[r₀ J]` at `theta` (see
    /// [`Objective::jacobian_r_factor`]), `J` never held: the models one
    /// forward step along each coordinate are replayed side by side, a
    /// stretch of [`FOLDED_ROWS`] judged samples at a time (the stretch's
    /// columns made in parallel), and each stretch's rows `(r₀, (r_j −
    /// r₀)/step)` folded in as they come; the penalty row's derivative is
    /// zero. Each column's entries are those of the Jacobian made whole, to
    /// the bit; only the fold's rounding differs from factoring it. A
    /// record the simulator rejects partway through a column's replay is
    /// made again for that column as rejected from its start.
    pub fn jacobian_r_factor(
        &self,
        theta: &[f64],
        r0: &[f64],
        step: f64,
    ) -> Result<nalgebra::DMatrix<f64>> {
        use rayon::prelude::*;
        let n = theta.len();
        let m = r0.len() - 1;
        let models = (0..n)
            .map(|j| {
                let mut t = theta.to_vec();
                t[j] += step;
                self.model_at(&t)
            })
            .collect::<Result<Vec<_>>>()?;
        let mut rejected = vec![vec![false; self.records.len()]; n];
        'again: loop {
            let mut columns: Vec<ModelResiduals> = models
                .iter()
                .zip(&rejected)
                .map(|((model, _), rejected)| {
                    ModelResiduals::new(self, model.clone(), rejected.clone())
                })
                .collect();
            let mut buffers = vec![vec![0.0; FOLDED_ROWS]; n];
            let mut fold = optimise::RowFold::new(n + 1);
            let mut at = 0;
            while at < m {
                if self.observer.is_some_and(|o| o.cancelled()) {
                    return Err(Error::Cancelled);
                }
                let rows = FOLDED_ROWS.min(m - at);
                let made: Vec<std::result::Result<usize, StreamFailure>> = columns
                    .par_iter_mut()
                    .zip(buffers.par_iter_mut())
                    .map(|(c, b)| c.fill(&mut b[..rows]))
                    .collect();
                for (j, made) in made.into_iter().enumerate() {
                    match made {
                        Ok(k) if k == rows => {}
                        Ok(k) => {
                            return Err(Error::NotConverged {
                                stage: "time-domain Jacobian",
                                reason: format!(
                                    "column {j} made {k} of the {rows} residuals from row {at}"
                                ),
                            });
                        }
                        Err(StreamFailure::RejectedPartway(i)) => {
                            rejected[j][i] = true;
                            continue 'again;
                        }
                        Err(StreamFailure::Error(e)) => return Err(e),
                    }
                }
                let block = nalgebra::DMatrix::from_fn(rows, n + 1, |i, k| {
                    let b = r0[at + i];
                    if k == 0 {
                        b
                    } else {
                        (buffers[k - 1][i] - b) / step
                    }
                });
                fold.fold(&block);
                at += rows;
            }
            // the penalty row: the residual's, its derivative zero inside
            // the bounds
            let mut penalty = nalgebra::DMatrix::zeros(1, n + 1);
            penalty[(0, 0)] = r0[m];
            fold.fold(&penalty);
            // each column is a residual vector computed: counted and shown
            // as `residuals_into` does
            for (j, (c, (_, outside))) in columns.iter().zip(&models).enumerate() {
                let replay = self.replays.fetch_add(1, Ordering::Relaxed) + 1;
                if let Some(o) = self.observer {
                    let rms = (c.sum_of_squares / m.max(1) as f64).sqrt();
                    let pen = outside * 10.0 * rms * (m as f64).sqrt();
                    let mut t = theta.to_vec();
                    t[j] += step;
                    let entry = crate::observe::TraceEntry {
                        evaluation: replay,
                        cost: c.sum_of_squares + pen * pen,
                        parameters: self.parameters.values(&t),
                    };
                    o.observe(crate::observe::Event::Cost(&entry));
                }
            }
            return Ok(fold.finish());
        }
    }
}

impl Objective for TimeProblem<'_> {
    /// See [`TimeProblem::residuals_into`].
    fn residuals(&self, theta: &[f64]) -> Result<Vec<f64>> {
        let judged: usize = self.judged_samples().iter().sum();
        let mut r = vec![0.0; judged + 1];
        self.residuals_into(theta, &mut r)?;
        Ok(r)
    }
    fn cost(&self, theta: &[f64]) -> Result<f64> {
        self.evaluations.fetch_add(1, Ordering::Relaxed);
        Ok(self.residuals(theta)?.iter().map(|v| v * v).sum::<f64>())
    }
    fn evaluations(&self) -> usize {
        self.evaluations.load(Ordering::Relaxed)
    }
    /// Written into its final matrix: a long recording's Jacobian (a column
    /// per parameter, a row per judged sample) is the largest thing the fit
    /// holds.
    fn jacobian_with_penalty_row(
        &self,
        theta: &[f64],
        r0: &[f64],
        step: f64,
    ) -> Result<nalgebra::DMatrix<f64>> {
        // each column's residuals written into it (a residual vector per
        // column in flight was as large as the column)
        optimise::forward_difference_in_place(theta, r0, step, |t, column| {
            self.residuals_into(t, column)
        })
    }
    /// Where the Jacobian would hold more than [`JACOBIAN_HELD_UP_TO`]
    /// entries (or the problem says so: [`TimeProblem::with_jacobian_held_up_to`]).
    fn folds_jacobian(&self) -> bool {
        let judged: usize = self.judged_samples().iter().sum();
        judged.saturating_mul(self.parameters.parameters.len()) > self.jacobian_held_up_to
    }
    /// See [`TimeProblem::jacobian_r_factor`].
    fn jacobian_r_factor(
        &self,
        theta: &[f64],
        r0: &[f64],
        step: f64,
    ) -> Result<nalgebra::DMatrix<f64>> {
        TimeProblem::jacobian_r_factor(self, theta, r0, step)
    }
}
