//! The command line's observer: one progress bar on standard error for long runs, and the
//! library's warnings printed as `warning: ...` with its fields shown as flags.

use crate::progress::Observer;
use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};
use std::sync::Mutex;

/// Pixel-frames per second per core the estimate assumes (conservative).
const PIXEL_FRAMES_PER_SECOND: f64 = 2e7;

/// The observer of every long command: a bar per stage, shown only when the stage is expected
/// to last over a second, and warnings on standard error.
#[derive(Default)]
pub struct Terminal {
    bar: Mutex<Option<ProgressBar>>,
}

impl Terminal {
    fn with_bar(&self, f: impl FnOnce(&ProgressBar)) {
        if let Some(bar) = self.bar.lock().expect("progress lock").as_ref() {
            f(bar);
        }
    }
}

impl Observer for Terminal {
    fn begin(&self, label: &str, total: u64, work_pixel_frames: u64) {
        let cores = rayon::current_num_threads() as f64;
        let seconds = work_pixel_frames as f64 / (PIXEL_FRAMES_PER_SECOND * cores);
        let bar = if seconds > 1.0 {
            ProgressBar::with_draw_target(Some(total), ProgressDrawTarget::stderr())
        } else {
            ProgressBar::hidden()
        };
        bar.set_style(
            ProgressStyle::with_template(
                "{prefix:>10} [{elapsed_precise}] {wide_bar} {human_pos}/{human_len} {msg} (eta {eta})",
            )
            .expect("valid template"),
        );
        bar.set_prefix(label.to_string());
        // Iterations are frames; a stage with named steps (the paper's figures) shows the step.
        bar.set_message("frames");
        if let Some(old) = self.bar.lock().expect("progress lock").replace(bar) {
            old.finish_and_clear();
        }
    }

    fn unit(&self, unit: &str) {
        self.with_bar(|bar| bar.set_message(unit.to_string()));
    }

    fn step(&self, label: &str) {
        self.with_bar(|bar| bar.set_message(label.to_string()));
    }

    fn grow(&self, more: u64) {
        self.with_bar(|bar| bar.inc_length(more));
    }

    fn advance(&self, iterations: u64) {
        self.with_bar(|bar| bar.inc(iterations));
    }

    fn end(&self) {
        if let Some(bar) = self.bar.lock().expect("progress lock").take() {
            bar.finish_and_clear();
        }
    }

    fn warn(&self, message: &str) {
        let line = format!("warning: {}", super::fields::flags_in(message));
        match self.bar.lock().expect("progress lock").as_ref() {
            Some(bar) => bar.suspend(|| eprintln!("{line}")),
            None => eprintln!("{line}"),
        }
    }
}
