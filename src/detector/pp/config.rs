//! What fixes a PP readout besides the reference light level: the rule, the 0|1 boundary, the
//! gain and read noise, and the light range covered; it builds thresholds and counters.

use super::correction::PhotometricCorrection;
use super::counter::PpCounter;
use super::thresholds::{
    check_lambda, output_span_over_g, rule_a_thresholds, rule_b_thresholds, zero_one_threshold_e,
    PpThresholds,
};
use crate::error::{Error, Result};

/// Which boundaries between photon counts are used (see the module documentation).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum PpRule {
    /// Rule A: MAP boundaries under a Poisson prior of mean `lambda_ref`, `t_n / g = n (n + 1) / lambda_ref`.
    PoissonPrior,
    /// Rule B: fixed boundaries where the output densities of light levels `n` and `n + 1` are equal.
    EqualDensity,
    /// Rule A per pixel: each pixel's own prior, its mean light level in the noiseless spot
    /// (the mean spot image a closed-loop controller knows), so each pixel has its own
    /// boundaries and photometric correction.
    PixelPrior,
}

impl PpRule {
    /// Every rule, in the order of the `--pp-rule` values.
    pub const ALL: [PpRule; 3] = [
        PpRule::PoissonPrior,
        PpRule::EqualDensity,
        PpRule::PixelPrior,
    ];

    /// The rules' names, in the order of [`PpRule::ALL`].
    pub const NAMES: [&'static str; 3] = ["poisson-prior", "equal-density", "pixel-prior"];

    /// The rule's name on the command line and in tables.
    pub fn label(self) -> &'static str {
        Self::NAMES[self as usize]
    }

    /// The rule named `label` (see [`PpRule::label`]).
    pub fn parse(label: &str) -> Option<PpRule> {
        Self::ALL.into_iter().find(|r| r.label() == label)
    }

    /// Mean photo-electrons per pixel that splits the rules' useful ranges (docs/models.md's
    /// table at 16x16 px): below it the pixel prior lowers R (0.80-0.89 of the analogue
    /// EMCCD's) and the sub-aperture-mean rules lose 24-35 % or far more (1.0 px against 0.19
    /// at 0.08 e- per pixel); above it the pixel prior loses 1.8-4.3x and the sub-aperture-mean
    /// rules follow the analogue EMCCD (within 9 %, 2.5 % from 2 e- per pixel).
    pub const RANGE_SPLIT_E_PER_PX: f64 = 0.4;

    /// Whether the rule's R describes a usable camera at `mean_e_per_px` (the sub-aperture's
    /// mean photo-electrons per pixel): the pixel prior at or below
    /// [`PpRule::RANGE_SPLIT_E_PER_PX`], the sub-aperture-mean rules at or above it.
    pub fn in_range(self, mean_e_per_px: f64) -> bool {
        match self {
            PpRule::PixelPrior => mean_e_per_px <= Self::RANGE_SPLIT_E_PER_PX,
            PpRule::PoissonPrior | PpRule::EqualDensity => {
                mean_e_per_px >= Self::RANGE_SPLIT_E_PER_PX
            }
        }
    }
}

/// How the 0|1 boundary is placed.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum ZeroOneRule {
    /// The rule's own equal-probability (Rule A) or equal-density (Rule B) boundary.
    Equal,
    /// A fixed boundary at `k` times the read noise (output electrons).
    KSigma(f64),
}

/// Everything that fixes a PP readout except the reference light level.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PpConfig {
    /// Threshold rule.
    pub rule: PpRule,
    /// Placement of the 0|1 boundary.
    pub zero_one: ZeroOneRule,
    /// Mean EM gain g (output electrons per photo-electron).
    pub gain: f64,
    /// Read noise in output electrons rms (before division by g).
    pub read_noise_e: f64,
    /// Largest mean photo-electrons per pixel the correction must cover; brighter pixels saturate.
    pub lambda_max: f64,
}

impl PpConfig {
    /// Default largest light level covered by the thresholds and the correction, photo-electrons per pixel.
    pub const DEFAULT_LAMBDA_MAX: f64 = 256.0;
    /// Reference light levels below this (photo-electrons per pixel) are raised to it (Rule A).
    pub const LAMBDA_MIN: f64 = 1e-6;

    /// A configuration with the rule's own 0|1 boundary and the default `lambda_max`; checks the values.
    pub fn new(rule: PpRule, gain: f64, read_noise_e: f64) -> Result<Self> {
        let cfg = PpConfig {
            rule,
            zero_one: ZeroOneRule::Equal,
            gain,
            read_noise_e,
            lambda_max: Self::DEFAULT_LAMBDA_MAX,
        };
        cfg.validate()?;
        Ok(cfg)
    }

    /// Checks that gain, read noise, `lambda_max` and `k` are finite and in range.
    pub fn validate(&self) -> Result<()> {
        if !(self.gain.is_finite() && self.gain > 0.0) {
            return Err(Error::invalid(
                "em_gain",
                format!("EM gain must be > 0, got {}", self.gain),
            ));
        }
        if !(self.read_noise_e.is_finite() && self.read_noise_e >= 0.0) {
            return Err(Error::invalid(
                "emccd_read_noise_e",
                format!("read noise must be >= 0 e-, got {}", self.read_noise_e),
            ));
        }
        if !(self.lambda_max.is_finite()
            && self.lambda_max > 0.0
            && self.lambda_max <= Self::LAMBDA_MAX_BOUND)
        {
            return Err(Error::invalid(
                "pp_lambda_max",
                format!(
                    "must be in (0, 1e5] photo-electrons, got {}",
                    self.lambda_max
                ),
            ));
        }
        if let ZeroOneRule::KSigma(k) = self.zero_one {
            if !(k.is_finite() && k > 0.0) || self.read_noise_e == 0.0 {
                return Err(Error::invalid(
                    "pp_zero_one",
                    format!(
                        "k*sigma threshold needs k > 0 and `emccd_read_noise_e` > 0, got k = {k}"
                    ),
                ));
            }
        }
        Ok(())
    }

    /// The thresholds for reference light level `lambda_ref` (photo-electrons per pixel, >= 0;
    /// ignored by Rule B; a pixel's own level for the pixel prior).
    pub fn thresholds(&self, lambda_ref: f64) -> Result<PpThresholds> {
        self.validate()?;
        let u_max = output_span_over_g(self.lambda_max);
        let mut t = match self.rule {
            // The pixel prior is Rule A at each pixel's own level.
            PpRule::PoissonPrior | PpRule::PixelPrior => {
                check_lambda(lambda_ref, "pp_lambda")?;
                // A dark frame (lambda 0) gets the thresholds of a very faint one: practically
                // everything counts 0, which is the MAP answer.
                let lambda = lambda_ref.max(Self::LAMBDA_MIN);
                let t0 = zero_one_threshold_e(lambda, self.gain, self.read_noise_e)? / self.gain;
                rule_a_thresholds(t0, lambda, u_max)
            }
            PpRule::EqualDensity => rule_b_thresholds(self.gain, self.read_noise_e, u_max)?,
        };
        if let ZeroOneRule::KSigma(k) = self.zero_one {
            t[0] = k * self.read_noise_e / self.gain;
            if t.len() > 1 && t[0] >= t[1] {
                return Err(Error::invalid(
                    "pp_zero_one",
                    format!("{k} sigma lies above the 1|2 boundary ({:.3} g)", t[1]),
                ));
            }
        }
        Ok(PpThresholds {
            t_over_g: t,
            gain: self.gain,
            read_noise_e: self.read_noise_e,
        })
    }

    /// Largest `lambda_max` (photo-electrons per pixel), the bound `validate` checks.
    pub const LAMBDA_MAX_BOUND: f64 = 1e5;

    /// This configuration with `lambda_max` raised, when a pixel of `peak_e` photo-electrons
    /// (a frame's brightest expected pixel) needs it, to the power of two at or above twice
    /// `peak_e` (so a run's frames share a few values), at most [`Self::LAMBDA_MAX_BOUND`].
    ///
    /// Thresholds and correction span outputs up to a pixel of `lambda_max`: a brighter
    /// pixel's count saturates there and its corrected level with it. With the default 256 a
    /// point-sampled 2 px Airy spot of 1000 photons on 16x16 px (brightest pixel about 290 e-)
    /// was clipped, and `emccd-pp`'s R grew with the signal.
    pub fn spanning(&self, peak_e: f64) -> PpConfig {
        let need = (2.0 * peak_e).max(1.0).log2().ceil().exp2();
        PpConfig {
            lambda_max: self.lambda_max.max(need.min(Self::LAMBDA_MAX_BOUND)),
            ..*self
        }
    }

    /// Thresholds plus photometric correction for `lambda_ref` (photo-electrons per pixel).
    pub fn counter(&self, lambda_ref: f64) -> Result<PpCounter> {
        let thresholds = self.thresholds(lambda_ref)?;
        let correction = PhotometricCorrection::new(&thresholds, self.lambda_max)?;
        let posterior = super::posterior::posterior_by_count(
            &thresholds,
            lambda_ref.max(Self::LAMBDA_MIN),
            self.lambda_max,
            |k| correction.lambda_for_count(k),
        );
        Ok(PpCounter {
            lambda_ref,
            thresholds,
            correction,
            posterior,
        })
    }
}
