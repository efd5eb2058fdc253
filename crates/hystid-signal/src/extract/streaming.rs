//! Stepped-sine reduction of a recording read one dwell at a time.
//!
//! [`reduce_stepped`](super::reduce_stepped) needs the whole recording in
//! memory; a long test (a gigabyte of WAV) need not be. Each dwell is read
//! on its own from a [`FrameSource`] (a file reader, e.g.
//! `record::RecordingReader`), reduced exactly as the in-memory path
//! reduces it (same settle, frequency check, blocks and phase origin: the
//! dwell's first analysed sample), and the points are grouped into levels
//! the same way. The dwells are the recording's stated steps, or, where it
//! states none, found in its reference a stretch at a time
//! ([`super::find_dwells`]). The dwells are read forwards, in the
//! order they start, whatever order they are stated in (a replay made as
//! it is read can only go forwards), and reported in the stated order.
//! Memory is the largest dwell's samples and the dwell search's blocks,
//! whatever the file size.

use super::stepped::{group_levels, reduce_stepped_as};
use super::{NonlinearFrf, ReduceOptions, SteppedReduction};
use crate::error::{Error, Result};
use crate::observe::{Observer, Silent};
use crate::signals::{FrameSource, Recording, Step};

/// Reduces the stepped-sine recording `source` into nonlinear FRFs of
/// channel `response_channel`, reading one dwell at a time (see the module
/// docs). The result equals [`super::reduce_stepped_report`] on the whole
/// recording where it states its steps; where it does not, the dwells are
/// found a stretch at a time, as [`super::find_dwells_whole`] finds them in
/// the whole reference to within their windows (see
/// [`super::find_dwells`]).
///
/// `observer` is told how it progresses (the dwell search's
/// [`super::dwell_blocks::FINDING`] where it finds them, then `reducing`
/// after each dwell), and the reduction stops where it asks
/// ([`Error::Cancelled`]).
///
/// Errors: those of [`FrameSource::read_at`], of the dwell search and of the
/// reduction.
pub fn reduce_stepped_by_dwell(
    source: &mut impl FrameSource,
    response_channel: usize,
    options: &ReduceOptions,
    observer: &dyn Observer,
) -> Result<SteppedReduction> {
    let mut meta = source.meta().clone();
    let reference = reference_of(&meta, options, &source.source_name())?;
    let nch = meta.channels.len();
    for (what, c) in [("reference", reference), ("response", response_channel)] {
        if c >= nch {
            return Err(Error::input(
                format!("{what} channel {c}"),
                format!("out of range: the recording has {nch} channels"),
            ));
        }
    }
    let dwells_found = meta.excitation.steps.is_empty();
    if dwells_found {
        if response_channel == reference {
            return Err(Error::input(
                format!("response channel {response_channel}"),
                "is the reference channel",
            ));
        }
        meta.excitation.steps = super::find_dwells(source, reference, &options.dwell, observer)?;
    }
    let frames = source.frames();
    let steps = &meta.excitation.steps;
    check_step_frames(steps, frames)?;
    // read forwards whatever order the steps are stated in (a replay made
    // as it is read can only go forwards), reported in the stated order
    let mut order: Vec<usize> = (0..steps.len()).collect();
    order.sort_by_key(|&i| steps[i].start);
    let mut buffers = vec![Vec::new(); nch];
    let mut reduced = vec![None; steps.len()];
    let pair_options = ReduceOptions {
        reference_channel: Some(0),
        ..options.clone()
    };
    for (done, i) in order.into_iter().enumerate() {
        crate::observe::progress(observer, "reducing", done as u64, steps.len() as u64)?;
        let step = &steps[i];
        let got = source.read_at(step.start, step.length, &mut buffers)?;
        if got != step.length {
            return Err(Error::input(
                format!("excitation.steps[{i}]"),
                format!("read {got} of its {} frames", step.length),
            ));
        }
        // the dwell alone, as a two-channel recording with one step at 0
        let mut m = meta.clone();
        m.channels = vec![
            meta.channels[reference].clone(),
            meta.channels[response_channel].clone(),
        ];
        m.excitation.steps = vec![Step { start: 0, ..*step }];
        let dwell = Recording {
            meta: m,
            channels: vec![
                std::mem::take(&mut buffers[reference]),
                std::mem::take(&mut buffers[response_channel]),
            ],
        };
        // errors name the step by its index in the whole recording
        let r = reduce_stepped_as(&dwell, 1, &pair_options, &Silent, dwells_found);
        let mut r = r.map_err(|e| match e {
            Error::InvalidInput { what, message } => Error::InvalidInput {
                what: what
                    .replacen("steps[0]", &format!("steps[{i}]"), 1)
                    .replacen("step 0 (", &format!("step {i} ("), 1),
                message,
            },
            other => other,
        })?;
        let mut channels = dwell.channels.into_iter();
        buffers[reference] = channels.next().unwrap_or_default();
        buffers[response_channel] = channels.next().unwrap_or_default();
        let mut report = r.dwells.remove(0);
        report.step.start = step.start;
        let point = r.frf.levels.remove(0).points.remove(0);
        reduced[i] = Some(((step.level, point), report));
    }
    crate::observe::progress(observer, "reducing", steps.len() as u64, steps.len() as u64)?;
    let (points, mut dwells): (Vec<_>, Vec<_>) = reduced.into_iter().flatten().unzip();
    let (levels, index) = group_levels(points);
    for (d, (l, p)) in dwells.iter_mut().zip(index) {
        d.level = l;
        d.point = p;
    }
    Ok(SteppedReduction {
        frf: NonlinearFrf {
            response: meta.channels[response_channel].quantity,
            reference: meta.channels[reference].quantity,
            max_harmonic: options.max_harmonic,
            levels,
        },
        dwells,
        dwells_found,
    })
}

/// The reference channel: as given, or the recording's force or voltage.
fn reference_of(
    meta: &crate::signals::RecordingMeta,
    options: &ReduceOptions,
    source_name: &str,
) -> Result<usize> {
    Ok(match options.reference_channel {
        Some(r) => r,
        None => {
            let probe = Recording {
                meta: meta.clone(),
                channels: Vec::new(),
            };
            probe.reference_channel().ok_or_else(|| {
                Error::input(
                    source_name,
                    "has no force or voltage channel to use as the reference",
                )
            })?
        }
    })
}

/// Every step lies inside the recording's `frames`.
fn check_step_frames(steps: &[Step], frames: usize) -> Result<()> {
    for (i, step) in steps.iter().enumerate() {
        let end = step.start.saturating_add(step.length);
        if end > frames {
            return Err(Error::input(
                format!("excitation.steps[{i}]"),
                format!(
                    "frames {}..{end} lie outside the recording's {frames} frames",
                    step.start
                ),
            ));
        }
    }
    Ok(())
}
