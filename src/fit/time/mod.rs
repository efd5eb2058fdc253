//! Output-error identification in the time domain: the model driven by the
//! measured force, its simulated response matched to the measured one sample
//! by sample.
//!
//! The FRF fit (paper eq. 9) matches steady-state harmonics, one dwell at a
//! time, each started from a virgin joint. A recording is more than that: the
//! joint carries its state from one dwell to the next (where it settles under
//! a static load depends on the loads before), a sweep is never steady, and
//! a transient holds information a steady state hides. Here the recording is
//! replayed whole through the digital-filter simulator (the same replay as
//! [`crate::validate`]), and the parameters minimise
//!
//! `Σ_s Σ_{i ∈ s} (y_sim(i) − y_meas(i))² / (N_s · RMS_s²)`,
//!
//! the sum over segments `s` of the recordings of each segment's squared
//! relative `e_RMS` (`N_s` samples, `RMS_s` the measured response's RMS
//! there). A swept or unknown record is one segment; a stepped sine is cut
//! at its dwells' starts (stated in the recording, else found from the
//! reference), so each dwell counts as much as any other, as each point does
//! in the FRF fit: levels span decades, and one RMS over the record would
//! judge the loudest level only. The simulation starts from rest; a
//! recording that does not is given a window that starts after its
//! transient.
//!
//! The optimiser is Levenberg–Marquardt on those residuals (a forward
//! difference Jacobian, one replay per free parameter, in parallel), in the
//! bounded coordinates of [`super::params`]; a model the simulator rejects
//! (unstable, beyond the resampling limit) is a bad point whose residual is
//! twice the measured response, never an error. Confidence intervals take the
//! residual as white noise (`cov = s² (JᵀJ)⁻¹`, `s²` its mean square): right
//! for measurement noise, optimistic where model error dominates (it is
//! correlated in time), which the reported relative error shows.

use super::identify::Estimate;
use super::optimise::{self, FitStatus, Objective, OptimiserRun};
use super::params::{ParameterSet, Transform};
use crate::error::{Error, Result};
use crate::harmonics::Quantity;
use crate::model::Model;
use crate::observe::Silent;
use crate::signals::{Samples, SamplesView};
use crate::validate::resample::{Decimator, MAX_FACTOR};
use crate::validate::{
    DriveInput, ErrorMetrics, PreparedDrive, error_metrics_of_sum, error_window,
    quasi_static_above_hz, sum_start, upsampling_factor,
};
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;
use std::ops::Range;
use std::sync::atomic::{AtomicUsize, Ordering};

/// One recording as the time-domain fit sees it.
#[derive(Clone, Debug, PartialEq)]
pub struct TimeRecord {
    /// A name for reports (the file).
    pub name: String,
    /// The measured force driving the model, N (or the voltage driving a
    /// shaker), held as recorded (see [`Samples`]).
    pub reference: Samples,
    /// What the reference is: a force, or a voltage.
    pub reference_quantity: Quantity,
    /// The measured response, in `quantity`, held as recorded.
    pub response: Samples,
    /// Samples per second.
    pub sample_rate_hz: f64,
    /// The response's quantity (a motion).
    pub quantity: Quantity,
    /// The samples judged.
    pub window: Range<usize>,
    /// The stretches of the window each judged on its own RMS (see the
    /// module docs): ordered, not overlapping.
    pub segments: Vec<Range<usize>>,
    /// The band judged, Hz (`--band`), about which the fit's final error is
    /// split by frequency ([`TimeProblem::errors_by_frequency`]).
    pub band_hz: Option<(f64, f64)>,
    /// The segments are the steady periods of a periodic excitation (see
    /// [`TimeRecord::steady_periods`]): alike, so a fit that judges the
    /// record only in part judges its first periods whole and replays no
    /// further (see [`TimeFitOptions::max_judged_samples`]).
    pub periodic: bool,
}

impl TimeRecord {
    /// Checks the record: equal lengths, a motion response, a window inside
    /// the samples that holds some, a finite measured RMS above zero there.
    pub fn check(&self) -> Result<()> {
        let at = |f: &str| format!("{}: {f}", self.name);
        if self.reference.len() != self.response.len() {
            return Err(Error::input(
                at("response"),
                format!(
                    "{} samples against the force's {}",
                    self.response.len(),
                    self.reference.len()
                ),
            ));
        }
        if !self.quantity.is_motion() {
            return Err(Error::input(
                at("response quantity"),
                format!("{} is not a motion", self.quantity),
            ));
        }
        if self.window.start >= self.window.end || self.window.end > self.response.len() {
            return Err(Error::input(
                at("window"),
                format!(
                    "samples {}..{} are not inside the {} recorded",
                    self.window.start,
                    self.window.end,
                    self.response.len()
                ),
            ));
        }
        if self.segments.is_empty() {
            return Err(Error::input(
                at("segments"),
                "none: no stretch of the response to judge",
            ));
        }
        let mut next = self.window.start;
        for s in &self.segments {
            if s.start < next || s.end <= s.start || s.end > self.window.end {
                return Err(Error::input(
                    at("segments"),
                    format!(
                        "must be ordered, non-empty stretches inside the window {}..{}; {}..{} is not",
                        self.window.start, self.window.end, s.start, s.end
                    ),
                ));
            }
            next = s.end;
            let rms = self.measured_rms(s.clone());
            if !(rms.is_finite() && rms > 0.0) {
                return Err(Error::input(
                    at("response"),
                    format!(
                        "its RMS over samples {}..{} is {rms}: nothing to fit",
                        s.start, s.end
                    ),
                ));
            }
        }
        Ok(())
    }

    /// The window cut at the starts of `steps` that fall inside it, but for
    /// the first step's: the few samples before the first dwell (silence
    /// and noise) belong to it (one segment when no step does).
    pub fn segments_at(window: Range<usize>, steps: &[crate::signals::Step]) -> Vec<Range<usize>> {
        let mut cuts: Vec<usize> = steps.iter().map(|s| s.start).collect();
        cuts.sort_unstable();
        cuts.dedup();
        let cuts: Vec<usize> = cuts
            .into_iter()
            .skip(1)
            .filter(|&c| c > window.start && c < window.end)
            .collect();
        let mut out = Vec::with_capacity(cuts.len() + 1);
        let mut a = window.start;
        for c in cuts {
            out.push(a..c);
            a = c;
        }
        out.push(a..window.end);
        out
    }

    /// A recording's reference driving the model and its `response`
    /// channel, judged over samples `window` (the whole record if `None`),
    /// cut at its dwells: the stated `steps`, else for a stepped or unknown
    /// excitation the dwells found in the reference (none: one segment).
    ///
    /// With `band_hz`, only what the band holds is judged: a stepped record's
    /// dwells at frequencies inside it, a swept record's stretch where the
    /// sweep (its law fitted to the reference's phase) is inside it. The
    /// model is still driven from the record's first sample, so the joint
    /// reaches the band with the history the structure had.
    pub fn from_recording(
        name: &str,
        rec: &crate::signals::Recording,
        response: usize,
        window: Option<Range<usize>>,
        band_hz: Option<(f64, f64)>,
    ) -> Result<TimeRecord> {
        let reference = Self::reference_of(name, &rec.meta, response)?;
        let channels = (
            rec.channels[reference].clone(),
            rec.channels[response].clone(),
        );
        Self::from_values(name, &rec.meta, response, channels, window, band_hz)
    }

    /// [`TimeRecord::from_recording`] taking the recording's reference and
    /// response channels over, not copying them (a long recording's
    /// channels are the largest thing a time fit holds).
    pub fn from_owned_recording(
        name: &str,
        mut rec: crate::signals::Recording,
        response: usize,
        window: Option<Range<usize>>,
        band_hz: Option<(f64, f64)>,
    ) -> Result<TimeRecord> {
        let reference = Self::reference_of(name, &rec.meta, response)?;
        let measured = if response == reference {
            rec.channels[response].clone()
        } else {
            std::mem::take(&mut rec.channels[response])
        };
        let channels = (std::mem::take(&mut rec.channels[reference]), measured);
        Self::from_values(name, &rec.meta, response, channels, window, band_hz)
    }

    /// [`TimeRecord::from_recording`] of a recording described by `meta`
    /// whose reference and response are already held (see
    /// [`crate::analysis::load_time_record`]).
    pub fn from_held(
        name: &str,
        meta: &crate::signals::RecordingMeta,
        response: usize,
        channels: (Samples, Samples),
        window: Option<Range<usize>>,
        band_hz: Option<(f64, f64)>,
    ) -> Result<TimeRecord> {
        Self::reference_of(name, meta, response)?;
        Self::from_channels(name, meta, response, channels, window, band_hz)
    }

    /// A periodic record (a multisine played several times) judged over
    /// its steady periods of `period` samples: its whole periods after the
    /// first (the model's replay starts from rest), one segment each, as a
    /// multisine's time fit, its diagnosis and its validation judge it.
    /// `None` when it holds fewer than two. No dwell is looked for: a
    /// multisine has none.
    pub fn steady_periods(
        name: &str,
        meta: &crate::signals::RecordingMeta,
        response_channel: usize,
        (reference, response): (Samples, Samples),
        period: usize,
    ) -> Result<Option<TimeRecord>> {
        let reference_channel = Self::reference_of(name, meta, response_channel)?;
        let periods = reference.len().min(response.len()) / period.max(1);
        if period == 0 || periods < 2 {
            return Ok(None);
        }
        let r = TimeRecord {
            name: name.to_string(),
            reference,
            reference_quantity: meta.channels[reference_channel].quantity,
            response,
            sample_rate_hz: meta.sample_rate_hz,
            quantity: meta.channels[response_channel].quantity,
            window: period..periods * period,
            segments: (1..periods).map(|k| k * period..(k + 1) * period).collect(),
            band_hz: None,
            periodic: true,
        };
        r.check()?;
        Ok(Some(r))
    }

    /// The record of values in physical units, held as the file stored
    /// them where they are its values (half the bytes, the same values).
    fn from_values(
        name: &str,
        meta: &crate::signals::RecordingMeta,
        response: usize,
        (reference, measured): (Vec<f64>, Vec<f64>),
        window: Option<Range<usize>>,
        band_hz: Option<(f64, f64)>,
    ) -> Result<TimeRecord> {
        let reference_channel = meta.reference_channel().expect("checked by reference_of");
        let held = |samples, channel: usize| {
            Samples::recorded(samples, &[meta.channels[channel].scale, 1.0])
        };
        let channels = (held(reference, reference_channel), held(measured, response));
        Self::from_channels(name, meta, response, channels, window, band_hz)
    }

    /// The reference channel of a recording described by `meta`, checked
    /// with its `response` channel.
    fn reference_of(
        name: &str,
        meta: &crate::signals::RecordingMeta,
        response: usize,
    ) -> Result<usize> {
        let reference = meta.reference_channel().ok_or_else(|| {
            Error::input(
                format!("{name}: channels"),
                "no force or voltage channel to drive the model with",
            )
        })?;
        if response >= meta.channels.len() {
            return Err(Error::input(
                format!("{name}: response channel"),
                format!("{response} is not one of the {}", meta.channels.len()),
            ));
        }
        Ok(reference)
    }

    /// The record of a recording described by `meta` whose reference and
    /// response (channel `response_channel`) samples are `(reference,
    /// response)` (see [`TimeRecord::from_recording`]).
    fn from_channels(
        name: &str,
        meta: &crate::signals::RecordingMeta,
        response_channel: usize,
        (reference, response): (Samples, Samples),
        window: Option<Range<usize>>,
        band_hz: Option<(f64, f64)>,
    ) -> Result<TimeRecord> {
        let reference_channel = meta.reference_channel().expect("checked by reference_of");
        let n = reference.len();
        let mut window = window.unwrap_or(0..n);
        let fs = meta.sample_rate_hz;
        let stated = &meta.excitation.steps;
        let swept = meta.excitation.kind == crate::signals::ExcitationKind::SweptSine;
        if let (Some(band), true, true) = (band_hz, swept, stated.is_empty()) {
            let sweep = crate::extract::find_sweep_held(
                reference.view(),
                fs,
                &crate::extract::SweepOptions::default(),
            )
            .map_err(|e| Error::context(format!("{name}: the sweep"), e))?;
            let inside = sweep.samples_in(band);
            let (a, b) = (inside.start.max(window.start), inside.end.min(window.end));
            if b <= a {
                return Err(Error::input(
                    format!("{name}: band"),
                    format!(
                        "the sweep ({:.4}-{:.4} Hz) is never inside {}-{} Hz within the window",
                        sweep.f_start_hz, sweep.f_end_hz, band.0, band.1
                    ),
                ));
            }
            window = a..b;
        }
        let steps = if !stated.is_empty() {
            stated.clone()
        } else if swept {
            Vec::new()
        } else {
            crate::extract::find_dwells_held(
                reference.view(),
                fs,
                &crate::extract::DwellOptions::default(),
            )
            .unwrap_or_default()
        };
        let mut segments = TimeRecord::segments_at(window.clone(), &steps);
        if let (Some((lo, hi)), false) = (band_hz, steps.is_empty()) {
            // each segment is judged as the dwell it starts in
            let mut by_start: Vec<&crate::signals::Step> = steps.iter().collect();
            by_start.sort_by_key(|s| s.start);
            segments.retain(|seg| {
                let k = by_start.partition_point(|s| s.start <= seg.start);
                let f = by_start[k.saturating_sub(1)].frequency_hz;
                (lo..=hi).contains(&f)
            });
            if segments.is_empty() {
                return Err(Error::input(
                    format!("{name}: band"),
                    format!("no dwell of the record is inside {lo}-{hi} Hz"),
                ));
            }
        }
        // a dwell whose response the converter resolved to a few steps (a
        // quiet level in a 16-bit file) has no scale to be judged on: left
        // out, as the FRF reduction leaves it out
        segments.retain(|s| {
            rms_of(response.view(), s.clone()) > 0.0
                && !crate::extract::below_resolution(&response.range(s.clone()))
        });
        let r = TimeRecord {
            name: name.to_string(),
            reference,
            reference_quantity: meta.channels[reference_channel].quantity,
            response,
            sample_rate_hz: fs,
            quantity: meta.channels[response_channel].quantity,
            segments,
            window,
            band_hz,
            periodic: false,
        };
        r.check()?;
        Ok(r)
    }

    /// RMS of the measured response over `range` (about zero: the model's
    /// response has the same static part to match).
    fn measured_rms(&self, range: Range<usize>) -> f64 {
        rms_of(self.response.view(), range)
    }
}

/// RMS of `x` over `range`, about zero.
fn rms_of(x: SamplesView, range: Range<usize>) -> f64 {
    let n = range.len() as f64;
    let mut sum = sum_start();
    x.for_each_stretch(range, |_, w| sum = w.iter().fold(sum, |acc, v| acc + v * v));
    (sum / n).sqrt()
}

/// Options of [`identify_time`].
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct TimeFitOptions {
    /// Samples per period of the model's highest linearised frequency below
    /// which the replay is upsampled (see [`crate::validate`]). Default 40,
    /// twice validation's: at 20 the filter's error at a stick mode (about
    /// 1 % in the response) is as large as a fit's whole residual can be
    /// on a good recording, and the fit would bend the parameters to it.
    pub min_samples_per_period: f64,
    /// Levenberg–Marquardt's patience: at most `patience·(n+1)` residual
    /// evaluations.
    pub patience: usize,
    /// Whether the linear part's parameters are refined with the elements'.
    pub refine_linear: bool,
    /// What the force is between its samples (see [`DriveInput`]).
    pub input: DriveInput,
    /// How many starts the fit descends from: the given one and `starts −
    /// 1` others spread about it (see [`spread_start`]); the one with the
    /// lowest misfit (the cost without the bounds' penalty) is kept. A
    /// time fit over several modes, a joint and a shaker has more than one
    /// basin, and which one Levenberg–Marquardt settles in depends on where
    /// it starts.
    #[serde(default = "one")]
    pub starts: usize,
    /// Most samples the fit judges, over all its recordings. Levenberg–
    /// Marquardt holds a Jacobian of a row per judged sample and a column
    /// per parameter, and each residual vector a value per sample: judged
    /// at every one of the default test's 8.2 M frames, 66 MB a vector and
    /// 330 MB a Jacobian of five parameters. A fit that would judge more
    /// judges its recordings at `1/k` of their rate, `k` the smallest
    /// factor that brings it within this (never one that leaves fewer than
    /// [`MIN_JUDGED_PER_PERIOD`] samples a period of the start model's
    /// highest linearised frequency): the measured and simulated responses
    /// low-passed alike (a windowed sinc) and kept at every `k`-th sample.
    /// What the model makes lies well inside the pass band, so the misfit
    /// is the same but for the measurement noise above it, which carries
    /// no information on the model. Where that floor (or the largest
    /// factor) leaves more than this, each segment is judged on its share
    /// of it, in stretches spread over the segment (see
    /// [`judged_stretches`]): the Jacobian stays within this whatever the
    /// recording's length. The replays, and every error reported, are
    /// still over every sample.
    #[serde(default = "max_judged")]
    pub max_judged_samples: usize,
    /// How the recorded response was decimated to the recording's rate
    /// (see [`crate::validate::acquisition`]): every replay is put through
    /// the same chain before it is compared, so that the fit does not bend
    /// the parameters to the chain's droop near the recording's Nyquist
    /// frequency. None: the response as recorded.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub acquisition: Option<crate::validate::acquisition::Acquisition>,
    /// After a fit of several recordings, refit each alone from the fitted
    /// model (the same free parameters) and report how much closer each
    /// comes ([`TimeFitResult::each_alone`], [`level_consistency`]): what
    /// tells a model that lacks something every recording shares from one
    /// whose dependence on level is wrong. Costs a fit per recording.
    #[serde(default, skip_serializing_if = "std::ops::Not::not")]
    pub each_alone: bool,
}

fn max_judged() -> usize {
    MAX_JUDGED_SAMPLES
}

fn one() -> usize {
    1
}

impl Default for TimeFitOptions {
    fn default() -> Self {
        TimeFitOptions {
            min_samples_per_period: 40.0,
            patience: 40,
            refine_linear: true,
            input: DriveInput::BandLimited,
            starts: 1,
            max_judged_samples: MAX_JUDGED_SAMPLES,
            acquisition: None,
            each_alone: false,
        }
    }
}

/// How far [`spread_start`] moves a parameter at most: a factor of 1.5
/// either way for a parameter fitted in its logarithm or reciprocal, 15 %
/// of its value for one fitted on a linear scale.
const SPREAD_FACTOR: f64 = 1.5;
const SPREAD_LINEAR: f64 = 0.15;

/// The `k`-th further start about `theta0` (`k ≥ 1`): every parameter
/// moved by a share of its spread drawn uniformly from the `k`-th stream of
/// a seeded ChaCha8 generator (the same starts on every run and machine),
/// then held inside its bounds. A parameter fitted on a linear scale whose
/// value is 0 stays there unless 0 is a bound.
pub fn spread_start(parameters: &ParameterSet, theta0: &[f64], k: usize) -> Vec<f64> {
    use rand::{RngExt, SeedableRng};
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(SPREAD_SEED);
    rng.set_stream(k as u64);
    parameters
        .parameters
        .iter()
        .zip(theta0)
        .map(|(p, &t)| {
            let u: f64 = rng.random_range(-1.0..=1.0);
            let moved = match p.transform {
                Transform::Log => t + u * SPREAD_FACTOR.ln(),
                Transform::Reciprocal => t * SPREAD_FACTOR.powf(u),
                Transform::Scaled { .. } => t * (1.0 + SPREAD_LINEAR * u),
            };
            // inside the bounds by a hair: a start on a bound is a start
            // the optimiser's transform cannot leave
            let (lo, hi) = (p.theta(p.bounds[0]), p.theta(p.bounds[1]));
            let (lo, hi) = (lo.min(hi), lo.max(hi));
            let margin = 1e-6 * (hi - lo).abs().min(1.0);
            if (hi - lo).is_finite() && hi > lo {
                moved.clamp(lo + margin, hi - margin)
            } else {
                moved
            }
        })
        .collect()
}

/// The seed of [`spread_start`]'s generator.
const SPREAD_SEED: u64 = 0x5EED_57A2;

/// The error of a model on one recording.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct RecordError {
    /// The recording.
    pub recording: String,
    /// Over its judged window.
    pub window: ErrorMetrics,
    /// Segments judged (dwells of a stepped sine).
    pub segments: usize,
    /// The root mean square over segments of each one's relative `e_RMS`
    /// (what the fit minimises, per recording).
    pub segment_relative: f64,
}

/// A time-domain fit.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct TimeFitResult {
    /// The fitted model.
    pub model: Model,
    /// The model predicts `response_sign × measured`.
    pub response_sign: f64,
    /// The free parameters by name.
    pub parameters: BTreeMap<String, Estimate>,
    /// Each recording's error with the starting model.
    pub before: Vec<RecordError>,
    /// Each recording's error with the fitted model.
    pub after: Vec<RecordError>,
    /// The optimiser's run.
    pub optimiser: OptimiserRun,
    /// How it ended.
    pub status: FitStatus,
    /// Samples judged, over all recordings.
    pub samples: usize,
    /// Notes for the user.
    pub notes: Vec<String>,
    /// The parameters that ended at (within 1 % of) a bound of the fit.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub at_bound: Vec<String>,
    /// Where the fit descended from more than one start
    /// ([`TimeFitOptions::starts`]): how each ended.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub starts: Vec<StartOutcome>,
    /// The quantity of the recordings' reference (a force or a voltage):
    /// `validate` refuses a recording driven by the other.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub reference_quantity: Option<Quantity>,
    /// The response's acquisition chain the replays were put through
    /// ([`TimeFitOptions::acquisition`]): `validate` puts its replays
    /// through it too.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub acquisition: Option<crate::validate::acquisition::Acquisition>,
    /// With [`TimeFitOptions::each_alone`]: each recording refitted alone
    /// from the fitted model.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub each_alone: Vec<AloneFit>,
}

/// One recording of a fit over several, refitted alone from the fit's
/// model ([`TimeFitOptions::each_alone`]).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct AloneFit {
    /// The recording.
    pub recording: String,
    /// Its relative `e_RMS` over its judged window in the fit of every
    /// recording (its `after` figure).
    pub together: f64,
    /// The same figure refitted alone (`None`: the refit failed).
    pub alone: Option<f64>,
    /// How the refit ended.
    pub status: FitStatus,
    /// Why it failed.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub failed: Option<String>,
}

impl AloneFit {
    /// How many times closer the recording comes alone (`None`: its refit
    /// failed, or it is exact either way).
    pub fn closer(&self) -> Option<f64> {
        self.alone.filter(|a| *a > 0.0).map(|a| self.together / a)
    }
}

/// How much closer than together a recording must come alone, at the
/// median, before the fit is said to miss what changes between them.
/// A model that holds every recording leaves each the same residual alone
/// or together but for the few parameters an alone fit adapts to thousands
/// of samples' noise (the consistent case of
/// `tests::recordings_fitted_alone_tell_a_wrong_dependence_on_level`:
/// 1.00x); a quarter is far outside that and well inside what a level
/// dependence the model lacks gives (a stick stiffness that changed
/// between the runs there: 9.7x; the UNESP beam's chirps: 2.4x).
pub const CLOSER_ALONE: f64 = 1.25;

/// What the recordings refitted alone say ([`TimeFitOptions::each_alone`]):
/// a note for the user, `None` without two refits that ended.
pub fn level_consistency(alone: &[AloneFit]) -> Option<String> {
    let mut closer: Vec<f64> = alone.iter().filter_map(AloneFit::closer).collect();
    if closer.len() < 2 {
        return None;
    }
    closer.sort_by(f64::total_cmp);
    let median = if closer.len() % 2 == 1 {
        closer[closer.len() / 2]
    } else {
        0.5 * (closer[closer.len() / 2 - 1] + closer[closer.len() / 2])
    };
    let each: Vec<String> = alone
        .iter()
        .map(|a| match a.alone {
            Some(x) => format!(
                "{} {:.2} % -> {:.2} %",
                a.recording,
                100.0 * a.together,
                100.0 * x
            ),
            None => format!("{} (its refit failed)", a.recording),
        })
        .collect();
    let each = each.join(", ");
    Some(if median >= CLOSER_ALONE {
        format!(
            "refitted alone, the recordings come {median:.2}x closer at the median ({each}, of \
             the RMS): the model reaches each recording but not all of them at once, so what it \
             lacks changes from one to the next (the joint law's dependence on level, or a \
             structure that changed between the runs), not a shape they share"
        )
    } else {
        format!(
            "refitted alone, the recordings come {median:.2}x closer at the median ({each}, of \
             the RMS): what the model misses is shared by every recording (a mode, a law's \
             shape, the noise), not its dependence on level"
        )
    })
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

/// How one start of a fit ended.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct StartOutcome {
    /// 0 for the given start, `k` for the `k`-th spread about it.
    pub start: usize,
    /// The cost it descended to (`None`: it failed).
    pub cost: Option<f64>,
    /// Its misfit, the cost without the bounds' penalty, on the grid the
    /// last start ended on: what the starts are compared by.
    pub misfit: Option<f64>,
    /// How it ended.
    pub status: FitStatus,
    /// Why it failed.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub failed: Option<String>,
}

impl StartOutcome {
    fn of(
        start: usize,
        run: std::result::Result<&OptimiserRun, &Error>,
        misfit: Option<f64>,
    ) -> StartOutcome {
        match run {
            Ok(r) => StartOutcome {
                start,
                cost: Some(r.cost),
                misfit,
                status: r.status,
                failed: None,
            },
            Err(e) => StartOutcome {
                start,
                cost: None,
                misfit: None,
                status: FitStatus::Stopped,
                failed: Some(e.to_string()),
            },
        }
    }
}

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

/// Most samples a time-domain fit judges by default, over all its
/// recordings (see [`TimeFitOptions::max_judged_samples`]).
pub const MAX_JUDGED_SAMPLES: usize = 1 << 20;

/// Fewest judged samples per period of the model's highest linearised
/// frequency that judging at a lower rate leaves (see
/// [`TimeFitOptions::max_judged_samples`]).
pub const MIN_JUDGED_PER_PERIOD: f64 = 8.0;

/// Half-width of the low-pass filter before a lower judging rate, in
/// samples of that rate (see [`crate::validate::resample::decimate_with`]):
/// what is judged lies below a quarter of its Nyquist frequency (at least
/// [`MIN_JUDGED_PER_PERIOD`] samples a period), well inside the pass band
/// of even a short filter.
const JUDGING_HALF_WIDTH: usize = 8;

/// Each record's judging factor `k` (see
/// [`TimeFitOptions::max_judged_samples`]), for a model whose highest
/// linearised frequency is `top_hz`: the smallest that brings the judged
/// samples within `most`, but never one that leaves fewer than
/// [`MIN_JUDGED_PER_PERIOD`] judged samples a period of `top_hz`, nor more
/// than [`MAX_FACTOR`].
pub fn judging_factors(records: &[TimeRecord], top_hz: f64, most: usize) -> Vec<usize> {
    let total: usize = records
        .iter()
        .map(|r| r.segments.iter().map(|s| s.len()).sum::<usize>())
        .sum();
    let wanted = total.div_ceil(most.max(1)).max(1);
    records
        .iter()
        .map(|r| {
            let coarsest = if top_hz.is_finite() && top_hz > 0.0 {
                (r.sample_rate_hz / (MIN_JUDGED_PER_PERIOD * top_hz)).floor()
            } else {
                1.0
            };
            wanted.min(coarsest.max(1.0) as usize).min(MAX_FACTOR)
        })
        .collect()
}

/// Judged samples a judged stretch holds at most where a recording is judged
/// only in part (see [`judged_stretches`]): 256 periods of the model's
/// highest linearised frequency at the fewest judged samples a period.
const JUDGED_STRETCH: usize = 2048;

/// Which samples of each segment (in samples of the judging rate) are
/// judged, where judging every one of them would judge more than `most`
/// over all recordings (`total`): that share of each segment, as stretches
/// of at most [`JUDGED_STRETCH`] samples, each at the end of its equal share
/// of the segment (a single stretch is a dwell's last, most settled
/// samples; several spread over it, its transient included). Every sample
/// of every segment where `total <= most`. The steady periods of a
/// periodic record (`periodic`) are alike: its share is judged as its first
/// periods whole (the last of them in part), so that its replays stop
/// there. Returns the stretches in order with the segment each lies in.
fn judged_stretches(
    segments: &[Range<usize>],
    total: usize,
    most: usize,
    periodic: bool,
) -> Vec<(Range<usize>, usize)> {
    if total <= most {
        return segments
            .iter()
            .enumerate()
            .map(|(k, s)| (s.clone(), k))
            .collect();
    }
    // `len·most/total` in 128 bits: never more than `most` over all
    let share = |len: usize| (len as u128 * most as u128 / total as u128) as usize;
    if periodic {
        let mut left: usize = segments.iter().map(|s| share(s.len())).sum();
        let mut out = Vec::new();
        for (k, s) in segments.iter().enumerate() {
            if left == 0 {
                break;
            }
            let n = s.len().min(left);
            out.push((s.start..s.start + n, k));
            left -= n;
        }
        return out;
    }
    let mut out = Vec::new();
    for (k, s) in segments.iter().enumerate() {
        let len = s.len();
        let kept = share(len);
        let blocks = kept.div_ceil(JUDGED_STRETCH);
        for j in 0..blocks {
            let end = s.start + len * (j + 1) / blocks;
            let n = kept * (j + 1) / blocks - kept * j / blocks;
            out.push((end - n..end, k));
        }
    }
    out
}

/// How a record is judged: at its own rate, or low-passed and kept at every
/// `factor`-th sample; every sample of its segments at that rate, or
/// stretches of them (see [`judged_stretches`]).
struct Judging {
    factor: usize,
    /// The measured response at each judged sample, in order (`None`: every
    /// sample of the segments at the record's own rate, read from it).
    measured: Option<Vec<f64>>,
    /// The judged stretches in samples of the judging rate, in order, each
    /// with the segment it lies in.
    stretches: Vec<(Range<usize>, usize)>,
    /// `RMS_s · √N_s` of each segment over its judged samples: the
    /// residual's divisor.
    scale: Vec<f64>,
}

impl Judging {
    /// `r`'s segments in samples of `1/factor` of its rate.
    fn segments_at(r: &TimeRecord, factor: usize) -> Vec<Range<usize>> {
        // sample q of the judging rate is sample q·factor of the record's
        let outputs = r.response.len().div_ceil(factor);
        r.segments
            .iter()
            .map(|s| s.start.div_ceil(factor)..s.end.div_ceil(factor).min(outputs))
            .collect()
    }

    /// `r` judged at `1/factor` of its rate at `stretches` (`scale`: its
    /// segments' divisors at its own rate, every sample judged).
    fn of(
        r: &TimeRecord,
        scale: &[f64],
        factor: usize,
        stretches: Vec<(Range<usize>, usize)>,
    ) -> Result<Judging> {
        let every = stretches.len() == r.segments.len()
            && stretches.iter().zip(&r.segments).all(|((a, _), b)| a == b);
        if factor <= 1 && every {
            return Ok(Judging {
                factor: 1,
                measured: None,
                stretches,
                scale: scale.to_vec(),
            });
        }
        // the response at the judging rate, made a stretch at a time and
        // kept where judged (the same bits as `decimate_with` whole)
        let mut decimator = Decimator::new(factor, JUDGING_HALF_WIDTH, r.response.len())?;
        let judged: usize = stretches.iter().map(|(s, _)| s.len()).sum();
        let mut measured = Vec::with_capacity(judged);
        let mut made = Vec::new();
        let (mut q, mut k) = (0, 0);
        let mut bad = None;
        r.response.for_each_stretch(0..r.response.len(), |at, x| {
            if bad.is_none() {
                bad = x.iter().position(|v| !v.is_finite()).map(|i| at + i);
            }
            made.clear();
            decimator.push(x, &mut made);
            for &v in &made {
                while k < stretches.len() && stretches[k].0.end <= q {
                    k += 1;
                }
                if k < stretches.len() && stretches[k].0.start <= q {
                    measured.push(v);
                }
                q += 1;
            }
        });
        if let Some(i) = bad {
            return Err(crate::validate::resample::not_finite(
                "signal",
                r.response.view(),
                i,
            ));
        }
        let mut sums = vec![0.0; r.segments.len()];
        let mut at = 0;
        for (s, k) in &stretches {
            let w = &measured[at..at + s.len()];
            sums[*k] = w.iter().fold(sums[*k], |acc, v| acc + v * v);
            at += s.len();
        }
        Ok(Judging {
            factor,
            measured: Some(measured),
            stretches,
            scale: sums.into_iter().map(f64::sqrt).collect(),
        })
    }

    /// Samples judged.
    fn judged(&self) -> usize {
        self.stretches.iter().map(|(s, _)| s.len()).sum()
    }

    /// The measured response at each judged sample, in order, read from
    /// `r` where not held.
    fn for_each_measured(&self, r: &TimeRecord, mut f: impl FnMut(usize, f64)) {
        match &self.measured {
            Some(m) => {
                let mut at = 0;
                for (s, k) in &self.stretches {
                    for &v in &m[at..at + s.len()] {
                        f(*k, v);
                    }
                    at += s.len();
                }
            }
            None => {
                for (s, k) in &self.stretches {
                    r.response.for_each_stretch(s.clone(), |_, w| {
                        for &v in w {
                            f(*k, v);
                        }
                    });
                }
            }
        }
    }
}

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
enum StreamFailure {
    /// The simulator rejected the model in record `i` after some of its
    /// residuals had been handed out: they are to be made again, as
    /// rejected from the record's start.
    RejectedPartway(usize),
    Error(Error),
}

/// A model's residuals over every record in turn (the residual vector's
/// rows but its penalty), handed out a stretch at a time, a record the
/// simulator rejects as [`TimeProblem::residuals_of_into`] writes it.
struct ModelResiduals<'p, 'a> {
    problem: &'p TimeProblem<'a>,
    model: Model,
    /// Records to be taken as rejected from their start.
    rejected: Vec<bool>,
    record: usize,
    current: Option<RecordResiduals<'p, 'a>>,
    /// Residuals of the current record handed out.
    made: usize,
    /// `Σ r²` of every residual handed out, in order.
    sum_of_squares: f64,
}

impl<'p, 'a> ModelResiduals<'p, 'a> {
    fn new(problem: &'p TimeProblem<'a>, model: Model, rejected: Vec<bool>) -> Self {
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
    fn fill(&mut self, out: &mut [f64]) -> std::result::Result<usize, StreamFailure> {
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

/// Judged rows of a Jacobian made and folded at a time
/// ([`TimeProblem::jacobian_r_factor`]).
const FOLDED_ROWS: usize = 4096;

/// Samples of its grid each of the replays side by side in a folded
/// Jacobian makes at a time: a replay's buffers are a few of its stretches,
/// and a Jacobian holds one replay per parameter.
const FOLDED_REPLAY_STRETCH: usize = 1 << 14;

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
    parameters: ParameterSet,
    records: &'a [TimeRecord],
    sign: f64,
    options: TimeFitOptions,
    /// `RMS_s · √N_s` per segment of each recording: the reported errors'
    /// divisor.
    scale: Vec<Vec<f64>>,
    /// How each recording is judged (see [`TimeFitOptions::max_judged_samples`]).
    judging: Vec<Judging>,
    /// Each recording's force, prepared once per upsampling factor.
    drives: Vec<PreparedDrive<'a>>,
    /// Each recording's replay grid, as its upsampling factor; `None`: the
    /// sure rate of each model replayed (see [`TimeProblem::fix_replay_grid`]).
    replay_factor: Vec<Option<usize>>,
    /// What choosing those rates found, for the fit's notes.
    rate_notes: Vec<String>,
    evaluations: AtomicUsize,
    /// Residual vectors computed (each a replay of every recording).
    replays: AtomicUsize,
    observer: Option<&'a dyn crate::observe::Observer>,
    /// A Jacobian of more entries is folded as it is made (see
    /// [`JACOBIAN_HELD_UP_TO`]).
    jacobian_held_up_to: usize,
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

    /// The upper-triangular R factor of `[r₀ J]` at `theta` (see
    /// [`Objective::jacobian_r_factor`]), `J` never held: the models one
    /// forward step along each coordinate are replayed side by side, a
    /// stretch of [`FOLDED_ROWS`] judged samples at a time (the stretch's
    /// columns made in parallel), and each stretch's rows `(r₀, (r_j −
    /// r₀)/step)` folded in as they come; the penalty row's derivative is
    /// zero. Each column's entries are those of the Jacobian made whole, to
    /// the bit; only the fold's rounding differs from factoring it. A
    /// record the simulator rejects partway through a column's replay is
    /// made again for that column as rejected from its start.
    pub fn jacobian_r_factor(
        &self,
        theta: &[f64],
        r0: &[f64],
        step: f64,
    ) -> Result<nalgebra::DMatrix<f64>> {
        use rayon::prelude::*;
        let n = theta.len();
        let m = r0.len() - 1;
        let models = (0..n)
            .map(|j| {
                let mut t = theta.to_vec();
                t[j] += step;
                self.model_at(&t)
            })
            .collect::<Result<Vec<_>>>()?;
        let mut rejected = vec![vec![false; self.records.len()]; n];
        'again: loop {
            let mut columns: Vec<ModelResiduals> = models
                .iter()
                .zip(&rejected)
                .map(|((model, _), rejected)| {
                    ModelResiduals::new(self, model.clone(), rejected.clone())
                })
                .collect();
            let mut buffers = vec![vec![0.0; FOLDED_ROWS]; n];
            let mut fold = optimise::RowFold::new(n + 1);
            let mut at = 0;
            while at < m {
                if self.observer.is_some_and(|o| o.cancelled()) {
                    return Err(Error::Cancelled);
                }
                let rows = FOLDED_ROWS.min(m - at);
                let made: Vec<std::result::Result<usize, StreamFailure>> = columns
                    .par_iter_mut()
                    .zip(buffers.par_iter_mut())
                    .map(|(c, b)| c.fill(&mut b[..rows]))
                    .collect();
                for (j, made) in made.into_iter().enumerate() {
                    match made {
                        Ok(k) if k == rows => {}
                        Ok(k) => {
                            return Err(Error::NotConverged {
                                stage: "time-domain Jacobian",
                                reason: format!(
                                    "column {j} made {k} of the {rows} residuals from row {at}"
                                ),
                            });
                        }
                        Err(StreamFailure::RejectedPartway(i)) => {
                            rejected[j][i] = true;
                            continue 'again;
                        }
                        Err(StreamFailure::Error(e)) => return Err(e),
                    }
                }
                let block = nalgebra::DMatrix::from_fn(rows, n + 1, |i, k| {
                    let b = r0[at + i];
                    if k == 0 {
                        b
                    } else {
                        (buffers[k - 1][i] - b) / step
                    }
                });
                fold.fold(&block);
                at += rows;
            }
            // the penalty row: the residual's, its derivative zero inside
            // the bounds
            let mut penalty = nalgebra::DMatrix::zeros(1, n + 1);
            penalty[(0, 0)] = r0[m];
            fold.fold(&penalty);
            // each column is a residual vector computed: counted and shown
            // as `residuals_into` does
            for (j, (c, (_, outside))) in columns.iter().zip(&models).enumerate() {
                let replay = self.replays.fetch_add(1, Ordering::Relaxed) + 1;
                if let Some(o) = self.observer {
                    let rms = (c.sum_of_squares / m.max(1) as f64).sqrt();
                    let pen = outside * 10.0 * rms * (m as f64).sqrt();
                    let mut t = theta.to_vec();
                    t[j] += step;
                    let entry = crate::observe::TraceEntry {
                        evaluation: replay,
                        cost: c.sum_of_squares + pen * pen,
                        parameters: self.parameters.values(&t),
                    };
                    o.observe(crate::observe::Event::Cost(&entry));
                }
            }
            return Ok(fold.finish());
        }
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
    fn replay_factor_of(&self, model: &Model, i: usize) -> Result<usize> {
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
    fn replay_on(
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

    /// [`TimeProblem::judged_residuals_into`] with record `i` replayed at
    /// `replay_factor` times its rate, whatever grid it is fixed on.
    fn judged_residuals_on(
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
    fn residuals_into(&self, theta: &[f64], out: &mut [f64]) -> Result<()> {
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

impl Objective for TimeProblem<'_> {
    /// See [`TimeProblem::residuals_into`].
    fn residuals(&self, theta: &[f64]) -> Result<Vec<f64>> {
        let judged: usize = self.judged_samples().iter().sum();
        let mut r = vec![0.0; judged + 1];
        self.residuals_into(theta, &mut r)?;
        Ok(r)
    }
    fn cost(&self, theta: &[f64]) -> Result<f64> {
        self.evaluations.fetch_add(1, Ordering::Relaxed);
        Ok(self.residuals(theta)?.iter().map(|v| v * v).sum::<f64>())
    }
    fn evaluations(&self) -> usize {
        self.evaluations.load(Ordering::Relaxed)
    }
    /// Written into its final matrix: a long recording's Jacobian (a column
    /// per parameter, a row per judged sample) is the largest thing the fit
    /// holds.
    fn jacobian_with_penalty_row(
        &self,
        theta: &[f64],
        r0: &[f64],
        step: f64,
    ) -> Result<nalgebra::DMatrix<f64>> {
        // each column's residuals written into it (a residual vector per
        // column in flight was as large as the column)
        optimise::forward_difference_in_place(theta, r0, step, |t, column| {
            self.residuals_into(t, column)
        })
    }
    /// Where the Jacobian would hold more than [`JACOBIAN_HELD_UP_TO`]
    /// entries (or the problem says so: [`TimeProblem::with_jacobian_held_up_to`]).
    fn folds_jacobian(&self) -> bool {
        let judged: usize = self.judged_samples().iter().sum();
        judged.saturating_mul(self.parameters.parameters.len()) > self.jacobian_held_up_to
    }
    /// See [`TimeProblem::jacobian_r_factor`].
    fn jacobian_r_factor(
        &self,
        theta: &[f64],
        r0: &[f64],
        step: f64,
    ) -> Result<nalgebra::DMatrix<f64>> {
        TimeProblem::jacobian_r_factor(self, theta, r0, step)
    }
}

/// The starts' joint slips at these multiples of the displacement's RMS
/// (from slipping over most of every cycle to sticking throughout). A start
/// that sticks throughout has no gradient in the slip force and one that
/// slips throughout none in the stick stiffness, so the fit starts from the
/// best of a grid over this, [`START_STRUCTURE`], [`START_JOINT`] and
/// [`START_DAMPING`].
pub const START_SLIP_RMS: [f64; 5] = [0.1, 0.3, 1.0, 3.0, 10.0];

/// The structure's stiffness in the starts, as fractions of the linear
/// estimate's: the linear estimate is the structure and the joint together,
/// at the response's amplitude, and how much of it a slipping joint carries
/// is not known.
pub const START_STRUCTURE: [f64; 4] = [0.25, 0.5, 0.75, 1.0];

/// The joint's stick stiffness in the starts, as multiples of the linear
/// estimate's stiffness.
pub const START_JOINT: [f64; 3] = [0.25, 1.0, 4.0];

/// The structure's damping in the starts, as fractions of the linear
/// estimate's: that holds the joint's dissipation too.
pub const START_DAMPING: [f64; 3] = [0.25, 0.5, 1.0];

/// One start of the grid of [`periodic_starts`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct StartShape {
    /// The joint's slip, multiples of the displacement's RMS.
    pub slip_rms: f64,
    /// The structure's stiffness, a fraction of the linear estimate's.
    pub structure: f64,
    /// The joint's stick stiffness, a multiple of the linear estimate's.
    pub joint: f64,
    /// The structure's damping, a fraction of the linear estimate's.
    pub damping: f64,
}

/// The starts of a time-domain fit of a periodic excitation without a model
/// written down: `linear` an SDOF fitted to the linear FRF at the excited
/// lines (`1/(k − mω² + jcω)`, the FRF fit's own linear estimate; `lines`
/// of `quantity` per force), and a joint of `kind` beside a structure of
/// its mass, over the grid of [`START_SLIP_RMS`] (from
/// `displacement_rms`, the displacement's RMS as the linear estimate
/// predicts it), [`START_STRUCTURE`], [`START_JOINT`] and
/// [`START_DAMPING`]. Returns the starts with their shapes, and the SDOF.
pub fn periodic_starts(
    lines: &[super::FrfSample],
    quantity: Quantity,
    kind: crate::model::ElementKind,
    displacement_rms: impl Fn(&super::SdofEstimate) -> f64,
) -> Result<(Vec<(Model, StartShape)>, super::SdofEstimate)> {
    let linear = super::fit_sdof(lines, quantity, "the excited lines")?;
    let starts = start_grid(
        kind,
        displacement_rms(&linear),
        linear.stiffness,
        |structure, damping| {
            crate::model::ModalModel::sdof(
                linear.mass,
                damping * linear.damping,
                structure * linear.stiffness,
            )
        },
    )?;
    Ok((starts, linear))
}

/// The grid of [`periodic_starts`]: a joint of `kind` whose stick stiffness
/// is [`START_JOINT`] times `stiffness` and whose slip is [`START_SLIP_RMS`]
/// times `x`, the displacement's RMS the linear estimate predicts, beside
/// `structure(stiffness share, damping share)` over [`START_STRUCTURE`] and
/// [`START_DAMPING`].
fn start_grid(
    kind: crate::model::ElementKind,
    x: f64,
    stiffness: f64,
    structure: impl Fn(f64, f64) -> Result<crate::model::ModalModel>,
) -> Result<Vec<(Model, StartShape)>> {
    if !(x.is_finite() && x > 0.0) {
        return Err(Error::input(
            "response",
            format!("the linear estimate predicts no displacement (RMS {x:e} m)"),
        ));
    }
    let mut starts = Vec::new();
    for slip_rms in START_SLIP_RMS {
        for share in START_STRUCTURE {
            for joint in START_JOINT {
                for damping in START_DAMPING {
                    let kd = joint * stiffness;
                    let spec =
                        crate::model::ElementSpec::joint(kind, kd, kd * slip_rms * x, "--element")?;
                    let model =
                        Model::with_joint(structure(share, damping)?, Some(spec), Vec::new())?;
                    let shape = StartShape {
                        slip_rms,
                        structure: share,
                        joint,
                        damping,
                    };
                    starts.push((model, shape));
                }
            }
        }
    }
    Ok(starts)
}

/// The linear estimate at a multisine's excited lines with `modes` modes:
/// the SDOF fit ([`super::fit_sdof`]) is the dominant mode, `modes − 1`
/// more are located in its residual and all are refitted together
/// ([`super::linear::locate_extra_mode`], [`super::linear::fit_modes`]), as
/// the FRF fit's linear start does for a level. The modal constants carry
/// the SDOF's sign (a transfer's are negative). Returns the modes and the
/// SDOF.
pub fn linear_modes_at_lines(
    lines: &[super::FrfSample],
    quantity: Quantity,
    modes: usize,
) -> Result<(crate::model::ModalModel, super::SdofEstimate)> {
    use crate::model::{ModalModel, Mode};
    let what = "the excited lines";
    let sdof = super::fit_sdof(lines, quantity, what)?;
    // fitted to H × sign, so that every modal constant starts positive
    let signed: Vec<super::FrfSample> = lines
        .iter()
        .map(|l| super::FrfSample {
            h: l.h * sdof.sign,
            ..*l
        })
        .collect();
    let mut m = ModalModel::new(vec![Mode::from_mck(
        sdof.mass,
        sdof.damping,
        sdof.stiffness,
    )?])?;
    for _ in 1..modes {
        let guess = super::linear::locate_extra_mode(&signed, quantity, &m)
            .ok_or_else(|| Error::input(what, "too few lines to locate another mode"))?;
        m.modes.push(guess);
        m = super::linear::fit_modes(&signed, quantity, &m, what)?.0;
    }
    for mode in &mut m.modes {
        mode.residue *= sdof.sign;
    }
    Ok((m, sdof))
}

/// [`periodic_starts`] for a structure of several modes
/// ([`linear_modes_at_lines`]): the grid's shares of stiffness and damping
/// are the dominant mode's (the one the joint softens: the SDOF fit's), the
/// joint's stick stiffness a multiple of that mode's modal stiffness, and
/// its slip force from `displacement_rms` of the modes' receptance. The
/// other modes are kept as estimated. Returns the starts with their shapes,
/// and the modes.
pub fn periodic_starts_modal(
    lines: &[super::FrfSample],
    quantity: Quantity,
    kind: crate::model::ElementKind,
    modes: usize,
    displacement_rms: impl Fn(&crate::model::ModalModel) -> f64,
) -> Result<(Vec<(Model, StartShape)>, crate::model::ModalModel)> {
    let (linear, _) = linear_modes_at_lines(lines, quantity, modes)?;
    // the dominant mode: the SDOF fit's, refitted among the others
    let main = &linear.modes[0];
    let (sign, mass, damping, stiffness) = (
        main.residue.signum(),
        main.modal_mass().abs(),
        main.modal_damping().abs(),
        main.modal_stiffness().abs(),
    );
    let starts = start_grid(
        kind,
        displacement_rms(&linear),
        stiffness,
        |structure, share| {
            let mut dominant =
                crate::model::Mode::from_mck(mass, share * damping, structure * stiffness)?;
            dominant.residue *= sign;
            let mut m = linear.clone();
            m.modes[0] = dominant;
            Ok(m)
        },
    )?;
    Ok((starts, linear))
}

/// Most samples [`closest_start`] judges each start on (an eighth of
/// [`MAX_JUDGED_SAMPLES`]): a grid of 180 starts replayed over a long
/// multisine's million judged samples takes minutes, and the starts differ
/// by far more than a part of the record can hide.
pub const START_JUDGED_SAMPLES: usize = MAX_JUDGED_SAMPLES / 8;

/// The index of the start whose replay is closest to `records` (the fit's
/// own misfit over what it judges, [`TimeProblem::judged_misfit`]: each
/// segment's squared relative e_RMS, summed; judged on at most
/// [`START_JUDGED_SAMPLES`]), replayed on the coarsest grid
/// that replays the start of the highest frequency as the options' rate
/// does ([`TimeProblem::fix_replay_grid`]); a start the simulator rejects
/// is passed over, ties go to the first. `None` when the simulator rejects
/// every one.
pub fn closest_start(
    starts: &[Model],
    records: &[TimeRecord],
    options: &TimeFitOptions,
) -> Result<Option<(usize, f64)>> {
    use rayon::prelude::*;
    let Some(first) = starts.first() else {
        return Ok(None);
    };
    // one problem: the drives are prepared (resampled) once for every start;
    // a long record's starts told apart on a part of what the fit judges
    let options = TimeFitOptions {
        max_judged_samples: options.max_judged_samples.min(START_JUDGED_SAMPLES),
        ..options.clone()
    };
    let mut problem = TimeProblem::new(
        first.clone(),
        ParameterSet::default(),
        records,
        1.0,
        options,
        None,
    )?;
    // replayed on the grid the start with the highest frequency needs (see
    // `fix_replay_grid`), not at the sure rate: a grid of starts replayed
    // at 12 times a long multisine's rate takes minutes
    let slowest = records
        .iter()
        .map(|r| r.sample_rate_hz)
        .fold(f64::INFINITY, f64::min);
    let top = |m: &Model| m.highest_replayed_frequency_hz(quasi_static_above_hz(slowest));
    let stiffest = starts
        .iter()
        .max_by(|a, b| top(a).total_cmp(&top(b)))
        .expect("one start at least");
    problem.fix_replay_grid(stiffest, "stiffest start");
    let misfits = starts
        .par_iter()
        .map(|m| match problem.judged_misfit(m) {
            Ok(misfit) => Ok(Some(misfit)),
            Err(Error::InvalidModel { .. } | Error::NotConverged { .. }) => Ok(None),
            Err(e) => Err(e),
        })
        .collect::<Result<Vec<Option<f64>>>>()?;
    Ok(misfits
        .into_iter()
        .enumerate()
        .filter_map(|(i, m)| m.filter(|v| v.is_finite()).map(|v| (i, v)))
        .min_by(|a, b| a.1.total_cmp(&b.1).then(a.0.cmp(&b.0))))
}

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
const LM_TOLERANCE: f64 = 1.49e-8;

/// How many times a fit resumes on a finer replay grid its optimum needs
/// (see [`TimeProblem::fix_replay_grid`]).
const MAX_GRID_RESUMPTIONS: usize = 2;

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

/// `s² (JᵀJ)⁻¹` over the columns of `jac` that are free (not `at_bound`)
/// and felt, with those columns' indices.
///
/// Directly: `optimise::covariance` never deflates below the unit
/// variances, and these residuals are relative errors (≪ 1). A parameter
/// the replay does not feel at all (a damping ratio driven to 1e-20 beside
/// a joint that gives all the damping: a step in it leaves the replay the
/// same to the bit, its column zero) makes `JᵀJ` singular and would leave
/// every parameter without an interval; it is left out instead (reported
/// as not determined).
fn felt_covariance(
    jac: &nalgebra::DMatrix<f64>,
    at_bound: &[bool],
    s2: f64,
) -> (Vec<usize>, Option<nalgebra::DMatrix<f64>>) {
    // `JᵀJ` of the Jacobian itself, neither its transpose nor its free
    // columns copied (either as large as the Jacobian: a long recording's is
    // the largest thing the fit holds); each entry is one column's dot
    // product with another, so the free columns' entries are the same bits
    // as those of their copy's `JᵀJ`
    let norms: Vec<f64> = jac.column_iter().map(|c| c.norm()).collect();
    felt_covariance_of_gram(&jac.tr_mul(jac), &norms, at_bound, s2)
}

/// [`felt_covariance`] from `JᵀJ` and the columns' norms (a Jacobian folded
/// into its R factor has both, not the Jacobian).
fn felt_covariance_of_gram(
    gram: &nalgebra::DMatrix<f64>,
    norms: &[f64],
    at_bound: &[bool],
    s2: f64,
) -> (Vec<usize>, Option<nalgebra::DMatrix<f64>>) {
    let unfelt = optimise::unfelt_of_norms(norms, at_bound);
    let free: Vec<usize> = (0..norms.len())
        .filter(|&j| !at_bound[j] && !unfelt[j])
        .collect();
    let jtj = nalgebra::DMatrix::from_fn(free.len(), free.len(), |a, b| gram[(free[a], free[b])]);
    let cov = jtj.try_inverse().map(|a| a * s2);
    (free, cov)
}

/// Estimates with 95 % intervals from the Jacobian at `theta`, the residual
/// taken as white noise (see the module docs). A parameter at a bound gets
/// no interval (`identifiable: false`, with a note).
fn time_confidence(problem: &TimeProblem, theta: &[f64]) -> Result<BTreeMap<String, Estimate>> {
    let params = &problem.parameters;
    let r0 = problem.residuals(theta)?;
    let values = params.values(theta);
    let at_bound = params.at_bounds(&values);
    let m = r0.len() - 1;
    let s2 = r0[..m].iter().map(|v| v * v).sum::<f64>() / (m as f64 - theta.len() as f64).max(1.0);
    let (free, cov) = if problem.folds_jacobian() {
        // `JᵀJ` is the R factor's last columns' own
        let rf = problem.jacobian_r_factor(theta, &r0, 1e-5)?;
        let c = rf.columns(1, theta.len());
        let norms: Vec<f64> = c.column_iter().map(|c| c.norm()).collect();
        felt_covariance_of_gram(&c.tr_mul(&c), &norms, &at_bound, s2)
    } else {
        // written in place (a residual vector per column in flight was as
        // large as the column), its penalty row zero: `JᵀJ` the same
        let jac = problem.jacobian_with_penalty_row(theta, &r0, 1e-5)?;
        felt_covariance(&jac, &at_bound, s2)
    };
    let mut out = BTreeMap::new();
    for (j, p) in params.parameters.iter().enumerate() {
        let value = values[j];
        let k = free.iter().position(|&f| f == j);
        let sd = match (&cov, k) {
            (Some(c), Some(k)) => c[(k, k)].sqrt(),
            _ => f64::NAN,
        };
        let (ci95, identifiable, note) = if at_bound[j] {
            (
                [value, value],
                false,
                Some(format!("{} sits at its bound", p.name)),
            )
        } else if !sd.is_finite() {
            (
                [f64::NEG_INFINITY, f64::INFINITY],
                false,
                Some(format!("{} is not determined by the recordings", p.name)),
            )
        } else {
            let (lo, hi) = (p.value(theta[j] - 1.96 * sd), p.value(theta[j] + 1.96 * sd));
            let wide = matches!(p.transform, Transform::Log) && sd > 1.0;
            (
                [lo.min(hi), lo.max(hi)],
                !wide,
                wide.then(|| {
                    format!(
                        "{} is poorly determined: its 95 % interval spans more than a factor 50",
                        p.name
                    )
                }),
            )
        };
        out.insert(
            p.name.clone(),
            Estimate {
                value,
                ci95,
                identifiable,
                note,
                bootstrap_ci95: None,
            },
        );
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A column the replay does not feel (exactly zero) is left out of the
    /// covariance, which the others then have: with it, `JᵀJ` is singular.
    #[test]
    fn an_unfelt_parameter_is_left_out_of_the_covariance() {
        let jac = nalgebra::DMatrix::from_row_slice(
            4,
            3,
            &[
                1.0, 0.0, 0.5, //
                0.0, 0.0, 1.0, //
                2.0, 0.0, 0.0, //
                1.0, 0.0, 1.0,
            ],
        );
        let (free, cov) = felt_covariance(&jac, &[false; 3], 2.0);
        assert_eq!(free, vec![0, 2]);
        // the two felt columns' `s² (JᵀJ)⁻¹`, by hand: JᵀJ = [[6, 1.5], [1.5, 2.25]]
        let det = 6.0 * 2.25 - 1.5 * 1.5;
        let expected = [2.0 * 2.25 / det, -2.0 * 1.5 / det, 2.0 * 6.0 / det];
        let cov = cov.expect("invertible without the unfelt column");
        for (got, want) in [cov[(0, 0)], cov[(0, 1)], cov[(1, 1)]]
            .into_iter()
            .zip(expected)
        {
            assert!((got - want).abs() < 1e-12, "{got} against {want}");
        }
        // with every column kept there is no inverse
        let all = (jac.transpose() * &jac).try_inverse();
        assert!(all.is_none());
        // a tall Jacobian with a column at its bound: the free columns'
        // `JᵀJ`, read from the whole one's, is the same bits as that of their
        // copy (each entry one column's dot product with another)
        let tall = nalgebra::DMatrix::from_fn(5_001, 4, |i, j| {
            ((i * 7 + j * 13) as f64 * 0.37).sin() * (1.0 + j as f64)
        });
        let at_bound = [false, true, false, false];
        let (free, cov) = felt_covariance(&tall, &at_bound, 1.5);
        assert_eq!(free, vec![0, 2, 3]);
        let copy = nalgebra::DMatrix::from_fn(tall.nrows(), 3, |i, k| tall[(i, free[k])]);
        let want = copy.tr_mul(&copy).try_inverse().expect("invertible") * 1.5;
        assert_eq!(cov.expect("invertible"), want);
    }
    use crate::signals::{Channel, Excitation, ExcitationKind, Recording, RecordingMeta, Step};
    use std::f64::consts::PI;
    /// The further starts are the same on every call, move a parameter
    /// fitted in its logarithm by up to a factor 1.5, a reciprocal one
    /// likewise and a linear one by up to 15 %, cover that range both ways
    /// (the draws are uniform: over 400 starts the extremes come within 2 %
    /// of it and the mean within 0.1 of the middle), and stay strictly
    /// inside the bounds: a start on a bound (a damping ratio at its
    /// largest) is moved off it.
    #[test]
    fn further_starts_are_spread_about_the_given_one_inside_the_bounds() {
        use super::super::params::{Parameter, Target};
        let p = |transform, bounds| Parameter {
            name: "p".into(),
            target: Target::Mass { mode: 0 },
            transform,
            bounds,
        };
        let set = ParameterSet {
            parameters: vec![
                p(Transform::Log, [1e-3, 1e3]),
                p(Transform::Scaled { scale: 0.1 }, [0.0, 0.9]),
                p(Transform::Reciprocal, [1.0, 1e3]),
            ],
        };
        let values = [2.0, 0.9, 10.0];
        let theta0: Vec<f64> = set
            .parameters
            .iter()
            .zip(values)
            .map(|(p, v)| p.theta(v))
            .collect();
        let mut shares: Vec<Vec<f64>> = vec![Vec::new(); 3];
        for k in 1..=400 {
            let t = spread_start(&set, &theta0, k);
            assert_eq!(t, spread_start(&set, &theta0, k));
            let v = set.values(&t);
            let ratio = v[0] / values[0];
            assert!((1.0 / 1.5..=1.5).contains(&ratio), "{ratio}");
            shares[0].push(ratio.ln() / 1.5f64.ln());
            // from its upper bound: only down, and never on it
            assert!(v[1] < 0.9 && v[1] >= 0.9 * 0.85, "{}", v[1]);
            let ratio = v[2] / values[2];
            assert!((1.0 / 1.5..=1.5).contains(&ratio), "{ratio}");
            shares[2].push(ratio.ln() / 1.5f64.ln());
        }
        assert_ne!(
            spread_start(&set, &theta0, 1),
            spread_start(&set, &theta0, 2)
        );
        for u in [&shares[0], &shares[2]] {
            let (lo, hi) = u
                .iter()
                .fold((1.0f64, -1.0f64), |(a, b), &x| (a.min(x), b.max(x)));
            let mean = u.iter().sum::<f64>() / u.len() as f64;
            assert!(
                lo < -0.98 && hi > 0.98 && mean.abs() < 0.1,
                "{lo} {hi} {mean}"
            );
        }
    }

    /// The judging factor: the smallest that brings the samples within the
    /// bound, over all the recordings; none below 8 samples a period of the
    /// model's highest frequency, nor above the resampling limit.
    #[test]
    fn a_fit_judges_at_the_lowest_rate_its_bound_asks_and_its_model_allows() {
        let rec = |fs: f64, n: usize| TimeRecord {
            name: "r".into(),
            reference: vec![1.0; n].into(),
            reference_quantity: Quantity::Force,
            response: vec![1.0; n].into(),
            sample_rate_hz: fs,
            quantity: Quantity::Displacement,
            window: 0..n,
            segments: vec![0..n / 2, n / 2..n],
            band_hz: None,
            periodic: false,
        };
        let two = [rec(30_000.0, 6_000_000), rec(30_000.0, 2_230_473)];
        // 8 230 473 over 2^20: 8; 30 kHz allows 12 at 293 Hz, 3 at 1 kHz
        assert_eq!(judging_factors(&two, 293.0, MAX_JUDGED_SAMPLES), vec![8, 8]);
        assert_eq!(
            judging_factors(&two, 1000.0, MAX_JUDGED_SAMPLES),
            vec![3, 3]
        );
        // within the bound, or no frequency to go by: every sample
        assert_eq!(judging_factors(&two, 293.0, 1 << 24), vec![1, 1]);
        assert_eq!(judging_factors(&two, f64::NAN, 1000), vec![1, 1]);
        // a slow recording beside a fast one keeps its own floor
        let mixed = [rec(30_000.0, 8_000_000), rec(2_000.0, 1_000_000)];
        assert_eq!(
            judging_factors(&mixed, 100.0, MAX_JUDGED_SAMPLES),
            vec![9, 2]
        );
        assert_eq!(
            judging_factors(&mixed, 1.0, 1000),
            vec![MAX_FACTOR, MAX_FACTOR]
        );
    }

    /// A stepped sine of `steps`, stated.
    fn stepped(steps: Vec<Step>) -> Excitation {
        Excitation {
            kind: ExcitationKind::SteppedSine,
            steps,
            sweep: None,
        }
    }

    fn recording(fs: f64, force: Vec<f64>, excitation: Excitation) -> Recording {
        let channel = |name: &str, quantity: Quantity| Channel {
            name: name.into(),
            quantity,
            unit: quantity.si_unit().into(),
            scale: 1.0,
        };
        // any response that is not silent: the band only picks samples
        let response: Vec<f64> = force.iter().map(|f| 1e-3 * f).collect();
        Recording {
            meta: RecordingMeta {
                format: crate::record::FORMAT_V1.into(),
                sample_rate_hz: fs,
                channels: vec![
                    channel("force", Quantity::Force),
                    channel("x", Quantity::Displacement),
                ],
                excitation,
                description: String::new(),
                metadata: Default::default(),
                extra: Default::default(),
                chosen_reference: None,
            },
            channels: vec![force, response],
        }
    }

    /// A linear sweep 2 -> 20 Hz over 100 s at 200 Hz: the band 5-10 Hz is
    /// reached at t = 50/3 s and left at 400/9 s, by the closed form
    /// `f(t) = 2 + 0.18 t`, so the window is samples 3333..8889 (within the
    /// phase fit's rounding, a sample).
    #[test]
    fn a_swept_record_is_judged_where_the_sweep_is_in_the_band() {
        let fs = 200.0;
        let force: Vec<f64> = (0..20_000)
            .map(|i| {
                let t = i as f64 / fs;
                (2.0 * PI * (2.0 * t + 0.09 * t * t)).sin()
            })
            .collect();
        let kind = |kind| Excitation {
            kind,
            ..Excitation::default()
        };
        let rec = recording(fs, force, kind(ExcitationKind::SweptSine));
        let r = TimeRecord::from_recording("sweep", &rec, 1, None, Some((5.0, 10.0))).unwrap();
        let want = (50.0 / 3.0 * fs, 400.0 / 9.0 * fs);
        assert!(
            (r.window.start as f64 - want.0).abs() <= 2.0
                && (r.window.end as f64 - want.1).abs() <= 2.0,
            "{:?} against {want:?}",
            r.window
        );
        assert_eq!(r.segments, vec![r.window.clone()]);
        let all = TimeRecord::from_recording("sweep", &rec, 1, None, None).unwrap();
        assert_eq!(all.window, 0..20_000);
        let e = TimeRecord::from_recording("sweep", &rec, 1, None, Some((30.0, 40.0)))
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("sweep: band") && e.contains("never inside"),
            "{e}"
        );
    }

    /// Three stated dwells at 4, 6 and 8 Hz: the band 5-7 Hz keeps the
    /// middle one's segment only; a band holding none is an error.
    #[test]
    fn a_stepped_record_is_judged_on_its_dwells_in_the_band() {
        let fs = 200.0;
        let steps: Vec<Step> = [4.0, 6.0, 8.0]
            .iter()
            .enumerate()
            .map(|(k, &f)| Step {
                frequency_hz: f,
                level: 1.0,
                start: 1000 * k,
                settle: 0,
                length: 1000,
            })
            .collect();
        let force: Vec<f64> = (0..3000)
            .map(|i| (2.0 * PI * steps[i / 1000].frequency_hz * i as f64 / fs).sin())
            .collect();
        let rec = recording(fs, force, stepped(steps));
        let r = TimeRecord::from_recording("dwells", &rec, 1, None, Some((5.0, 7.0))).unwrap();
        assert_eq!(r.segments, vec![1000..2000]);
        let all = TimeRecord::from_recording("dwells", &rec, 1, None, None).unwrap();
        assert_eq!(all.segments.len(), 3);
        let e = TimeRecord::from_recording("dwells", &rec, 1, None, Some((9.0, 10.0)))
            .unwrap_err()
            .to_string();
        assert!(e.contains("no dwell"), "{e}");
    }

    /// `model`'s displacement driven by `force` sampled at `fs` (20 samples
    /// a period of its highest frequency, noise-free).
    fn displacement_of(model: &Model, force: &[f64], fs: f64) -> Vec<f64> {
        crate::validate::simulate_response(model, force, fs, Quantity::Displacement, 1.0, 20.0)
            .unwrap()
            .values
    }

    /// An SDOF at 60 Hz (1 kg, 2 % damping) with a Jenkins joint of slip
    /// force 40 N and stick stiffness `kd` times the linear one, driven in
    /// three stated dwells (52 Hz at 20 N, 60 and 71 Hz at 60 N; 12 000
    /// samples each at 4 kHz after 500 of silence): the recording of the
    /// joint at `kd` 1.2, noise-free; the model as a function of `kd`.
    fn jenkins_dwells() -> (Recording, impl Fn(f64) -> Model, Model) {
        use crate::model::{ElementSpec, ModalModel};
        let fs = 4000.0;
        let w = 2.0 * PI * 60.0;
        let model = move |kd: f64| {
            Model::new(
                ModalModel::sdof(1.0, 2.0 * 0.02 * w, w * w).unwrap(),
                vec![ElementSpec::Jenkins {
                    kd: kd * w * w,
                    fd: 40.0,
                }],
            )
            .unwrap()
        };
        let mut force = Vec::new();
        let mut steps = Vec::new();
        for (f, level) in [(52.0, 20.0), (60.0, 60.0), (71.0, 60.0)] {
            force.extend(std::iter::repeat_n(0.0, 500));
            steps.push(Step {
                frequency_hz: f,
                level,
                start: force.len(),
                settle: 4000,
                length: 12_000,
            });
            force.extend((0..12_000).map(|i| level * (2.0 * PI * f * i as f64 / fs).sin()));
        }
        let truth = model(1.2);
        let measured = displacement_of(&truth, &force, fs);
        let mut rec = recording(fs, force, stepped(steps));
        rec.channels[1] = measured;
        (rec, model, truth)
    }

    /// A problem of the joint's parameters from `start`, judging at most
    /// `most` samples.
    fn judged_within<'a>(start: &Model, records: &'a [TimeRecord], most: usize) -> TimeProblem<'a> {
        let options = TimeFitOptions {
            max_judged_samples: most,
            ..TimeFitOptions::default()
        };
        let parameters = time_parameters(start, false, None);
        TimeProblem::new(start.clone(), parameters, records, 1.0, options, None).unwrap()
    }

    /// The joint fitted from `start` judging at most `most` samples, its
    /// stick stiffness checked against `truth`'s to `tolerance`.
    fn fits_kd_within(
        start: &Model,
        records: &[TimeRecord],
        most: usize,
        truth: &Model,
        tolerance: f64,
    ) -> TimeFitResult {
        let options = TimeFitOptions {
            max_judged_samples: most,
            refine_linear: false,
            ..TimeFitOptions::default()
        };
        let parameters = time_parameters(start, false, None);
        let fit = identify_time(start, parameters, 1.0, records, &options, None).unwrap();
        let kd = |m: &Model| match m.elements().next() {
            Some(&crate::model::ElementSpec::Jenkins { kd, .. }) => kd,
            _ => unreachable!(),
        };
        let error = kd(&fit.model) / kd(truth) - 1.0;
        assert!(error.abs() < tolerance, "kd {error:e} off");
        fit
    }

    /// Where the floor of [`MIN_JUDGED_PER_PERIOD`] samples a period keeps
    /// more samples than the bound, each dwell is judged on its share, in
    /// stretches: the judged samples stay within the bound, every stretch
    /// inside its dwell (a dwell of one stretch judged on its last
    /// samples), each residual the one judging every sample at that rate
    /// gives there but for the divisor (its dwell's RMS over what is
    /// judged), and the fit still finds the joint (noise-free: to 1e-6).
    #[test]
    fn a_recording_the_floor_keeps_above_the_bound_is_judged_in_stretches_of_each_dwell() {
        let (rec, model, truth) = jenkins_dwells();
        let records = [TimeRecord::from_recording("dwells", &rec, 1, None, None).unwrap()];
        let start = model(1.0);
        let problem = |most: usize| judged_within(&start, &records, most);
        // 37 500 samples; the stick mode at 60·√2.2 = 89 Hz allows at most
        // 4000/(8·89) = 5.6: one in 5, 7 500 judged, more than 3 000
        let (part, whole) = (problem(3_000), problem(7_500));
        assert_eq!(part.judging_factors(), [5]);
        assert_eq!(whole.judging_factors(), [5]);
        assert!(part.judged_in_part() && !whole.judged_in_part());
        let judged = part.judged_samples()[0];
        assert!((2_997..=3_000).contains(&judged), "{judged}");
        let (jp, jw) = (&part.judging[0], &whole.judging[0]);
        let mut last_end = 0;
        for (s, k) in &jp.stretches {
            let segment = &jw.stretches[*k].0;
            assert!(s.start >= segment.start && s.end <= segment.end && s.start >= last_end);
            assert!(s.len() <= JUDGED_STRETCH);
            last_end = s.end;
        }
        // 2 500 a dwell at 1/5 of 12 500: a share of 1 000, one stretch
        for (k, segment) in jw.stretches.iter().enumerate() {
            let mine: Vec<_> = jp.stretches.iter().filter(|(_, j)| *j == k).collect();
            assert_eq!(mine.len(), 1);
            assert_eq!(mine[0].0.end, segment.0.end);
        }
        let theta = part.parameters().theta_of(&start).unwrap();
        let (rp, rw) = (
            part.residuals(&theta).unwrap(),
            whole.residuals(&theta).unwrap(),
        );
        let mut p = 0;
        for (s, k) in &jp.stretches {
            for q in s.clone() {
                let at_whole = q - jw.stretches[*k].0.start
                    + jw.stretches[..*k]
                        .iter()
                        .map(|(s, _)| s.len())
                        .sum::<usize>();
                let (a, b) = (rp[p] * jp.scale[*k], rw[at_whole] * jw.scale[*k]);
                assert!(
                    (a - b).abs() <= 1e-12 * b.abs().max(1e-9),
                    "{q}: {a} against {b}"
                );
                p += 1;
            }
        }
        assert_eq!(p, judged);
        let fit = fits_kd_within(&start, &records, 3_000, &truth, 1e-6);
        assert_eq!(fit.samples, judged);
        assert!(
            fit.notes
                .iter()
                .any(|n| n.contains("in stretches of at most"))
        );
    }

    /// A periodic record judged in part is judged on its first steady
    /// periods whole (the periods are alike), not on a share of each: the
    /// judged samples within the bound, the stretches the first periods
    /// (the last in part), each residual the one judging every steady
    /// sample gives there but for the divisor, and the fit still finds the
    /// joint (noise-free: to 1e-6). Its replays stop at the last judged
    /// sample, which leaves the residuals as they were.
    #[test]
    fn a_periodic_record_judged_in_part_is_judged_on_its_first_periods() {
        let (_, model, truth) = jenkins_dwells();
        let fs = 4000.0;
        // lines 40-80 Hz every 4 Hz (period 2 000 samples), Schroeder
        // phases, 8 periods: the joint slips on the peaks
        let (period, periods) = (2000, 8);
        let lines: Vec<usize> = (20..=40).step_by(2).collect();
        let force: Vec<f64> = (0..period * periods)
            .map(|i| {
                lines
                    .iter()
                    .enumerate()
                    .map(|(j, &l)| {
                        let phase = -PI * (j * (j + 1)) as f64 / lines.len() as f64;
                        let t = (i % period) as f64 / period as f64;
                        10.0 * (2.0 * PI * l as f64 * t + phase).cos()
                    })
                    .sum()
            })
            .collect();
        let measured = displacement_of(&truth, &force, fs);
        let rec = recording(fs, force.clone(), Excitation::default());
        let record = TimeRecord::steady_periods(
            "multisine",
            &rec.meta,
            1,
            (force.into(), measured.into()),
            period,
        )
        .unwrap()
        .unwrap();
        assert!(record.periodic && record.segments.len() == periods - 1);
        let records = [record];
        let start = model(1.0);
        let problem = |most: usize| judged_within(&start, &records, most);
        // judged at one in 5 (the stick mode at 89 Hz): 400 a period, 2 800
        // in all; a bound of 1 000 gives each period a share of 142: two
        // periods whole and 194 samples of the third
        let (part, whole) = (problem(1_000), problem(2_800));
        assert_eq!(part.judging_factors(), [5]);
        assert!(part.judged_in_part() && !whole.judged_in_part());
        let (jp, jw) = (&part.judging[0], &whole.judging[0]);
        let first = |k: usize, n: usize| {
            let s = &jw.stretches[k].0;
            (s.start..s.start + n, k)
        };
        assert_eq!(jp.stretches, [first(0, 400), first(1, 400), first(2, 194)]);
        assert_eq!(part.judged_samples(), [994]);
        let theta = part.parameters().theta_of(&start).unwrap();
        let (rp, rw) = (
            part.residuals(&theta).unwrap(),
            whole.residuals(&theta).unwrap(),
        );
        // every sample judged: the misfit a start is chosen by is the sum
        // of the segments' relative errors squared
        let every = problem(14_000);
        assert_eq!(every.judging_factors(), [1]);
        let by_segment: f64 = every.errors(&start).unwrap()[0].segment_relative.powi(2);
        let judged = every.judged_misfit(&start).unwrap();
        assert!(
            (judged - by_segment).abs() < 1e-12 * by_segment,
            "{judged} {by_segment}"
        );
        // the judged samples', then the bounds' penalty row
        assert_eq!(rp.len(), 994 + 1);
        for (p, a) in rp[..994].iter().enumerate() {
            let k = p / 400;
            let (a, b) = (a * jp.scale[k], rw[p] * jw.scale[k]);
            assert!(
                (a - b).abs() <= 1e-12 * b.abs().max(1e-9),
                "{p}: {a} against {b}"
            );
        }
        let fit = fits_kd_within(&start, &records, 1_000, &truth, 1e-6);
        // the fit judges at the rate its own start model allows: within the bound
        assert!((990..=1_000).contains(&fit.samples), "{}", fit.samples);
        assert!(fit.notes.iter().any(|n| n.contains("first steady periods")));
    }

    /// A Jacobian folded into the R factor of `[r₀ J]` as its rows are made
    /// (a stretch of every column's replay at a time) is the whole one's:
    /// `RᵀR = [r₀ J]ᵀ[r₀ J]` to rounding, `R₀₀ = ‖r₀‖`; a model's residuals
    /// handed out in stretches of any length are the residual vector's to
    /// the bit, and a record taken as rejected gives what the residual
    /// vector gives a model the simulator rejects; Levenberg–Marquardt on
    /// the folded Jacobian reaches the optimum it reaches on the whole one.
    #[test]
    fn a_jacobian_folded_as_it_is_made_is_the_whole_ones() {
        let (rec, model, truth) = jenkins_dwells();
        let records = [TimeRecord::from_recording("dwells", &rec, 1, None, None).unwrap()];
        let start = model(1.0);
        let make = |held: usize| {
            let options = TimeFitOptions {
                max_judged_samples: 20_000,
                ..TimeFitOptions::default()
            };
            let parameters = time_parameters(&start, true, None);
            let mut p = TimeProblem::new(start.clone(), parameters, &records, 1.0, options, None)
                .unwrap()
                .with_jacobian_held_up_to(held);
            p.choose_replay_rates();
            p
        };
        let (whole, folded) = (make(usize::MAX), make(0));
        assert!(!whole.folds_jacobian() && folded.folds_jacobian());
        let theta: Vec<f64> = whole
            .parameters()
            .theta_of(&start)
            .unwrap()
            .iter()
            .map(|t| t + 0.01)
            .collect();
        let n = theta.len();
        let r0 = whole.residuals(&theta).unwrap();
        let m = r0.len() - 1;
        assert!(
            m > 3 * FOLDED_ROWS,
            "{m} judged: the fold is to take several stretches"
        );
        eprintln!("{m} judged samples, {n} parameters");
        let j = whole.jacobian_with_penalty_row(&theta, &r0, 1e-6).unwrap();
        let rf = folded.jacobian_r_factor(&theta, &r0, 1e-6).unwrap();
        assert_eq!(rf.shape(), (n + 1, n + 1));
        let a =
            nalgebra::DMatrix::from_fn(
                m + 1,
                n + 1,
                |i, k| if k == 0 { r0[i] } else { j[(i, k - 1)] },
            );
        let (g, h) = (a.tr_mul(&a), rf.tr_mul(&rf));
        let largest = g.amax();
        let worst = (&g - &h).amax();
        assert!(
            worst < 1e-12 * largest,
            "RᵀR off by {worst:e} of {largest:e}"
        );
        let norm = r0.iter().map(|v| v * v).sum::<f64>().sqrt();
        assert!((rf[(0, 0)] - norm).abs() < 1e-12 * norm);
        assert!((0..=n).all(|i| (0..i).all(|k| rf[(i, k)] == 0.0)));
        // stretches of any length: the residual vector's bits
        let (probe, _) = whole.model_at(&theta).unwrap();
        for chunk in [1, 777, 5_000] {
            let mut stream = ModelResiduals::new(&whole, probe.clone(), vec![false]);
            let mut got = Vec::new();
            let mut buffer = vec![0.0; chunk];
            loop {
                let k = stream.fill(&mut buffer).ok().expect("made");
                got.extend_from_slice(&buffer[..k]);
                if k < chunk {
                    break;
                }
            }
            assert_eq!(got.len(), m);
            assert!(
                got.iter().zip(&r0).all(|(a, b)| a.to_bits() == b.to_bits()),
                "{chunk}"
            );
        }
        // a record taken as rejected: worse than predicting nothing
        let mut rejected = ModelResiduals::new(&whole, probe, vec![true]);
        let mut got = vec![0.0; m];
        assert_eq!(rejected.fill(&mut got).ok(), Some(m));
        let mut want = Vec::new();
        whole.judging[0].for_each_measured(&records[0], |k, v| {
            want.push(-2.0 * v / whole.judging[0].scale[k]);
        });
        assert_eq!(got, want);
        // Levenberg–Marquardt on either: the same optimum, the truth's
        let kd = |p: &TimeProblem, t: &[f64]| match p.model_at(t).unwrap().0.elements().next() {
            Some(&crate::model::ElementSpec::Jenkins { kd, .. }) => kd,
            _ => unreachable!(),
        };
        let truth_kd = match truth.elements().next() {
            Some(&crate::model::ElementSpec::Jenkins { kd, .. }) => kd,
            _ => unreachable!(),
        };
        let fits: Vec<f64> = [&whole, &folded]
            .iter()
            .map(|p| {
                let run = optimise::levenberg_marquardt_to(*p, &theta, 40, LM_TOLERANCE).unwrap();
                kd(p, &run.theta)
            })
            .collect();
        eprintln!(
            "kd: whole {:e}, folded {:e}, truth {truth_kd:e}",
            fits[0], fits[1]
        );
        assert!((fits[1] / fits[0] - 1.0).abs() < 1e-7, "{fits:?}");
        assert!(
            (fits[1] / truth_kd - 1.0).abs() < 1e-6,
            "{fits:?} against {truth_kd}"
        );
    }

    /// A record whose channels are held in scratch files (as a loader holds
    /// a long recording's) is judged as the one held in memory, to the bit:
    /// its residuals, its replays, its errors split by frequency and the
    /// replay grid chosen for it, at the recording's rate and judged at
    /// every sample, and upsampled (the drive interpolated a stretch at a
    /// time rather than made whole) and judged at a lower rate.
    #[test]
    fn a_record_held_in_scratch_files_is_judged_as_the_one_held_in_memory() {
        use crate::signals::SamplesBuilder;
        let (rec, model, truth) = jenkins_dwells();
        let held = |spill: bool| {
            let samples = |x: &[f64]| {
                let b = SamplesBuilder::new(x.len(), &[]);
                let mut b = if spill { b.spilling_above(5_000) } else { b };
                x.chunks(4_321).for_each(|c| b.extend(c).unwrap());
                b.finish().unwrap()
            };
            let channels = (samples(&rec.channels[0]), samples(&rec.channels[1]));
            assert_eq!(channels.0.is_spilled(), spill);
            TimeRecord::from_held("dwells", &rec.meta, 1, channels, None, Some((55.0, 75.0)))
                .unwrap()
        };
        let (in_memory, spilled) = ([held(false)], [held(true)]);
        let start = model(1.0);
        let bits = |v: &[f64]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
        for options in [
            TimeFitOptions::default(),
            TimeFitOptions {
                min_samples_per_period: 300.0,
                max_judged_samples: 10_000,
                ..TimeFitOptions::default()
            },
        ] {
            let problem = |records| {
                let mut p = TimeProblem::new(
                    start.clone(),
                    time_parameters(&start, true, None),
                    records,
                    1.0,
                    options.clone(),
                    None,
                )
                .unwrap();
                p.choose_replay_rates();
                p
            };
            let (a, b) = (problem(&in_memory), problem(&spilled));
            // both paths taken: upsampled 7 times and judged at a third
            let upsampled = options.max_judged_samples < MAX_JUDGED_SAMPLES;
            let factors = if upsampled { (7, 3) } else { (1, 1) };
            assert_eq!(a.replay_factors(), [Some(factors.0)]);
            assert_eq!(a.judging_factors(), [factors.1]);
            assert_eq!(a.replay_factors(), b.replay_factors());
            assert_eq!(a.judging_factors(), b.judging_factors());
            let theta: Vec<f64> = a
                .parameters()
                .theta_of(&start)
                .unwrap()
                .iter()
                .map(|t| t + 0.01)
                .collect();
            assert_eq!(
                bits(&a.residuals(&theta).unwrap()),
                bits(&b.residuals(&theta).unwrap())
            );
            let truth_replays = a.replays_of(&truth).unwrap();
            assert_eq!(truth_replays, b.replays_of(&truth).unwrap());
            let errors = a.errors_by_frequency(&start).unwrap();
            assert!(errors[0].window.by_frequency.is_some());
            assert_eq!(errors, b.errors_by_frequency(&start).unwrap());
        }
    }

    /// Three recordings of an SDOF at 60 Hz with a Jenkins joint (as
    /// [`jenkins_dwells`]), each two dwells (56 and 64 Hz) at its own level
    /// (15, 40, 80 N), with 1 % of seeded Gaussian noise, fitted with a
    /// Jenkins joint (`kd` and `fd` free, from 10 % off), then each
    /// refitted alone. Made by one joint, alone and together leave the same
    /// residual, the noise (1.00x at the median, each within 0.2 % of the
    /// 1 %); made by a joint whose stick stiffness was another in each run
    /// (1.05, 1.2, 1.4 times the structure's), each level alone is matched
    /// to the noise but all three at once only to 5-10 % (9.7x at the
    /// median): the note says which.
    #[test]
    fn recordings_fitted_alone_tell_a_wrong_dependence_on_level() {
        use crate::model::{ElementSpec, ModalModel};
        use rand::SeedableRng;
        use rand_distr::{Distribution, Normal};
        let fs = 4000.0;
        let w = 2.0 * PI * 60.0;
        let model = |joint: ElementSpec| {
            Model::new(
                ModalModel::sdof(1.0, 2.0 * 0.02 * w, w * w).unwrap(),
                vec![joint],
            )
            .unwrap()
        };
        let jenkins = |kd: f64, fd: f64| ElementSpec::Jenkins { kd: kd * w * w, fd };
        let records = |truth: &dyn Fn(usize) -> Model| -> Vec<TimeRecord> {
            let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(13);
            let normal = Normal::new(0.0, 1.0).unwrap();
            [15.0, 40.0, 80.0]
                .iter()
                .enumerate()
                .map(|(k, &level)| {
                    let mut force = Vec::new();
                    let mut steps = Vec::new();
                    for f in [56.0, 64.0] {
                        force.extend(std::iter::repeat_n(0.0, 500));
                        steps.push(Step {
                            frequency_hz: f,
                            level,
                            start: force.len(),
                            settle: 2000,
                            length: 6000,
                        });
                        force.extend(
                            (0..6000).map(|i| level * (2.0 * PI * f * i as f64 / fs).sin()),
                        );
                    }
                    let mut x = displacement_of(&truth(k), &force, fs);
                    let rms = (x.iter().map(|v| v * v).sum::<f64>() / x.len() as f64).sqrt();
                    x.iter_mut()
                        .for_each(|v| *v += 0.01 * rms * normal.sample(&mut rng));
                    let mut rec = recording(fs, force, stepped(steps));
                    rec.channels[1] = x;
                    TimeRecord::from_recording(&format!("{level} N"), &rec, 1, None, None).unwrap()
                })
                .collect()
        };
        let options = TimeFitOptions {
            refine_linear: false,
            each_alone: true,
            ..TimeFitOptions::default()
        };
        let start = model(jenkins(1.1, 40.0));
        let median = |fit: &TimeFitResult| {
            let mut c: Vec<f64> = fit.each_alone.iter().map(|a| a.closer().unwrap()).collect();
            c.sort_by(f64::total_cmp);
            c[1]
        };
        let mut closer = Vec::new();
        // the same joint at every level, then one whose slip force was
        // another in each run (30, 40, 55 N)
        let same = |_: usize| model(jenkins(1.2, 40.0));
        let changed = |k: usize| model(jenkins([1.05, 1.2, 1.4][k], 40.0));
        let truths: [&dyn Fn(usize) -> Model; 2] = [&same, &changed];
        for truth in truths {
            let recs = records(truth);
            let parameters = time_parameters(&start, false, None);
            let fit = identify_time(&start, parameters, 1.0, &recs, &options, None).unwrap();
            assert_eq!(fit.each_alone.len(), 3);
            for (a, after) in fit.each_alone.iter().zip(&fit.after) {
                assert_eq!(a.recording, after.recording);
                assert_eq!(a.together, after.window.relative);
                assert!(
                    a.failed.is_none() && a.status == FitStatus::Converged,
                    "{a:?}"
                );
                // an alone fit starts from the joint optimum: no worse but
                // for the optimiser's tolerance (it minimises the dwells'
                // relative errors, this is the window's)
                assert!(a.alone.unwrap() <= a.together * (1.0 + 1e-4), "{a:?}");
            }
            let note = fit.notes.last().unwrap();
            assert!(note.starts_with("refitted alone"), "{note}");
            eprintln!("{note}");
            closer.push((median(&fit), note.clone(), fit));
        }
        let (consistent, note, fit) = &closer[0];
        // the noise floor, alone or together: 1 % of the RMS
        assert!((consistent - 1.0).abs() < 0.02, "{consistent}: {note}");
        assert!(
            fit.each_alone
                .iter()
                .all(|a| (a.together - 0.01).abs() < 0.002)
        );
        assert!(note.contains("shared by every recording"), "{note}");
        let (inconsistent, note, _) = &closer[1];
        assert!(*inconsistent > 2.0 * CLOSER_ALONE, "{inconsistent}: {note}");
        assert!(note.contains("changes from one to the next"), "{note}");
        eprintln!("closer alone: {consistent:.3}x / {inconsistent:.3}x");
        // one refit or none that ended says nothing
        assert_eq!(level_consistency(&fit.each_alone[..1]), None);
    }
}
