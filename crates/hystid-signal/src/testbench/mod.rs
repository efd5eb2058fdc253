//! The virtual stepped-sine test bench: a shaker test of a simulated
//! structure, analysed as a lab would analyse a real one (paper section 3).
//!
//! For each force level the bench steps through the frequencies; the
//! structure's state carries from dwell to dwell as on a real shaker, and the
//! drive changes frequency phase-continuously. Each dwell settles until the
//! harmonics of consecutive blocks of whole periods agree (or a cap is hit,
//! which is reported), then measures whole blocks. Sampling is coherent: the
//! sample rate is fixed for the run and each dwell's frequency is shifted by
//! at most `frequency_tolerance` so that a block of `q` whole periods spans a
//! whole number of samples, which puts every harmonic on an exact FFT bin.
//! Gaussian noise, seeded per level (so the bytes do not depend on the thread
//! count), is added to every response channel at a given fraction of each
//! dwell's clean RMS (the convention of ABRAVIBE's noise examples, e.g.
//! `d_2DOF_OutputNoise.m`; the paper does not define its "10 %"), and
//! optionally to the force.

pub mod plan;

pub use plan::{DEFAULT_TEST, StructureDefinition, TestDefinition, model_from_toml};

use crate::error::{Error, Result};
use crate::extract::{
    Direction, DwellHarmonics, FrfLevel, FrfPoint, HarmonicAnalyser, NonlinearFrf, harmonics_agree,
};
use crate::harmonics::Quantity;
use crate::model::Model;
use crate::observe::{Event, Observer};
use crate::sim::{Response, Simulator};
use num_complex::Complex64;
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, StandardNormal};
use rayon::prelude::*;
use serde::{Deserialize, Serialize};
use std::f64::consts::PI;

/// The four channels a virtual test records, in recording order: the
/// reference, displacement, velocity, acceleration (SI units, unit scale).
/// The reference is the force, or with a shaker in the model
/// ([`reference_quantity`]) the voltage driving it.
pub fn recorded_channels(reference: Quantity) -> Vec<crate::record::Channel> {
    let name = match reference {
        Quantity::Voltage => "drive",
        _ => "force",
    };
    [
        (name, reference),
        ("displacement", Quantity::Displacement),
        ("velocity", Quantity::Velocity),
        ("acceleration", Quantity::Acceleration),
    ]
    .into_iter()
    .map(|(n, q)| crate::record::Channel {
        name: n.into(),
        quantity: q,
        unit: q.si_unit().into(),
        scale: 1.0,
    })
    .collect()
}

/// The channels the virtual test of `def` records, in recording order: those
/// of [`recorded_channels`], with `test.force_gauge` the shaker's force
/// (channel `force`) after the voltage.
pub fn test_channels(def: &TestDefinition) -> Result<Vec<crate::record::Channel>> {
    let mut channels = recorded_channels(reference_quantity(&def.model()?));
    if def.test.force_gauge {
        channels.insert(
            1,
            crate::record::Channel {
                name: "force".into(),
                quantity: Quantity::Force,
                unit: Quantity::Force.si_unit().into(),
                scale: 1.0,
            },
        );
    }
    Ok(channels)
}

/// What a virtual test of `model` records as its reference: the force, or,
/// when a shaker stands between the drive and the structure, its voltage
/// (at 1 N/V: the model's forces are then in the drive's unit, as a model
/// identified from a voltage has them).
pub fn reference_quantity(model: &Model) -> Quantity {
    if model.laws().any(|e| e.drive_load().is_some()) {
        Quantity::Voltage
    } else {
        Quantity::Force
    }
}

/// Fewest measured blocks per dwell.
pub const MIN_BLOCKS: usize = 8;

/// How a dwell's requested frequency was made coherent.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct DwellDesign {
    /// Requested frequency, Hz.
    pub requested_hz: f64,
    /// Frequency driven, Hz: `q fs / block_len`.
    pub frequency_hz: f64,
    /// Whole periods per block `q`.
    pub periods_per_block: usize,
    /// Samples per block.
    pub block_len: usize,
}

/// The smallest number of periods per block `q ≤ 64` for which a block of
/// `round(q fs/f)` samples holds `q` whole periods of a frequency within
/// `tolerance` of `f` (else the closest one found).
pub fn design_dwell(requested_hz: f64, sample_rate_hz: f64, tolerance: f64) -> DwellDesign {
    let mut best: Option<(f64, DwellDesign)> = None;
    for q in 1..=64usize {
        let block_len = ((q as f64 * sample_rate_hz / requested_hz).round() as usize).max(1);
        let frequency_hz = q as f64 * sample_rate_hz / block_len as f64;
        let err = (frequency_hz / requested_hz - 1.0).abs();
        let d = DwellDesign {
            requested_hz,
            frequency_hz,
            periods_per_block: q,
            block_len,
        };
        if err <= tolerance {
            return d;
        }
        if best.is_none_or(|(e, _)| err < e) {
            best = Some((err, d));
        }
    }
    best.expect("q = 1 was tried").1
}

/// Everything the bench knows about one dwell.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct DwellRecord {
    /// Dwell number within the run (all levels).
    pub index: usize,
    /// Level number.
    pub level_index: usize,
    /// Nominal force amplitude, N.
    pub level: f64,
    /// Sweep direction of the run this dwell belongs to.
    pub direction: Direction,
    /// The frequency design.
    pub design: DwellDesign,
    /// First frame of the dwell in the run's recording.
    pub start: u64,
    /// Frames spent settling.
    pub settle: usize,
    /// Frames in the dwell (settle included).
    pub length: usize,
    /// Periods spent settling.
    pub settle_periods: usize,
    /// False when the settling cap was hit first.
    pub settled: bool,
    /// Harmonics of the measured (noisy) force and response.
    pub measured: DwellHarmonics,
    /// `H_k` of the clean (noise-free) signals: the steady state itself.
    pub clean_h: Vec<Complex64>,
    /// The clean receptance harmonics `X_k/F_1` (whatever the FRFs' response
    /// quantity), for comparisons with harmonic balance.
    pub clean_receptance: Vec<Complex64>,
    /// Measured noise RMS over clean RMS of the response channel.
    pub noise_ratio: f64,
    /// The measured response's subharmonic, when it repeats only every 2 or
    /// 3 periods (see [`crate::extract::subharmonic`]).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub subharmonic: Option<crate::extract::Subharmonic>,
}

/// One level's recorded signals (f32, as written to files) and its dwells.
#[derive(Clone, Debug, Default)]
pub struct LevelOutput {
    /// Level number.
    pub level_index: usize,
    /// The dwells, `start` relative to the whole run.
    pub dwells: Vec<DwellRecord>,
    /// Measured force, N.
    pub force: Vec<f32>,
    /// Measured displacement, m.
    pub displacement: Vec<f32>,
    /// Measured velocity, m/s.
    pub velocity: Vec<f32>,
    /// Measured acceleration, m/s².
    pub acceleration: Vec<f32>,
    /// With a force gauge, the measured force the shaker applies, N (else
    /// empty).
    pub gauge: Vec<f32>,
}

impl LevelOutput {
    /// The signals in the order [`test_channels`] lists them.
    pub fn channels(&self) -> Vec<&[f32]> {
        let mut c = vec![
            &self.force[..],
            &self.displacement[..],
            &self.velocity[..],
            &self.acceleration[..],
        ];
        if !self.gauge.is_empty() {
            c.insert(1, &self.gauge[..]);
        }
        c
    }
}

/// Receives each level's output, in level order.
pub trait BenchSink {
    /// One level's signals and dwells; `first_frame` is its position in the run.
    fn level(&mut self, output: &LevelOutput, first_frame: u64) -> Result<()>;
}

/// A sink that keeps nothing.
#[derive(Debug, Default)]
pub struct NoSink;

impl BenchSink for NoSink {
    fn level(&mut self, _: &LevelOutput, _: u64) -> Result<()> {
        Ok(())
    }
}

/// The result of a virtual test.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct BenchRun {
    /// Sample rate, Hz.
    pub sample_rate_hz: f64,
    /// The nonlinear FRFs of the chosen response.
    pub frf: NonlinearFrf,
    /// Every dwell, in recording order.
    pub dwells: Vec<DwellRecord>,
    /// Frames recorded.
    pub frames: u64,
}

impl BenchRun {
    /// Dwells that hit the settling cap.
    pub fn unsettled(&self) -> impl Iterator<Item = &DwellRecord> {
        self.dwells.iter().filter(|d| !d.settled)
    }
}

/// Runs the virtual test of `def`, handing each level's signals to `sink` in
/// level order and telling `observer` of each dwell (from any thread).
pub fn run(
    def: &TestDefinition,
    sink: &mut dyn BenchSink,
    observer: &dyn Observer,
) -> Result<BenchRun> {
    def.validate()?;
    let model = def.model()?;
    let fs = def.sample_rate_hz()?;
    let sweeps = def.sweeps()?;
    let levels = &def.test.levels_n;
    let chunk = rayon::current_num_threads().max(1);
    let mut dwells = Vec::new();
    let mut frames = 0u64;
    let mut frf_levels = Vec::new();
    let mut counted = 0;
    // levels run in parallel a few at a time, so memory stays bounded by the
    // thread count while the sink still receives them in order; the next
    // batch is simulated while the sink writes this one (writing the MCAP
    // and WAV files is serial, and left the other cores idle)
    let batches: Vec<std::ops::Range<usize>> = (0..levels.len())
        .step_by(chunk)
        .map(|start| start..(start + chunk).min(levels.len()))
        .collect();
    let simulate = |batch: std::ops::Range<usize>| -> Vec<Result<LevelOutput>> {
        batch
            .into_par_iter()
            .map(|i| run_level(def, &model, fs, &sweeps, i, levels[i], observer))
            .collect()
    };
    let mut pending = batches.first().cloned().map(simulate);
    for k in 0..batches.len() {
        let outputs = pending.take().unwrap_or_default();
        let next = batches.get(k + 1).cloned();
        let (written, simulated) = std::thread::scope(|scope| {
            let ahead = next.map(|b| scope.spawn(|| simulate(b)));
            let write = || -> Result<()> {
                for out in outputs {
                    let mut out = out?;
                    for d in &mut out.dwells {
                        d.start += frames;
                        d.index = dwells.len() + counted;
                        counted += 1;
                    }
                    sink.level(&out, frames)?;
                    frames += out.force.len() as u64;
                    for (dir, _) in &sweeps {
                        let points = out
                            .dwells
                            .iter()
                            .filter(|d| d.direction == *dir)
                            .map(|d| FrfPoint {
                                frequency_hz: d.design.frequency_hz,
                                force_amplitude: d.measured.force[1].norm(),
                                h: d.measured.h.clone(),
                                std_error: d.measured.std_error.clone(),
                                force_distortion: d
                                    .measured
                                    .force
                                    .iter()
                                    .map(|f| f / d.measured.force[1])
                                    .collect(),
                                blocks: d.measured.blocks,
                                settle_periods: d.settle_periods,
                                settled: d.settled,
                                subharmonic: d.subharmonic,
                            })
                            .collect();
                        frf_levels.push(FrfLevel {
                            level: levels[out.level_index],
                            direction: *dir,
                            points,
                        });
                    }
                    dwells.extend(out.dwells);
                    counted = 0;
                }
                Ok(())
            };
            let written = write();
            // a simulation that panicked is a bug: its panic goes on
            let simulated =
                ahead.map(|h| h.join().unwrap_or_else(|p| std::panic::resume_unwind(p)));
            (written, simulated)
        });
        written?;
        pending = simulated;
    }
    Ok(BenchRun {
        sample_rate_hz: fs,
        frf: NonlinearFrf {
            response: def.test.response.quantity(),
            reference: if def.test.force_gauge {
                Quantity::Force
            } else {
                reference_quantity(&model)
            },
            max_harmonic: def.test.max_harmonic,
            levels: frf_levels,
        },
        dwells,
        frames,
    })
}

fn channel(r: &Response, q: Quantity) -> &[f64] {
    match q {
        Quantity::Displacement => &r.displacement,
        Quantity::Velocity => &r.velocity,
        _ => &r.acceleration,
    }
}

fn rms(x: &[f64]) -> f64 {
    (x.iter().map(|v| v * v).sum::<f64>() / x.len().max(1) as f64).sqrt()
}

/// One level: a continuous simulation from rest through every dwell.
fn run_level(
    def: &TestDefinition,
    model: &Model,
    fs: f64,
    sweeps: &[(Direction, Vec<f64>)],
    level_index: usize,
    level: f64,
    observer: &dyn Observer,
) -> Result<LevelOutput> {
    let t = &def.test;
    // the simulator runs `os` times faster than the recording; every os-th
    // sample is recorded (an exact sampling of the simulated response), so
    // the method's own error stays ~1e-4 without larger files
    let os = def.oversample()?;
    let mut sim = Simulator::new(&model.linear, model.element_set()?, fs * os as f64)?;
    let mut fine = Response::default();
    let mut rng = ChaCha8Rng::seed_from_u64(t.seed);
    // an independent stream per level: the same bytes whatever the threads
    rng.set_stream(level_index as u64);
    // the gauge's noise has streams of its own, so that the other channels
    // are the same with a gauge as without
    let mut gauge_rng = ChaCha8Rng::seed_from_u64(t.seed);
    gauge_rng.set_stream((1 << 32) + level_index as u64);
    let mut analyser = HarmonicAnalyser::new();
    let response_q = t.response.quantity();
    let mut out = LevelOutput {
        level_index,
        ..Default::default()
    };
    let mut phase = 0.0f64;
    let mut clean = Response::default();
    let mut force = Vec::new();
    let mut gauge = Vec::new();
    for (direction, freqs) in sweeps {
        for &f_req in freqs {
            let d = design_dwell(f_req, fs, t.frequency_tolerance);
            let frequency_hz = d.frequency_hz;
            let (l, q) = (d.block_len, d.periods_per_block);
            clean.clear();
            force.clear();
            let block = |sim: &mut Simulator<_>,
                         force: &mut Vec<f64>,
                         clean: &mut Response,
                         fine: &mut Response|
             -> Result<()> {
                let n = l * os;
                fine.clear();
                sim.run_generator(
                    n,
                    |i| level * (phase + 2.0 * PI * (q * i) as f64 / n as f64).cos(),
                    fine,
                )?;
                for i in (0..n).step_by(os) {
                    force.push(level * (phase + 2.0 * PI * (q * i) as f64 / n as f64).cos());
                    clean.displacement.push(fine.displacement[i]);
                    clean.velocity.push(fine.velocity[i]);
                    clean.acceleration.push(fine.acceleration[i]);
                    clean.element_force.push(fine.element_force[i]);
                    clean.drive_force.push(fine.drive_force[i]);
                }
                Ok(())
            };
            // settle: blocks of q periods until consecutive harmonics agree
            let max_blocks = t.max_settle_periods.div_ceil(q).max(2);
            let mut previous: Option<Vec<Complex64>> = None;
            let mut settled = false;
            let mut settle_blocks = 0;
            while settle_blocks < max_blocks {
                block(&mut sim, &mut force, &mut clean, &mut fine)?;
                settle_blocks += 1;
                let y = channel(&clean, response_q);
                let h = analyser.harmonics(&y[y.len() - l..], l, q, t.max_harmonic)?;
                if let Some(p) = &previous
                    && harmonics_agree(p, &h, t.settle_tolerance)
                {
                    settled = true;
                    break;
                }
                previous = Some(h);
            }
            // measure whole blocks
            // at least 8 blocks: the standard errors come from their scatter,
            // and from 2 or 3 blocks they can be off by a factor of 10
            let blocks = t.measure_periods.div_ceil(q).max(MIN_BLOCKS);
            for _ in 0..blocks {
                block(&mut sim, &mut force, &mut clean, &mut fine)?;
            }
            let settle = settle_blocks * l;
            let n = force.len();
            // noise at a fraction of each channel's clean RMS over the measured window
            let mut noisy: [Vec<f64>; 4] = [
                force.clone(),
                clean.displacement.clone(),
                clean.velocity.clone(),
                clean.acceleration.clone(),
            ];
            let fractions = [t.force_noise, t.noise, t.noise, t.noise];
            let add_noise = |sig: &mut [f64], frac: f64, rng: &mut ChaCha8Rng| {
                let sigma = frac * rms(&sig[settle..]);
                if sigma > 0.0 {
                    for v in sig.iter_mut() {
                        let z: f64 = StandardNormal.sample(rng);
                        *v += sigma * z;
                    }
                }
            };
            for (sig, frac) in noisy.iter_mut().zip(fractions) {
                add_noise(sig, frac, &mut rng);
            }
            // with a gauge, the bench's reference is the force it reads
            gauge.clear();
            if t.force_gauge {
                gauge.extend_from_slice(&clean.drive_force);
                add_noise(&mut gauge, t.force_noise, &mut gauge_rng);
            }
            let reference = if t.force_gauge { &gauge } else { &noisy[0] };
            let ri = match response_q {
                Quantity::Displacement => 1,
                Quantity::Velocity => 2,
                _ => 3,
            };
            let measured = analyser
                .coherent(
                    &reference[settle..],
                    &noisy[ri][settle..],
                    l,
                    q,
                    t.max_harmonic,
                )
                .map_err(|e| {
                    Error::input(
                        format!("dwell at {:.4} Hz, level {level} N", d.frequency_hz),
                        e.to_string(),
                    )
                })?;
            let clean_receptance = analyser
                .coherent(
                    &force[settle..],
                    &clean.displacement[settle..],
                    l,
                    q,
                    t.max_harmonic,
                )?
                .h;
            let clean_y = channel(&clean, response_q);
            let clean_h = analyser
                .coherent(&force[settle..], &clean_y[settle..], l, q, t.max_harmonic)?
                .h;
            let noise: Vec<f64> = noisy[ri][settle..]
                .iter()
                .zip(&clean_y[settle..])
                .map(|(a, b)| a - b)
                .collect();
            let noise_ratio = rms(&noise) / rms(&clean_y[settle..]).max(f64::MIN_POSITIVE);
            out.dwells.push(DwellRecord {
                index: 0,
                level_index,
                level,
                direction: *direction,
                design: d,
                start: out.force.len() as u64,
                settle,
                length: n,
                settle_periods: settle_blocks * q,
                settled,
                measured,
                clean_h,
                clean_receptance,
                noise_ratio,
                subharmonic: crate::extract::subharmonic(
                    &noisy[ri][settle..],
                    fs,
                    frequency_hz,
                    t.max_harmonic,
                    blocks,
                ),
            });
            for (dst, src) in [
                &mut out.force,
                &mut out.displacement,
                &mut out.velocity,
                &mut out.acceleration,
            ]
            .into_iter()
            .zip(&noisy)
            {
                dst.extend(src.iter().map(|&v| v as f32));
            }
            out.gauge.extend(gauge.iter().map(|&v| v as f32));
            // the next dwell starts where this one's phase left off (each
            // block is whole periods, so the phase is back where it started)
            phase = phase.rem_euclid(2.0 * PI);
            observer.observe(Event::Dwell {
                level_index,
                frequency_hz,
            });
            if observer.cancelled() {
                return Err(Error::Cancelled);
            }
        }
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn dwell_design_is_coherent_and_close() {
        for f in [100.0, 123.456, 250.0, 349.99] {
            let d = design_dwell(f, 30000.0, 2e-4);
            assert!((d.frequency_hz / f - 1.0).abs() <= 2e-4);
            let periods = d.frequency_hz * d.block_len as f64 / 30000.0;
            assert!((periods - d.periods_per_block as f64).abs() < 1e-9);
        }
        assert_eq!(design_dwell(250.0, 30000.0, 2e-4).periods_per_block, 1);
    }
}
