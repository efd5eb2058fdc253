//! Confidence intervals at an optimum: from the Jacobian and the measured
//! noise, a one-sided range for a parameter at its bound, a likelihood-ratio
//! check of the Jenkins limit, and a parametric bootstrap.

use super::{Estimate, FitOptions};
use crate::error::Result;
use crate::fit::optimise;
use crate::fit::params::Transform;
use crate::fit::problem::{FitProblem, Prediction, Weighting, chi_square};
use rand::SeedableRng;
use rand_distr::{Distribution, StandardNormal};
use std::collections::BTreeMap;

/// Estimates with confidence intervals at an optimum.
pub struct Confidence {
    /// Per parameter, in the problem's order.
    pub estimates: Vec<Estimate>,
    /// Reduced `χ²` that inflated the intervals.
    pub reduced_chi2: f64,
}

/// Confidence intervals at `theta` from the Jacobian and the measured noise;
/// parameters at a bound get a one-sided range from a cost scan instead.
pub fn confidence(problem: &FitProblem, theta: &[f64], pred: &Prediction) -> Result<Confidence> {
    let params = &problem.parameters;
    let r0 = problem.residuals(theta)?;
    let jac = optimise::jacobian(problem, theta, &r0, 1e-5)?;
    // measurement variance of each residual row as fitted
    let mut variances = Vec::with_capacity(r0.len());
    for s in &problem.data.series {
        for p in &s.points {
            for k in 0..problem.data.harmonics.len() {
                let v = match problem.weighting {
                    Weighting::None => p.std_error[k].powi(2) / 2.0,
                    Weighting::StandardError => 1.0,
                };
                variances.push(v);
                variances.push(v);
            }
        }
    }
    let chi2 = chi_square(problem.data, pred);
    let values = params.values(theta);
    let at_bound = params.at_bounds(&values);
    let unfelt = optimise::unfelt_columns(&jac, &at_bound);
    let cov = optimise::covariance(&jac, &variances, chi2, &at_bound);
    let (cov, reduced) = match cov {
        Some(c) => c,
        None => (
            nalgebra::DMatrix::from_element(theta.len(), theta.len(), f64::NAN),
            f64::NAN,
        ),
    };
    let mut estimates = Vec::new();
    for (j, p) in params.parameters.iter().enumerate() {
        let value = values[j];
        let sd = cov[(j, j)].sqrt();
        if at_bound[j] || unfelt[j] {
            // the far end of the 95 % region, away from the (nearer) bound
            let lower = one_sided_range(problem, theta, j, reduced)?;
            let shape = matches!(p.transform, Transform::Reciprocal);
            let jenkins_limit = shape && value >= 0.99 * p.bounds[1];
            let ci95 = if jenkins_limit {
                [lower, f64::INFINITY]
            } else {
                [lower.min(value), lower.max(value)]
            };
            let direction = if lower > value { "up" } else { "down" };
            estimates.push(Estimate {
                value,
                ci95,
                identifiable: false,
                note: Some(if jenkins_limit {
                    format!(
                        "{} ran to its bound {}: the loops cannot be told from the law's limit (a Jenkins element for the Masing curvature) within the noise; any value ≳ {lower:.3} fits as well (95 %)",
                        p.name, p.bounds[1]
                    )
                } else if at_bound[j] {
                    format!(
                        "{} sits at its bound; the data allow it {direction} to {lower:.4e}",
                        p.name
                    )
                } else {
                    format!(
                        "{} has no effect on the prediction at this value (its derivative is nil); the data allow it {direction} to {lower:.4e}",
                        p.name
                    )
                }),
                bootstrap_ci95: None,
            });
            continue;
        }
        let lo_t = theta[j] - 1.96 * sd;
        let hi_t = theta[j] + 1.96 * sd;
        // 1/θ: an interval reaching θ ≤ 0 reaches N = ∞ (the Jenkins limit)
        let ci = match p.transform {
            Transform::Reciprocal if lo_t <= 0.0 => [p.value(hi_t), f64::INFINITY],
            _ => [p.value(lo_t), p.value(hi_t)],
        };
        let ci95 = [ci[0].min(ci[1]), ci[0].max(ci[1])];
        let wide = !(sd.is_finite()) || matches!(p.transform, Transform::Log) && sd > 1.0;
        estimates.push(Estimate {
            value,
            ci95,
            identifiable: !wide,
            note: wide.then(|| {
                format!(
                    "{} is poorly determined: its 95 % interval spans more than a factor 50",
                    p.name
                )
            }),
            bootstrap_ci95: None,
        });
    }
    Ok(Confidence {
        estimates,
        reduced_chi2: reduced,
    })
}

/// The Jenkins limit `N → ∞` against a finite fitted `N`, by a likelihood
/// ratio: refit with `N` at its bound, everything else free. If the cost
/// rises by less than the 95 % threshold (3.84 χ² units, inflated by the
/// reduced χ²), the data cannot exclude a Jenkins element and `N` is not
/// identifiable, whatever its Wald interval says (the valley in `N` is far
/// from parabolic: it flattens out towards `N → ∞`).
pub(super) fn jenkins_limit_check(
    problem: &FitProblem,
    theta: &[f64],
    pred: &Prediction,
    reduced_chi2: f64,
    estimate: &mut Estimate,
) -> Result<()> {
    let params = &problem.parameters;
    let Some(j) = params
        .parameters
        .iter()
        .position(|p| matches!(p.transform, Transform::Reciprocal))
    else {
        return Ok(());
    };
    let n_param = &params.parameters[j];
    let (base, _) = params.model_at(&problem.base, theta)?;
    let mut jenkins_like = base.clone();
    n_param.write(&mut jenkins_like, n_param.bounds[1])?;
    let mut rest = params.clone();
    rest.parameters.remove(j);
    let sub = FitProblem::new(
        jenkins_like.clone(),
        rest.clone(),
        problem.data,
        problem.predictor,
        problem.weighting,
        None,
    );
    let start = rest.theta_of(&jenkins_like)?;
    let mut theta_j = start.clone();
    let start_cost = sub.cost(&start)?;
    if let Ok(r) = optimise::levenberg_marquardt(&sub, &start, 8)
        && r.cost < start_cost
    {
        theta_j = r.theta;
    }
    // compare the two optima by χ² with the measured standard errors (the
    // likelihood), not by the cost, which for plain eq. (9) weights points
    // by their size rather than their noise
    let (_, pred_j, _) = sub.evaluate(&theta_j)?;
    let delta = chi_square(problem.data, &pred_j) - chi_square(problem.data, pred);
    let threshold = 3.84
        * if reduced_chi2.is_finite() {
            reduced_chi2.max(1.0)
        } else {
            1.0
        };
    if delta < threshold {
        estimate.identifiable = false;
        estimate.ci95[1] = f64::INFINITY;
        estimate.note = Some(format!(
            "N = {:.4} fits best, but N → ∞ (a Jenkins element) is within the 95 % region (Δχ² = {delta:.2} < {threshold:.2}): \
             the data cannot tell eq. (10) from a Jenkins element beyond N ≳ {:.4}",
            estimate.value, estimate.ci95[0]
        ));
    }
    Ok(())
}

/// For a parameter at a bound: how far from the bound the cost stays within
/// the 95 % threshold (3.84 χ² units, inflated by the reduced χ² like the
/// intervals; the other parameters held), scanned in θ.
fn one_sided_range(
    problem: &FitProblem,
    theta: &[f64],
    j: usize,
    reduced_chi2: f64,
) -> Result<f64> {
    let p = &problem.parameters.parameters[j];
    let chi2_at = |t: &[f64]| -> Result<f64> {
        let (_, pred, _) = problem.evaluate(t)?;
        Ok(chi_square(problem.data, &pred))
    };
    let limit = chi2_at(theta)?
        + 3.84
            * if reduced_chi2.is_finite() {
                reduced_chi2.max(1.0)
            } else {
                1.0
            };
    let lo_t = p.theta(p.bounds[0]).min(p.theta(p.bounds[1]));
    let hi_t = p.theta(p.bounds[0]).max(p.theta(p.bounds[1]));
    let toward = if (theta[j] - hi_t).abs() < (theta[j] - lo_t).abs() {
        -1.0
    } else {
        1.0
    };
    let mut t = theta.to_vec();
    // steps doubling away from the bound, then bisection between the last
    // point inside the 95 % region and the first outside
    let mut inside = theta[j];
    let mut step = 1e-3 * theta[j].abs().max(1e-3);
    let mut outside = None;
    for _ in 0..60 {
        let cand = (inside + toward * step).clamp(lo_t, hi_t);
        t[j] = cand;
        if chi2_at(&t)? <= limit {
            inside = cand;
            if cand == lo_t || cand == hi_t {
                break;
            }
            step *= 2.0;
        } else {
            outside = Some(cand);
            break;
        }
    }
    if let Some(mut out) = outside {
        for _ in 0..12 {
            let mid = 0.5 * (inside + out);
            t[j] = mid;
            if problem.cost(&t)? <= limit {
                inside = mid
            } else {
                out = mid
            }
        }
    }
    Ok(p.value(inside))
}

/// Parametric bootstrap: refits to the fitted model plus Gaussian noise of
/// the measured standard errors; percentile intervals.
pub(super) fn bootstrap(
    problem: &FitProblem,
    theta: &[f64],
    pred: &Prediction,
    options: &FitOptions,
    parameters: &mut BTreeMap<String, Estimate>,
) -> Result<()> {
    use rayon::prelude::*;
    let data = problem.data;
    let runs: Vec<Result<Vec<f64>>> = (0..options.bootstrap)
        .into_par_iter()
        .map(|b| {
            let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(options.seed);
            rng.set_stream(b as u64 + 1);
            let mut d = data.clone();
            for (s, ps) in d.series.iter_mut().zip(&pred.h) {
                for (p, m) in s.points.iter_mut().zip(ps) {
                    let Some(m) = m else { continue };
                    for k in 0..p.h.len() {
                        let sd = p.std_error[k] / std::f64::consts::SQRT_2;
                        let (a, b): (f64, f64) = (
                            StandardNormal.sample(&mut rng),
                            StandardNormal.sample(&mut rng),
                        );
                        p.h[k] = m[k] + num_complex::Complex64::new(a * sd, b * sd);
                    }
                }
            }
            let pb = FitProblem::new(
                problem.base.clone(),
                problem.parameters.clone(),
                &d,
                problem.predictor,
                problem.weighting,
                None,
            );
            let step = vec![0.05; theta.len()];
            let r = optimise::nelder_mead(&pb, theta, &step, options.max_iterations / 2, 1e-9)?;
            Ok(problem.parameters.values(&r.theta))
        })
        .collect();
    let runs: Vec<Vec<f64>> = runs.into_iter().collect::<Result<_>>()?;
    for (j, p) in problem.parameters.parameters.iter().enumerate() {
        let mut v: Vec<f64> = runs.iter().map(|r| r[j]).collect();
        v.sort_by(f64::total_cmp);
        let q = |f: f64| v[((f * (v.len() - 1) as f64).round() as usize).min(v.len() - 1)];
        if let Some(e) = parameters.get_mut(&p.name) {
            e.bootstrap_ci95 = Some([q(0.025), q(0.975)]);
        }
    }
    Ok(())
}
