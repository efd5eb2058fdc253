//! The recording's force replayed through the model: the drive prepared on the
//! simulation grid, the simulated response whole or a stretch at a time.

use super::{DriveInput, acquisition, resample};
use crate::error::{Error, Result};
use crate::harmonics::Quantity;
use crate::model::Model;
use crate::observe::{Observer, Silent};
use crate::signals::SamplesView;
use crate::sim::Simulator;
/// The samples pre-emphasised as [`DriveInput::BandLimited`] says (the
/// ends held: a record starts and ends at rest), sample by sample: the
/// tests' reference for [`pre_emphasise`].
#[cfg(test)]
pub(super) fn pre_emphasis(x: &[f64]) -> Vec<f64> {
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

/// Periods of `period_s` a periodic drive is repeated so that the
/// linearised model's slowest mode has decayed by 1e-6 before the last
/// (at least 2, at most 64).
pub(super) fn settling_periods(model: &Model, period_s: f64) -> usize {
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
    pub(super) cache: std::sync::Mutex<Vec<(usize, std::sync::Arc<Vec<f64>>)>>,
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
    pub(super) fn holding_at_most(self, samples: usize) -> PreparedDrive<'a> {
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
pub(super) const REPLAY_STRETCH: usize = crate::observe::SAMPLES_PER_REPORT;

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
            (Some(h), _) => self
                .sim
                .run_output(&h[done..end], self.output, fine, &Silent)?,
            (None, DriveInput::Ramp) => {
                let x = drive_on_grid(reference, interpolator, buffer, done..end);
                self.sim.run_output(&x, self.output, fine, &Silent)?
            }
            (None, _) => {
                // with a neighbour each side where there is one: the same
                // drive as the whole reference pre-emphasised
                let lo = done.saturating_sub(1);
                let x = drive_on_grid(reference, interpolator, buffer, lo..(end + 1).min(total));
                self.force.clear();
                self.force
                    .extend((done..end).map(|i| pre_emphasised(&x, i - lo)));
                self.sim
                    .run_output(&self.force, self.output, fine, &Silent)?;
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
