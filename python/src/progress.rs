//! The caller's `progress` callable as the library's observer: each event
//! handed to it as a dict, the library run on a thread of its own, Ctrl-C and
//! the callable's exceptions turned into a stop.

use super::err;
use hystid::observe::{Event, Observer};
use pyo3::prelude::*;
use std::sync::Mutex;

/// The caller's `progress` callable as the library's observer, and Ctrl-C.
///
/// Each event reaches the callable as a dict: `{"stage": "dwell",
/// "level_index", "frequency_hz"}` from the test bench, `{"stage": "fit",
/// "evaluation", "cost"}` from a fit, `{"stage": "diagnosis", "event":
/// "baseline" | "round" | "candidate" | "checking", ...}` from a diagnosis,
/// `{"stage": "progress", "task", "done", "total"}` from a simulation or a
/// reduction.
///
/// The library works on a thread of its own ([`Progress::run`]) while the
/// calling thread, Python's main thread as a rule, waits with the GIL
/// released and lets Python run its signal handlers every 50 ms. The first
/// exception, a `KeyboardInterrupt` or one the callable raised, stops the
/// callable's calls and asks the library to stop ([`Observer::cancelled`]:
/// the bench after its dwell, a fit before its next evaluation, a diagnosis
/// before its next candidate, a simulation within a quarter of a million
/// samples, a reduction after its dwell), and the call raises it.
pub(super) struct Progress {
    callback: Option<Py<PyAny>>,
    raised: Mutex<Option<PyErr>>,
}

impl Progress {
    pub(super) fn new(callback: Option<Py<PyAny>>) -> Self {
        Progress {
            callback,
            raised: Mutex::new(None),
        }
    }

    fn raise(&self, e: PyErr) {
        self.raised
            .lock()
            .unwrap_or_else(|e| e.into_inner())
            .get_or_insert(e);
    }

    /// Runs `work` (which observes `self`) on a thread of its own, the GIL
    /// released, and returns its result unless an exception was raised
    /// meanwhile.
    pub(super) fn run<T: Send>(
        &self,
        py: Python<'_>,
        work: impl FnOnce() -> hystid::Result<T> + Send,
    ) -> PyResult<T> {
        let result = std::thread::scope(|s| {
            let (done, mut finished) = std::sync::mpsc::channel();
            let worker = s.spawn(move || {
                let r = work();
                let _ = done.send(());
                r
            });
            loop {
                // the receiver goes into the GIL-free wait and comes back
                let (waited, back) = py.detach(move || {
                    let w = finished.recv_timeout(std::time::Duration::from_millis(50));
                    (w, finished)
                });
                finished = back;
                if !matches!(waited, Err(std::sync::mpsc::RecvTimeoutError::Timeout)) {
                    break;
                }
                if let Err(e) = py.check_signals() {
                    self.raise(e);
                }
            }
            match worker.join() {
                Ok(r) => r,
                Err(panic) => std::panic::resume_unwind(panic),
            }
        });
        match self.raised.lock().unwrap_or_else(|e| e.into_inner()).take() {
            Some(e) => Err(e),
            None => result.map_err(err),
        }
    }

    /// [`Progress::run`] for work too short to need a thread of its own
    /// (a few milliseconds: a worker thread and its polling would cost more
    /// than the work): run here with the GIL released; an exception the
    /// callable raised meanwhile is raised, Ctrl-C is seen when it returns.
    fn run_here<T: Send>(
        &self,
        py: Python<'_>,
        work: impl FnOnce() -> hystid::Result<T> + Send,
    ) -> PyResult<T> {
        let result = py.detach(work);
        match self.raised.lock().unwrap_or_else(|e| e.into_inner()).take() {
            Some(e) => Err(e),
            None => result.map_err(err),
        }
    }

    /// [`Progress::run`] for a simulation of `samples`: on this thread when
    /// it is one stretch ([`hystid::observe::SAMPLES_PER_REPORT`]).
    pub(super) fn run_simulation<T: Send>(
        &self,
        py: Python<'_>,
        samples: usize,
        work: impl FnOnce() -> hystid::Result<T> + Send,
    ) -> PyResult<T> {
        if samples <= hystid::observe::SAMPLES_PER_REPORT {
            self.run_here(py, work)
        } else {
            self.run(py, work)
        }
    }

    fn event<'py>(py: Python<'py>, event: Event<'_>) -> PyResult<Bound<'py, pyo3::types::PyDict>> {
        use hystid::observe::DiagnoseEvent as D;
        let d = pyo3::types::PyDict::new(py);
        match event {
            Event::Dwell {
                level_index,
                frequency_hz,
            } => {
                d.set_item("stage", "dwell")?;
                d.set_item("level_index", level_index)?;
                d.set_item("frequency_hz", frequency_hz)?;
            }
            Event::Cost(t) => {
                d.set_item("stage", "fit")?;
                d.set_item("evaluation", t.evaluation)?;
                d.set_item("cost", t.cost)?;
            }
            Event::Progress { task, done, total } => {
                d.set_item("stage", "progress")?;
                d.set_item("task", task)?;
                d.set_item("done", done)?;
                d.set_item("total", total)?;
            }
            Event::Diagnosis(e) => {
                d.set_item("stage", "diagnosis")?;
                match e {
                    D::Baseline { chi2_per_dof } => {
                        d.set_item("event", "baseline")?;
                        d.set_item("chi2_per_dof", chi2_per_dof)?;
                    }
                    D::Round { round, candidates } => {
                        d.set_item("event", "round")?;
                        d.set_item("round", round)?;
                        d.set_item("candidates", candidates)?;
                    }
                    D::Candidate { round, effect } => {
                        d.set_item("event", "candidate")?;
                        d.set_item("round", round)?;
                        d.set_item("effect", effect.name())?;
                    }
                    D::Checking { effect } => {
                        d.set_item("event", "checking")?;
                        d.set_item("effect", effect.name())?;
                    }
                }
            }
        }
        Ok(d)
    }
}

impl Observer for Progress {
    fn observe(&self, event: Event<'_>) {
        let Some(callback) = &self.callback else {
            return;
        };
        if self.cancelled() {
            return;
        }
        Python::attach(|py| {
            // again with the GIL held: another thread's event may have raised
            // while this one waited for it (levels run in parallel), and the
            // callable is never called once it raised
            if self.cancelled() {
                return;
            }
            if let Err(e) = Self::event(py, event).and_then(|d| callback.call1(py, (d,))) {
                self.raise(e);
            }
        });
    }
    fn cancelled(&self) -> bool {
        self.raised
            .lock()
            .unwrap_or_else(|e| e.into_inner())
            .is_some()
    }
}
