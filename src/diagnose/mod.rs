//! Close the loop: trace a fit's residual to an effect the model lacks, add
//! it, refit, and report the error before and after.
//!
//! The paper ends where its experiment's fit fails at high levels (section
//! 4: "there is something in the structure that is not taken into account in
//! the theoretical model"). This stage goes on from there:
//!
//! 1. the baseline model (the fitted joint on its linear modes) is refitted
//!    on the fundamental and the second and third harmonics, with every
//!    residual scaled by its measured standard error, so that the cost is the
//!    likelihood `χ²`;
//! 2. the residual's features ([`features`]) rank the candidate effects;
//! 3. every candidate is added in turn, started from a Gauss–Newton step on
//!    the residual (a grid search for a mode), and refitted with all other
//!    parameters free, in parallel;
//! 4. the best candidate is kept only if its `χ²` drop beats the Bayesian
//!    information criterion, `Δχ² > p ln n + 2 ln K` (p new parameters, n
//!    real residuals, K candidates compared), scaled by the reduced `χ²` when
//!    the fit is still worse than the noise, and if its own size is resolved
//!    (an interval that excludes zero, not at a bound, a mode of positive
//!    modal mass below the largest damping ratio); an effect kept earlier
//!    that loses its resolution when a later one comes in is dropped again,
//!    unless the newcomer then loses its own: that round is undone (the
//!    model before it is the one whose every effect is resolved);
//!    then the loop repeats with the rest. A candidate whose refit fails is
//!    reported as failed, with the reason, and the diagnosis goes on.
//!
//! "No significant missing effect" is an answer, given when no candidate
//! passes.

pub mod candidates;
pub mod features;
pub mod lines;
pub mod time_residual;

pub use candidates::Effect;
pub use features::{ResidualFeatures, features};

use candidates::Context;

use crate::error::{Error, Result};
use crate::extract::NonlinearFrf;
use crate::fit::optimise::{FitStatus, Race};
use crate::fit::{
    Estimate, FitData, FitProblem, FitResult, FrfPredictor, HbPredictor, ParameterSet, Prediction,
    Transform, Weighting,
};
use crate::harmonics::omega;
use crate::model::{ElementSpec, Model};
use crate::observe::{DiagnoseEvent, EffectName};
use rayon::prelude::*;
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;

/// Options of a diagnosis.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct DiagnoseOptions {
    /// The candidates tried.
    pub candidates: Vec<Effect>,
    /// At most this many effects are added.
    pub max_effects: usize,
    /// Harmonics judged (default: 1, 2, 3; see [`default_harmonics`]).
    pub harmonics: Option<Vec<usize>>,
    /// Frequency band, Hz.
    pub band_hz: Option<(f64, f64)>,
    /// Levenberg–Marquardt patience of each refit.
    pub patience: usize,
    /// How the baseline was identified (a candidate mode is identified the
    /// same way, with one more mode).
    pub fit: crate::fit::FitOptions,
    /// With a refinement in the time domain: how many of the candidates the
    /// FRFs did not keep are put to the recorded time histories, those that
    /// explain the most of the time residual first (see
    /// [`time_residual`]; each costs a refit on the whole recordings; 0:
    /// none).
    pub time_proposals: usize,
}

impl Default for DiagnoseOptions {
    fn default() -> Self {
        DiagnoseOptions {
            candidates: Effect::defaults(),
            max_effects: 3,
            harmonics: None,
            band_hz: None,
            patience: 12,
            fit: crate::fit::FitOptions::default(),
            time_proposals: 0,
        }
    }
}

/// How well one model fits.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ModelFit {
    /// The model's parameters by name.
    pub parameters: BTreeMap<String, f64>,
    /// `‖H_meas − H_model‖/‖H_meas‖` of the fundamental over all points.
    pub error_relative: f64,
    /// The same per harmonic judged.
    pub error_relative_per_harmonic: BTreeMap<usize, f64>,
    /// `χ²` with the measured standard errors.
    pub chi2: f64,
    /// `χ²` per degree of freedom.
    pub chi2_per_dof: f64,
}

/// One candidate's refit.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct CandidateReport {
    /// The effect.
    pub effect: Effect,
    /// The round (1 = tried on the baseline).
    pub round: usize,
    /// Where the features ranked it (1 = most likely).
    pub rank: usize,
    /// The refit.
    #[serde(flatten)]
    pub fit: ModelFit,
    /// The effect's own parameters.
    pub effect_parameters: BTreeMap<String, f64>,
    /// `χ²` drop against the model it was added to.
    pub delta_chi2: f64,
    /// The parameters it added to the model it was tried on (a joint law
    /// in place of another adds the difference).
    #[serde(default)]
    pub parameters_added: usize,
    /// The BIC threshold it had to beat.
    pub threshold: f64,
    /// `Δχ² − threshold` (the criterion value; > 0 passes).
    pub criterion: f64,
    /// Whether it was kept.
    pub accepted: bool,
    /// Why it was kept or not, as a type (`note` says it in words).
    #[serde(default)]
    pub verdict: Verdict,
    /// Why a candidate that passed the criterion was still not kept.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub note: Option<String>,
}

/// What became of a candidate refit.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Verdict {
    /// Kept in the final model.
    Kept,
    /// Kept in its round, dropped in a later one when another effect made
    /// it unresolved.
    DroppedLater,
    /// Passed the information criterion, but the data do not resolve its
    /// size (or it is implausible, e.g. a mode of negative modal mass).
    SizeNotResolved,
    /// Passed the information criterion, but another candidate of its round
    /// did better.
    AnotherDidBetter,
    /// Did not lower `χ²` by what the information criterion asks.
    #[default]
    BelowCriterion,
    /// Kept by the FRF diagnosis, dropped when the model without it, refitted
    /// on the recorded time histories, fitted them as well (see
    /// [`without_effect`]).
    NotConfirmedInTime,
    /// Not kept on the FRFs, kept when the final model with it, refitted on
    /// the recorded time histories, fitted them better (see
    /// [`with_effect`]).
    KeptInTime,
}

/// A candidate whose refit could not be done, and why: a finding of the
/// diagnosis, which goes on without it.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct FailedCandidate {
    /// The effect.
    pub effect: Effect,
    /// The round.
    pub round: usize,
    /// Why (the error, or no starting point in the residual, or why it does
    /// not apply).
    pub reason: String,
    /// It does not apply to these FRFs (the shaker on a force reference):
    /// not a failure.
    #[serde(default, skip_serializing_if = "std::ops::Not::not")]
    pub not_applicable: bool,
}

/// An effect kept, with its parameters' intervals.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct SelectedEffect {
    /// The effect.
    pub effect: Effect,
    /// Its parameters with 95 % intervals.
    pub parameters: BTreeMap<String, Estimate>,
}

/// The result of [`diagnose`].
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Diagnosis {
    /// The harmonics judged.
    pub harmonics: Vec<usize>,
    /// The frequency band judged, Hz (all points when absent).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub band_hz: Option<(f64, f64)>,
    /// The baseline (the fitted joint), refitted on those harmonics.
    pub baseline: ModelFit,
    /// The baseline residual's features.
    pub features: ResidualFeatures,
    /// Every candidate refit, in order of rounds.
    pub candidates: Vec<CandidateReport>,
    /// Candidates whose refit failed, with the reason.
    #[serde(default)]
    pub failed: Vec<FailedCandidate>,
    /// The effects kept.
    pub selected: Vec<SelectedEffect>,
    /// The final model's fit.
    #[serde(rename = "final")]
    pub final_fit: ModelFit,
    /// The final residual's features.
    pub final_features: ResidualFeatures,
    /// Whether the final residual is consistent with the noise (`χ²/dof < 2`).
    pub consistent_with_noise: bool,
    /// Plain-language account.
    pub explanation: String,
    /// The baseline model (refitted).
    pub baseline_model: Model,
    /// The final model.
    pub model: Model,
    /// The response sign the models predict (see `FitData::response_sign`).
    pub response_sign: f64,
    /// The baseline's first-mode parameters at or beyond the range the
    /// smallest level's linear estimate allows (see [`crate::fit::anchor`]):
    /// a baseline gone astray, on which the effects added are not trusted.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub baseline_astray: Option<crate::fit::identify::Astray>,
}

/// The free parameters of a model: every element's, the first mode as an
/// SDOF (`m, c, k`), and any further mode's frequency, damping ratio and
/// modal constant (its static flexibility for a mode above `band_hz`, see
/// [`ParameterSet::for_linear_in`]).
pub fn model_parameters(model: &Model, band_hz: Option<(f64, f64)>) -> ParameterSet {
    let mut p = ParameterSet::default();
    for (at, _) in model.placed_all() {
        // the joint's parameters keep their plain names (kd, fd, …)
        let prefix = model.parameter_prefix(at);
        let mut set = ParameterSet::for_element(model, at, &prefix);
        for q in &mut set.parameters {
            // a parameter that starts at zero still needs a sensible scale
            if let Transform::Scaled { scale } = &mut q.transform
                && *scale == 1.0
            {
                *scale = 1e-3;
            }
        }
        p.extend(set);
    }
    p.extend(ParameterSet::for_linear_in(model, band_hz));
    p.without_gauges(model)
}

/// A model written down (a declared shaker, a hysteretic mode, an effect
/// the user knows is there), fitted to the nonlinear FRFs: every parameter
/// of its elements and of its linear part, on the residuals weighted by their
/// standard errors: a Nelder–Mead simplex from the model as written, then
/// the refit the diagnosis gives its candidates (Levenberg–Marquardt), with
/// 95 % intervals. A local fit: a start far from the data can end in
/// another basin, which its `χ²` then shows.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct DeclaredFit {
    /// The fitted model.
    pub model: Model,
    /// The sign its `H` carry against the measured ones.
    pub response_sign: f64,
    /// The harmonics judged.
    pub harmonics: Vec<usize>,
    /// Its parameters with 95 % intervals.
    pub parameters: BTreeMap<String, Estimate>,
    /// Its error on the data judged.
    pub error: crate::fit::identify::ErrorReport,
    /// The error of the model as written, on the same data.
    pub start_error: crate::fit::identify::ErrorReport,
}

/// The simplex's first step in each fit coordinate of a declared model's
/// fit: 10 % of a positive parameter, a tenth of a signed one's scale.
const DECLARED_SIMPLEX_STEP: f64 = 0.1;
/// Its iterations per free parameter.
const DECLARED_SIMPLEX_ITERATIONS_PER_PARAMETER: u64 = 60;

/// Fits the model `start`, which predicts `response_sign` times the
/// measured response (`transfer`: not at the drive point), to `frf`'s
/// `harmonics` within `band_hz` (see [`DeclaredFit`]).
#[allow(clippy::too_many_arguments)]
pub fn fit_declared(
    frf: &NonlinearFrf,
    start: &Model,
    response_sign: f64,
    transfer: bool,
    harmonics: &[usize],
    band_hz: Option<(f64, f64)>,
    predictor: &HbPredictor,
    patience: usize,
    observer: &dyn crate::observe::Observer,
) -> Result<DeclaredFit> {
    start.validate()?;
    start.check_reference(frf.reference, "the FRFs' reference")?;
    let data = FitData::from_frf(frf, harmonics, band_hz, None)?
        .with_sign(response_sign)
        .with_transfer(transfer);
    let params = model_parameters(start, data.band_hz());
    let before = predictor.predict_from(start, &data, None)?;
    // the refit's cost is χ² (residuals weighted by their standard errors)
    let start_error = crate::fit::identify::error_report(
        &data,
        &before,
        crate::fit::problem::chi_square(&data, &before),
        params.len(),
    );
    // a start written down may sit some way off: a simplex first (one
    // failed model is a penalised point, not an error), then the refit's
    // Levenberg–Marquardt from the better of the two
    let problem = FitProblem::new(
        start.clone(),
        params.clone(),
        &data,
        predictor,
        Weighting::StandardError,
        Some(observer),
    )
    .with_warm_start(before.clone());
    let theta0 = params.theta_of(start)?;
    let cost0 = problem.cost(&theta0)?;
    let n = theta0.len();
    let simplex = crate::fit::optimise::nelder_mead(
        &problem,
        &theta0,
        &vec![DECLARED_SIMPLEX_STEP; n],
        DECLARED_SIMPLEX_ITERATIONS_PER_PARAMETER * n as u64,
        1e-8,
    );
    // (a cancelled cost ends the simplex as a failure would: say which)
    if observer.cancelled() {
        return Err(Error::Cancelled);
    }
    let from = match simplex {
        Ok(s) if s.cost < cost0 => problem.evaluate(&s.theta)?.0,
        _ => start.clone(),
    };
    // one fit, one numbering of its evaluations
    let observed = Observed {
        observer,
        after: problem.evaluations(),
    };
    let r = refit_within(&from, &data, predictor, None, patience, 3, Some(observed))?;
    if observer.cancelled() {
        return Err(Error::Cancelled);
    }
    let params = model_parameters(&r.model, data.band_hz());
    let conf = confidence_at(&r.model, &params, &r.pred, &data, predictor)?;
    let parameters = params
        .parameters
        .iter()
        .map(|p| p.name.clone())
        .zip(conf.estimates)
        .collect();
    let error = crate::fit::identify::error_report(&data, &r.pred, r.chi2, params.len());
    Ok(DeclaredFit {
        model: r.model,
        response_sign,
        harmonics: harmonics.to_vec(),
        parameters,
        error,
        start_error,
    })
}

/// A model refitted to the data judged, with its prediction and `χ²`.
#[derive(Clone)]
pub(crate) struct Refit {
    pub(crate) model: Model,
    pub(crate) pred: Prediction,
    pub(crate) chi2: f64,
}

/// Refits every free parameter of `model` to `data` (σ-weighted), by
/// Levenberg–Marquardt from the model as given.
fn refit(
    model: &Model,
    data: &FitData,
    predictor: &HbPredictor,
    warm: Option<&Prediction>,
    patience: usize,
) -> Result<Refit> {
    refit_within(model, data, predictor, warm, patience, 3, None)
}

/// Who is told of a refit's evaluations, numbered on from `after`.
#[derive(Clone, Copy)]
struct Observed<'a> {
    observer: &'a dyn crate::observe::Observer,
    after: usize,
}

/// [`refit`] with at most `budgets` Levenberg–Marquardt runs of `patience`
/// (one: a brief refit, as a start's screening).
fn refit_within(
    model: &Model,
    data: &FitData,
    predictor: &HbPredictor,
    warm: Option<&Prediction>,
    patience: usize,
    budgets: usize,
    observed: Option<Observed<'_>>,
) -> Result<Refit> {
    let budget = Budget {
        patience,
        runs: budgets,
        race: None,
    };
    refit_counted(model, data, predictor, warm, budget, observed).map(|(r, _)| r)
}

/// A refit's Levenberg–Marquardt runs: at most `runs` of `patience` each,
/// given up where `race` says (over all the runs).
#[derive(Clone, Copy)]
struct Budget {
    patience: usize,
    runs: usize,
    race: Option<Race>,
}

/// [`refit_within`] within `budget`, with the residual evaluations it took.
fn refit_counted(
    model: &Model,
    data: &FitData,
    predictor: &HbPredictor,
    warm: Option<&Prediction>,
    budget: Budget,
    observed: Option<Observed<'_>>,
) -> Result<(Refit, usize)> {
    let mut params = data.anchored(model_parameters(model, data.band_hz()), model);
    // a parameter at its bound (the joint's N → ∞ for Jenkins-like data) is
    // held there: its penalty row would mislead a derivative-based step
    params.parameters.retain(|p| {
        let v = p.read(model).unwrap_or(f64::NAN);
        !p.bounds
            .iter()
            .any(|&b| b.is_finite() && b != 0.0 && (v / b - 1.0).abs() < 0.01)
    });
    let mut problem = FitProblem::new(
        model.clone(),
        params.clone(),
        data,
        predictor,
        Weighting::StandardError,
        observed.map(|o| o.observer),
    )
    .numbered_after(observed.map_or(0, |o| o.after));
    if let Some(w) = warm {
        problem = problem.with_warm_start(w.clone());
    }
    let mut theta = params.theta_of(model)?;
    let mut cost = problem.cost(&theta)?;
    let mut used = 0;
    // Levenberg–Marquardt stops on its evaluation budget as often as on its
    // tolerance: restart it from where it ended while that still pays (a
    // start far from the optimum, as a scanned effect size can be, needs
    // more than one budget)
    for _ in 0..budget.runs {
        // a start already ahead of the one it races runs on unhindered
        let race = budget
            .race
            .filter(|r| cost >= r.cost_to_beat)
            .map(|r| Race {
                after: r.after.saturating_sub(used),
                ..r
            });
        let run = crate::fit::optimise::levenberg_marquardt_racing(
            &problem,
            &theta,
            budget.patience,
            REFIT_TOLERANCE,
            race,
        );
        if let Ok(r) = &run {
            used += r.evaluations;
        }
        match run {
            Ok(r) if r.cost < cost => {
                let gain = (cost - r.cost) / cost.max(f64::MIN_POSITIVE);
                (theta, cost) = (r.theta, r.cost);
                if r.converged || gain < 1e-3 || r.status == FitStatus::Abandoned {
                    break;
                }
            }
            _ => break,
        }
    }
    let (model, pred, _) = problem.evaluate(&theta)?;
    let chi2 = crate::fit::problem::chi_square(data, &pred);
    Ok((Refit { model, pred, chi2 }, used))
}

/// The best refit seen of each set of kept effects (the baseline's: none).
/// A refit after an effect is dropped starts from the model without it and
/// can settle in a worse basin than the same effects reached in an earlier
/// round: the earlier model is then the diagnosis's, since both are fits
/// of the same model class to the same data.
#[derive(Default)]
struct BestBySet(Vec<(Vec<Effect>, Refit)>);

impl BestBySet {
    fn key(chosen: &[Effect]) -> Vec<Effect> {
        let mut k = chosen.to_vec();
        k.sort();
        k
    }

    /// Notes `r` as a refit of `chosen`.
    fn note(&mut self, chosen: &[Effect], r: &Refit) {
        let key = Self::key(chosen);
        match self.0.iter_mut().find(|(k, _)| *k == key) {
            Some((_, best)) if best.chi2 <= r.chi2 => {}
            Some((_, best)) => *best = r.clone(),
            None => self.0.push((key, r.clone())),
        }
    }

    /// `r`, or the better refit of the same effects seen before.
    fn better(&mut self, chosen: &[Effect], r: Refit) -> Refit {
        self.note(chosen, &r);
        let key = Self::key(chosen);
        let best = &self.0.iter().find(|(k, _)| *k == key).expect("noted").1;
        if best.chi2 < r.chi2 { best.clone() } else { r }
    }
}

fn model_fit(model: &Model, data: &FitData, pred: &Prediction, chi2: f64) -> ModelFit {
    let params = model_parameters(model, data.band_hz());
    let values = params
        .theta_of(model)
        .map(|t| params.values(&t))
        .unwrap_or_default();
    let dof = (2 * data.observations())
        .saturating_sub(params.len())
        .max(1) as f64;
    ModelFit {
        parameters: params
            .parameters
            .iter()
            .map(|p| p.name.clone())
            .zip(values)
            .collect(),
        error_relative: crate::fit::problem::relative_error(data, pred, 1).unwrap_or(f64::NAN),
        error_relative_per_harmonic: data
            .harmonics
            .iter()
            .filter_map(|&h| Some((h, crate::fit::problem::relative_error(data, pred, h)?)))
            .collect(),
        chi2,
        chi2_per_dof: chi2 / dof,
    }
}

/// The largest displacement and velocity amplitudes in the data.
pub(crate) fn amplitudes(data: &FitData) -> (f64, f64) {
    let Some(k) = data.harmonic_index(1) else {
        return (1.0, 1.0);
    };
    let (mut a, mut v) = (0.0f64, 0.0f64);
    for s in &data.series {
        for p in &s.points {
            let w = omega(p.frequency_hz);
            let x = p.h[k].norm() / data.response.from_displacement(w).norm() * p.force_amplitude;
            a = a.max(x);
            v = v.max(x * w);
        }
    }
    (a.max(f64::MIN_POSITIVE), v.max(f64::MIN_POSITIVE))
}

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

/// A refit's parameters and their confidence intervals: computed once per
/// model and asked of each effect it holds.
struct Intervals {
    params: ParameterSet,
    conf: crate::fit::identify::Confidence,
}

impl Intervals {
    fn at(r: &Refit, data: &FitData, predictor: &HbPredictor) -> Result<Intervals> {
        let params = model_parameters(&r.model, data.band_hz());
        let conf = confidence_at(&r.model, &params, &r.pred, data, predictor)?;
        Ok(Intervals { params, conf })
    }
}

/// Why the data do not resolve an effect's size in `r` (k3, kb, c2, a
/// clearance's stiffness, a mode's modal constant), if they do not: an
/// interval that includes zero (the effect may not be there at all) or
/// spans more than a decade. `intervals` are the refit's, computed once
/// for every effect it holds.
fn unresolved_in(
    effect: Effect,
    r: &Refit,
    intervals: &Intervals,
    data: &FitData,
) -> Option<String> {
    let Intervals { params, conf } = intervals;
    let candidate = effect.candidate();
    for (p, e) in params.parameters.iter().zip(&conf.estimates) {
        let Some(name) = candidate.own_parameter(effect.name(), &r.model, &p.name) else {
            continue;
        };
        if let Some(why) = candidate.implausible(name, e, &r.model, data) {
            return Some(why);
        }
        // the effect's size; its shape (a mode's frequency and damping, a
        // gap) may sit at a bound without making the effect doubtful
        if !candidate.size_parameters().contains(&name) {
            continue;
        }
        let at_bound = p
            .bounds
            .iter()
            .any(|&b| b.is_finite() && (e.value - b).abs() <= 1e-9 * b.abs().max(e.value.abs()));
        if !e.identifiable {
            return Some(format!(
                "lowered χ² enough, but the data do not determine its {name}{}",
                e.note
                    .as_deref()
                    .map(|n| format!(" ({n})"))
                    .unwrap_or_default()
            ));
        }
        if at_bound || e.value == 0.0 {
            return Some(format!(
                "lowered χ² enough, but its {name} = {} sits at its bound: not resolved from the noise",
                fmt_value(e.value)
            ));
        }
        let [lo, hi] = e.ci95;
        let straddles = lo <= 0.0 && hi >= 0.0;
        let too_wide = !(lo.is_finite() && hi.is_finite())
            || (lo > 0.0 && hi / lo > 10.0)
            || (hi < 0.0 && lo / hi > 10.0);
        if straddles || too_wide {
            return Some(format!(
                "lowered χ² enough, but its {name} = {} has the 95 % interval [{}, {}]: not resolved from the noise",
                fmt_value(e.value),
                fmt_value(lo),
                fmt_value(hi)
            ));
        }
    }
    None
}

/// The σ-weighted confidence intervals of `params` at `model`.
fn confidence_at(
    model: &Model,
    params: &ParameterSet,
    pred: &Prediction,
    data: &FitData,
    predictor: &HbPredictor,
) -> Result<crate::fit::identify::Confidence> {
    let problem = FitProblem::new(
        model.clone(),
        params.clone(),
        data,
        predictor,
        Weighting::StandardError,
        None,
    )
    .with_warm_start(pred.clone());
    let theta = params.theta_of(model)?;
    crate::fit::identify::confidence(&problem, &theta, pred)
}

/// The lower levels only (the lowest half of those with points to fit, at
/// least three, of at least four) and the joint law identified on them;
/// `None` when there are too few levels or the fit fails.
fn lower_levels_fit(
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
fn lower_levels_joint(
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

/// A refit stops where a step changes χ² or the parameters by less than
/// this, relative (MINPACK's default): χ² is then known far better than the
/// information criterion's threshold needs (a few units in thousands), and
/// each parameter far inside its interval, where the optimiser's own
/// default (30 machine epsilons) ran every refit to its evaluation budget.
const REFIT_TOLERANCE: f64 = 1.49012e-8;

/// A baseline refit whose χ² is above this many times what the noise alone
/// gives is suspected to have gone astray, and is also started afresh (the
/// weighted identification, the lower levels' joint): the bound the
/// controls of the independent corpus are held to.
pub(crate) const ASTRAY_CHI2_PER_DOF: f64 = 2.0;

/// True when a model's `chi2` is more than [`ASTRAY_CHI2_PER_DOF`] times
/// `expected`, what the noise alone gives: the one test of "far from the
/// noise" behind every start or candidate spent only there.
pub(crate) fn far_from_noise(chi2: f64, expected: f64) -> bool {
    chi2 > ASTRAY_CHI2_PER_DOF * expected
}

/// A candidate with more starts than this has them screened first: each
/// refitted briefly, only the best this many refitted in full.
const POLISHED_STARTS: usize = 2;

/// Levenberg–Marquardt's patience while screening starts: enough to let a
/// start settle into its basin, a fraction of a full refit.
const SCREEN_PATIENCE: usize = 1;

/// What the trials of a round's candidates share: everything their starts
/// are made from but the model each is added to.
struct Trials<'a> {
    frf: &'a NonlinearFrf,
    data: &'a FitData,
    options: &'a DiagnoseOptions,
    predictor: &'a HbPredictor,
    identified: &'a candidates::Identified,
    expected_chi2: f64,
}

impl<'a> Trials<'a> {
    /// The trials on `data`, judged against the `χ²` its noise alone gives.
    fn new(
        frf: &'a NonlinearFrf,
        data: &'a FitData,
        options: &'a DiagnoseOptions,
        predictor: &'a HbPredictor,
        identified: &'a candidates::Identified,
    ) -> Self {
        Trials {
            frf,
            data,
            options,
            predictor,
            identified,
            expected_chi2: crate::fit::problem::expected_chi_square(data),
        }
    }

    /// A candidate's context: `current` the model it is added to.
    fn context(&self, current: &'a Refit) -> Context<'a> {
        Context {
            current,
            data: self.data,
            frf: self.frf,
            options: self.options,
            predictor: self.predictor,
            identified: self.identified,
            expected_chi2: self.expected_chi2,
        }
    }

    /// Makes the identifications afresh that the starts of `effects` from
    /// `currents` will read (see [`candidates::Candidate::identifications`]),
    /// before the candidates are refitted side by side.
    fn identify_beforehand(&self, effects: &[Effect], currents: &[&'a Refit]) {
        let wanted: Vec<usize> = currents
            .iter()
            .flat_map(|&current| {
                let cx = self.context(current);
                effects
                    .iter()
                    .flat_map(|e| e.candidate().identifications(&cx))
                    .collect::<Vec<_>>()
            })
            .collect();
        candidates::identify_beforehand(
            self.identified,
            &wanted,
            self.frf,
            self.options,
            self.predictor,
        );
    }
}

/// One candidate's refit: its start(s) from the residual of each current
/// model (the baseline, and in the first round the lower levels' joint),
/// each refitted, the best kept (`None` when no start exists).
///
/// Starts are many where the residual is ambiguous (a further mode has up
/// to eight per current model, most of them far from the optimum): each is
/// refitted briefly, and only the best [`POLISHED_STARTS`] are refitted in
/// full, so that the candidate costs a few refits, not one per start.
fn try_candidate<'a>(
    effect: Effect,
    currents: &[&'a Refit],
    trials: &Trials<'a>,
) -> Result<Option<Refit>> {
    let (data, predictor, options) = (trials.data, trials.predictor, trials.options);
    let mut starts: Vec<(Model, &Prediction)> = Vec::new();
    let mut last_error = None;
    for &current in currents {
        let cx = trials.context(current);
        match effect.candidate().starts(&cx) {
            Ok(s) => starts.extend(s.into_iter().map(|m| (m, &current.pred))),
            Err(e) => last_error = Some(e),
        }
    }
    let patience = options.patience;
    let full = |(m, warm): &(Model, &Prediction)| refit(m, data, predictor, Some(warm), patience);
    // independent refits: side by side, collected in order (the result does
    // not depend on the thread count)
    let refits: Vec<Result<Refit>> = if starts.len() <= POLISHED_STARTS {
        starts.par_iter().map(full).collect()
    } else {
        let screened: Vec<Result<Refit>> = starts
            .par_iter()
            .map(|(m, warm)| refit_within(m, data, predictor, Some(warm), SCREEN_PATIENCE, 1, None))
            .collect();
        let mut order: Vec<usize> = (0..screened.len())
            .filter(|&i| screened[i].as_ref().is_ok_and(|r| r.chi2.is_finite()))
            .collect();
        order.sort_by(|&a, &b| {
            let chi2 = |i: usize| screened[i].as_ref().map_or(f64::INFINITY, |r| r.chi2);
            chi2(a).total_cmp(&chi2(b)).then(a.cmp(&b))
        });
        order.truncate(POLISHED_STARTS);
        if order.is_empty() {
            screened
        } else {
            // one after the other, from the best screened: each later start
            // races the best polished so far, and is given up once it has
            // taken twice that one's evaluations without coming below it
            // (decided by evaluation counts, so the result does not depend on
            // the thread count; each refit runs its series in parallel)
            let mut leader: Option<(f64, usize)> = None;
            let mut polished = Vec::with_capacity(order.len());
            for &i in &order {
                let r = screened[i].as_ref().expect("screened start kept");
                let budget = Budget {
                    patience,
                    runs: 3,
                    race: leader.map(|(chi2, used)| Race {
                        after: 2 * used,
                        cost_to_beat: chi2,
                    }),
                };
                let q = refit_counted(&r.model, data, predictor, Some(&r.pred), budget, None);
                if let Ok((q, used)) = &q
                    && leader.is_none_or(|(chi2, _)| q.chi2 < chi2)
                {
                    leader = Some((q.chi2, *used));
                }
                polished.push(q.map(|(q, _)| q));
            }
            polished
        }
    };
    let mut best: Option<Refit> = None;
    for r in refits {
        match r {
            Ok(r) => {
                if best.as_ref().is_none_or(|b| r.chi2 < b.chi2) {
                    best = Some(r);
                }
            }
            Err(e) => last_error = Some(e),
        }
    }
    match (best, last_error) {
        (Some(b), _) => Ok(Some(b)),
        (None, Some(e)) => Err(e),
        (None, None) => Ok(None),
    }
}

/// Ranks the candidates by what the residual says (1 = most likely).
fn rank(features: &ResidualFeatures, candidates: &[Effect]) -> Vec<(Effect, f64)> {
    let mut scored: Vec<(Effect, f64)> = candidates
        .iter()
        .map(|&e| (e, e.candidate().score(features)))
        .collect();
    scored.sort_by(|a, b| b.1.total_cmp(&a.1).then(a.0.cmp(&b.0)));
    scored
}

/// The harmonics a diagnosis judges by default: 1, 2 and 3.
///
/// Not the static part: a hysteretic joint that sticks keeps whatever
/// offset its load history left (where the slider stopped after the first
/// transient), which no periodic steady-state model can know; on virtual
/// tests of a symmetric Jenkins joint it shows as a DC residual 6 times the
/// noise. The second harmonic alone reveals an asymmetric element.
pub fn default_harmonics(frf: &NonlinearFrf) -> Vec<usize> {
    let mut h = vec![1, 2, 3];
    h.retain(|&k| k <= frf.max_harmonic);
    h
}

/// Diagnoses a fit: see the module docs.
pub fn diagnose(
    frf: &NonlinearFrf,
    fit: &FitResult,
    options: &DiagnoseOptions,
    predictor: &HbPredictor,
) -> Result<Diagnosis> {
    diagnose_observed(frf, fit, options, predictor, &crate::observe::Silent)
}

/// [`diagnose`], telling `observer` what it is doing (called from worker
/// threads while candidates are refitted in parallel).
pub fn diagnose_observed(
    frf: &NonlinearFrf,
    fit: &FitResult,
    options: &DiagnoseOptions,
    predictor: &HbPredictor,
    observer: &dyn crate::observe::Observer,
) -> Result<Diagnosis> {
    let cancelled = || observer.cancelled();
    let observer = |e: DiagnoseEvent| observer.observe(crate::observe::Event::Diagnosis(&e));
    let harmonics = options
        .harmonics
        .clone()
        .unwrap_or_else(|| default_harmonics(frf));
    if !harmonics.contains(&1) {
        return Err(Error::plan(
            "harmonics",
            "the diagnosis needs the fundamental",
        ));
    }
    let data = FitData::from_frf(frf, &harmonics, options.band_hz, None)?
        .with_sign(fit.response_sign)
        .with_transfer(options.fit.transfer || fit.transfer)
        .with_anchor(crate::fit::LinearAnchor::of(&fit.linear.stick));
    let n_real = (2 * data.observations()) as f64;
    // χ² against what noise alone gives with block-estimated standard errors
    let expected = crate::fit::problem::expected_chi_square(&data);
    let normalised = |chi2: f64| chi2 / expected.max(f64::MIN_POSITIVE);
    // within 3 standard deviations of the noise's χ²: nothing left to explain
    let noise_band = 1.0 + 3.0 * (2.0 / n_real).sqrt();
    let mut base = refit(&fit.model, &data, predictor, None, options.patience)?;
    // the fit handed in is one start of the baseline; an identification on
    // the harmonics judged here, weighted by their standard errors, is a
    // second: the unweighted fundamental (the paper's cost) can be led far
    // astray by points near a recording's resolution, and a start with a
    // parameter at its bound (N at the Jenkins limit) is held there by the
    // refit
    let weighted = crate::fit::FitOptions {
        harmonics: harmonics.clone(),
        weighting: Weighting::StandardError,
        bootstrap: 0,
        second_optimiser: false,
        band_hz: options.band_hz.or(options.fit.band_hz),
        ..options.fit.clone()
    };
    // both are guards against a baseline gone astray: where the refit
    // already explains the data to within twice the noise, neither could
    // lower χ² by much, and they are not computed (they cost as much as
    // the refit itself)
    let astray = far_from_noise(base.chi2, expected);
    // the weighted identification and the lower levels' (below) are
    // independent: side by side, each on its own thread
    let (again, lower_fit) = rayon::join(
        || {
            if !astray
                || weighted.harmonics == options.fit.harmonics
                    && weighted.weighting == options.fit.weighting
            {
                return None;
            }
            let f = crate::fit::identify(frf, &weighted, predictor, None).ok()?;
            if f.response_sign != fit.response_sign {
                return None;
            }
            refit(&f.model, &data, predictor, None, options.patience).ok()
        },
        || {
            if astray {
                lower_levels_fit(frf, &weighted, predictor)
            } else {
                None
            }
        },
    );
    if let Some(b) = again
        && b.chi2 < base.chi2
    {
        base = b;
    }
    // the joint as the lower levels see it: a strong stiffening or softening
    // at the top levels can drag a joint-only fit of every level into
    // another basin (N at its bound, kd tenfold), and an effect refitted
    // from there keeps that basin; where the two joints disagree, every
    // candidate of the first round is also started from this one
    let lower = lower_fit
        .and_then(|(lower, f)| {
            lower_levels_joint(
                &lower,
                &f,
                &weighted,
                predictor,
                &base.model,
                fit.response_sign,
            )
        })
        .and_then(|m| {
            let pred = predictor.predict_from(&m, &data, None).ok()?;
            let chi2 = crate::fit::problem::chi_square(&data, &pred);
            chi2.is_finite().then_some(Refit {
                model: m,
                pred,
                chi2,
            })
        });
    let baseline = model_fit(&base.model, &data, &base.pred, base.chi2);
    observer(DiagnoseEvent::Baseline {
        chi2_per_dof: baseline.chi2_per_dof,
    });
    let base_features = features(&data, &base.pred);
    let mut current = Refit {
        model: base.model.clone(),
        pred: base.pred.clone(),
        chi2: base.chi2,
    };
    let identified = candidates::Identified::default();
    let trials = Trials::new(frf, &data, options, predictor, &identified);
    let mut remaining = options.candidates.clone();
    let mut reports = Vec::new();
    let mut chosen: Vec<Effect> = Vec::new();
    let mut seen = BestBySet::default();
    seen.note(&chosen, &current);
    // the intervals at `current`, once a round has computed them
    let mut current_intervals: Option<Intervals> = None;
    let mut failed: Vec<FailedCandidate> = Vec::new();
    let mut round = 0;
    while round < options.max_effects
        && remaining
            .iter()
            .any(|e| e.candidate().applies_to(&current.model))
        && (round == 0 || normalised(current.chi2) > noise_band)
    {
        round += 1;
        let feats = features(&data, &current.pred);
        // a candidate the model cannot take (a joint law it already has) is
        // neither tried nor counted among the K compared
        let far = far_from_noise(current.chi2, expected);
        let applicable: Vec<Effect> = remaining
            .iter()
            .copied()
            .filter(|e| e.candidate().applies_to(&current.model))
            .filter(|e| far || !e.candidate().only_far_from_noise())
            .collect();
        let ranked = rank(&feats, &applicable);
        observer(DiagnoseEvent::Round {
            round,
            candidates: ranked.len(),
        });
        // the largest candidates (most parameters, most starts) are started
        // first, in that order, so that no thread is left with one of them
        // at the end; the results are taken back in rank order
        let mut by_size: Vec<(usize, Effect)> = ranked
            .iter()
            .enumerate()
            .map(|(i, &(effect, _))| (i, effect))
            .collect();
        by_size.sort_by_key(|&(i, e)| (std::cmp::Reverse(e.candidate().size()), i));
        // the identifications afresh the candidates' starts read, made
        // first with every thread (see `Candidate::identifications`)
        let mut currents = vec![&current];
        if round == 1
            && let Some(low) = &lower
        {
            currents.push(low);
        }
        let effects: Vec<Effect> = ranked.iter().map(|&(e, _)| e).collect();
        trials.identify_beforehand(&effects, &currents);
        let slots: Vec<std::sync::Mutex<Option<Result<Option<Refit>>>>> =
            ranked.iter().map(|_| Default::default()).collect();
        rayon::scope_fifo(|s| {
            for &(i, effect) in &by_size {
                let (slots, currents, trials) = (&slots, &currents, &trials);
                s.spawn_fifo(move |_| {
                    if cancelled() {
                        *slots[i].lock().unwrap_or_else(|e| e.into_inner()) =
                            Some(Err(Error::Cancelled));
                        return;
                    }
                    let r = try_candidate(effect, currents, trials);
                    observer(DiagnoseEvent::Candidate {
                        round,
                        effect: EffectName(effect.name()),
                    });
                    *slots[i].lock().unwrap_or_else(|e| e.into_inner()) = Some(r);
                });
            }
        });
        if cancelled() {
            return Err(Error::Cancelled);
        }
        let tried = ranked
            .iter()
            .zip(slots)
            .enumerate()
            .map(|(i, (&(effect, _), slot))| {
                let r = slot
                    .into_inner()
                    .unwrap_or_else(|e| e.into_inner())
                    .expect("every candidate was tried");
                (effect, i + 1, r)
            });
        let mut round_results = Vec::new();
        for (effect, rank_pos, t) in tried {
            let r = match t {
                Ok(Some(r)) => r,
                Ok(None) => {
                    let why = effect.candidate().not_applicable_to(frf.reference);
                    failed.push(FailedCandidate {
                        effect,
                        round,
                        reason: why.map_or_else(
                            || "no starting point: the residual offered none".into(),
                            |w| format!("not applicable: {w}"),
                        ),
                        not_applicable: why.is_some(),
                    });
                    continue;
                }
                Err(e) => {
                    // one candidate's failure is a finding, not the end of the
                    // diagnosis
                    failed.push(FailedCandidate {
                        effect,
                        round,
                        reason: e.to_string(),
                        not_applicable: false,
                    });
                    continue;
                }
            };
            let delta = current.chi2 - r.chi2;
            let reduced = normalised(r.chi2).max(1.0);
            // the best of K candidates is judged, not one chosen beforehand:
            // 2 ln K more (a Bonferroni share of the same criterion) keeps
            // the chance that noise alone passes one of them near what it is
            // for one (on the independent corpus's controls, ln n alone let
            // a contact of 1e-3 of the stiffness through)
            let added = effect.candidate().added_parameters(&current.model);
            let threshold =
                (added as f64 * n_real.ln() + 2.0 * (ranked.len() as f64).ln()) * reduced;
            let criterion = delta - threshold;
            let report = CandidateReport {
                effect,
                round,
                rank: rank_pos,
                fit: model_fit(&r.model, &data, &r.pred, r.chi2),
                effect_parameters: effect.candidate().parameters(&r.model, &data),
                delta_chi2: delta,
                parameters_added: added,
                threshold,
                criterion,
                accepted: false,
                verdict: if criterion > 0.0 {
                    Verdict::AnotherDidBetter
                } else {
                    Verdict::BelowCriterion
                },
                note: None,
            };
            round_results.push((report, r));
        }
        // the best penalised improvement (an effect with more parameters must
        // earn them) whose own parameters the data resolve (a χ² drop bought
        // by a size whose interval straddles zero is the noise being fitted).
        // A cross-validation on every other frequency was tried here and
        // dropped: refitted on half the points, a true effect's size is
        // poorly determined, and a clearance's jump lands on another branch,
        // so it rejected true effects of the independent corpus (a quadratic
        // damping, a clearance) and caught no false one the resolution test
        // missed
        let mut order: Vec<usize> = (0..round_results.len())
            .filter(|&j| round_results[j].0.criterion > 0.0)
            .collect();
        order.sort_by(|&a, &b| {
            round_results[b]
                .0
                .criterion
                .total_cmp(&round_results[a].0.criterion)
        });
        let mut best: Option<(usize, Intervals)> = None;
        for j in order {
            let (rep, r) = &mut round_results[j];
            observer(DiagnoseEvent::Checking {
                effect: EffectName(rep.effect.name()),
            });
            let why = match Intervals::at(r, &data, predictor) {
                Ok(intervals) => match unresolved_in(rep.effect, r, &intervals, &data) {
                    None => {
                        best = Some((j, intervals));
                        break;
                    }
                    Some(why) => why,
                },
                Err(e) => format!("its intervals could not be computed: {e}"),
            };
            rep.note = Some(why);
            rep.verdict = Verdict::SizeNotResolved;
        }
        let Some((i, intervals)) = best else {
            reports.extend(round_results.into_iter().map(|(r, _)| r));
            break;
        };
        let added_now = round_results[i].0.effect;
        // the model before this round's addition, restored if the addition
        // does not hold (see `drop_cascade`)
        let before = (chosen.clone(), current.clone(), current_intervals.take());
        for (j, (mut rep, r)) in round_results.into_iter().enumerate() {
            if j == i {
                rep.accepted = true;
                rep.verdict = Verdict::Kept;
                chosen.push(rep.effect);
                remaining.retain(|e| *e != rep.effect);
                seen.note(&chosen, &r);
                current = r;
            }
            reports.push(rep);
        }
        // an effect kept earlier may have lost its reason to be there once
        // this one came in (a quadratic damping that stood in for a mode):
        // drop it, refit, and look again. The intervals are the model's,
        // computed once for every effect it holds (the kept candidate's
        // from its check above)
        let cascade = drop_cascade(
            (current, Ok(intervals)),
            &chosen,
            added_now,
            |e, (model, at): &(Refit, Result<Intervals>)| match at {
                Ok(i) => unresolved_in(e, model, i, &data),
                Err(_) => Some("its intervals could not be computed".into()),
            },
            |gone, (model, _), left| {
                let without = gone.candidate().remove(&model.model)?;
                let r = refit(&without, &data, predictor, None, options.patience).ok()?;
                let model = seen.better(left, r);
                let at = Intervals::at(&model, &data, predictor);
                Some((model, at))
            },
        );
        match cascade {
            Cascade::Settled {
                state: (model, at),
                chosen: left,
                dropped,
            } => {
                current = model;
                chosen = left;
                current_intervals = at.ok();
                for (gone, why) in dropped {
                    mark_dropped(&mut reports, gone, Verdict::DroppedLater, |kept_in| {
                        format!(
                            "kept in round {kept_in}, dropped in round {round}: once {} was added, {why}",
                            added_now.name()
                        )
                    });
                }
            }
            Cascade::Reverted { displaced, why } => {
                (chosen, current, current_intervals) = before;
                let displaced: Vec<&str> = displaced.iter().map(|e| e.name()).collect();
                let once = if displaced.is_empty() {
                    String::new()
                } else {
                    format!("once {} had gone beside it, ", displaced.join(" and "))
                };
                mark_dropped(&mut reports, added_now, Verdict::DroppedLater, |kept_in| {
                    format!(
                        "kept in round {kept_in}, dropped in round {round}: {once}{why}; the model before it was kept"
                    )
                });
            }
        }
    }
    let baseline_astray = gone_astray(
        &data,
        &base.model,
        &base.pred,
        fit.linear.stick.relative_rms_residual,
    );
    conclude(Conclusion {
        baseline_astray,
        harmonics,
        band_hz: options.band_hz,
        baseline,
        base_features,
        reports,
        failed,
        chosen,
        current,
        data: &data,
        predictor,
        baseline_model: base.model,
        response_sign: fit.response_sign,
        expected,
        intervals: current_intervals,
    })
}

/// What a diagnosis concludes from: its rounds' outcome and the model they
/// ended with.
struct Conclusion<'a> {
    harmonics: Vec<usize>,
    band_hz: Option<(f64, f64)>,
    baseline: ModelFit,
    base_features: ResidualFeatures,
    reports: Vec<CandidateReport>,
    failed: Vec<FailedCandidate>,
    chosen: Vec<Effect>,
    current: Refit,
    data: &'a FitData,
    predictor: &'a HbPredictor,
    baseline_model: Model,
    response_sign: f64,
    /// The `χ²` noise alone gives.
    expected: f64,
    /// The intervals at `current`, where the rounds computed them.
    intervals: Option<Intervals>,
    /// Whether the baseline went astray.
    baseline_astray: Option<crate::fit::identify::Astray>,
}

/// Whether `model` (predicting `pred`) went astray from the data's anchor
/// (see [`crate::fit::identify::Astray`]); `stick_residual` is the smallest
/// level's linear fit's RMS relative residual.
fn gone_astray(
    data: &FitData,
    model: &Model,
    pred: &Prediction,
    stick_residual: f64,
) -> Option<crate::fit::identify::Astray> {
    use crate::fit::identify::{LOWEST_LEVEL_MARGIN, LOWEST_LEVEL_SLACK, lowest_level_residual};
    let anchor = data.anchor?;
    let parameters = anchor.astray_in(model);
    let smallest_level_residual = lowest_level_residual(data, pred)
        .filter(|r| *r > LOWEST_LEVEL_SLACK * stick_residual + LOWEST_LEVEL_MARGIN)
        .map(|r| [r, stick_residual]);
    (!parameters.is_empty() || smallest_level_residual.is_some()).then(|| {
        crate::fit::identify::Astray {
            parameters,
            anchor: anchor.describe(),
            smallest_level_residual,
        }
    })
}

/// The diagnosis: the kept effects' intervals at the final model, its fit
/// and the account in words.
fn conclude(c: Conclusion<'_>) -> Result<Diagnosis> {
    let Conclusion {
        harmonics,
        band_hz,
        baseline,
        base_features,
        reports,
        failed,
        chosen,
        current,
        data,
        predictor,
        baseline_model,
        response_sign,
        expected,
        intervals,
        baseline_astray,
    } = c;
    let normalised = |chi2: f64| chi2 / expected.max(f64::MIN_POSITIVE);
    // intervals of the effects kept, at the final model
    let mut selected = Vec::new();
    if !chosen.is_empty() {
        let Intervals { params, conf } = match intervals {
            Some(i) => i,
            None => Intervals::at(&current, data, predictor)?,
        };
        let mut pairs: Vec<(crate::fit::params::Parameter, Estimate)> =
            params.parameters.into_iter().zip(conf.estimates).collect();
        // a mode above the band was fitted by its flexibility; its modal
        // mass is reported too, with the interval the data give it (wide
        // where only the flexibility is seen)
        if pairs
            .iter()
            .any(|(p, _)| matches!(p.target, crate::fit::params::Target::Flexibility { .. }))
        {
            let plain = model_parameters(&current.model, None);
            if let Ok(c) = confidence_at(&current.model, &plain, &current.pred, data, predictor) {
                pairs.extend(
                    plain
                        .parameters
                        .into_iter()
                        .zip(c.estimates)
                        .filter(|(p, _)| {
                            matches!(p.target, crate::fit::params::Target::Residue { .. })
                        }),
                );
            }
        }
        for &effect in &chosen {
            let mut parameters = BTreeMap::new();
            for (p, e) in &pairs {
                if let Some(rest) =
                    effect
                        .candidate()
                        .own_parameter(effect.name(), &current.model, &p.name)
                {
                    let (name, e) = effect.candidate().reported(rest, e.clone());
                    parameters.insert(name, e);
                }
            }
            selected.push(SelectedEffect { effect, parameters });
        }
    }
    let final_fit = model_fit(&current.model, data, &current.pred, current.chi2);
    let final_features = features(data, &current.pred);
    let consistent = final_fit.chi2_per_dof < 2.0 && normalised(current.chi2) < 2.0;
    let mut explanation = explain(
        &baseline,
        &base_features,
        &reports,
        &selected,
        &final_fit,
        consistent,
    );
    // where the residual stays above the noise, the candidates left out
    // are the user's next step
    let untried: Vec<&str> = Effect::ALL
        .iter()
        .filter(|e| !e.by_default())
        .filter(|e| {
            !reports.iter().any(|r| r.effect == **e) && !failed.iter().any(|f| f.effect == **e)
        })
        .map(|e| e.name())
        .collect();
    if !consistent && !untried.is_empty() {
        explanation.push_str(&format!(
            " Not tried, as they are tried only when named: {} (`--candidates default,{}`).",
            untried.join(", "),
            untried[0]
        ));
    }
    if let Some(a) = &baseline_astray {
        explanation.push_str(&format!(
            " The baseline went astray ({}): what was added to it is not trusted.",
            a.describe()
        ));
    }
    Ok(Diagnosis {
        baseline_astray,
        harmonics,
        band_hz,
        baseline,
        features: base_features,
        candidates: reports,
        failed,
        selected,
        final_fit,
        final_features,
        consistent_with_noise: consistent,
        explanation,
        baseline_model,
        model: current.model,
        response_sign,
    })
}

/// `d` with `effect` taken out of its final model: the rest refitted on the
/// same FRFs, the effect's report marked [`Verdict::NotConfirmedInTime`]
/// with `why`, the intervals, fit and account of the smaller model. For an
/// effect the time domain does not confirm: the FRFs start every dwell from
/// a virgin joint, so where a joint settles under a static load (which
/// depends on the loads before) is a residual that an extra effect can
/// absorb there and that a replay of the whole recording does not leave.
pub fn without_effect(
    d: &Diagnosis,
    frf: &NonlinearFrf,
    effect: Effect,
    why: String,
    patience: usize,
    predictor: &HbPredictor,
) -> Result<Diagnosis> {
    let without = effect
        .candidate()
        .remove(&d.model)
        .ok_or_else(|| Error::plan("effect", format!("{} is not in the model", effect.name())))?;
    let data = FitData::from_frf(frf, &d.harmonics, d.band_hz, None)?.with_sign(d.response_sign);
    let current = refit(&without, &data, predictor, None, patience)?;
    let mut reports = d.candidates.clone();
    mark_dropped(&mut reports, effect, Verdict::NotConfirmedInTime, |_| why);
    let chosen = d
        .selected
        .iter()
        .map(|s| s.effect)
        .filter(|&e| e != effect)
        .collect();
    reconcluded(d, reports, chosen, current, &data, predictor)
}

/// `d` concluded again with `reports`, the effects `chosen` and the final
/// refit `current` on `data` (its baseline and features as they were).
fn reconcluded(
    d: &Diagnosis,
    reports: Vec<CandidateReport>,
    chosen: Vec<Effect>,
    current: Refit,
    data: &FitData,
    predictor: &HbPredictor,
) -> Result<Diagnosis> {
    conclude(Conclusion {
        harmonics: d.harmonics.clone(),
        band_hz: d.band_hz,
        baseline: d.baseline.clone(),
        base_features: d.features.clone(),
        reports,
        failed: d.failed.clone(),
        chosen,
        current,
        data,
        predictor,
        baseline_model: d.baseline_model.clone(),
        response_sign: d.response_sign,
        expected: crate::fit::problem::expected_chi_square(data),
        intervals: None,
        baseline_astray: d.baseline_astray.clone(),
    })
}

/// The final model of `d` with `effect` added, refitted on the same FRFs as
/// the diagnosis refits a candidate (its starts from the residual, the best
/// refit kept): a start for putting the effect to the recorded time
/// histories. `None` where the candidate finds no start in the residual.
pub fn candidate_on_final(
    d: &Diagnosis,
    frf: &NonlinearFrf,
    effect: Effect,
    options: &DiagnoseOptions,
    predictor: &HbPredictor,
) -> Result<Option<Model>> {
    candidates_on_final(d, frf, &[effect], options, predictor)?
        .pop()
        .unwrap_or(Ok(None))
}

/// [`candidate_on_final`] for each of `effects` (in parallel, each result in
/// its effect's place): the final model refitted once, every candidate
/// started from it.
pub fn candidates_on_final(
    d: &Diagnosis,
    frf: &NonlinearFrf,
    effects: &[Effect],
    options: &DiagnoseOptions,
    predictor: &HbPredictor,
) -> Result<Vec<Result<Option<Model>>>> {
    use rayon::prelude::*;
    let data = FitData::from_frf(frf, &d.harmonics, d.band_hz, None)?
        .with_sign(d.response_sign)
        .with_transfer(options.fit.transfer || d.response_sign < 0.0);
    let current = refit(&d.model, &data, predictor, None, options.patience)?;
    let identified = candidates::Identified::default();
    let trials = Trials::new(frf, &data, options, predictor, &identified);
    trials.identify_beforehand(effects, &[&current]);
    Ok(effects
        .par_iter()
        .map(|&effect| try_candidate(effect, &[&current], &trials).map(|r| r.map(|r| r.model)))
        .collect())
}

/// `d` with `effect` added to its final model, for an effect the FRFs did
/// not keep that the recorded time histories need: `model` (the final model
/// with the effect, refitted in time) is the final model, judged on the same
/// FRFs as it stands (refitted there it would go back to where the FRFs
/// left the effect unresolved), the effect's latest report marked
/// [`Verdict::KeptInTime`] with `why`, the intervals, fit and account of the
/// larger model. The FRFs start every
/// dwell from a virgin joint and a steady state; a replay of the whole
/// recording carries what they leave out (the joint's load history, a
/// sweep's transients), so an effect they cannot resolve may be plain in
/// the time domain.
pub fn with_effect(
    d: &Diagnosis,
    frf: &NonlinearFrf,
    effect: Effect,
    model: &Model,
    why: String,
    predictor: &HbPredictor,
) -> Result<Diagnosis> {
    let data = FitData::from_frf(frf, &d.harmonics, d.band_hz, None)?.with_sign(d.response_sign);
    // no Levenberg-Marquardt run (no budget): the model's own prediction and χ²
    let current = refit_within(model, &data, predictor, None, 0, 0, None)?;
    let mut reports = d.candidates.clone();
    if let Some(rep) = reports.iter_mut().rev().find(|r| r.effect == effect) {
        rep.accepted = true;
        rep.verdict = Verdict::KeptInTime;
        rep.note = Some(why);
    }
    let mut chosen: Vec<Effect> = d.selected.iter().map(|s| s.effect).collect();
    chosen.push(effect);
    reconcluded(d, reports, chosen, current, &data, predictor)
}

/// How the drop cascade after an addition ended.
#[derive(Debug, PartialEq)]
enum Cascade<S> {
    /// Every effect left is resolved: the model (`state`), its effects, and
    /// those dropped on the way with why.
    Settled {
        state: S,
        chosen: Vec<Effect>,
        dropped: Vec<(Effect, String)>,
    },
    /// The addition itself lost its resolution once the effects it
    /// displaced had gone: it does not hold, and the model before it stands.
    Reverted { displaced: Vec<Effect>, why: String },
}

/// After `added` came in (`chosen` holds it, `state` is the model with it):
/// an effect kept earlier may have lost its reason to be there (a quadratic
/// damping that stood in for a mode). Drops, one at a time, the first of
/// `chosen` that `unresolved` names, refitted without it by `without`
/// (given the effects left; `None`: it cannot be removed or refitted, and
/// the cascade stops there), until every effect left is resolved.
///
/// If that would drop `added` itself, the round is undone instead: the
/// effects it displaced were resolved without it, and it is not resolved
/// without them, so the model of the round before is the one whose every
/// effect the data resolve (a second mode that displaced a cubic stiffness
/// and then lost its own resolution ended, before this rule, with neither,
/// below both the round before and the round it was added in).
fn drop_cascade<S>(
    mut state: S,
    chosen: &[Effect],
    added: Effect,
    unresolved: impl Fn(Effect, &S) -> Option<String>,
    mut without: impl FnMut(Effect, &S, &[Effect]) -> Option<S>,
) -> Cascade<S> {
    let mut chosen = chosen.to_vec();
    let mut dropped: Vec<(Effect, String)> = Vec::new();
    while let Some((gone, why)) = chosen
        .iter()
        .find_map(|&e| unresolved(e, &state).map(|why| (e, why)))
    {
        if gone == added {
            return Cascade::Reverted {
                displaced: dropped.into_iter().map(|(e, _)| e).collect(),
                why,
            };
        }
        let left: Vec<Effect> = chosen.iter().copied().filter(|&e| e != gone).collect();
        let Some(next) = without(gone, &state, &left) else {
            break;
        };
        state = next;
        chosen = left;
        dropped.push((gone, why));
    }
    Cascade::Settled {
        state,
        chosen,
        dropped,
    }
}

/// Turns the latest accepted report of `effect` into a dropped one: the
/// verdict says why it went, the note (given the round it was kept in) the
/// figures.
fn mark_dropped(
    reports: &mut [CandidateReport],
    effect: Effect,
    verdict: Verdict,
    note: impl FnOnce(usize) -> String,
) {
    if let Some(rep) = reports
        .iter_mut()
        .rev()
        .find(|r| r.effect == effect && r.accepted)
    {
        rep.accepted = false;
        rep.verdict = verdict;
        rep.note = Some(note(rep.round));
    }
}

pub(crate) fn fmt_value(v: f64) -> String {
    if v.abs() >= 1e4 || v.abs() < 1e-2 {
        format!("{v:.4e}")
    } else {
        format!("{v:.4}")
    }
}

/// A few sentences of plain explanation.
fn explain(
    baseline: &ModelFit,
    f: &ResidualFeatures,
    reports: &[CandidateReport],
    selected: &[SelectedEffect],
    final_fit: &ModelFit,
    consistent: bool,
) -> String {
    let mut s = String::new();
    s.push_str(&format!(
        "The baseline (the fitted joint law, refitted with the measured standard errors on the harmonics judged) left a residual of {:.2} % in H1 (χ²/dof = {:.2}). ",
        100.0 * baseline.error_relative,
        baseline.chi2_per_dof
    ));
    let mut dropped = String::new();
    for r in reports
        .iter()
        .filter(|r| r.verdict == Verdict::NotConfirmedInTime)
    {
        dropped.push_str(&format!(
            "The candidate {} was kept on the FRFs but not confirmed in the time domain ({}), \
             so it was dropped and the rest refitted. ",
            r.effect.name(),
            r.note.as_deref().unwrap_or("no reason recorded")
        ));
    }
    for r in reports.iter().filter(|r| r.verdict == Verdict::KeptInTime) {
        dropped.push_str(&format!(
            "The candidate {} was not kept on the FRFs, but the recorded time histories \
             need it ({}), so it was added. ",
            r.effect.name(),
            r.note.as_deref().unwrap_or("no reason recorded")
        ));
    }
    if selected.is_empty() && !dropped.is_empty() {
        s.push_str(&dropped);
        s.push_str("No missing effect is confirmed.");
        return s;
    }
    s.push_str(&dropped);
    if selected.is_empty() {
        let best = reports
            .iter()
            .max_by(|a, b| a.criterion.total_cmp(&b.criterion));
        match best {
            Some(b) if b.note.is_some() => s.push_str(&format!(
                "No significant missing effect: the candidate that did best against the information criterion, {}, {}.",
                b.effect.name(),
                b.note.as_deref().unwrap_or_default()
            )),
            Some(b) => s.push_str(&format!(
                "No significant missing effect: the candidate that came closest to the information criterion, {}, lowered χ² by {:.1}, short of the {:.1} it asks for {} parameter(s).",
                b.effect.name(),
                b.delta_chi2,
                b.threshold,
                b.parameters_added
            )),
            None => s.push_str("No significant missing effect."),
        }
        return s;
    }
    for sel in selected {
        let why = sel.effect.candidate().explain(f, sel);
        let params: Vec<String> = sel
            .parameters
            .iter()
            .map(|(n, e)| {
                format!(
                    "{n} = {} [{}, {}]",
                    fmt_value(e.value),
                    fmt_value(e.ci95[0]),
                    fmt_value(e.ci95[1])
                )
            })
            .collect();
        s.push_str(&format!(
            "{}: {} added ({}). ",
            capitalise(&why),
            sel.effect.name(),
            params.join(", ")
        ));
    }
    // a harmonic the baseline leaves at the noise (χ²/dof < 2) with an
    // error of half the harmonic or more is itself no more than noise: its
    // "100 % → 100 %" says nothing of the model, so it is left out
    let at_noise = |h: usize| {
        f.chi2_per_dof_by_harmonic.get(&h).is_some_and(|c| *c < 2.0)
            && baseline
                .error_relative_per_harmonic
                .get(&h)
                .is_some_and(|e| *e >= 0.5)
    };
    let shown = |fit: &ModelFit| -> Vec<String> {
        fit.error_relative_per_harmonic
            .iter()
            .filter(|(h, _)| **h != 1 && !at_noise(**h))
            .map(|(h, e)| format!("H{h} {:.1} %", 100.0 * e))
            .collect()
    };
    let (even_before, even_after) = (shown(baseline), shown(final_fit));
    let others = if even_before.is_empty() && even_after.is_empty() {
        String::new()
    } else {
        format!(" ({} → {})", even_before.join(", "), even_after.join(", "))
    };
    s.push_str(&format!(
        "Error {:.2} % → {:.2} % in H1{others}; χ²/dof {:.2} → {:.2}, {}.",
        100.0 * baseline.error_relative,
        100.0 * final_fit.error_relative,
        baseline.chi2_per_dof,
        final_fit.chi2_per_dof,
        if consistent {
            "consistent with the noise"
        } else {
            "still above the noise: something else may be missing"
        }
    ));
    s
}

fn capitalise(s: &str) -> String {
    let mut c = s.chars();
    match c.next() {
        Some(f) => f.to_uppercase().collect::<String>() + c.as_str(),
        None => String::new(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The summary's harmonics beside H1 leave out those at the noise (no
    /// "H2 100.0 % → H2 100.0 %" where there are no even harmonics), and
    /// keep those the model is judged on.
    #[test]
    fn the_summary_leaves_out_harmonics_at_the_noise() {
        let fit = |h2: f64, h3: f64| ModelFit {
            parameters: BTreeMap::new(),
            error_relative: 0.05,
            error_relative_per_harmonic: [(1, 0.05), (2, h2), (3, h3)].into(),
            chi2: 100.0,
            chi2_per_dof: 1.2,
        };
        let features = ResidualFeatures {
            chi2_per_dof_by_harmonic: [(1, 1.2), (2, 1.0), (3, 6.0)].into(),
            chi2_per_dof_by_level: Vec::new(),
            growth_with_level: 0.0,
            level_independent_share: 0.0,
            peak_shift_hz: Vec::new(),
            peak_ratio: Vec::new(),
            peak_shift_trend: 0.0,
            peak_ratio_trend: 0.0,
        };
        let added = [SelectedEffect {
            effect: Effect::CubicStiffness,
            parameters: BTreeMap::new(),
        }];
        let s = explain(&fit(1.0, 0.4), &features, &[], &added, &fit(1.0, 0.1), true);
        assert!(!s.contains("H2"), "{s}");
        assert!(s.contains("(H3 40.0 % → H3 10.0 %)"), "{s}");
        // every harmonic beside H1 at the noise: no empty parentheses
        let quiet = ResidualFeatures {
            chi2_per_dof_by_harmonic: [(1, 1.2), (2, 1.0), (3, 1.0)].into(),
            ..features
        };
        let s = explain(&fit(1.0, 0.9), &quiet, &[], &added, &fit(1.0, 0.9), true);
        assert!(s.contains("in H1; χ²/dof"), "{s}");
    }

    /// The drop cascade on a toy model (its state: the effects it holds,
    /// a refit without one always possible), `added` last in `chosen`.
    fn cascade_of(
        chosen: &[Effect],
        unresolved: impl Fn(Effect, &Vec<Effect>) -> Option<String>,
    ) -> Cascade<Vec<Effect>> {
        let added = *chosen.last().expect("an addition");
        drop_cascade(
            chosen.to_vec(),
            chosen,
            added,
            unresolved,
            |gone, state, left| {
                assert!(state.contains(&gone) && !left.contains(&gone));
                Some(left.to_vec())
            },
        )
    }

    /// A cubic stiffness kept in round 2 loses its resolution once a second
    /// mode comes in (round 3), and without it the mode loses its own: the
    /// round is undone (the model of round 2, with the cubic stiffness,
    /// stands) rather than the cascade ending with neither.
    #[test]
    fn an_addition_that_loses_its_resolution_without_what_it_displaced_is_undone() {
        use Effect::{CubicStiffness as Cubic, SecondMode as Mode, Shaker};
        let undone = cascade_of(&[Shaker, Cubic, Mode], |e, state| match e {
            Cubic if state.contains(&Mode) => Some("k3 straddles zero".into()),
            Mode if !state.contains(&Cubic) => Some("its flexibility straddles zero".into()),
            _ => None,
        });
        assert_eq!(
            undone,
            Cascade::Reverted {
                displaced: vec![Cubic],
                why: "its flexibility straddles zero".into()
            }
        );
        // the same, but the mode holds without the cubic stiffness: it
        // replaces it
        let replaced = cascade_of(&[Shaker, Cubic, Mode], |e, state| {
            (e == Cubic && state.contains(&Mode)).then(|| "k3 straddles zero".to_string())
        });
        assert_eq!(
            replaced,
            Cascade::Settled {
                state: vec![Shaker, Mode],
                chosen: vec![Shaker, Mode],
                dropped: vec![(Cubic, "k3 straddles zero".into())],
            }
        );
        // nothing unresolved: nothing dropped; a refit that fails stops the
        // cascade where it is
        let kept = cascade_of(&[Shaker, Cubic], |_, _| None);
        assert_eq!(
            kept,
            Cascade::Settled {
                state: vec![Shaker, Cubic],
                chosen: vec![Shaker, Cubic],
                dropped: vec![],
            }
        );
        let stuck = drop_cascade(
            vec![Shaker, Cubic, Mode],
            &[Shaker, Cubic, Mode],
            Mode,
            |e, _: &Vec<Effect>| (e == Cubic).then(|| "unresolved".to_string()),
            |_, _, _| None,
        );
        assert_eq!(
            stuck,
            Cascade::Settled {
                state: vec![Shaker, Cubic, Mode],
                chosen: vec![Shaker, Cubic, Mode],
                dropped: vec![],
            }
        );
    }

    fn refit(chi2: f64, mass: f64) -> Refit {
        Refit {
            model: Model {
                linear: crate::model::ModalModel::sdof(mass, 1.0, 1e4).unwrap(),
                joint: None,
                effects: Vec::new(),
            },
            pred: Prediction::default(),
            chi2,
        }
    }

    /// After a drop, the refit of a set of effects seen before in a better
    /// fit gives way to it (whatever the order the effects were kept in);
    /// a better one is kept, and another set is its own.
    #[test]
    fn a_drop_never_leaves_a_worse_fit_of_effects_seen_before() {
        let mut seen = BestBySet::default();
        let (shaker, cubic) = (Effect::Shaker, Effect::CubicStiffness);
        seen.note(&[shaker], &refit(1254.8, 1.0));
        seen.note(&[shaker, cubic], &refit(1115.9, 2.0));
        // round 3's cascade: cubic dropped, a cold refit of the shaker alone
        // settles higher than round 1's
        let r = seen.better(&[shaker], refit(3041.7, 3.0));
        assert_eq!((r.chi2, r.model.linear.modes[0].residue), (1254.8, 1.0));
        // one lower is kept, and is what the set gives from then on
        let r = seen.better(&[shaker], refit(1200.0, 4.0));
        assert_eq!(r.chi2, 1200.0);
        assert_eq!(seen.better(&[shaker], refit(1300.0, 5.0)).chi2, 1200.0);
        // the set, not the order
        assert_eq!(
            seen.better(&[cubic, shaker], refit(2000.0, 6.0)).chi2,
            1115.9
        );
        // a set not seen is the refit itself
        assert_eq!(seen.better(&[cubic], refit(5000.0, 7.0)).chi2, 5000.0);
    }
}
