//! What a decomposition is given: the conversion gain, the fitted EM gains, the temperature
//! term, and the options of the fit.

use serde::Serialize;

use super::classes::HotRule;

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
