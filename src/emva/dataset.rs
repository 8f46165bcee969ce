//! An EMVA 1288 dataset: what the standard's measurement consists of, as paths to frames.
//!
//! A temporal point is a pair of bright frames and a pair of dark frames at one exposure time
//! (with the mean photons per pixel of the bright pair, when the input gives it); the spatial
//! stacks are many frames at one bright point (about 50 % of saturation) and dark at the same
//! exposure.

use std::path::PathBuf;

use crate::campaign::input::EmvaFormat;

/// One point of the photon-transfer series: two bright and two dark frames at one exposure.
#[derive(Clone, Debug, PartialEq)]
pub struct PairPoint {
    /// Exposure time (s).
    pub exposure_s: f64,
    /// Mean photons per pixel of the bright pair (None: the input does not give it; QE then
    /// cannot be computed).
    pub photons_per_px: Option<f64>,
    /// The two bright frames.
    pub bright: [PathBuf; 2],
    /// The two dark frames at the same exposure.
    pub dark: [PathBuf; 2],
}

/// A spatial stack: many frames at one condition, for DSNU / PRNU.
#[derive(Clone, Debug, PartialEq)]
pub struct SpatialStack {
    /// Exposure time (s).
    pub exposure_s: f64,
    /// Mean photons per pixel (None for the dark stack, or when the input does not give it).
    pub photons_per_px: Option<f64>,
    /// The stack's frames, in order.
    pub files: Vec<PathBuf>,
}

/// A whole EMVA 1288 dataset, as paths (frames are streamed when computed).
#[derive(Clone, Debug, PartialEq)]
pub struct EmvaDataset {
    /// Where it was described (descriptor file or manifest), for messages.
    pub source: PathBuf,
    /// Declared bits per sample and frame size, when the input gives them.
    pub format: Option<EmvaFormat>,
    /// The photon-transfer series, by increasing photons (or exposure).
    pub points: Vec<PairPoint>,
    /// The bright spatial stack (None: the input has none).
    pub spatial_bright: Option<SpatialStack>,
    /// The dark spatial stack (None: the input has none).
    pub spatial_dark: Option<SpatialStack>,
}
