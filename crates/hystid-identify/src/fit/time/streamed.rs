//! A model's judged residuals made as its replay comes, a stretch at a time,
//! never held whole.

use super::judging::{JUDGING_HALF_WIDTH, Judging};
use super::problem::TimeProblem;
use super::records::TimeRecord;
use crate::error::{Error, Result};
use crate::model::Model;
use crate::observe::Silent;
use crate::validate::resample::Decimator;
use crate::validate::sum_start;

/// Record `i`'s judged residuals for one model, made as its replay comes
/// and handed out a stretch at a time ([`JudgedResiduals::fill`]): the
/// replay low-passed and decimated to the judging rate as it is made and
/// compared at the judged samples, never held whole. The replay stops once
/// the last judged sample is made (a periodic record judged in part is
/// judged on its first periods). Filled whole it is
/// [`TimeProblem::judged_residuals_into`]; filled a stretch at a time beside
/// the replays of other models, the rows of a Jacobian are folded as they
/// come ([`TimeProblem::jacobian_r_factor`]).
struct JudgedResiduals<'p, 'a> {
    judging: &'p Judging,
    replay: crate::validate::Replay<'p, 'a>,
    decimator: Decimator,
    measured: crate::signals::SampleCursor<'a>,
    /// The judging rate's samples of the replay's last stretch, and how many
    /// of them have been read.
    decimated: Vec<f64>,
    read: usize,
    /// The next sample of the judging rate, the stretch it may lie in, and
    /// the residuals handed out so far.
    q: usize,
    k: usize,
    p: usize,
}

impl<'p, 'a> JudgedResiduals<'p, 'a> {
    fn new(
        problem: &'p TimeProblem<'a>,
        model: &Model,
        i: usize,
        replay_factor: usize,
    ) -> Result<Self> {
        let records: &'a [TimeRecord] = problem.records;
        let r = &records[i];
        let judging = &problem.judging[i];
        Ok(JudgedResiduals {
            judging,
            replay: problem.replay_on(model, i, replay_factor)?,
            decimator: Decimator::new(judging.factor, JUDGING_HALF_WIDTH, r.response.len())?,
            measured: r.response.view().cursor(),
            decimated: Vec::new(),
            read: 0,
            q: 0,
            k: 0,
            p: 0,
        })
    }

    /// Writes the next residuals into `out`, as many as it holds or as are
    /// left; returns how many (fewer than `out.len()` only at the end).
    fn fill(&mut self, out: &mut [f64]) -> Result<usize> {
        let judging = self.judging;
        let (held, stretches) = (judging.measured.as_deref(), &judging.stretches);
        let total = judging.judged();
        let mut written = 0;
        loop {
            while self.read < self.decimated.len() && written < out.len() && self.p < total {
                let s = self.decimated[self.read];
                self.read += 1;
                let q = self.q;
                while self.k < stretches.len() && stretches[self.k].0.end <= q {
                    self.k += 1;
                }
                if self.k < stretches.len() && stretches[self.k].0.start <= q {
                    let m = match held {
                        Some(m) => m[self.p],
                        None => self.measured.get(q),
                    };
                    out[written] = (s - m) / judging.scale[stretches[self.k].1];
                    written += 1;
                    self.p += 1;
                }
                self.q += 1;
            }
            if written == out.len() || self.p == total {
                return Ok(written);
            }
            match self.replay.next_stretch(&Silent)? {
                Some(stretch) => {
                    self.decimated.clear();
                    self.read = 0;
                    self.decimator.push(stretch, &mut self.decimated);
                }
                None => return Ok(written),
            }
        }
    }
}

/// Record `i`'s residuals where the simulator rejects the model, a stretch
/// at a time: worse than predicting nothing (`−2 m/scale` at each judged
/// sample, as [`TimeProblem::residuals_of_into`] writes them).
struct RejectedResiduals<'p, 'a> {
    judging: &'p Judging,
    measured: crate::signals::SampleCursor<'a>,
    /// The judged stretch, the offset in it, the residuals handed out.
    stretch: usize,
    offset: usize,
    p: usize,
}

impl RejectedResiduals<'_, '_> {
    fn fill(&mut self, out: &mut [f64]) -> usize {
        let stretches = &self.judging.stretches;
        let mut written = 0;
        while written < out.len() && self.stretch < stretches.len() {
            let (s, k) = &stretches[self.stretch];
            if self.offset >= s.len() {
                self.stretch += 1;
                self.offset = 0;
                continue;
            }
            let m = match &self.judging.measured {
                Some(m) => m[self.p],
                None => self.measured.get(s.start + self.offset),
            };
            out[written] = -2.0 * m / self.judging.scale[*k];
            written += 1;
            self.offset += 1;
            self.p += 1;
        }
        written
    }
}

/// One record's residuals for a model as they come.
enum RecordResiduals<'p, 'a> {
    Replayed(Box<JudgedResiduals<'p, 'a>>),
    Rejected(RejectedResiduals<'p, 'a>),
}

/// Why a model's residuals a stretch at a time could not go on.
pub(super) enum StreamFailure {
    /// The simulator rejected the model in record `i` after some of its
    /// residuals had been handed out: they are to be made again, as
    /// rejected from the record's start.
    RejectedPartway(usize),
    Error(Error),
}

/// A model's residuals over every record in turn (the residual vector's
/// rows but its penalty), handed out a stretch at a time, a record the
/// simulator rejects as [`TimeProblem::residuals_of_into`] writes it.
pub(super) struct ModelResiduals<'p, 'a> {
    problem: &'p TimeProblem<'a>,
    model: Model,
    /// Records to be taken as rejected from their start.
    rejected: Vec<bool>,
    record: usize,
    current: Option<RecordResiduals<'p, 'a>>,
    /// Residuals of the current record handed out.
    made: usize,
    /// `Σ r²` of every residual handed out, in order.
    pub(super) sum_of_squares: f64,
}

impl<'p, 'a> ModelResiduals<'p, 'a> {
    pub(super) fn new(problem: &'p TimeProblem<'a>, model: Model, rejected: Vec<bool>) -> Self {
        ModelResiduals {
            problem,
            model,
            rejected,
            record: 0,
            current: None,
            made: 0,
            sum_of_squares: sum_start(),
        }
    }

    fn rejected_stream(&self, i: usize) -> RecordResiduals<'p, 'a> {
        let records: &'a [TimeRecord] = self.problem.records;
        RecordResiduals::Rejected(RejectedResiduals {
            judging: &self.problem.judging[i],
            measured: records[i].response.view().cursor(),
            stretch: 0,
            offset: 0,
            p: 0,
        })
    }

    /// Writes the next residuals into `out`; returns how many (fewer than
    /// `out.len()` only at the end).
    pub(super) fn fill(&mut self, out: &mut [f64]) -> std::result::Result<usize, StreamFailure> {
        let problem = self.problem;
        let mut written = 0;
        while written < out.len() && self.record < problem.records.len() {
            let i = self.record;
            let judged = problem.judging[i].judged();
            if self.current.is_none() {
                self.current = Some(if self.rejected[i] {
                    self.rejected_stream(i)
                } else {
                    let stream = problem
                        .replay_factor_of(&self.model, i)
                        .and_then(|factor| JudgedResiduals::new(problem, &self.model, i, factor))
                        .map(|mut s| {
                            // a replay beside every other column's: small buffers
                            s.replay = s.replay.with_stretch(FOLDED_REPLAY_STRETCH);
                            s
                        });
                    match stream {
                        Ok(s) => RecordResiduals::Replayed(Box::new(s)),
                        Err(Error::InvalidModel { .. } | Error::NotConverged { .. }) => {
                            self.rejected_stream(i)
                        }
                        Err(e) => return Err(StreamFailure::Error(e)),
                    }
                });
            }
            let target = &mut out[written..];
            let n = match self.current.as_mut().expect("opened") {
                RecordResiduals::Replayed(s) => match s.fill(target) {
                    Ok(n) => n,
                    Err(Error::InvalidModel { .. } | Error::NotConverged { .. }) => {
                        if self.made > 0 {
                            return Err(StreamFailure::RejectedPartway(i));
                        }
                        self.current = Some(self.rejected_stream(i));
                        continue;
                    }
                    Err(e) => return Err(StreamFailure::Error(e)),
                },
                RecordResiduals::Rejected(s) => s.fill(target),
            };
            self.sum_of_squares = target[..n]
                .iter()
                .fold(self.sum_of_squares, |acc, v| acc + v * v);
            written += n;
            self.made += n;
            if self.made >= judged || n == 0 {
                // a replay that ended short leaves its rows zero, as a
                // residual vector made whole does
                if self.made < judged {
                    let short = (judged - self.made).min(out.len() - written);
                    out[written..written + short].fill(0.0);
                    written += short;
                    self.made += short;
                    if self.made < judged {
                        continue;
                    }
                }
                self.record += 1;
                self.current = None;
                self.made = 0;
            }
        }
        Ok(written)
    }
}

/// Samples of its grid each of the replays side by side in a folded
/// Jacobian makes at a time: a replay's buffers are a few of its stretches,
/// and a Jacobian holds one replay per parameter.
const FOLDED_REPLAY_STRETCH: usize = 1 << 14;

impl TimeProblem<'_> {
    /// [`TimeProblem::judged_residuals_into`] with record `i` replayed at
    /// `replay_factor` times its rate, whatever grid it is fixed on.
    pub(super) fn judged_residuals_on(
        &self,
        model: &Model,
        i: usize,
        replay_factor: usize,
        out: &mut [f64],
    ) -> Result<()> {
        let mut stream = JudgedResiduals::new(self, model, i, replay_factor)?;
        let made = stream.fill(out)?;
        debug_assert_eq!(made, out.len());
        Ok(())
    }
}
