//! Photon transfer: conversion gain (e per adu), global and per pixel, from a dark reference
//! and flat stacks at several light levels.
//!
//! Layout: `transfer` is the analysis, `levels` splits one stack into its light levels, `points`
//! writes the levels as a table, and `run` is the whole `ptc` command as one call (maps, chart,
//! points and ptc.json written).

mod excess;
mod levels;
mod points;
mod run;
mod transfer;

pub use excess::{ExcessNoise, ExcessVerdict};
pub use levels::{light_levels, LightLevel};
pub use points::{points, write_points, PtcPoint, POINTS_NAMES};
pub use run::{chart, run, DarkInput, PtcRun, PtcRunResult, PtcSummary, OUTPUT_NAMES};
pub use transfer::{
    flat_stats, flat_stats_of, photon_transfer, DarkReference, Level, PtcOptions, PtcResult,
};
