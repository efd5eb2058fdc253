//! The measured data, the model's prediction of it, and the cost of paper
//! eq. (9): `ε = ||H_measured − H_model||₂` stacked over levels, frequencies
//! and the harmonics used, optionally weighted by the measured standard
//! errors.

use super::optimise::{Objective, forward_difference};
use super::params::ParameterSet;
use crate::error::{Error, Result};
use crate::extract::{Direction, NonlinearFrf};
use crate::harmonics::Quantity;
use crate::model::Model;
use crate::observe::TraceEntry;
use nalgebra::DMatrix;
use num_complex::Complex64;
use serde::{Deserialize, Serialize};
use std::sync::Mutex;
use std::sync::atomic::{AtomicUsize, Ordering};

/// One measured point.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct MeasuredPoint {
    /// Hz.
    pub frequency_hz: f64,
    /// Measured `|F_1|`, N.
    pub force_amplitude: f64,
    /// `H_h` for each harmonic of [`FitData::harmonics`].
    pub h: Vec<Complex64>,
    /// Standard error of each.
    pub std_error: Vec<f64>,
    /// Blocks the standard errors were estimated from (0: unknown).
    #[serde(default)]
    pub blocks: usize,
}

/// The points of one level (one sweep), in measurement order.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct MeasuredSeries {
    /// Nominal level.
    pub level: f64,
    /// Sweep direction.
    pub direction: Direction,
    /// Points in measurement order.
    pub points: Vec<MeasuredPoint>,
}

/// What a fit is fitted to.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct FitData {
    /// Response quantity of `H`.
    pub response: Quantity,
    /// Harmonics used in the cost (1 = fundamental).
    pub harmonics: Vec<usize>,
    /// The series.
    pub series: Vec<MeasuredSeries>,
    /// The measured `H` were multiplied by this (−1 for a transfer FRF with a
    /// negative modal constant, so the model's modal constant is positive).
    #[serde(default = "plus_one")]
    pub response_sign: f64,
    /// The response is not at the driving point, so a mode's modal constant
    /// may take either sign: stated by the user, or implied by a negative
    /// first modal constant (which no driving point has).
    #[serde(default)]
    pub transfer: bool,
    /// Measured points left out because they carry no usable information:
    /// a fundamental of exactly zero or a zero or non-finite standard error
    /// (a response below the recording's resolution, e.g. a PCM16 file whose
    /// lowest level stays within one step of the converter).
    #[serde(default)]
    pub unusable_points: usize,
    /// Dwells left out because the response repeated only every 2 or 3
    /// drive periods ([`crate::extract::subharmonic`]), which harmonic
    /// balance at the drive's period cannot describe.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub subharmonic_points: Vec<SubharmonicPoint>,
    /// What the smallest level's linear estimate allows the first mode's
    /// `m, c, k` (see [`super::anchor`]); none where it could not be made.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub anchor: Option<super::anchor::LinearAnchor>,
}

/// Whether a measured point can be weighed: a non-zero, finite fundamental
/// and finite, positive standard errors for every harmonic in `harmonics`,
/// and no subharmonic response (which a harmonic-balance model at the
/// drive's period cannot describe).
pub fn usable_point(p: &crate::extract::FrfPoint, harmonics: &[usize]) -> bool {
    let h1 = p.h.get(1).copied().unwrap_or_default();
    p.subharmonic.is_none()
        && p.frequency_hz > 0.0
        && h1.norm() > 0.0
        && h1.re.is_finite()
        && h1.im.is_finite()
        && harmonics.iter().all(|&k| {
            p.h.get(k)
                .is_some_and(|h| h.re.is_finite() && h.im.is_finite())
                && p.std_error
                    .get(k)
                    .is_some_and(|s| s.is_finite() && *s > 0.0)
        })
}

/// A measured dwell left out of the harmonic-balance fit for its
/// subharmonic response.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct SubharmonicPoint {
    /// Nominal level of its series.
    pub level: f64,
    /// Drive frequency, Hz.
    pub frequency_hz: f64,
    /// What was measured.
    pub subharmonic: crate::extract::Subharmonic,
}

impl SubharmonicPoint {
    /// One sentence on the dwells left out for their subharmonic response
    /// (none when there are none).
    pub fn describe(points: &[SubharmonicPoint]) -> Option<String> {
        let first = points.first()?;
        let (mut lo, mut hi, mut top) = (first.frequency_hz, first.frequency_hz, 0.0f64);
        let mut orders = Vec::new();
        for p in points {
            lo = lo.min(p.frequency_hz);
            hi = hi.max(p.frequency_hz);
            top = top.max(p.subharmonic.ratio);
            if !orders.contains(&p.subharmonic.order) {
                orders.push(p.subharmonic.order);
            }
        }
        orders.sort_unstable();
        let at: Vec<String> = orders.iter().map(|q| format!("f/{q}")).collect();
        Some(format!(
            "{} dwell(s) between {lo:.4} and {hi:.4} Hz responded at {} (up to {:.0} % of the \
             fundamental): the response repeats only every {} drive periods, as a one-sided \
             contact driven near a multiple of its natural frequency does, which harmonic \
             balance at the drive's period cannot describe; they were left out of the fit \
             (a time-domain fit keeps them).",
            points.len(),
            at.join(" and "),
            100.0 * top,
            orders
                .iter()
                .map(|q| q.to_string())
                .collect::<Vec<_>>()
                .join(" or "),
        ))
    }
}

fn plus_one() -> f64 {
    1.0
}

impl FitData {
    /// Selects harmonics, a frequency band and levels from measured FRFs.
    ///
    /// `levels` are indices into `frf.levels` (all when `None`).
    pub fn from_frf(
        frf: &NonlinearFrf,
        harmonics: &[usize],
        band_hz: Option<(f64, f64)>,
        levels: Option<&[usize]>,
    ) -> Result<FitData> {
        if harmonics.is_empty() {
            return Err(Error::plan(
                "harmonics",
                "at least one harmonic must be fitted",
            ));
        }
        if let Some(&h) = harmonics.iter().find(|&&h| h > frf.max_harmonic) {
            return Err(Error::plan(
                "harmonics",
                format!("harmonic {h} was not extracted (max {})", frf.max_harmonic),
            ));
        }
        let mut series = Vec::new();
        let mut unusable_points = 0;
        let mut subharmonic_points = Vec::new();
        for (i, l) in frf.levels.iter().enumerate() {
            if levels.is_some_and(|ls| !ls.contains(&i)) {
                continue;
            }
            let points: Vec<MeasuredPoint> = l
                .points
                .iter()
                .filter(|p| {
                    band_hz.is_none_or(|(lo, hi)| p.frequency_hz >= lo && p.frequency_hz <= hi)
                })
                .filter(|p| {
                    let ok = usable_point(p, harmonics);
                    match p.subharmonic {
                        Some(subharmonic) => subharmonic_points.push(SubharmonicPoint {
                            level: l.level,
                            frequency_hz: p.frequency_hz,
                            subharmonic,
                        }),
                        None => unusable_points += usize::from(!ok),
                    }
                    ok
                })
                .map(|p| MeasuredPoint {
                    frequency_hz: p.frequency_hz,
                    force_amplitude: p.force_amplitude,
                    h: harmonics.iter().map(|&k| p.h[k]).collect(),
                    std_error: harmonics.iter().map(|&k| p.std_error[k]).collect(),
                    blocks: p.blocks,
                })
                .collect();
            if !points.is_empty() {
                series.push(MeasuredSeries {
                    level: l.level,
                    direction: l.direction,
                    points,
                });
            }
        }
        if series.is_empty() {
            return Err(Error::plan(
                "band",
                "no measured points in the selected band and levels",
            ));
        }
        Ok(FitData {
            response: frf.response,
            harmonics: harmonics.to_vec(),
            series,
            response_sign: 1.0,
            transfer: false,
            unusable_points,
            subharmonic_points,
            anchor: None,
        })
    }

    /// Multiplies every measured `H` by `sign` (see [`FitData::response_sign`]).
    pub fn with_sign(mut self, sign: f64) -> FitData {
        if sign != 1.0 {
            for s in &mut self.series {
                for p in &mut s.points {
                    p.h.iter_mut().for_each(|h| *h *= sign);
                }
            }
        }
        self.response_sign *= sign;
        self.transfer |= sign < 0.0;
        self
    }

    /// States that the response is not at the driving point (`true`; see
    /// [`FitData::transfer`]).
    pub fn with_transfer(mut self, transfer: bool) -> FitData {
        self.transfer |= transfer;
        self
    }

    /// The data with the first mode's `m, c, k` anchored (see
    /// [`super::anchor`]).
    pub fn with_anchor(mut self, anchor: Option<super::anchor::LinearAnchor>) -> FitData {
        self.anchor = anchor;
        self
    }

    /// Whether `model`, predicting `pred`, went astray from the data's
    /// anchor: its first mode at the ends of the anchor's range, or the
    /// smallest level's FRF missed far beyond that level's linear fit
    /// (see [`Astray`]).
    pub fn astray(&self, model: &Model, pred: &Prediction) -> Option<Astray> {
        let anchor = self.anchor?;
        let parameters = anchor.astray_in(model);
        let smallest_level_residual = lowest_level_residual(self, pred)
            .filter(|r| *r > LOWEST_LEVEL_SLACK * anchor.residual + LOWEST_LEVEL_MARGIN)
            .map(|r| [r, anchor.residual]);
        (!parameters.is_empty() || smallest_level_residual.is_some()).then(|| Astray {
            parameters,
            anchor: anchor.describe(),
            smallest_level_residual,
        })
    }

    /// `set` bounded by the data's anchor, if any (see
    /// [`super::anchor::LinearAnchor::bound`]).
    pub fn anchored(
        &self,
        set: super::params::ParameterSet,
        start: &Model,
    ) -> super::params::ParameterSet {
        match &self.anchor {
            Some(a) => a.bound(set, start),
            None => set,
        }
    }

    /// Number of complex observations.
    pub fn observations(&self) -> usize {
        self.series.iter().map(|s| s.points.len()).sum::<usize>() * self.harmonics.len()
    }

    /// Index of harmonic `h` in [`FitData::harmonics`].
    pub fn harmonic_index(&self, h: usize) -> Option<usize> {
        self.harmonics.iter().position(|&k| k == h)
    }

    /// The lowest and highest excitation frequency, Hz (`None` without
    /// points).
    pub fn band_hz(&self) -> Option<(f64, f64)> {
        let f = self
            .series
            .iter()
            .flat_map(|s| &s.points)
            .map(|p| p.frequency_hz);
        let lo = f.clone().fold(f64::INFINITY, f64::min);
        let hi = f.fold(0.0, f64::max);
        (lo.is_finite() && hi >= lo).then_some((lo, hi))
    }
}

/// A fit led astray: its first mode's parameters at the bounds its anchor
/// sets, or the smallest level's FRF missed by far more than that level's
/// own linear fit misses it.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Astray {
    /// The parameters at an anchored bound (`mass`, `stiffness`, `damping`).
    pub parameters: Vec<String>,
    /// The anchor, as a sentence.
    pub anchor: String,
    /// The smallest level's RMS relative residual: the model's and its
    /// linear fit's, where the model's is the larger by far.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub smallest_level_residual: Option<[f64; 2]>,
}

impl Astray {
    /// What went astray, as a clause ("its mass at the bound ... allows").
    pub fn describe(&self) -> String {
        let mut parts = Vec::new();
        if !self.parameters.is_empty() {
            parts.push(format!(
                "its {} at or beyond the range {} allows",
                self.parameters.join(", "),
                self.anchor
            ));
        }
        if let Some([model, linear]) = self.smallest_level_residual {
            parts.push(format!(
                "the smallest level's FRF missed by {:.1} % (RMS), where that level's linear fit misses it by {:.1} %",
                100.0 * model,
                100.0 * linear
            ));
        }
        parts.join("; ")
    }
}

/// How much further a joint model may sit from the smallest level's FRF
/// than that level's own linear fit (an RMS of relative residuals) before
/// the fit counts as astray: the model holds that linear fit (its joint
/// stuck), so a fit of every level trades away at most a little of it.
const LOWEST_LEVEL_SLACK: f64 = 2.0;
const LOWEST_LEVEL_MARGIN: f64 = 0.02;

/// The RMS over the smallest level's points of `|H1 − H1_model| / |H1|`
/// (the definition of [`super::linear::SdofEstimate::relative_rms_residual`]).
fn lowest_level_residual(data: &FitData, pred: &Prediction) -> Option<f64> {
    let k = data.harmonic_index(1)?;
    let (i, series) = data
        .series
        .iter()
        .enumerate()
        .min_by(|a, b| a.1.level.total_cmp(&b.1.level))?;
    let relative: Vec<f64> = series
        .points
        .iter()
        .zip(pred.h.get(i)?)
        .filter_map(|(p, m)| Some(((p.h[k] - m.as_ref()?[k]).norm() / p.h[k].norm()).powi(2)))
        .collect();
    (!relative.is_empty()).then(|| (relative.iter().sum::<f64>() / relative.len() as f64).sqrt())
}

/// The model's FRFs at the measured points.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Prediction {
    /// `[series][point][harmonic]`, as in [`FitData`]; `None` where the
    /// model's solve failed.
    pub h: Vec<Vec<Option<Vec<Complex64>>>>,
    /// Harmonic-balance points solved.
    pub solves: usize,
    /// The solver's state per point (its displacement harmonics), for warm
    /// starts of the next prediction; empty if the predictor keeps none.
    pub states: Vec<Vec<Option<Vec<Complex64>>>>,
    /// The harmonic balance's samples per period (0: not balanced), which
    /// a Jacobian's columns keep (see [`FrfPredictor::predict_near`]).
    pub samples_per_period: usize,
}

impl Prediction {
    /// A prediction in which every point failed (a model that cannot be
    /// built or solved at all).
    pub fn failed(data: &FitData) -> Prediction {
        Prediction {
            h: data
                .series
                .iter()
                .map(|s| vec![None; s.points.len()])
                .collect(),
            solves: 0,
            states: Vec::new(),
            samples_per_period: 0,
        }
    }

    /// Points whose solve failed.
    pub fn failures(&self) -> usize {
        self.h.iter().flatten().filter(|p| p.is_none()).count()
    }
}

/// Computes a model's FRFs at the measured points.
pub trait FrfPredictor: Sync {
    /// The prediction of `model` for `data`.
    fn predict(&self, model: &Model, data: &FitData) -> Result<Prediction> {
        self.predict_from(model, data, None)
    }

    /// The same, warm-started from a nearby model's prediction (its
    /// `states`); the result must not depend on the start beyond the
    /// solver's tolerance.
    fn predict_from(
        &self,
        model: &Model,
        data: &FitData,
        start: Option<&Prediction>,
    ) -> Result<Prediction>;

    /// The prediction of a model a difference step away from the one
    /// `start` was predicted for: as [`FrfPredictor::predict_from`], but a
    /// point whose start already meets the solver's tolerance must still
    /// move with the step (a harmonic-balance point takes one Newton step),
    /// or a derivative by differences reads zero where the model changed.
    fn predict_near(
        &self,
        model: &Model,
        data: &FitData,
        start: &Prediction,
    ) -> Result<Prediction> {
        self.predict_from(model, data, Some(start))
    }
}

/// How residuals are scaled.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Weighting {
    /// The paper's eq. (9): plain differences.
    #[default]
    None,
    /// Differences divided by the measured standard errors.
    StandardError,
}

/// Stacked real residuals `[Re, Im]` per point and harmonic.
pub fn residuals(data: &FitData, pred: &Prediction, weighting: Weighting) -> Vec<f64> {
    let mut r = Vec::with_capacity(2 * data.observations());
    for (s, ps) in data.series.iter().zip(&pred.h) {
        for (p, model) in s.points.iter().zip(ps) {
            for k in 0..data.harmonics.len() {
                // a failed solve counts worse than predicting nothing, so an
                // optimiser is not drawn into parameters where the model fails
                let m = model.as_ref().map_or(-2.0 * p.h[k], |m| m[k]);
                let w = match weighting {
                    Weighting::None => 1.0,
                    // σ is the RMS of the complex error: σ/√2 per component
                    Weighting::StandardError => {
                        std::f64::consts::SQRT_2 / p.std_error[k].max(f64::MIN_POSITIVE)
                    }
                };
                let d = (p.h[k] - m) * w;
                r.push(d.re);
                r.push(d.im);
            }
        }
    }
    r
}

/// `||H_meas − H_model|| / ||H_meas||` over every point, for harmonic `h`
/// (`None` if it is not fitted).
pub fn relative_error(data: &FitData, pred: &Prediction, h: usize) -> Option<f64> {
    let k = data.harmonic_index(h)?;
    let (mut num, mut den) = (0.0, 0.0);
    for (s, ps) in data.series.iter().zip(&pred.h) {
        for (p, model) in s.points.iter().zip(ps) {
            let m = model.as_ref().map_or(Complex64::new(0.0, 0.0), |m| m[k]);
            num += (p.h[k] - m).norm_sqr();
            den += p.h[k].norm_sqr();
        }
    }
    Some((num / den.max(f64::MIN_POSITIVE)).sqrt())
}

/// The `χ²` expected from noise alone: with a standard error estimated from
/// the scatter of `B` blocks (`2(B − 1)` real degrees of freedom), each real
/// residual component's `z²` follows `F(1, 2(B − 1))`, whose mean is
/// `(B − 1)/(B − 2)`, not 1 (1.17 for 8 blocks, 1.07 for 16).
pub fn expected_chi_square(data: &FitData) -> f64 {
    let per = |b: usize| {
        if b > 2 {
            (b as f64 - 1.0) / (b as f64 - 2.0)
        } else {
            1.0
        }
    };
    data.series
        .iter()
        .flat_map(|s| &s.points)
        .map(|p| 2.0 * data.harmonics.len() as f64 * per(p.blocks))
        .sum()
}

/// `χ²`: the sum of squared residuals scaled by the measured standard errors.
pub fn chi_square(data: &FitData, pred: &Prediction) -> f64 {
    residuals(data, pred, Weighting::StandardError)
        .iter()
        .map(|r| r * r)
        .sum()
}

/// A model, its free parameters and the data: residuals and cost as
/// functions of the optimiser coordinates.
pub struct FitProblem<'a> {
    /// The model whose free parameters are varied.
    pub base: Model,
    /// The free parameters.
    pub parameters: ParameterSet,
    /// The data.
    pub data: &'a FitData,
    /// The predictor (harmonic balance).
    pub predictor: &'a dyn FrfPredictor,
    /// Residual scaling.
    pub weighting: Weighting,
    evaluations: AtomicUsize,
    /// Evaluations of earlier stages of the same fit: the trace and the
    /// observer number this problem's on from them.
    numbered_after: usize,
    solves: AtomicUsize,
    trace: Mutex<Vec<TraceEntry>>,
    observer: Option<&'a dyn crate::observe::Observer>,
    /// The best prediction so far: every evaluation starts from it. Only the
    /// sequential cost evaluations update it, so parallel Jacobian columns
    /// all start from the same state and the result does not depend on the
    /// thread count.
    warm: Mutex<Option<(f64, Prediction)>>,
    /// The point whose residuals were evaluated last in sequence (an
    /// optimiser's accepted or trial step, never a Jacobian column) and its
    /// prediction: the Jacobian there starts its columns from it, a step
    /// of 1e-6 away, instead of from the best point so far.
    last: Mutex<Option<(Vec<f64>, Prediction)>>,
    /// The prediction where the Jacobian was last taken (the optimiser's
    /// current point): its trial steps start from it.
    accepted: Mutex<Option<Prediction>>,
}

impl<'a> FitProblem<'a> {
    /// A problem.
    pub fn new(
        base: Model,
        parameters: ParameterSet,
        data: &'a FitData,
        predictor: &'a dyn FrfPredictor,
        weighting: Weighting,
        observer: Option<&'a dyn crate::observe::Observer>,
    ) -> FitProblem<'a> {
        FitProblem {
            base,
            parameters,
            data,
            predictor,
            weighting,
            evaluations: AtomicUsize::new(0),
            numbered_after: 0,
            solves: AtomicUsize::new(0),
            trace: Mutex::new(Vec::new()),
            observer,
            warm: Mutex::new(None),
            last: Mutex::new(None),
            accepted: Mutex::new(None),
        }
    }

    /// Numbers this problem's evaluations on from `n` of an earlier stage
    /// (in the trace and to the observer: one fit, one numbering).
    pub fn numbered_after(mut self, n: usize) -> Self {
        self.numbered_after = n;
        self
    }

    /// The model and prediction at `theta`, and the distance outside bounds.
    ///
    /// An error here is the model's, not the data's: parameters the model
    /// rejects (a mode pushed past critical damping) or a predictor that
    /// cannot solve it. Use [`FitProblem::evaluate_or_fail`] inside an
    /// optimiser, where such a point must be a bad point, not the end.
    pub fn evaluate(&self, theta: &[f64]) -> Result<(Model, Prediction, f64)> {
        let start = self.start();
        self.evaluate_from(theta, start.as_ref(), false)
    }

    /// Where an evaluation in sequence starts: the optimiser's current point
    /// once it has one, else the best point so far.
    fn start(&self) -> Option<Prediction> {
        if let Some(p) = self.accepted.lock().expect("accepted lock").as_ref() {
            return Some(p.clone());
        }
        self.warm
            .lock()
            .expect("warm lock")
            .as_ref()
            .map(|w| w.1.clone())
    }

    /// The model and prediction at `theta` from `start`; `near`: `start` is
    /// the prediction a difference step away (see
    /// [`FrfPredictor::predict_near`]).
    fn evaluate_from(
        &self,
        theta: &[f64],
        start: Option<&Prediction>,
        near: bool,
    ) -> Result<(Model, Prediction, f64)> {
        let (model, outside) = self.parameters.model_at(&self.base, theta)?;
        let pred = match start {
            Some(s) if near => self.predictor.predict_near(&model, self.data, s)?,
            _ => self.predictor.predict_from(&model, self.data, start)?,
        };
        self.solves.fetch_add(pred.solves, Ordering::Relaxed);
        Ok((model, pred, outside))
    }

    /// [`FitProblem::evaluate`], with a model the library rejects or cannot
    /// solve turned into a prediction whose every point failed (the residual
    /// then counts each point worse than predicting nothing, see
    /// [`residuals`]), so an optimiser steps back from it. Errors that are
    /// not the model's (an unusable parameter set) still propagate.
    pub fn evaluate_or_fail(&self, theta: &[f64]) -> Result<(Prediction, f64)> {
        let start = self.start();
        self.evaluate_or_fail_from(theta, start.as_ref(), false)
    }

    fn evaluate_or_fail_from(
        &self,
        theta: &[f64],
        start: Option<&Prediction>,
        near: bool,
    ) -> Result<(Prediction, f64)> {
        match self.evaluate_from(theta, start, near) {
            Ok((_, pred, outside)) => Ok((pred, outside)),
            Err(Error::InvalidModel { .. } | Error::NotConverged { .. }) => {
                let outside = self
                    .parameters
                    .parameters
                    .iter()
                    .zip(theta)
                    .map(|(p, &t)| p.clamped(t).1)
                    .sum::<f64>();
                Ok((Prediction::failed(self.data), outside))
            }
            Err(e) => Err(e),
        }
    }

    /// Residuals at `theta`, with a penalty row for any distance outside the
    /// bounds (so a simplex is pushed back in). Called in sequence (by an
    /// optimiser), never for a Jacobian's columns.
    pub fn residuals(&self, theta: &[f64]) -> Result<Vec<f64>> {
        let (pred, outside) = self.evaluate_or_fail(theta)?;
        let r = self.residuals_of(&pred, outside);
        if pred.failures() == 0 {
            *self.last.lock().expect("last lock") = Some((theta.to_vec(), pred));
        }
        Ok(r)
    }

    /// The forward-difference Jacobian at `theta` (whose residuals are
    /// `r0`), penalty row excluded: every column's harmonic balance starts
    /// from the prediction at `theta` itself (a step away), so each point
    /// takes a Newton iteration or two and follows the branch `theta`'s
    /// does. The columns run in parallel and change no state, so the result
    /// does not depend on the thread count.
    pub fn jacobian(&self, theta: &[f64], r0: &[f64], step: f64) -> Result<DMatrix<f64>> {
        let here = {
            let last = self.last.lock().expect("last lock");
            last.as_ref()
                .filter(|(t, _)| t.as_slice() == theta)
                .map(|(_, p)| p.clone())
        };
        let here = match here {
            Some(p) => Some(p),
            None => {
                let (pred, _) = self.evaluate_or_fail(theta)?;
                (pred.failures() == 0).then_some(pred)
            }
        };
        let fallback = if here.is_none() { self.start() } else { None };
        let start = here.as_ref().or(fallback.as_ref());
        let jac = forward_difference(theta, r0, step, |t| {
            let (pred, outside) = self.evaluate_or_fail_from(t, start, here.is_some())?;
            Ok(self.residuals_of(&pred, outside))
        })?;
        if let Some(p) = here {
            *self.accepted.lock().expect("accepted lock") = Some(p);
        }
        Ok(jac)
    }

    fn residuals_of(&self, pred: &Prediction, outside: f64) -> Vec<f64> {
        let mut r = residuals(self.data, pred, self.weighting);
        let scale = (r.iter().map(|v| v * v).sum::<f64>() / r.len().max(1) as f64).sqrt();
        r.push(outside * 10.0 * scale * (r.len() as f64).sqrt());
        r
    }

    /// Cost `Σ r²` at `theta` (recorded in the trace).
    pub fn cost(&self, theta: &[f64]) -> Result<f64> {
        if self.observer.is_some_and(|o| o.cancelled()) {
            return Err(Error::Cancelled);
        }
        let (pred, outside) = self.evaluate_or_fail(theta)?;
        let r = self.residuals_of(&pred, outside);
        let cost = r.iter().map(|v| v * v).sum::<f64>();
        {
            let mut w = self.warm.lock().expect("warm lock");
            if w.as_ref().is_none_or(|(c, _)| cost < *c) && pred.failures() == 0 {
                *w = Some((cost, pred));
            }
        }
        let entry = TraceEntry {
            evaluation: self.numbered_after + self.evaluations.fetch_add(1, Ordering::Relaxed) + 1,
            cost,
            parameters: self.parameters.values(theta),
        };
        if let Some(o) = self.observer {
            o.observe(crate::observe::Event::Cost(&entry));
        }
        self.trace.lock().expect("trace lock").push(entry);
        Ok(cost)
    }

    /// Starts every evaluation from `pred` until a better one is found (a
    /// warm start from a nearby model's prediction).
    pub fn with_warm_start(self, pred: Prediction) -> Self {
        *self.warm.lock().expect("warm lock") = Some((f64::INFINITY, pred));
        self
    }

    /// Cost evaluations so far.
    pub fn evaluations(&self) -> usize {
        self.evaluations.load(Ordering::Relaxed)
    }

    /// Harmonic-balance points solved so far.
    pub fn solves(&self) -> usize {
        self.solves.load(Ordering::Relaxed)
    }

    /// The cost trace so far.
    pub fn trace(&self) -> Vec<TraceEntry> {
        self.trace.lock().expect("trace lock").clone()
    }
}

impl Objective for FitProblem<'_> {
    fn residuals(&self, theta: &[f64]) -> Result<Vec<f64>> {
        FitProblem::residuals(self, theta)
    }
    fn cost(&self, theta: &[f64]) -> Result<f64> {
        FitProblem::cost(self, theta)
    }
    fn evaluations(&self) -> usize {
        FitProblem::evaluations(self)
    }
    fn jacobian(&self, theta: &[f64], r0: &[f64], step: f64) -> Result<DMatrix<f64>> {
        FitProblem::jacobian(self, theta, r0, step)
    }
}
