//! One stack of a campaign: the operating condition it was taken at and its per-pixel moments.

use std::path::PathBuf;

use crate::calib::darks::TemporalNoiseSummary;

/// What a stack is: darks (no light) or flats (uniform light).
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum StackKind {
    /// No light reaches the sensor.
    Dark,
    /// Uniform illumination.
    Flat,
}

/// The operating condition a stack was taken at, as the campaign's input states it.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Condition {
    /// Exposure time (s).
    pub exposure_s: f64,
    /// Commanded EM gain (e-/e-); `None` for a camera without an EM register.
    pub em_gain: Option<f64>,
    /// Sensor temperature (deg C), when the input gives it.
    pub temperature_c: Option<f64>,
    /// Darks or flats.
    pub kind: StackKind,
    /// Light level of a flat, in the input's own unit (irradiance, photons per pixel); `None`
    /// for darks.
    pub light_level: Option<f64>,
}

/// Per-pixel moments of one stack of a campaign (row-major, `rows x cols`), from one pass.
#[derive(Clone, Debug)]
pub struct ConditionStats {
    /// The stack's file.
    pub file: PathBuf,
    /// What it was taken at.
    pub condition: Condition,
    /// Frames read.
    pub frames: usize,
    /// Image rows.
    pub rows: usize,
    /// Image columns.
    pub cols: usize,
    /// Per-pixel mean (adu).
    pub mean_adu: Vec<f64>,
    /// Per-pixel unbiased temporal variance (adu^2), every sample (the frame-common, row and
    /// column parts included: `temporal` splits them).
    pub var_adu2: Vec<f64>,
    /// The temporal noise split into pixel, row, column and frame parts (adu, with SEs).
    pub temporal: TemporalNoiseSummary,
}
