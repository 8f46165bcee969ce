//! `emccd-distribution` (paper Eq. 2): the register output drawn from a Gamma distribution.

use rand_distr::{Distribution, Gamma, StandardNormal};

use super::readout::{FrameInput, Readout};
use super::spec::{ModelEntry, ModelSpec, Sensor};
use crate::rng::SimRng;

/// The registry entry of `emccd-distribution`.
pub const ENTRY: ModelEntry = ModelEntry {
    name: "emccd-distribution",
    arg: None,
    help: "EMCCD with the register output drawn from Gamma(k, gain) (Eq. 2) + read noise, divided by the gain",
    sensor: Sensor::Emccd,
    params: &["em_gain", "emccd_read_noise_e", "gaussian_switch_e"],
    parse: |_, _| Ok(ModelSpec::EmccdDistribution),
    build: |_, p, _| {
        Ok(Box::new(EmccdDistribution::new(
            p.em_gain,
            p.emccd_read_noise_e,
            p.gaussian_switch_e,
        )))
    },
};

/// `emccd-distribution`: register output drawn from Gamma(k, g) (paper Eq. 2), with the
/// optional Gaussian switch N(k g, k g^2) above a threshold. The paper prints this
/// approximation wrongly (centre g(k-1), variance g sqrt(k)); this is the corrected form.
#[derive(Debug, Clone)]
pub struct EmccdDistribution {
    gain: f64,
    read_noise_e: f64,
    gaussian_switch_e: Option<u32>,
}

impl EmccdDistribution {
    /// Gain, read noise before division (e-), and the Gaussian switch threshold (input e-).
    pub fn new(gain: f64, read_noise_e: f64, gaussian_switch_e: Option<u32>) -> Self {
        EmccdDistribution {
            gain,
            read_noise_e,
            gaussian_switch_e,
        }
    }

    /// Register output (e-) for k >= 1 input electrons.
    pub fn register_output(&self, k: u32, rng: &mut SimRng) -> f64 {
        let kf = k as f64;
        match self.gaussian_switch_e {
            Some(t) if k > t => {
                let z: f64 = StandardNormal.sample(rng);
                kf * self.gain + kf.sqrt() * self.gain * z
            }
            _ => Gamma::new(kf, self.gain)
                .expect("positive shape")
                .sample(rng),
        }
    }
}

impl Readout for EmccdDistribution {
    fn name(&self) -> String {
        "emccd-distribution".into()
    }

    fn read(&self, input: &FrameInput, aux: &mut SimRng, out: &mut [f64]) {
        for ((o, &k), &z) in out.iter_mut().zip(input.photo_e).zip(input.normals) {
            let em = if k == 0 {
                0.0
            } else {
                self.register_output(k, aux)
            };
            *o = (em + self.read_noise_e * z) / self.gain;
        }
    }

    fn noise_scale_e(&self) -> f64 {
        self.read_noise_e / self.gain
    }

    fn photon_variance_factor(&self) -> f64 {
        // Gamma(k, g) / g has variance k, on top of the Poisson variance of k.
        2.0
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::detector::readout::sampling::pixel_samples;
    use crate::rng::stream;
    use crate::stats::mean_var;

    #[test]
    fn gamma_model_moments() {
        // k fixed: output/g has mean k and variance k + (50/500)^2.
        let model = EmccdDistribution::new(500.0, 50.0, None);
        check_fixed_k_moments(&model, 7);
    }

    #[test]
    fn corrected_gaussian_switch_moments() {
        // Above the switch the output is N(k g, k g^2): same mean and variance as the Gamma.
        let model = EmccdDistribution::new(500.0, 50.0, Some(50));
        check_fixed_k_moments(&model, 80);
    }

    fn check_fixed_k_moments(model: &EmccdDistribution, k: u32) {
        let n = 200_000;
        let mut aux = stream(4, k as u64, 0);
        let xs: Vec<f64> = (0..n)
            .map(|_| model.register_output(k, &mut aux) / 500.0)
            .collect();
        let (m, v) = mean_var(&xs);
        let kf = k as f64;
        // Gamma(k) excess kurtosis 6/k: SE(var) = var sqrt((2 + 6/k)/N).
        assert!((m - kf).abs() < 4.0 * (kf / n as f64).sqrt(), "mean {m}");
        assert!(
            (v - kf).abs() < 4.0 * kf * ((2.0 + 6.0 / kf) / n as f64).sqrt(),
            "var {v}"
        );
    }

    #[test]
    fn readout_has_excess_noise_factor_two() {
        // Poisson input lambda through Gamma(k, g): output/g has mean lambda and variance
        // 2 lambda + (50/500)^2 (F^2 = 2). Compound Poisson of exponentials: excess kurtosis
        // 6/lambda = 3, so SE(var) = var sqrt(5/N); 4 SE.
        let model = EmccdDistribution::new(500.0, 50.0, None);
        let (n, lambda) = (200_000, 2.0);
        let (m, v) = mean_var(&pixel_samples(&model, lambda, n));
        let var = 2.0 * lambda + 0.01;
        assert!((m - lambda).abs() < 4.0 * (var / n as f64).sqrt(), "mean {m}");
        assert!((v - var).abs() < 4.0 * var * (5.0 / n as f64).sqrt(), "var {v}");
    }
}
