//! What a decomposition is given: the conversion gain, the fitted EM gains, the temperature
//! term, and the options of the fit.

use serde::Serialize;

use super::classes::HotRule;
use crate::error::{Error, Result};

/// Largest threshold of the warm and hot classes in robust sigmas of the dark-current map:
/// beyond it no pixel of a map of a million is classed by chance or by its spread alone.
pub const MAX_CLASS_SIGMAS: f64 = 1e3;
/// Largest threshold of the warm and hot classes in e-/s: a dark current that fills a full
/// well (~1e6 e-) within a second.
pub const MAX_CLASS_E_PER_S: f64 = 1e6;
/// Default p-value below which a pixel's fit is flagged bad.
pub const DEFAULT_BAD_FIT_P_VALUE: f64 = 1e-3;

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
            bad_fit_p_value: DEFAULT_BAD_FIT_P_VALUE,
        }
    }

    /// These options with the user's thresholds `t`.
    pub fn with_thresholds(self, t: FitThresholds) -> Self {
        DecomposeOptions {
            hot: t.hot,
            bad_fit_p_value: t.bad_fit_p_value,
            ..self
        }
    }
}

/// The thresholds of a decomposition a user sets (`campaign --warm-sigma`, ...): the warm and
/// hot pixel classes and the bad-fit p-value.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FitThresholds {
    /// Thresholds of the warm and hot classes.
    pub hot: HotRule,
    /// A pixel's fit is flagged bad when its chi2 has a p-value below this (unitless).
    pub bad_fit_p_value: f64,
}

impl Default for FitThresholds {
    /// Warm/hot at 5/25 robust sigmas above the median dark current, bad fit at p < 1e-3.
    fn default() -> Self {
        FitThresholds {
            hot: HotRule::default(),
            bad_fit_p_value: DEFAULT_BAD_FIT_P_VALUE,
        }
    }
}

impl FitThresholds {
    /// Check every value before any frame is read: thresholds in (0, max] of their unit and
    /// warm below hot, the p-value in (0, 1); the error names the field at fault.
    pub fn check(&self) -> Result<()> {
        let (warm, hot, max, unit, names) = match self.hot {
            HotRule::Robust {
                warm_sigmas,
                hot_sigmas,
            } => (
                warm_sigmas,
                hot_sigmas,
                MAX_CLASS_SIGMAS,
                "robust sigmas",
                ["warm_sigma", "hot_sigma"],
            ),
            HotRule::Absolute {
                warm_e_per_s,
                hot_e_per_s,
            } => (
                warm_e_per_s,
                hot_e_per_s,
                MAX_CLASS_E_PER_S,
                "e-/s",
                ["warm_e_per_s", "hot_e_per_s"],
            ),
        };
        for (field, v) in names.iter().zip([warm, hot]) {
            if !(v > 0.0 && v <= max) {
                return Err(Error::invalid(
                    *field,
                    format!("{v} {unit}: must be > 0 and at most {max:e}"),
                ));
            }
        }
        if warm >= hot {
            return Err(Error::invalid(
                names[1],
                format!(
                    "{hot} {unit}: the hot threshold must be above the warm one (`{}` {warm})",
                    names[0]
                ),
            ));
        }
        let p = self.bad_fit_p_value;
        if !(p > 0.0 && p < 1.0) {
            return Err(Error::invalid(
                "bad_fit_p_value",
                format!("{p}: must be in (0, 1)"),
            ));
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn thresholds_are_bounded_and_errors_name_the_field() {
        assert!(FitThresholds::default().check().is_ok());
        let field = |hot: HotRule, p: f64| match (FitThresholds {
            hot,
            bad_fit_p_value: p,
        })
        .check()
        {
            Err(Error::Usage { field, .. }) => field,
            other => panic!("{other:?}"),
        };
        let robust = |warm_sigmas, hot_sigmas| HotRule::Robust {
            warm_sigmas,
            hot_sigmas,
        };
        let absolute = |warm_e_per_s, hot_e_per_s| HotRule::Absolute {
            warm_e_per_s,
            hot_e_per_s,
        };
        assert_eq!(field(robust(0.0, 25.0), 1e-3), "warm_sigma");
        assert_eq!(field(robust(5.0, 2e3), 1e-3), "hot_sigma");
        assert_eq!(field(robust(5.0, f64::NAN), 1e-3), "hot_sigma");
        assert_eq!(field(robust(30.0, 25.0), 1e-3), "hot_sigma");
        assert_eq!(field(absolute(-1.0, 5.0), 1e-3), "warm_e_per_s");
        assert_eq!(field(absolute(1.0, 1e7), 1e-3), "hot_e_per_s");
        assert_eq!(field(robust(5.0, 25.0), 1.0), "bad_fit_p_value");
        assert_eq!(field(robust(5.0, 25.0), 0.0), "bad_fit_p_value");
        assert!(FitThresholds {
            hot: absolute(1.0, 1e6),
            bad_fit_p_value: 0.5
        }
        .check()
        .is_ok());
    }
}
