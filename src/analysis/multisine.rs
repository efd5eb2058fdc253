//! `diagnose --domain time` on multisines: the loop closed on recordings no
//! FRF is read from.
//!
//! A multisine's nonlinear FRFs do not exist (harmonic balance predicts a
//! single sine's steady state), so the diagnosis runs on the time histories
//! and reads their residual at the lines of the period
//! ([`crate::diagnose::lines`]):
//!
//! 1. the baseline: the joint on the linear estimate at the excited lines,
//!    fitted in the time domain (as `identify --domain time` fits a
//!    multisine);
//! 2. the model's residual per line, in units of the noise the periods'
//!    scatter measures: by class of line (excited, odd and even not
//!    excited), by band, by recording, and the strongest lines;
//! 3. every candidate that can join the model, started from the lines (an
//!    effect of one size sized by the Gauss–Newton step along a probe, a
//!    joint law in place of the fitted one at the shape that fits the lines
//!    best), traced by the share of the residual's `χ²` its signature
//!    explains;
//! 4. those that explain the most (at most `--time-proposals`, above
//!    [`MIN_TRACED_SHARE`]) refitted in time with every parameter free; the
//!    best that lowers the misfit by more than [`CONFIRMATION_RISE`] (against
//!    the model as it stands refitted with the same budget: a fit stopped
//!    short of its optimum gains from any further parameter) is added and
//!    refitted in full, and the loop repeats on the new residual,
//!    until no candidate earns its place, the residual is within twice the
//!    noise, or [`crate::diagnose::DiagnoseOptions::max_effects`] are in.
//!
//! The error is reported before (the baseline) and after (the final model)
//! for each recording.

use super::diagnose::{
    CONFIRMATION_RISE, MIN_TRACED_SHARE, PROPOSAL_PATIENCE, TimeProposal, judge_proposal, misfit,
};
use crate::diagnose::lines::{LineContext, share_explained};
use crate::diagnose::time_residual::TracedCandidate;
use crate::diagnose::{DiagnoseOptions, Effect};
use crate::error::{Error, Result};
use crate::extract::lines::{LineResidual, line_residual};
use crate::fit::time::{TimeProblem, time_parameters};
use crate::fit::{TimeFitOptions, TimeFitResult, TimeRecord, identify_time};
use crate::model::Model;
use crate::observe::Observer;
use crate::plot::{NoiseLevel, ResidualPanel, ResidualSeries};
use serde::Serialize;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

/// Proposals refitted per round when `--time-proposals` is not given.
pub const DEFAULT_PROPOSALS: usize = 3;

/// A residual whose `χ²` per line is within this many times the noise's is
/// not traced further: what is left is the noise (the FRF diagnosis's
/// "far from the noise" test).
pub const NOISE_CHI2_PER_LINE: f64 = 2.0;

/// One round of the diagnosis on the lines.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct LineRound {
    /// 1 for the baseline's residual.
    pub round: usize,
    /// The model's residual per line.
    pub residual: LineResidual,
    /// Each candidate traced in it, the largest share first.
    pub traced: Vec<TracedCandidate>,
    /// The model as it stands refitted with a proposal's budget, where that
    /// lowered its misfit: what the proposals' gains are measured from
    /// (else from the model's own misfit).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub control_misfit: Option<f64>,
    /// The candidates refitted in time, and which was added.
    pub proposals: Vec<TimeProposal>,
}

/// The diagnosis of a time-domain fit to multisines.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct MultisineDiagnosis {
    /// How the baseline's start was made (the recordings' periods and
    /// lines, the linear estimate).
    pub start: String,
    /// The baseline: the joint alone, fitted in time (`after`: its error
    /// on each recording).
    pub baseline: TimeFitResult,
    /// The rounds, in order.
    pub rounds: Vec<LineRound>,
    /// The effects added, in order.
    pub selected: Vec<Effect>,
    /// The final model, refitted in time (the baseline when none was
    /// added).
    pub refit: TimeFitResult,
    /// The final model's residual per line.
    pub residual: LineResidual,
    /// What was found, in words.
    pub explanation: String,
}

/// Diagnoses the time-domain fit of `start` to the multisine `records`
/// (each judged over its steady periods, one segment per period; see the
/// module docs), telling `observer` how it goes. `options.starts`: the
/// baseline's starts (every later fit starts from a fitted model).
pub fn diagnose_multisine(
    start: &Model,
    records: &[TimeRecord],
    options: &TimeFitOptions,
    diagnose_options: &DiagnoseOptions,
    observer: &dyn Observer,
) -> Result<MultisineDiagnosis> {
    let spectra = records
        .iter()
        .map(TimeRecord::periodic_spectra)
        .collect::<Result<Vec<_>>>()?;
    let quantity = records
        .first()
        .ok_or_else(|| Error::input("recordings", "none given"))?
        .quantity;
    let band = diagnose_options.band_hz;
    let fit = |m: &Model, o: &TimeFitOptions| {
        let p = time_parameters(m, o.refine_linear, band);
        identify_time(m, p, 1.0, records, o, Some(observer))
    };
    // the baseline descends from `options.starts` starts; every later fit
    // starts next to a fitted model, from one
    let baseline = fit(start, options)?;
    let options = &TimeFitOptions {
        starts: 1,
        ..options.clone()
    };
    let proposal_options = TimeFitOptions {
        patience: options.patience.min(PROPOSAL_PATIENCE),
        ..options.clone()
    };
    let at_most = match diagnose_options.time_proposals {
        0 => DEFAULT_PROPOSALS,
        n => n,
    };
    let mut current = baseline.clone();
    let mut selected: Vec<Effect> = Vec::new();
    let mut rounds = Vec::new();
    let mut tried: Vec<Effect> = Vec::new();
    let residual = loop {
        // the residual at the lines and every candidate traced in it; the
        // problem that replays them (its drive held on the replay grid) is
        // let go before the refits, each of which holds its own
        let (residual, mut traced, starts) = {
            let params = time_parameters(&current.model, options.refine_linear, band);
            let mut problem = TimeProblem::new(
                current.model.clone(),
                params,
                records,
                1.0,
                options.clone(),
                None,
            )?;
            problem.choose_replay_rates();
            let cx = LineContext::new(&current.model, &problem, &spectra, quantity)?;
            let residual = line_residual(&spectra, cx.residual());
            if residual.chi2_per_line <= NOISE_CHI2_PER_LINE
                || selected.len() >= diagnose_options.max_effects
            {
                break residual;
            }
            // every candidate that may join, traced by its start's signature
            let effects: Vec<Effect> = diagnose_options
                .candidates
                .iter()
                .copied()
                .filter(|e| e.candidate().applies_to(&current.model))
                .filter(|e| !selected.contains(e) && !tried.contains(e))
                .collect();
            let mut traced = Vec::new();
            let mut starts: Vec<(Effect, Model)> = Vec::new();
            for (i, &effect) in effects.iter().enumerate() {
                crate::observe::progress(observer, "tracing", i as u64, effects.len() as u64)?;
                let best = effect
                    .candidate()
                    .line_starts(&cx)
                    .into_iter()
                    .filter_map(|m| {
                        let sig = cx.signature(&m)?;
                        Some((share_explained(cx.residual(), &sig), m))
                    })
                    .max_by(|a, b| a.0.total_cmp(&b.0));
                traced.push(match best {
                    Some((share, m)) => {
                        starts.push((effect, m));
                        TracedCandidate {
                            effect,
                            share,
                            failed: None,
                        }
                    }
                    None => TracedCandidate {
                        effect,
                        share: f64::NAN,
                        failed: Some("no start on the lines".into()),
                    },
                });
            }
            (residual, traced, starts)
        };
        traced.sort_by(|a, b| {
            let key = |t: &TracedCandidate| if t.share.is_nan() { -1.0 } else { t.share };
            key(b).total_cmp(&key(a)).then(a.effect.cmp(&b.effect))
        });
        // the model as it stands refitted with a proposal's budget from
        // where it is: a proposal must beat what that budget alone gains (a
        // fit stopped short of its optimum lowers the misfit with any
        // further parameter, or none)
        let control = match fit(&current.model, &proposal_options) {
            Ok(r) if misfit(&r.after) < misfit(&current.after) => Some(r),
            Ok(_) => None,
            Err(Error::Cancelled) => return Err(Error::Cancelled),
            // no evidence either way: the proposals are judged against the
            // model as it stands
            Err(_) => None,
        };
        let with = control
            .as_ref()
            .map_or(misfit(&current.after), |r| misfit(&r.after));
        // the best-traced refitted briefly; the best that earns it added
        let mut proposals: Vec<TimeProposal> = Vec::new();
        let mut best: Option<(usize, Model)> = None;
        let put: Vec<Effect> = traced
            .iter()
            .filter(|t| t.failed.is_none() && t.share > MIN_TRACED_SHARE)
            .take(at_most)
            .map(|t| t.effect)
            .collect();
        for effect in put {
            let start = &starts.iter().find(|(e, _)| *e == effect).expect("traced").1;
            tried.push(effect);
            judge_proposal(
                effect,
                fit(start, &proposal_options),
                with,
                &mut proposals,
                &mut best,
            )?;
        }
        let added = match best {
            // the one added refitted with the full budget
            Some((i, m)) => match fit(&m, options) {
                Ok(mut r) => {
                    proposals[i].kept = true;
                    selected.push(proposals[i].effect);
                    r.before = current.after.clone();
                    current = r;
                    true
                }
                Err(Error::Cancelled) => return Err(Error::Cancelled),
                Err(e) => {
                    proposals[i].failed = Some(format!("its full time refit failed: {e}"));
                    false
                }
            },
            None => false,
        };
        let control_misfit = control.as_ref().map(|r| misfit(&r.after));
        if !added && let Some(r) = control {
            // no effect earned its place: the model as it stands, further
            // refitted, is the final one
            let before = current.after.clone();
            current = r;
            current.before = before;
        }
        rounds.push(LineRound {
            round: rounds.len() + 1,
            residual,
            traced,
            control_misfit,
            proposals,
        });
        if !added {
            // the residual of the model as it stands is the last round's
            let last = rounds.last().expect("a round").residual.clone();
            break last;
        }
    };
    let mut refit = current;
    refit.before = baseline.after.clone();
    let explanation = explain(&baseline, &refit, &rounds, &selected, &residual);
    Ok(MultisineDiagnosis {
        start: String::new(),
        baseline,
        rounds,
        selected,
        refit,
        residual,
        explanation,
    })
}

/// The diagnosis in one sentence or two.
fn explain(
    baseline: &TimeFitResult,
    refit: &TimeFitResult,
    rounds: &[LineRound],
    selected: &[Effect],
    residual: &LineResidual,
) -> String {
    let (before, after) = (misfit(&baseline.after), misfit(&refit.after));
    let left = format!(
        "the final residual is {:.2} times the noise's chi2 per line",
        residual.chi2_per_line
    );
    if selected.is_empty() {
        let why = match rounds.first() {
            None => "the baseline's residual per line is within twice the noise".to_string(),
            Some(r) if r.proposals.is_empty() => {
                "no candidate explains more than 1 % of the residual per line".to_string()
            }
            Some(_) => format!(
                "no candidate refitted in time lowered the misfit by more than {:.1} %",
                100.0 * CONFIRMATION_RISE
            ),
        };
        return format!(
            "No significant missing effect: {why} (misfit {:.2} % per period, relative e_RMS); {left}.",
            100.0 * before
        );
    }
    let named: Vec<String> = selected
        .iter()
        .map(|e| {
            // its share in the round it was added in
            let share = rounds
                .iter()
                .find(|r| r.proposals.iter().any(|p| p.kept && p.effect == *e))
                .and_then(|r| r.traced.iter().find(|t| t.effect == *e))
                .map_or(f64::NAN, |t| t.share);
            format!(
                "{} (it explained {:.0} % of the residual per line)",
                e.name(),
                100.0 * share
            )
        })
        .collect();
    format!(
        "Added {}: the misfit fell from {:.2} % to {:.2} % per period (relative e_RMS, {:.1}x); {left}.",
        named.join(", then "),
        100.0 * before,
        100.0 * after,
        before / after.max(f64::MIN_POSITIVE)
    )
}

/// `diagnosis.json` of a multisine's diagnosis.
#[derive(Serialize)]
pub struct MultisineReport<'a> {
    /// `diagnose`.
    pub command: &'static str,
    /// Tool version.
    pub version: &'static str,
    /// `time`.
    pub domain: &'static str,
    /// `multisine`.
    pub excitation: &'static str,
    /// The recordings.
    pub recordings: Vec<String>,
    /// Wall time, s.
    pub seconds: f64,
    /// The final model (what `validate` reads from a diagnosis).
    pub model: &'a Model,
    /// The model predicts `response_sign × measured` (a multisine's fit
    /// keeps the response as recorded: 1).
    pub response_sign: f64,
    /// The recordings' reference quantity (a force or a voltage).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub reference_quantity: Option<crate::harmonics::Quantity>,
    /// The reference channel named (`--reference`), when one was.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub reference_channel: Option<&'a str>,
    /// The diagnosis.
    #[serde(flatten)]
    pub diagnosis: &'a MultisineDiagnosis,
}

impl<'a> MultisineReport<'a> {
    /// The report of `d`, diagnosed on `recordings` in `seconds`.
    pub fn new(
        d: &'a MultisineDiagnosis,
        recordings: Vec<String>,
        seconds: f64,
        reference_channel: Option<&'a str>,
    ) -> MultisineReport<'a> {
        MultisineReport {
            command: "diagnose",
            version: super::VERSION,
            domain: "time",
            excitation: "multisine",
            recordings,
            seconds,
            model: &d.refit.model,
            response_sign: d.refit.response_sign,
            reference_quantity: d.refit.reference_quantity,
            reference_channel,
            diagnosis: d,
        }
    }
}

/// Writes `diagnosis.json`, `diagnosis.md` and the residual per line before
/// and after (`residual_lines.png`/`.svg`, the models replayed as the
/// diagnosis replayed them, `options`) into `dir`; returns the files.
pub fn write_multisine_diagnosis(
    dir: &Path,
    d: &MultisineDiagnosis,
    records: &[TimeRecord],
    seconds: f64,
    reference_channel: Option<&str>,
    options: &TimeFitOptions,
) -> Result<Vec<PathBuf>> {
    let mut files = vec![dir.join("diagnosis.json"), dir.join("diagnosis.md")];
    let names = records.iter().map(|r| r.name.clone()).collect();
    super::write_json(
        &files[0],
        &MultisineReport::new(d, names, seconds, reference_channel),
    )?;
    crate::atomic::write_bytes(&files[1], markdown(d, seconds).as_bytes())?;
    files.extend(residual_figure(dir, d, records, options)?);
    Ok(files)
}

/// The residual per line of the baseline and the final model, each
/// recording a series, in units of the noise.
fn residual_figure(
    dir: &Path,
    d: &MultisineDiagnosis,
    records: &[TimeRecord],
    options: &TimeFitOptions,
) -> Result<Vec<PathBuf>> {
    let spectra = records
        .iter()
        .map(TimeRecord::periodic_spectra)
        .collect::<Result<Vec<_>>>()?;
    let panel = |heading: String, model: &Model| -> Result<ResidualPanel> {
        let params = time_parameters(model, false, None);
        let problem = TimeProblem::new(model.clone(), params, records, 1.0, options.clone(), None)?;
        let lines = crate::diagnose::lines::replay_lines(&problem, &spectra, model)?;
        Ok(ResidualPanel {
            heading,
            series: spectra
                .iter()
                .zip(&lines)
                .enumerate()
                .map(|(g, (s, l))| ResidualSeries {
                    // the file's stem: a path does not fit a legend
                    label: Path::new(&s.name)
                        .file_stem()
                        .map_or_else(|| s.name.clone(), |f| f.to_string_lossy().into_owned()),
                    group: g,
                    frequency_hz: (0..s.bins.len()).map(|i| s.frequency_hz(i)).collect(),
                    residual: s.residual(l).iter().map(|v| v.norm()).collect(),
                })
                .collect(),
        })
    };
    let joint = |m: &Model| m.joint.as_ref().map_or("no joint", |j| j.kind().name());
    let mut panels = vec![panel(
        format!("before: {} joint alone", joint(&d.baseline.model)),
        &d.baseline.model,
    )?];
    if !d.selected.is_empty() {
        let added: Vec<&str> = d.selected.iter().map(|e| e.name()).collect();
        panels.push(panel(
            format!("after: + {}", added.join(" + ")),
            &d.refit.model,
        )?);
    }
    crate::plot::write_residual_plot(
        &dir.join("residual_lines"),
        "residual at the multisine's lines",
        "|Y - Y_model| / noise",
        &panels,
        Some(&NoiseLevel {
            value: 2.0,
            label: "2x the noise".into(),
        }),
    )
}

/// `diagnosis.md`.
fn markdown(d: &MultisineDiagnosis, seconds: f64) -> String {
    let mut s = String::new();
    let _ = writeln!(
        s,
        "# Diagnosis of a time-domain fit to multisines\n\n{}\n\n{}\n",
        d.explanation, d.start
    );
    let _ = writeln!(
        s,
        "| recording | baseline (joint alone) | final | relative e_RMS before | after |\n|---|---|---|---|---|"
    );
    for (b, a) in d.baseline.after.iter().zip(&d.refit.after) {
        let _ = writeln!(
            s,
            "| {} | {:.2} % | {:.2} % | {:.2} % | {:.2} % |",
            a.recording,
            100.0 * b.segment_relative,
            100.0 * a.segment_relative,
            100.0 * b.window.relative,
            100.0 * a.window.relative,
        );
    }
    let _ = writeln!(
        s,
        "\nThe first two columns are the misfit the fits minimise (each period's relative e_RMS, \
         root mean square over the periods).\n"
    );
    for r in &d.rounds {
        let _ = writeln!(s, "## Round {}\n", r.round);
        s += &residual_markdown(&r.residual);
        if !r.traced.is_empty() {
            let _ = writeln!(
                s,
                "\nThe candidates traced (the share of the residual's chi2 a step along its \
                 signature removes):\n\n| effect | share | refitted: misfit | gain | added |\n|---|---|---|---|---|"
            );
            for t in &r.traced {
                let p = r.proposals.iter().find(|p| p.effect == t.effect);
                let share = match &t.failed {
                    Some(why) => format!("not traced: {why}"),
                    None => format!("{:.1} %", 100.0 * t.share),
                };
                let (m, g, k) = match p {
                    Some(p) if p.failed.is_none() => (
                        format!("{:.2} %", 100.0 * misfit(&p.with)),
                        format!("{:+.2} %", 100.0 * p.gain),
                        if p.kept { "**yes**" } else { "no" }.to_string(),
                    ),
                    Some(p) => (
                        p.failed.clone().unwrap_or_default(),
                        String::new(),
                        "no".into(),
                    ),
                    None => (String::new(), String::new(), String::new()),
                };
                let _ = writeln!(s, "| {} | {share} | {m} | {g} | {k} |", t.effect.name());
            }
        }
        s.push('\n');
    }
    let _ = writeln!(s, "## The final model's residual\n");
    s += &residual_markdown(&d.residual);
    let _ = writeln!(s, "\n## The final model\n");
    for (name, e) in &d.refit.parameters {
        let _ = writeln!(s, "- {name}: {:.6e}", e.value);
    }
    let _ = writeln!(s, "\nWall time {seconds:.1} s.");
    s
}

/// A residual per line as a few lines of markdown.
fn residual_markdown(r: &LineResidual) -> String {
    let mut s = String::new();
    let classes: Vec<String> = r
        .by_class
        .iter()
        .map(|c| {
            format!(
                "{} {:.2} ({} lines, {:.0} % of it)",
                c.class.words(),
                c.chi2_per_line,
                c.lines,
                100.0 * c.share
            )
        })
        .collect();
    let bands: Vec<String> = r
        .by_band
        .iter()
        .map(|b| format!("{:.1}-{:.1} Hz {:.2}", b.from_hz, b.to_hz, b.chi2_per_line))
        .collect();
    let strongest: Vec<String> = r
        .strongest
        .iter()
        .map(|l| {
            format!(
                "{:.3} Hz ({}, {}) {:.1}",
                l.frequency_hz,
                l.class.words(),
                l.recording,
                l.in_noise
            )
        })
        .collect();
    let _ = writeln!(
        s,
        "chi2 per line (1: the noise) {:.2} over {} lines; by class: {}; by band: {}; the \
         strongest lines (|residual| / noise): {}.",
        r.chi2_per_line,
        r.lines,
        classes.join(", "),
        bands.join(", "),
        strongest.join(", ")
    );
    s
}
