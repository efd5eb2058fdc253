//! `hystid._hystid`: the native half of the Python package.
//!
//! Every function calls the library as the command line does (`hystid::sim`,
//! `hystid::analysis`, `hystid::fit`, `hystid::diagnose`) and hands back what
//! the command writes: reports as JSON text (the same serialisation, so the
//! same field names and numbers; `hystid/__init__.py` turns them into dicts)
//! and signals as numpy arrays. Arrays come in as read-only views (no copy
//! for `simulate`) and results are moved into numpy (no copy). The GIL is
//! released while the library works. Errors are `hystid.HystidError`
//! (a `ValueError`) with the message the command line prints.

mod points;
mod progress;
mod reduction;

use progress::Progress;
use reduction::ReductionJson;

use hystid::analysis::diagnose::DiagnoseRequest;
use hystid::analysis::diagnose::{DiagnosisReport, TimeOutcome, refine_in_time};
use hystid::analysis::identify::IdentifyRequest;
use hystid::analysis::recording::ReplayReduction;
use hystid::analysis::request::{FitDomain, parse_candidates};
use hystid::analysis::run::FinalModel;
use hystid::analysis::validate::{
    FitModel, RecordingValidation, ValidateReport, ValidateRequest, ValidationSettings,
    validate_loaded,
};
use hystid::analysis::{FitReport, Loaded, reduce};
use hystid::diagnose::Effect;
use hystid::fit::{FitOptions, TimeFitOptions, TimeRecord};
use hystid::harmonics::Quantity;
use hystid::model::Model;
use hystid::sim::Output;
use hystid::testbench::{DEFAULT_TEST, TestDefinition};
use numpy::{IntoPyArray, PyArray1, PyReadonlyArray1};
use pyo3::create_exception;
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use serde::Deserialize;
use serde::de::DeserializeOwned;
use std::path::Path;
use std::sync::Mutex;

create_exception!(
    hystid,
    HystidError,
    PyValueError,
    "An error of the hystid library; its message names the file, field or stage, as the command line prints it."
);

/// The library's error as a `HystidError`, with its causes on one line.
fn err(e: hystid::Error) -> PyErr {
    match e {
        hystid::Error::TimeDomainOnly { option, why } => HystidError::new_err(format!(
            "{option}: {why}; give the time histories as recordings=[...]"
        )),
        e => HystidError::new_err(hystid::error::one_line(&e)),
    }
}

fn fail(message: impl Into<String>) -> PyErr {
    HystidError::new_err(message.into())
}

/// The time-domain fits' options the bindings take: how the model is
/// replayed, the fewest samples per period, the starts, the samples judged
/// and the response's acquisition chain (JSON); the request they go into
/// checks them.
fn time_fit_options(
    min_samples_per_period: f64,
    replay: &str,
    starts: usize,
    max_judged_samples: usize,
    acquisition: Option<&str>,
) -> PyResult<TimeFitOptions> {
    Ok(TimeFitOptions {
        min_samples_per_period,
        input: self::replay(replay)?,
        starts,
        max_judged_samples,
        acquisition: acquisition
            .map(|text| from_json("acquisition", text))
            .transpose()?,
        ..TimeFitOptions::default()
    })
}

/// A replay's name (`band_limited`, `continuous`, `ramp`) as the library
/// reads it.
fn replay(name: &str) -> PyResult<hystid::validate::DriveInput> {
    from_json("replay", &serde_json::Value::from(name).to_string())
}

fn to_json(value: &impl serde::Serialize) -> PyResult<String> {
    serde_json::to_string(value).map_err(|e| fail(format!("cannot serialise the result: {e}")))
}

fn from_json<T: DeserializeOwned>(what: &str, text: &str) -> PyResult<T> {
    serde_json::from_str(text).map_err(|e| fail(format!("{what}: {e}")))
}

fn quantity(what: &str, name: &str) -> PyResult<Quantity> {
    Quantity::from_name(name).ok_or_else(|| {
        fail(format!(
            "{what}: unknown quantity `{name}` (force, voltage, displacement, velocity or acceleration)"
        ))
    })
}

fn slice<'a>(what: &str, a: &'a PyReadonlyArray1<'_, f64>) -> PyResult<&'a [f64]> {
    a.as_slice()
        .map_err(|e| fail(format!("{what}: {e} (pass a contiguous float64 array)")))
}

/// A structural model: the underlying linear modes and the elements at the
/// joint (fit.json's `model`).
#[pyclass(frozen, module = "hystid", name = "Model")]
#[derive(Clone)]
struct PyModel {
    inner: Model,
}

#[pymethods]
impl PyModel {
    /// The model of a test definition's TOML text, or of its structure
    /// alone (`[system]` or `[[modes]]`, `[joint]`, `[[effects]]`).
    #[staticmethod]
    #[pyo3(signature = (text, origin = None))]
    fn from_toml(text: String, origin: Option<String>) -> PyResult<Self> {
        let origin = origin.unwrap_or_else(|| "test definition".into());
        let inner = hystid::testbench::model_from_toml(&text, &origin).map_err(err)?;
        Ok(PyModel { inner })
    }

    /// A model in its JSON form (fit.json's `model`: `linear`, `elements`).
    #[staticmethod]
    fn from_json(text: String) -> PyResult<Self> {
        let inner: Model = from_json("model", &text)?;
        inner.validate().map_err(err)?;
        Ok(PyModel { inner })
    }

    /// The model's JSON form (fit.json's `model`).
    fn to_json(&self) -> PyResult<String> {
        to_json(&self.inner)
    }

    /// The highest frequency the linearised structure can ring at, Hz (a
    /// sample rate must be well above it).
    #[getter]
    fn highest_linearised_frequency_hz(&self) -> f64 {
        self.inner.highest_linearised_frequency_hz()
    }

    fn __eq__(&self, other: &Self) -> bool {
        self.inner == other.inner
    }

    fn __repr__(&self) -> PyResult<String> {
        Ok(format!("hystid.Model({})", to_json(&self.inner)?))
    }
}

/// A test definition's JSON (a dict) as TOML text, so that it is read and
/// checked exactly as a file is.
#[pyfunction]
fn json_to_toml(text: String) -> PyResult<String> {
    let value: serde_json::Value = from_json("test definition", &text)?;
    toml::to_string(&value).map_err(|e| fail(format!("test definition: {e}")))
}

/// A range given as the command line writes it (`"LO:HI"`) or as a pair,
/// checked as the command line checks it: `0 <= LO < HI`; `option` names it
/// in the refusal.
#[pyfunction]
fn range_option(range: Bound<'_, PyAny>, option: String, unit: String) -> PyResult<(f64, f64)> {
    use hystid::analysis::request::{check_range, parse_range};
    if let Ok(text) = range.extract::<String>() {
        return parse_range(&text, &option, &unit).map_err(err);
    }
    let pair: (f64, f64) = range.extract().map_err(|_| {
        fail(format!(
            "{option}: expected (LO, HI) or \"LO:HI\" in {unit}, got {range}"
        ))
    })?;
    check_range(pair, &option).map_err(err)?;
    Ok(pair)
}

fn output(name: &str) -> PyResult<Output> {
    Output::from_name(name).ok_or_else(|| {
        let names: Vec<&str> = Output::ALL.iter().map(|o| o.name()).collect();
        fail(format!(
            "output: expected one of {}, got `{name}`",
            names.join(", ")
        ))
    })
}

/// `model` driven from rest by `force` sampled at `sample_rate_hz`: one
/// output (`displacement`, `velocity`, `acceleration`, `element_force`).
#[pyfunction]
#[pyo3(signature = (model, force, sample_rate_hz, output_name = "displacement".to_string(), progress = None))]
fn simulate<'py>(
    py: Python<'py>,
    model: PyRef<'py, PyModel>,
    force: PyReadonlyArray1<'py, f64>,
    sample_rate_hz: f64,
    output_name: String,
    progress: Option<Py<PyAny>>,
) -> PyResult<Bound<'py, PyArray1<f64>>> {
    let which = output(&output_name)?;
    let f = slice("force", &force)?;
    let m = &model.inner;
    let progress = Progress::new(progress);
    let y = progress.run_simulation(py, f.len(), || {
        hystid::sim::simulate(m, f, sample_rate_hz, which, &progress)
    })?;
    Ok(y.into_pyarray(py))
}

/// Every output of [`simulate`], in `Output::ALL`'s order.
#[pyfunction]
#[pyo3(signature = (model, force, sample_rate_hz, progress = None))]
#[allow(clippy::type_complexity)]
fn simulate_all<'py>(
    py: Python<'py>,
    model: PyRef<'py, PyModel>,
    force: PyReadonlyArray1<'py, f64>,
    sample_rate_hz: f64,
    progress: Option<Py<PyAny>>,
) -> PyResult<Vec<Bound<'py, PyArray1<f64>>>> {
    let f = slice("force", &force)?;
    let m = &model.inner;
    let progress = Progress::new(progress);
    let r = progress.run_simulation(py, f.len(), || {
        hystid::sim::simulate_all(m, f, sample_rate_hz, &progress)
    })?;
    Ok(vec![
        r.displacement.into_pyarray(py),
        r.velocity.into_pyarray(py),
        r.acceleration.into_pyarray(py),
        r.element_force.into_pyarray(py),
    ])
}

/// The simulator of a model with its elements.
type ModelSimulator = hystid::sim::Simulator<hystid::model::ElementSet<hystid::model::AnyElement>>;

/// A simulation that carries its state from one `run` to the next: a
/// record fed in blocks (from a DAQ, a co-simulation, a file read in
/// pieces) gives the samples one `simulate` of the whole gives.
#[pyclass(module = "hystid", name = "Simulation")]
struct PySimulation {
    /// Behind a lock for pyo3 (a Python object may be shared between
    /// threads; `run` takes `&mut self` anyway).
    sim: Mutex<ModelSimulator>,
    sample_rate_hz: f64,
    /// Samples run since rest.
    samples: u64,
    /// Why the state is not one a run may continue from: a run that
    /// stopped inside its block (interrupted, or the solve failed) left it
    /// part-way.
    broken: Option<String>,
}

impl PySimulation {
    /// Runs `work` on the block of `n` samples, unless a run before broke
    /// the state; a run that fails breaks it.
    fn block<T: Send>(
        &mut self,
        py: Python<'_>,
        n: usize,
        progress: Option<Py<PyAny>>,
        work: impl FnOnce(&mut ModelSimulator, &Progress) -> hystid::Result<T> + Send,
    ) -> PyResult<T> {
        if let Some(why) = &self.broken {
            return Err(fail(format!(
                "the simulation stopped inside the run that started at sample {} ({why}): its \
                 state is part-way through that block; call reset() to start again from rest",
                self.samples
            )));
        }
        let progress = Progress::new(progress);
        let mut guard = self.sim.lock().unwrap_or_else(|e| e.into_inner());
        let sim = &mut *guard;
        let p = &progress;
        let result = progress.run_simulation(py, n, move || work(sim, p));
        drop(guard);
        match result {
            Ok(y) => {
                self.samples += n as u64;
                Ok(y)
            }
            Err(e) => {
                self.broken = Some(e.to_string());
                Err(e)
            }
        }
    }
}

#[pymethods]
impl PySimulation {
    #[new]
    fn new(model: PyRef<'_, PyModel>, sample_rate_hz: f64) -> PyResult<Self> {
        let m = &model.inner;
        m.validate().map_err(err)?;
        let sim = ModelSimulator::new(&m.linear, m.element_set().map_err(err)?, sample_rate_hz)
            .map_err(err)?;
        Ok(PySimulation {
            sim: Mutex::new(sim),
            sample_rate_hz,
            samples: 0,
            broken: None,
        })
    }

    /// The response to the next block of `force`: one output.
    #[pyo3(signature = (force, output_name = "displacement".to_string(), progress = None))]
    fn run<'py>(
        &mut self,
        py: Python<'py>,
        force: PyReadonlyArray1<'py, f64>,
        output_name: String,
        progress: Option<Py<PyAny>>,
    ) -> PyResult<Bound<'py, PyArray1<f64>>> {
        let which = output(&output_name)?;
        let f = slice("force", &force)?;
        let y = self.block(py, f.len(), progress, |sim, p| {
            let mut out = vec![0.0; f.len()];
            sim.run_output(f, which, &mut out, p).map(|_| out)
        })?;
        Ok(y.into_pyarray(py))
    }

    /// Every output of [`PySimulation::run`], in `Output::ALL`'s order.
    #[pyo3(signature = (force, progress = None))]
    fn run_all<'py>(
        &mut self,
        py: Python<'py>,
        force: PyReadonlyArray1<'py, f64>,
        progress: Option<Py<PyAny>>,
    ) -> PyResult<Vec<Bound<'py, PyArray1<f64>>>> {
        let f = slice("force", &force)?;
        let r = self.block(py, f.len(), progress, |sim, p| sim.run(f, p))?;
        Ok(vec![
            r.displacement.into_pyarray(py),
            r.velocity.into_pyarray(py),
            r.acceleration.into_pyarray(py),
            r.element_force.into_pyarray(py),
        ])
    }

    /// Back to rest (and a broken state forgotten).
    fn reset(&mut self) {
        self.sim.lock().unwrap_or_else(|e| e.into_inner()).reset();
        self.samples = 0;
        self.broken = None;
    }

    /// Samples run since rest.
    #[getter]
    fn samples(&self) -> u64 {
        self.samples
    }

    #[getter]
    fn sample_rate_hz(&self) -> f64 {
        self.sample_rate_hz
    }
}

/// The seconds the library's own `simulate` takes on `force` (timed in
/// Rust, without Python): the reference of the overhead benchmark.
#[pyfunction]
#[pyo3(signature = (model, force, sample_rate_hz, output_name = "displacement".to_string()))]
fn _rust_simulate_seconds<'py>(
    py: Python<'py>,
    model: PyRef<'py, PyModel>,
    force: PyReadonlyArray1<'py, f64>,
    sample_rate_hz: f64,
    output_name: String,
) -> PyResult<f64> {
    let which = output(&output_name)?;
    let f = slice("force", &force)?;
    let m = &model.inner;
    py.detach(|| {
        let t0 = std::time::Instant::now();
        let y = hystid::sim::simulate(m, f, sample_rate_hz, which, &hystid::observe::Silent)?;
        let s = t0.elapsed().as_secs_f64();
        drop(y);
        Ok(s)
    })
    .map_err(err)
}

/// A virtual stepped-sine test of a definition (TOML text; the embedded
/// default when `None`), in memory: `(definition text, recording.json,
/// frf.json, summary.json, hb_check.json or None, the recorded channels)`.
#[pyfunction]
#[pyo3(signature = (text = None, origin = None, check_hb = false, progress = None))]
#[allow(clippy::type_complexity)]
fn virtual_test<'py>(
    py: Python<'py>,
    text: Option<String>,
    origin: Option<String>,
    check_hb: bool,
    progress: Option<Py<PyAny>>,
) -> PyResult<(
    String,
    String,
    String,
    String,
    Option<String>,
    Vec<Bound<'py, PyArray1<f32>>>,
)> {
    let text = text.unwrap_or_else(|| DEFAULT_TEST.to_string());
    let origin = origin.unwrap_or_else(|| "test definition".into());
    let def = TestDefinition::from_toml(&text, &origin).map_err(err)?;
    let progress = Progress::new(progress);
    let t = progress.run(py, || {
        hystid::analysis::simulate::simulate_in_memory(&def, &text, check_hb, &progress)
    });
    let t = t?;
    let hb = t.hb_checks.as_ref().map(to_json).transpose()?;
    let out = (
        to_json(&t.meta)?,
        to_json(&t.run.frf)?,
        to_json(&t.summary)?,
        hb,
    );
    let channels = t.channels.into_iter().map(|c| c.into_pyarray(py)).collect();
    Ok((text, out.0, out.1, out.2, out.3, channels))
}

/// A force (or voltage) and a response sampled at `sample_rate_hz` as a
/// loaded recording; `excitation` is recording.json's section of that name.
fn loaded(
    reference: &PyReadonlyArray1<'_, f64>,
    reference_quantity: &str,
    response: &PyReadonlyArray1<'_, f64>,
    response_quantity: &str,
    sample_rate_hz: f64,
    excitation: &str,
) -> PyResult<Loaded> {
    let excitation: hystid::record::Excitation = from_json("excitation", excitation)?;
    Loaded::from_signals(
        slice("reference", reference)?.to_vec(),
        quantity("reference_quantity", reference_quantity)?,
        slice("response", response)?.to_vec(),
        quantity("response_quantity", response_quantity)?,
        sample_rate_hz,
        excitation,
    )
    .map_err(err)
}

/// Recordings as a multisine's start reads them, each with its name: the
/// reference and response held as a file's are (a long one in a scratch
/// file, not in memory).
fn held(
    names: Vec<String>,
    loaded: Vec<Loaded>,
) -> hystid::Result<Vec<(String, hystid::analysis::HeldRecording)>> {
    names
        .into_iter()
        .zip(loaded)
        .map(|(name, l)| Ok((name, hystid::analysis::HeldRecording::of_loaded(l)?)))
        .collect()
}

/// Nonlinear FRFs (frf.json) of a reference and a response.
#[pyfunction]
#[pyo3(signature = (reference, reference_quantity, response, response_quantity, sample_rate_hz, excitation, reduction, progress = None))]
#[allow(clippy::too_many_arguments)]
fn extract<'py>(
    py: Python<'py>,
    reference: PyReadonlyArray1<'py, f64>,
    reference_quantity: String,
    response: PyReadonlyArray1<'py, f64>,
    response_quantity: String,
    sample_rate_hz: f64,
    excitation: String,
    reduction: String,
    progress: Option<Py<PyAny>>,
) -> PyResult<String> {
    let options = from_json::<ReductionJson>("reduction", &reduction)?.options()?;
    let loaded = loaded(
        &reference,
        &reference_quantity,
        &response,
        &response_quantity,
        sample_rate_hz,
        &excitation,
    )?;
    let progress = Progress::new(progress);
    let red = progress.run(py, || reduce(&loaded, &options, &progress))?;
    to_json(&red.frf)
}

/// Fit options: the library's defaults with the given fields replaced
/// (unknown fields are errors that name them); the request they go into
/// checks them.
fn fit_options(text: &str) -> PyResult<FitOptions> {
    let given: serde_json::Map<String, serde_json::Value> = from_json("fit options", text)?;
    let mut value = serde_json::to_value(FitOptions::default())
        .map_err(|e| fail(format!("fit options: {e}")))?;
    let fields = value.as_object_mut().expect("FitOptions is a JSON object");
    let known: Vec<String> = fields
        .keys()
        .cloned()
        .chain(["extra_modes".into()])
        .collect();
    for (k, v) in given {
        if !known.contains(&k) {
            return Err(fail(format!(
                "fit options: unknown option `{k}` (known: {})",
                known.join(", ")
            )));
        }
        let mut one = fields.clone();
        one.insert(k.clone(), v.clone());
        if let Err(e) = serde_json::from_value::<FitOptions>(one.into()) {
            return Err(fail(format!("fit options: `{k}`: {e}")));
        }
        fields.insert(k, v);
    }
    serde_json::from_value(value).map_err(|e| fail(format!("fit options: {e}")))
}

/// Names as a request's recordings.
fn paths(names: &[String]) -> Vec<std::path::PathBuf> {
    names.iter().map(std::path::PathBuf::from).collect()
}

/// fit.json's `recording`, a list, of the one path given (none: empty).
fn listed(recording: String) -> Vec<String> {
    (!recording.is_empty())
        .then_some(recording)
        .into_iter()
        .collect()
}

/// Fits a joint model to nonlinear FRFs (frf.json): fit.json.
#[pyfunction]
#[pyo3(signature = (frf, options, reference = None, recording = String::new(), response = None, progress = None))]
fn identify<'py>(
    py: Python<'py>,
    frf: String,
    options: String,
    reference: Option<PyRef<'py, PyModel>>,
    recording: String,
    response: Option<String>,
    progress: Option<Py<PyAny>>,
) -> PyResult<String> {
    let frf: hystid::extract::NonlinearFrf = from_json("frf", &frf)?;
    let options = fit_options(&options)?;
    IdentifyRequest::new(paths(&listed(recording.clone())), options.clone())
        .validate()
        .map_err(err)?;
    let reference = reference.and_then(|m| m.inner.joint);
    let progress = Progress::new(progress);
    let fit = progress.run(py, || {
        hystid::analysis::run_fit(&frf, &options, &progress, None)
    });
    let (fit, _) = fit?;
    let response = response.unwrap_or_else(|| frf.response.name().to_string());
    let report = FitReport::new(listed(recording), response, fit, reference, Vec::new());
    to_json(&report)
}

/// A model written down fitted to nonlinear FRFs as it stands (`hystid
/// identify --start MODEL`): fit.json with its `frequency_domain`.
#[pyfunction]
#[pyo3(signature = (frf, start, options, response_sign = 1.0, recording = String::new(), response = None, progress = None))]
#[allow(clippy::too_many_arguments)]
fn identify_declared<'py>(
    py: Python<'py>,
    frf: String,
    start: PyRef<'py, PyModel>,
    options: String,
    response_sign: f64,
    recording: String,
    response: Option<String>,
    progress: Option<Py<PyAny>>,
) -> PyResult<String> {
    let frf: hystid::extract::NonlinearFrf = from_json("frf", &frf)?;
    let options = fit_options(&options)?;
    IdentifyRequest {
        start: Some("start".into()),
        response_sign: Some(response_sign),
        ..IdentifyRequest::new(paths(&listed(recording.clone())), options.clone())
    }
    .validate()
    .map_err(err)?;
    let model = start.inner.clone();
    let progress = Progress::new(progress);
    let report = progress.run(py, || {
        hystid::analysis::identify::DeclaredFitReport::fit(
            &frf,
            &model,
            response_sign,
            &options,
            listed(recording),
            response.unwrap_or_default(),
            &progress,
        )
    })?;
    to_json(&report)
}

/// The candidates named as `--candidates` takes them (none: the default
/// set).
fn candidates_of(names: Option<Vec<String>>) -> PyResult<Vec<Effect>> {
    match names {
        None => Ok(Effect::defaults()),
        Some(c) => parse_candidates(&c).map_err(err),
    }
}

/// The recordings a diagnosis refines its final model on in the time domain
/// (`diagnose --domain time` on stepped and swept sines), and how: the
/// reduction their replays are read with (extract's), the replay, the first
/// refit's starts, the upsampling threshold, the candidates put to the
/// time histories and the most samples a fit judges.
#[derive(FromPyObject)]
#[pyo3(from_item_all)]
struct TimeRecordings<'py> {
    /// None: the options as given, for the request to refuse those that
    /// need the time histories.
    recordings: Option<Recordings<'py>>,
    reduction: String,
    replay: String,
    starts: usize,
    min_samples_per_period: f64,
    time_proposals: usize,
    max_judged_samples: usize,
    /// The response's acquisition chain (JSON), or none.
    acquisition: Option<String>,
    /// Whether the final refit's recordings are each refitted alone.
    each_alone: bool,
}

/// Diagnoses a fit of nonlinear FRFs (fit.json, or fitted first with
/// `options`, as `hystid diagnose` does): diagnosis.json. With `time`, the
/// diagnosis's final model is then refined on the recordings' time
/// histories, as `diagnose --domain time` does.
#[pyfunction]
#[pyo3(signature = (frf, options, fit = None, candidates = None, progress = None, time = None))]
fn diagnose<'py>(
    py: Python<'py>,
    frf: String,
    options: String,
    fit: Option<String>,
    candidates: Option<Vec<String>>,
    progress: Option<Py<PyAny>>,
    time: Option<TimeRecordings<'py>>,
) -> PyResult<String> {
    let fit_opts = fit_options(&options)?;
    // the candidates re-identify with the user's fit options, as the
    // command line's diagnosis does
    let recordings = time.as_ref().and_then(|t| t.recordings.as_ref());
    let mut req = DiagnoseRequest::new(
        recordings.map_or_else(Vec::new, |r| paths(&r.names)),
        fit_opts.clone(),
        candidates_of(candidates)?,
    );
    if recordings.is_some() {
        req.domain = FitDomain::Time;
    }
    if let Some(t) = &time {
        req.diagnosis.time_proposals = t.time_proposals;
        req.time = TimeFitOptions {
            each_alone: t.each_alone,
            ..time_fit_options(
                t.min_samples_per_period,
                &t.replay,
                t.starts,
                t.max_judged_samples,
                t.acquisition.as_deref(),
            )?
        };
    }
    req.validate().map_err(err)?;
    // the options before the data, as the command checks them
    let frf: hystid::extract::NonlinearFrf = from_json("frf", &frf)?;
    let d = req.diagnosis.clone();
    let fit = match fit {
        Some(text) => Some(from_json::<FitReport>("fit", &text)?.fit),
        None => None,
    };
    // the recordings as the time refit takes them, and how it replays
    let time = match time.as_ref().and_then(|t| Some((t, t.recordings.as_ref()?))) {
        None => None,
        Some((t, recordings)) => {
            let loaded = recordings.loaded()?;
            let named: Vec<(std::path::PathBuf, Loaded)> = recordings
                .names
                .iter()
                .map(std::path::PathBuf::from)
                .zip(loaded)
                .collect();
            let reduction = from_json::<ReductionJson>("reduction", &t.reduction)?.options()?;
            Some((named, reduction, req.time.clone()))
        }
    };
    let progress = Progress::new(progress);
    let outcome = progress.run(py, || {
        let t0 = std::time::Instant::now();
        let fit = match fit {
            Some(f) => f,
            None => hystid::analysis::run_fit(&frf, &fit_opts, &progress, None)?.0,
        };
        let (mut diagnosis, predictor) =
            hystid::analysis::diagnose::run_diagnosis(&frf, &fit, &d, &progress)?;
        // a refit that fails leaves the FRF diagnosis standing, with why
        // (as the command's); an interrupt stops the call
        let time = match time {
            None => None,
            Some((named, reduction, options)) => {
                let refined =
                    ReplayReduction::from_loaded(named, &reduction).and_then(|mut replays| {
                        let records = replays.take_time_records(d.band_hz)?;
                        refine_in_time(
                            &mut diagnosis,
                            &frf,
                            &records,
                            &options,
                            d.band_hz,
                            &d,
                            &predictor,
                            Some(&replays),
                            &progress,
                        )
                    });
                Some(match refined {
                    Ok(t) => TimeOutcome::Refined(Box::new(t)),
                    Err(hystid::Error::Cancelled) => return Err(hystid::Error::Cancelled),
                    Err(e) => TimeOutcome::Failed {
                        failed: e.to_string(),
                    },
                })
            }
        };
        // the final model as reported, with its flags, as the command states it
        let final_model = FinalModel::of(
            &frf,
            &fit,
            &fit_opts.harmonics,
            d.band_hz,
            Some(&diagnosis),
            None,
            &predictor,
        )?;
        Ok((diagnosis, final_model, time, t0.elapsed().as_secs_f64()))
    });
    let (diagnosis, final_model, time, seconds) = outcome?;
    to_json(&DiagnosisReport {
        final_model: Some(&final_model),
        time_domain: time.as_ref(),
        ..DiagnosisReport::new(&diagnosis, frf.reference, seconds)
    })
}

/// How a recording is validated on (the command line's validate flags).
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct SettingsJson {
    #[serde(default)]
    band_hz: Option<(f64, f64)>,
    #[serde(default)]
    window_s: Option<(f64, f64)>,
    #[serde(default = "twenty")]
    min_samples_per_period: f64,
    #[serde(default = "yes")]
    frf: bool,
    #[serde(default)]
    periodic: bool,
    reduction: ReductionJson,
    /// `band_limited` (the default), `continuous` or `ramp` (see
    /// `hystid::validate::DriveInput`), read by [`replay`].
    #[serde(default = "band_limited")]
    replay: String,
    /// The response's acquisition chain, in place of the fit's
    /// (`--acquisition`).
    #[serde(default)]
    acquisition: Option<serde_json::Value>,
}

fn band_limited() -> String {
    "band_limited".into()
}
fn twenty() -> f64 {
    20.0
}
fn yes() -> bool {
    true
}

/// A fit (fit.json) driven by a measured force, compared with the measured
/// response: validate.json with this one recording, and the simulated
/// response.
#[pyfunction]
#[pyo3(signature = (fit, linear, reference, reference_quantity, response, response_quantity, sample_rate_hz, excitation, settings, fit_name = String::new(), recording_name = String::new(), progress = None))]
#[allow(clippy::too_many_arguments)]
fn validate<'py>(
    py: Python<'py>,
    fit: String,
    linear: bool,
    reference: PyReadonlyArray1<'py, f64>,
    reference_quantity: String,
    response: PyReadonlyArray1<'py, f64>,
    response_quantity: String,
    sample_rate_hz: f64,
    excitation: String,
    settings: String,
    fit_name: String,
    recording_name: String,
    progress: Option<Py<PyAny>>,
) -> PyResult<(String, Bound<'py, PyArray1<f64>>)> {
    let origin = if fit_name.is_empty() {
        "fit"
    } else {
        &fit_name
    };
    let mut fit = FitModel::of_json(fit.as_bytes(), linear, Path::new(origin)).map_err(err)?;
    let s: SettingsJson = from_json("settings", &settings)?;
    let req = ValidateRequest {
        fit: origin.into(),
        linear,
        recordings: vec![recording_name.clone().into()],
        acquisition: s
            .acquisition
            .map(|chain| from_json("acquisition", &chain.to_string()))
            .transpose()?,
        settings: ValidationSettings {
            input: replay(&s.replay)?,
            band_hz: s.band_hz,
            window_s: s.window_s,
            min_samples_per_period: s.min_samples_per_period,
            frf: s.frf,
            reduction: s.reduction.options()?,
            periodic: s.periodic,
        },
    };
    req.validate().map_err(err)?;
    if let Some(chain) = req.acquisition {
        fit.acquisition = Some(chain);
    }
    let settings = req.settings;
    let loaded = loaded(
        &reference,
        &reference_quantity,
        &response,
        &response_quantity,
        sample_rate_hz,
        &excitation,
    )?;
    let progress = Progress::new(progress);
    let mut v = progress.run(py, || {
        validate_loaded(&fit, &recording_name, &loaded, &settings, &progress)
    })?;
    let simulated = std::mem::take(&mut v.simulated);
    let response = loaded.recording.meta.channels[loaded.response].name.clone();
    let report = ValidateReport {
        command: "validate",
        version: hystid::analysis::VERSION,
        fit: fit_name,
        model_kind: fit.kind,
        model: &fit.model,
        response_sign: fit.response_sign,
        acquisition: fit.acquisition.as_ref(),
        recordings: vec![RecordingValidation {
            recording: recording_name,
            response,
            validation: Some(v),
            replay_failed: None,
        }],
        files: Vec::new(),
    };
    Ok((to_json(&report)?, simulated.into_pyarray(py)))
}

/// The shaker's coil (fit.json's `coil`: R, L, Bl and the shaker model's
/// terms) from a stepped recording's voltage, the force the shaker applies
/// and the drive point's motion, dwell by dwell (`excitation`: its steps).
#[pyfunction]
#[allow(clippy::too_many_arguments)]
fn fit_coil<'py>(
    py: Python<'py>,
    voltage: PyReadonlyArray1<'py, f64>,
    force: PyReadonlyArray1<'py, f64>,
    motion: PyReadonlyArray1<'py, f64>,
    motion_quantity: String,
    sample_rate_hz: f64,
    excitation: String,
) -> PyResult<String> {
    let excitation: hystid::record::Excitation = from_json("excitation", &excitation)?;
    let q = quantity("motion_quantity", &motion_quantity)?;
    let (e, f, m) = (
        slice("voltage", &voltage)?.to_vec(),
        slice("force", &force)?.to_vec(),
        slice("motion", &motion)?.to_vec(),
    );
    let coil = py
        .detach(|| hystid::fit::coil::fit_coil_of_signals(e, f, m, q, sample_rate_hz, excitation))
        .map_err(err)?;
    to_json(&coil)
}

/// The recordings of a time-domain call: one per entry of each list (a
/// dict of the lists, as the package's `_time_records` makes it).
#[derive(FromPyObject)]
#[pyo3(from_item_all)]
struct Recordings<'py> {
    references: Vec<PyReadonlyArray1<'py, f64>>,
    reference_quantities: Vec<String>,
    responses: Vec<PyReadonlyArray1<'py, f64>>,
    response_quantities: Vec<String>,
    sample_rates: Vec<f64>,
    excitations: Vec<String>,
    names: Vec<String>,
}

impl Recordings<'_> {
    /// Each recording loaded (the lists all of one length, at least one).
    fn loaded(&self) -> PyResult<Vec<Loaded>> {
        let n = self.references.len();
        if [
            self.reference_quantities.len(),
            self.responses.len(),
            self.response_quantities.len(),
            self.sample_rates.len(),
            self.excitations.len(),
            self.names.len(),
        ]
        .iter()
        .any(|&m| m != n)
            || n == 0
        {
            return Err(fail(
                "recordings: give at least one, each with its force and response",
            ));
        }
        (0..n)
            .map(|i| {
                loaded(
                    &self.references[i],
                    &self.reference_quantities[i],
                    &self.responses[i],
                    &self.response_quantities[i],
                    self.sample_rates[i],
                    &self.excitations[i],
                )
            })
            .collect()
    }
}

/// A time-domain fit (fit.json, as `hystid identify --domain time`): of
/// an FRF fit's model (`fit`, fit.json, refined as the command refines it),
/// of a model written down (`start`, as `--start`), or with neither of
/// multisine recordings from their linear estimate.
#[pyfunction]
#[pyo3(signature = (recordings, options, fit = None, start = None, fix = Vec::new(), window_s = None, min_samples_per_period = 40.0, progress = None, replay = String::from("band_limited"), starts = 1, max_judged_samples = hystid::fit::time::MAX_JUDGED_SAMPLES, acquisition = None, each_alone = false))]
#[allow(clippy::too_many_arguments)]
fn identify_time<'py>(
    py: Python<'py>,
    recordings: Recordings<'py>,
    options: String,
    fit: Option<String>,
    start: Option<PyRef<'py, PyModel>>,
    fix: Vec<String>,
    window_s: Option<(f64, f64)>,
    min_samples_per_period: f64,
    progress: Option<Py<PyAny>>,
    replay: String,
    starts: usize,
    max_judged_samples: usize,
    acquisition: Option<String>,
    each_alone: bool,
) -> PyResult<String> {
    let time_options = TimeFitOptions {
        each_alone,
        ..time_fit_options(
            min_samples_per_period,
            &replay,
            starts,
            max_judged_samples,
            acquisition.as_deref(),
        )?
    };
    let fit_opts = fit_options(&options)?;
    IdentifyRequest {
        domain: FitDomain::Time,
        start: start.as_ref().map(|_| "start".into()),
        refined_fit: fit.as_ref().map(|_| "fit".into()),
        fix: fix.clone(),
        window_s,
        time: time_options.clone(),
        ..IdentifyRequest::new(paths(&recordings.names), fit_opts.clone())
    }
    .validate()
    .map_err(err)?;
    let progress = Progress::new(progress);
    let loaded = recordings.loaded()?;
    let names = recordings.names;
    let band = fit_opts.band_hz;
    // the recordings' channels moved into their time records (the arrays
    // were copied once, into the library; not again)
    let records = |loaded: Vec<Loaded>, window_s: Option<(f64, f64)>| {
        loaded
            .into_iter()
            .zip(&names)
            .map(|(l, name)| {
                let fs = l.recording.meta.sample_rate_hz;
                let window =
                    window_s.map(|(a, b)| (a * fs).round() as usize..(b * fs).round() as usize);
                TimeRecord::from_owned_recording(name, l.recording, l.response, window, band)
            })
            .collect::<hystid::Result<Vec<TimeRecord>>>()
    };
    let recording = names.clone();
    // the response fitted to, named in fit.json as the command names it
    // (here its quantity: the arrays name no channel)
    let response = loaded
        .first()
        .map(|l| l.recording.meta.channels[l.response].name.clone())
        .unwrap_or_default();
    let text = match (fit, start) {
        // both given: refused by the request
        (Some(text), _) => {
            let mut report = from_json::<FitReport>("fit", &text)?;
            let t = progress.run(py, || {
                let records = records(loaded, None)?;
                // the replay and the starts as given; the upsampling
                // threshold is the start's and multisines' only, as on the
                // command line
                hystid::analysis::run_time_fit(
                    &report.fit,
                    &records,
                    &TimeFitOptions {
                        input: time_options.input,
                        starts: time_options.starts,
                        max_judged_samples: time_options.max_judged_samples,
                        acquisition: time_options.acquisition.clone(),
                        each_alone: time_options.each_alone,
                        ..TimeFitOptions::default()
                    },
                    band,
                    &progress,
                )
            });
            let t = t?;
            report.set_time_domain(Some(t));
            to_json(&report)?
        }
        (None, Some(start)) => {
            let start = start.inner.clone();
            let report = progress.run(py, || {
                let records = records(loaded, window_s)?;
                hystid::analysis::run_time_fit_from_start(
                    recording,
                    response,
                    &start,
                    &fix,
                    &records,
                    &time_options,
                    &progress,
                )
            });
            let report = report?;
            to_json(&report)?
        }
        (None, None) => {
            let report = progress
                .run(py, || {
                    let Some(p) = hystid::analysis::periodic_start_of(held(names.clone(), loaded)?, fit_opts.element, fit_opts.modes)?
                    else {
                        return Err(hystid::Error::input(
                            "recordings",
                            "not multisines (a force that repeats, with at least 3 lines excited): give fit= (an FRF fit to refine) or start= (a model)",
                        ));
                    };
                    let mut report = hystid::analysis::run_time_fit_from_start(
                        recording,
                        response,
                        &p.start,
                        &fix,
                        &p.records,
                        &time_options,
                        &progress,
                    )?;
                    report.time_domain.notes.insert(0, p.note);
                    Ok(report)
                });
            let report = report?;
            to_json(&report)?
        }
    };
    Ok(text)
}

/// A diagnosis of multisine recordings on the lines of their period
/// (diagnosis.json, as `hystid diagnose --domain time` on multisines): the
/// joint of `options`' element on their linear estimate fitted in time,
/// then the loop closed on the residual per line.
#[pyfunction]
#[pyo3(signature = (recordings, options, candidates = None, time_proposals = 0, min_samples_per_period = 40.0, progress = None, replay = String::from("band_limited"), starts = 1, max_judged_samples = hystid::fit::time::MAX_JUDGED_SAMPLES, acquisition = None))]
#[allow(clippy::too_many_arguments)]
fn diagnose_time<'py>(
    py: Python<'py>,
    recordings: Recordings<'py>,
    options: String,
    candidates: Option<Vec<String>>,
    time_proposals: usize,
    min_samples_per_period: f64,
    progress: Option<Py<PyAny>>,
    replay: String,
    starts: usize,
    max_judged_samples: usize,
    acquisition: Option<String>,
) -> PyResult<String> {
    let time_options = time_fit_options(
        min_samples_per_period,
        &replay,
        starts,
        max_judged_samples,
        acquisition.as_deref(),
    )?;
    let fit_opts = fit_options(&options)?;
    let mut req = DiagnoseRequest::new(
        paths(&recordings.names),
        fit_opts.clone(),
        candidates_of(candidates)?,
    );
    req.domain = FitDomain::Time;
    req.diagnosis.time_proposals = time_proposals;
    req.time = time_options.clone();
    req.validate().map_err(err)?;
    let d = req.diagnosis;
    let progress = Progress::new(progress);
    let loaded = recordings.loaded()?;
    let names = recordings.names;
    let outcome = progress.run(py, || {
        let t0 = std::time::Instant::now();
        let Some(p) = hystid::analysis::periodic_start_of(
            held(names.clone(), loaded)?,
            fit_opts.element,
            fit_opts.modes,
        )?
        else {
            return Err(hystid::Error::input(
                "recordings",
                "not multisines (a force that repeats, with at least 3 lines excited): diagnose stepped or swept sines through their FRFs (diagnose)",
            ));
        };
        let mut diagnosis = hystid::analysis::multisine::diagnose_multisine(
            &p.start,
            &p.records,
            &time_options,
            &d,
            &progress,
        )?;
        diagnosis.start = p.note;
        Ok((diagnosis, t0.elapsed().as_secs_f64()))
    });
    let (diagnosis, seconds) = outcome?;
    to_json(&hystid::analysis::multisine::MultisineReport::new(
        &diagnosis, names, seconds, None,
    ))
}

#[pymodule]
fn _hystid(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add("HystidError", m.py().get_type::<HystidError>())?;
    m.add("DEFAULT_TEST", DEFAULT_TEST)?;
    m.add("VERSION", hystid::analysis::VERSION)?;
    m.add_class::<PyModel>()?;
    m.add_class::<PySimulation>()?;
    m.add_function(wrap_pyfunction!(json_to_toml, m)?)?;
    m.add_function(wrap_pyfunction!(range_option, m)?)?;
    m.add_function(wrap_pyfunction!(simulate, m)?)?;
    m.add_function(wrap_pyfunction!(simulate_all, m)?)?;
    m.add_function(wrap_pyfunction!(_rust_simulate_seconds, m)?)?;
    m.add_function(wrap_pyfunction!(virtual_test, m)?)?;
    m.add_function(wrap_pyfunction!(extract, m)?)?;
    m.add_function(wrap_pyfunction!(identify, m)?)?;
    m.add_function(wrap_pyfunction!(identify_declared, m)?)?;
    m.add_function(wrap_pyfunction!(diagnose, m)?)?;
    m.add_function(wrap_pyfunction!(validate, m)?)?;
    m.add_function(wrap_pyfunction!(identify_time, m)?)?;
    m.add_function(wrap_pyfunction!(diagnose_time, m)?)?;
    m.add_function(wrap_pyfunction!(fit_coil, m)?)?;
    m.add_function(wrap_pyfunction!(points::identify_points, m)?)?;
    Ok(())
}
