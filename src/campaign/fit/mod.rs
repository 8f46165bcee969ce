//! Per-pixel decomposition of a campaign's dark signal (issue 31, part 2): the mean dark of
//! every pixel fitted by weighted least squares as
//!
//! - EMCCD: `mean_adu = F + (G/K) (C + t D(T))`,
//! - no EM register (sCMOS, CCD): `mean_adu = F + t D(T) / K` (CIC cannot be told from the
//!   offset without a gain to vary, so no CIC map),
//!
//! with `D(T) = D_ref 2^((T - T_ref)/T_d)` when the temperature term is on (EMVA 1288). F is the
//! offset (adu), C the clock-induced charge (e-/frame), D the dark current (e-/s), G the EM gain
//! of each condition, K the conversion gain (e-/adu). The noise is checked against D through
//! the slope of the temporal variance with exposure time (EMVA 1288's second method), and the
//! fitted EM gains make a calibration curve. A pure library step: `Vec<ConditionStats>` in,
//! maps and a summary out ([`decompose`]); [`write_outputs`] writes them.

mod classes;
mod design;
mod gain_curve;
mod noise;
mod outputs;
mod pixels;
mod summary;
mod temperature;
#[cfg(test)]
mod tests;
mod wls;

use serde::Serialize;

use super::ConditionStats;
use crate::calib::darks::TemporalNoiseSummary;
use crate::error::Result;

pub use classes::{HotClass, HotPixels, HotRule};
pub use gain_curve::{EmGainCurve, EmGainRow};
pub use noise::{GainNoiseFactor, ShotNoiseCheck};
pub use outputs::{write_outputs, OUTPUT_NAMES};

/// The conversion gain K that turns adu into electrons.
#[derive(Clone, Debug, PartialEq)]
pub enum ConversionGain {
    /// One gain for every pixel (e-/adu) with its standard error (e-/adu, 0 if unknown).
    Global {
        /// Gain (e-/adu).
        e_per_adu: f64,
        /// Its standard error (e-/adu); it scales C and D and enters the summary's systematic
        /// errors, not the per-pixel maps.
        se_e_per_adu: f64,
    },
    /// One gain per pixel (e-/adu), row-major like the stacks.
    Map(Vec<f64>),
}

/// A fitted EM gain of one commanded gain (e.g. from `emgain` on that stack).
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct EmGainFit {
    /// The commanded gain it belongs to (e-/e-), as in [`super::Condition::em_gain`].
    pub commanded: f64,
    /// The fitted gain (e-/e-).
    pub gain: f64,
    /// Its standard error (e-/e-).
    pub se: f64,
}

/// The temperature dependence of the dark current.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum TemperatureTerm {
    /// None: D is one number per pixel whatever the temperature (a note says if they vary).
    Off,
    /// `D(T) = D_ref 2^((T - T_ref)/T_d)` with the doubling temperature T_d fitted globally
    /// (deg C, with its SE); needs darks at two or more temperatures.
    Fit {
        /// T_ref (deg C); `None`: the median temperature of the darks.
        reference_c: Option<f64>,
    },
    /// The same form with a given doubling temperature.
    Given {
        /// T_d (deg C), > 0.
        doubling_c: f64,
        /// T_ref (deg C); `None`: the median temperature of the darks.
        reference_c: Option<f64>,
    },
}

/// How to decompose a campaign.
#[derive(Clone, Debug, PartialEq)]
pub struct DecomposeOptions {
    /// Conversion gain K (e-/adu).
    pub conversion_gain: ConversionGain,
    /// Fitted EM gains, one per commanded gain of the darks; empty: the commanded gains are
    /// used as exact. Given for some commanded gains, they must be given for all.
    pub em_gains: Vec<EmGainFit>,
    /// Fit the CIC map (EMCCD only; needs two or more EM gains). Off: CIC is part of F.
    pub fit_cic: bool,
    /// Temperature term of the dark current.
    pub temperature: TemperatureTerm,
    /// Stages of the EM register, for its excess noise factor F^2 in the variance check
    /// (default 604, the project's `--stages` default).
    pub register_stages: u32,
    /// Thresholds of the warm and hot pixel classes.
    pub hot: HotRule,
    /// A pixel's fit is flagged bad when its chi2 has a p-value below this (default 1e-3).
    pub bad_fit_p_value: f64,
}

impl DecomposeOptions {
    /// Defaults with conversion gain `k_e_per_adu` (e-/adu, SE unknown): commanded EM gains,
    /// CIC fitted where there is a register, no temperature term, 604 stages, warm/hot at 5/25
    /// robust sigmas above the median dark current, bad fit at p < 1e-3.
    pub fn new(k_e_per_adu: f64) -> Self {
        DecomposeOptions {
            conversion_gain: ConversionGain::Global {
                e_per_adu: k_e_per_adu,
                se_e_per_adu: 0.0,
            },
            em_gains: Vec::new(),
            fit_cic: true,
            temperature: TemperatureTerm::Off,
            register_stages: 604,
            hot: HotRule::default(),
            bad_fit_p_value: 1e-3,
        }
    }
}

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

/// Fit quality over the pixels.
#[derive(Clone, Debug, Serialize, PartialEq)]
pub struct FitQuality {
    /// Degrees of freedom of each pixel's fit (conditions minus parameters).
    pub dof: usize,
    /// Median reduced chi2 over the fitted pixels (1 when the model and the weights hold).
    pub median_reduced_chi2: f64,
    /// The p-value below which a fit is flagged.
    pub flag_p_value: f64,
    /// The reduced chi2 above which a fit is flagged (that p-value at `dof`).
    pub flag_reduced_chi2_above: f64,
    /// Pixels flagged.
    pub pixels_flagged: usize,
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

/// Decompose the dark stacks of `stats` (flats are ignored) per pixel; every check of the
/// design and the options is made before the fit, and a design that cannot separate the
/// requested terms is refused naming what is missing.
pub fn decompose(stats: &[ConditionStats], opts: &DecomposeOptions) -> Result<Decomposition> {
    let mut design = design::Design::new(stats, opts)?;
    let k = pixels::PixelGain::new(&opts.conversion_gain);
    let ones = vec![1.0; design.conds.len()];
    pixels::set_signal_floor(&mut design, &k, &ones, 1);
    let temp = temperature::resolve(&design, &k, &opts.temperature)?;
    let fit = pixels::fit_all(&design, &k, &temp.factors);
    let quality = pixels::quality(&fit, design.dof(), opts.bad_fit_p_value);
    let hot = classes::classify(&fit.d, &opts.hot);
    let shot = noise::check(&design, &k, &temp.factors, &fit, opts.register_stages);
    let summary = summary::summarise(summary::Parts {
        design: &design,
        maps: &fit,
        k: &k,
        temp: &temp,
        quality,
        hot: hot.summary,
        shot,
        curve: gain_curve::fit(&opts.em_gains),
        opts,
    });
    Ok(Decomposition {
        rows: design.rows,
        cols: design.cols,
        offset_adu: fit.f,
        offset_se_adu: fit.f_se,
        dark_current_e_per_s: fit.d,
        dark_current_se_e_per_s: fit.d_se,
        cic_e_per_frame: fit.c,
        cic_se_e_per_frame: fit.c_se,
        reduced_chi2: fit.reduced_chi2,
        hot_class: hot.classes,
        summary,
    })
}
