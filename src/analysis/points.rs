//! `identify-points`: a structure seen at several sensors and one joint,
//! fitted to every sensor's FRFs at every level at once
//! ([`crate::fit::points`]).
//!
//! Each recording is reduced once per response channel, every channel over
//! the same force lines (a sweep's compensation is the drive point's, so
//! the lines agree), cut to the band and weighted by its level's RMS
//! ([`Weighting::None`]). The start comes from the data alone
//! ([`joint_start`]); the fit is [`fit_points`]. The result is
//! `points.json`, `points.md` and one FRF figure per sensor.

mod output;

use super::recording::{ChannelChoice, Compensation, ReductionOptions, SweptReading, reduce_path};
use super::request::{parse_joint, parse_range};
use crate::error::{Error, Result};
use crate::extract::NonlinearFrf;
use crate::fit::Weighting;
use crate::fit::points::{
    JointPlacement, PointFit, PointFitOptions, PointMeasurement, StartPlan, fit_points,
    frf_errors_percent, joint_start, predict_points,
};
use crate::model::{ElementKind, PointModes};
use crate::observe::{Observer, progress};
use serde::Serialize;
use std::path::{Path, PathBuf};

/// What `identify-points` is asked.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct PointsRequest {
    /// Recordings, each holding the force and every response channel.
    pub recordings: Vec<PathBuf>,
    /// The response channels, one per sensor, in point order.
    pub responses: Vec<String>,
    /// The response channel at the drive point.
    pub drive: String,
    /// Where the joint acts: `A:B` (two responses), `A:ground`, or `own`
    /// (a coordinate no sensor reads, to the ground).
    pub joint: String,
    /// The joint's law (`jenkins`, `masing`, `iwan4`, ...).
    pub law: String,
    /// The band fitted, `LO:HI` Hz (all lines when `None`).
    pub band_hz: Option<String>,
    /// Modes at the band's peaks.
    pub modes: usize,
    /// Modes held outside the band (Hz): the rest of the structure.
    pub outside_hz: Vec<f64>,
    /// How each response is reduced (a sweep's compensation is then the
    /// drive point's for every response).
    pub reduction: ReductionOptions,
}

/// A request whose options were checked.
#[derive(Clone, Debug, PartialEq)]
pub struct CheckedPoints {
    drive: usize,
    placement: JointPlacement,
    law: ElementKind,
    band_hz: (f64, f64),
}

impl PointsRequest {
    /// Checks every option before any work.
    pub fn validate(&self) -> Result<CheckedPoints> {
        if self.recordings.is_empty() {
            return Err(Error::option("recordings", "give at least one recording"));
        }
        if self.responses.len() < 2 {
            return Err(Error::option(
                "responses",
                "give two response channels or more (a single one is `identify`)",
            ));
        }
        let index = |name: &str, option: &str| {
            self.responses
                .iter()
                .position(|r| r == name)
                .ok_or_else(|| {
                    Error::option(
                        option,
                        format!(
                            "`{name}` is not one of the responses ({})",
                            self.responses.join(", ")
                        ),
                    )
                })
        };
        let drive = index(&self.drive, "drive")?;
        let placement = match self.joint.split_once(':') {
            _ if self.joint == "own" => JointPlacement::OwnCoordinate,
            Some((a, "ground")) => JointPlacement::Between(index(a, "joint")?, None),
            Some((a, b)) if a != b => {
                JointPlacement::Between(index(a, "joint")?, Some(index(b, "joint")?))
            }
            _ => {
                return Err(Error::option(
                    "joint",
                    format!("expected A:B, A:ground or own, got `{}`", self.joint),
                ));
            }
        };
        if self.modes == 0 || self.modes > 8 {
            return Err(Error::option("modes", "between 1 and 8 modes at peaks"));
        }
        if let Some(f) = self
            .outside_hz
            .iter()
            .find(|f| !(f.is_finite() && **f > 0.0))
        {
            return Err(Error::option("outside_hz", format!("a mode at {f} Hz")));
        }
        let band_hz = match &self.band_hz {
            Some(b) => parse_range(b, "band_hz", "Hz")?,
            None => (0.0, f64::INFINITY),
        };
        Ok(CheckedPoints {
            drive,
            placement,
            law: parse_joint(&self.law)?,
            band_hz,
        })
    }
}

/// One sensor's fit quality at one level.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct SensorError {
    /// The response channel.
    pub response: String,
    /// The level's nominal drive.
    pub level: f64,
    /// RMS `|H_model − H_measured|` over RMS `|H_measured|`, % (a line the
    /// model could not solve counts as predicting nothing).
    pub frf_error_percent: f64,
}

/// What `identify-points` found: `points.json`.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct PointsReport {
    /// hystid's version.
    pub version: &'static str,
    /// The recordings, as given.
    pub recordings: Vec<PathBuf>,
    /// The response channels, in point order.
    pub responses: Vec<String>,
    /// The joint's law, its ends (`points` indices; `null`: the ground)
    /// and parameters, in the drive's units at the joint's coordinate.
    pub joint: JointReport,
    /// The structure beside the joint: its points (the responses, then the
    /// joint's own coordinate if it has one) and modes.
    pub structure: PointModes,
    /// Each sensor's FRF error at each level.
    pub errors: Vec<SensorError>,
    /// The fit: weighted residual RMS at its start and end, lines not
    /// solved, parameters at a bound, whether it was restarted.
    pub fit: FitSummary,
    /// The files written.
    pub files: Vec<PathBuf>,
}

/// The fitted joint.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct JointReport {
    /// Its law.
    pub law: &'static str,
    /// Its ends.
    pub ends: (usize, Option<usize>),
    /// Its parameters by name.
    pub parameters: Vec<(&'static str, f64)>,
}

impl PointsReport {
    /// The joint in words: `masing joint from a2 to the ground: kd =
    /// 1.2e6, fd = 3.4e1, n = 8.9e0`.
    pub fn joint_in_words(&self) -> String {
        let name = |p: usize| self.structure.points[p].clone();
        let to = self.joint.ends.1.map_or("the ground".to_string(), name);
        let values: Vec<String> = (self.joint.parameters.iter())
            .map(|(n, v)| format!("{n} = {v:.4e}"))
            .collect();
        format!(
            "{} joint from {} to {to}: {}",
            self.joint.law,
            name(self.joint.ends.0),
            values.join(", ")
        )
    }
}

/// How the fit went.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct FitSummary {
    /// Weighted residual RMS at the start.
    pub start_rms: f64,
    /// The same at the end.
    pub residual_rms: f64,
    /// Lines whose balance did not converge at the end.
    pub failed_lines: usize,
    /// Joint parameters that ended at a bound of their range.
    pub at_bounds: Vec<String>,
    /// Whether the fit was run again with those held at their bound.
    pub restarted: bool,
    /// Residual evaluations.
    pub evaluations: usize,
}

/// Reduces, starts, fits and writes into `out` (which must exist).
pub fn identify_points(
    request: &PointsRequest,
    out: &Path,
    observer: &dyn Observer,
) -> Result<PointsReport> {
    let checked = request.validate()?;
    let (data, frfs) = measurements(request, &checked, observer)?;
    progress(observer, "fitting", 0, 1)?;
    let plan = StartPlan {
        points: request.responses.clone(),
        drive: checked.drive,
        modes: (request.modes, &request.outside_hz),
        law: checked.law,
        placement: checked.placement,
    };
    let (structure, joint) = joint_start(&data, &plan)?;
    let fit = fit_points(
        &data,
        &structure,
        checked.drive,
        &joint,
        &PointFitOptions::default(),
        observer,
    )?;
    progress(observer, "fitting", 1, 1)?;
    let predicted = predict_points(
        &data,
        &fit.structure,
        checked.drive,
        &fit.joint,
        &PointFitOptions::default(),
    )?;
    let mut report = report_of(request, &fit, sensor_errors(request, &data, &predicted));
    report.files = output::write(out, &report, &frfs, &data, &predicted)?;
    Ok(report)
}

/// Every sensor's measurement over every recording's levels, and the
/// reduced FRFs in the band, `[sensor][recording]`.
fn measurements(
    request: &PointsRequest,
    checked: &CheckedPoints,
    observer: &dyn Observer,
) -> Result<(Vec<PointMeasurement>, Vec<Vec<NonlinearFrf>>)> {
    let sensors = request.responses.len();
    let mut frfs: Vec<Vec<NonlinearFrf>> = vec![Vec::new(); sensors];
    let total = (request.recordings.len() * sensors) as u64;
    for (r, path) in request.recordings.iter().enumerate() {
        let (reduced, _) = reduce_sensors(path, request, checked, |done| {
            progress(observer, "reducing", (r * sensors + done) as u64, total)
        })?;
        for (p, frf) in reduced.into_iter().enumerate() {
            frfs[p].push(frf);
        }
    }
    let data = frfs
        .iter()
        .enumerate()
        .map(|(p, by_recording)| {
            let mut merged = by_recording[0].clone();
            for f in &by_recording[1..] {
                merged.levels.extend(f.levels.iter().cloned());
            }
            PointMeasurement::from_frf(p, &merged, Weighting::None)
                .map_err(|e| Error::input(&request.responses[p], format!("{e}")))
        })
        .collect::<Result<Vec<_>>>()?;
    Ok((data, frfs))
}

/// One recording reduced at every sensor as [`identify_points`] reduces
/// it: each response's FRFs cut to the band, in the order of
/// `request.responses`, and the drive point's sweep reading when the
/// recording was swept (its compensation is every sensor's). For callers
/// that fit or judge the sensors otherwise; `request.recordings` is not
/// read.
pub fn reduce_at_sensors(
    path: &Path,
    request: &PointsRequest,
) -> Result<(Vec<NonlinearFrf>, Option<SweptReading>)> {
    let request = PointsRequest {
        recordings: vec![path.to_path_buf()],
        ..request.clone()
    };
    let checked = request.validate()?;
    reduce_sensors(path, &request, &checked, |_| Ok(()))
}

/// `path` reduced at every response, the drive point's first (its sweep
/// compensation then holds for all), each cut to the band; with the drive
/// point's sweep reading.
fn reduce_sensors(
    path: &Path,
    request: &PointsRequest,
    checked: &CheckedPoints,
    done: impl Fn(usize) -> Result<()>,
) -> Result<(Vec<NonlinearFrf>, Option<SweptReading>)> {
    let mut options = request.reduction.clone();
    let silent = &crate::observe::Silent;
    let one = |name: &str, options: &ReductionOptions| {
        reduce_path(path, ChannelChoice::response(Some(name)), options, silent)
    };
    let first = one(&request.drive, &options)?;
    if let Some(c) = first.sweep.as_ref().and_then(|s| s.compensation_s) {
        options.compensation = Compensation::Seconds(c);
    }
    let mut out = Vec::with_capacity(request.responses.len());
    for (p, name) in request.responses.iter().enumerate() {
        let mut frf = if p == checked.drive {
            first.frf.clone()
        } else {
            one(name, &options)?.frf
        };
        for l in &mut frf.levels {
            l.points
                .retain(|x| (checked.band_hz.0..=checked.band_hz.1).contains(&x.frequency_hz));
        }
        if frf.levels.iter().all(|l| l.points.is_empty()) {
            return Err(Error::input(
                path.display().to_string(),
                format!("response `{name}`: no line inside the band"),
            ));
        }
        out.push(frf);
        done(p + 1)?;
    }
    Ok((out, first.sweep))
}

/// Each sensor's FRF error at each level.
fn sensor_errors(
    request: &PointsRequest,
    data: &[PointMeasurement],
    predicted: &[Vec<Option<Vec<num_complex::Complex64>>>],
) -> Vec<SensorError> {
    let errors = frf_errors_percent(data, predicted);
    let mut out = Vec::new();
    for (m, by_level) in errors.iter().enumerate() {
        for (level, e) in data[m].levels.iter().zip(by_level) {
            out.push(SensorError {
                response: request.responses[m].clone(),
                level: level.level,
                frf_error_percent: *e,
            });
        }
    }
    out
}

fn report_of(request: &PointsRequest, fit: &PointFit, errors: Vec<SensorError>) -> PointsReport {
    PointsReport {
        version: super::VERSION,
        recordings: request.recordings.clone(),
        responses: request.responses.clone(),
        joint: JointReport {
            law: fit.joint.law.kind().name(),
            ends: fit.joint.ends,
            parameters: fit.joint.law.parameters(),
        },
        structure: fit.structure.clone(),
        errors,
        fit: FitSummary {
            start_rms: fit.start_rms,
            residual_rms: fit.residual_rms,
            failed_lines: fit.failed_lines,
            at_bounds: fit.at_bounds.clone(),
            restarted: fit.restarted,
            evaluations: fit.run.evaluations,
        },
        files: Vec::new(),
    }
}
