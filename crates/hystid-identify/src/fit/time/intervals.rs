//! Confidence intervals of a time-domain fit, the residual taken as white
//! noise.

use super::problem::TimeProblem;
use crate::error::Result;
use crate::fit::identify::Estimate;
use crate::fit::optimise::{self, Objective};
use crate::fit::params::Transform;
use std::collections::BTreeMap;

/// `s² (JᵀJ)⁻¹` over the columns of `jac` that are free (not `at_bound`)
/// and felt, with those columns' indices.
///
/// Directly: `optimise::covariance` never deflates below the unit
/// variances, and these residuals are relative errors (≪ 1). A parameter
/// the replay does not feel at all (a damping ratio driven to 1e-20 beside
/// a joint that gives all the damping: a step in it leaves the replay the
/// same to the bit, its column zero) makes `JᵀJ` singular and would leave
/// every parameter without an interval; it is left out instead (reported
/// as not determined).
pub(super) fn felt_covariance(
    jac: &nalgebra::DMatrix<f64>,
    at_bound: &[bool],
    s2: f64,
) -> (Vec<usize>, Option<nalgebra::DMatrix<f64>>) {
    // `JᵀJ` of the Jacobian itself, neither its transpose nor its free
    // columns copied (either as large as the Jacobian: a long recording's is
    // the largest thing the fit holds); each entry is one column's dot
    // product with another, so the free columns' entries are the same bits
    // as those of their copy's `JᵀJ`
    let norms: Vec<f64> = jac.column_iter().map(|c| c.norm()).collect();
    felt_covariance_of_gram(&jac.tr_mul(jac), &norms, at_bound, s2)
}

/// [`felt_covariance`] from `JᵀJ` and the columns' norms (a Jacobian folded
/// into its R factor has both, not the Jacobian).
fn felt_covariance_of_gram(
    gram: &nalgebra::DMatrix<f64>,
    norms: &[f64],
    at_bound: &[bool],
    s2: f64,
) -> (Vec<usize>, Option<nalgebra::DMatrix<f64>>) {
    let unfelt = optimise::unfelt_of_norms(norms, at_bound);
    let free: Vec<usize> = (0..norms.len())
        .filter(|&j| !at_bound[j] && !unfelt[j])
        .collect();
    let jtj = nalgebra::DMatrix::from_fn(free.len(), free.len(), |a, b| gram[(free[a], free[b])]);
    let cov = jtj.try_inverse().map(|a| a * s2);
    (free, cov)
}

/// Estimates with 95 % intervals from the Jacobian at `theta`, the residual
/// taken as white noise (see the module docs). A parameter at a bound gets
/// no interval (`identifiable: false`, with a note).
pub(super) fn time_confidence(
    problem: &TimeProblem,
    theta: &[f64],
) -> Result<BTreeMap<String, Estimate>> {
    let params = &problem.parameters;
    let r0 = problem.residuals(theta)?;
    let values = params.values(theta);
    let at_bound = params.at_bounds(&values);
    let m = r0.len() - 1;
    let s2 = r0[..m].iter().map(|v| v * v).sum::<f64>() / (m as f64 - theta.len() as f64).max(1.0);
    let (free, cov) = if problem.folds_jacobian() {
        // `JᵀJ` is the R factor's last columns' own
        let rf = problem.jacobian_r_factor(theta, &r0, 1e-5)?;
        let c = rf.columns(1, theta.len());
        let norms: Vec<f64> = c.column_iter().map(|c| c.norm()).collect();
        felt_covariance_of_gram(&c.tr_mul(&c), &norms, &at_bound, s2)
    } else {
        // written in place (a residual vector per column in flight was as
        // large as the column), its penalty row zero: `JᵀJ` the same
        let jac = problem.jacobian_with_penalty_row(theta, &r0, 1e-5)?;
        felt_covariance(&jac, &at_bound, s2)
    };
    let mut out = BTreeMap::new();
    for (j, p) in params.parameters.iter().enumerate() {
        let value = values[j];
        let k = free.iter().position(|&f| f == j);
        let sd = match (&cov, k) {
            (Some(c), Some(k)) => c[(k, k)].sqrt(),
            _ => f64::NAN,
        };
        let (ci95, identifiable, note) = if at_bound[j] {
            (
                [value, value],
                false,
                Some(format!("{} sits at its bound", p.name)),
            )
        } else if !sd.is_finite() {
            (
                [f64::NEG_INFINITY, f64::INFINITY],
                false,
                Some(format!("{} is not determined by the recordings", p.name)),
            )
        } else {
            let (lo, hi) = (p.value(theta[j] - 1.96 * sd), p.value(theta[j] + 1.96 * sd));
            let wide = matches!(p.transform, Transform::Log) && sd > 1.0;
            (
                [lo.min(hi), lo.max(hi)],
                !wide,
                wide.then(|| {
                    format!(
                        "{} is poorly determined: its 95 % interval spans more than a factor 50",
                        p.name
                    )
                }),
            )
        };
        out.insert(
            p.name.clone(),
            Estimate {
                value,
                ci95,
                identifiable,
                note,
                bootstrap_ci95: None,
            },
        );
    }
    Ok(out)
}
