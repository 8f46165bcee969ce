//! Photon transfer: conversion gain (e per adu), global and per pixel, from a dark reference
//! and flat stacks at several light levels.
//!
//! Layout: `transfer` is the analysis, `levels` splits one stack into its light levels, and
//! `run` is the whole `ptc` command as one call (maps, chart and ptc.json written).

mod levels;
mod run;
mod transfer;

pub use levels::{light_levels, LightLevel};
pub use run::{chart, run, DarkInput, PtcRun, PtcRunResult, PtcSummary, OUTPUT_NAMES};
pub use transfer::{
    flat_stats, flat_stats_of, photon_transfer, DarkReference, Level, PtcOptions, PtcResult,
};
