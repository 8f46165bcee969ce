//! `detnoise darks` as one library call: a dark stack in, its maps and summary written to an
//! output directory that appears only when the run succeeds.

use std::path::PathBuf;
use std::time::Instant;

use super::illumination::{require_dark_expecting, ExpectedDark};
use super::maps::{dark_maps, dark_maps_hashed};
use super::options::DarkOptions;
use super::outputs::{write_outputs, DarkSummary, OUTPUT_NAMES};
use crate::calib::summary::{unhashed, Checksum};
use crate::error::Result;
use crate::io::FrameStack;
use crate::output::{DirPlan, OutputDir};
use crate::progress::Observer;

/// A dark calibration to run.
#[derive(Clone, Debug)]
pub struct DarksRun {
    /// Dark frames: files, directories or glob patterns, in stack order.
    pub stack: Vec<PathBuf>,
    /// Output directory (replaced only if detnoise wrote it).
    pub out: PathBuf,
    /// Write into an existing `out` that holds other files (never replacing them).
    pub force: bool,
    /// Clipping, common mode and flag thresholds.
    pub options: DarkOptions,
    /// Conversion gain (e- per adu): adds rms_e.fits and the e- figures.
    pub gain_e_per_adu: Option<f64>,
    /// Record this digest of every input in summary.json (None: no checksums), computed on
    /// its own thread while the statistics run: BLAKE3 ~0.17 CPU-s per GB (AVX-512), SHA-256
    /// ~0.5 CPU-s per GB (SHA extensions), which then bounds the run.
    pub checksum: Option<Checksum>,
    /// Use frames that look illuminated as darks (with a warning) instead of refusing them.
    pub accept_illuminated: bool,
    /// The dark signal the frames are expected to hold (a camera model at their exposure),
    /// taken off before the check for light; one value per pixel of the stack.
    pub expected_dark: Option<ExpectedDark>,
}

/// What a dark calibration produced.
#[derive(Debug)]
pub struct DarksRunResult {
    /// The content of summary.json.
    pub summary: DarkSummary,
    /// The output directory written.
    pub out: PathBuf,
    /// Bytes of sample data read, as stored.
    pub stored_bytes: u64,
    /// Wall-clock seconds spent reading and accumulating the stack.
    pub read_seconds: f64,
}

/// Run a dark calibration; a stack that looks illuminated but is accepted is reported to
/// `observer` as a warning.
pub fn run(job: &DarksRun, observer: &dyn Observer) -> Result<DarksRunResult> {
    job.options.check()?;
    let dir = OutputDir::prepare(
        &job.out,
        DirPlan {
            command: "darks",
            force: job.force,
            inputs: &job.stack,
            names: &OUTPUT_NAMES,
        },
    )?;
    let stack = FrameStack::open(&job.stack)?;
    if let Some(e) = &job.expected_dark {
        e.check_shape(&stack)?;
    }
    let t = Instant::now();
    let (maps, inputs) = match job.checksum {
        Some(algorithm) => dark_maps_hashed(&stack, &job.options, algorithm)?,
        None => (dark_maps(&stack, &job.options)?, unhashed(&stack)),
    };
    let read_seconds = t.elapsed().as_secs_f64();
    let expected = job.expected_dark.as_ref();
    if let Some(warning) = require_dark_expecting(&stack, &maps, job.accept_illuminated, expected)?
    {
        observer.warn(&warning);
    }
    let summary = write_outputs(
        &dir.path(""),
        &stack,
        &maps,
        &job.options,
        job.gain_e_per_adu,
        inputs,
        "summary.json",
    )?;
    Ok(DarksRunResult {
        summary,
        out: dir.commit()?,
        stored_bytes: stack.stored_bytes(),
        read_seconds,
    })
}
