//! Validation: a fitted model against a measurement it never saw, in the
//! time domain.
//!
//! The fit matches steady-state nonlinear FRFs (paper eq. 9); validation
//! asks whether the model also reproduces a recording as measured, with no
//! steady-state assumption (paper section 4, Fig. 4.5: "simulated and
//! measured response"). The recording's measured reference signal (force,
//! or amplifier voltage for a voltage-driven model) drives the model through
//! the digital-filter simulator ([`crate::sim`]), and the simulated response,
//! in the recording's response quantity and times the fit's
//! `response_sign`, is compared sample by sample with the measured one:
//!
//! * `e_RMS = √(mean((y_sim − y_meas)²))`, the metric of the nonlinear
//!   system-identification benchmarks (Noël & Schoukens 2016/2017, "the
//!   output is simulated"), over the whole record and optionally over a time
//!   window (given, or where a sweep is inside a frequency band), also
//!   relative to the RMS of the measured response;
//! * both signals reduced the same way into nonlinear FRFs (stepped sine on
//!   the same dwells, or swept sine on the same fitted sweep law), with the
//!   relative error of `H1` per level and the `|H1|` peak of each.
//!
//! The simulation runs at the recording's rate when that gives at least
//! [`ValidateOptions::min_samples_per_period`] samples per period of the
//! model's stiffest linearised mode
//! ([`Model::highest_linearised_frequency_hz`]); otherwise the reference is
//! interpolated by the smallest integer factor that does, and the response
//! decimated back ([`resample`]). Nothing else is resampled: the comparison is
//! at the recording's own samples.
//!
//! A linear mode above [`QUASI_STATIC_ABOVE_RATE`] times the recording's
//! sample rate is replayed quasi-statically, its flexibility alone
//! ([`crate::sim::ModeFilter::quasi_static`]), and does not count towards
//! the rate: the recording cannot show its dynamics, and resolving them
//! would replay at up to 64 times the rate for nothing (a further mode a
//! fit places far above the band, only its flexibility seen, at 67.6 kHz
//! beside a 16 kHz recording).
//!
//! A validation replays the model once and holds none of the replay
//! ([`validate_view`]): a [`Replay`] is made a stretch at a time, each
//! stretch folded into the error sums ([`tally`]: the same bits as the
//! whole signals' figures), handed to the caller's [`ReplayTap`] (the
//! figures' traces) and, for a stepped sine, to the reduction reading it a
//! dwell at a time beside the reference. An upsampled drive is interpolated
//! a stretch at a time ([`resample::Interpolator`]). Only what needs the
//! replay whole keeps it: a sweep (followed over the record), a multisine's
//! lines, dwells stated out of order, and a caller that asks for it.

pub mod acquisition;
pub mod resample;
mod tally;

pub(crate) use tally::FrequencySplit;
pub use tally::SPLIT_BLOCK;

use crate::error::{Error, Result};
use crate::extract::reduce_stepped_stream;
use crate::extract::{
    FrfPoint, NonlinearFrf, ReduceOptions, SweepFit, SweepOptions, reduce_sweep_held,
};
use crate::harmonics::Quantity;
use crate::model::Model;
use crate::observe::{Observer, Silent};
use crate::record::{Recording, Step};
use crate::signals::{FrameSource, InMemoryFrames, RecordingMeta, RecordingView, SamplesView};
use crate::sim::Simulator;
use serde::{Deserialize, Serialize};

/// How both signals are reduced into nonlinear FRFs for the comparison.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Reduction {
    /// Stepped sine: the measured recording's dwells (stated or found) are
    /// reduced, and the simulated response on exactly the same dwells.
    Stepped(ReduceOptions),
    /// Swept sine: both follow the sweep law fitted to the reference.
    Swept(SweepOptions),
}

/// Options of [`validate_recording`].
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ValidateOptions {
    /// Samples per period of the model's highest linearised frequency below
    /// which the simulation is upsampled (default 20: the implicit
    /// digital-filter solve then errs by about 1.5 % in `H1` at a stick mode;
    /// at least 2).
    pub min_samples_per_period: f64,
    /// A time window, seconds from the first sample, for a second set of
    /// error figures.
    pub window_s: Option<(f64, f64)>,
    /// A frequency band, Hz: limits the FRF comparison (peaks, `H1` error)
    /// and, for a swept sine without `window_s`, sets the window to where
    /// the fitted sweep is inside the band.
    pub band_hz: Option<(f64, f64)>,
    /// The FRF comparison, if any.
    pub reduction: Option<Reduction>,
    /// What the force is between its samples.
    pub input: DriveInput,
    /// The recording is one period of a periodic steady state (a multisine
    /// test set): the model is driven by it repeated until its slowest mode
    /// has settled (at least twice) and the last period is compared.
    pub periodic: bool,
    /// The recorded response's acquisition chain, which the replay is put
    /// through before it is compared (see [`acquisition`]).
    pub acquisition: Option<acquisition::Acquisition>,
}

/// What a sampled force is between its samples when it drives the
/// simulator.
///
/// The digital-filter simulator is ramp invariant: exact for a force that
/// runs straight between samples, whose fundamental at `f` is the samples'
/// times `sinc²(f/fs)` (0.3 % low at `fs/30`, 5 % at `fs/8`). A measured
/// force is not that: its samples stand for the band-limited signal they
/// were taken from. For it the samples are pre-emphasised at the
/// simulation rate by the FIR `[−1/12, 7/6, −1/12]`, whose gain
/// `1 + (1 − cos 2πf/fs)/6` undoes `sinc²` to fourth order (0.011 % left at
/// `fs/20`, 0.4 % at `fs/8`), a zero-phase filter, so the replay sees the
/// measured force and not its straight-line sketch. The joint's force on
/// the structure is made inside the loop and keeps its loss unless
/// [`DriveInput::Continuous`] asks (a stuck joint's stiffness then loses
/// `(πf/fs)²/3`: 0.2 % at 40 samples per period, on a lightly damped
/// resonance a per-dwell misfit 1 % high).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum DriveInput {
    /// The band-limited signal the samples stand for (a measured force).
    #[default]
    BandLimited,
    /// The band-limited signal, and the joint's force taken as band-limited
    /// too: its `sinc²` loss inside the loop compensated
    /// ([`crate::sim::Simulator::with_element_force_compensated`]), so that
    /// the replay is the continuous model to fourth order where the element
    /// law is smooth. Not the default yet: it moved one walkthrough's time
    /// fit (the UNESP beam with a background) into another basin (README).
    Continuous,
    /// Straight lines between samples: the input of a ramp-invariant
    /// simulator that ran at the recording's own rate (the element force
    /// too is then as that simulator made it, uncompensated).
    Ramp,
}

/// The samples pre-emphasised as [`DriveInput::BandLimited`] says (the
/// ends held: a record starts and ends at rest), sample by sample: the
/// tests' reference for [`pre_emphasise`].
#[cfg(test)]
fn pre_emphasis(x: &[f64]) -> Vec<f64> {
    (0..x.len()).map(|i| pre_emphasised(x, i)).collect()
}

/// [`pre_emphasis`] in place (a drive held for replays is the largest
/// thing a fit of a long recording makes: not twice).
fn pre_emphasise(x: &mut [f64]) {
    let n = x.len();
    if n == 0 {
        return;
    }
    // the sample before, as it was
    let mut before = x[0];
    for i in 0..n {
        let (a, here, b) = (before, x[i], x[(i + 1).min(n - 1)]);
        before = here;
        x[i] = here + (2.0 * here - a - b) / 12.0;
    }
}

/// Sample `i` of [`pre_emphasis`]`(x)`, made where it is needed (a replay
/// at the recording's own rate makes its drive a stretch at a time).
fn pre_emphasised(x: &[f64], i: usize) -> f64 {
    let a = x[i.saturating_sub(1)];
    let b = x[(i + 1).min(x.len() - 1)];
    x[i] + (2.0 * x[i] - a - b) / 12.0
}

impl Default for ValidateOptions {
    fn default() -> Self {
        ValidateOptions {
            min_samples_per_period: 20.0,
            window_s: None,
            band_hz: None,
            reduction: None,
            input: DriveInput::BandLimited,
            periodic: false,
            acquisition: None,
        }
    }
}

/// Periods of `period_s` a periodic drive is repeated so that the
/// linearised model's slowest mode has decayed by 1e-6 before the last
/// (at least 2, at most 64).
fn settling_periods(model: &Model, period_s: f64) -> usize {
    let slowest = model
        .linear
        .modes
        .iter()
        .map(|m| m.damping_ratio * 2.0 * std::f64::consts::PI * m.frequency_hz)
        .fold(f64::INFINITY, f64::min);
    let periods = (1e6f64.ln() / (slowest * period_s)).ceil() + 1.0;
    if periods.is_finite() {
        (periods as usize).clamp(2, 64)
    } else {
        64
    }
}

/// A simulated response at the recording's rate.
#[derive(Clone, Debug, PartialEq)]
pub struct SimulatedResponse {
    /// The response, in the asked quantity, times the sign.
    pub values: Vec<f64>,
    /// The integer factor the simulation was upsampled by (1: none).
    pub upsampling: usize,
    /// The model's highest linearised frequency, Hz.
    pub highest_frequency_hz: f64,
}

/// Drives `model` from rest with `reference` (sampled at `sample_rate_hz`,
/// in the model's force unit, taken as a band-limited signal: see
/// [`DriveInput`]) and returns its `quantity` response times `sign` at the
/// same samples, upsampling the simulation as
/// [`ValidateOptions::min_samples_per_period`] asks (see the module docs).
///
/// Errors: a non-motion quantity, a non-finite or empty reference, a bad
/// rate, a model the simulator rejects, a non-finite simulated response
/// (an unstable model), a model needing more than
/// [`resample::MAX_FACTOR`] times the rate.
pub fn simulate_response(
    model: &Model,
    reference: &[f64],
    sample_rate_hz: f64,
    quantity: Quantity,
    sign: f64,
    min_samples_per_period: f64,
) -> Result<SimulatedResponse> {
    simulate_response_with(
        model,
        reference,
        sample_rate_hz,
        quantity,
        sign,
        min_samples_per_period,
        DriveInput::BandLimited,
        &Silent,
    )
}

/// [`simulate_response`] with the force between samples as `input` says,
/// its progress told to `observer` (which may stop it).
#[allow(clippy::too_many_arguments)]
pub fn simulate_response_with(
    model: &Model,
    reference: &[f64],
    sample_rate_hz: f64,
    quantity: Quantity,
    sign: f64,
    min_samples_per_period: f64,
    input: DriveInput,
    observer: &dyn Observer,
) -> Result<SimulatedResponse> {
    if !quantity.is_motion() {
        return Err(Error::input(
            "response quantity",
            format!("{quantity} is not a motion (displacement, velocity or acceleration)"),
        ));
    }
    if !(sample_rate_hz.is_finite() && sample_rate_hz > 0.0) {
        return Err(Error::input(
            "sample_rate_hz",
            format!("must be finite and > 0, got {sample_rate_hz}"),
        ));
    }
    if !(min_samples_per_period.is_finite() && min_samples_per_period >= 2.0) {
        return Err(Error::plan(
            "min_samples_per_period",
            format!("must be at least 2, got {min_samples_per_period}"),
        ));
    }
    if !(sign == 1.0 || sign == -1.0) {
        return Err(Error::input(
            "response_sign",
            format!("must be +1 or -1, got {sign}"),
        ));
    }
    let drive = PreparedDrive::new(reference, input);
    let factor = upsampling_factor(model, sample_rate_hz, min_samples_per_period)?;
    simulate_prepared_at(
        model,
        &drive,
        sample_rate_hz,
        quantity,
        sign,
        factor,
        observer,
    )
}

/// Samples of a drive on the replays' grids held for the replays that
/// follow, over every upsampling factor (64 MiB of `f64`s): a long
/// recording's drive is held up to there and interpolated a stretch at a
/// time beyond, whatever its length and the factor.
pub const DRIVE_HELD: usize = 1 << 23;

/// A reference prepared for replays: interpolated to each upsampling
/// factor a model asks for and pre-emphasised as its [`DriveInput`] says,
/// once per factor (a fit replays the same recording through many models)
/// for its first [`DRIVE_HELD`] samples on that grid; a replay interpolates
/// the rest a stretch at a time ([`resample::Interpolator`]: the same
/// samples). A fit of a long periodic record replays its first periods
/// only, so what it replays is all held.
pub struct PreparedDrive<'a> {
    reference: SamplesView<'a>,
    input: DriveInput,
    /// Interpolated a stretch at a time by each replay, none of it held
    /// (see [`PreparedDrive::for_one_replay`]).
    per_stretch: bool,
    /// The drive's first samples on each factor's grid, most recent last,
    /// at most `held_at_most` in all.
    cache: std::sync::Mutex<Vec<(usize, std::sync::Arc<Vec<f64>>)>>,
    /// [`DRIVE_HELD`] (less in tests).
    held_at_most: usize,
    /// The reference's first sample that is not finite, looked for once.
    not_finite: std::sync::OnceLock<Option<usize>>,
}

impl<'a> PreparedDrive<'a> {
    /// `reference` as `input` says it is between samples.
    pub fn new(reference: impl Into<SamplesView<'a>>, input: DriveInput) -> PreparedDrive<'a> {
        let reference = reference.into();
        PreparedDrive {
            reference,
            input,
            per_stretch: false,
            cache: Default::default(),
            held_at_most: DRIVE_HELD,
            not_finite: Default::default(),
        }
    }

    /// `reference` for a single replay (a validation): where the replay is
    /// upsampled, its drive is interpolated a stretch at a time as it goes
    /// ([`resample::Interpolator`]: the same samples), not made whole and
    /// kept for further replays (`factor` times the record in `f64`s).
    pub fn for_one_replay(
        reference: impl Into<SamplesView<'a>>,
        input: DriveInput,
    ) -> PreparedDrive<'a> {
        PreparedDrive {
            per_stretch: true,
            ..PreparedDrive::new(reference, input)
        }
    }

    /// The drive holding at most `samples` on the replays' grids (tests of
    /// the stretches beyond).
    #[cfg(test)]
    fn holding_at_most(self, samples: usize) -> PreparedDrive<'a> {
        PreparedDrive {
            held_at_most: samples,
            ..self
        }
    }

    /// Errors if a sample of the reference is not finite (checked once).
    fn check_finite(&self) -> Result<()> {
        let x = self.reference;
        match self.not_finite.get_or_init(|| {
            let mut first = None;
            x.for_each_stretch(0..x.len(), |at, w| {
                if first.is_none() {
                    first = w.iter().position(|v| !v.is_finite()).map(|i| at + i);
                }
            });
            first
        }) {
            Some(i) => Err(resample::not_finite("signal", x, *i)),
            None => Ok(()),
        }
    }

    /// The drive at `factor` (at least 2) times the rate, its first
    /// [`DRIVE_HELD`] samples (the whole where it is shorter); the cache's
    /// oldest factors dropped to keep it within that.
    fn at(&self, factor: usize) -> Result<std::sync::Arc<Vec<f64>>> {
        // held while the drive is made: replays on other threads wait for it
        // rather than make it again beside it
        let mut cache = self.cache.lock().expect("drive cache");
        if let Some((_, d)) = cache.iter().find(|(f, _)| *f == factor) {
            return Ok(d.clone());
        }
        // (a replay at the recording's own rate makes its drive as it goes:
        // see `replay_streamed`)
        let total = self.reference.len() * factor;
        let held = self.held_at_most.min(total);
        // with the neighbour past the end held that pre-emphasis reads
        let made = (held + 1).min(total);
        // the oldest factors' dropped first (a replay still using one keeps
        // it)
        while !cache.is_empty()
            && cache.iter().map(|(_, d)| d.len()).sum::<usize>() + held > self.held_at_most
        {
            cache.remove(0);
        }
        let mut drive = Vec::with_capacity(made);
        resample::Interpolator::new(factor).fill(self.reference, 0..made, &mut drive);
        if self.input != DriveInput::Ramp {
            pre_emphasise(&mut drive);
        }
        drive.truncate(held);
        let drive = std::sync::Arc::new(drive);
        cache.push((factor, drive.clone()));
        Ok(drive)
    }
}

/// [`simulate_response_with`] on a prepared drive.
pub fn simulate_prepared(
    model: &Model,
    drive: &PreparedDrive,
    sample_rate_hz: f64,
    quantity: Quantity,
    sign: f64,
    min_samples_per_period: f64,
) -> Result<SimulatedResponse> {
    let factor = upsampling_factor(model, sample_rate_hz, min_samples_per_period)?;
    simulate_prepared_at(
        model,
        drive,
        sample_rate_hz,
        quantity,
        sign,
        factor,
        &Silent,
    )
}

/// The upsampling that gives `model`'s highest linearised frequency at
/// least `min_samples_per_period` samples per period (at least 1), at most
/// [`resample::MAX_FACTOR`]. A linear mode above
/// [`QUASI_STATIC_ABOVE_RATE`] times the rate is replayed quasi-statically
/// and not counted; one below that but beyond the finest grid's reach (a
/// broad background a time fit drove upwards: it replays such a model on
/// its finest grid too, see `fit::time`) is replayed with fewer samples
/// per period, its flexibility in the band kept (a mode's digital filter
/// keeps its static gain). An error where even the lowest mode would need
/// more: nothing of the model is within the recording's reach.
pub fn upsampling_factor(
    model: &Model,
    sample_rate_hz: f64,
    min_samples_per_period: f64,
) -> Result<usize> {
    let needs = |f: f64| (min_samples_per_period * f / sample_rate_hz).ceil();
    let needed = needs(model.highest_replayed_frequency_hz(quasi_static_above_hz(sample_rate_hz)));
    // every mode counted here, the quasi-static ones too: a model none of
    // whose modes the recording reaches is refused, not replayed as a spring
    let lowest = model.lowest_linearised_frequency_hz();
    if needs(lowest) > resample::MAX_FACTOR as f64 {
        return Err(Error::model(
            "model",
            format!(
                "its lowest linearised frequency {lowest:.6} Hz would need {} times the \
                 recording's {sample_rate_hz} Hz (at most {}): the model is far stiffer than the \
                 measurement can show",
                needs(lowest),
                resample::MAX_FACTOR
            ),
        ));
    }
    Ok((needed as usize).clamp(1, resample::MAX_FACTOR))
}

/// A linear mode above this multiple of a recording's sample rate (four
/// times its Nyquist frequency) is replayed quasi-statically (see the
/// module docs). Its dynamic amplification below the Nyquist frequency,
/// `1/(1 − (f/f_r)²)`, is then at most 1/15 of its part of the response,
/// and a fraction of that below the band's top.
pub const QUASI_STATIC_ABOVE_RATE: f64 = 2.0;

/// The frequency above which a replay of a recording sampled at
/// `sample_rate_hz` takes a linear mode quasi-static, Hz.
pub fn quasi_static_above_hz(sample_rate_hz: f64) -> f64 {
    QUASI_STATIC_ABOVE_RATE * sample_rate_hz
}

/// [`simulate_prepared`] at a given upsampling `factor` (a fit keeps one
/// grid while its parameters move: see `fit::time`), its progress told to
/// `observer` (which may stop it).
pub fn simulate_prepared_at(
    model: &Model,
    drive: &PreparedDrive,
    sample_rate_hz: f64,
    quantity: Quantity,
    sign: f64,
    factor: usize,
    observer: &dyn Observer,
) -> Result<SimulatedResponse> {
    let mut values = Vec::with_capacity(drive.reference.len());
    let top = replay_streamed(
        model,
        drive,
        (sample_rate_hz, factor),
        quantity,
        sign,
        observer,
        &mut |stretch| {
            values.extend_from_slice(stretch);
            Ok(())
        },
    )?;
    Ok(SimulatedResponse {
        values,
        upsampling: factor,
        highest_frequency_hz: top,
    })
}

/// Samples of the replay's grid simulated at a time by [`replay_streamed`].
const REPLAY_STRETCH: usize = crate::observe::SAMPLES_PER_REPORT;

/// [`simulate_prepared_at`] handed to `sink` a stretch at a time, at the
/// recording's rate (`rate`: the recording's sample rate and the
/// upsampling factor), as it is made: the same samples to the bit, without
/// the response held whole (a [`Replay`] run to its end). A time fit
/// judging one sample in `k` keeps only those (its replays were a copy of
/// the response each, two at a time, and the drive a third: 200 MB of a
/// 66 MB channel). Returns the model's highest replayed frequency, Hz.
///
/// Errors: as [`simulate_response`]'s, and `sink`'s.
pub fn replay_streamed(
    model: &Model,
    drive: &PreparedDrive,
    rate: (f64, usize),
    quantity: Quantity,
    sign: f64,
    observer: &dyn Observer,
    sink: &mut dyn FnMut(&[f64]) -> Result<()>,
) -> Result<f64> {
    let mut replay = Replay::new(model, drive, rate, quantity, sign)?;
    while let Some(stretch) = replay.next_stretch(observer)? {
        sink(stretch)?;
    }
    Ok(replay.highest_frequency_hz())
}

/// A model's replay of a prepared drive, made a stretch at a time as it
/// is asked for (a reduction reading the replay a dwell at a time beside
/// the measured response, say): the samples of [`simulate_prepared_at`],
/// at the recording's rate, in order. At the recording's own rate the
/// drive too is made a stretch at a time.
pub struct Replay<'d, 'a> {
    drive: &'d PreparedDrive<'a>,
    /// Where it is interpolated, the drive's first samples (made once,
    /// shared by the replays: see [`PreparedDrive`]); beyond them, or
    /// without them, the samples themselves or interpolated a stretch at a
    /// time by `interpolator`.
    held: Option<std::sync::Arc<Vec<f64>>>,
    interpolator: Option<resample::Interpolator>,
    /// The interpolated stretch (with a sample each side).
    interpolated: Vec<f64>,
    sim: Simulator<crate::model::ElementSet<crate::model::AnyElement>>,
    output: crate::sim::Output,
    decimator: resample::Decimator,
    sign: f64,
    quantity: Quantity,
    factor: usize,
    top: f64,
    /// Samples of the replay's grid made so far, of `total`.
    done: usize,
    total: usize,
    force: Vec<f64>,
    fine: Vec<f64>,
    out: Vec<f64>,
    /// The response's acquisition chain, if declared, and its output.
    acquisition: Option<acquisition::AcquisitionFilter>,
    acquired: Vec<f64>,
}

impl<'d, 'a> Replay<'d, 'a> {
    /// `model` driven by `drive` at `factor` times `sample_rate_hz` (see
    /// [`replay_streamed`]).
    ///
    /// Errors: as [`simulate_response`]'s.
    pub fn new(
        model: &Model,
        drive: &'d PreparedDrive<'a>,
        (sample_rate_hz, factor): (f64, usize),
        quantity: Quantity,
        sign: f64,
    ) -> Result<Replay<'d, 'a>> {
        let reference = drive.reference;
        if reference.is_empty() {
            return Err(Error::input("reference", "holds no samples"));
        }
        model.validate()?;
        // against the recording's rate, whatever the replay's: a fit
        // compares replays at several rates
        let quasi_static = quasi_static_above_hz(sample_rate_hz);
        let top = model.highest_replayed_frequency_hz(quasi_static);
        let total = reference.len() * factor;
        drive.check_finite()?;
        let (held, interpolator) = if factor == 1 {
            (None, None)
        } else {
            resample::check(factor, &[], "signal")?;
            let held = (!drive.per_stretch).then(|| drive.at(factor)).transpose()?;
            // beyond what is held, interpolated a stretch at a time
            let beyond = held.as_ref().is_none_or(|h| h.len() < total);
            (held, beyond.then(|| resample::Interpolator::new(factor)))
        };
        let mut sim = Simulator::with_quasi_static_above(
            &model.linear,
            model.element_set()?,
            sample_rate_hz * factor as f64,
            quasi_static,
        )?;
        // the joint's force on the structure taken as band-limited too: the
        // continuous model, not the bench's ramp-invariant sketch of it
        if drive.input == DriveInput::Continuous {
            sim = sim.with_element_force_compensated();
        }
        // only the quantity compared (a replay of the time fit: no other
        // output is stored)
        let output = match quantity {
            Quantity::Displacement => crate::sim::Output::Displacement,
            Quantity::Velocity => crate::sim::Output::Velocity,
            Quantity::Acceleration => crate::sim::Output::Acceleration,
            Quantity::Force | Quantity::Voltage => {
                return Err(Error::input(
                    "replayed quantity",
                    format!("is a {quantity}; a motion is needed"),
                ));
            }
        };
        let stretch = REPLAY_STRETCH.min(total);
        Ok(Replay {
            drive,
            held,
            interpolator,
            interpolated: Vec::new(),
            sim,
            output,
            decimator: resample::Decimator::new(factor, resample::HALF_WIDTH, total)?,
            sign,
            quantity,
            factor,
            top,
            done: 0,
            total,
            force: Vec::with_capacity(stretch),
            fine: vec![0.0; stretch],
            out: Vec::with_capacity(stretch / factor + 1),
            acquisition: None,
            acquired: Vec::new(),
        })
    }

    /// The replay put through the response's acquisition chain (see
    /// [`acquisition`]): what the chain would have recorded of it.
    ///
    /// Errors: a chain the recording's rate cannot follow.
    pub fn with_acquisition(mut self, chain: Option<&acquisition::Acquisition>) -> Result<Self> {
        self.acquisition = chain
            .map(|c| acquisition::AcquisitionFilter::new(c, self.drive.reference.len()))
            .transpose()?;
        Ok(self)
    }

    /// The replay made `samples` of its grid at a time (at least one; the
    /// default is [`crate::observe::SAMPLES_PER_REPORT`]): the same samples,
    /// in smaller buffers, for many replays advanced side by side (the rows
    /// of a time fit's Jacobian folded as they are made).
    pub fn with_stretch(mut self, samples: usize) -> Self {
        let stretch = samples.max(1).min(self.total);
        self.force = Vec::with_capacity(stretch);
        self.fine = vec![0.0; stretch];
        self.out = Vec::with_capacity(stretch / self.factor + 1);
        self
    }

    /// The model's highest replayed frequency, Hz.
    pub fn highest_frequency_hz(&self) -> f64 {
        self.top
    }

    /// The next stretch of the replay at the recording's rate (possibly
    /// empty while the decimator fills), `None` once every sample has been
    /// handed on; progress is told to `observer` (which may stop it).
    ///
    /// Errors: a sample that is not finite (the model is unstable), the
    /// simulator's, and [`Error::Cancelled`].
    pub fn next_stretch(&mut self, observer: &dyn Observer) -> Result<Option<&[f64]>> {
        let (done, total) = (self.done, self.total);
        if done >= total {
            return Ok(None);
        }
        let reference = self.drive.reference;
        let mut end = (done + self.fine.len()).min(total);
        // what is held, up to its end
        let held = self.held.as_ref().filter(|h| done < h.len());
        if let Some(h) = held {
            end = end.min(h.len());
        }
        let fine = &mut self.fine[..end - done];
        // the drive's samples `lo..hi` on the replay's grid
        let (interpolator, buffer) = (self.interpolator.as_ref(), &mut self.interpolated);
        match (held, self.drive.input) {
            (Some(h), _) => self.sim.run_output(&h[done..end], self.output, fine)?,
            (None, DriveInput::Ramp) => {
                let x = drive_on_grid(reference, interpolator, buffer, done..end);
                self.sim.run_output(&x, self.output, fine)?
            }
            (None, _) => {
                // with a neighbour each side where there is one: the same
                // drive as the whole reference pre-emphasised
                let lo = done.saturating_sub(1);
                let x = drive_on_grid(reference, interpolator, buffer, lo..(end + 1).min(total));
                self.force.clear();
                self.force
                    .extend((done..end).map(|i| pre_emphasised(&x, i - lo)));
                self.sim.run_output(&self.force, self.output, fine)?;
            }
        }
        if let Some(i) = fine.iter().position(|v| !v.is_finite()) {
            return Err(Error::NotConverged {
                stage: "validation simulation",
                reason: format!(
                    "the simulated {} is {} at sample {} of {}: the model is unstable",
                    self.quantity,
                    fine[i],
                    (done + i) / self.factor,
                    reference.len()
                ),
            });
        }
        self.out.clear();
        self.decimator.push(fine, &mut self.out);
        if self.sign < 0.0 {
            self.out.iter_mut().for_each(|v| *v = -*v);
        }
        self.done = end;
        crate::observe::progress(observer, "simulating", end as u64, total as u64)?;
        if let Some(chain) = &mut self.acquisition {
            self.acquired.clear();
            chain.push(&self.out, &mut self.acquired);
            return Ok(Some(&self.acquired));
        }
        Ok(Some(&self.out))
    }
}

/// Samples `fine` of `reference` on a replay's grid: the samples
/// themselves, or interpolated into `buffer` by `interpolator`.
fn drive_on_grid<'c>(
    reference: SamplesView<'c>,
    interpolator: Option<&resample::Interpolator>,
    buffer: &'c mut Vec<f64>,
    fine: std::ops::Range<usize>,
) -> std::borrow::Cow<'c, [f64]> {
    match interpolator {
        None => reference.range(fine),
        Some(ip) => {
            buffer.clear();
            ip.fill(reference, fine, buffer);
            std::borrow::Cow::Borrowed(&buffer[..])
        }
    }
}

/// Error figures over a stretch of samples.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct ErrorMetrics {
    /// Start of the stretch, s from the first sample.
    pub start_s: f64,
    /// End of the stretch (exclusive), s.
    pub end_s: f64,
    /// Samples compared.
    pub samples: usize,
    /// `√(mean((y_sim − y_meas)²))`, response unit.
    pub e_rms: f64,
    /// RMS of the measured response over the stretch (about its mean).
    pub measured_rms: f64,
    /// `e_rms / measured_rms`.
    pub relative: f64,
    /// The error and both responses split below, inside, just above and
    /// far above the band (`--band`): where in frequency the residual lies.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub by_frequency: Option<ErrorByFrequency>,
}

/// A stretch's error, measured and simulated responses split by frequency
/// about a band `[lo, hi]`: below it, inside it, just above it (`(hi,
/// 2 hi]`: the skirts of the band's modes and the second harmonic) and
/// beyond (the higher harmonics), each as a share of the measured
/// response's RMS over the stretch (about its mean; the parts' squares add
/// up to the square of the whole, by Parseval's theorem). The residual of a
/// model whose modes lie in the band shows here what it cannot make: the
/// higher harmonics that modes far above the band amplify, say, or a drift
/// below it.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct ErrorByFrequency {
    /// The band, Hz.
    pub band_hz: (f64, f64),
    /// Below the band (with the mean).
    pub below: BandShares,
    /// Inside the band (its edges included).
    pub inside: BandShares,
    /// Above the band, up to twice its top.
    pub above: BandShares,
    /// Above twice the band's top.
    pub beyond: BandShares,
}

/// The RMS of the error and of both responses in one part of the spectrum,
/// as shares of the measured response's RMS over the stretch.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct BandShares {
    /// Of `y_sim − y_meas`.
    pub error: f64,
    /// Of the measured response (about its mean).
    pub measured: f64,
    /// Of the simulated response (about the measured mean).
    pub simulated: f64,
}

/// [`ErrorByFrequency`] of `simulated` against `measured` over samples
/// `range` (clipped to the shorter signal): the mean square of each signal
/// in each part of its spectrum by Parseval's theorem on one real FFT of
/// the stretch (no window: the parts' squares add up to the whole), or of
/// each of nearly equal blocks of a stretch longer than [`SPLIT_BLOCK`].
pub fn error_by_frequency(
    measured: &[f64],
    simulated: &[f64],
    sample_rate_hz: f64,
    range: std::ops::Range<usize>,
    band_hz: (f64, f64),
) -> Result<ErrorByFrequency> {
    let n = measured.len().min(simulated.len());
    let (a, b) = (range.start.min(n), range.end.min(n));
    let mut split = tally::FrequencySplit::new(measured.into(), sample_rate_hz, a..b, band_hz)?;
    split.push(a, &measured[a..b], &simulated[a..b])?;
    Ok(split.finish())
}

/// The error figures of `simulated` against `measured` over samples
/// `range` (clipped to the shorter signal).
pub fn error_metrics(
    measured: &[f64],
    simulated: &[f64],
    sample_rate_hz: f64,
    range: std::ops::Range<usize>,
) -> Result<ErrorMetrics> {
    let n = measured.len().min(simulated.len());
    let (a, b) = error_window(range, n)?;
    let e2 = measured[a..b]
        .iter()
        .zip(&simulated[a..b])
        .map(|(x, y)| (y - x).powi(2))
        .sum::<f64>();
    Ok(error_metrics_of_sum(measured, e2, sample_rate_hz, a..b))
}

/// `range` clipped to the `n` samples compared; an error where nothing of
/// them is left.
pub(crate) fn error_window(range: std::ops::Range<usize>, n: usize) -> Result<(usize, usize)> {
    let (a, b) = (range.start.min(n), range.end.min(n));
    if a >= b {
        return Err(Error::input(
            "error window",
            format!(
                "samples {}..{} hold nothing of the {n} compared",
                range.start, range.end
            ),
        ));
    }
    Ok((a, b))
}

/// The value `Iterator::sum` starts an `f64` sum from: a sum folded in
/// order from it, a stretch at a time, is the same to the bit as the whole
/// summed at once.
pub(crate) fn sum_start() -> f64 {
    std::iter::empty::<f64>().sum::<f64>()
}

/// [`error_metrics`] over `a..b` (clipped by [`error_window`]) given the
/// sum of the squared errors there, `Σ (y_sim − y_meas)²` in the samples'
/// order (a replay handed on a stretch at a time sums it as it comes).
pub(crate) fn error_metrics_of_sum<'a>(
    measured: impl Into<SamplesView<'a>>,
    squared_errors: f64,
    sample_rate_hz: f64,
    std::ops::Range { start: a, end: b }: std::ops::Range<usize>,
) -> ErrorMetrics {
    let m = measured.into();
    let len = (b - a) as f64;
    let e2 = squared_errors / len;
    // folded in order a stretch at a time: the same bits as summing the
    // window at once
    let mut sum = sum_start();
    m.for_each_stretch(a..b, |_, w| sum = w.iter().fold(sum, |acc, x| acc + x));
    let mean = sum / len;
    let mut squares = sum_start();
    m.for_each_stretch(a..b, |_, w| {
        squares = w.iter().fold(squares, |acc, x| acc + (x - mean).powi(2))
    });
    let v = squares / len;
    let (e_rms, measured_rms) = (e2.sqrt(), v.sqrt());
    ErrorMetrics {
        start_s: a as f64 / sample_rate_hz,
        end_s: b as f64 / sample_rate_hz,
        samples: b - a,
        e_rms,
        measured_rms,
        relative: if measured_rms > 0.0 {
            e_rms / measured_rms
        } else {
            f64::INFINITY
        },
        by_frequency: None,
    }
}

/// The largest `|H1|` of a series, refined by a parabola through it and its
/// neighbours.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Peak {
    /// Frequency, Hz.
    pub frequency_hz: f64,
    /// `|H1|`, response unit per reference unit.
    pub magnitude: f64,
}

/// The `|H1|` peak of `points` (within `band_hz`), `None` when there are no
/// points. A peak with a neighbour on each side is refined by the parabola
/// through the three (magnitude against frequency).
pub fn h1_peak(points: &[FrfPoint], band_hz: Option<(f64, f64)>) -> Option<Peak> {
    let mut pts: Vec<(f64, f64)> = points
        .iter()
        .filter(|p| in_band(p.frequency_hz, band_hz))
        .filter_map(|p| Some((p.frequency_hz, p.h.get(1)?.norm())))
        .filter(|(f, a)| f.is_finite() && a.is_finite())
        .collect();
    pts.sort_by(|a, b| a.0.total_cmp(&b.0));
    let (i, &(f, a)) = pts
        .iter()
        .enumerate()
        .max_by(|x, y| x.1.1.total_cmp(&y.1.1))?;
    if i == 0 || i + 1 == pts.len() {
        return Some(Peak {
            frequency_hz: f,
            magnitude: a,
        });
    }
    let ((x0, y0), (x1, y1), (x2, y2)) = (pts[i - 1], pts[i], pts[i + 1]);
    // y = y1 + b (x − x1) + c (x − x1)², through the three points
    let (d0, d2) = (x0 - x1, x2 - x1);
    let (s0, s2) = ((y0 - y1) / d0, (y2 - y1) / d2);
    let c = (s2 - s0) / (d2 - d0);
    let b = s0 - c * d0;
    if c.is_nan() || c >= 0.0 {
        return Some(Peak {
            frequency_hz: f,
            magnitude: a,
        });
    }
    let dx = (-b / (2.0 * c)).clamp(d0, d2);
    Some(Peak {
        frequency_hz: x1 + dx,
        magnitude: y1 + b * dx + c * dx * dx,
    })
}

fn in_band(f: f64, band_hz: Option<(f64, f64)>) -> bool {
    band_hz.is_none_or(|(lo, hi)| f >= lo && f <= hi)
}

/// One level of the FRF comparison.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct LevelComparison {
    /// Nominal level of the measured series, reference unit.
    pub level: f64,
    /// Points compared (within the band).
    pub points: usize,
    /// `‖H1_sim − H1_meas‖ / ‖H1_meas‖` over those points.
    pub relative_h1_error: f64,
    /// The measured `|H1|` peak in the band.
    pub measured_peak: Option<Peak>,
    /// The simulated `|H1|` peak in the band.
    pub simulated_peak: Option<Peak>,
}

/// Both signals reduced the same way.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct FrfComparison {
    /// Per level of the measured reduction.
    pub levels: Vec<LevelComparison>,
    /// The sweep fitted to the reference (swept sine only).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub sweep: Option<SweepFit>,
    /// The measured nonlinear FRFs.
    #[serde(skip)]
    pub measured: Option<NonlinearFrf>,
    /// The simulated ones, on the same dwells or sweep windows.
    #[serde(skip)]
    pub simulated: Option<NonlinearFrf>,
}

/// The validation of one recording.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Validation {
    /// The recording's sample rate, Hz.
    pub sample_rate_hz: f64,
    /// The response quantity compared.
    pub quantity: Quantity,
    /// The simulation's upsampling factor (1: at the recording's rate).
    pub upsampling: usize,
    /// The model's highest linearised frequency, Hz.
    pub highest_frequency_hz: f64,
    /// How the model was replayed (`--replay`: what the reference and the
    /// joint's force are between samples).
    #[serde(default)]
    pub replay: DriveInput,
    /// Over the whole record.
    pub whole: ErrorMetrics,
    /// Over the window (given, or from the band through the sweep law).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub window: Option<ErrorMetrics>,
    /// The FRF comparison, if asked for.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub frf: Option<FrfComparison>,
    /// On a multisine of at least two steady periods: the residual at the
    /// lines of its period, in units of the noise (written, not read back).
    #[serde(default, skip_deserializing, skip_serializing_if = "Option::is_none")]
    pub lines: Option<crate::extract::lines::LineValidation>,
    /// On a record of one period of a periodic steady state (`periodic`):
    /// the error at the lines of that period, relative to what was
    /// measured there (written, not read back).
    #[serde(default, skip_deserializing, skip_serializing_if = "Option::is_none")]
    pub line_spectrum: Option<crate::extract::lines::LineSpectrum>,
    /// The simulated response, at the recording's samples, where it was
    /// asked to be kept (see [`validate_view`]); else empty.
    #[serde(skip)]
    pub simulated: Vec<f64>,
}

/// What a validation hands on of the replay as it is made (the figures of
/// a recording too long to hold its replay, say): the samples compared and
/// the window of the second error figure, then every stretch of the
/// simulated response in order. Both do nothing by default.
pub trait ReplayTap {
    /// Before the first stretch: the samples compared and the window.
    fn begin(&mut self, _samples: usize, _window: Option<std::ops::Range<usize>>) {}
    /// The simulated response from sample `at` on, beside the measured one
    /// there (as long).
    fn stretch(&mut self, _at: usize, _measured: &[f64], _simulated: &[f64]) {}
}

impl ReplayTap for () {}

/// Validates `model` on a recording: simulates the response channel
/// `response_channel` from the reference channel (see the module docs) and
/// compares.
///
/// `response_sign` is the fit's (the model predicts `sign × H_measured`, so
/// the simulated response is multiplied by it). Errors name the channel:
/// no reference, a response that is not a motion or is the reference, a
/// window outside the record, and those of [`simulate_response`] and of the
/// reductions.
pub fn validate_recording(
    model: &Model,
    response_sign: f64,
    rec: &Recording,
    response_channel: usize,
    options: &ValidateOptions,
) -> Result<Validation> {
    validate_recording_observed(
        model,
        response_sign,
        rec,
        response_channel,
        options,
        &Silent,
    )
}

/// [`validate_recording`], telling `observer` how the replay and the
/// FRF comparison progress ([`REDUCING`] 0 and 1 of 2 around the measured
/// response's reduction, `simulating` as the replay is made and reduced,
/// then [`REDUCING`] 2 of 2) and stopping where it asks
/// ([`Error::Cancelled`]). The replay is kept ([`Validation::simulated`]).
pub fn validate_recording_observed(
    model: &Model,
    response_sign: f64,
    rec: &Recording,
    response_channel: usize,
    options: &ValidateOptions,
    observer: &dyn Observer,
) -> Result<Validation> {
    validate_view(
        model,
        (response_sign, true),
        &rec.view(),
        response_channel,
        options,
        observer,
        &mut (),
    )
}

/// [`validate_recording_observed`] on a recording however its channels are
/// held, `keep_replay` saying whether the simulated response is kept whole
/// ([`Validation::simulated`]) and `tap` handed it a stretch at a time.
///
/// Without `keep_replay`, a stepped recording whose dwells are stated (or
/// found on the measured reference) is replayed once and never held: the
/// error figures are tallied as the replay comes (the same bits as the
/// whole signals' figures), and the simulated response is reduced a dwell
/// at a time beside the reference. A swept one is held (the sweep is
/// followed over the record whole), and so is a periodic one (it is short).
pub fn validate_view(
    model: &Model,
    (response_sign, keep_replay): (f64, bool),
    rec: &RecordingView,
    response_channel: usize,
    options: &ValidateOptions,
    observer: &dyn Observer,
    tap: &mut dyn ReplayTap,
) -> Result<Validation> {
    let reference = rec.meta.reference_channel().ok_or_else(|| {
        Error::input(
            "recording",
            "has no force or voltage channel to drive the model with",
        )
    })?;
    model.check_reference(
        rec.meta.channels[reference].quantity,
        &format!(
            "the reference channel `{}`",
            rec.meta.channels[reference].name
        ),
    )?;
    let nch = rec.channels.len().min(rec.meta.channels.len());
    if response_channel >= nch || response_channel == reference {
        return Err(Error::input(
            format!("response channel {response_channel}"),
            format!("must be one of the {nch} channels other than the reference {reference}"),
        ));
    }
    let channel = &rec.meta.channels[response_channel];
    let quantity = channel.quantity;
    if !quantity.is_motion() {
        return Err(Error::input(
            format!("channel `{}`", channel.name),
            format!("is a {quantity} channel; a motion response is needed"),
        ));
    }
    let fs = rec.meta.sample_rate_hz;
    let force = rec.channels[reference];
    let measured = rec.channels[response_channel];
    // a periodic recording drives the model repeated until it has settled;
    // the last period is compared
    let n = force.len();
    let repeats = if options.periodic {
        settling_periods(model, n as f64 / fs)
    } else {
        1
    };
    let repeated = (repeats > 1).then(|| force.values().repeat(repeats));
    let drive = PreparedDrive::for_one_replay(
        repeated.as_ref().map_or(force, SamplesView::from),
        options.input,
    );
    let factor = upsampling_factor(model, fs, options.min_samples_per_period)?;
    let report = |task, done, total| crate::observe::progress(observer, task, done, total);
    // the measured FRFs first: a sweep's law sets the window in a band
    let measured_frfs = match &options.reduction {
        Some(r) => {
            report(REDUCING, 0, 2)?;
            let m = MeasuredFrfs::of(rec, (reference, response_channel), r)?;
            report(REDUCING, 1, 2)?;
            Some(m)
        }
        None => None,
    };
    let compared = n.min(measured.len());
    let window = match (options.window_s, options.band_hz, &measured_frfs) {
        (Some((t0, t1)), _, _) => {
            if !(t0.is_finite() && t1.is_finite() && 0.0 <= t0 && t0 < t1) {
                return Err(Error::plan(
                    "window_s",
                    format!("need 0 <= start < end, got {t0}:{t1} s"),
                ));
            }
            let a = (t0 * fs).round() as usize;
            let b = ((t1 * fs).round() as usize).min(measured.len());
            Some(a..b)
        }
        (None, Some(band), Some(MeasuredFrfs { sweep: Some(s), .. })) => {
            let (a, b) = sweep_window(s, band);
            (a < b).then_some(a..b)
        }
        _ => None,
    };
    let tally = |range| tally::RangeTally::new(measured, compared, fs, range, options.band_hz);
    let mut pass = Pass {
        measured,
        skip: (repeats - 1) * n,
        compared,
        made: 0,
        whole: tally(0..compared)?,
        window: window.clone().map(tally).transpose()?,
        kept: {
            let held = crate::signals::SAMPLES_HELD_IN_MEMORY;
            let b = crate::signals::SamplesBuilder::new(compared.min(held), &[]);
            if keep_replay {
                b
            } else {
                b.spilling_above(held)
            }
        },
        // a sweep is followed over the record whole (held in scratch
        // files where it is long)
        keep: keep_replay || measured_frfs.as_ref().is_some_and(|m| m.dwells.is_none()),
        floor: usize::MAX,
        pending: Vec::new(),
        pending_from: 0,
        tap,
    };
    pass.tap
        .begin(compared, pass.window.as_ref().map(|w| w.range()));
    let mut replay = Replay::new(model, &drive, (fs, factor), quantity, response_sign)?
        .with_acquisition(options.acquisition.as_ref())?;
    // a stepped recording's replay reduced a dwell at a time as it comes
    let simulated_stepped = match &measured_frfs {
        Some(MeasuredFrfs {
            dwells: Some((meta, opts)),
            ..
        }) => {
            let mut frames = ReplayFrames {
                meta,
                reference: force,
                replay: &mut replay,
                pass: &mut pass,
                observer,
            };
            Some(reduce_stepped_stream(&mut frames, 1, opts)?.frf)
        }
        _ => None,
    };
    pass.floor = usize::MAX;
    while let Some(stretch) = replay.next_stretch(observer)? {
        pass.take(stretch)?;
    }
    let top = replay.highest_frequency_hz();
    let Pass {
        whole,
        window,
        kept,
        ..
    } = pass;
    let kept = kept.finish()?;
    let frf = match measured_frfs {
        None => None,
        Some(m) => {
            let simulated = match (simulated_stepped, &options.reduction) {
                (Some(s), _) => s,
                (None, Some(Reduction::Swept(opts))) => {
                    let q = rec.meta.channels[response_channel].quantity;
                    let r = rec.meta.channels[reference].quantity;
                    reduce_sweep_held(force, kept.view(), fs, opts)?.into_frf(q, r)
                }
                (None, _) => unreachable!("a measured reduction is stepped or swept"),
            };
            report(REDUCING, 2, 2)?;
            Some(m.compared_with(simulated, options.band_hz))
        }
    };
    Ok(Validation {
        sample_rate_hz: fs,
        quantity,
        upsampling: factor,
        highest_frequency_hz: top,
        replay: options.input,
        whole: whole.finish(measured, fs),
        window: window.map(|w| w.finish(measured, fs)),
        frf,
        lines: None,
        line_spectrum: None,
        simulated: if keep_replay {
            kept.into_values()
        } else {
            Vec::new()
        },
    })
}

/// A validation's pass over the replay: the error tallies, the replay kept
/// where asked, the tap, and the samples a reduction reading it a dwell at
/// a time still needs.
struct Pass<'p, 'a> {
    measured: SamplesView<'a>,
    /// Samples of the replay before the one compared first (a periodic
    /// recording's settling periods).
    skip: usize,
    compared: usize,
    /// Replayed samples taken so far (the skipped ones too).
    made: usize,
    whole: tally::RangeTally,
    window: Option<tally::RangeTally>,
    keep: bool,
    /// The replay kept (held in a scratch file once it is longer than
    /// [`crate::signals::SAMPLES_HELD_IN_MEMORY`] where the caller does not
    /// take it).
    kept: crate::signals::SamplesBuilder,
    /// The first compared sample a reduction still reads (`usize::MAX`:
    /// none), and those held for it from `pending_from` on.
    floor: usize,
    pending: Vec<f64>,
    pending_from: usize,
    tap: &'p mut dyn ReplayTap,
}

impl Pass<'_, '_> {
    /// The next stretch of the replay.
    fn take(&mut self, stretch: &[f64]) -> Result<()> {
        let first = self.made;
        self.made += stretch.len();
        // the compared samples of the stretch, and the first one's index
        let (a, b) = (
            first.max(self.skip).min(self.made),
            self.made.min(self.skip + self.compared),
        );
        if a >= b {
            return Ok(());
        }
        let at = a - self.skip;
        let simulated = &stretch[a - first..b - first];
        let measured = self.measured.range(at..at + simulated.len());
        self.whole.push(at, &measured, simulated)?;
        if let Some(w) = &mut self.window {
            w.push(at, &measured, simulated)?;
        }
        if self.keep {
            self.kept.extend(simulated)?;
        }
        self.tap.stretch(at, &measured, simulated);
        let end = at + simulated.len();
        if end > self.floor {
            let from = at.max(self.floor);
            if self.pending.is_empty() {
                self.pending_from = from;
            }
            self.pending.extend_from_slice(&simulated[from - at..]);
        }
        Ok(())
    }

    /// Compared samples taken so far.
    fn compared_made(&self) -> usize {
        self.made.saturating_sub(self.skip).min(self.compared)
    }
}

/// A model's replay beside the reference that drives it, read as a
/// recording of `meta`'s two channels (the reference, and the replay in the
/// response's place) a stretch at a time in increasing order (a stepped
/// reduction's dwells, stated in order): the replay is made as far as each
/// read needs, and only what the reads may still ask for is held (from the
/// last read's first frame on). What a time-domain diagnosis reduces its
/// model's replay with, as the measured recording was reduced, whatever the
/// recording's length.
pub(crate) struct ReplayBeside<'r, 'd, 'a> {
    meta: &'r RecordingMeta,
    /// The reference's and the response's channels in `meta`.
    channels: (usize, usize),
    reference: SamplesView<'a>,
    replay: Replay<'d, 'a>,
    /// Replayed samples made so far, and those held from `held_from` on.
    made: usize,
    held: Vec<f64>,
    held_from: usize,
    observer: &'r dyn Observer,
}

impl<'r, 'd, 'a> ReplayBeside<'r, 'd, 'a> {
    /// `replay` (of a drive made from `reference`) beside `reference`, as
    /// the recording `meta` of two channels (`reference`, `response`).
    pub(crate) fn new(
        meta: &'r RecordingMeta,
        (reference_channel, response): (usize, usize),
        reference: SamplesView<'a>,
        replay: Replay<'d, 'a>,
        observer: &'r dyn Observer,
    ) -> Result<ReplayBeside<'r, 'd, 'a>> {
        if meta.channels.len() != 2
            || reference_channel == response
            || reference_channel.max(response) > 1
        {
            return Err(Error::input(
                "the replay",
                format!(
                    "read beside its reference as a recording of two channels, not {} \
                     (reference {reference_channel}, response {response})",
                    meta.channels.len()
                ),
            ));
        }
        Ok(ReplayBeside {
            meta,
            channels: (reference_channel, response),
            reference,
            replay,
            made: 0,
            held: Vec::new(),
            held_from: 0,
            observer,
        })
    }
}

impl FrameSource for ReplayBeside<'_, '_, '_> {
    fn meta(&self) -> &RecordingMeta {
        self.meta
    }
    fn frames(&self) -> usize {
        self.reference.len()
    }
    fn source_name(&self) -> String {
        "the replay".into()
    }
    fn read_at(&mut self, start: usize, count: usize, out: &mut [Vec<f64>]) -> Result<usize> {
        let frames = self.frames();
        if start < self.held_from || start > frames {
            return Err(Error::input(
                "the replay",
                format!(
                    "frame {start} is behind the {} let go, or beyond its {frames} frames: it \
                     is read in increasing order",
                    self.held_from
                ),
            ));
        }
        // what lies before `start` is not read again
        let drop = (start - self.held_from).min(self.held.len());
        self.held.drain(..drop);
        self.held_from += drop;
        let end = start.saturating_add(count).min(frames);
        while self.made < end {
            let Some(stretch) = self.replay.next_stretch(self.observer)? else {
                break;
            };
            let first = self.made;
            self.made += stretch.len();
            let from = first.max(start);
            if self.held.is_empty() {
                self.held_from = from.min(self.made);
            }
            if from < self.made {
                self.held.extend_from_slice(&stretch[from - first..]);
            }
        }
        let end = end.min(self.made);
        let (reference, response) = self.channels;
        out[reference].clear();
        out[reference].extend_from_slice(&self.reference.range(start..end));
        out[response].clear();
        out[response].extend_from_slice(&self.held[start - self.held_from..end - self.held_from]);
        Ok(end - start)
    }
}

/// The reference beside the replay, read as a two-channel recording a
/// stretch at a time in increasing order (a stepped reduction's dwells):
/// the replay is made as far as each read needs, and only what the reads
/// still ask for is held.
struct ReplayFrames<'r, 'p, 'a, 'd> {
    meta: &'r RecordingMeta,
    reference: SamplesView<'a>,
    replay: &'r mut Replay<'d, 'a>,
    pass: &'r mut Pass<'p, 'a>,
    observer: &'r dyn Observer,
}

impl FrameSource for ReplayFrames<'_, '_, '_, '_> {
    fn meta(&self) -> &RecordingMeta {
        self.meta
    }
    fn frames(&self) -> usize {
        self.pass.compared
    }
    fn source_name(&self) -> String {
        "the replay".into()
    }
    fn read_at(&mut self, start: usize, count: usize, out: &mut [Vec<f64>]) -> Result<usize> {
        let frames = self.frames();
        let pass = &mut *self.pass;
        // what was made before `start` is not read again
        if !pass.pending.is_empty() {
            let drop = start
                .saturating_sub(pass.pending_from)
                .min(pass.pending.len());
            pass.pending.drain(..drop);
            pass.pending_from += drop;
        }
        let held_from = if pass.pending.is_empty() {
            pass.compared_made()
        } else {
            pass.pending_from
        };
        if start > frames || start < held_from {
            return Err(Error::input(
                "the replay",
                format!(
                    "frame {start} is behind the {held_from} made and let go, or beyond its \
                     {frames} frames: it is read in increasing order"
                ),
            ));
        }
        let end = start.saturating_add(count).min(frames);
        pass.floor = start;
        if pass.pending.is_empty() {
            pass.pending_from = start;
        }
        while pass.compared_made() < end {
            let Some(stretch) = self.replay.next_stretch(self.observer)? else {
                break;
            };
            pass.take(stretch)?;
        }
        let (a, b) = (start - pass.pending_from, end - pass.pending_from);
        out[0].clear();
        out[0].extend_from_slice(&self.reference.range(start..end));
        out[1].clear();
        out[1].extend_from_slice(&pass.pending[a..b]);
        Ok(end - start)
    }
}

/// The measured response's nonlinear FRFs, and how the simulated one is
/// reduced the same way.
struct MeasuredFrfs {
    frf: NonlinearFrf,
    /// The sweep fitted to the reference (swept sine).
    sweep: Option<SweepFit>,
    /// A stepped sine's two-channel description (the reference, then the
    /// response) with the dwells reduced and the options: the simulated
    /// response is reduced on exactly those dwells, a dwell at a time as
    /// it is made.
    dwells: Option<(RecordingMeta, ReduceOptions)>,
}

impl MeasuredFrfs {
    /// Reduces the measured response `channels.1` against the reference
    /// `channels.0` of `rec` as `reduction` says.
    fn of(rec: &RecordingView, channels: (usize, usize), reduction: &Reduction) -> Result<Self> {
        let (reference, response) = channels;
        let fs = rec.meta.sample_rate_hz;
        match reduction {
            Reduction::Swept(opts) => {
                let m =
                    reduce_sweep_held(rec.channels[reference], rec.channels[response], fs, opts)?;
                let sweep = m.sweep;
                Ok(MeasuredFrfs {
                    frf: m.into_frf(
                        rec.meta.channels[response].quantity,
                        rec.meta.channels[reference].quantity,
                    ),
                    sweep: Some(sweep),
                    dwells: None,
                })
            }
            Reduction::Stepped(opts) => {
                let opts = ReduceOptions {
                    reference_channel: Some(0),
                    ..opts.clone()
                };
                let mut meta = rec.meta.clone();
                meta.channels = vec![
                    rec.meta.channels[reference].clone(),
                    rec.meta.channels[response].clone(),
                ];
                let pair = vec![rec.channels[reference], rec.channels[response]];
                // the dwells, stated or found (a stretch at a time where
                // the record is long), are read one at a time
                let first = reduce_stepped_stream(
                    &mut InMemoryFrames::of_channels(&meta, pair.clone(), "recording"),
                    1,
                    &opts,
                )?;
                // the simulated response on exactly the measured dwells
                let steps: Vec<Step> = first.dwells.iter().map(|d| d.step).collect();
                let frf = if steps == meta.excitation.steps {
                    first.frf
                } else {
                    meta.excitation.steps = steps;
                    reduce_stepped_stream(
                        &mut InMemoryFrames::of_channels(&meta, pair, "recording"),
                        1,
                        &opts,
                    )?
                    .frf
                };
                Ok(MeasuredFrfs {
                    frf,
                    sweep: None,
                    dwells: Some((meta, opts)),
                })
            }
        }
    }

    /// The comparison with `simulated`, reduced the same way, within
    /// `band_hz`.
    fn compared_with(self, simulated: NonlinearFrf, band_hz: Option<(f64, f64)>) -> FrfComparison {
        let levels = self
            .frf
            .levels
            .iter()
            .zip(&simulated.levels)
            .map(|(m, s)| {
                let (mut num, mut den, mut n) = (0.0, 0.0, 0);
                for (a, b) in m.points.iter().zip(&s.points) {
                    if in_band(a.frequency_hz, band_hz) {
                        num += (b.h[1] - a.h[1]).norm_sqr();
                        den += a.h[1].norm_sqr();
                        n += 1;
                    }
                }
                LevelComparison {
                    level: m.level,
                    points: n,
                    relative_h1_error: if den > 0.0 {
                        (num / den).sqrt()
                    } else {
                        f64::NAN
                    },
                    measured_peak: h1_peak(&m.points, band_hz),
                    simulated_peak: h1_peak(&s.points, band_hz),
                }
            })
            .collect();
        FrfComparison {
            levels,
            sweep: self.sweep,
            measured: Some(self.frf),
            simulated: Some(simulated),
        }
    }
}

/// Samples `a..b` where the fitted sweep's frequency lies inside `band`.
pub fn sweep_window(sweep: &SweepFit, band: (f64, f64)) -> (usize, usize) {
    let r = sweep.samples_in(band);
    (r.start, r.end)
}

/// The task the FRF comparison reports: both signals reduced.
const REDUCING: &str = "reducing the measured and simulated responses";

#[cfg(test)]
mod tests {
    use super::*;
    use crate::extract::reduce_stepped_report;
    use crate::model::ModalModel;
    use std::f64::consts::PI;

    /// A replay made a stretch at a time is the replay made whole, to the
    /// bit: the reference below is the simulation of the whole drive
    /// (interpolated and pre-emphasised at once, as a replay made it before
    /// it was streamed) decimated at once, on a Jenkins structure (300 N at
    /// 250 Hz puts about 780 N on the stuck joint, which slips at 246 N:
    /// its state crosses the stretches), over more samples than a stretch, at
    /// the recording's own rate and at three times it, for each way the
    /// force is taken between samples; and the same from the force held as
    /// a file stores it (`f32`s of a unit, see [`crate::signals::Samples`]),
    /// whose stretches are converted as they are replayed, and interpolated
    /// a stretch at a time ([`PreparedDrive::for_one_replay`]).
    #[test]
    fn a_replay_made_a_stretch_at_a_time_is_the_replay_made_whole() {
        use crate::model::ElementSpec;
        use crate::sim::{Output, Simulator};
        let fs = 20_000.0;
        let model = Model::new(
            ModalModel::sdof(10.0, 200.0, 1e7).unwrap(),
            vec![ElementSpec::Jenkins {
                kd: 2.4e7,
                fd: 246.048,
            }],
        )
        .unwrap();
        let n = REPLAY_STRETCH + REPLAY_STRETCH / 3 + 7;
        let force: Vec<f64> = (0..n)
            .map(|i| {
                let t = i as f64 / fs;
                let f =
                    300.0 * (2.0 * PI * 250.0 * t).sin() + 120.0 * (2.0 * PI * 1130.0 * t).cos();
                // a float32 file's value of a unit of 0.25 N
                (f / 0.25) as f32 as f64 * 0.25
            })
            .collect();
        let held = crate::signals::Samples::recorded(force.clone(), &[0.25]);
        assert_eq!(held.bytes(), 4 * n);
        for input in [DriveInput::BandLimited, DriveInput::Ramp] {
            for factor in [1, 3] {
                let replay = |drive: &PreparedDrive, factor: usize| {
                    simulate_prepared_at(
                        &model,
                        drive,
                        fs,
                        Quantity::Velocity,
                        -1.0,
                        factor,
                        &Silent,
                    )
                    .unwrap()
                    .values
                };
                let streamed = replay(&PreparedDrive::new(&force, input), factor);
                assert!(replay(&PreparedDrive::new(&held, input), factor) == streamed);
                // held for the first 1 001 samples on the grid, interpolated
                // a stretch at a time beyond; replayed again from what is
                // held, and after a replay at another factor (which drops
                // this factor's held samples)
                let partly = PreparedDrive::new(&held, input).holding_at_most(1001);
                assert!(replay(&partly, factor) == streamed);
                assert!(replay(&partly, factor) == streamed);
                if factor > 1 {
                    let twice = replay(&PreparedDrive::new(&force, input), 2);
                    assert!(replay(&partly, 2) == twice);
                    assert_eq!(partly.cache.lock().unwrap().len(), 1);
                    assert!(replay(&partly, factor) == streamed);
                }
                // interpolated a stretch at a time, never whole
                let one = PreparedDrive::for_one_replay(&held, input);
                assert!(replay(&one, factor) == streamed);
                let fine_drive = match input {
                    DriveInput::Ramp => resample::interpolate(&force, factor).unwrap(),
                    _ => pre_emphasis(&resample::interpolate(&force, factor).unwrap()),
                };
                let mut sim = Simulator::with_quasi_static_above(
                    &model.linear,
                    model.element_set().unwrap(),
                    fs * factor as f64,
                    quasi_static_above_hz(fs),
                )
                .unwrap();
                let mut fine = vec![0.0; fine_drive.len()];
                sim.run_output(&fine_drive, Output::Velocity, &mut fine)
                    .unwrap();
                let whole: Vec<f64> = resample::decimate(&fine, factor)
                    .unwrap()
                    .into_iter()
                    .map(|v| -v)
                    .collect();
                assert_eq!(streamed.len(), n);
                let differ = streamed
                    .iter()
                    .zip(&whole)
                    .filter(|(a, b)| a.to_bits() != b.to_bits())
                    .count();
                assert_eq!(differ, 0, "{input:?} at {factor}x: {differ} samples differ");
            }
        }
    }

    /// A stepped recording of six dwells (two levels, three frequencies
    /// about a Jenkins joint's slip resonance) with gaps between them, more
    /// samples than a replay's stretch: its "measured" response is the
    /// replay of a stiffer joint plus noise.
    fn stepped_recording() -> (Recording, Model) {
        use crate::model::ElementSpec;
        use crate::signals::{Channel, Excitation, ExcitationKind};
        let fs = 8000.0;
        let model = |kd: f64| {
            Model::new(
                ModalModel::sdof(
                    1.0,
                    2.0 * 0.02 * (2.0 * PI * 60.0),
                    (2.0 * PI * 60.0f64).powi(2),
                )
                .unwrap(),
                vec![ElementSpec::Jenkins { kd, fd: 40.0 }],
            )
            .unwrap()
        };
        let (dwell, gap) = (48_000, 1000);
        let mut force = Vec::new();
        let mut steps = Vec::new();
        for level in [20.0, 60.0] {
            for f in [52.0, 60.0, 71.0] {
                force.extend(std::iter::repeat_n(0.0, gap));
                steps.push(Step {
                    frequency_hz: f,
                    level,
                    start: force.len(),
                    settle: 16_000,
                    length: dwell,
                });
                force.extend((0..dwell).map(|i| level * (2.0 * PI * f * i as f64 / fs).sin()));
            }
        }
        assert!(force.len() > REPLAY_STRETCH);
        let truth = model(1.2 * (2.0 * PI * 60.0f64).powi(2));
        let mut seed = 7u64;
        let measured: Vec<f64> =
            simulate_response(&truth, &force, fs, Quantity::Velocity, 1.0, 20.0)
                .unwrap()
                .values
                .into_iter()
                .map(|v| {
                    seed = seed
                        .wrapping_mul(6364136223846793005)
                        .wrapping_add(1442695040888963407);
                    v + 1e-3 * ((seed >> 11) as f64 / (1u64 << 53) as f64 - 0.5)
                })
                .collect();
        let channel = |name: &str, quantity: Quantity| Channel {
            name: name.into(),
            quantity,
            unit: quantity.si_unit().into(),
            scale: 1.0,
        };
        let rec = Recording {
            meta: RecordingMeta::new(
                fs,
                vec![
                    channel("force", Quantity::Force),
                    channel("velocity", Quantity::Velocity),
                ],
                Excitation {
                    kind: ExcitationKind::SteppedSine,
                    steps,
                    sweep: None,
                },
            ),
            channels: vec![force, measured],
        };
        (rec, model((2.0 * PI * 60.0f64).powi(2)))
    }

    /// A validation that never holds its replay gives the figures of the
    /// replay held whole, to the bit: the reference below replays the
    /// whole record at once, computes the error figures from the two
    /// signals whole (`error_metrics`, `error_by_frequency`) and reduces the
    /// measured and simulated responses on the measured dwells as two
    /// recordings held whole (`reduce_stepped_report`). The tap is handed
    /// every simulated sample once,
    /// in order; the replay is kept only when asked. Dwells stated in
    /// increasing order, found on the reference (no steps stated) and
    /// stated out of order (read forwards all the same, one at a time
    /// beside the replay) all give the reference's figures, and so do the channels
    /// held in scratch files (as a loader holds a long recording's).
    #[test]
    fn a_validation_that_never_holds_its_replay_gives_the_whole_replays_figures() {
        struct Collect(Vec<f64>, usize, Option<std::ops::Range<usize>>);
        impl ReplayTap for Collect {
            fn begin(&mut self, samples: usize, window: Option<std::ops::Range<usize>>) {
                (self.1, self.2) = (samples, window);
            }
            fn stretch(&mut self, at: usize, _: &[f64], simulated: &[f64]) {
                assert_eq!(at, self.0.len(), "stretches in order, each once");
                self.0.extend_from_slice(simulated);
            }
        }
        let (stated, model) = stepped_recording();
        let fs = stated.meta.sample_rate_hz;
        let mut found = stated.clone();
        found.meta.excitation.steps.clear();
        let mut shuffled = stated.clone();
        shuffled.meta.excitation.steps.swap(1, 4);
        let band = (45.0, 80.0);
        let options = ValidateOptions {
            window_s: Some((10.0, 30.5)),
            band_hz: Some(band),
            reduction: Some(Reduction::Stepped(ReduceOptions {
                reference_channel: Some(0),
                max_harmonic: 5,
                blocks: 8,
                ..ReduceOptions::default()
            })),
            ..ValidateOptions::default()
        };
        let Some(Reduction::Stepped(reduce)) = &options.reduction else {
            unreachable!()
        };
        for rec in [&stated, &found, &shuffled] {
            // the reference: everything held whole
            let (force, measured) = (&rec.channels[0], &rec.channels[1]);
            let simulated = simulate_response(&model, force, fs, Quantity::Velocity, -1.0, 20.0)
                .unwrap()
                .values;
            let n = measured.len();
            let metrics = |r: std::ops::Range<usize>| {
                let mut e = error_metrics(measured, &simulated, fs, r.clone()).unwrap();
                e.by_frequency =
                    Some(error_by_frequency(measured, &simulated, fs, r, band).unwrap());
                e
            };
            let window = 80_000..244_000;
            let first = reduce_stepped_report(rec, 1, reduce).unwrap();
            let mut pair = rec.clone();
            pair.meta.excitation.steps = first.dwells.iter().map(|d| d.step).collect();
            let want_measured = reduce_stepped_report(&pair, 1, reduce).unwrap().frf;
            pair.channels[1] = simulated.clone();
            let want_simulated = reduce_stepped_report(&pair, 1, reduce).unwrap().frf;
            let spilled: Vec<crate::signals::Samples> = rec
                .channels
                .iter()
                .map(|c| {
                    let mut b =
                        crate::signals::SamplesBuilder::new(c.len(), &[]).spilling_above(10_000);
                    c.chunks(7_777).for_each(|x| b.extend(x).unwrap());
                    b.finish().unwrap()
                })
                .collect();
            assert!(spilled.iter().all(|c| c.is_spilled()));
            let spilled = crate::signals::RecordingView {
                meta: &rec.meta,
                channels: spilled.iter().map(Into::into).collect(),
            };
            for (keep, view) in [(false, rec.view()), (true, rec.view()), (false, spilled)] {
                let mut tap = Collect(Vec::new(), 0, None);
                let v = validate_view(&model, (-1.0, keep), &view, 1, &options, &Silent, &mut tap)
                    .unwrap();
                assert!(v.whole == metrics(0..n), "whole record");
                assert!(v.window == Some(metrics(window.clone())), "window");
                let frf = v.frf.as_ref().unwrap();
                assert!(frf.measured.as_ref() == Some(&want_measured));
                assert!(frf.simulated.as_ref() == Some(&want_simulated));
                assert!(tap.0 == simulated && tap.1 == n && tap.2 == Some(window.clone()));
                assert!(v.simulated == if keep { simulated.clone() } else { Vec::new() });
            }
        }
    }

    /// Four sines on the FFT's bins (1 s at 1 kHz) about the band 10-20 Hz:
    /// 3 Hz below it, 15 Hz inside, 30 Hz just above (up to 40 Hz) and
    /// 100 Hz beyond, plus a mean. The simulated response has the 15 Hz
    /// sine 10 % low, no 30 Hz sine and the 100 Hz one right: each part's
    /// share is the closed-form RMS of the sine it holds, `A/√2`, over the
    /// measured RMS, and the error's parts add up to the whole figure. The
    /// same at sixteen times the frequencies over 2 1/16 s at 2^20 Hz,
    /// longer than [`SPLIT_BLOCK`]: split into two blocks of a second and
    /// one of 1/16 s, each holding whole periods of every sine, the shares
    /// are the same closed forms. With a last block of 65 537 samples
    /// (padded with zeros to a fast length: no sine holds whole periods
    /// there) the parts still add up to the whole, and the shares are the
    /// closed forms within 5e-3 (that block's leakage: 3 % of the samples,
    /// whose rectangular window of 1/16 s leaks about 2 % of a sine's
    /// energy five bins away; the shares are square roots of energies).
    #[test]
    fn the_error_split_by_frequency_is_each_sines_share() {
        the_error_split_at(1000.0, 1000, 1.0, None);
        let fs = SPLIT_BLOCK as f64;
        the_error_split_at(fs, 2 * SPLIT_BLOCK + SPLIT_BLOCK / 16, 16.0, None);
        the_error_split_at(fs, 2 * SPLIT_BLOCK + 65_537, 16.0, Some(5e-3));
    }

    /// The test above at sample rate `fs` over `n` samples, the frequencies
    /// times `u`, the shares within `leakage` of their closed forms where
    /// given (else to rounding).
    fn the_error_split_at(fs: f64, n: usize, u: f64, leakage: Option<f64>) {
        let amplitudes = [
            (3.0 * u, 0.5),
            (15.0 * u, 2.0),
            (30.0 * u, 0.7),
            (100.0 * u, 0.3),
        ];
        let sine = |f: f64, i: usize| (2.0 * PI * f * u * i as f64 / fs).sin();
        let measured: Vec<f64> = (0..n)
            .map(|i| {
                4.0 + amplitudes
                    .iter()
                    .map(|&(f, a)| a * sine(f / u, i))
                    .sum::<f64>()
            })
            .collect();
        let simulated: Vec<f64> = (0..n)
            .map(|i| 4.0 + 0.5 * sine(3.0, i) + 1.8 * sine(15.0, i) + 0.3 * sine(100.0, i))
            .collect();
        let band = (10.0 * u, 20.0 * u);
        let b = error_by_frequency(&measured, &simulated, fs, 0..n, band).unwrap();
        let rms = (amplitudes.iter().map(|(_, a)| a * a).sum::<f64>() / 2.0).sqrt();
        let share = |a: f64| a / 2f64.sqrt() / rms;
        // a rounding error of about 1e-15 a sample, summed
        let tol = 1e-15 * n as f64;
        let near = |got: f64, want: f64, tol: f64| {
            assert!((got - want).abs() < tol, "{n} samples: {got} vs {want}")
        };
        let close = |got: f64, want: f64| near(got, want, leakage.unwrap_or(tol));
        close(b.below.error, 0.0);
        close(b.inside.error, share(0.2));
        close(b.above.error, share(0.7));
        close(b.beyond.error, 0.0);
        for (part, (_, a)) in [b.below, b.inside, b.above, b.beyond]
            .iter()
            .zip(amplitudes)
        {
            close(part.measured, share(a));
        }
        close(b.inside.simulated, share(1.8));
        close(b.above.simulated, 0.0);
        let whole = error_metrics(&measured, &simulated, fs, 0..n).unwrap();
        let parts = [b.below, b.inside, b.above, b.beyond];
        near(
            parts.iter().map(|p| p.error * p.error).sum::<f64>().sqrt(),
            whole.relative,
            tol,
        );
        assert!(error_by_frequency(&measured, &simulated, fs, 0..n, (band.1, band.0)).is_err());
    }

    /// A linear SDOF driven by the samples of a sine at `fs/8` and `fs/20`,
    /// its steady amplitude against closed forms. Taken as a ramp, the
    /// force drives the filter's exact response `Σ_k H(f + k·fs)·sinc²(u + k)`
    /// (`u = f/fs`: the fundamental `sinc²(u)` low, 5 % and 0.8 %, plus
    /// aliases); taken as band-limited, that times the pre-emphasis gain
    /// `1 + (1 − cos 2πu)/6`, which brings it to the receptance `|H(f)|`
    /// within the FIR's fourth-order remainder and the aliases: at least 5
    /// times closer than the ramp.
    #[test]
    fn a_measured_force_is_replayed_as_the_band_limited_signal() {
        use num_complex::Complex64;
        let fs = 8000.0;
        let (m, k) = (1.0, (2.0 * PI * 3000.0f64).powi(2));
        let c = 2.0 * 0.05 * (k * m).sqrt();
        let model = Model::new(ModalModel::sdof(m, c, k).unwrap(), vec![]).unwrap();
        let h = |f: f64| {
            let w = 2.0 * PI * f;
            Complex64::new(1.0, 0.0) / Complex64::new(k - m * w * w, c * w)
        };
        let sinc2 = |u: f64| {
            if u == 0.0 {
                1.0
            } else {
                ((PI * u).sin() / (PI * u)).powi(2)
            }
        };
        for f in [fs / 8.0, fs / 20.0] {
            let n = (fs * 0.5) as usize;
            let force: Vec<f64> = (0..n)
                .map(|i| (2.0 * PI * f * i as f64 / fs).sin())
                .collect();
            let w = 2.0 * PI * f;
            let amplitude = |input| {
                let x = simulate_response_with(
                    &model,
                    &force,
                    fs,
                    Quantity::Displacement,
                    1.0,
                    2.0,
                    input,
                    &Silent,
                )
                .unwrap()
                .values;
                // least-squares sine and cosine over whole periods of the
                // second half
                let period = (fs / f).round() as usize;
                let tail = n / 2..n / 2 + period * ((n / 2 - 64) / period);
                let (mut sc, mut cc) = (0.0, 0.0);
                for i in tail.clone() {
                    let ph = w * i as f64 / fs;
                    sc += x[i] * ph.sin();
                    cc += x[i] * ph.cos();
                }
                2.0 * (sc * sc + cc * cc).sqrt() / tail.len() as f64
            };
            let u = f / fs;
            let ramp_exact: Complex64 = (-4..=4)
                .map(|j| h(f + j as f64 * fs) * sinc2(u + j as f64))
                .sum();
            let gain = 1.0 + (1.0 - (2.0 * PI * u).cos()) / 6.0;
            let want = h(f).norm();
            let (ramp, band) = (
                amplitude(DriveInput::Ramp),
                amplitude(DriveInput::BandLimited),
            );
            assert!(
                (ramp / ramp_exact.norm() - 1.0).abs() < 1e-3,
                "f {f}: ramp {ramp} vs {}",
                ramp_exact.norm()
            );
            assert!(
                (band / (gain * ramp_exact.norm()) - 1.0).abs() < 1e-3,
                "f {f}: band-limited {band}"
            );
            assert!(
                (band / want - 1.0).abs() * 5.0 < (ramp / want - 1.0).abs(),
                "f {f}: band-limited {:.3e}, ramp {:.3e} off |H|",
                band / want - 1.0,
                ramp / want - 1.0
            );
        }
    }
}
