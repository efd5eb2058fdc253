//! Recordings reduced into nonlinear FRFs: stepped or swept sine, held or
//! streamed from the file, several combined.

use super::load::{
    ChannelChoice, Loaded, flat_reference, is_mcap, load_recording, recorded_truth,
    response_channel,
};
use crate::error::{Error, Result};
use crate::extract::{
    NonlinearFrf, ReduceOptions, SweepFit, SweepOptions, WHOLE_RECORD_FRAMES, choose_compensation,
    reduce_stepped_by_dwell, reduce_stepped_report, reduce_sweep, reduce_sweep_recording,
};
use crate::record::{ExcitationKind, FrameSource, Recording, RecordingMeta};
use crate::signals::RecordingView;
use crate::testbench::TestDefinition;
use std::path::{Path, PathBuf};

/// How a recording is reduced.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum SineTest {
    /// Dwells (stated or found).
    Stepped,
    /// A continuous sweep.
    Swept,
}

/// Swept sine: the sweep-distortion compensation.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Compensation {
    /// Chosen from the data ([`choose_compensation`]).
    Auto,
    /// None.
    Off,
    /// The Gaussian window's standard deviation, s (> 0).
    Seconds(f64),
}

/// As the command line writes it: `auto`, 0 (off) or seconds.
impl std::str::FromStr for Compensation {
    type Err = Error;
    fn from_str(text: &str) -> Result<Self> {
        let text = text.trim();
        if text == "auto" {
            return Ok(Compensation::Auto);
        }
        let s: f64 = text.parse().map_err(|e| {
            Error::option(
                "compensation",
                format!("expected auto, 0 or seconds, got `{text}`: {e}"),
            )
        })?;
        if !(s.is_finite() && s >= 0.0) {
            return Err(Error::option(
                "compensation",
                format!("must be auto or seconds >= 0, got {s}"),
            ));
        }
        Ok(if s > 0.0 {
            Compensation::Seconds(s)
        } else {
            Compensation::Off
        })
    }
}

/// How recordings are reduced into nonlinear FRFs.
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct ReductionOptions {
    /// The reduction; `None`: the recording's `excitation.kind` (stepped
    /// when not stated).
    pub excitation: Option<SineTest>,
    /// Highest harmonic; `None`: 7 for stepped sine, 3 for swept.
    pub max_harmonic: Option<usize>,
    /// Swept sine: the compensation.
    pub compensation: Compensation,
    /// Swept sine: hop between analysis windows, periods of the sweep.
    pub hop_periods: f64,
    /// Swept sine: analysis window, whole periods.
    pub window_periods: usize,
}

impl Default for ReductionOptions {
    fn default() -> Self {
        ReductionOptions {
            excitation: None,
            max_harmonic: None,
            compensation: Compensation::Auto,
            hop_periods: 1.0,
            window_periods: 4,
        }
    }
}

/// The reduction a recording gets: the option, else its `excitation.kind`
/// (stepped when not stated).
pub fn excitation_of(meta: &RecordingMeta, choice: Option<SineTest>) -> SineTest {
    choice.unwrap_or(match meta.excitation.kind {
        ExcitationKind::SweptSine => SineTest::Swept,
        _ => SineTest::Stepped,
    })
}

/// One recording reduced into nonlinear FRFs.
pub struct Reduced {
    /// The FRFs.
    pub frf: NonlinearFrf,
    /// The response channel's name.
    pub response_name: String,
    /// The recording's sample rate, Hz.
    pub sample_rate_hz: f64,
    /// How it was reduced.
    pub excitation: SineTest,
    /// Swept sine: the sweep found, the compensation and the hop used.
    pub sweep: Option<SweptReading>,
    /// The virtual test's definition, if recorded.
    pub truth: Option<TestDefinition>,
    /// Reduced from disk one dwell at a time (memory bounded).
    pub streamed: bool,
    /// An MCAP run file cut short: only its complete chunks were reduced.
    pub truncated: bool,
    /// The warnings and errors of the quality report `hystid import` wrote
    /// beside the recording, one line each ([`quality_notes`]).
    pub quality: Vec<String>,
}

/// The highest harmonic for a reduction.
pub fn max_harmonic(r: &ReductionOptions, e: SineTest) -> usize {
    r.max_harmonic.unwrap_or(match e {
        SineTest::Stepped => 7,
        SineTest::Swept => 3,
    })
}

/// Stepped-sine reduction options.
pub fn stepped_options(r: &ReductionOptions) -> ReduceOptions {
    ReduceOptions {
        max_harmonic: max_harmonic(r, SineTest::Stepped),
        blocks: 16,
        ..ReduceOptions::default()
    }
}

/// Sweep options for channels `reference` and `response` of `source`, the
/// compensation resolved ([`Compensation::Auto`]: [`choose_compensation`],
/// reading them a stretch at a time; held channels are handed over as
/// [`crate::signals::InMemoryFrames::pair`]).
pub fn sweep_options(
    source: &mut impl FrameSource,
    reference: usize,
    response: usize,
    r: &ReductionOptions,
) -> Result<SweepOptions> {
    let mut opts = SweepOptions {
        max_harmonic: max_harmonic(r, SineTest::Swept),
        window_periods: r.window_periods,
        hop_periods: r.hop_periods,
        ..SweepOptions::default()
    };
    opts.compensation_s = match r.compensation {
        Compensation::Auto => Some(choose_compensation(source, reference, response, &opts)?),
        Compensation::Off => None,
        Compensation::Seconds(s) => Some(s),
    };
    Ok(opts)
}

/// Fewest excited lines for a periodic record to count as a multisine (the
/// linear estimate's `m, c, k` need them; a single sine is periodic too).
pub const MULTISINE_LINES: usize = 3;

/// A recording that states no excitation, read as a periodic multisine:
/// its period (samples) and the excited lines (Hz, lowest and highest, and
/// how many), found in its first [`crate::extract::PERIOD_SEARCH`] frames; `None` where
/// its reference does not repeat with at least [`MULTISINE_LINES`]
/// excited lines (a stepped sine's repeats only within a dwell, at one
/// line).
pub(crate) fn multisine_period(
    rec: &RecordingView,
    response: usize,
) -> Option<(usize, f64, f64, usize)> {
    if !rec.meta.excitation.kind.may_be_multisine() || !rec.meta.excitation.steps.is_empty() {
        return None;
    }
    let reference = rec.meta.reference_channel()?;
    let (u, y) = (&rec.channels[reference], &rec.channels[response]);
    // unequal lengths are the reduction's to refuse, naming the channels
    let n = u.len().min(y.len()).min(crate::extract::PERIOD_SEARCH);
    let (u, y) = (u.range(0..n), y.range(0..n));
    let fs = rec.meta.sample_rate_hz;
    // the heads are in memory: reading them cannot fail
    let mut head =
        crate::signals::InMemoryFrames::pair((&u[..]).into(), (&y[..]).into(), fs).ok()?;
    let period = crate::extract::find_period(&mut head, 0).ok().flatten()?;
    let lines = crate::extract::periodic_frf(&mut head, 0, 1, period).ok()?;
    if lines.len() < MULTISINE_LINES {
        return None;
    }
    let (lo, hi) = lines.iter().fold((f64::INFINITY, 0.0f64), |(a, b), l| {
        (a.min(l.frequency_hz), b.max(l.frequency_hz))
    });
    Some((period, lo, hi, lines.len()))
}

/// An error when a recording is a periodic multisine
/// ([`multisine_period`]): a dwell search would cut it into meaningless
/// "dwells".
pub(crate) fn refuse_a_multisine(rec: &Recording, response: usize) -> Result<()> {
    let Some((period, lo, hi, lines)) = multisine_period(&rec.view(), response) else {
        return Ok(());
    };
    Err(Error::input(
        "recording",
        format!(
            "its reference is a multisine (a period of {period} samples repeated, {lines} excited \
             lines over {lo:.4}-{hi:.4} Hz), which nonlinear FRFs are not read from (they need \
             stepped or swept sines): fit it in the time domain (`identify --domain time`, \
             which starts from its linear FRF at the excited lines; `diagnose --domain time` \
             diagnoses it at the lines of its period), or state `--excitation \
             stepped` if it is one"
        ),
    ))
}

/// An error when a recording states a random excitation and no reduction
/// was chosen: a random drive has no harmonics to read nonlinear FRFs from.
pub(crate) fn refuse_a_random(meta: &RecordingMeta, r: &ReductionOptions) -> Result<()> {
    if meta.excitation.kind != ExcitationKind::Random || r.excitation.is_some() {
        return Ok(());
    }
    Err(Error::input(
        "recording",
        "its `excitation.kind` is `random`, which nonlinear FRFs are not read from (they need \
         stepped or swept sines): validate a model on it (`hystid validate`, which compares it \
         in the time domain and by H1), or state `--excitation stepped` or `swept` if it is one",
    ))
}

/// Nonlinear FRFs of a loaded recording, telling `observer` how it
/// progresses (`reducing`: a stepped sine's dwells; a swept sine's whole
/// reductions, three where the compensation is chosen from the data) and
/// stopping where it asks ([`Error::Cancelled`]).
pub fn reduce(
    loaded: &Loaded,
    r: &ReductionOptions,
    observer: &dyn crate::observe::Observer,
) -> Result<Reduced> {
    let rec = &loaded.recording;
    refuse_a_random(&rec.meta, r)?;
    let excitation = excitation_of(&rec.meta, r.excitation);
    let response_name = rec.meta.channels[loaded.response].name.clone();
    let fs = rec.meta.sample_rate_hz;
    let (frf, sweep) = match excitation {
        SineTest::Stepped => {
            if r.excitation.is_none() {
                refuse_a_multisine(rec, loaded.response)?;
            }
            (
                reduce_stepped_report(rec, loaded.response, &stepped_options(r), observer)?.frf,
                None,
            )
        }
        SineTest::Swept => {
            let reference = rec
                .reference_channel()
                .ok_or_else(|| Error::input("recording", "no reference channel"))?;
            let (total, report) = swept_stages(r, observer);
            report(0)?;
            let mut pair = crate::signals::InMemoryFrames::pair(
                (&rec.channels[reference]).into(),
                (&rec.channels[loaded.response]).into(),
                fs,
            )?;
            let opts = sweep_options(&mut pair, 0, 1, r)?;
            report(total - 1)?;
            let red = reduce_sweep_recording(rec, loaded.response, &opts)?;
            report(total)?;
            let reading = SweptReading {
                sweep: red.sweep,
                compensation_s: opts.compensation_s,
                hop_periods: red.hop_periods,
                hop_asked: opts.hop_periods,
            };
            let q = rec.meta.channels[loaded.response].quantity;
            let rq = rec.meta.channels[reference].quantity;
            (red.into_frf(q, rq), Some(reading))
        }
    };
    Ok(Reduced {
        frf,
        response_name,
        sample_rate_hz: fs,
        excitation,
        sweep,
        truth: loaded.truth.clone(),
        streamed: false,
        truncated: loaded.truncated,
        quality: Vec::new(),
    })
}

/// A swept reduction's stages, and how to tell `observer` that `done` of
/// them are (`reducing`): the automatic compensation is two reductions
/// more than the one kept.
fn swept_stages<'o>(
    r: &ReductionOptions,
    observer: &'o dyn crate::observe::Observer,
) -> (u64, impl Fn(u64) -> Result<()> + 'o) {
    let total = if r.compensation == Compensation::Auto {
        3
    } else {
        1
    };
    (total, move |done| {
        crate::observe::progress(observer, "reducing", done, total)
    })
}

/// How a swept-sine recording was read into FRF points.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SweptReading {
    /// The sweep found.
    pub sweep: SweepFit,
    /// The compensation's window, s (`None`: off).
    pub compensation_s: Option<f64>,
    /// The hop between windows, periods.
    pub hop_periods: f64,
    /// The hop asked (`hop_periods` is longer where the sweep holds more
    /// points than [`crate::extract::SweepOptions::max_points`]).
    pub hop_asked: f64,
}

/// Reduces the recording at `path`: a stepped-sine WAV + JSON recording
/// whose sidecar states its steps is reduced from disk one dwell at a time,
/// and a swept-sine one longer than [`WHOLE_RECORD_FRAMES`] a stretch at a
/// time (memory bounded whatever the file size); anything else is read
/// whole. `observer` is told how it progresses (a dwell search's
/// `finding dwells`; `reducing`: a stepped sine's dwells, a swept sine's
/// whole reductions), and the reduction stops where it asks
/// ([`Error::Cancelled`]).
pub fn reduce_path(
    path: &Path,
    choice: ChannelChoice,
    r: &ReductionOptions,
    observer: &dyn crate::observe::Observer,
) -> Result<Reduced> {
    if path
        .to_str()
        .is_some_and(|p| p.to_ascii_lowercase().ends_with(".quality.json"))
    {
        return Err(Error::input(
            path.display().to_string(),
            "this is the data-quality report `hystid import` writes beside a recording, not a recording (a glob such as `*.json` picks it up: name the recordings)",
        ));
    }
    let mut reduced = match reduce_path_streamed(path, choice, r, observer)? {
        Some(reduced) => reduced,
        None => reduce(&load_recording(path, choice)?, r, observer)?,
    };
    reduced.quality = quality_notes(path);
    Ok(reduced)
}

/// The quality report `hystid import` writes beside `path` (NAME.wav or
/// NAME.json: NAME.quality.json), if there is one.
fn quality_report_path(path: &Path) -> Option<PathBuf> {
    let ext = path.extension()?.to_str()?.to_ascii_lowercase();
    if ext != "wav" && ext != "json" {
        return None;
    }
    let mut s = path.with_extension("").into_os_string();
    s.push(".quality.json");
    Some(PathBuf::from(s))
}

/// The warnings and errors of the import's quality report beside `path`,
/// one line each naming the recording, so that clipping found at import
/// reaches the fit and the diagnosis. No report: none; an unreadable one:
/// a line saying so (the analysis goes on, as it would without).
pub fn quality_notes(path: &Path) -> Vec<String> {
    use crate::import::quality::{QualityReport, Severity};
    let Some(report_path) = quality_report_path(path).filter(|p| p.is_file()) else {
        return Vec::new();
    };
    let name = path.display();
    let report = std::fs::read_to_string(&report_path)
        .map_err(|e| e.to_string())
        .and_then(|t| serde_json::from_str::<QualityReport>(&t).map_err(|e| e.to_string()));
    match report {
        Ok(r) => r
            .findings
            .iter()
            .filter(|f| f.severity != Severity::Info)
            .map(|f| {
                format!(
                    "{name}: {}: {} (import's quality report)",
                    f.severity, f.message
                )
            })
            .collect(),
        Err(e) => vec![format!(
            "{name}: the import's quality report {} could not be read ({e}); its warnings are not carried",
            report_path.display()
        )],
    }
}

/// [`reduce_path`] where it reads the file a stretch at a time (stated
/// dwells, a long sweep); `None` where it would read it whole.
pub(super) fn reduce_path_streamed(
    path: &Path,
    choice: ChannelChoice,
    r: &ReductionOptions,
    observer: &dyn crate::observe::Observer,
) -> Result<Option<Reduced>> {
    // stepped sines whose steps are stated are reduced one dwell at a time
    // from disk (memory bounded whatever the file's size)
    Ok(if is_mcap(path) {
        let reader = crate::record::McapRunReader::open(path)?;
        let truth = TestDefinition::from_toml(
            &reader.run().info.test_definition,
            "recorded test definition",
        )
        .ok();
        let truncated = reader.run().truncated;
        reduce_streamed(path, reader, (truth, truncated), choice, r, observer)?
    } else {
        let reader = crate::record::RecordingReader::open(path)?;
        let truth = recorded_truth(reader.meta())
            .and_then(|t| TestDefinition::from_toml(&t, "recorded test definition").ok());
        reduce_streamed(path, reader, (truth, false), choice, r, observer)?
    })
}

/// The shaker's coil of the recording at `path` (a run file or a WAV
/// recording), when it holds a voltage, the force the shaker applies and
/// the drive point's motion at stated steps ([`crate::fit::coil`]); read
/// one dwell at a time.
pub fn coil_of_path(path: &Path) -> Result<Option<crate::fit::coil::CoilFit>> {
    if is_mcap(path) {
        crate::fit::coil::fit_coil(&mut crate::record::McapRunReader::open(path)?)
    } else {
        crate::fit::coil::fit_coil(&mut crate::record::RecordingReader::open(path)?)
    }
}

/// [`reduce_path`]'s streamed reduction of `source`, when its excitation is
/// stepped and its steps are stated; `None` otherwise.
fn reduce_streamed(
    path: &Path,
    mut source: impl FrameSource,
    (truth, truncated): (Option<TestDefinition>, bool),
    choice: ChannelChoice,
    r: &ReductionOptions,
    observer: &dyn crate::observe::Observer,
) -> Result<Option<Reduced>> {
    let mut meta = source.meta().clone();
    refuse_a_random(&meta, r)
        .map_err(|e| Error::context(format!("reducing {}", path.display()), e))?;
    let excitation = excitation_of(&meta, r.excitation);
    let long = source.frames() > WHOLE_RECORD_FRAMES;
    let swept = excitation == SineTest::Swept && long;
    let stepped = excitation == SineTest::Stepped && (!meta.excitation.steps.is_empty() || long);
    if !swept && !stepped {
        return Ok(None);
    }
    choice.apply(path, &mut meta)?;
    let ch = response_channel(path, &meta, choice.response, truth.as_ref())?;
    let reference = meta
        .reference_channel()
        .expect("checked by response_channel");
    if stepped && meta.excitation.steps.is_empty() && r.excitation.is_none() {
        // a multisine's periods would be cut into "dwells": say what it is,
        // from its first frames as the whole path does
        let n = source.frames().min(crate::extract::PERIOD_SEARCH);
        let mut buffers = vec![Vec::new(); source.meta().channels.len()];
        source.read_at(0, n, &mut buffers)?;
        let probe = Recording {
            meta: meta.clone(),
            channels: buffers,
        };
        refuse_a_multisine(&probe, ch)?;
    }
    if swept {
        return reduce_swept_stream(
            path,
            source,
            (truth, truncated),
            &meta,
            (reference, ch),
            r,
            observer,
        )
        .map(Some);
    }
    let options = ReduceOptions {
        reference_channel: Some(reference),
        ..stepped_options(r)
    };
    let red = match reduce_stepped_by_dwell(&mut source, ch, &options, observer) {
        Ok(red) => red,
        Err(e) => return Err(why_failed(e, path, &mut source, &meta, reference)?),
    };
    Ok(Some(Reduced {
        frf: red.frf,
        response_name: meta.channels[ch].name.clone(),
        sample_rate_hz: meta.sample_rate_hz,
        excitation: SineTest::Stepped,
        sweep: None,
        truth,
        streamed: true,
        truncated,
        quality: Vec::new(),
    }))
}

/// [`reduce_streamed`]'s swept-sine reduction of a long recording, read a
/// stretch at a time (`channels`: the reference and the response).
fn reduce_swept_stream(
    path: &Path,
    mut source: impl FrameSource,
    (truth, truncated): (Option<TestDefinition>, bool),
    meta: &RecordingMeta,
    (reference, ch): (usize, usize),
    r: &ReductionOptions,
    observer: &dyn crate::observe::Observer,
) -> Result<Reduced> {
    let (total, report) = swept_stages(r, observer);
    let reduced = report(0)
        .and_then(|()| sweep_options(&mut source, reference, ch, r))
        .and_then(|opts| {
            report(total - 1)?;
            let red = reduce_sweep(&mut source, reference, ch, &opts)?;
            report(total)?;
            Ok((red, opts.compensation_s, opts.hop_periods))
        });
    let (red, compensation, hop_asked) = match reduced {
        Ok(r) => r,
        Err(e) => return Err(why_failed(e, path, &mut source, meta, reference)?),
    };
    let reading = SweptReading {
        sweep: red.sweep,
        compensation_s: compensation,
        hop_periods: red.hop_periods,
        hop_asked,
    };
    Ok(Reduced {
        frf: red.into_frf(
            meta.channels[ch].quantity,
            meta.channels[reference].quantity,
        ),
        response_name: meta.channels[ch].name.clone(),
        sample_rate_hz: meta.sample_rate_hz,
        excitation: SineTest::Swept,
        sweep: Some(reading),
        truth,
        streamed: true,
        truncated,
        quality: Vec::new(),
    })
}

/// The error a streamed reduction of `path` failed with, said better where
/// its reference channel is all zero (which fails the first dwell or the
/// sweep's fit), as `load_recording` says it: read through once more, only
/// on failure, and not when the user stopped it.
fn why_failed(
    e: Error,
    path: &Path,
    source: &mut impl FrameSource,
    meta: &RecordingMeta,
    reference: usize,
) -> Result<Error> {
    if !matches!(e, Error::Cancelled) && is_flat(source, reference)? {
        return Ok(flat_reference(path, &meta.channels[reference].name));
    }
    Ok(e)
}

/// True when channel `c` of `source` is zero throughout (read a block at a
/// time).
fn is_flat(source: &mut impl FrameSource, c: usize) -> Result<bool> {
    const BLOCK: usize = 1 << 16;
    let mut buffers = vec![Vec::new(); source.meta().channels.len()];
    let mut start = 0;
    while start < source.frames() {
        let got = source.read_at(start, BLOCK, &mut buffers)?;
        if got == 0 {
            break;
        }
        if buffers[c].iter().any(|&v| v != 0.0) {
            return Ok(false);
        }
        start += got;
    }
    Ok(true)
}

/// Several recordings' FRFs as one set: single-dwell recordings (one point
/// each, e.g. steady single sines) are merged by level
/// ([`crate::extract::combine`]); otherwise each recording's levels are
/// kept as they are, in the order given (a swept recording is one level).
pub fn combine_recordings(sets: &[(PathBuf, NonlinearFrf)]) -> Result<NonlinearFrf> {
    let (first_path, first) = sets
        .first()
        .ok_or_else(|| Error::input("recordings", "none given"))?;
    for (p, f) in sets {
        if f.response != first.response || f.reference != first.reference {
            return Err(Error::input(
                p.display().to_string(),
                format!(
                    "its FRFs are {}/{} but {} gives {}/{}: recordings combine only with the \
                     same response and reference quantities",
                    f.response,
                    f.reference,
                    first_path.display(),
                    first.response,
                    first.reference
                ),
            ));
        }
    }
    let single = sets
        .iter()
        .all(|(_, f)| f.levels.iter().map(|l| l.points.len()).sum::<usize>() == 1);
    let k = sets.iter().map(|(_, f)| f.max_harmonic).min().unwrap_or(0);
    // a common harmonic count: drop what not every recording holds
    let trimmed: Vec<NonlinearFrf> = sets
        .iter()
        .map(|(_, f)| {
            let mut f = f.clone();
            f.max_harmonic = k;
            for l in &mut f.levels {
                for p in &mut l.points {
                    p.h.truncate(k + 1);
                    p.std_error.truncate(k + 1);
                    p.force_distortion.truncate(k + 1);
                }
            }
            f
        })
        .collect();
    if single && sets.len() > 1 {
        return crate::extract::combine(&trimmed);
    }
    let mut out = trimmed[0].clone();
    out.levels = trimmed.into_iter().flat_map(|f| f.levels).collect();
    Ok(out)
}

/// Reduces every recording and combines them into one FRF set (one level
/// per file, or the levels each holds); also returns the first reduction,
/// its `quality` holding every recording's. `on_reduced` sees each
/// reduction as it is made, `observer` how each
/// progresses ([`reduce_path`]).
pub fn reduce_recordings(
    recordings: &[PathBuf],
    choice: ChannelChoice,
    reduction: &ReductionOptions,
    on_reduced: &mut dyn FnMut(&Path, &Reduced),
    observer: &dyn crate::observe::Observer,
) -> Result<(NonlinearFrf, Reduced)> {
    let mut sets = Vec::with_capacity(recordings.len());
    let mut first: Option<Reduced> = None;
    let mut quality = Vec::new();
    for path in recordings {
        let red = reduce_path(path, choice, reduction, observer)
            .map_err(|e| Error::context(format!("reducing {}", path.display()), e))?;
        on_reduced(path, &red);
        sets.push((path.clone(), red.frf.clone()));
        quality.extend(red.quality.iter().cloned());
        first.get_or_insert(red);
    }
    let mut first = first.ok_or_else(|| Error::input("recordings", "no recording given"))?;
    // the combined FRFs carry every recording's quality warnings
    first.quality = quality;
    Ok((combine_recordings(&sets)?, first))
}
