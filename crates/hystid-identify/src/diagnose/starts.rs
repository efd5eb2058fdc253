//! Where refits start: a scan of an effect's size from the residual, and the
//! joint the lower levels alone identify.

use crate::error::Result;
use crate::extract::NonlinearFrf;
use crate::fit::{FitData, FitResult, FrfPredictor, HbPredictor, Prediction};
use crate::model::{ElementSpec, Model};

/// One Gauss–Newton step from zero for a scalar effect parameter: the model
/// with the effect at `probe` gives the residual's direction.
fn gauss_newton_start(
    base: &Model,
    data: &FitData,
    pred: &Prediction,
    predictor: &HbPredictor,
    with: &dyn Fn(f64) -> ElementSpec,
    probe: f64,
) -> Result<f64> {
    let m = base.with_effect(with(probe));
    let p1 = predictor.predict_from(&m, data, Some(pred))?;
    let (mut num, mut den) = (0.0, 0.0);
    for ((s, a), b) in data.series.iter().zip(&pred.h).zip(&p1.h) {
        for ((p, a), b) in s.points.iter().zip(a).zip(b) {
            let (Some(a), Some(b)) = (a, b) else { continue };
            for k in 0..data.harmonics.len() {
                let w = 1.0 / p.std_error[k].max(f64::MIN_POSITIVE).powi(2);
                let j = (b[k] - a[k]) / probe;
                let d = p.h[k] - a[k];
                num += w * (j.conj() * d).re;
                den += w * j.norm_sqr();
            }
        }
    }
    Ok(if den > 0.0 { num / den } else { probe })
}

/// The best of a scan of an effect's size: the model with the effect at
/// sizes spread over four decades around `probe` (both signs where the size
/// may take either) and at the Gauss–Newton estimate from zero, judged by
/// `χ²`. A linearisation from zero alone misjudges a large effect (a contact
/// whose even harmonics are 40 % of the fundamental is far from its
/// small-size limit); the scan finds the basin, the refit the optimum.
pub(crate) fn scan_start(
    base: &Model,
    data: &FitData,
    pred: &Prediction,
    predictor: &HbPredictor,
    with: &dyn Fn(f64) -> ElementSpec,
    probe: f64,
    signed: bool,
) -> Option<(f64, f64, Option<f64>)> {
    let mut sizes: Vec<f64> = (-4..=4)
        .map(|k| probe * 10f64.powf(0.5 * k as f64))
        .collect();
    if signed {
        let neg: Vec<f64> = sizes.iter().map(|v| -v).collect();
        sizes.extend(neg);
    }
    let gn = gauss_newton_start(base, data, pred, predictor, with, probe)
        .ok()
        .filter(|g| g.is_finite() && *g != 0.0 && (signed || *g > 0.0));
    sizes.extend(gn);
    let mut best: Option<(f64, f64)> = None;
    for size in sizes {
        let m = base.with_effect(with(size));
        let Ok(p) = predictor.predict_from(&m, data, Some(pred)) else {
            continue;
        };
        let chi2 = crate::fit::problem::chi_square(data, &p);
        if chi2.is_finite() && best.is_none_or(|b| chi2 < b.1) {
            best = Some((size, chi2));
        }
    }
    best.map(|(size, chi2)| (size, chi2, gn))
}

/// The lower levels only (the lowest half of those with points to fit, at
/// least three, of at least four) and the joint law identified on them;
/// `None` when there are too few levels or the fit fails.
pub(super) fn lower_levels_fit(
    frf: &NonlinearFrf,
    options: &crate::fit::FitOptions,
    predictor: &HbPredictor,
) -> Option<(NonlinearFrf, FitResult)> {
    // the levels with something to fit (a PCM16 file's lowest may have
    // nothing above the converter's resolution)
    let usable: Vec<usize> = (0..frf.levels.len())
        .filter(|&i| {
            frf.levels[i]
                .points
                .iter()
                .filter(|p| crate::fit::problem::usable_point(p, &options.harmonics))
                .count()
                >= 3
        })
        .collect();
    let n = usable.len();
    if n < 4 {
        return None;
    }
    let mut order = usable;
    order.sort_by(|&a, &b| frf.levels[a].level.total_cmp(&frf.levels[b].level));
    let keep = n.div_ceil(2).max(3);
    let mut lower = frf.clone();
    lower.levels = order[..keep]
        .iter()
        .map(|&i| frf.levels[i].clone())
        .collect();
    let fit = crate::fit::identify(&lower, options, predictor, None).ok()?;
    Some((lower, fit))
}

/// The joint of [`lower_levels_fit`] with the baseline's linear part, when
/// the baseline explains those levels far worse than it does; `None` when
/// the two agree.
pub(super) fn lower_levels_joint(
    lower: &NonlinearFrf,
    fit: &FitResult,
    options: &crate::fit::FitOptions,
    predictor: &HbPredictor,
    base: &Model,
    sign: f64,
) -> Option<Model> {
    let joint = fit.model.joint?;
    let base_joint = base.joint.as_ref()?;
    if joint.kind() != base_joint.kind() {
        return None;
    }
    // pulled away when the baseline explains the lower levels far worse
    // (twice the χ²) than a joint fitted to them alone does
    let lower_data = FitData::from_frf(lower, &options.harmonics, options.band_hz, None)
        .ok()?
        .with_sign(sign);
    let chi2_on = |m: &Model| {
        let p = predictor.predict_from(m, &lower_data, None).ok()?;
        let c = crate::fit::problem::chi_square(&lower_data, &p);
        c.is_finite().then_some(c)
    };
    if fit.response_sign != sign || !(chi2_on(base)? > 2.0 * chi2_on(&fit.model)?) {
        return None;
    }
    let mut m = base.clone();
    m.joint = Some(joint);
    Some(m)
}
