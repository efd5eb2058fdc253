//! Stepped-sine reduction of a recording: dwells → FRF points → levels.
//!
//! With `excitation.steps` in the recording, each dwell after its `settle`
//! samples is reduced by the non-coherent least-squares fit at the stated
//! frequency (refined from the reference channel when the stated value is
//! off). Without steps, the dwells are found from the reference channel
//! ([`find_dwells_whole`]). The reference is first divided by its local RMS,
//! so that the Hilbert transform's non-local tails (and the FFT's wrap of
//! the record's end onto its start) cannot bury a weak level under a strong
//! one; its phase is then cut into windows of whole periods, each with a
//! least-squares frequency and an amplitude and their standard errors. A
//! window joins the running dwell while both agree with the dwell's mean
//! within the tolerances or within 5 standard errors, whichever is wider, so
//! force noise and PCM quantisation do not split a dwell; neighbouring runs
//! of the same frequency and amplitude across a gap too short to be a dwell
//! are merged (a noisy window does not cut a dwell in two). The first and
//! last window of each dwell are dropped (either may hold the switch), the
//! level's settling at the start of a dwell (force amplitude ramping in) is
//! not taken for a dwell of its own, and the transient at the start of each
//! dwell is skipped by a settling test on consecutive blocks of whole
//! periods (how long a real structure rings is not known in advance; see
//! [`settling`]) run on the reference and then on the response. The points are
//! grouped into levels by nominal level, in measurement order, and split where
//! the frequency order reverses, which sets each level's [`Direction`]. Found
//! dwells have no nominal level: their measured reference amplitudes are
//! clustered (`level_tolerance`, 5 %), so a test whose force amplitude is not
//! controlled (force drop-out at resonance) should state its steps or widen
//! the tolerance.

use super::estimator::check_finite;
use super::noncoherent::{
    estimate_frequency_named, noncoherent_named, phase_slope_frequency, whole_periods,
};
use super::{Direction, FrfLevel, FrfPoint, NonlinearFrf};
use crate::error::{Error, Result};
use crate::harmonics::Quantity;
use crate::observe::{Observer, Silent};
use crate::signals::{Recording, Step};
use serde::{Deserialize, Serialize};

mod dwells;
mod settling;

use dwells::same_level;

pub(super) use dwells::{WindowTracker, dwells_of_windows};
pub use dwells::{below_resolution, find_dwells_whole};
#[cfg(test)]
pub(super) use dwells::{normalise, track};
pub(super) use settling::check_rate;
pub use settling::{Settling, settling};

/// How dwells are found and when a dwell counts as settled.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct DwellOptions {
    /// Tracking window, in periods of the reference's own phase.
    pub window_periods: usize,
    /// Windows whose frequency differs from the running dwell mean by more
    /// than this (relative) or 5 standard errors, whichever is wider, start a
    /// new dwell. Both must be below the smallest relative frequency step.
    pub frequency_tolerance: f64,
    /// Same for the reference amplitude (relative).
    pub amplitude_tolerance: f64,
    /// Shortest usable dwell after settling, in periods.
    pub min_dwell_periods: usize,
    /// Block length of the settling test, in periods.
    pub settle_block_periods: usize,
    /// The settling test's tolerance, relative to the fundamental: a dwell is
    /// settled from the first block from which every block's harmonics agree
    /// with the dwell's settled state within it (or within the noise; see
    /// [`settling`]). The default 1e-3 suits real structures, whose FRFs
    /// drift slowly (the UNESP beam's |H1| moves 0.5 % over 40 s); a
    /// noise-free virtual test can ask for 1e-6.
    pub settle_tolerance: f64,
    /// Highest harmonic compared by the settling test.
    pub settle_max_harmonic: usize,
    /// Dwell amplitudes within this relative distance of each other form one
    /// level (found dwells; [`combine`] uses it to merge levels too).
    pub level_tolerance: f64,
}

impl Default for DwellOptions {
    fn default() -> Self {
        DwellOptions {
            window_periods: 4,
            frequency_tolerance: 2e-4,
            amplitude_tolerance: 0.02,
            min_dwell_periods: 16,
            settle_block_periods: 2,
            settle_tolerance: 1e-3,
            settle_max_harmonic: 3,
            level_tolerance: 0.05,
        }
    }
}

/// Options of [`reduce_stepped`].
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct ReduceOptions {
    /// Highest harmonic `K`.
    pub max_harmonic: usize,
    /// Blocks per dwell for the H1 estimator and its standard error (fewer
    /// when a dwell holds fewer whole periods, at least 2).
    pub blocks: usize,
    /// The stated frequency of a step is replaced by the one estimated from
    /// the reference when they differ by more than this (relative).
    pub frequency_tolerance: f64,
    /// The reference channel; default [`Recording::reference_channel`].
    pub reference_channel: Option<usize>,
    /// Dwell finding and settling.
    pub dwell: DwellOptions,
}

impl Default for ReduceOptions {
    fn default() -> Self {
        ReduceOptions {
            max_harmonic: 5,
            blocks: 8,
            frequency_tolerance: 1e-6,
            reference_channel: None,
            dwell: DwellOptions::default(),
        }
    }
}

/// What was done with one dwell.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct DwellReport {
    /// The dwell as analysed: `settle` covers every sample skipped.
    pub step: Step,
    /// The frequency stated by the recording's step (or by the dwell finder).
    pub stated_frequency_hz: f64,
    /// The frequency used: the stated one, or the estimate from the reference
    /// when they differed by more than the tolerance.
    pub frequency_hz: f64,
    /// Whether the frequency was replaced by the estimate.
    pub frequency_refined: bool,
    /// Index into `levels`, then into that level's `points`.
    pub level: usize,
    /// Index of the point within its level.
    pub point: usize,
}

/// The result of [`reduce_stepped_report`].
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct SteppedReduction {
    /// The FRFs.
    pub frf: NonlinearFrf,
    /// One report per dwell, in measurement order.
    pub dwells: Vec<DwellReport>,
    /// True when the dwells were found from the reference channel (the
    /// recording had no steps).
    pub dwells_found: bool,
}

/// Groups points (with their nominal level) into levels in measurement
/// order: a new level starts where the nominal level changes or where the
/// frequency order reverses. Returns the levels and, per input point, its
/// `(level, point)` index.
pub(super) fn group_levels(points: Vec<(f64, FrfPoint)>) -> (Vec<FrfLevel>, Vec<(usize, usize)>) {
    let mut levels: Vec<FrfLevel> = Vec::new();
    let mut dir: Option<Direction> = None;
    let mut index = Vec::with_capacity(points.len());
    for (level, p) in points {
        let joins = match levels.last() {
            Some(l) if same_level(l.level, level) => {
                let last = l.points.last().expect("non-empty").frequency_hz;
                let step = if p.frequency_hz > last {
                    Some(Direction::Up)
                } else if p.frequency_hz < last {
                    Some(Direction::Down)
                } else {
                    None
                };
                match (dir, step) {
                    (None, s) => {
                        if s.is_some() {
                            dir = s;
                        }
                        true
                    }
                    (Some(d), Some(s)) => d == s,
                    (Some(_), None) => false,
                }
            }
            _ => false,
        };
        if !joins {
            if let (Some(l), Some(d)) = (levels.last_mut(), dir) {
                l.direction = d;
            }
            levels.push(FrfLevel {
                level,
                direction: Direction::Up,
                points: Vec::new(),
            });
            dir = None;
        }
        let li = levels.len() - 1;
        let l = &mut levels[li];
        index.push((li, l.points.len()));
        l.points.push(p);
    }
    if let (Some(l), Some(d)) = (levels.last_mut(), dir) {
        l.direction = d;
    }
    (levels, index)
}

/// Reduces a stepped-sine recording into nonlinear FRFs of one response
/// channel (see [`reduce_stepped_report`]).
pub fn reduce_stepped(
    rec: &Recording,
    response_channel: usize,
    options: &ReduceOptions,
) -> Result<NonlinearFrf> {
    reduce_stepped_report(rec, response_channel, options, &Silent).map(|r| r.frf)
}

/// Reduces a stepped-sine recording into nonlinear FRFs of one response
/// channel, with a report per dwell.
///
/// Dwells come from `meta.excitation.steps` when present (each analysed
/// after its `settle` samples; the stated frequency is checked against the
/// reference by the phase advance between the dwell's halves and replaced by
/// the least-squares estimate when they differ by more than
/// `frequency_tolerance`), otherwise from [`find_dwells_whole`], in which
/// case the [`settling`] test is also run on the response (the force of a
/// virtual test has no transient; the response has). Each dwell is reduced by
/// [`super::noncoherent`] with `blocks` blocks over its largest window of
/// whole periods. Points are grouped into levels in measurement order (a new
/// level where the nominal level changes or the frequency order reverses).
///
/// Errors name the channel or the step: no reference channel, a response
/// channel out of range or equal to the reference, a step outside the record,
/// a dwell too short for 2 blocks, a harmonic above Nyquist.
///
/// `observer` is told after each dwell (`reducing`, dwells done of all),
/// and the reduction stops there if it asks ([`Error::Cancelled`]).
pub fn reduce_stepped_report(
    rec: &Recording,
    response_channel: usize,
    options: &ReduceOptions,
    observer: &dyn Observer,
) -> Result<SteppedReduction> {
    reduce_stepped_as(rec, response_channel, options, observer, false)
}

/// [`reduce_stepped_report`]; `as_found`: the steps the recording states
/// were found in its reference (by [`super::find_dwells`]), and are
/// reduced as found ones are (the response's settling tested too).
pub(super) fn reduce_stepped_as(
    rec: &Recording,
    response_channel: usize,
    options: &ReduceOptions,
    observer: &dyn Observer,
    as_found: bool,
) -> Result<SteppedReduction> {
    let reference_channel = options
        .reference_channel
        .or_else(|| rec.reference_channel())
        .ok_or_else(|| {
            Error::input(
                "recording",
                "has no force or voltage channel to use as the reference",
            )
        })?;
    let nch = rec.channels.len().min(rec.meta.channels.len());
    for (what, c) in [
        ("reference", reference_channel),
        ("response", response_channel),
    ] {
        if c >= nch {
            return Err(Error::input(
                format!("{what} channel {c}"),
                format!("out of range: the recording has {nch} channels"),
            ));
        }
    }
    if response_channel == reference_channel {
        return Err(Error::input(
            format!("response channel {response_channel}"),
            "is the reference channel",
        ));
    }
    let fs = rec.meta.sample_rate_hz;
    check_rate(fs)?;
    let reference = &rec.channels[reference_channel];
    let response = &rec.channels[response_channel];
    let ref_name = &rec.meta.channels[reference_channel].name;
    let resp_name = &rec.meta.channels[response_channel].name;
    if reference.len() != response.len() {
        return Err(Error::input(
            format!("channel `{resp_name}`"),
            format!(
                "has {} frames but the reference `{ref_name}` has {}",
                response.len(),
                reference.len()
            ),
        ));
    }
    let ref_quantity = rec.meta.channels[reference_channel].quantity;
    if !matches!(ref_quantity, Quantity::Force | Quantity::Voltage) {
        return Err(Error::input(
            format!("reference channel `{ref_name}`"),
            format!("is a {ref_quantity} channel; a force or voltage is expected"),
        ));
    }
    check_finite(reference, &format!("channel `{ref_name}`"))?;
    check_finite(response, &format!("channel `{resp_name}`"))?;
    let frames = reference.len();
    let dwells_found = as_found || rec.meta.excitation.steps.is_empty();
    let steps = if rec.meta.excitation.steps.is_empty() {
        find_dwells_whole(reference, fs, &options.dwell)?
    } else {
        rec.meta.excitation.steps.clone()
    };
    let mut points = Vec::with_capacity(steps.len());
    let mut reports = Vec::with_capacity(steps.len());
    for (i, step) in steps.iter().enumerate() {
        let what = format!("step {i} ({} Hz)", step.frequency_hz);
        let end = step.start.saturating_add(step.length);
        if end > frames || step.settle >= step.length {
            return Err(Error::input(
                format!("excitation.steps[{i}]"),
                format!(
                    "start {} + length {} (settle {}) must lie within the {frames} frames and \
                     settle must be shorter than the length",
                    step.start, step.length, step.settle
                ),
            ));
        }
        if !(step.frequency_hz.is_finite() && step.frequency_hz > 0.0) {
            return Err(Error::input(
                format!("excitation.steps[{i}].frequency_hz"),
                format!("must be finite and > 0, got {}", step.frequency_hz),
            ));
        }
        let mut start = step.start + step.settle;
        let mut settled = true;
        let stated = step.frequency_hz;
        let mut f = stated;
        if dwells_found {
            let s = settling(
                &reference[start..end],
                Some(&response[start..end]),
                fs,
                f,
                &options.dwell,
            )?;
            settled = s.settled;
            if s.settled {
                start += s.settle;
            } else {
                // never settled: use the later half, and say so
                start += (end - start) / 2;
            }
        }
        let mut refined = false;
        let check = phase_slope_frequency(&reference[start..end], fs, f);
        if check.is_none_or(|fc| (fc - f).abs() > options.frequency_tolerance * f) {
            f = estimate_frequency_named(&reference[start..end], fs, &what)?;
            refined = (f - stated).abs() > options.frequency_tolerance * stated;
            if !refined {
                f = stated;
            }
        }
        let periods = whole_periods(end - start, fs, f);
        let blocks = options.blocks.min(periods).max(2);
        let d = noncoherent_named(
            &reference[start..end],
            &response[start..end],
            fs,
            f,
            options.max_harmonic,
            blocks,
            &what,
        )?;
        let f1 = d.force[1];
        let settle = start - step.start;
        // a response within a few steps of an integer converter is not a
        // signal plus noise: its quantisation error follows the signal, so
        // the block scatter says nothing of it. Its standard error is unknown
        // (NaN), which leaves the point out of any fit.
        let std_error = if below_resolution(&response[start..end]) {
            vec![f64::NAN; d.std_error.len()]
        } else {
            d.std_error
        };
        points.push((
            step.level,
            FrfPoint {
                frequency_hz: f,
                force_amplitude: f1.norm(),
                h: d.h,
                std_error,
                force_distortion: d
                    .force
                    .iter()
                    .enumerate()
                    .map(|(k, fk)| crate::harmonics::referred_to_force(*fk, k, f1) / f1)
                    .collect(),
                blocks: d.blocks,
                settle_periods: (settle as f64 * f / fs).round() as usize,
                settled,
                subharmonic: super::subharmonic(
                    &response[start..end],
                    fs,
                    f,
                    options.max_harmonic,
                    options.blocks,
                ),
            },
        ));
        reports.push(DwellReport {
            step: Step {
                frequency_hz: f,
                level: step.level,
                start: step.start,
                settle,
                length: step.length,
            },
            stated_frequency_hz: stated,
            frequency_hz: f,
            frequency_refined: refined,
            level: 0,
            point: 0,
        });
        crate::observe::progress(observer, "reducing", i as u64 + 1, steps.len() as u64)?;
    }
    let (levels, index) = group_levels(points);
    for (r, (l, p)) in reports.iter_mut().zip(index) {
        r.level = l;
        r.point = p;
    }
    Ok(SteppedReduction {
        frf: NonlinearFrf {
            response: rec.meta.channels[response_channel].quantity,
            reference: ref_quantity,
            max_harmonic: options.max_harmonic,
            levels,
        },
        dwells: reports,
        dwells_found,
    })
}

/// Combines FRF sets (e.g. several single-sine recordings, one dwell each)
/// into one: levels within the default 5 % of each other are merged (see
/// [`combine_with`]).
pub fn combine(frfs: &[NonlinearFrf]) -> Result<NonlinearFrf> {
    combine_with(frfs, DwellOptions::default().level_tolerance)
}

/// Combines FRF sets into one.
///
/// All sets must have the same response and reference quantities and the
/// same `max_harmonic`. Levels of the same [`Direction`] whose nominal levels
/// lie within `level_tolerance` (relative, chained in ascending order) are
/// merged into one level at their mean nominal level; the merged points are
/// sorted by frequency (ascending for [`Direction::Up`], descending for
/// [`Direction::Down`], the order of a measurement in that direction).
/// Levels are returned in ascending nominal level, `Up` before `Down`.
pub fn combine_with(frfs: &[NonlinearFrf], level_tolerance: f64) -> Result<NonlinearFrf> {
    let first = frfs
        .first()
        .ok_or_else(|| Error::input("frfs", "nothing to combine: the list is empty"))?;
    for (i, f) in frfs.iter().enumerate() {
        if f.response != first.response
            || f.reference != first.reference
            || f.max_harmonic != first.max_harmonic
        {
            return Err(Error::input(
                format!("frfs[{i}]"),
                format!(
                    "is {}/{} up to harmonic {} but frfs[0] is {}/{} up to harmonic {}: only FRFs \
                     of the same quantities and harmonics combine",
                    f.response,
                    f.reference,
                    f.max_harmonic,
                    first.response,
                    first.reference,
                    first.max_harmonic
                ),
            ));
        }
    }
    let mut out = Vec::new();
    for dir in [Direction::Up, Direction::Down] {
        let mut levels: Vec<&FrfLevel> = frfs
            .iter()
            .flat_map(|f| &f.levels)
            .filter(|l| l.direction == dir)
            .collect();
        levels.sort_by(|a, b| a.level.total_cmp(&b.level));
        let mut groups: Vec<Vec<&FrfLevel>> = Vec::new();
        for l in levels {
            match groups.last_mut() {
                Some(g)
                    if (l.level - g.last().expect("non-empty").level).abs()
                        <= level_tolerance * l.level.abs() =>
                {
                    g.push(l)
                }
                _ => groups.push(vec![l]),
            }
        }
        for g in groups {
            let level = g.iter().map(|l| l.level).sum::<f64>() / g.len() as f64;
            let mut points: Vec<FrfPoint> = g.iter().flat_map(|l| l.points.clone()).collect();
            points.sort_by(|a, b| a.frequency_hz.total_cmp(&b.frequency_hz));
            if dir == Direction::Down {
                points.reverse();
            }
            out.push(FrfLevel {
                level,
                direction: dir,
                points,
            });
        }
    }
    out.sort_by(|a, b| a.level.total_cmp(&b.level));
    Ok(NonlinearFrf {
        response: first.response,
        reference: first.reference,
        max_harmonic: first.max_harmonic,
        levels: out,
    })
}
