//! Calibration: per-pixel maps (a [`Map`] carries its unit) from dark and flat stacks.
//!
//! `map` is the map type, `darks` the dark calibration (offset, read noise, flags), `ptc` the
//! photon transfer (conversion gain) and `summary` the distribution figures and input
//! provenance their summaries share.

pub mod darks;
mod map;
pub mod ptc;
pub mod summary;

pub use map::{Map, Unit};
