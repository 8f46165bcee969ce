//! detnoise: read-noise models of sCMOS and EMCCD cameras for Shack-Hartmann wavefront sensors.
//!
//! Data flows one way: frames (`io`) -> maps (`calib`) -> fitted models (`pdf`, `fit`)
//! -> Monte-Carlo (`spot`, `detector`, `centroid`, `montecarlo`) -> tables and charts
//! (`effective`, `plot`, `report`). The binary `detnoise` is a thin layer in `cli`.

#![warn(missing_docs)]

pub mod calib;
pub mod camera;
pub mod campaign;
pub mod centroid;
pub mod charts;
#[cfg(feature = "cli")]
pub mod cli;
pub mod crlb;
pub mod detector;
pub mod effective;
pub mod emva;
pub mod error;
pub mod fit;
pub mod io;
pub mod montecarlo;
pub mod output;
pub mod paper;
pub mod pdf;
pub mod plot;
pub mod progress;
pub mod report;
pub mod rng;
pub mod settings;
pub mod special;
pub mod spot;
pub mod stats;
pub mod subaps;
pub mod synth;

pub use error::{Error, Result};
