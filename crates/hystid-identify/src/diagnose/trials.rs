//! A round's candidate trials: each candidate's starts from the residual
//! refitted, screened where they are many, the best kept; and the
//! candidates ranked by the residual's features.

use super::candidates::{self, Context};
use super::{
    Budget, DiagnoseOptions, Effect, Refit, ResidualFeatures, refit, refit_counted, refit_within,
};
use crate::error::Result;
use crate::extract::NonlinearFrf;
use crate::fit::optimise::Race;
use crate::fit::{FitData, HbPredictor, Prediction};
use crate::model::Model;
use rayon::prelude::*;

/// A candidate with more starts than this has them screened first: each
/// refitted briefly, only the best this many refitted in full.
const POLISHED_STARTS: usize = 2;

/// Levenberg–Marquardt's patience while screening starts: enough to let a
/// start settle into its basin, a fraction of a full refit.
const SCREEN_PATIENCE: usize = 1;

/// What the trials of a round's candidates share: everything their starts
/// are made from but the model each is added to.
pub(super) struct Trials<'a> {
    frf: &'a NonlinearFrf,
    data: &'a FitData,
    options: &'a DiagnoseOptions,
    predictor: &'a HbPredictor,
    identified: &'a candidates::Identified,
    expected_chi2: f64,
}

impl<'a> Trials<'a> {
    /// The trials on `data`, judged against the `χ²` its noise alone gives.
    pub(super) fn new(
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
    pub(super) fn identify_beforehand(&self, effects: &[Effect], currents: &[&'a Refit]) {
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
pub(super) fn try_candidate<'a>(
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
pub(super) fn rank(features: &ResidualFeatures, candidates: &[Effect]) -> Vec<(Effect, f64)> {
    let mut scored: Vec<(Effect, f64)> = candidates
        .iter()
        .map(|&e| (e, e.candidate().score(features)))
        .collect();
    scored.sort_by(|a, b| b.1.total_cmp(&a.1).then(a.0.cmp(&b.0)));
    scored
}
