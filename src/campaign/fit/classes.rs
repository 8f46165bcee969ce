//! Pixel classes by dark current: normal, warm, hot (and not fitted), with thresholds in e-/s
//! given or set from the median and robust sigma of the dark-current map.

use serde::Serialize;

use crate::stats::median_and_robust_sigma;

/// The thresholds of the warm and hot classes.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum HotRule {
    /// Warm above median + `warm_sigmas` x robust sigma of D, hot above median + `hot_sigmas`
    /// x robust sigma (the robust sigma holds the pixels' statistical noise as well as the
    /// true spread).
    Robust {
        /// Robust sigmas above the median for warm (default 5).
        warm_sigmas: f64,
        /// Robust sigmas above the median for hot (default 25).
        hot_sigmas: f64,
    },
    /// Warm above `warm_e_per_s`, hot above `hot_e_per_s` (e-/s).
    Absolute {
        /// Warm threshold (e-/s).
        warm_e_per_s: f64,
        /// Hot threshold (e-/s).
        hot_e_per_s: f64,
    },
}

impl Default for HotRule {
    fn default() -> Self {
        HotRule::Robust {
            warm_sigmas: 5.0,
            hot_sigmas: 25.0,
        }
    }
}

/// A pixel's class (the value in hot_class.fits).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum HotClass {
    /// Dark current at or below the warm threshold (0).
    Normal = 0,
    /// Above the warm threshold (1).
    Warm = 1,
    /// Above the hot threshold (2).
    Hot = 2,
    /// Not fitted: a non-finite or zero variance at some condition (3).
    NotFitted = 3,
}

/// The classes in numbers (decomposition.json).
#[derive(Clone, Debug, Serialize, PartialEq)]
pub struct HotPixels {
    /// The rule, in words.
    pub rule: String,
    /// Median dark current over the fitted pixels (e-/s).
    pub median_e_per_s: f64,
    /// Robust sigma of the dark current (e-/s).
    pub robust_sigma_e_per_s: f64,
    /// Warm above (e-/s).
    pub warm_above_e_per_s: f64,
    /// Hot above (e-/s).
    pub hot_above_e_per_s: f64,
    /// Normal pixels.
    pub normal: usize,
    /// Warm pixels.
    pub warm: usize,
    /// Hot pixels.
    pub hot: usize,
    /// Pixels not fitted.
    pub not_fitted: usize,
}

/// The classes of every pixel and their summary.
pub(super) struct Classes {
    /// Per pixel.
    pub classes: Vec<HotClass>,
    /// Counts and thresholds.
    pub summary: HotPixels,
}

/// Classify the dark-current map `d` (e-/s, NaN where not fitted) by `rule`.
pub(super) fn classify(d: &[f64], rule: &HotRule) -> Classes {
    let (m, s) = median_and_robust_sigma(d);
    let (warm, hot, words) = match *rule {
        HotRule::Robust {
            warm_sigmas,
            hot_sigmas,
        } => (
            m + warm_sigmas * s,
            m + hot_sigmas * s,
            format!(
                "warm above median + {warm_sigmas} robust sigma, hot above median + \
                 {hot_sigmas} robust sigma of the dark current"
            ),
        ),
        HotRule::Absolute {
            warm_e_per_s,
            hot_e_per_s,
        } => (
            warm_e_per_s,
            hot_e_per_s,
            format!("warm above {warm_e_per_s} e-/s, hot above {hot_e_per_s} e-/s"),
        ),
    };
    let classes: Vec<HotClass> = d
        .iter()
        .map(|&v| {
            if !v.is_finite() {
                HotClass::NotFitted
            } else if v > hot {
                HotClass::Hot
            } else if v > warm {
                HotClass::Warm
            } else {
                HotClass::Normal
            }
        })
        .collect();
    let count = |c: HotClass| classes.iter().filter(|&&x| x == c).count();
    let summary = HotPixels {
        rule: words,
        median_e_per_s: m,
        robust_sigma_e_per_s: s,
        warm_above_e_per_s: warm,
        hot_above_e_per_s: hot,
        normal: count(HotClass::Normal),
        warm: count(HotClass::Warm),
        hot: count(HotClass::Hot),
        not_fitted: count(HotClass::NotFitted),
    };
    Classes { classes, summary }
}
