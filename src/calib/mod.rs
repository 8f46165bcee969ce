//! Calibration: per-pixel maps from dark and flat stacks.

pub mod darks;
pub mod ptc;
pub mod summary;
