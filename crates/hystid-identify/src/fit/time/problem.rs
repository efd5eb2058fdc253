//! The replay of recordings through a model whose free parameters are varied:
//! the time-domain fit's problem, its replays, errors and residuals.

use super::judging::{Judging, judged_stretches, judging_factors};
use super::options::TimeFitOptions;
use super::records::TimeRecord;
use super::results::RecordError;
use crate::error::{Error, Result};
use crate::fit::params::ParameterSet;
use crate::model::Model;
use crate::observe::Silent;
use crate::validate::resample::MAX_FACTOR;
use crate::validate::{
    PreparedDrive, error_metrics_of_sum, error_window, quasi_static_above_hz, sum_start,
    upsampling_factor,
};
use std::ops::Range;
use std::sync::atomic::{AtomicUsize, Ordering};

/// A time fit whose Jacobian would hold more entries than this (judged
/// samples times parameters: 32 MiB) has it folded into the R factor of
/// `[r J]` as its rows are made, never held (see
/// [`Objective::folds_jacobian`]): a long recording's Jacobian was the
/// largest thing its fit held, and grew with every parameter a diagnosis
/// adds.
pub const JACOBIAN_HELD_UP_TO: usize = 1 << 22;

/// The replay of recordings through a model whose free parameters are
/// varied.
pub struct TimeProblem<'a> {
    base: Model,
    pub(super) parameters: ParameterSet,
    pub(super) records: &'a [TimeRecord],
    sign: f64,
    options: TimeFitOptions,
    /// `RMS_s · √N_s` per segment of each recording: the reported errors'
    /// divisor.
    scale: Vec<Vec<f64>>,
    /// How each recording is judged (see [`TimeFitOptions::max_judged_samples`]).
    pub(super) judging: Vec<Judging>,
    /// Each recording's force, prepared once per upsampling factor.
    drives: Vec<PreparedDrive<'a>>,
    /// Each recording's replay grid, as its upsampling factor; `None`: the
    /// sure rate of each model replayed (see [`TimeProblem::fix_replay_grid`]).
    replay_factor: Vec<Option<usize>>,
    /// What choosing those rates found, for the fit's notes.
    rate_notes: Vec<String>,
    pub(super) evaluations: AtomicUsize,
    /// Residual vectors computed (each a replay of every recording).
    pub(super) replays: AtomicUsize,
    pub(super) observer: Option<&'a dyn crate::observe::Observer>,
    /// A Jacobian of more entries is folded as it is made (see
    /// [`JACOBIAN_HELD_UP_TO`]).
    pub(super) jacobian_held_up_to: usize,
}

impl<'a> TimeProblem<'a> {
    /// A problem; checks every record.
    pub fn new(
        base: Model,
        parameters: ParameterSet,
        records: &'a [TimeRecord],
        sign: f64,
        options: TimeFitOptions,
        observer: Option<&'a dyn crate::observe::Observer>,
    ) -> Result<TimeProblem<'a>> {
        if records.is_empty() {
            return Err(Error::input("recordings", "none given"));
        }
        for r in records {
            r.check()?;
        }
        let scale: Vec<Vec<f64>> = records
            .iter()
            .map(|r| {
                r.segments
                    .iter()
                    .map(|s| r.measured_rms(s.clone()) * (s.len() as f64).sqrt())
                    .collect()
            })
            .collect();
        let drives = records
            .iter()
            .map(|r| PreparedDrive::new(&r.reference, options.input))
            .collect();
        // a mode above twice the slowest recording's rate is replayed
        // quasi-statically in every one (see `validate`): held
        let slowest = records
            .iter()
            .map(|r| r.sample_rate_hz)
            .fold(f64::INFINITY, f64::min);
        let quasi_static = quasi_static_above_hz(slowest);
        let (parameters, rate_notes) = parameters.for_replay(&base, quasi_static);
        let factors = judging_factors(
            records,
            base.highest_replayed_frequency_hz(quasi_static),
            options.max_judged_samples,
        );
        let at_rate: Vec<Vec<Range<usize>>> = records
            .iter()
            .zip(&factors)
            .map(|(r, &k)| Judging::segments_at(r, k))
            .collect();
        let total = at_rate.iter().flatten().map(|s| s.len()).sum();
        let judging = records
            .iter()
            .zip(&scale)
            .zip(factors)
            .zip(&at_rate)
            .map(|(((r, scale), k), segments)| {
                let stretches =
                    judged_stretches(segments, total, options.max_judged_samples, r.periodic);
                Judging::of(r, scale, k, stretches)
            })
            .collect::<Result<_>>()?;
        Ok(TimeProblem {
            replay_factor: vec![None; records.len()],
            rate_notes,
            drives,
            judging,
            base,
            parameters,
            records,
            sign,
            options,
            scale,
            evaluations: AtomicUsize::new(0),
            replays: AtomicUsize::new(0),
            observer,
            jacobian_held_up_to: JACOBIAN_HELD_UP_TO,
        })
    }

    /// The problem with its Jacobian folded as it is made where it would
    /// hold more than `entries` (see [`JACOBIAN_HELD_UP_TO`]; 0: always).
    pub fn with_jacobian_held_up_to(mut self, entries: usize) -> Self {
        self.jacobian_held_up_to = entries;
        self
    }

    /// Chooses each recording's replay rate by what it changes, measured on
    /// the start model, and fixes it for the fit (a problem made only to
    /// report errors keeps the sure rate of each model it replays rather
    /// than pay for the choice). See [`TimeProblem::fix_replay_grid`].
    pub fn choose_replay_rates(&mut self) {
        let start = self.base.clone();
        self.fix_replay_grid(&start, "start");
    }

    /// Fixes each recording's replay grid (its upsampling factor) for
    /// `model`; returns whether any grid became finer than the one it had.
    ///
    /// The grid is fixed while the fit moves the parameters. The upsampling
    /// follows the model's highest linearised frequency, so a grid that
    /// followed each trial model would make the misfit jump wherever the
    /// factor steps (a finite-difference Jacobian across a step is noise),
    /// and a further mode or a stick stiffness the fit drives upwards would
    /// make every replay dearer: a four-level F-16 fit whose broad mode
    /// climbed from 12 to 265 Hz went from 2 to 27 times the recordings'
    /// rate and had not finished its first Jacobian after ten minutes. The
    /// fit instead checks its optimum (see [`identify_time`]): where that
    /// model needs a finer grid, the fit is resumed from the optimum on it.
    ///
    /// The rate [`TimeFitOptions::min_samples_per_period`] asks for is sure
    /// but can be costly: a further mode far above the band (its frequency
    /// unresolved, its flexibility all the band sees) can ask for ten times
    /// the recording's rate and make a fit of a long recording take minutes
    /// per iteration, while replays at the recording's own rate differ by a
    /// trifle. So `model` is replayed at that rate and at coarser ones (2.5,
    /// 5, 10, 20 samples per period), and the coarsest whose response
    /// differs from the sure one by at most 0.2 % of the model's own misfit
    /// (both in the fit's segment weighting, over the samples it judges) is
    /// used. At 1 % a joint's stick stiffness ended 2 % further from the
    /// truth than at the sure rate on
    /// an independent recording (a Masing joint with kd 2.7 times the
    /// structure's stiffness, a further mode fitted at 5 times the band's
    /// top): the misfit is mostly noise, the discretisation's change is
    /// not, and the fit follows it. The sure rate is capped at
    /// [`crate::validate::resample::MAX_FACTOR`] times the recording's: a
    /// model stiffer than that is still replayed, on the finest grid there
    /// is. A grid already at least as fine as the one chosen is kept.
    pub fn fix_replay_grid(&mut self, model: &Model, which: &str) -> bool {
        let mut finer = false;
        for i in 0..self.records.len() {
            let (chosen, note) = self.coarsest_grid(model, i, which);
            match self.replay_factor[i] {
                Some(used) if used >= chosen => {}
                previous => {
                    finer |= previous.is_some();
                    self.replay_factor[i] = Some(chosen);
                    self.rate_notes.extend(note);
                }
            }
        }
        finer
    }

    /// The coarsest upsampling of record `i` that replays `model` as its
    /// sure rate does (see [`TimeProblem::fix_replay_grid`]), with a note
    /// when it is coarser than the sure one.
    fn coarsest_grid(&self, model: &Model, i: usize, which: &str) -> (usize, Option<String>) {
        const LADDER: [f64; 4] = [2.5, 5.0, 10.0, 20.0];
        let sure = self.options.min_samples_per_period;
        let r = &self.records[i];
        let top = model.highest_replayed_frequency_hz(quasi_static_above_hz(r.sample_rate_hz));
        let factor =
            |spp: f64| ((spp * top / r.sample_rate_hz).ceil().max(1.0) as usize).min(MAX_FACTOR);
        // what the fit judges (its replays stop at the last judged sample;
        // never a whole replay held)
        let judged = self.judging[i].judged();
        let residuals = |f: usize| {
            let mut out = vec![0.0; judged];
            self.judged_residuals_on(model, i, f, &mut out)
                .ok()
                .map(|()| out)
        };
        let sure_factor = factor(sure);
        let Some(fine) = (sure_factor > 1).then(|| residuals(sure_factor)).flatten() else {
            return (sure_factor, None);
        };
        let norm = |v: &mut dyn Iterator<Item = f64>| v.map(|x| x * x).sum::<f64>().sqrt();
        let misfit = norm(&mut fine.iter().copied());
        let mut tried = 0;
        for spp in LADDER.into_iter().filter(|&spp| spp < sure) {
            // the same factor as one tried already, or as the sure one:
            // nothing new
            let f = factor(spp);
            if f <= tried || f >= sure_factor {
                continue;
            }
            tried = f;
            let Some(coarse) = residuals(f) else { continue };
            let change = norm(&mut coarse.iter().zip(&fine).map(|(c, f)| c - f));
            if change <= 0.002 * misfit {
                let note = format!(
                    "{}: replayed at {f} times its rate, not {sure_factor}: that changes the \
                     {which} model's response by {:.2} % of its misfit",
                    r.name,
                    100.0 * change / misfit.max(f64::MIN_POSITIVE)
                );
                return (f, Some(note));
            }
        }
        (sure_factor, None)
    }

    /// The model at `theta` and its distance outside the bounds.
    pub fn model_at(&self, theta: &[f64]) -> Result<(Model, f64)> {
        self.parameters.model_at(&self.base, theta)
    }

    /// Record `i`'s replay grid for `model`, as its upsampling factor.
    pub(super) fn replay_factor_of(&self, model: &Model, i: usize) -> Result<usize> {
        match self.replay_factor[i] {
            Some(f) => Ok(f),
            None => {
                let r = &self.records[i];
                upsampling_factor(model, r.sample_rate_hz, self.options.min_samples_per_period)
            }
        }
    }

    /// `model`'s replay of record `i`, made a stretch at a time as it is
    /// pulled (see [`crate::validate::Replay`]), on the record's replay grid.
    pub fn replay_of(&self, model: &Model, i: usize) -> Result<crate::validate::Replay<'_, 'a>> {
        self.replay_on(model, i, self.replay_factor_of(model, i)?)
    }

    /// [`TimeProblem::replay_of`] at `factor` times the record's rate: every
    /// replay the fit compares is made here, through the response's
    /// acquisition chain where one is declared.
    pub(super) fn replay_on(
        &self,
        model: &Model,
        i: usize,
        factor: usize,
    ) -> Result<crate::validate::Replay<'_, 'a>> {
        let r = &self.records[i];
        let rate = (r.sample_rate_hz, factor);
        crate::validate::Replay::new(model, &self.drives[i], rate, r.quantity, self.sign)?
            .with_acquisition(self.options.acquisition.as_ref())
    }

    /// The records, in order.
    pub fn records(&self) -> &'a [TimeRecord] {
        self.records
    }

    /// `model`'s simulated response to record `i`, every sample.
    pub fn replay(&self, model: &Model, i: usize) -> Result<Vec<f64>> {
        let mut whole = Vec::with_capacity(self.records[i].response.len());
        self.replay_by_stretch(model, i, &mut |stretch| {
            whole.extend_from_slice(stretch);
            Ok(())
        })?;
        Ok(whole)
    }

    /// `model`'s simulated response to record `i` handed to `sink` a
    /// stretch at a time, on the record's replay grid (see
    /// [`crate::validate::Replay`]; through the response's acquisition chain where one is declared).
    fn replay_by_stretch(
        &self,
        model: &Model,
        i: usize,
        sink: &mut dyn FnMut(&[f64]) -> Result<()>,
    ) -> Result<()> {
        // through the response's acquisition chain, if declared
        let mut replay = self.replay_of(model, i)?;
        while let Some(stretch) = replay.next_stretch(&Silent)? {
            sink(stretch)?;
        }
        Ok(())
    }

    /// Record `i`'s residuals for `model` (its judged samples inside its
    /// segments, in order) written into `out`: the replay low-passed and
    /// decimated to the judging rate as it is made, and compared as it
    /// comes (no replay held whole, see [`crate::validate::Replay`]); the
    /// same residuals to the bit as the whole replay decimated and
    /// compared. The replay stops once the last judged sample is made (a
    /// periodic record judged in part is judged on its first periods).
    fn judged_residuals_into(&self, model: &Model, i: usize, out: &mut [f64]) -> Result<()> {
        let factor = self.replay_factor_of(model, i)?;
        self.judged_residuals_on(model, i, factor, out)
    }

    /// `model`'s simulated response to every recording, every sample (in
    /// the recordings' order).
    pub fn replays_of(&self, model: &Model) -> Result<Vec<Vec<f64>>> {
        (0..self.records.len())
            .map(|i| self.replay(model, i))
            .collect()
    }

    /// Each recording's error figures with `model`.
    pub fn errors(&self, model: &Model) -> Result<Vec<RecordError>> {
        self.errors_with(model, false)
    }

    /// [`TimeProblem::errors`], each window's error split by frequency about
    /// its record's band, where it has one (an FFT of the window each: for
    /// a fit's final report, not for every replay).
    pub fn errors_by_frequency(&self, model: &Model) -> Result<Vec<RecordError>> {
        self.errors_with(model, true)
    }

    /// Each recording's replay is compared as it is made, a stretch at a
    /// time (a copy of the response each, two at once, would be most of
    /// what a time fit of a long recording holds), but where its error is
    /// split by frequency (an FFT of the window, which needs it whole).
    fn errors_with(&self, model: &Model, split: bool) -> Result<Vec<RecordError>> {
        // the sums start where `Iterator::sum` starts them: the same bits
        // as summing the whole replay
        let zero = sum_start();
        self.records
            .iter()
            .zip(&self.scale)
            .enumerate()
            .map(|(i, (r, scale))| {
                let split = split && r.band_hz.is_some();
                let n = r.response.len();
                let (a, b) = error_window(r.window.clone(), n)?;
                // the split tallied as the replay comes (an error making it
                // is reported only where there is a response to split)
                let mut by_frequency = r.band_hz.filter(|_| split).map(|band| {
                    let w = r.window.start.min(n)..r.window.end.min(n);
                    crate::validate::FrequencySplit::new(
                        r.response.view(),
                        r.sample_rate_hz,
                        w,
                        band,
                    )
                });
                // by segment, and over the window
                let mut segments = vec![zero; r.segments.len()];
                let mut window = zero;
                let mut at = 0;
                self.replay_by_stretch(model, i, &mut |stretch| {
                    let end = at + stretch.len();
                    // the measured stretch read once (a long channel is
                    // held in a scratch file)
                    let measured = r.response.range(at..end.min(n));
                    for ((seg, sc), sum) in r.segments.iter().zip(scale).zip(&mut segments) {
                        let (lo, hi) = (seg.start.max(at), seg.end.min(end));
                        *sum = (lo..hi).fold(*sum, |acc, j| {
                            acc + ((stretch[j - at] - measured[j - at]) / sc).powi(2)
                        });
                    }
                    let (lo, hi) = (a.max(at), b.min(end));
                    window = (lo..hi).fold(window, |acc, j| {
                        acc + (stretch[j - at] - measured[j - at]).powi(2)
                    });
                    if let Some(Ok(split)) = &mut by_frequency {
                        let m = measured.len();
                        split.push(at, &measured, &stretch[..m])?;
                    }
                    at = end;
                    Ok(())
                })?;
                let sum = segments.iter().fold(zero, |acc, s| acc + s);
                let mut window = error_metrics_of_sum(&r.response, window, r.sample_rate_hz, a..b);
                if let Some(split) = by_frequency
                    && window.measured_rms > 0.0
                {
                    window.by_frequency = Some(split?.finish());
                }
                Ok(RecordError {
                    recording: r.name.clone(),
                    window,
                    segments: r.segments.len(),
                    segment_relative: (sum / r.segments.len() as f64).sqrt(),
                })
            })
            .collect()
    }

    /// `model`'s misfit over what is judged: per recording, the mean over
    /// its judged segments of each one's relative error squared, summed
    /// over the recordings (with every sample judged, the sum of
    /// [`RecordError::segment_relative`] squared). A start is chosen by it:
    /// it is what the fit minimises, and a replay stops at the last sample
    /// judged (a long periodic record's first periods).
    pub fn judged_misfit(&self, model: &Model) -> Result<f64> {
        let mut misfit = 0.0;
        for (i, judging) in self.judging.iter().enumerate() {
            let mut out = vec![0.0; judging.judged()];
            self.judged_residuals_into(model, i, &mut out)?;
            let mut segments: Vec<usize> = judging.stretches.iter().map(|(_, k)| *k).collect();
            segments.dedup();
            misfit += out.iter().map(|v| v * v).sum::<f64>() / segments.len().max(1) as f64;
        }
        Ok(misfit)
    }

    /// The misfit at `theta` without the bounds' penalty: `Σ r²` of the
    /// model whose parameters are held at their bounds (what the fit's
    /// result is), comparable between fits that leave `θ` beyond a bound
    /// by different amounts.
    pub fn misfit(&self, theta: &[f64]) -> Result<f64> {
        let (model, _) = self.model_at(theta)?;
        let r = self.residuals_of(&model, 0.0)?;
        Ok(r[..r.len() - 1].iter().map(|v| v * v).sum())
    }

    fn residuals_of(&self, model: &Model, outside: f64) -> Result<Vec<f64>> {
        let judged: usize = self.judged_samples().iter().sum();
        let mut out = vec![0.0; judged + 1];
        self.residuals_of_into(model, outside, &mut out)?;
        Ok(out)
    }

    /// [`TimeProblem::residuals_of`] written into `out` (as long as the
    /// judged samples, and the penalty row).
    fn residuals_of_into(&self, model: &Model, outside: f64, out: &mut [f64]) -> Result<()> {
        let mut at = 0;
        for (i, (r, judging)) in self.records.iter().zip(&self.judging).enumerate() {
            let n = judging.judged();
            let block = &mut out[at..at + n];
            match self.judged_residuals_into(model, i, block) {
                Ok(()) => {}
                // a model the simulator rejects: worse than predicting nothing
                Err(Error::InvalidModel { .. } | Error::NotConverged { .. }) => {
                    let mut p = 0;
                    judging.for_each_measured(r, |k, m| {
                        block[p] = -2.0 * m / judging.scale[k];
                        p += 1;
                    });
                }
                Err(e) => return Err(e),
            }
            at += n;
        }
        let rms = (out[..at].iter().map(|v| v * v).sum::<f64>() / at.max(1) as f64).sqrt();
        out[at] = outside * 10.0 * rms * (at as f64).sqrt();
        Ok(())
    }

    /// [`Objective::residuals`] written into `out` (as long as the judged
    /// samples and the penalty row). Every set of replays is shown to the
    /// observer (Levenberg–Marquardt and its Jacobian ask for residuals
    /// only, and a fit of long recordings spends minutes there), numbered
    /// by [`TimeProblem::replays`]; the optimiser's count of evaluations
    /// stays its own.
    pub(super) fn residuals_into(&self, theta: &[f64], out: &mut [f64]) -> Result<()> {
        if self.observer.is_some_and(|o| o.cancelled()) {
            return Err(Error::Cancelled);
        }
        let (model, outside) = self.model_at(theta)?;
        self.residuals_of_into(&model, outside, out)?;
        let replay = self.replays.fetch_add(1, Ordering::Relaxed) + 1;
        if let Some(o) = self.observer {
            let entry = crate::observe::TraceEntry {
                evaluation: replay,
                cost: out.iter().map(|v| v * v).sum::<f64>(),
                parameters: self.parameters.values(theta),
            };
            o.observe(crate::observe::Event::Cost(&entry));
        }
        Ok(())
    }

    /// Each recording's replay grid as its upsampling factor (`None`: the
    /// sure rate of each model replayed; see
    /// [`TimeProblem::fix_replay_grid`]).
    pub fn replay_factors(&self) -> &[Option<usize>] {
        &self.replay_factor
    }

    /// What choosing the replay rates found (one note per coarser rate).
    pub fn replay_notes(&self) -> &[String] {
        &self.rate_notes
    }

    /// Each recording's judged samples (see
    /// [`TimeFitOptions::max_judged_samples`]).
    pub fn judged_samples(&self) -> Vec<usize> {
        self.judging.iter().map(Judging::judged).collect()
    }

    /// Whether some recording is judged on stretches of its segments only
    /// (see [`judged_stretches`]).
    pub fn judged_in_part(&self) -> bool {
        self.judging.iter().zip(self.records).any(|(j, r)| {
            j.judged()
                < Judging::segments_at(r, j.factor)
                    .iter()
                    .map(|s| s.len())
                    .sum()
        })
    }

    /// Each recording's judging factor: its response judged at `1/k` of its
    /// rate (1: every sample; see [`TimeFitOptions::max_judged_samples`]).
    pub fn judging_factors(&self) -> Vec<usize> {
        self.judging.iter().map(|j| j.factor).collect()
    }

    /// How many residual vectors (replays of every recording) were
    /// computed.
    pub fn replays(&self) -> usize {
        self.replays.load(Ordering::Relaxed)
    }

    /// The free parameters.
    pub fn parameters(&self) -> &ParameterSet {
        &self.parameters
    }
}
