//! What a decomposition gives: the maps and the summary written as decomposition.json.

use serde::Serialize;

use super::classes::{HotClass, HotPixels};
use super::gain_curve::EmGainCurve;
use super::noise::ShotNoiseCheck;
use super::pixels::FitQuality;
use crate::calib::darks::TemporalNoiseSummary;

/// A median over pixels with its standard errors.
#[derive(Clone, Copy, Debug, Serialize, PartialEq)]
pub struct MedianSe {
    /// Median over the fitted pixels.
    pub median: f64,
    /// Its statistical SE: 1.2533 x robust sigma / sqrt(pixels).
    pub se: f64,
    /// Its systematic SE from the SEs of the EM gains and of the conversion gain (common to
    /// every pixel, so not in the per-pixel SE maps).
    pub systematic_se: f64,
    /// Median of the per-pixel SE map.
    pub median_pixel_se: f64,
}

/// The temperature term as fitted or given.
#[derive(Clone, Debug, Serialize, PartialEq)]
pub struct TemperatureSummary {
    /// T_ref: the dark current map is at this temperature (deg C).
    pub reference_c: f64,
    /// T_d (deg C).
    pub doubling_c: f64,
    /// Its SE (deg C), from the curvature of the total chi2 (inflated by sqrt(reduced chi2)
    /// when above 1); 0 when given.
    pub doubling_se_c: f64,
    /// Fitted (true) or given.
    pub fitted: bool,
    /// The distinct temperatures of the darks (deg C).
    pub temperatures_c: Vec<f64>,
}

/// One condition of the campaign as used by the fit; its read noise passes through.
#[derive(Clone, Debug, Serialize, PartialEq)]
pub struct ConditionRow {
    /// The stack's file.
    pub file: String,
    /// Exposure time (s).
    pub exposure_s: f64,
    /// Commanded EM gain (e-/e-), if a register.
    pub em_gain_commanded: Option<f64>,
    /// EM gain the fit used (e-/e-): the fitted one if given, else the commanded one.
    pub em_gain_used: Option<f64>,
    /// Its SE (e-/e-; 0 for a commanded gain).
    pub em_gain_used_se: Option<f64>,
    /// Temperature (deg C), if given.
    pub temperature_c: Option<f64>,
    /// Frames.
    pub frames: usize,
    /// Median over pixels of the mean dark (adu).
    pub median_mean_adu: f64,
    /// The temporal noise of the stack as measured on the input side (adu, with SEs).
    pub read_noise: TemporalNoiseSummary,
}

/// Contents of decomposition.json: everything but the maps.
#[derive(Clone, Debug, Serialize, PartialEq)]
pub struct DecompositionSummary {
    /// Tool and version.
    pub tool: String,
    /// The model fitted, in words.
    pub model: String,
    /// An EM register (EMCCD) or not.
    pub em_register: bool,
    /// Image shape [rows, cols].
    pub shape: [usize; 2],
    /// Pixels fitted (finite positive variance at every condition).
    pub pixels_fitted: usize,
    /// Pixels not fitted (NaN in the maps, class `not_fitted`).
    pub pixels_not_fitted: usize,
    /// The global conversion gain (e-/adu), `None` for a per-pixel map.
    pub conversion_gain_e_per_adu: Option<f64>,
    /// Its SE (e-/adu).
    pub conversion_gain_se_e_per_adu: Option<f64>,
    /// The dark conditions, in input order.
    pub conditions: Vec<ConditionRow>,
    /// Offset F (adu).
    pub offset_adu: MedianSe,
    /// Dark current D (e-/s, at the reference temperature).
    pub dark_current_e_per_s: MedianSe,
    /// CIC C (e-/frame), EMCCD only.
    pub cic_e_per_frame: Option<MedianSe>,
    /// The temperature term, if on.
    pub temperature: Option<TemperatureSummary>,
    /// Fit quality.
    pub fit_quality: FitQuality,
    /// Warm and hot pixels.
    pub hot_pixels: HotPixels,
    /// The shot noise of the dark current against D, if the design allows it.
    pub shot_noise: Option<ShotNoiseCheck>,
    /// The EM gain calibration curve, if fitted gains were given.
    pub em_gain_curve: Option<EmGainCurve>,
    /// What the reader must know (what is not separable, what was assumed).
    pub notes: Vec<String>,
}

/// The decomposition: per-pixel maps (row-major, `rows x cols`, NaN where not fitted) and
/// the summary.
#[derive(Clone, Debug)]
pub struct Decomposition {
    /// Image rows.
    pub rows: usize,
    /// Image columns.
    pub cols: usize,
    /// Offset F (adu).
    pub offset_adu: Vec<f64>,
    /// Its SE (adu).
    pub offset_se_adu: Vec<f64>,
    /// Dark current D at the reference temperature (e-/s).
    pub dark_current_e_per_s: Vec<f64>,
    /// Its SE (e-/s).
    pub dark_current_se_e_per_s: Vec<f64>,
    /// CIC C (e-/frame); `None` without a register or with `fit_cic` off.
    pub cic_e_per_frame: Option<Vec<f64>>,
    /// Its SE (e-/frame).
    pub cic_se_e_per_frame: Option<Vec<f64>>,
    /// Reduced chi2 of each pixel's fit (`summary.fit_quality.dof` degrees of freedom).
    pub reduced_chi2: Vec<f64>,
    /// Each pixel's class by dark current.
    pub hot_class: Vec<HotClass>,
    /// The summary (decomposition.json).
    pub summary: DecompositionSummary,
}

impl Decomposition {
    /// Whether pixel `i`'s fit is flagged bad (reduced chi2 above the flag threshold).
    pub fn bad_fit(&self, i: usize) -> bool {
        self.reduced_chi2[i] > self.summary.fit_quality.flag_reduced_chi2_above
    }
}
