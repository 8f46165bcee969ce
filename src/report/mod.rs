//! The detector report: a camera's dark (and flat) frames in, effective read-noise tables,
//! charts and one offline page (`index.html`) out.
//!
//! [`run`] takes [`ReportOptions`] and returns a [`ReportResult`] (the key numbers, the tables,
//! the files written); progress and warnings go to a [`crate::progress::Observer`]. The output
//! directory is written only when the whole report succeeded.

mod camera;
mod centroiders;
mod compare;
pub mod datasheet;
mod emccd;
mod grid;
pub(crate) mod html;
mod options;
mod page;
mod point;
pub mod qe_factor;
mod real_noise;
mod result;
mod scmos;
mod static_part;
mod subaps;

#[cfg(test)]
mod tests;

pub use crate::effective::EffectiveRecord;
pub use crate::montecarlo::SimRecord;
pub use camera::{CameraSection, CurveRow, Simulated, Terms, CURVE_RATES_HZ};
pub use grid::{
    DEFAULT_AIRY_DIAMETERS_PX, DEFAULT_SIGNALS_PHOTONS, DEFAULT_SUBAPS_PX, QUICK_AIRY_DIAMETERS_PX,
    QUICK_MAX_ITERS, QUICK_SIGNALS_PHOTONS, QUICK_SUBAPS_PX,
};
pub use options::{DetectorKind, ReportOptions};
pub use point::{ChosenPoint, OperatingPoint};
pub use result::{
    Compared, EmccdSummary, Headline, RealNoise, RealNoiseRow, ReportInput, ReportResult,
    ReportSummary, Summary,
};

use crate::io::FrameStack;
use crate::output::{DirPlan, OutputDir};
use crate::progress::Observer;
use crate::Result;
use std::path::PathBuf;

/// Files a report may write into its directory (glob patterns, `*` for a signal or a spot), as
/// its parts declare them: an sCMOS report's and an EMCCD report's (either may replace the
/// other's directory), and with a lenslet geometry the per-sub-aperture map's.
pub fn output_names(with_subaps: bool) -> Vec<&'static str> {
    let mut names: Vec<&str> = scmos::outputs().collect();
    for name in emccd::outputs() {
        if !names.contains(&name) {
            names.push(name);
        }
    }
    if with_subaps {
        names.extend(crate::subaps::OUTPUT_NAMES);
    }
    names
}

/// Run a whole report: check the options, read the frames, compute, and write every output
/// into `options.out_dir`.
pub fn run(options: &ReportOptions, observer: &dyn Observer) -> Result<ReportResult> {
    options.validate()?;
    // Each flat is its own stack, which checks only its own files: one file given as two
    // flats (two light levels of one) or as the darks and a flat is refused here.
    if !options.flats_paths.is_empty() {
        let stacks: Vec<PathBuf> = options
            .flats_paths
            .iter()
            .chain(&options.darks_paths)
            .cloned()
            .collect();
        let files = crate::io::expand_inputs(&stacks)?;
        crate::io::check_distinct(&files, "the darks' and flats' files")?;
    }
    let grid = options.grid();
    let inputs: Vec<PathBuf> = options
        .darks_paths
        .iter()
        .chain(&options.flats_paths)
        .chain(&options.model_input_paths)
        .cloned()
        .collect();
    let names = output_names(options.subaps.is_some());
    let dir = OutputDir::prepare(
        &options.out_dir,
        DirPlan {
            command: "report",
            force: options.force,
            inputs: &inputs,
            names: &names,
        },
    )?;
    let stack = FrameStack::open(&options.darks_paths)?;
    stack.require_frames(2, "a read-noise map")?;
    real_noise::check_given_frames(&options.model_params, stack.shape)?;
    // The geometry must fit the frames (known from the headers) before the work.
    if let Some(g) = &options.subaps {
        subaps::check_geometry(options, &grid, g, stack.shape)?;
    }
    let mut result = match options.detector {
        DetectorKind::Scmos => scmos::run(options, &grid, &stack, &dir, observer)?,
        DetectorKind::Emccd => emccd::run(options, &grid, &stack, &dir, observer)?,
    };
    let out_dir = dir.commit()?;
    for f in &mut result.files {
        *f = out_dir.join(&*f);
    }
    result.out_dir = out_dir;
    Ok(result)
}
