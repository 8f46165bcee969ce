//! Long runs seen from Python: progress to a callback, warnings as Python warnings, and Ctrl-C.
//!
//! A run releases the GIL ([`observed`]); its observer takes the GIL only briefly: to call the
//! progress callback (at most every [`INTERVAL`], and at the start and end of every stage) and
//! to ask Python whether Ctrl-C was pressed (at most every [`INTERVAL`], when the library polls
//! [`Observer::cancelled`] between batches of work). Warnings are kept and issued as Python
//! warnings when the run returns, on the caller's thread, so that warning filters apply.

use crate::errors::{keywords_in, to_py};
use detnoise::progress::Observer;
use pyo3::prelude::*;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering::Relaxed};
use std::sync::Mutex;
use std::time::{Duration, Instant};

/// Shortest time between two progress calls, and between two looks for Ctrl-C.
pub const INTERVAL: Duration = Duration::from_millis(100);

pyo3::create_exception!(
    _detnoise,
    DetnoiseWarning,
    pyo3::exceptions::PyUserWarning,
    "Something a detnoise run wants the user to know that did not stop it (e.g. an optimum at \
     the edge of the background grid)."
);

/// The current stage: its label, unit and total.
#[derive(Default)]
struct Stage {
    label: String,
    unit: String,
}

/// An [`Observer`] that reports to a Python callback `progress(stage, done, total, unit)` and
/// stops the run when Python has a pending Ctrl-C (or the callback raised).
pub struct PyObserver {
    callback: Option<Py<PyAny>>,
    stage: Mutex<Stage>,
    done: AtomicU64,
    total: AtomicU64,
    last_call: Mutex<Instant>,
    last_poll: Mutex<Instant>,
    stop: AtomicBool,
    /// The exception that stopped the run (KeyboardInterrupt, or the callback's own).
    error: Mutex<Option<PyErr>>,
    warnings: Mutex<Vec<String>>,
}

impl PyObserver {
    /// An observer calling `callback` (None: progress is not reported).
    pub fn new(callback: Option<Py<PyAny>>) -> Self {
        let long_ago = Instant::now() - INTERVAL;
        PyObserver {
            callback,
            stage: Mutex::new(Stage::default()),
            done: AtomicU64::new(0),
            total: AtomicU64::new(0),
            last_call: Mutex::new(long_ago),
            last_poll: Mutex::new(long_ago),
            stop: AtomicBool::new(false),
            error: Mutex::new(None),
            warnings: Mutex::new(Vec::new()),
        }
    }

    /// Call the callback with the current counts; `force` ignores the interval (stage start
    /// and end). A callback that raises stops the run with its exception, and once the run is
    /// stopped the callback is not called again.
    fn report(&self, force: bool) {
        let Some(callback) = &self.callback else {
            return;
        };
        if self.stop.load(Relaxed) {
            return; // stopped: the progress stays where it was
        }
        {
            let Ok(mut last) = self.last_call.try_lock() else {
                return; // another thread is reporting right now
            };
            if !force && last.elapsed() < INTERVAL {
                return;
            }
            *last = Instant::now();
        }
        let (label, unit) = {
            let s = self.stage.lock().expect("stage lock");
            (s.label.clone(), s.unit.clone())
        };
        let (done, total) = (self.done.load(Relaxed), self.total.load(Relaxed));
        Python::attach(|py| {
            if let Err(e) = callback.call1(py, (label, done.min(total), total, unit)) {
                self.stop_with(e);
            }
        });
    }

    /// Stop the run, keeping the first exception.
    fn stop_with(&self, e: PyErr) {
        let mut slot = self.error.lock().expect("error lock");
        if slot.is_none() {
            *slot = Some(e);
        }
        self.stop.store(true, Relaxed);
    }

    /// The run's result as Python sees it: warnings issued, and an interrupted run's
    /// exception (KeyboardInterrupt, or what the callback raised).
    pub fn finish<T>(self, py: Python<'_>, result: detnoise::Result<T>) -> PyResult<T> {
        let warnings = std::mem::take(&mut *self.warnings.lock().expect("warnings lock"));
        let category = py.get_type::<DetnoiseWarning>();
        for w in warnings {
            let message = std::ffi::CString::new(keywords_in(&w)).unwrap_or_default();
            PyErr::warn(py, &category, &message, 1)?;
        }
        let stopped = self.error.lock().expect("error lock").take();
        match (result, stopped) {
            (Err(detnoise::Error::Interrupted), Some(e)) => Err(e),
            (r, _) => r.map_err(to_py),
        }
    }
}

impl Observer for PyObserver {
    fn begin(&self, label: &str, total: u64, _work_pixel_frames: u64) {
        *self.stage.lock().expect("stage lock") = Stage {
            label: label.to_string(),
            unit: "frames".to_string(),
        };
        self.done.store(0, Relaxed);
        self.total.store(total, Relaxed);
        self.report(true);
    }

    fn unit(&self, unit: &str) {
        self.stage.lock().expect("stage lock").unit = unit.to_string();
    }

    fn step(&self, label: &str) {
        self.stage.lock().expect("stage lock").label = label.to_string();
        self.report(true);
    }

    fn grow(&self, more: u64) {
        self.total.fetch_add(more, Relaxed);
    }

    fn advance(&self, iterations: u64) {
        self.done.fetch_add(iterations, Relaxed);
        self.report(false);
    }

    fn end(&self) {
        // A stopped run (Ctrl-C, or the callback raised) ends its stage too: not at its total.
        if self.stop.load(Relaxed) {
            return;
        }
        self.done.store(self.total.load(Relaxed), Relaxed);
        self.report(true);
    }

    fn warn(&self, message: &str) {
        self.warnings
            .lock()
            .expect("warnings lock")
            .push(message.to_string());
    }

    fn cancelled(&self) -> bool {
        if self.stop.load(Relaxed) {
            return true;
        }
        {
            let mut last = self.last_poll.lock().expect("poll lock");
            if last.elapsed() < INTERVAL {
                return false;
            }
            *last = Instant::now();
        }
        // Signals are delivered to the main thread: elsewhere this finds nothing.
        if let Err(e) = Python::attach(|py| py.check_signals()) {
            self.stop_with(e);
        }
        self.stop.load(Relaxed)
    }
}

/// Run `f` without the GIL, observed by a [`PyObserver`] reporting to `progress`.
pub fn observed<T, F>(py: Python<'_>, progress: Option<Py<PyAny>>, f: F) -> PyResult<T>
where
    T: Send,
    F: FnOnce(&PyObserver) -> detnoise::Result<T> + Send,
{
    let observer = PyObserver::new(progress);
    let result = py.detach(|| f(&observer));
    observer.finish(py, result)
}
