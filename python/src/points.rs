//! `identify_points`: the binding of `hystid identify-points`.

use super::progress::Progress;
use super::reduction::ReductionJson;
use super::{err, from_json, to_json};
use hystid::analysis::points::{PointsRequest, identify_points as run};
use pyo3::prelude::*;

/// A structure seen at several sensors and one joint, fitted to every
/// sensor's FRFs at once from recordings on disk, its files written into
/// `out`: points.json as text.
#[pyfunction]
#[pyo3(signature = (recordings, out, responses, drive, joint, law, band_hz, modes, outside_hz, reduction, progress = None))]
#[allow(clippy::too_many_arguments)]
pub(super) fn identify_points(
    py: Python<'_>,
    recordings: Vec<String>,
    out: String,
    responses: Vec<String>,
    drive: Option<String>,
    joint: String,
    law: String,
    band_hz: Option<String>,
    modes: usize,
    outside_hz: Vec<f64>,
    reduction: String,
    progress: Option<Py<PyAny>>,
) -> PyResult<String> {
    let reduction: ReductionJson = from_json("reduction", &reduction)?;
    let request = PointsRequest {
        recordings: recordings.iter().map(Into::into).collect(),
        drive: drive.unwrap_or_else(|| responses.first().cloned().unwrap_or_default()),
        responses,
        joint,
        law,
        band_hz,
        modes,
        outside_hz,
        reduction: reduction.options()?,
    };
    request.validate().map_err(err)?;
    let out = std::path::PathBuf::from(out);
    let _claim = hystid::atomic::OutDir::claim(&out).map_err(err)?;
    let progress = Progress::new(progress);
    let report = progress.run(py, || run(&request, &out, &progress))?;
    to_json(&report)
}
