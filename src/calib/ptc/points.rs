//! The photon-transfer points as a table (`ptc_points.csv`, `ptc_points.json`): per light level
//! the dark-subtracted mean and variance, the gain that level alone gives, and the frames used,
//! so the chart's points can be refitted or compared elsewhere.

use std::path::{Path, PathBuf};

use serde::Serialize;

use super::transfer::PtcResult;
use crate::error::Result;

/// Files [`write_points`] writes: the points as CSV and as JSON.
pub const POINTS_NAMES: [&str; 2] = ["ptc_points.csv", "ptc_points.json"];

/// One light level of a photon-transfer analysis.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct PtcPoint {
    /// Level number, 1 upwards, in the order the levels were given (or split).
    pub level: usize,
    /// Frames used at this level.
    pub frames: usize,
    /// Pixels used (not saturated, finite).
    pub pixels: usize,
    /// Mean over pixels of the dark-subtracted mean (adu).
    pub mean_adu: f64,
    /// Mean over pixels of the dark-subtracted variance (adu^2).
    pub var_adu2: f64,
    /// Standard error of `var_adu2` (adu^2): the weight of this point in the fit.
    pub var_se_adu2: f64,
    /// The conversion gain of this level alone (e- per adu): EM gain x F^2 x mean / variance;
    /// None (empty) where the variance is not positive.
    pub gain_e_per_adu: Option<f64>,
    /// Its standard error (e- per adu), from the variance's (the mean's is far smaller).
    pub gain_se_e_per_adu: Option<f64>,
    /// Lamp flicker seen at this level (fraction of the mean signal).
    pub flicker_fraction: f64,
    /// Pixels masked as saturated at this level.
    pub saturated_pixels: usize,
}

/// The points of `r`, one per level in order.
pub fn points(r: &PtcResult) -> Vec<PtcPoint> {
    // The fit's slope is EM gain x F^2 / gain: their product is the factor of each level's gain.
    let factor = r.gain_e_per_adu * r.slope;
    r.levels
        .iter()
        .enumerate()
        .map(|(k, l)| {
            let gain = (l.var_adu2 > 0.0 && l.mean_adu > 0.0)
                .then(|| factor * l.mean_adu / l.var_adu2)
                .filter(|g| g.is_finite());
            PtcPoint {
                level: k + 1,
                frames: l.frames,
                pixels: l.pixels,
                mean_adu: l.mean_adu,
                var_adu2: l.var_adu2,
                var_se_adu2: l.var_err_adu2,
                gain_e_per_adu: gain,
                gain_se_e_per_adu: gain.map(|g| g * l.var_err_adu2 / l.var_adu2),
                flicker_fraction: l.flicker_fraction,
                saturated_pixels: l.saturated_pixels,
            }
        })
        .collect()
}

/// Write the points of `r` into `dir` as [`POINTS_NAMES`] (each atomically); returns the paths.
pub fn write_points(r: &PtcResult, dir: &Path) -> Result<Vec<PathBuf>> {
    crate::output::write_csv_json(&points(r), dir, POINTS_NAMES)
}
