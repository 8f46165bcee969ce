//! Poisson-probability (PP) thresholding of EMCCD output (Basden, Haniff & Mackay 2003) and its
//! photometric correction: the thresholds, the bin count of a pixel, and the mean transfer curve.
//!
//! **This is a reconstruction.** The 2003 paper that defines the thresholds could not be read; SPEC
//! ("Poisson-probability thresholding") and notes section 2.5 fix the rule used here:
//!
//! * Rule A ([`PpRule::PoissonPrior`], the default): for a pixel of mean light level `lambda`
//!   photo-electrons the boundary between `n` and `n + 1` counts is where
//!   `Pois(n; lambda) p(x | n) = Pois(n + 1; lambda) p(x | n + 1)` with the Erlang register output
//!   `p(x | n)`, which is `x / g = n (n + 1) / lambda` for `n >= 1`. The 0|1 boundary is where the
//!   zero-electron Gaussian read-noise peak and the one-electron exponentially modified Gaussian are
//!   equally likely under the same prior ([`zero_one_threshold_e`]), or a fixed `k * sigma`.
//! * Per-pixel prior ([`PpRule::PixelPrior`]): Rule A with each pixel's own mean light level
//!   in the noiseless centred spot (the mean spot image an AO system knows) as `lambda`, so each
//!   pixel has its own boundaries and photometric correction ([`PixelPrior`]).
//! * Rule B ([`PpRule::EqualDensity`]): the literal reading, fixed boundaries where the output
//!   densities of Poisson light levels `n` and `n + 1` are equal (about 0.203, 0.719, 1.896,
//!   2.936 g for g = 500, read noise 50 e-). It hardly reduces noise; it is kept as a documented
//!   alternative.
//!
//! The output model is the exact Gamma register (`Gamma(n, g)` for `n >= 1` input electrons, 0 for
//! none) plus Gaussian read noise, in output electrons; thresholds are in units of the mean gain
//! `g`, so a readout that divides by `g` can compare directly. The photometric correction inverts
//! the mean transfer curve `E[K | lambda] = sum_k P(X > t_k | lambda)` by interpolation on a
//! tabulated `lambda` grid; the per-count inverse is precomputed, so correcting a pixel is a lookup.
//!
//! Use in a readout (the register output plus read noise, divided by g, is `x_over_g`):
//!
//! ```
//! use detnoise::detector::pp::{PpCache, PpConfig, PpRule};
//! let cache = PpCache::new(PpConfig::new(PpRule::PoissonPrior, 500.0, 50.0)?, 1024)?;
//! // Once per frame: the sub-aperture's photo-electrons per pixel.
//! let counter = cache.get(50.0 / 64.0)?;
//! let x_over_g = 1.3;
//! let photons = counter.count(x_over_g); // `emccd-pp-uncorrected`
//! let lambda_hat = counter.corrected(x_over_g); // `emccd-pp`
//! assert_eq!(photons, 1);
//! assert!(lambda_hat > 0.0);
//! # Ok::<(), detnoise::Error>(())
//! ```
//!
//! Cost (release build, `cargo run --release --example pp_cost`): a Rule A [`PpCounter`] takes
//! 0.4 ms (lambda_ref 0.05) to 1 ms (lambda_ref 20) to build with the default `lambda_max`, mostly
//! the exact per-electron transfer table; Rule B takes about 0.36 s, once per run. A readout whose
//! reference light level changes per frame should use [`PpCache`]: the sub-aperture mean
//! photo-electrons per pixel (total / pixels) takes few distinct values, so almost every frame
//! is a cache hit (about 1 us).
//!
//! Layout: [`PpConfig`] (rule, gain, read noise) makes [`PpThresholds`] (`thresholds`, from the
//! output densities in `density`) and a [`PhotometricCorrection`] (`correction`, from the exact
//! survival functions in `survival`), joined in a [`PpCounter`]; [`PpCache`] keeps counters per
//! reference light level, [`PixelPrior`] one counter per pixel of a mean image. The readout
//! itself is [`crate::detector::EmccdPp`].

mod cache;
mod config;
mod correction;
mod counter;
mod density;
mod pixel;
mod posterior;
mod survival;
mod thresholds;

pub use cache::PpCache;
pub use config::{PpConfig, PpRule, ZeroOneRule};
pub use correction::PhotometricCorrection;
pub use counter::PpCounter;
pub use pixel::{PixelCounters, PixelPrior};
pub use posterior::posterior_by_count;
pub use survival::{p_exceed, survival_by_n};
pub use thresholds::{rule_a_threshold_over_g, zero_one_threshold_e, PpThresholds};

#[cfg(test)]
mod tests;
