//! `emccd-pp`: the exact EM register followed by Poisson-probability thresholding into photon
//! counts, with or without the photometric correction. The threshold rule is a reconstruction
//! of Basden, Haniff & Mackay (2003); see [`crate::pp`].

use super::{EmRegister, FrameInput, Readout};
use crate::pp::{PpCache, PpConfig};
use crate::rng::SimRng;
use rand_distr::{Distribution, StandardNormal};

/// Thresholded EMCCD readout.
#[derive(Debug)]
pub struct EmccdPp {
    register: EmRegister,
    read_noise_e: f64,
    cache: PpCache,
    /// Reference light level (photo-electrons per pixel); None = the sub-aperture mean.
    lambda_ref: Option<f64>,
    corrected: bool,
}

impl EmccdPp {
    /// Register, read noise before division (e-), threshold configuration, optional fixed
    /// reference light level, and whether to apply the photometric correction.
    pub fn new(
        register: EmRegister,
        read_noise_e: f64,
        config: PpConfig,
        lambda_ref: Option<f64>,
        corrected: bool,
    ) -> crate::Result<Self> {
        Ok(EmccdPp {
            register,
            read_noise_e,
            cache: PpCache::new(config, 64)?,
            lambda_ref,
            corrected,
        })
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

    fn read(&self, input: &FrameInput, noise: &mut SimRng, aux: &mut SimRng, out: &mut [f64]) {
        let lambda = self.lambda_ref.unwrap_or_else(|| {
            input.expected_e.iter().sum::<f64>() / input.expected_e.len() as f64
        });
        // The reference is validated when the model is built and the signal is > 0, so a
        // failure here is a bug, not bad input.
        let counter = self
            .cache
            .get(lambda.max(1e-9))
            .expect("PP thresholds for a valid light level");
        let g = self.register.gain();
        for (o, &k) in out.iter_mut().zip(input.photo_e) {
            let em = if k == 0 {
                0.0
            } else {
                self.register.sample(k as u64, aux)
            };
            let z: f64 = StandardNormal.sample(noise);
            let x = (em + self.read_noise_e * z) / g;
            *o = if self.corrected {
                counter.corrected(x)
            } else {
                counter.count(x) as f64
            };
        }
    }

    fn noise_scale_e(&self) -> f64 {
        self.read_noise_e / self.register.gain()
    }
}
