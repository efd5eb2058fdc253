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
mod conclude;
pub mod features;
pub mod lines;
mod resolution;
mod starts;
pub mod time_residual;
mod trials;

pub use candidates::Effect;
pub use conclude::{candidate_on_final, candidates_on_final, with_effect, without_effect};
pub use features::{ResidualFeatures, features};
pub(crate) use starts::scan_start;

use conclude::{Cascade, Conclusion, conclude, drop_cascade, mark_dropped};
use resolution::{Intervals, confidence_at, largest_change, unresolved_in};
use starts::{lower_levels_fit, lower_levels_joint};
use trials::{Trials, rank, try_candidate};

use crate::error::{Error, Result};
use crate::extract::NonlinearFrf;
use crate::fit::optimise::{FitStatus, Race};
use crate::fit::{
    Estimate, FitData, FitProblem, FitResult, FrfPredictor, HbPredictor, ParameterSet, Prediction,
    Transform, Weighting,
};
use crate::harmonics::omega;
use crate::model::Model;
use crate::observe::{DiagnoseEvent, EffectName};
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
    /// The largest change the refit made to the predicted FRFs of the model
    /// it was tried on, at any measured point and harmonic judged, in
    /// measured standard errors of that point (see [`VISIBLE_CHANGE`]).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub largest_change: Option<f64>,
}

/// The least an added effect must change the model's predicted FRFs at
/// one measured point at least, in measured standard errors of that point,
/// to be kept (see [`CandidateReport::largest_change`]). Not scaled by the
/// reduced `χ²` as the information criterion is: a model far from the data
/// misses them most at a few points, and an effect that mends a part of
/// that is seen by its own points' noise, not by the misfit elsewhere.
pub const VISIBLE_CHANGE: f64 = 3.0;

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
    /// Passed the information criterion, but moved no measured point by
    /// [`VISIBLE_CHANGE`] of its standard error: a χ² drop pooled from
    /// changes each within the noise.
    NotSeenAtAnyPoint,
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
    /// Dwells left out of the harmonic-balance fits for their subharmonic
    /// response (see [`crate::extract::subharmonic`]).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub subharmonic_dwells: Vec<crate::fit::SubharmonicPoint>,
    /// The final model's prediction at the points judged, as the diagnosis
    /// left it: a start that keeps a report's figures on the branch the
    /// diagnosis followed where a harmonic balance has more than one
    /// (absent when read back from JSON).
    #[serde(skip)]
    pub final_prediction: Option<Prediction>,
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

/// Diagnoses a fit (see the module docs), telling `observer` what it is
/// doing (called from worker threads while candidates are refitted in
/// parallel).
pub fn diagnose(
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
        .with_anchor(crate::fit::LinearAnchor::of(
            &fit.linear.stick,
            frf.reference,
        ));
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
                largest_change: Some(largest_change(&data, &current.pred, &r.pred)),
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
            if let Some(seen) = rep.largest_change.filter(|c| *c < VISIBLE_CHANGE) {
                rep.note = Some(format!(
                    "lowered χ² enough, but moves no measured point by more than {seen:.2} of its noise \
                     (at least {VISIBLE_CHANGE} asked): a drop pooled from changes each within the noise, \
                     as a model's own small inaccuracies give"
                ));
                rep.verdict = Verdict::NotSeenAtAnyPoint;
                continue;
            }
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
    let baseline_astray = data.astray(&base.model, &base.pred);
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
        drive: crate::model::units::force_drive(&fit.model, frf.reference),
    })
}

/// A parameter value as reports print it: four significant digits,
/// in exponent form when it is large or small.
pub fn fmt_value(v: f64) -> String {
    if v.abs() >= 1e4 || v.abs() < 1e-2 {
        format!("{v:.4e}")
    } else {
        format!("{v:.4}")
    }
}

#[cfg(test)]
mod tests;
