//! The result of an EM-gain fit (the content of `emgain.json`), its start values and the
//! cross-check routes to the gain.

use serde::{Deserialize, Serialize};

use super::mixture::LambdaMixture;
use super::options::{EmShape, SerialCic};

/// Start values of the fit (notes 6.2).
#[derive(Debug, Clone, Copy, Serialize, Deserialize)]
pub struct EmStart {
    /// Bias: leftmost significant peak of the smoothed histogram (adu).
    pub bias_adu: f64,
    /// Read noise: rms of the values below the bias (adu).
    pub read_noise_adu: f64,
    /// Gain: mean excess over bias + 6 read noise (tail memorylessness) at low light,
    /// else (mean - bias) / lambda (adu per e-).
    pub gain_adu_per_e: f64,
    /// Mean input electrons from the fraction below the bias: -ln(2 P(x < b)).
    pub lambda_e: f64,
}

/// Cross-check routes to the gain, beside the histogram fit.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct EmCrossChecks {
    /// Excess noise factor squared used (2 for the Gamma model).
    pub excess_noise_factor_sq: f64,
    /// (variance - read noise^2) / ((mean - bias) F^2): photon transfer with the ENF (adu/e-).
    pub mean_variance_gain_adu_per_e: f64,
    /// The same ignoring the excess noise factor (what a naive photon transfer gives).
    pub mean_variance_gain_no_enf_adu_per_e: f64,
    /// Mean signal above bias (adu) and variance (adu^2) of the fitted values.
    pub mean_signal_adu: f64,
    /// Variance of the fitted values (adu^2).
    pub variance_adu2: f64,
}

/// The result of an EM-gain fit: the content of `emgain.json`.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct EmGainFit {
    /// EM gain in `em_gain_units`.
    pub em_gain: f64,
    /// Its standard error.
    pub em_gain_se: f64,
    /// "e-/e-" (output electrons per input electron, conversion gain given) or "adu/e-".
    pub em_gain_units: String,
    /// Gain in adu per input electron (G = g / conversion).
    pub gain_adu_per_e: f64,
    /// Its standard error (adu/e-).
    pub gain_adu_per_e_se: f64,
    /// Bias (adu).
    pub bias_adu: f64,
    /// Its standard error (adu).
    pub bias_adu_se: f64,
    /// Read noise (adu rms).
    pub read_noise_adu: f64,
    /// Its standard error (adu).
    pub read_noise_adu_se: f64,
    /// Read noise referred to the input (e- rms) = read noise / G.
    pub read_noise_input_e: f64,
    /// Mean input electrons per pixel-sample (photo + dark + parallel CIC: on dark frames
    /// the parallel CIC and dark charge per pixel and frame).
    pub lambda_e: f64,
    /// Its standard error.
    pub lambda_e_se: f64,
    /// Serial CIC electrons per pixel-sample (born inside the register), if fitted.
    pub serial_cic_e: Option<f64>,
    /// Its standard error.
    pub serial_cic_e_se: Option<f64>,
    /// The comparison of the fits without and with serial CIC (absent when it was off).
    pub serial_cic_test: Option<SerialCicTest>,
    /// The conversion gain used (e- per adu), if given.
    pub gain_e_per_adu: Option<f64>,
    /// Single-electron law of the model.
    pub shape: EmShape,
    /// The law in words.
    pub law: String,
    /// Whether Nelder-Mead converged (always true: a failed fit is an error).
    pub converged: bool,
    /// Nelder-Mead iterations.
    pub iterations: u64,
    /// Maximised multinomial log-likelihood of the binned values.
    pub log_likelihood: f64,
    /// Pixel-samples fitted.
    pub n_samples: f64,
    /// Pixel-samples excluded (above `max_value_adu`).
    pub n_excluded: f64,
    /// Upper limit of the fitted values (adu).
    pub max_value_adu: f64,
    /// Width of the fitted bins (adu).
    pub bin_width_adu: f64,
    /// Correlations of the free parameters among (bias, ln read noise, ln G, ln lambda,
    /// ln serial CIC), in that order.
    pub correlations: Option<Vec<Vec<f64>>>,
    /// The pixels' spread of mean charge the light term was fitted with (absent: one lambda
    /// for all pixels).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub lambda_mixture: Option<LambdaMixture>,
    /// The mean charge from the zero-electron peak alone, beside the fit's (absent unless
    /// asked for, see [`super::zero_peak_lambda`]).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub zero_peak: Option<ZeroPeak>,
    /// Start values.
    pub start: EmStart,
    /// Other routes to the gain.
    pub cross_checks: EmCrossChecks,
}

/// Whether the frames hold serial CIC: the fits without and with it on the same bins.
///
/// The likelihood ratio of nested models with the rate on the boundary (0) of its range
/// follows 1/2 chi^2_0 + 1/2 chi^2_1 where there is none; the BIC difference
/// (ratio - ln n, n pixel-samples) decides on auto: > 0 keeps serial CIC (about 1 in 4000
/// stacks without it would be called present at n = 10^5).
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct SerialCicTest {
    /// What was asked: auto (decide), on or off.
    pub mode: SerialCic,
    /// The verdict: the kept model has serial CIC.
    pub present: bool,
    /// Maximised log-likelihood without serial CIC (None if that fit failed).
    pub log_likelihood_without: Option<f64>,
    /// Maximised log-likelihood with serial CIC (None if that fit failed).
    pub log_likelihood_with: Option<f64>,
    /// 2 (ln L with - ln L without).
    pub likelihood_ratio: Option<f64>,
    /// Probability of a ratio this large without serial CIC (1/2 chi^2_1 tail).
    pub p_value: Option<f64>,
    /// BIC without minus BIC with (= ratio - ln n): > 0 favours serial CIC.
    pub delta_bic: Option<f64>,
    /// Serial CIC rate of the fit with it (e- per pixel-sample), kept or not.
    pub serial_cic_e: Option<f64>,
    /// Its standard error.
    pub serial_cic_e_se: Option<f64>,
    /// Why a fit is missing, if one failed.
    pub note: Option<String>,
}

/// The ratio-of-means route: EM gain (e-/e-) from the mean signal above bias at gain and
/// at unity EM gain under the same light (both adu).
pub fn gain_from_mean_ratio(signal_adu: f64, reference_signal_adu: f64) -> f64 {
    signal_adu / reference_signal_adu
}

/// The zero-electron peak's estimate of the mean input charge.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ZeroPeak {
    /// Fraction of the pixel-samples below the fitted bias.
    pub fraction_below_bias: f64,
    /// Fraction of the pixel-samples the fitted model puts below the bias from one or more
    /// (input or serial-CIC) electrons.
    pub events_below_bias: f64,
    /// Probability of a pixel-sample without any electron: 2 (fraction - events).
    pub p_zero: f64,
    /// Its binomial SE, 2 sqrt(F (1 - F) / n): an upper bound, because the bias is fitted to
    /// the same values (for a Gaussian peak alone the SE is 0.6 of it).
    pub p_zero_se: f64,
    /// Mean input electrons per pixel-sample (e-): p_zero = P(no input electron) x
    /// exp(-serial CIC), with the fit's serial CIC and pixels' spread of charge.
    pub lambda_e: f64,
    /// Its SE (e-), from `p_zero_se`.
    pub lambda_e_se: f64,
}
