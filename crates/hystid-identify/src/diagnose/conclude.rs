//! The diagnosis concluded: the kept effects' intervals at the final model,
//! its fit and the account in words; the drop cascade after an addition;
//! and a diagnosis concluded again with an effect taken out or added.

use super::resolution::{Intervals, confidence_at};
use super::trials::{Trials, try_candidate};
use super::{
    CandidateReport, DiagnoseOptions, Diagnosis, Effect, FailedCandidate, ModelFit, Refit,
    ResidualFeatures, SelectedEffect, Verdict, candidates, features, fmt_value, model_fit,
    model_parameters, refit, refit_within,
};
use crate::error::{Error, Result};
use crate::extract::NonlinearFrf;
use crate::fit::{Estimate, FitData, HbPredictor};
use crate::model::Model;
use std::collections::BTreeMap;

/// What a diagnosis concludes from: its rounds' outcome and the model they
/// ended with.
pub(super) struct Conclusion<'a> {
    pub(super) harmonics: Vec<usize>,
    pub(super) band_hz: Option<(f64, f64)>,
    pub(super) baseline: ModelFit,
    pub(super) base_features: ResidualFeatures,
    pub(super) reports: Vec<CandidateReport>,
    pub(super) failed: Vec<FailedCandidate>,
    pub(super) chosen: Vec<Effect>,
    pub(super) current: Refit,
    pub(super) data: &'a FitData,
    pub(super) predictor: &'a HbPredictor,
    pub(super) baseline_model: Model,
    pub(super) response_sign: f64,
    /// The `χ²` noise alone gives.
    pub(super) expected: f64,
    /// The intervals at `current`, where the rounds computed them.
    pub(super) intervals: Option<Intervals>,
    /// Whether the baseline went astray.
    pub(super) baseline_astray: Option<crate::fit::identify::Astray>,
    /// What the model's forces are measured against: its units.
    pub(super) drive: crate::harmonics::Quantity,
}

/// The diagnosis: the kept effects' intervals at the final model, its fit
/// and the account in words.
pub(super) fn conclude(c: Conclusion<'_>) -> Result<Diagnosis> {
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
        drive,
    } = c;
    let normalised = |chi2: f64| chi2 / expected.max(f64::MIN_POSITIVE);
    let selected = selected_effects(&chosen, &current, data, predictor, intervals)?;
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
        drive,
    );
    if !consistent {
        explanation.push_str(&untried_note(&reports, &failed));
    }
    if let Some(a) = &baseline_astray {
        explanation.push_str(&format!(
            " The baseline went astray ({}): what was added to it is not trusted.",
            a.describe()
        ));
    }
    if let Some(s) = crate::fit::SubharmonicPoint::describe(&data.subharmonic_points) {
        explanation.push(' ');
        explanation.push_str(&s);
    }
    Ok(Diagnosis {
        subharmonic_dwells: data.subharmonic_points.clone(),
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
        final_prediction: Some(current.pred),
        response_sign,
    })
}

/// The effects kept, each with its parameters' intervals at the final
/// model (`intervals` when they are known already).
fn selected_effects(
    chosen: &[Effect],
    current: &Refit,
    data: &FitData,
    predictor: &HbPredictor,
    intervals: Option<Intervals>,
) -> Result<Vec<SelectedEffect>> {
    let mut selected = Vec::new();
    if chosen.is_empty() {
        return Ok(selected);
    }
    let Intervals { params, conf } = match intervals {
        Some(i) => i,
        None => Intervals::at(current, data, predictor)?,
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
    for &effect in chosen {
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

    Ok(selected)
}

/// Where the residual stays above the noise, the candidates left out are
/// the user's next step: those tried only when named, and not tried.
fn untried_note(reports: &[CandidateReport], failed: &[FailedCandidate]) -> String {
    let untried: Vec<&str> = Effect::ALL
        .iter()
        .filter(|e| !e.by_default())
        .filter(|e| {
            !reports.iter().any(|r| r.effect == **e) && !failed.iter().any(|f| f.effect == **e)
        })
        .map(|e| e.name())
        .collect();
    if untried.is_empty() {
        return String::new();
    }
    format!(
        " Not tried, as they are tried only when named: {} (`--candidates default,{}`).",
        untried.join(", "),
        untried[0]
    )
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
    reconcluded(d, reports, chosen, current, &data, predictor, frf.reference)
}

/// `d` concluded again with `reports`, the effects `chosen` and the final
/// refit `current` on `data` (its baseline and features as they were), the
/// FRFs referred to `reference`.
fn reconcluded(
    d: &Diagnosis,
    reports: Vec<CandidateReport>,
    chosen: Vec<Effect>,
    current: Refit,
    data: &FitData,
    predictor: &HbPredictor,
    reference: crate::harmonics::Quantity,
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
        drive: crate::model::units::force_drive(&d.baseline_model, reference),
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
    reconcluded(d, reports, chosen, current, &data, predictor, frf.reference)
}

/// How the drop cascade after an addition ended.
#[derive(Debug, PartialEq)]
pub(super) enum Cascade<S> {
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
pub(super) fn drop_cascade<S>(
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
pub(super) fn mark_dropped(
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

/// A few sentences of plain explanation.
pub(super) fn explain(
    baseline: &ModelFit,
    f: &ResidualFeatures,
    reports: &[CandidateReport],
    selected: &[SelectedEffect],
    final_fit: &ModelFit,
    consistent: bool,
    drive: crate::harmonics::Quantity,
) -> String {
    let mut s = String::new();
    s.push_str(&format!(
        "The baseline (the fitted joint law, refitted with the measured standard errors on the harmonics judged) left a residual of {:.2} % in H1 (χ²/dof = {:.2}). ",
        100.0 * baseline.error_relative,
        baseline.chi2_per_dof
    ));
    let decided_in_time = time_verdicts(reports);
    s.push_str(&decided_in_time);
    if selected.is_empty() {
        if decided_in_time.is_empty() {
            s.push_str(&nothing_added(reports));
        } else {
            s.push_str("No missing effect is confirmed.");
        }
        return s;
    }
    for sel in selected {
        s.push_str(&effect_added(f, sel, drive));
    }
    s.push_str(&error_change(baseline, f, final_fit, consistent));
    s
}

/// The candidates the time domain decided otherwise than the FRFs: those
/// dropped there, and those added there.
fn time_verdicts(reports: &[CandidateReport]) -> String {
    let mut s = String::new();
    for r in reports
        .iter()
        .filter(|r| r.verdict == Verdict::NotConfirmedInTime)
    {
        s.push_str(&format!(
            "The candidate {} was kept on the FRFs but not confirmed in the time domain ({}), \
             so it was dropped and the rest refitted. ",
            r.effect.name(),
            r.note.as_deref().unwrap_or("no reason recorded")
        ));
    }
    for r in reports.iter().filter(|r| r.verdict == Verdict::KeptInTime) {
        s.push_str(&format!(
            "The candidate {} was not kept on the FRFs, but the recorded time histories \
             need it ({}), so it was added. ",
            r.effect.name(),
            r.note.as_deref().unwrap_or("no reason recorded")
        ));
    }
    s
}

/// Why nothing was added: the candidate that came closest, and how far.
fn nothing_added(reports: &[CandidateReport]) -> String {
    let best = reports
        .iter()
        .max_by(|a, b| a.criterion.total_cmp(&b.criterion));
    match best {
        Some(b) if b.note.is_some() => format!(
            "No significant missing effect: the candidate that did best against the information criterion, {}, {}.",
            b.effect.name(),
            b.note.as_deref().unwrap_or_default()
        ),
        Some(b) => format!(
            "No significant missing effect: the candidate that came closest to the information criterion, {}, lowered χ² by {:.1}, short of the {:.1} it asks for {} parameter(s).",
            b.effect.name(),
            b.delta_chi2,
            b.threshold,
            b.parameters_added
        ),
        None => "No significant missing effect.".to_string(),
    }
}

/// One effect added: why, and its parameters with their intervals.
fn effect_added(
    f: &ResidualFeatures,
    sel: &SelectedEffect,
    drive: crate::harmonics::Quantity,
) -> String {
    let why = sel.effect.candidate().explain(f, sel);
    let params: Vec<String> = sel
        .parameters
        .iter()
        .map(|(n, e)| {
            let law = sel.effect.candidate().law();
            let unit = crate::model::units::law_parameter_unit(law, n, drive);
            format!(
                "{n} = {} [{}, {}]{}",
                fmt_value(e.value),
                fmt_value(e.ci95[0]),
                fmt_value(e.ci95[1]),
                crate::model::units::unit_suffix(unit)
            )
        })
        .collect();
    format!(
        "{}: {} added ({}). ",
        capitalise(&why),
        sel.effect.name(),
        params.join(", ")
    )
}

/// The error before and after, in H1 and in the higher harmonics that say
/// something of the model, and whether the rest is noise.
fn error_change(
    baseline: &ModelFit,
    f: &ResidualFeatures,
    final_fit: &ModelFit,
    consistent: bool,
) -> String {
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
    format!(
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
    )
}

fn capitalise(s: &str) -> String {
    let mut c = s.chars();
    match c.next() {
        Some(f) => f.to_uppercase().collect::<String>() + c.as_str(),
        None => String::new(),
    }
}
