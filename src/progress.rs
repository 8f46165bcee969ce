//! Progress of long runs, reported to whoever drives the library: the command line's progress
//! bar, a Python callback, or nobody. The library never prints; it tells its observer.
//!
//! Modelled on argmin's observers: the run calls the observer, the observer decides what to show.

/// Receives the progress and warnings of a long run. Every method has a silent default.
pub trait Observer: Sync {
    /// A stage begins: `label` names it (e.g. `effective`), `total` counts its iterations, and
    /// `work_pixel_frames` (iterations x pixels x models) lets a front end guess its duration.
    fn begin(&self, _label: &str, _total: u64, _work_pixel_frames: u64) {}
    /// The current stage counts `unit` instead of frames (e.g. `pixel-frames`, frames x models
    /// x pixels, for a stage whose runs differ in size); called right after `begin`.
    fn unit(&self, _unit: &str) {}
    /// The current stage moves on to the part named `label` (e.g. one figure of the paper).
    fn step(&self, _label: &str) {}
    /// The current stage's total grows by `more`: the run decided to do more work than it
    /// planned (e.g. the effective-noise solver adding iterations to reach its target), so that
    /// at the end of every stage exactly its total has been advanced.
    fn grow(&self, _more: u64) {}
    /// `iterations` more iterations of the current stage are done (called from worker threads).
    fn advance(&self, _iterations: u64) {}
    /// The current stage has ended.
    fn end(&self) {}
    /// Something the user should know that does not stop the run (e.g. an optimum at a grid
    /// edge). Settings are named as `` `field` `` (backticks), like in errors.
    fn warn(&self, _message: &str) {}
    /// The driver wants the run stopped (e.g. Ctrl-C in Python): long loops poll this between
    /// work items and return [`crate::Error::Interrupted`], leaving no output behind.
    fn cancelled(&self) -> bool {
        false
    }
}

/// An observer that ignores everything: for library callers that want no progress.
#[derive(Debug, Clone, Copy, Default)]
pub struct Silent;

impl Observer for Silent {}

/// An observer that records what it is told, for tests of the long runs.
#[cfg(test)]
#[derive(Debug, Default)]
pub(crate) struct Recorder {
    /// `(label, total, work)` of every stage begun.
    pub stages: std::sync::Mutex<Vec<(String, u64, u64)>>,
    /// Labels of the steps.
    pub steps: std::sync::Mutex<Vec<String>>,
    /// Units named by stages.
    pub units: std::sync::Mutex<Vec<String>>,
    /// Growth of the totals, over all stages.
    pub grown: std::sync::atomic::AtomicU64,
    /// Iterations advanced, over all stages.
    pub advanced: std::sync::atomic::AtomicU64,
    /// Stages ended.
    pub ended: std::sync::atomic::AtomicU64,
    /// Warnings.
    pub warnings: std::sync::Mutex<Vec<String>>,
}

#[cfg(test)]
impl Observer for Recorder {
    fn begin(&self, label: &str, total: u64, work: u64) {
        let stage = (label.to_string(), total, work);
        self.stages.lock().unwrap().push(stage);
    }
    fn unit(&self, unit: &str) {
        self.units.lock().unwrap().push(unit.to_string());
    }
    fn step(&self, label: &str) {
        self.steps.lock().unwrap().push(label.to_string());
    }
    fn grow(&self, more: u64) {
        use std::sync::atomic::Ordering::Relaxed;
        self.grown.fetch_add(more, Relaxed);
    }
    fn advance(&self, iterations: u64) {
        use std::sync::atomic::Ordering::Relaxed;
        self.advanced.fetch_add(iterations, Relaxed);
    }
    fn end(&self) {
        self.ended
            .fetch_add(1, std::sync::atomic::Ordering::Relaxed);
    }
    fn warn(&self, message: &str) {
        self.warnings.lock().unwrap().push(message.to_string());
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn silent_and_recorder_observe_through_the_trait() {
        let observers: [&dyn Observer; 2] = [&Silent, &Recorder::default()];
        for o in observers {
            o.begin("stage", 10, 100);
            o.unit("pixel-frames");
            o.step("part");
            o.grow(3);
            o.advance(4);
            o.advance(6);
            o.end();
            o.warn("w");
        }
        let r = Recorder::default();
        r.begin("stage", 10, 100);
        std::thread::scope(|s| {
            for _ in 0..4 {
                s.spawn(|| r.advance(5));
            }
        });
        r.grow(7);
        r.unit("pixel-frames");
        r.end();
        r.warn("edge");
        assert_eq!(*r.stages.lock().unwrap(), [("stage".to_string(), 10, 100)]);
        assert_eq!(r.advanced.load(std::sync::atomic::Ordering::Relaxed), 20);
        assert_eq!(r.grown.load(std::sync::atomic::Ordering::Relaxed), 7);
        assert_eq!(*r.units.lock().unwrap(), ["pixel-frames"]);
        assert_eq!(r.ended.load(std::sync::atomic::Ordering::Relaxed), 1);
        assert_eq!(*r.warnings.lock().unwrap(), ["edge"]);
    }
}
