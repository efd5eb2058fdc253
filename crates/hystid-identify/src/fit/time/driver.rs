//! The time-domain fit: its free parameters, its descent from each start, and
//! each recording refitted alone.

use super::intervals::time_confidence;
use super::judging::{JUDGED_STRETCH, MIN_JUDGED_PER_PERIOD};
use super::options::TimeFitOptions;
use super::problem::TimeProblem;
use super::records::TimeRecord;
use super::results::{AloneFit, StartOutcome, TimeFitResult, level_consistency};
use super::starts::spread_start;
use crate::error::{Error, Result};
use crate::fit::optimise::{self, FitStatus, OptimiserRun};
use crate::fit::params::ParameterSet;
use crate::model::Model;
use crate::validate::DriveInput;

/// The free parameters of a time-domain fit of `model`: every element's
/// (the joint's under their plain names, an effect's prefixed with its law;
/// not the joint's gauges),
/// and with `refine_linear` the linear part's (see
/// [`ParameterSet::for_linear_in`]).
pub fn time_parameters(
    model: &Model,
    refine_linear: bool,
    band_hz: Option<(f64, f64)>,
) -> ParameterSet {
    let mut p = ParameterSet::default();
    for (at, _) in model.placed_all() {
        p.extend(ParameterSet::for_element(
            model,
            at,
            &model.parameter_prefix(at),
        ));
    }
    if refine_linear {
        p.extend(ParameterSet::for_linear_in(model, band_hz));
    }
    // as in the FRF fit: a gauge is held (Bouc-Wen's β)
    p.without_gauges(model)
}

/// Levenberg–Marquardt's relative tolerance on the sum of squares and the
/// step (MINPACK's `ftol`, `xtol`; its default). Each of its iterations
/// costs a replay per free parameter for the Jacobian, and an ill-posed fit
/// crawls: a four-level F-16 fit of 21 parameters spent 3000 replays
/// lowering its cost by less than one part in 10⁷, on the way to the
/// patience's 20000.
pub(super) const LM_TOLERANCE: f64 = 1.49e-8;

/// How many times a fit resumes on a finer replay grid its optimum needs
/// (see [`TimeProblem::fix_replay_grid`]).
const MAX_GRID_RESUMPTIONS: usize = 2;

/// Levenberg–Marquardt from `theta0` on the problem's replay grid, resumed
/// where the optimum needs a finer one than the grid holds (fixed on the
/// start: at most [`MAX_GRID_RESUMPTIONS`] in a fit, counted in `resumed`;
/// each resumption starts next to its optimum).
fn descend(
    problem: &mut TimeProblem<'_>,
    theta0: &[f64],
    patience: usize,
    resumed: &mut usize,
) -> Result<OptimiserRun> {
    let mut run = optimise::levenberg_marquardt_to(&*problem, theta0, patience, LM_TOLERANCE)?;
    loop {
        let (optimum, _) = problem.model_at(&run.theta)?;
        if *resumed == MAX_GRID_RESUMPTIONS || !problem.fix_replay_grid(&optimum, "fitted") {
            return Ok(run);
        }
        *resumed += 1;
        let (evaluations, iterations) = (run.evaluations, run.iterations);
        run = optimise::levenberg_marquardt_to(&*problem, &run.theta, patience, LM_TOLERANCE)?;
        run.evaluations += evaluations;
        run.iterations += iterations;
    }
}

/// Fits `parameters` of `start` to `records` in the time domain (see the
/// module docs); `sign` is the response sign of the start's fit.
pub fn identify_time(
    start: &Model,
    parameters: ParameterSet,
    sign: f64,
    records: &[TimeRecord],
    options: &TimeFitOptions,
    observer: Option<&dyn crate::observe::Observer>,
) -> Result<TimeFitResult> {
    if parameters.is_empty() {
        return Err(Error::plan("parameters", "none free: nothing to fit"));
    }
    for r in records {
        start.check_reference(r.reference_quantity, &format!("{}: the reference", r.name))?;
    }
    let each_alone = (options.each_alone && records.len() > 1).then(|| parameters.clone());
    let mut problem = TimeProblem::new(
        start.clone(),
        parameters,
        records,
        sign,
        options.clone(),
        observer,
    )?;
    if problem.parameters.is_empty() {
        return Err(Error::plan(
            "parameters",
            "none free that the replay feels: nothing to fit",
        ));
    }
    problem.choose_replay_rates();
    let before = problem.errors(start)?;
    let theta0 = problem.parameters.theta_of(start)?;
    let mut resumed = 0;
    let run = descend(&mut problem, &theta0, options.patience, &mut resumed)?;
    // further starts spread about the given one, each on the grid the fit
    // has reached so far; a start that fails is reported, not fatal
    let mut ended: Vec<(usize, Result<OptimiserRun>)> = vec![(0, Ok(run))];
    for k in 1..options.starts.max(1) {
        let theta = spread_start(&problem.parameters, &theta0, k);
        let other = descend(&mut problem, &theta, options.patience, &mut resumed);
        if matches!(other, Err(Error::Cancelled)) {
            return Err(Error::Cancelled);
        }
        ended.push((k, other));
    }
    // compared by their misfit on the grid the last one ended on (a
    // resumption may have refined it), the bounds' penalty left out
    let several = ended.len() > 1;
    let mut starts = Vec::with_capacity(ended.len());
    let mut best: Option<(f64, usize, OptimiserRun)> = None;
    let (mut evaluations, mut iterations) = (0, 0);
    for (k, run) in ended {
        let misfit = match &run {
            Ok(r) if several => Some(problem.misfit(&r.theta)?),
            _ => None,
        };
        starts.push(StartOutcome::of(k, run.as_ref(), misfit));
        if let Ok(r) = run {
            evaluations += r.evaluations;
            iterations += r.iterations;
            let m = misfit.unwrap_or(0.0);
            if best.as_ref().is_none_or(|(b, _, _)| m < *b) {
                best = Some((m, k, r));
            }
        }
    }
    // the given start descended (its failure is the fit's, above)
    let (_, kept, mut run) = best.expect("the given start's run");
    run.evaluations = evaluations;
    run.iterations = iterations;
    let (model, _) = problem.model_at(&run.theta)?;
    let mut notes = problem.replay_notes().to_vec();
    if several {
        notes.push(format!(
            "descended from {} starts (the given one and {} spread about it); the lowest misfit \
             is start {kept}'s{}",
            starts.len(),
            starts.len() - 1,
            if kept == 0 { ", the given one" } else { "" }
        ));
    }
    if options.input == DriveInput::Continuous {
        notes.insert(
            0,
            "replayed as the continuous model: the joint's force taken as band-limited, its \
             sinc^2 loss inside the filters' loop compensated (--replay continuous)"
                .into(),
        );
    }
    if resumed > 0 {
        notes.push(format!(
            "the optimum needed a finer replay grid than the start: the fit was resumed on it \
             {resumed} time(s)"
        ));
    }
    let every: usize = records
        .iter()
        .flat_map(|r| r.segments.iter().map(|s| s.len()))
        .sum();
    let samples: usize = problem.judged_samples().iter().sum();
    if samples < every {
        let factors: Vec<String> = problem
            .judging_factors()
            .iter()
            .map(|k| k.to_string())
            .collect();
        let in_part = if problem.judged_in_part() {
            let how = if records.iter().all(|r| r.periodic) {
                "each record on its share as its first steady periods (alike in a steady state; \
                 the replays stop there)"
                    .to_string()
            } else {
                format!(
                    "each segment on its share in stretches of at most {JUDGED_STRETCH} spread \
                     over it"
                )
            };
            format!(
                ", {how} (the rate left at least {MIN_JUDGED_PER_PERIOD} samples a period of \
                 the model's highest linearised frequency)"
            )
        } else {
            String::new()
        };
        notes.push(format!(
            "judged on {samples} of the {every} samples: the responses low-passed and judged \
             at one sample in {} (by recording){in_part}, for at most {} judged \
             (--max-judged-samples; the Jacobian holds a row per sample judged); the errors \
             reported are over every sample",
            factors.join("/"),
            options.max_judged_samples
        ));
    }
    let after = problem.errors_by_frequency(&model)?;
    let parameters = time_confidence(&problem, &run.theta)?;
    let set = &problem.parameters;
    let mut at_bound: Vec<String> = set
        .parameters
        .iter()
        .zip(set.at_bounds(&set.values(&run.theta)))
        .filter(|(_, hit)| *hit)
        .map(|(p, _)| p.name.clone())
        .collect();
    at_bound.sort();
    let worse = before
        .iter()
        .zip(&after)
        .filter(|(b, a)| a.window.e_rms > b.window.e_rms * (1.0 + 1e-9))
        .count();
    if worse > 0 {
        notes.push(format!(
            "{worse} recording(s) fit worse than with the start: the optimum trades them \
             against the others"
        ));
    }
    let mut fit = TimeFitResult {
        starts: if several { starts } else { Vec::new() },
        model,
        response_sign: sign,
        parameters,
        before,
        after,
        status: run.status,
        optimiser: run,
        samples,
        notes,
        at_bound,
        reference_quantity: records.first().map(|r| r.reference_quantity),
        acquisition: options.acquisition.clone(),
        each_alone: Vec::new(),
    };
    if let Some(parameters) = each_alone {
        // the problem's scratch (its replays, its Jacobian) freed first
        drop(problem);
        refit_each_alone(&mut fit, &parameters, records, options, observer)?;
    }
    Ok(fit)
}

/// Each of `records` refitted alone from `fitted`'s model with the
/// `parameters` its fit freed, into `fitted.each_alone`, and the note of
/// what that says (see [`TimeFitOptions::each_alone`]); a refit that fails
/// is reported, not fatal. `identify_time` calls it when asked, and so does
/// a diagnosis for its final refit.
pub fn refit_each_alone(
    fitted: &mut TimeFitResult,
    parameters: &ParameterSet,
    records: &[TimeRecord],
    options: &TimeFitOptions,
    observer: Option<&dyn crate::observe::Observer>,
) -> Result<()> {
    fitted.each_alone = alone_refits(fitted, parameters, records, options, observer)?;
    fitted.notes.extend(level_consistency(&fitted.each_alone));
    Ok(())
}

fn alone_refits(
    fitted: &TimeFitResult,
    parameters: &ParameterSet,
    records: &[TimeRecord],
    options: &TimeFitOptions,
    observer: Option<&dyn crate::observe::Observer>,
) -> Result<Vec<AloneFit>> {
    let options = TimeFitOptions {
        each_alone: false,
        starts: 1,
        ..options.clone()
    };
    let mut alone = Vec::with_capacity(records.len());
    let n = records.len() as u64;
    for (k, (record, together)) in records.iter().zip(&fitted.after).enumerate() {
        // the stage said between the refits (each one's evaluations are
        // told as a fit's)
        if let Some(o) = observer {
            crate::observe::progress(o, "refitting each recording alone", k as u64, n)?;
        }
        let refit = identify_time(
            &fitted.model,
            parameters.clone(),
            fitted.response_sign,
            std::slice::from_ref(record),
            &options,
            observer,
        );
        alone.push(match refit {
            Ok(r) => AloneFit {
                recording: together.recording.clone(),
                together: together.window.relative,
                alone: r.after.first().map(|a| a.window.relative),
                status: r.status,
                failed: None,
            },
            Err(Error::Cancelled) => return Err(Error::Cancelled),
            Err(e) => AloneFit {
                recording: together.recording.clone(),
                together: together.window.relative,
                alone: None,
                status: FitStatus::Stopped,
                failed: Some(e.to_string()),
            },
        });
    }
    if let Some(o) = observer {
        crate::observe::progress(o, "refitting each recording alone", n, n)?;
    }
    Ok(alone)
}
