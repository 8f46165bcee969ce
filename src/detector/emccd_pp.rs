//! `emccd-pp` and `emccd-pp-uncorrected`: the exact EM register followed by Poisson-probability
//! thresholding into photon counts, with or without the photometric correction. The threshold
//! rule is a reconstruction of Basden, Haniff & Mackay (2003); see [`crate::detector::pp`]. Its
//! prior is the sub-aperture mean light level (or a fixed one), or with the pixel prior each
//! pixel's own level in the mean spot image. The correction is the inverse of the mean transfer
//! curve with the sub-aperture prior, and the posterior mean E[n | K] under the pixel's own
//! prior with the pixel prior. Thresholds and correction span the frame's brightest pixel.


use super::params::ModelParams;
use super::pp::{PixelPrior, PpCache, PpConfig, PpCounter, PpRule};
use super::readout::{FrameInput, PhotonNoise, Readout};
use super::register::EmRegister;
use super::spec::{ModelEntry, ModelSpec, Sensor};
use crate::rng::SimRng;

/// The parameters both PP models read.
const PARAMS: &[&str] = &["em_gain", "stages", "emccd_read_noise_e", "pp_rule", "pp_lambda"];

/// The registry entry of `emccd-pp` (photometrically corrected).
pub const CORRECTED: ModelEntry = ModelEntry {
    name: "emccd-pp",
    arg: None,
    help: "emccd-stochastic, then Poisson-probability thresholding and photometric correction",
    sensor: Sensor::Emccd,
    params: PARAMS,
    parse: |_, _| Ok(ModelSpec::EmccdPp(true)),
    build: |_, p, _| build(p, true),
};

/// The registry entry of `emccd-pp-uncorrected` (photon counts).
pub const UNCORRECTED: ModelEntry = ModelEntry {
    name: "emccd-pp-uncorrected",
    arg: None,
    help: "emccd-stochastic, then Poisson-probability thresholding into photon counts",
    sensor: Sensor::Emccd,
    params: PARAMS,
    parse: |_, _| Ok(ModelSpec::EmccdPp(false)),
    build: |_, p, _| build(p, false),
};

/// The PP readout of `p`, photometrically corrected or not.
fn build(p: &ModelParams, corrected: bool) -> crate::Result<Box<dyn Readout>> {
    Ok(Box::new(EmccdPp::new(
        EmRegister::new(p.em_gain, p.stages)?,
        p.emccd_read_noise_e,
        PpConfig::new(p.pp_rule, p.em_gain, p.emccd_read_noise_e)?,
        p.pp_lambda,
        corrected,
    )?))
}

/// Thresholded EMCCD readout.
#[derive(Debug)]
pub struct EmccdPp {
    register: EmRegister,
    read_noise_e: f64,
    cache: PpCache,
    /// Reference light level (photo-electrons per pixel); None = the sub-aperture mean.
    lambda_ref: Option<f64>,
    /// With the pixel prior: each pixel's counter from the mean spot image.
    pixel_prior: Option<PixelPrior>,
    corrected: bool,
    /// The threshold rule (its useful range).
    rule: PpRule,
}

impl EmccdPp {
    /// Register, read noise before division (e-), threshold configuration, optional fixed
    /// reference light level (refused with the pixel prior, whose levels are the pixels' own),
    /// and whether to apply the photometric correction.
    pub fn new(
        register: EmRegister,
        read_noise_e: f64,
        config: PpConfig,
        lambda_ref: Option<f64>,
        corrected: bool,
    ) -> crate::Result<Self> {
        let pixel_prior = match (config.rule, lambda_ref) {
            (PpRule::PixelPrior, Some(l)) => {
                return Err(crate::Error::invalid(
                    "pp_lambda",
                    format!(
                        "{l}: a fixed reference light level does not apply with `pp_rule` \
                         pixel-prior (each pixel's prior is its own mean level)"
                    ),
                ))
            }
            (PpRule::PixelPrior, None) => Some(PixelPrior::new(config)?),
            _ => None,
        };
        Ok(EmccdPp {
            register,
            read_noise_e,
            cache: PpCache::new(config, 64)?,
            lambda_ref,
            pixel_prior,
            corrected,
            rule: config.rule,
        })
    }

    /// Read the frame with `counter_of(pixel)` binning each pixel.
    fn read_with<'c>(
        &self,
        input: &FrameInput,
        aux: &mut SimRng,
        out: &mut [f64],
        counter_of: impl Fn(usize) -> &'c PpCounter,
    ) {
        let g = self.register.gain();
        let pixels = out.iter_mut().zip(input.photo_e).zip(input.normals);
        for (i, ((o, &k), &z)) in pixels.enumerate() {
            let em = if k == 0 {
                0.0
            } else {
                self.register.sample(k as u64, aux)
            };
            let x = (em + self.read_noise_e * z) / g;
            let counter = counter_of(i);
            // With the pixel prior the correction is the posterior mean under the pixel's
            // own prior: the inverse transfer curve of a dark pixel's counter (one boundary
            // below the span) read a lone photon as tens to hundreds of photo-electrons.
            *o = if self.corrected && self.pixel_prior.is_some() {
                counter.posterior(x)
            } else if self.corrected {
                counter.corrected(x)
            } else {
                counter.count(x) as f64
            };
        }
    }
}

impl Readout for EmccdPp {
    fn name(&self) -> String {
        if self.corrected {
            "emccd-pp".into()
        } else {
            "emccd-pp-uncorrected".into()
        }
    }

    fn read(&self, input: &FrameInput, aux: &mut SimRng, out: &mut [f64]) {
        // The levels are validated when the model is built and the signal is > 0, so a failure
        // here is a bug, not bad input.
        // The counters span the frame's brightest expected pixel: a fixed span clipped bright
        // pixels, and R grew with the signal.
        let peak = input.expected_e.iter().copied().fold(0.0, f64::max);
        let lambda_max = self.cache.config().spanning(peak).lambda_max;
        if let Some(prior) = &self.pixel_prior {
            let counters = prior
                .counters(input.mean_e, lambda_max)
                .expect("PP thresholds for a valid light level");
            return self.read_with(input, aux, out, |i| &counters[i]);
        }
        let lambda = self.lambda_ref.unwrap_or_else(|| {
            input.expected_e.iter().sum::<f64>() / input.expected_e.len() as f64
        });
        let counter = self
            .cache
            .get_spanning(lambda.max(PixelPrior::FLOOR_E), lambda_max)
            .expect("PP thresholds for a valid light level");
        self.read_with(input, aux, out, |_| &counter);
    }

    fn noise_scale_e(&self) -> f64 {
        self.read_noise_e / self.register.gain()
    }

    // Thresholding is processing of an EMCCD's output: the floor is the register's, not a
    // photon counter's (the photon variance factor of 1 would floor it as one).
    fn photon_noise(&self) -> PhotonNoise {
        PhotonNoise::EmRegister
    }

    fn in_range(&self, mean_e_per_px: f64) -> Option<bool> {
        Some(self.rule.in_range(mean_e_per_px))
    }
}

#[cfg(test)]
mod tests;
