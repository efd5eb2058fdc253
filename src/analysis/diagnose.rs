//! A fit's residual traced to a missing effect, added and refitted
//! ([`crate::diagnose`]), and its files: `diagnosis.json`, `diagnosis.md`
//! and the residual figures.

pub use super::diagnosis_figures::{effects_label, residual_plots};

mod request;
pub use request::DiagnoseRequest;

use super::recording::ReplayReduction;
use super::write_json;
use crate::diagnose::time_residual::{
    TimeResidual, TracedCandidate, share_explained, time_residual,
};
use crate::diagnose::{DiagnoseOptions, Diagnosis, Effect, Verdict, diagnose};
use crate::error::Result;
use crate::extract::NonlinearFrf;
use crate::fit::time::{RecordError, TimeProblem, time_parameters};
use crate::fit::{
    FitData, FitResult, FrfPredictor, HbPredictor, TimeFitOptions, TimeFitResult, TimeRecord,
    identify_time,
};
use crate::observe::Observer;
use serde::Serialize;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

/// Diagnoses `fit` of `frf`, telling `observer` of the progress; returns the
/// diagnosis with the predictor it used (for the figures).
pub fn run_diagnosis(
    frf: &NonlinearFrf,
    fit: &FitResult,
    options: &DiagnoseOptions,
    observer: &dyn Observer,
) -> Result<(Diagnosis, HbPredictor)> {
    let predictor = HbPredictor::default();
    let d = diagnose(frf, fit, options, &predictor, observer)?;
    Ok((d, predictor))
}

/// The diagnosis's final model refined in the time domain on the
/// recordings themselves (`diagnose --domain time`).
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct TimeRefinement {
    /// The baseline model's error on each recording (the joint alone, as
    /// the FRF fit left it).
    pub baseline: Vec<RecordError>,
    /// The final model refitted in the time domain (`before`: the FRF
    /// diagnosis's final model).
    pub refit: TimeFitResult,
    /// How every model was replayed on the recordings (`--replay`).
    pub replay: crate::validate::DriveInput,
    /// Each effect the FRF diagnosis kept, taken out and the rest refitted
    /// in time: whether the recordings need it.
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub checks: Vec<EffectCheck>,
    /// The refitted model's residual in the FRFs' plane (the measured
    /// response and the model's replay reduced alike), with the candidates
    /// traced in it when some are put to the time histories
    /// ([`crate::diagnose::time_residual`]); `None` where the recordings
    /// were not given for it, or it failed (see `residual_failed`).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub residual: Option<TimeResidual>,
    /// Why the time residual could not be reduced or traced.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub residual_failed: Option<String>,
    /// The candidates put to the time histories, each added to the final
    /// model and refitted in time: whether the recordings need it. Those
    /// that explain the most of the time residual (`residual.traced`), else
    /// those the FRF diagnosis came closest to keeping.
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub proposals: Vec<TimeProposal>,
}

/// One candidate the FRFs did not keep, put to the time domain: the final
/// model with it, refitted on the recordings.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct TimeProposal {
    /// The effect.
    pub effect: Effect,
    /// Each recording's error with the final model plus the effect,
    /// refitted (empty when there was no start or the refit failed).
    pub with: Vec<RecordError>,
    /// How much lower the misfit is with it: the final model's misfit over
    /// this one's, minus 1 (the confirmation's `rise` seen from the other
    /// side).
    pub gain: f64,
    /// Whether it was added (`gain > CONFIRMATION_RISE`, the best such).
    pub kept: bool,
    /// Why it could not be tried, when it could not.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub failed: Option<String>,
}

/// One kept effect put to the time domain: the model without it refitted on
/// the recordings.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct EffectCheck {
    /// The effect.
    pub effect: Effect,
    /// Each recording's error with the model without it, refitted (only
    /// replayed where that already rose by no more than the threshold: a
    /// refit could only lower it; empty when the refit failed).
    pub without: Vec<RecordError>,
    /// How much the misfit rises without it: the dwells' relative e_RMS,
    /// root mean square over the recordings, without over with, minus 1.
    pub rise: f64,
    /// Whether the recordings need it (`rise > CONFIRMATION_RISE`, or the
    /// refit without it failed).
    pub confirmed: bool,
    /// Why the refit without it failed, when it did.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub failed: Option<String>,
}

/// What `diagnose --domain time` got: the refinement, or why there is
/// none (the FRF diagnosis stands either way).
#[derive(Clone, Debug, PartialEq, Serialize)]
#[serde(untagged)]
pub enum TimeOutcome {
    /// The final model refitted.
    Refined(Box<TimeRefinement>),
    /// The recordings could not be replayed or the refit failed.
    Failed {
        /// Why.
        failed: String,
    },
}

/// The rise of the time-domain misfit below which an effect is not
/// confirmed: 2.5 times the 0.2 % by which the replay's own discretisation
/// may move the misfit (see `TimeProblem::choose_replay_rates`), so that an
/// effect is kept for what the recordings show, not for the simulator's
/// step.
pub const CONFIRMATION_RISE: f64 = 0.005;

/// Levenberg–Marquardt's patience for a proposal's time refit: enough to
/// tell a misfit that falls by more than [`CONFIRMATION_RISE`] from one
/// that does not, from a start next to the refined model; the one added is
/// then refitted with the full budget.
pub(crate) const PROPOSAL_PATIENCE: usize = 6;

/// Levenberg–Marquardt's patience for a refit without one effect: it starts
/// next to its optimum (the full refit's values), so a shorter budget than
/// the full refit's finds it.
const CHECK_PATIENCE: usize = 12;

/// The misfit a confirmation compares: each recording's dwell-weighted
/// relative e_RMS, root mean square over the recordings.
pub fn misfit(errors: &[RecordError]) -> f64 {
    let n = errors.len().max(1) as f64;
    (errors
        .iter()
        .map(|e| e.segment_relative.powi(2))
        .sum::<f64>()
        / n)
        .sqrt()
}

/// Refines `d`'s final model in the time domain on `records`: every
/// parameter free (the linear part's as the diagnosis saw `band_hz`),
/// started from the diagnosis. What the replay adds is the history the
/// harmonic balance does not carry (where a joint settles under a static
/// load) and no steady-state assumption.
///
/// Then each effect the FRF diagnosis kept is confirmed: taken out, the rest
/// refitted in time. An FRF residual the history explains can make the FRF
/// diagnosis keep an effect that stands in for it (a broad mode beside a
/// bilinear stiffness); where the misfit without an effect rises by no more
/// than [`CONFIRMATION_RISE`], the effect is dropped from `d` (its FRF model
/// refitted without it, see [`crate::diagnose::without_effect`]), the least
/// needed first, and the rest are checked again. Where a plain replay
/// without the effect already stays within the threshold, no refit is run
/// (a refit could only lower the misfit). `patience` is the FRF refit's;
/// `options.starts` the first refit's starts (every later one starts from
/// a fitted model).
#[allow(clippy::too_many_arguments)]
pub fn refine_in_time(
    d: &mut Diagnosis,
    frf: &NonlinearFrf,
    records: &[TimeRecord],
    options: &TimeFitOptions,
    band_hz: Option<(f64, f64)>,
    diagnose_options: &DiagnoseOptions,
    predictor: &HbPredictor,
    replays: Option<&ReplayReduction>,
    observer: &dyn Observer,
) -> Result<TimeRefinement> {
    let patience = diagnose_options.patience;
    // the recordings alone are refitted from the final refit only
    let each_alone = options.each_alone && records.len() > 1;
    let options = &TimeFitOptions {
        each_alone: false,
        ..options.clone()
    };
    let params = time_parameters(&d.model, options.refine_linear, band_hz);
    let mut refit = identify_time(
        &d.model,
        params.clone(),
        d.response_sign,
        records,
        options,
        Some(observer),
    )?;
    // the first refit descends from `options.starts` starts; every later
    // one starts next to a fitted model, from one
    let options = &TimeFitOptions {
        starts: 1,
        ..options.clone()
    };
    let sign = d.response_sign;
    let replay = |model: &crate::model::Model| -> Result<Vec<RecordError>> {
        TimeProblem::new(
            model.clone(),
            params.clone(),
            records,
            sign,
            options.clone(),
            None,
        )?
        .errors(model)
    };
    let baseline = replay(&d.baseline_model)?;
    let mut checks: Vec<EffectCheck> = Vec::new();
    let check_options = TimeFitOptions {
        patience: options.patience.min(CHECK_PATIENCE),
        ..options.clone()
    };
    while !d.selected.is_empty() {
        let with = misfit(&refit.after);
        // the same model replayed as a plain replay of a model without an
        // effect is (at the sure rate), for the shortcut below
        let with_sure = replay(&refit.model).map(|e| misfit(&e)).ok();
        // each check, and the model a dropped effect's final refit starts from
        let mut round: Vec<(EffectCheck, Option<crate::model::Model>)> = Vec::new();
        for effect in d.selected.iter().map(|s| s.effect) {
            let Some(without) = effect.candidate().remove(&refit.model) else {
                continue;
            };
            // a refit can only lower the misfit without it: where the plain
            // replay already rises by no more than the threshold, no refit
            // is needed to know
            if let (Some(w), Ok(e)) = (with_sure, replay(&without)) {
                let rise = misfit(&e) / w.max(f64::MIN_POSITIVE) - 1.0;
                if rise <= CONFIRMATION_RISE {
                    let check = EffectCheck {
                        effect,
                        without: e,
                        rise,
                        confirmed: false,
                        failed: None,
                    };
                    round.push((check, Some(without)));
                    continue;
                }
            }
            let p = time_parameters(&without, options.refine_linear, band_hz);
            match identify_time(&without, p, sign, records, &check_options, None) {
                Ok(r) => {
                    let rise = misfit(&r.after) / with.max(f64::MIN_POSITIVE) - 1.0;
                    let check = EffectCheck {
                        effect,
                        without: r.after,
                        rise,
                        confirmed: rise > CONFIRMATION_RISE,
                        failed: None,
                    };
                    round.push((check, Some(r.model)));
                }
                // a refit that fails is no evidence against the effect
                Err(e) => round.push((
                    EffectCheck {
                        effect,
                        without: Vec::new(),
                        rise: f64::NAN,
                        confirmed: true,
                        failed: Some(e.to_string()),
                    },
                    None,
                )),
            }
        }
        let least = round
            .iter()
            .enumerate()
            .filter(|(_, (c, m))| !c.confirmed && m.is_some())
            .min_by(|a, b| a.1.0.rise.total_cmp(&b.1.0.rise))
            .map(|(i, _)| i);
        let Some(i) = least else {
            checks.extend(round.into_iter().map(|(c, _)| c));
            break;
        };
        let (check, start) = round.swap_remove(i);
        let start = start.expect("only a check with a model is dropped");
        let why = format!(
            "without it, the misfit to the recorded time histories rose by only {:.2} %, \
             from {:.2} % to {:.2} % per-dwell relative e_RMS, where {:.1} % confirms an effect",
            100.0 * check.rise,
            100.0 * with,
            100.0 * misfit(&check.without),
            100.0 * CONFIRMATION_RISE
        );
        // the smaller model refitted with the full budget (it stops at once
        // where the check's refit already converged), then its FRF side
        let p = time_parameters(&start, options.refine_linear, band_hz);
        let outcome = identify_time(&start, p, sign, records, options, None)
            .map_err(|e| format!("the time refit without it failed: {e}"))
            .and_then(|r| {
                crate::diagnose::without_effect(d, frf, check.effect, why, patience, predictor)
                    .map(|smaller| (r, smaller))
                    .map_err(|e| format!("the FRF refit without it failed: {e}"))
            });
        match outcome {
            Ok((mut r, smaller)) => {
                *d = smaller;
                // `before` as for the full refit: the FRF diagnosis's model
                r.before = replay(&d.model)?;
                refit = r;
                checks.push(check);
            }
            // it could not be taken out: it stays
            Err(why) => {
                checks.push(EffectCheck {
                    confirmed: true,
                    failed: Some(why),
                    ..check
                });
                checks.extend(round.into_iter().map(|(c, _)| c));
                break;
            }
        }
    }
    if each_alone {
        let p = time_parameters(&refit.model, options.refine_linear, band_hz);
        crate::fit::time::refit_each_alone(&mut refit, &p, records, options, Some(observer))?;
    }
    // the refitted model's residual in the FRFs' plane; with proposals
    // asked, every candidate traced in it
    let want = diagnose_options.time_proposals > 0;
    let (residual, traced_starts, residual_failed) = match replays {
        Some(rr) => match trace_time_residual(
            d,
            frf,
            rr,
            &refit.model,
            records,
            options,
            band_hz,
            diagnose_options,
            predictor,
            &checks,
            want,
        ) {
            Ok((r, starts)) => (Some(r), Some(starts), None),
            Err(e) => (None, None, Some(e.to_string())),
        },
        None => (None, None, None),
    };
    // then the other way: the candidates that explain the most of the time
    // residual (else those the FRFs came closest to keeping), each added to
    // the final model and refitted in time (briefly: it starts next to the
    // refined model); the best that lowers the misfit by more than a
    // confirmation asks is added, which the confirmation would then keep
    let with = misfit(&refit.after);
    let proposal_options = TimeFitOptions {
        patience: options.patience.min(PROPOSAL_PATIENCE),
        ..options.clone()
    };
    let mut proposals: Vec<TimeProposal> = Vec::new();
    let mut best: Option<(usize, crate::model::Model)> = None;
    let put: Vec<(Effect, Option<crate::model::Model>)> = match (&residual, traced_starts) {
        (Some(r), Some(mut starts)) if want => r
            .traced
            .iter()
            .filter(|t| t.failed.is_none() && t.share > MIN_TRACED_SHARE)
            .take(diagnose_options.time_proposals)
            .map(|t| {
                let i = starts.iter().position(|(e, _)| *e == t.effect);
                (t.effect, i.map(|i| starts.swap_remove(i).1))
            })
            .collect(),
        _ => time_proposals(d, &checks, diagnose_options.time_proposals)
            .into_iter()
            .map(|e| (e, None))
            .collect(),
    };
    for (effect, traced_start) in put {
        let start = match traced_start {
            Some(m) => m,
            None => {
                let start = match crate::diagnose::candidate_on_final(
                    d,
                    frf,
                    effect,
                    diagnose_options,
                    predictor,
                ) {
                    Ok(Some(m)) => m,
                    Ok(None) => {
                        proposals.push(TimeProposal::failed(
                            effect,
                            "no start in the residual".into(),
                        ));
                        continue;
                    }
                    Err(e) => {
                        proposals.push(TimeProposal::failed(
                            effect,
                            format!("its FRF refit failed: {e}"),
                        ));
                        continue;
                    }
                };
                // the effect as the FRFs sized it, on the final model as the
                // time domain refined it: the FRF refit moves the shared
                // parameters away from where the recordings want them
                grafted(&start, &refit.model, options.refine_linear, band_hz)
            }
        };
        let p = time_parameters(&start, options.refine_linear, band_hz);
        let refit = identify_time(&start, p, sign, records, &proposal_options, None);
        judge_proposal(effect, refit, with, &mut proposals, &mut best)?;
    }
    if let Some((i, start)) = best {
        let effect = proposals[i].effect;
        let why = format!(
            "with it, refitted, the misfit to the recorded time histories fell by {:.2} %, \
             from {:.2} % to {:.2} % per-dwell relative e_RMS, where {:.1} % confirms an effect",
            100.0 * proposals[i].gain,
            100.0 * with,
            100.0 * misfit(&proposals[i].with),
            100.0 * CONFIRMATION_RISE
        );
        let p = time_parameters(&start, options.refine_linear, band_hz);
        // the larger model refitted with the full budget, then its FRF side;
        // where either fails the diagnosis stands as it was
        if let Ok(mut r) = identify_time(&start, p, sign, records, options, None)
            && let Ok(larger) =
                crate::diagnose::with_effect(d, frf, effect, &r.model, why, predictor)
        {
            *d = larger;
            // `before` stays the FRF diagnosis's own final model
            r.before = refit.before.clone();
            refit = r;
            proposals[i].kept = true;
        }
    }
    Ok(TimeRefinement {
        replay: options.input,
        baseline,
        refit,
        checks,
        residual,
        residual_failed,
        proposals,
    })
}

/// A candidate is put to the time histories only where it explains more
/// than this share of the time residual's `χ²` (see
/// [`crate::diagnose::time_residual`]): below it, the step along its
/// signature is lost in what the residual holds besides.
pub const MIN_TRACED_SHARE: f64 = 0.01;

/// The refined model's time residual in the FRFs' plane (its replay of each
/// recording reduced as the measured response was) and, with `trace`, each
/// candidate that may join the model traced in it: started on the FRFs as
/// the diagnosis starts it on its final model, grafted onto the refined
/// model, its signature the change of the refined model's harmonic-balance
/// FRFs. Returns the residual and the grafted starts (the proposals' own).
#[allow(clippy::too_many_arguments)]
fn trace_time_residual(
    d: &Diagnosis,
    frf: &NonlinearFrf,
    replays: &ReplayReduction,
    refined: &crate::model::Model,
    records: &[TimeRecord],
    options: &TimeFitOptions,
    band_hz: Option<(f64, f64)>,
    diagnose_options: &DiagnoseOptions,
    predictor: &HbPredictor,
    checks: &[EffectCheck],
    trace: bool,
) -> Result<(TimeResidual, Vec<(Effect, crate::model::Model)>)> {
    let params = time_parameters(refined, options.refine_linear, band_hz);
    let problem = TimeProblem::new(
        refined.clone(),
        params,
        records,
        d.response_sign,
        options.clone(),
        None,
    )?;
    let replayed = replays.replayed_as_made(&problem, refined)?;
    let data = FitData::from_frf(replays.measured(), &d.harmonics, d.band_hz, None)?
        .with_sign(d.response_sign);
    let rdata =
        FitData::from_frf(&replayed, &d.harmonics, d.band_hz, None)?.with_sign(d.response_sign);
    let (mut residual, pred) = time_residual(&data, &rdata);
    if !trace {
        return Ok((residual, Vec::new()));
    }
    // what may join the model: not in it, not just dropped by a check
    let effects: Vec<Effect> = diagnose_options
        .candidates
        .iter()
        .copied()
        .filter(|e| e.candidate().applies_to(refined))
        .filter(|e| !d.selected.iter().any(|s| s.effect == *e))
        .filter(|e| !checks.iter().any(|k| k.effect == *e))
        .collect();
    let starts =
        crate::diagnose::candidates_on_final(d, frf, &effects, diagnose_options, predictor)?;
    let without = predictor.predict_from(refined, &data, None)?;
    let mut grafts = Vec::new();
    for (&effect, start) in effects.iter().zip(starts) {
        let failed = |why: String| TracedCandidate {
            effect,
            share: f64::NAN,
            failed: Some(why),
        };
        residual.traced.push(match start {
            Ok(Some(m)) => {
                let g = grafted(&m, refined, options.refine_linear, band_hz);
                match predictor.predict_from(&g, &data, None) {
                    Ok(with) => {
                        grafts.push((effect, g));
                        TracedCandidate {
                            effect,
                            share: share_explained(&data, &pred, &without, &with),
                            failed: None,
                        }
                    }
                    Err(e) => failed(format!("its FRFs could not be predicted: {e}")),
                }
            }
            Ok(None) => failed("no start in the residual".into()),
            Err(e) => failed(format!("its FRF refit failed: {e}")),
        });
    }
    // the largest share first; those not traced last
    residual.traced.sort_by(|a, b| {
        let key = |t: &TracedCandidate| if t.share.is_nan() { -1.0 } else { t.share };
        key(b).total_cmp(&key(a)).then(a.effect.cmp(&b.effect))
    });
    Ok((residual, grafts))
}

/// `candidate` with every parameter it shares by name with `refined` (the
/// joint's, the structure's, an effect's) at `refined`'s value: what the
/// candidate adds, on the refined model.
fn grafted(
    candidate: &crate::model::Model,
    refined: &crate::model::Model,
    refine_linear: bool,
    band_hz: Option<(f64, f64)>,
) -> crate::model::Model {
    let mut out = candidate.clone();
    let theirs = time_parameters(refined, refine_linear, band_hz);
    for q in &time_parameters(candidate, refine_linear, band_hz).parameters {
        if let Some(r) = theirs.parameters.iter().find(|r| r.name == q.name)
            && let Ok(v) = r.read(refined)
        {
            // a value the candidate's model refuses leaves the candidate's
            let mut trial = out.clone();
            if q.write(&mut trial, v).is_ok() && trial.validate().is_ok() {
                out = trial;
            }
        }
    }
    out
}

/// Adds `effect`'s time refit to `proposals`, its gain measured against the
/// misfit `with`, and keeps in `best` the refitted model of the largest gain
/// above [`CONFIRMATION_RISE`]; a refit that failed is reported as such,
/// one cancelled stops the caller.
pub(crate) fn judge_proposal(
    effect: Effect,
    refit: Result<TimeFitResult>,
    with: f64,
    proposals: &mut Vec<TimeProposal>,
    best: &mut Option<(usize, crate::model::Model)>,
) -> Result<()> {
    match refit {
        Ok(r) => {
            let gain = with / misfit(&r.after).max(f64::MIN_POSITIVE) - 1.0;
            if gain > CONFIRMATION_RISE
                && best.as_ref().is_none_or(|(i, _)| gain > proposals[*i].gain)
            {
                *best = Some((proposals.len(), r.model));
            }
            proposals.push(TimeProposal {
                effect,
                with: r.after,
                gain,
                kept: false,
                failed: None,
            });
        }
        Err(crate::error::Error::Cancelled) => return Err(crate::error::Error::Cancelled),
        Err(e) => proposals.push(TimeProposal::failed(
            effect,
            format!("its time refit failed: {e}"),
        )),
    }
    Ok(())
}

impl TimeProposal {
    pub(crate) fn failed(effect: Effect, why: String) -> Self {
        TimeProposal {
            effect,
            with: Vec::new(),
            gain: f64::NAN,
            kept: false,
            failed: Some(why),
        }
    }
}

/// The candidates to put to the time domain: those of the diagnosis's last
/// round (tried on its final model, or the one before it when the rounds
/// ran out) that lowered `χ²` but were not kept, the largest drop first, at
/// most `at_most`; never an effect in the model or one the time domain just
/// dropped.
fn time_proposals(d: &Diagnosis, checks: &[EffectCheck], at_most: usize) -> Vec<Effect> {
    let last = d.candidates.iter().map(|c| c.round).max().unwrap_or(0);
    let mut reports: Vec<&crate::diagnose::CandidateReport> = d
        .candidates
        .iter()
        .filter(|c| c.round == last && !c.accepted && c.delta_chi2 > 0.0)
        .filter(|c| !d.selected.iter().any(|s| s.effect == c.effect))
        .filter(|c| !checks.iter().any(|k| k.effect == c.effect))
        .collect();
    reports.sort_by(|a, b| {
        b.delta_chi2
            .total_cmp(&a.delta_chi2)
            .then(a.effect.cmp(&b.effect))
    });
    let mut effects: Vec<Effect> = Vec::new();
    for r in reports {
        if !effects.contains(&r.effect) {
            effects.push(r.effect);
        }
    }
    effects.truncate(at_most);
    effects
}

/// The time residual in words: its `χ²` per degree of freedom by harmonic
/// and by level (the measured response against the refitted model's replay,
/// reduced alike), and the candidates traced in it.
pub fn time_residual_lines(r: &TimeResidual) -> Vec<String> {
    let f = &r.features;
    let by_h = f
        .chi2_per_dof_by_harmonic
        .iter()
        .map(|(h, c)| format!("H{h} {c:.3}"))
        .collect::<Vec<_>>()
        .join(", ");
    let by_level = f
        .chi2_per_dof_by_level
        .iter()
        .map(|(l, c)| format!("{} {c:.3}", crate::diagnose::fmt_value(*l)))
        .collect::<Vec<_>>()
        .join(", ");
    let mut out = vec![format!(
        "the time residual in the FRFs' plane ({} points, the replay reduced as the recordings were): \
         chi2/dof by harmonic {by_h}; fundamental by level {by_level}",
        r.points
    )];
    if !r.traced.is_empty() {
        let shares = r
            .traced
            .iter()
            .map(|t| match &t.failed {
                None => format!("{} {:.1} %", t.effect.name(), 100.0 * t.share),
                Some(_) => format!("{} not traced", t.effect.name()),
            })
            .collect::<Vec<_>>()
            .join(", ");
        out.push(format!(
            "the share of it each candidate explains (a step along its own FRF change): {shares}"
        ));
    }
    out
}

/// `diagnosis.json`: the diagnosis with the command and its wall time.
#[derive(Serialize)]
pub struct DiagnosisReport<'a> {
    /// `diagnose`.
    pub command: &'static str,
    /// Tool version.
    pub version: &'static str,
    /// Wall time, s.
    pub seconds: f64,
    /// The diagnosis.
    #[serde(flatten)]
    pub diagnosis: &'a Diagnosis,
    /// Its final model refitted in the time domain (`--domain time`).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub time_domain: Option<&'a TimeOutcome>,
    /// The final model as reported: every parameter with its interval and
    /// flags, the first fit as the "before" (`diagnose`; `run` puts it in
    /// `run.json`).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub final_model: Option<&'a super::run::FinalModel>,
    /// The reference channel named by the user (`--reference`); none: the
    /// recording format's rule.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub reference_channel: Option<&'a str>,
    /// The warnings of the quality reports `hystid import` wrote beside the
    /// recordings, one line each; none: absent.
    #[serde(skip_serializing_if = "<[String]>::is_empty")]
    pub quality_warnings: &'a [String],
    /// Why the figures were not drawn, where they could not be (the
    /// analysis stands without them); absent when they were.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub figures_not_drawn: Option<String>,
    /// The quantity of the reference the FRFs were measured against (a
    /// force or a voltage): `validate` refuses a recording driven by the
    /// other.
    pub reference_quantity: crate::harmonics::Quantity,
}

/// What a diagnosis's report holds beside the diagnosis (see
/// [`write_diagnosis_with`]).
#[derive(Clone, Copy, Default)]
pub struct DiagnosisExtras<'a> {
    /// The time-domain refinement, when there is one.
    pub time: Option<&'a TimeOutcome>,
    /// The final model as reported, with its flags.
    pub final_model: Option<&'a super::run::FinalModel>,
    /// The reference channel the user named.
    pub reference_channel: Option<&'a str>,
    /// The import's quality warnings on the recordings.
    pub quality: &'a [String],
}

impl<'a> DiagnosisReport<'a> {
    /// The report of `d`, made in `seconds` from FRFs measured against a
    /// `reference` quantity.
    pub fn new(d: &'a Diagnosis, reference: crate::harmonics::Quantity, seconds: f64) -> Self {
        DiagnosisReport {
            command: "diagnose",
            version: super::VERSION,
            seconds,
            diagnosis: d,
            time_domain: None,
            final_model: None,
            reference_channel: None,
            quality_warnings: &[],
            figures_not_drawn: None,
            reference_quantity: reference,
        }
    }
}

/// Writes `diagnosis.json`, `diagnosis.md` and the residual plots.
pub fn write_diagnosis(
    dir: &Path,
    frf: &NonlinearFrf,
    d: &Diagnosis,
    predictor: &HbPredictor,
    seconds: f64,
) -> Result<Written> {
    write_diagnosis_with(dir, frf, d, predictor, seconds, DiagnosisExtras::default())
}

/// What [`write_diagnosis_with`] wrote, and what it could not (a figure
/// not drawn, with the reason), for the terminal.
#[derive(Clone, Debug, Default)]
pub struct Written {
    /// The files written.
    pub files: Vec<PathBuf>,
    /// One line per thing left out.
    pub notes: Vec<String>,
}

/// [`write_diagnosis`], with `extras`: the time-domain refinement when there
/// is one (`time_domain` in `diagnosis.json`, a section in `diagnosis.md`),
/// the final model as reported, with its flags (`final_model`, and a
/// section after the explanation), and the reference channel named.
pub fn write_diagnosis_with(
    dir: &Path,
    frf: &NonlinearFrf,
    d: &Diagnosis,
    predictor: &HbPredictor,
    seconds: f64,
    extras: DiagnosisExtras,
) -> Result<Written> {
    let DiagnosisExtras {
        time,
        final_model,
        reference_channel,
        quality,
    } = extras;
    let mut files = vec![dir.join("diagnosis.json"), dir.join("diagnosis.md")];
    // a figure that cannot be drawn (every residual of a level NaN, say)
    // is said, never the end of the analysis
    let figures_not_drawn = match residual_plots(dir, frf, d, predictor) {
        Ok(plots) => {
            files.extend(plots);
            None
        }
        Err(e) => Some(format!(
            "the figures residual and diagnosis_frf were not drawn: {e}"
        )),
    };
    write_json(
        &files[0],
        &DiagnosisReport {
            time_domain: time,
            final_model,
            reference_channel,
            quality_warnings: quality,
            figures_not_drawn: figures_not_drawn.clone(),
            ..DiagnosisReport::new(d, frf.reference, seconds)
        },
    )?;
    let mut md = markdown(d, frf.reference, seconds);
    if let Some(why) = &figures_not_drawn {
        md = md.replace(FIGURES_MARKDOWN, &format!("({why})"));
    }
    md += &quality_markdown(quality);
    if let Some(f) = final_model {
        md += "\n";
        md += &super::run::final_markdown(f);
    }
    match time {
        Some(TimeOutcome::Refined(t)) => md += &time_markdown(t),
        Some(TimeOutcome::Failed { failed }) => {
            md += &format!("\n## In the time domain\n\nNo refit: {failed}\n")
        }
        None => {}
    }
    crate::atomic::write_bytes(&files[1], md.as_bytes())?;
    Ok(Written {
        files,
        notes: figures_not_drawn.into_iter().collect(),
    })
}

/// The import's quality warnings as a section of `diagnosis.md`; none:
/// no section.
fn quality_markdown(quality: &[String]) -> String {
    if quality.is_empty() {
        return String::new();
    }
    let mut s =
        "\n## Data quality\n\nThe import found, in the recordings analysed:\n\n".to_string();
    for q in quality {
        let _ = writeln!(s, "- {q}");
    }
    s
}

/// The time-domain refinement as a section of `diagnosis.md`.
pub fn time_markdown(t: &TimeRefinement) -> String {
    let mut s = String::new();
    time_errors_md(&mut s, t);
    time_each_alone_md(&mut s, t);
    time_checks_md(&mut s, t);
    time_residual_md(&mut s, t);
    time_proposals_md(&mut s, t);
    time_parameters_md(&mut s, t);
    s
}

/// The header and each recording's error: the baseline, the final model as the FRF diagnosis fitted it, and refitted in time.
fn time_errors_md(s: &mut String, t: &TimeRefinement) {
    let _ = writeln!(
        s,
        "\n## In the time domain\n\nThe final model refitted on the recorded time histories \
         ({} samples, {:?}; every model replayed {}): each dwell's relative e_RMS, root mean \
         square over the dwells.\n",
        t.refit.samples,
        t.refit.status,
        match t.replay {
            crate::validate::DriveInput::Continuous => {
                "as the continuous model, the joint's sinc^2 loss compensated"
            }
            crate::validate::DriveInput::BandLimited => "on the band-limited reference",
            crate::validate::DriveInput::Ramp => "on the reference drawn straight between samples",
        }
    );
    let _ = writeln!(
        s,
        "| recording | baseline (joint alone) | final, as the FRF diagnosis fitted it | final, refitted in time |"
    );
    let _ = writeln!(s, "|---|---|---|---|");
    for ((b, f), a) in t.baseline.iter().zip(&t.refit.before).zip(&t.refit.after) {
        let _ = writeln!(
            s,
            "| {} | {:.2} % | {:.2} % | {:.2} % |",
            a.recording,
            100.0 * b.segment_relative,
            100.0 * f.segment_relative,
            100.0 * a.segment_relative
        );
    }
}

/// Each recording refitted alone (`--each-alone`), with what it says of the levels.
fn time_each_alone_md(s: &mut String, t: &TimeRefinement) {
    if !t.refit.each_alone.is_empty() {
        let _ = writeln!(
            s,
            "\nEach recording refitted alone from the refitted model (`--each-alone`): \
             its relative e_RMS over its judged window.\n\n\
             | recording | together | alone |\n|---|---|---|"
        );
        for a in &t.refit.each_alone {
            let alone = match (a.alone, &a.failed) {
                (Some(x), _) => format!("{:.2} %", 100.0 * x),
                (None, why) => format!("refit failed: {}", why.as_deref().unwrap_or("")),
            };
            let _ = writeln!(
                s,
                "| {} | {:.2} % | {alone} |",
                a.recording,
                100.0 * a.together
            );
        }
        if let Some(note) = crate::fit::time::level_consistency(&t.refit.each_alone) {
            let _ = writeln!(s, "\n{}{}.", note[..1].to_uppercase(), &note[1..]);
        }
    }
}

/// Each effect the FRF diagnosis kept, taken out and the rest refitted in time.
fn time_checks_md(s: &mut String, t: &TimeRefinement) {
    if !t.checks.is_empty() {
        let _ = writeln!(
            s,
            "\nEach effect the FRF diagnosis kept, taken out and the rest refitted in time \
             (kept when the misfit rises by more than {:.1} %):\n\n\
             | effect | misfit without it | rise | kept |\n|---|---|---|---|",
            100.0 * CONFIRMATION_RISE
        );
        for c in &t.checks {
            let _ = match &c.failed {
                Some(why) => writeln!(s, "| {} | refit failed: {why} | | yes |", c.effect.name()),
                None => writeln!(
                    s,
                    "| {} | {:.2} % | {:+.2} % | {} |",
                    c.effect.name(),
                    100.0 * misfit(&c.without),
                    100.0 * c.rise,
                    if c.confirmed {
                        "yes"
                    } else {
                        "**no: dropped**"
                    }
                ),
            };
        }
    }
}

/// The refitted model's residual in the FRFs' plane and the candidates traced in it.
fn time_residual_md(s: &mut String, t: &TimeRefinement) {
    if let Some(r) = &t.residual {
        let _ = writeln!(
            s,
            "\nThe refitted model's residual in the FRFs' plane: the model's replay of each \
             recording reduced as the recording was, against the measured FRFs ({} points; \
             chi-square per degree of freedom, 1 is the noise):\n\n\
             | harmonic | chi2/dof |\n|---|---|",
            r.points
        );
        for (h, c) in &r.features.chi2_per_dof_by_harmonic {
            let _ = writeln!(s, "| {h} | {c:.3} |");
        }
        let _ = writeln!(s, "\n| level | chi2/dof of the fundamental |\n|---|---|");
        for (l, c) in &r.features.chi2_per_dof_by_level {
            let _ = writeln!(s, "| {} | {c:.3} |", crate::diagnose::fmt_value(*l));
        }
        if !r.traced.is_empty() {
            let _ = writeln!(
                s,
                "\nEach candidate that may join the model traced in it: the share of its \
                 chi-square a step along the candidate's own FRF change removes (put to the \
                 time histories, the largest first, above {:.0} %):\n\n\
                 | candidate | share |\n|---|---|",
                100.0 * MIN_TRACED_SHARE
            );
            for c in &r.traced {
                let _ = match &c.failed {
                    Some(why) => writeln!(s, "| {} | not traced: {why} |", c.effect.name()),
                    None => writeln!(s, "| {} | {:.1} % |", c.effect.name(), 100.0 * c.share),
                };
            }
        }
    }
    if let Some(why) = &t.residual_failed {
        let _ = writeln!(
            s,
            "\nThe time residual could not be reduced or traced: {why}"
        );
    }
}

/// The candidates put to the time histories.
fn time_proposals_md(s: &mut String, t: &TimeRefinement) {
    if !t.proposals.is_empty() {
        let _ = writeln!(
            s,
            "\nThe candidates put to the time histories, each added to the final model \
             and refitted in time (added when the misfit falls by more than {:.1} %; the best \
             such):\n\n\
             | effect | misfit with it | fall | added |\n|---|---|---|---|",
            100.0 * CONFIRMATION_RISE
        );
        for p in &t.proposals {
            let _ = match &p.failed {
                Some(why) => writeln!(s, "| {} | not tried: {why} | | no |", p.effect.name()),
                None => writeln!(
                    s,
                    "| {} | {:.2} % | {:+.2} % | {} |",
                    p.effect.name(),
                    100.0 * misfit(&p.with),
                    100.0 * p.gain,
                    if p.kept { "**yes**" } else { "no" }
                ),
            };
        }
    }
}

/// The refitted parameters with their intervals, and the refit's notes.
fn time_parameters_md(s: &mut String, t: &TimeRefinement) {
    let _ = writeln!(s, "\n| parameter | value | 95 % interval |\n|---|---|---|");
    let reference = (t.refit.reference_quantity).unwrap_or(crate::harmonics::Quantity::Force);
    let drive = super::flags::force_drive(&t.refit.model, reference);
    for (name, e) in &t.refit.parameters {
        let unit = super::flags::parameter_unit(name, &t.refit.model, drive);
        let _ = writeln!(
            s,
            "| {name} | {:.6e}{} | [{:.4e}, {:.4e}]{} |",
            e.value,
            super::flags::unit_suffix(unit),
            e.ci95[0],
            e.ci95[1],
            if e.identifiable {
                ""
            } else {
                " (not identifiable)"
            }
        );
    }
    for n in &t.refit.notes {
        let _ = writeln!(s, "\nNote: {n}");
    }
}

/// `diagnosis.md`: the candidates, what was kept and why; `reference` the
/// quantity the FRFs are referred to (their parameters' units follow it).
pub fn markdown(d: &Diagnosis, reference: crate::harmonics::Quantity, seconds: f64) -> String {
    let drive = super::flags::force_drive(&d.baseline_model, reference);
    let mut s = String::new();
    let _ = writeln!(s, "# Diagnosis: what the fitted joint model lacks\n");
    let _ = writeln!(s, "{}\n", d.explanation);
    let _ = writeln!(
        s,
        "| candidate | round | feature rank | Δχ² | threshold (BIC) | kept | error H1 | χ²/dof | parameters |"
    );
    let _ = writeln!(s, "|---|---|---|---|---|---|---|---|---|");
    for c in &d.candidates {
        let p: Vec<String> = c
            .effect_parameters
            .iter()
            .map(|(n, v)| {
                let unit = super::flags::law_parameter_unit(c.effect.candidate().law(), n, drive);
                format!("{n} = {v:.4e}{}", super::flags::unit_suffix(unit))
            })
            .collect();
        let _ = writeln!(
            s,
            "| {} | {} | {} | {:.1} | {:.1} | {} | {:.3} % | {:.3} | {} |",
            c.effect.name(),
            c.round,
            c.rank,
            c.delta_chi2,
            c.threshold,
            match c.verdict {
                Verdict::Kept => "**yes**",
                Verdict::DroppedLater => "no: dropped later",
                Verdict::SizeNotResolved => "no: size not resolved",
                Verdict::NotSeenAtAnyPoint => "no: within the noise at every point",
                Verdict::AnotherDidBetter => "no: another did better",
                Verdict::BelowCriterion => "no",
                Verdict::NotConfirmedInTime => "no: not confirmed in the time domain",
                Verdict::KeptInTime => "**yes**: needed by the time histories",
            },
            100.0 * c.fit.error_relative,
            c.fit.chi2_per_dof,
            p.join(", ")
        );
    }
    for f in &d.failed {
        let _ = writeln!(
            s,
            "| {} | {} | | | | {} | | | {} |",
            f.effect.name(),
            f.round,
            if f.not_applicable {
                "not applicable"
            } else {
                "failed"
            },
            f.reason.replace('|', "/")
        );
    }
    let notes: Vec<String> = d
        .candidates
        .iter()
        .filter_map(|c| {
            c.note
                .as_ref()
                .map(|n| format!("- {} (round {}): {n}", c.effect.name(), c.round))
        })
        .collect();
    if !notes.is_empty() {
        let _ = writeln!(s, "\nWhy a candidate was not kept:\n\n{}", notes.join("\n"));
    }
    let _ = writeln!(
        s,
        "\nBaseline error {:.3} % → final {:.3} % (H1); χ²/dof {:.3} → {:.3} ({}). Harmonics judged: {:?}. {:.1} s.\n",
        100.0 * d.baseline.error_relative,
        100.0 * d.final_fit.error_relative,
        d.baseline.chi2_per_dof,
        d.final_fit.chi2_per_dof,
        if d.consistent_with_noise {
            "consistent with the noise"
        } else {
            "above the noise"
        },
        d.harmonics,
        seconds
    );
    let _ = writeln!(s, "{FIGURES_MARKDOWN}");
    s
}

/// The figures' place in `diagnosis.md`.
const FIGURES_MARKDOWN: &str = "![residual before and after](residual.png)\n\n\
*[residual.png](residual.png): |H1 meas − H1 model| / σ per level, the baseline's and the final model's.*\n\n\
![the baseline and the final model](diagnosis_frf.png)\n\n\
*[diagnosis_frf.png](diagnosis_frf.png): the measured FRFs (markers) with the baseline (grey) \
and the final model (solid) on a fine grid: where the grey line leaves the solid one, the effects added change the FRF.*";
