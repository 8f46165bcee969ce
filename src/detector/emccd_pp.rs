//! `emccd-pp` and `emccd-pp-uncorrected`: the exact EM register followed by Poisson-probability
//! thresholding into photon counts, with or without the photometric correction. The threshold
//! rule is a reconstruction of Basden, Haniff & Mackay (2003); see [`crate::detector::pp`].


use super::params::ModelParams;
use super::pp::{PpCache, PpConfig};
use super::readout::{FrameInput, Readout};
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

    fn read(&self, input: &FrameInput, aux: &mut SimRng, out: &mut [f64]) {
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
        for ((o, &k), &z) in out.iter_mut().zip(input.photo_e).zip(input.normals) {
            let em = if k == 0 {
                0.0
            } else {
                self.register.sample(k as u64, aux)
            };
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::detector::pp::PpRule;
    use crate::detector::readout::sampling::pixel_samples;
    use crate::special::norm_cdf;

    /// Gain 2^9 with 9 stages doubles every electron at every stage: k electrons give exactly
    /// 512 k, so x / g = k + (sigma / g) z and the count distribution is known in closed form.
    const G: f64 = 512.0;
    const SIGMA: f64 = 50.0;

    fn model(lambda_ref: Option<f64>, corrected: bool) -> EmccdPp {
        let config = PpConfig::new(PpRule::PoissonPrior, G, SIGMA).unwrap();
        let register = EmRegister::new(G, 9).unwrap();
        EmccdPp::new(register, SIGMA, config, lambda_ref, corrected).unwrap()
    }

    #[test]
    fn counts_and_corrections_follow_the_exact_output() {
        // P(K > j) = P(x > t_j) = sum_k Pois(k; lambda) Phi((k - t_j) g / sigma); from it the
        // mean and variance of the count and of the corrected level (a lookup by count).
        // The sample means agree within 4 SE, SE = sd / sqrt(N) from the analytic sd.
        let lambda = 1.0;
        let counter = PpConfig::new(PpRule::PoissonPrior, G, SIGMA)
            .unwrap()
            .counter(lambda)
            .unwrap();
        let pois: Vec<f64> = (0..40)
            .scan((-lambda).exp(), |p, k| {
                let now = *p;
                *p *= lambda / (k + 1) as f64;
                Some(now)
            })
            .collect();
        let above: Vec<f64> = counter
            .thresholds
            .t_over_g
            .iter()
            .map(|&t| {
                pois.iter()
                    .enumerate()
                    .map(|(k, p)| p * norm_cdf((k as f64 - t) * G / SIGMA))
                    .sum()
            })
            .collect();
        // P(K = j) = P(K > j - 1) - P(K > j), with P(K > -1) = 1.
        let p_count: Vec<f64> = (0..=above.len())
            .map(|j| {
                let hi = if j == 0 { 1.0 } else { above[j - 1] };
                hi - above.get(j).copied().unwrap_or(0.0)
            })
            .collect();
        let moments = |value: &dyn Fn(usize) -> f64| {
            let m: f64 = p_count.iter().enumerate().map(|(j, p)| p * value(j)).sum();
            let m2: f64 = p_count.iter().enumerate().map(|(j, p)| p * value(j).powi(2)).sum();
            (m, m2 - m * m)
        };
        let n = 200_000;
        for corrected in [false, true] {
            let (mean, var) = if corrected {
                moments(&|j| counter.correction.lambda_for_count(j))
            } else {
                moments(&|j| j as f64)
            };
            let xs = pixel_samples(&model(Some(lambda), corrected), lambda, n);
            let m = xs.iter().sum::<f64>() / n as f64;
            assert!(
                (m - mean).abs() < 4.0 * (var / n as f64).sqrt(),
                "corrected {corrected}: mean {m} vs {mean}"
            );
            if !corrected {
                assert!(xs.iter().all(|x| x.fract() == 0.0 && *x >= 0.0));
            }
        }
    }

    #[test]
    fn default_reference_is_the_sub_aperture_mean() {
        // Without a fixed reference the thresholds follow the frame's mean expected light, so
        // a frame whose mean is 1 photo-electron reads exactly as with a fixed reference of 1.
        for corrected in [false, true] {
            let fixed = pixel_samples(&model(Some(1.0), corrected), 1.0, 2000);
            let mean = pixel_samples(&model(None, corrected), 1.0, 2000);
            assert_eq!(fixed, mean);
        }
        assert_eq!(model(None, true).name(), "emccd-pp");
        assert_eq!(model(None, false).name(), "emccd-pp-uncorrected");
    }
}
