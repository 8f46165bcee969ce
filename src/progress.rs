//! Progress of long runs, reported to whoever drives the library: the command line's progress
//! bar, a Python callback, or nobody. The library never prints; it tells its observer.
//!
//! Modelled on argmin's observers: the run calls the observer, the observer decides what to show.

/// Receives the progress and warnings of a long run. Every method has a silent default.
pub trait Observer: Sync {
    /// A stage begins: `label` names it (e.g. `effective`), `total` counts its iterations, and
    /// `work_pixel_frames` (iterations x pixels x models) lets a front end guess its duration.
    fn begin(&self, _label: &str, _total: u64, _work_pixel_frames: u64) {}
    /// `iterations` more iterations of the current stage are done (called from worker threads).
    fn advance(&self, _iterations: u64) {}
    /// The current stage has ended.
    fn end(&self) {}
    /// Something the user should know that does not stop the run (e.g. an optimum at a grid edge).
    fn warn(&self, _message: &str) {}
}

/// An observer that ignores everything: for library callers that want no progress.
#[derive(Debug, Clone, Copy, Default)]
pub struct Silent;

impl Observer for Silent {}
