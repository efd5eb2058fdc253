//! A model's replay of the recordings reduced as the measurement was, for FRFs
//! to compare with the measured ones.

use super::load::{
    ChannelChoice, HeldRecording, Keep, LOAD_STRETCH, Loaded, load_held_reference_and_response,
    load_reference_and_response,
};
use super::reduce::{
    Compensation, Reduced, ReductionOptions, SineTest, SweptReading, combine_recordings,
    excitation_of, reduce, reduce_path_streamed, stepped_options,
};
use crate::error::{Error, Result};
use crate::extract::{NonlinearFrf, ReduceOptions, reduce_stepped_by_dwell};
use crate::observe::Silent;
use crate::record::{Recording, RecordingMeta};
use crate::signals::{SamplesBuilder, SamplesView};
use std::path::PathBuf;

/// Recordings held with the reduction each was given, so that a model's
/// replay of each is reduced exactly as the measured response was: the same
/// reduction of the same reference (the same windows, the same frequencies)
/// and the same sweep compensation, the automatic one resolved once on the
/// measured response. The difference of the two FRF sets is a time-domain
/// residual in the plane the FRFs live in
/// ([`crate::diagnose::time_residual`]).
///
/// What it holds does not grow with the recordings' length where their
/// dwells are stated in order: the measured response is reduced from the
/// file a dwell at a time ([`reduce_path`]), the reference and response are
/// held as the file stored them (a long channel in a scratch file, see
/// [`SAMPLES_HELD_IN_MEMORY`]) until the time records take them, and a model's replay
/// is reduced a dwell at a time as it is made
/// ([`ReplayReduction::replayed_as_made`]).
pub struct ReplayReduction {
    sources: Vec<ReplaySource>,
    measured: NonlinearFrf,
}

/// One recording of a [`ReplayReduction`].
struct ReplaySource {
    path: PathBuf,
    /// Trimmed to the channels held (the reference and the response).
    meta: RecordingMeta,
    response: usize,
    truncated: bool,
    /// The reduction, its excitation and sweep compensation settled.
    options: ReductionOptions,
    /// The channels of `meta`, until the time records take them.
    held: Option<Vec<crate::signals::Samples>>,
}

impl HeldRecording {
    /// `loaded`'s reference and response held as [`load_held_reference_and_response`]
    /// holds them.
    pub fn of_loaded(loaded: Loaded) -> Result<HeldRecording> {
        let loaded = loaded.with_only_reference_and_response();
        let Recording { meta, channels } = loaded.recording;
        let channels = channels
            .into_iter()
            .zip(&meta.channels)
            .map(|(values, channel)| {
                let mut b = SamplesBuilder::for_channel(values.len(), channel.scale);
                for x in values.chunks(LOAD_STRETCH) {
                    b.extend(x)?;
                }
                b.finish()
            })
            .collect::<Result<_>>()?;
        Ok(HeldRecording {
            meta,
            channels,
            response: loaded.response,
            truncated: loaded.truncated,
        })
    }
}

impl ReplayReduction {
    /// Reduces each recording and holds its reference and response: from
    /// the file a dwell at a time where [`reduce_path`] can (stated dwells,
    /// a long sweep), else loaded whole.
    pub fn new(
        recordings: &[PathBuf],
        choice: ChannelChoice,
        reduction: &ReductionOptions,
    ) -> Result<ReplayReduction> {
        let mut reduced = Vec::with_capacity(recordings.len());
        for path in recordings {
            let at = |e| Error::context(format!("reducing {}", path.display()), e);
            let one = match reduce_path_streamed(path, choice, reduction, &crate::observe::Silent)
                .map_err(at)?
            {
                Some(red) => (
                    red,
                    load_held_reference_and_response(path, choice).map_err(at)?,
                ),
                None => {
                    let loaded = load_reference_and_response(path, choice).map_err(at)?;
                    let red = reduce(&loaded, reduction, &Silent).map_err(at)?;
                    (red, HeldRecording::of_loaded(loaded)?)
                }
            };
            reduced.push((path.clone(), one));
        }
        ReplayReduction::of_reduced(reduced, reduction)
    }

    /// [`ReplayReduction::new`] of recordings already loaded (from a
    /// library's arrays), each with the name its time record takes.
    pub fn from_loaded(
        recordings: Vec<(PathBuf, Loaded)>,
        reduction: &ReductionOptions,
    ) -> Result<ReplayReduction> {
        let mut reduced = Vec::with_capacity(recordings.len());
        for (path, loaded) in recordings {
            let at = |e| Error::context(format!("reducing {}", path.display()), e);
            let red = reduce(&loaded, reduction, &Silent).map_err(at)?;
            reduced.push((path, (red, HeldRecording::of_loaded(loaded)?)));
        }
        ReplayReduction::of_reduced(reduced, reduction)
    }

    fn of_reduced(
        recordings: Vec<(PathBuf, (Reduced, HeldRecording))>,
        reduction: &ReductionOptions,
    ) -> Result<ReplayReduction> {
        let mut sources = Vec::with_capacity(recordings.len());
        let mut sets = Vec::with_capacity(recordings.len());
        for (path, (red, held)) in recordings {
            let options = ReductionOptions {
                excitation: Some(red.excitation),
                compensation: match red.sweep {
                    Some(SweptReading {
                        compensation_s: Some(s),
                        ..
                    }) => Compensation::Seconds(s),
                    Some(_) => Compensation::Off,
                    None => reduction.compensation,
                },
                // a replay is read at the measured recording's hop
                hop_periods: red.sweep.map_or(reduction.hop_periods, |s| s.hop_periods),
                ..reduction.clone()
            };
            sets.push((path.clone(), red.frf));
            sources.push(ReplaySource {
                path,
                meta: held.meta,
                response: held.response,
                truncated: held.truncated,
                options,
                held: Some(held.channels),
            });
        }
        Ok(ReplayReduction {
            measured: combine_recordings(&sets)?,
            sources,
        })
    }

    /// The measured FRFs, as [`reduce_recordings`] combines them.
    pub fn measured(&self) -> &NonlinearFrf {
        &self.measured
    }

    /// The held recordings as the time-domain fit takes them (as
    /// [`super::time_records`] reads them, without reading them again). The
    /// samples move to the records (a long recording's channels are the
    /// largest thing a time-domain diagnosis holds): the replays' reduction
    /// takes the references from them ([`ReplayReduction::replayed`]). Once
    /// only: a second call errors.
    pub fn take_time_records(
        &mut self,
        band_hz: Option<(f64, f64)>,
    ) -> Result<Vec<crate::fit::TimeRecord>> {
        self.sources
            .iter_mut()
            .map(|s| {
                let name = s.path.display().to_string();
                let Some(mut channels) = s.held.take() else {
                    return Err(Error::input(
                        format!("{name}: time records"),
                        "its samples were taken by an earlier call",
                    ));
                };
                let reference = s.meta.reference_channel().expect("checked when read");
                let measured = if s.response == reference {
                    channels[reference].clone()
                } else {
                    std::mem::replace(&mut channels[s.response], Vec::<f64>::new().into())
                };
                let reference_samples =
                    std::mem::replace(&mut channels[reference], Vec::<f64>::new().into());
                crate::fit::TimeRecord::from_channels(
                    &name,
                    &s.meta,
                    s.response,
                    (reference_samples, measured),
                    None,
                    band_hz,
                )
            })
            .collect()
    }

    /// Checks that `record` is source `s`'s time record.
    fn check_record(
        s: &ReplaySource,
        record: &crate::fit::TimeRecord,
        samples: usize,
    ) -> Result<()> {
        let frames = record.reference.len();
        if record.name != s.path.display().to_string() || samples != frames {
            return Err(Error::input(
                format!("{}: replay", s.path.display()),
                format!(
                    "{samples} samples for the {frames} frames of the time record {}",
                    record.name
                ),
            ));
        }
        Ok(())
    }

    /// The options source `s`'s replay is reduced with (its excitation
    /// settled when the measured recording was reduced: not searched for
    /// again), and whether its dwells are stated (then a replay is reduced
    /// a dwell at a time as it is made, whatever order they are stated in).
    fn replay_options(s: &ReplaySource) -> (ReductionOptions, bool) {
        let options = ReductionOptions {
            excitation: Some(excitation_of(&s.meta, s.options.excitation)),
            ..s.options.clone()
        };
        let steps = &s.meta.excitation.steps;
        let by_dwell = options.excitation == Some(SineTest::Stepped)
            && !steps.is_empty()
            && s.meta.channels.len() == 2
            && s.meta.reference_channel().is_some_and(|r| r != s.response);
        (options, by_dwell)
    }

    /// The FRFs of `responses` (one per recording, in order, every sample:
    /// a model's replay, or any response to those references) reduced as
    /// the measured ones were, each recording's reference taken from its
    /// time record in `records` (the same recordings, in order:
    /// [`ReplayReduction::take_time_records`] moved the samples there).
    pub fn replayed(
        &self,
        records: &[crate::fit::TimeRecord],
        responses: Vec<Vec<f64>>,
    ) -> Result<NonlinearFrf> {
        self.check_counts(records.len(), responses.len())?;
        let mut sets = Vec::with_capacity(responses.len());
        for ((s, record), response) in self.sources.iter().zip(records).zip(responses) {
            Self::check_record(s, record, response.len())?;
            sets.push((s.path.clone(), Self::reduce_whole(s, record, response)?));
        }
        combine_recordings(&sets)
    }

    /// [`ReplayReduction::replayed`] of `model`'s replays of `problem`'s
    /// records (these recordings, in order), each reduced a dwell at a time
    /// as it is made where its dwells are stated (no replay held whole: the
    /// same FRFs to the bit), else replayed whole and reduced.
    pub fn replayed_as_made(
        &self,
        problem: &crate::fit::time::TimeProblem,
        model: &crate::model::Model,
    ) -> Result<NonlinearFrf> {
        let records = problem.records();
        self.check_counts(records.len(), records.len())?;
        let mut sets = Vec::with_capacity(records.len());
        for (i, (s, record)) in self.sources.iter().zip(records).enumerate() {
            let at = |e| Error::context(format!("reducing the replay of {}", s.path.display()), e);
            let (options, by_dwell) = Self::replay_options(s);
            let frf = if by_dwell {
                Self::check_record(s, record, record.response.len())?;
                let reference = s.meta.reference_channel().expect("checked");
                let mut frames = crate::validate::ReplayBeside::new(
                    &s.meta,
                    (reference, s.response),
                    record.reference.view(),
                    problem.replay_of(model, i)?,
                    &crate::observe::Silent,
                )?;
                let stepped = ReduceOptions {
                    reference_channel: Some(reference),
                    ..stepped_options(&options)
                };
                reduce_stepped_by_dwell(&mut frames, s.response, &stepped, &Silent)
                    .map_err(at)?
                    .frf
            } else {
                let response = problem.replay(model, i)?;
                Self::check_record(s, record, response.len())?;
                Self::reduce_whole(s, record, response)?
            };
            sets.push((s.path.clone(), frf));
        }
        combine_recordings(&sets)
    }

    fn check_counts(&self, records: usize, responses: usize) -> Result<()> {
        for (what, n) in [("replays", responses), ("time records", records)] {
            if n != self.sources.len() {
                return Err(Error::input(
                    what,
                    format!("{n} given for {} recordings", self.sources.len()),
                ));
            }
        }
        Ok(())
    }

    /// Source `s`'s `response` reduced as its measured response was,
    /// beside the reference its time record `record` holds.
    fn reduce_whole(
        s: &ReplaySource,
        record: &crate::fit::TimeRecord,
        response: Vec<f64>,
    ) -> Result<NonlinearFrf> {
        let at = |e| Error::context(format!("reducing the replay of {}", s.path.display()), e);
        let (options, by_dwell) = Self::replay_options(s);
        let reference = s.meta.reference_channel();
        let frames = response.len();
        // a stepped sine whose steps are stated is read a dwell at a time
        // from the record's reference as it holds it and the response (no
        // copy of the reference; the same FRFs as reduced whole)
        if let (true, Some(reference)) = (by_dwell, reference) {
            let mut channels: Vec<SamplesView> = vec![SamplesView::Exact(&[]); 2];
            channels[reference] = record.reference.view();
            channels[s.response] = (&response).into();
            if channels.iter().all(|c| c.len() == frames) {
                let mut source = crate::signals::InMemoryFrames::of_channels(
                    &s.meta,
                    channels,
                    format!("the replay of {}", s.path.display()),
                );
                let stepped = ReduceOptions {
                    reference_channel: Some(reference),
                    ..stepped_options(&options)
                };
                let red = reduce_stepped_by_dwell(&mut source, s.response, &stepped, &Silent)
                    .map_err(at)?;
                return Ok(red.frf);
            }
        }
        // the response taken over, the reference copied from the record
        let mut response = Some(response);
        let replay = Loaded {
            recording: Recording {
                meta: s.meta.clone(),
                channels: (0..s.meta.channels.len())
                    .map(|c| {
                        if c == s.response {
                            response.take().unwrap_or_default()
                        } else if Some(c) == reference {
                            record.reference.values().into_owned()
                        } else {
                            Vec::new()
                        }
                    })
                    .collect(),
            },
            response: s.response,
            truth: None,
            truncated: s.truncated,
        };
        Ok(reduce(&replay, &options, &Silent).map_err(at)?.frf)
    }
}

/// Keeps the points inside `band` (all when `None`), dropping emptied levels.
pub fn band_limited(frf: &NonlinearFrf, band: Option<(f64, f64)>) -> NonlinearFrf {
    let mut out = frf.clone();
    if let Some((lo, hi)) = band {
        for l in &mut out.levels {
            l.points
                .retain(|p| p.frequency_hz >= lo && p.frequency_hz <= hi);
        }
        out.levels.retain(|l| !l.points.is_empty());
    }
    out
}
