//! One progress bar on standard error for long runs.

use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};

/// Pixel-frames per second per core the estimate assumes (conservative).
const PIXEL_FRAMES_PER_SECOND: f64 = 2e7;

/// A progress bar that shows itself only when the run is expected to last over a second.
pub struct Progress {
    bar: ProgressBar,
}

impl Progress {
    /// A bar counting `total` iterations; `work_pixel_frames` estimates the duration.
    pub fn new(label: &str, total: u64, work_pixel_frames: u64) -> Self {
        let cores = rayon::current_num_threads() as f64;
        let seconds = work_pixel_frames as f64 / (PIXEL_FRAMES_PER_SECOND * cores);
        let bar = if seconds > 1.0 {
            ProgressBar::with_draw_target(Some(total), ProgressDrawTarget::stderr())
        } else {
            ProgressBar::hidden()
        };
        bar.set_style(
            ProgressStyle::with_template(
                "{msg:>10} [{elapsed_precise}] {wide_bar} {pos}/{len} frames (eta {eta})",
            )
            .expect("valid template"),
        );
        bar.set_message(label.to_string());
        Progress { bar }
    }

    /// Count `k` more iterations.
    pub fn inc(&self, k: u64) {
        self.bar.inc(k);
    }

    /// Remove the bar.
    pub fn finish(&self) {
        self.bar.finish_and_clear();
    }
}
