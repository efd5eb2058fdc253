//! `hystid identify`: fit a hysteresis element to a recording's nonlinear
//! FRFs (paper Figures 2.2 and 3.3).

use super::args::{ExcitationArg, IdentifyArgs, IdentifyOptionsArgs, ReductionArgs};
use super::{create_out_dir, progress, write_json};
use anyhow::{Context, Result, bail};
use hystid::extract::{
    NonlinearFrf, ReduceOptions, SweepFit, SweepOptions, choose_compensation, reduce_stepped,
    reduce_stepped_file, reduce_sweep_recording,
};
use hystid::fit::{
    FitData, FitOptions, FitResult, FrfPredictor, HbPredictor, LinearRefinement, LinearStart,
    TraceEntry, Weighting, identify,
};
use hystid::model::{ElementKind, ElementSpec};
use hystid::plot::{self, ConvergenceSeries, FrfSeries, LoopSeries, SeriesStyle};
use hystid::record::{ExcitationKind, Recording, RecordingMeta};
use hystid::testbench::TestDefinition;
use serde::Serialize;
use std::path::{Path, PathBuf};
use std::sync::Mutex;

/// A recording loaded for analysis, with the test definition it came from
/// when it is a hystid virtual test (the truth, for comparison plots).
pub struct Loaded {
    /// The recording.
    pub recording: Recording,
    /// The response channel.
    pub response: usize,
    /// The virtual test's definition, if recorded.
    pub truth: Option<TestDefinition>,
}

/// The test definition a hystid virtual test keeps in its metadata.
fn recorded_truth(meta: &RecordingMeta) -> Option<String> {
    meta.metadata
        .get("test_definition")
        .and_then(|v| v.as_str())
        .map(str::to_string)
}

/// The response channel: `response` by name, else the virtual test's
/// response quantity, else the first channel that is not the reference;
/// it must be a motion and not the reference.
pub fn response_channel(
    path: &Path,
    meta: &RecordingMeta,
    response: Option<&str>,
    truth: Option<&TestDefinition>,
) -> Result<usize> {
    let probe = Recording {
        meta: meta.clone(),
        channels: Vec::new(),
    };
    let reference = probe.reference_channel().with_context(|| {
        format!(
            "{}: no force (or voltage) channel to use as the reference",
            path.display()
        )
    })?;
    let response = match response {
        Some(name) => probe.channel_index(name).with_context(|| {
            let names: Vec<&str> = meta.channels.iter().map(|c| c.name.as_str()).collect();
            format!(
                "{}: no channel `{name}` (channels: {names:?})",
                path.display()
            )
        })?,
        None => {
            // a virtual test says which response its FRFs were of
            let wanted = truth.map(|t| t.test.response.quantity().name().to_string());
            wanted
                .and_then(|q| meta.channels.iter().position(|c| c.quantity.name() == q))
                .or_else(|| probe.default_response_channel())
                .with_context(|| {
                    format!(
                        "{}: no response channel besides the reference",
                        path.display()
                    )
                })?
        }
    };
    if response == reference {
        bail!(
            "{}: the response channel is the reference channel",
            path.display()
        );
    }
    let q = meta.channels[response].quantity;
    if !q.is_motion() {
        bail!(
            "{}: the response channel `{}` is a {q}, not a motion",
            path.display(),
            meta.channels[response].name
        );
    }
    Ok(response)
}

fn is_mcap(path: &Path) -> bool {
    path.extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("mcap"))
}

/// Reads `run.mcap` or a WAV + JSON recording.
pub fn load_recording(path: &Path, response: Option<&str>) -> Result<Loaded> {
    let (recording, toml_text) = if is_mcap(path) {
        let run = hystid::record::read_run(path)?;
        if run.truncated {
            eprintln!(
                "warning: {} is truncated; analysing the complete chunks",
                path.display()
            );
        }
        let text = run.info.test_definition.clone();
        (
            run.to_recording()
                .with_context(|| format!("{}: rebuilding the recording", path.display()))?,
            Some(text),
        )
    } else {
        let rec = hystid::record::read_recording(path)?;
        let text = recorded_truth(&rec.meta);
        (rec, text)
    };
    let truth =
        toml_text.and_then(|t| TestDefinition::from_toml(&t, "recorded test definition").ok());
    let response = response_channel(path, &recording.meta, response, truth.as_ref())?;
    let reference = recording
        .reference_channel()
        .expect("checked by response_channel");
    let force = &recording.channels[reference];
    if force.iter().all(|&v| v == 0.0) {
        bail!(
            "{}: the reference channel `{}` is flat (all zero): nothing drove the structure",
            path.display(),
            recording.meta.channels[reference].name
        );
    }
    Ok(Loaded {
        recording,
        response,
        truth,
    })
}

/// How a recording is reduced.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Excitation {
    /// Dwells (stated or found).
    Stepped,
    /// A continuous sweep.
    Swept,
}

/// The reduction a recording gets: the flag, else its `excitation.kind`
/// (stepped when not stated).
pub fn excitation_of(meta: &RecordingMeta, arg: ExcitationArg) -> Excitation {
    match arg {
        ExcitationArg::Stepped => Excitation::Stepped,
        ExcitationArg::Swept => Excitation::Swept,
        ExcitationArg::Auto | ExcitationArg::Unknown => match meta.excitation.kind {
            ExcitationKind::SweptSine => Excitation::Swept,
            _ => Excitation::Stepped,
        },
    }
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
    pub excitation: Excitation,
    /// Swept sine: the sweep found and the compensation used (s).
    pub sweep: Option<(SweepFit, Option<f64>)>,
    /// The virtual test's definition, if recorded.
    pub truth: Option<TestDefinition>,
    /// Reduced from disk one dwell at a time (memory bounded).
    pub streamed: bool,
}

/// The highest harmonic for a reduction.
fn max_harmonic(r: &ReductionArgs, e: Excitation) -> usize {
    r.max_harmonic.unwrap_or(match e {
        Excitation::Stepped => 7,
        Excitation::Swept => 3,
    })
}

/// Sweep options for `force`/`response` from the flags, the compensation
/// resolved (`auto`: [`choose_compensation`]).
pub fn sweep_options(
    force: &[f64],
    response: &[f64],
    sample_rate_hz: f64,
    r: &ReductionArgs,
) -> Result<SweepOptions> {
    let mut opts = SweepOptions {
        max_harmonic: max_harmonic(r, Excitation::Swept),
        window_periods: r.window_periods,
        hop_periods: r.hop_periods,
        ..SweepOptions::default()
    };
    opts.compensation_s = match r.compensation.trim() {
        "auto" => Some(choose_compensation(force, response, sample_rate_hz, &opts)?),
        text => {
            let s: f64 = text.parse().with_context(|| {
                format!("--compensation: expected auto, 0 or seconds, got `{text}`")
            })?;
            if !(s.is_finite() && s >= 0.0) {
                bail!("--compensation: must be auto or seconds >= 0, got {s}");
            }
            (s > 0.0).then_some(s)
        }
    };
    Ok(opts)
}

/// Nonlinear FRFs of a loaded recording.
pub fn reduce(loaded: &Loaded, r: &ReductionArgs) -> Result<Reduced> {
    let rec = &loaded.recording;
    let excitation = excitation_of(&rec.meta, r.excitation);
    let response_name = rec.meta.channels[loaded.response].name.clone();
    let fs = rec.meta.sample_rate_hz;
    let (frf, sweep) = match excitation {
        Excitation::Stepped => {
            let opts = ReduceOptions {
                max_harmonic: max_harmonic(r, excitation),
                blocks: 16,
                ..ReduceOptions::default()
            };
            (reduce_stepped(rec, loaded.response, &opts)?, None)
        }
        Excitation::Swept => {
            let reference = rec.reference_channel().context("no reference channel")?;
            let opts = sweep_options(
                &rec.channels[reference],
                &rec.channels[loaded.response],
                fs,
                r,
            )?;
            let red = reduce_sweep_recording(rec, loaded.response, &opts)?;
            let sweep = red.sweep;
            let q = rec.meta.channels[loaded.response].quantity;
            let rq = rec.meta.channels[reference].quantity;
            (red.into_frf(q, rq), Some((sweep, opts.compensation_s)))
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
    })
}

/// Reduces the recording at `path`: a stepped-sine WAV + JSON recording
/// whose sidecar states its steps is reduced from disk one dwell at a time
/// (memory bounded whatever the file size); anything else is read whole.
pub fn reduce_path(path: &Path, response: Option<&str>, r: &ReductionArgs) -> Result<Reduced> {
    if path
        .to_str()
        .is_some_and(|p| p.to_ascii_lowercase().ends_with(".quality.json"))
    {
        bail!(
            "{} is the data-quality report `hystid import` writes beside a recording, not a recording (a glob such as `*.json` picks it up: name the recordings)",
            path.display()
        );
    }
    if !is_mcap(path) {
        let reader = hystid::record::RecordingReader::open(path)?;
        let meta = reader.meta().clone();
        drop(reader);
        if excitation_of(&meta, r.excitation) == Excitation::Stepped
            && !meta.excitation.steps.is_empty()
        {
            let truth = recorded_truth(&meta)
                .and_then(|t| TestDefinition::from_toml(&t, "recorded test definition").ok());
            let ch = response_channel(path, &meta, response, truth.as_ref())?;
            let opts = ReduceOptions {
                max_harmonic: max_harmonic(r, Excitation::Stepped),
                blocks: 16,
                ..ReduceOptions::default()
            };
            let red = reduce_stepped_file(path, ch, &opts)?;
            return Ok(Reduced {
                frf: red.frf,
                response_name: meta.channels[ch].name.clone(),
                sample_rate_hz: meta.sample_rate_hz,
                excitation: Excitation::Stepped,
                sweep: None,
                truth,
                streamed: true,
            });
        }
    }
    let loaded = load_recording(path, response)?;
    reduce(&loaded, r)
}

/// Several recordings' FRFs as one set: single-dwell recordings (one point
/// each, e.g. steady single sines) are merged by level
/// ([`hystid::extract::combine`]); otherwise each recording's levels are
/// kept as they are, in the order given (a swept recording is one level).
pub fn combine_recordings(sets: &[(PathBuf, NonlinearFrf)]) -> Result<NonlinearFrf> {
    let (first_path, first) = sets.first().context("no recordings")?;
    for (p, f) in sets {
        if f.response != first.response || f.reference != first.reference {
            bail!(
                "{}: its FRFs are {}/{} but {} gives {}/{}: recordings combine only with the \
                 same response and reference quantities",
                p.display(),
                f.response,
                f.reference,
                first_path.display(),
                first.response,
                first.reference
            );
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
        return Ok(hystid::extract::combine(&trimmed)?);
    }
    let mut out = trimmed[0].clone();
    out.levels = trimmed.into_iter().flat_map(|f| f.levels).collect();
    Ok(out)
}

/// Prints what a reduction found.
pub fn print_reduced(path: &Path, r: &Reduced) {
    let points: usize = r.frf.levels.iter().map(|l| l.points.len()).sum();
    let levels: Vec<String> = r
        .frf
        .levels
        .iter()
        .map(|l| format!("{:.4}", l.level))
        .collect();
    say_part!(
        "{}: `{}` {} {} point(s) at level(s) {} {}",
        path.display(),
        r.response_name,
        match r.excitation {
            Excitation::Stepped => "stepped sine,",
            Excitation::Swept => "swept sine,",
        },
        points,
        levels.join(", "),
        r.frf.reference.si_unit()
    );
    if let Some((s, comp)) = &r.sweep {
        say_part!(
            "; sweep {:.4} -> {:.4} Hz at {:.5} Hz/s, compensation {}",
            s.f_start_hz,
            s.f_end_hz,
            s.rate_hz_per_s,
            comp.map_or("off".to_string(), |c| format!("{c:.2} s"))
        );
    }
    if r.streamed {
        say_part!(" (streamed)");
    }
    say!();
}

/// Fit options from the command line.
pub fn fit_options(a: &IdentifyOptionsArgs) -> Result<FitOptions> {
    let element = match a.element.as_str() {
        "masing" => ElementKind::Masing,
        "jenkins" => ElementKind::Jenkins,
        other => bail!("--element: expected masing or jenkins, got `{other}`"),
    };
    let band_hz = match &a.band {
        None => None,
        Some(b) => {
            let (lo, hi) = b
                .split_once(':')
                .with_context(|| format!("--band: expected LO:HI in Hz, got `{b}`"))?;
            let lo: f64 = lo
                .trim()
                .parse()
                .with_context(|| format!("--band: `{lo}` is not a number"))?;
            let hi: f64 = hi
                .trim()
                .parse()
                .with_context(|| format!("--band: `{hi}` is not a number"))?;
            if !(lo.is_finite() && hi.is_finite() && 0.0 <= lo && lo < hi) {
                bail!("--band: need 0 <= LO < HI, got {lo}:{hi}");
            }
            Some((lo, hi))
        }
    };
    Ok(FitOptions {
        element,
        harmonics: a.harmonics.clone(),
        weighting: if a.weighted {
            Weighting::StandardError
        } else {
            Weighting::None
        },
        refine_linear: match a.refine_linear.as_str() {
            "none" => LinearRefinement::None,
            "damping" => LinearRefinement::Damping,
            "all" => LinearRefinement::All,
            other => bail!("--refine-linear: expected none, damping or all, got `{other}`"),
        },
        linear_start: match a.linear_start.as_str() {
            "extremes" => LinearStart::Extremes,
            "lowest" => LinearStart::Lowest,
            other => bail!("--linear-start: expected extremes or lowest, got `{other}`"),
        },
        modes: if (1..=4).contains(&a.modes) {
            a.modes
        } else {
            bail!("--modes: expected 1 to 4, got {}", a.modes)
        },
        second_optimiser: a.lm,
        bootstrap: a.bootstrap,
        seed: a.seed,
        band_hz,
        ..FitOptions::default()
    })
}

/// How the fit compares with the element the data were simulated with.
#[derive(Serialize)]
pub struct Comparison {
    /// Parameter name.
    pub parameter: String,
    /// Reference value.
    pub reference: f64,
    /// Estimate.
    pub estimate: f64,
    /// `estimate/reference − 1`.
    pub relative_error: f64,
    /// Whether the 95 % interval covers the reference.
    pub covered: bool,
}

/// `fit.json`.
#[derive(Serialize)]
pub struct FitReport<'a> {
    /// `identify`.
    pub command: &'static str,
    /// Tool version.
    pub version: &'static str,
    /// The recording.
    pub recording: String,
    /// The response analysed.
    pub response: String,
    /// The fit.
    #[serde(flatten)]
    pub fit: &'a FitResult,
    /// The element the data came from, when known.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub reference: Option<ElementSpec>,
    /// Estimates against the reference.
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub comparison: Vec<Comparison>,
    /// Files written.
    pub files: Vec<PathBuf>,
}

/// The reference joint of a virtual test.
pub fn reference_joint(truth: Option<&TestDefinition>) -> Option<ElementSpec> {
    let m = truth?.model().ok()?;
    m.elements
        .into_iter()
        .find(|e| matches!(e.kind(), ElementKind::Jenkins | ElementKind::Masing))
}

/// Compares estimates with a reference element's parameters.
pub fn compare(fit: &FitResult, reference: Option<&ElementSpec>) -> Vec<Comparison> {
    let Some(r) = reference else {
        return Vec::new();
    };
    r.parameters()
        .into_iter()
        .filter_map(|(name, value)| {
            let e = fit.parameters.get(name)?;
            Some(Comparison {
                parameter: name.to_string(),
                reference: value,
                estimate: e.value,
                relative_error: e.value / value - 1.0,
                covered: e.ci95[0] <= value && value <= e.ci95[1],
            })
        })
        .collect()
}

/// The fit's figures: FRF overlay, hysteresis loops, convergence.
pub fn write_fit_plots(
    dir: &Path,
    frf: &NonlinearFrf,
    fit: &FitResult,
    reference: Option<&ElementSpec>,
    predictor: &HbPredictor,
) -> Result<Vec<PathBuf>> {
    let mut files = Vec::new();
    // measured vs model |H1| and phase for every level (paper Fig. 3.4 right)
    let data = FitData::from_frf(frf, &[1], fit_band(fit), None)?;
    let pred = predictor.predict(&fit.model, &data)?;
    let mut series = Vec::new();
    for (g, (s, p)) in data.series.iter().zip(&pred.h).enumerate() {
        let label = hystid::plot::level_label(s.level, frf.reference.si_unit());
        let f: Vec<f64> = s.points.iter().map(|p| p.frequency_hz).collect();
        series.push(FrfSeries {
            label: label.clone(),
            group: g,
            frequency_hz: f.clone(),
            h: s.points.iter().map(|p| p.h[0]).collect(),
            std_error: Some(s.points.iter().map(|p| p.std_error[0]).collect()),
            style: SeriesStyle::Measured,
        });
        series.push(FrfSeries {
            label: format!("{label} (model)"),
            group: g,
            frequency_hz: f,
            h: p.iter()
                .map(|m| {
                    m.as_ref()
                        .map_or(num_complex::Complex64::new(f64::NAN, f64::NAN), |m| {
                            m[0] * fit.response_sign
                        })
                })
                .collect(),
            std_error: None,
            style: SeriesStyle::Model,
        });
    }
    files.extend(plot::write_frf_plot(
        &dir.join("fit_frf"),
        &format!(
            "Measured (markers) and fitted {} model (lines)",
            fit.element.name()
        ),
        &plot::frf_magnitude_label(frf, 1),
        &series,
    )?);
    // hysteresis loops at several amplitudes (Fig. 3.2 / 3.4 left)
    if let Some(spec) = fit.model.elements.first() {
        let (kd, fd) = (
            spec.stick_stiffness(),
            fit.parameters.get("fd").map_or(1.0, |e| e.value),
        );
        let xc = fd / kd;
        let mut loops = Vec::new();
        for (g, mult) in [0.5, 1.5, 3.0, 8.0].into_iter().enumerate() {
            let a = mult * xc;
            if let Some(r) = reference {
                let (x, f) = r.steady_loop(a, 400)?;
                loops.push(LoopSeries {
                    label: format!("reference, a = {mult} Fd/kd"),
                    group: g,
                    displacement: x,
                    force: f,
                    style: SeriesStyle::Measured,
                });
            }
            let (x, f) = spec.steady_loop(a, 400)?;
            loops.push(LoopSeries {
                label: format!("fitted, a = {mult} Fd/kd"),
                group: g,
                displacement: x,
                force: f,
                style: SeriesStyle::Model,
            });
        }
        files.extend(plot::write_loop_plot(
            &dir.join("loops"),
            "Hysteresis loops: fitted element over the reference",
            "displacement [m]",
            "element force [N]",
            &loops,
        )?);
    }
    let cost: Vec<f64> = fit.trace.iter().map(|t| t.cost).collect();
    if !cost.is_empty() {
        files.extend(plot::write_convergence_plot(
            &dir.join("convergence"),
            "Nelder-Mead: cost per evaluation",
            "cost (eq. 9 squared)",
            &[ConvergenceSeries {
                label: "Nelder-Mead".into(),
                group: 0,
                cost,
            }],
        )?);
    }
    Ok(files)
}

fn fit_band(_fit: &FitResult) -> Option<(f64, f64)> {
    None
}

/// Runs the fit with a progress line and an optional MCAP fit channel.
pub fn run_fit(
    frf: &NonlinearFrf,
    options: &FitOptions,
    quiet: bool,
    mcap: Option<&Mutex<&mut hystid::record::McapRecorder>>,
) -> Result<(FitResult, HbPredictor)> {
    let predictor = HbPredictor::default();
    let pb = progress::spinner("fitting", quiet);
    let write_error: Mutex<Option<hystid::Error>> = Mutex::new(None);
    let observer = |t: &TraceEntry| {
        pb.set_message(format!("evaluation {}: cost {:.6e}", t.evaluation, t.cost));
        pb.tick();
        if let Some(m) = mcap
            && let Err(e) = m
                .lock()
                .expect("mcap lock")
                .write_fit_iteration(t.evaluation as u64, t)
        {
            write_error.lock().expect("lock").get_or_insert(e);
        }
    };
    let fit = identify(frf, options, &predictor, Some(&observer))?;
    pb.finish_and_clear();
    if let Some(e) = write_error.into_inner().expect("lock") {
        return Err(e.into());
    }
    Ok((fit, predictor))
}

/// Prints the fit in a few lines.
pub fn print_fit(fit: &FitResult, comparison: &[Comparison]) {
    say!(
        "fitted {} element: relative error {:.4} (chi2/dof {:.3}), {} evaluations in {:.2} s",
        fit.element.name(),
        fit.error.relative,
        fit.error.chi2_per_dof,
        fit.effort.evaluations,
        fit.effort.seconds
    );
    for (name, e) in &fit.parameters {
        let cmp = comparison.iter().find(|c| &c.parameter == name);
        let r = cmp.map_or(String::new(), |c| {
            format!(
                "  (reference {:.6e}: {:+.2} %{})",
                c.reference,
                100.0 * c.relative_error,
                if c.covered {
                    ", covered"
                } else {
                    ", NOT covered"
                }
            )
        });
        say!(
            "  {name:>10} = {:.6e}  ci95 [{:.4e}, {:.4e}]{}{r}",
            e.value,
            e.ci95[0],
            e.ci95[1],
            if e.identifiable {
                ""
            } else {
                "  (not identifiable)"
            }
        );
        if let Some(n) = &e.note {
            say!("             {n}");
        }
    }
    say!(
        "  linear: m = {:.5} kg, c = {:.4} N s/m, k = {:.6e} N/m; stick k_low = {:.6e} N/m",
        fit.linear.mass,
        fit.linear.damping,
        fit.linear.stiffness,
        fit.linear.stick.stiffness
    );
    for n in &fit.notes {
        say!("  note: {n}");
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

/// `hystid identify`.
/// Reduces every recording and combines them into one FRF set (one level
/// per file, or the levels each holds); also returns the first reduction.
pub fn reduce_recordings(
    recordings: &[PathBuf],
    response: Option<&str>,
    reduction: &ReductionArgs,
    quiet: bool,
) -> Result<(NonlinearFrf, Reduced)> {
    let mut sets = Vec::with_capacity(recordings.len());
    let mut first: Option<Reduced> = None;
    for path in recordings {
        let red = reduce_path(path, response, reduction)
            .with_context(|| format!("reducing {}", path.display()))?;
        if !quiet {
            print_reduced(path, &red);
        }
        sets.push((path.clone(), red.frf.clone()));
        first.get_or_insert(red);
    }
    let first = first.context("no recording given")?;
    Ok((combine_recordings(&sets)?, first))
}

/// `hystid identify`.
pub fn identify_command(args: &IdentifyArgs, quiet: bool) -> Result<u8> {
    let options = fit_options(&args.fit)?;
    let (frf, first) = reduce_recordings(
        &args.recordings,
        args.response.as_deref(),
        &args.reduction,
        quiet,
    )?;
    let recording_names: Vec<String> = args
        .recordings
        .iter()
        .map(|p| p.display().to_string())
        .collect();
    create_out_dir(&args.out)?;
    let info = hystid::record::RunInfo {
        tool_version: format!("hystid {}", env!("CARGO_PKG_VERSION")),
        test_definition: String::new(),
        seed: options.seed,
        sample_rate_hz: first.sample_rate_hz,
        channels: hystid::testbench::recorded_channels(),
        metadata: [("recording".to_string(), recording_names.join(", "))].into(),
    };
    let mut mcap = hystid::record::McapRecorder::create(&args.out.join("fit.mcap"), &info)?;
    let (fit, predictor) = run_fit(&frf, &options, quiet, Some(&Mutex::new(&mut mcap)))?;
    mcap.finish()?;
    let reference = reference_joint(first.truth.as_ref());
    let comparison = compare(&fit, reference.as_ref());
    let mut files = vec![args.out.join("fit.json"), args.out.join("fit.mcap")];
    files.extend(write_fit_plots(
        &args.out,
        &band_limited(&frf, options.band_hz),
        &fit,
        reference.as_ref(),
        &predictor,
    )?);
    let report = FitReport {
        command: "identify",
        version: env!("CARGO_PKG_VERSION"),
        recording: recording_names.join(", "),
        response: first.response_name.clone(),
        fit: &fit,
        reference,
        comparison,
        files,
    };
    write_json(&args.out.join("fit.json"), &report)?;
    if !quiet {
        print_fit(&fit, &report.comparison);
        for f in &report.files {
            say!("  wrote {}", f.display());
        }
    }
    Ok(super::fit_exit_code(fit.status))
}
