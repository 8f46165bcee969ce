//! `emccd-stochastic` (paper section 2.2): the exact multiplication register.


use super::readout::{FrameInput, Readout};
use super::register::EmRegister;
use super::spec::{ModelEntry, ModelSpec, Sensor};
use crate::rng::SimRng;

/// The registry entry of `emccd-stochastic`.
pub const ENTRY: ModelEntry = ModelEntry {
    name: "emccd-stochastic",
    arg: None,
    help: "EMCCD with the exact multiplication register + Gaussian read noise, divided by the gain",
    sensor: Sensor::Emccd,
    params: &["em_gain", "stages", "emccd_read_noise_e", "cascade_register"],
    parse: |_, _| Ok(ModelSpec::EmccdStochastic),
    build: |_, p, _| {
        Ok(Box::new(EmccdStochastic::new(
            EmRegister::new(p.em_gain, p.stages)?,
            p.emccd_read_noise_e,
            p.cascade_register,
        )))
    },
};

/// `emccd-stochastic`: the exact multiplication register, read noise, division by the gain.
#[derive(Debug, Clone)]
pub struct EmccdStochastic {
    register: EmRegister,
    read_noise_e: f64,
    cascade: bool,
}

impl EmccdStochastic {
    /// Register, read noise before gain division (e-), and whether to use the per-stage cascade.
    pub fn new(register: EmRegister, read_noise_e: f64, cascade: bool) -> Self {
        EmccdStochastic {
            register,
            read_noise_e,
            cascade,
        }
    }
}

impl Readout for EmccdStochastic {
    fn name(&self) -> String {
        "emccd-stochastic".into()
    }

    fn read(&self, input: &FrameInput, aux: &mut SimRng, out: &mut [f64]) {
        let g = self.register.gain();
        for ((o, &k), &z) in out.iter_mut().zip(input.photo_e).zip(input.normals) {
            let em = match (k, self.cascade) {
                (0, _) => 0.0,
                (k, false) => self.register.sample(k as u64, aux),
                (k, true) => self.register.sample_cascade(k as u64, aux),
            };
            *o = (em + self.read_noise_e * z) / g;
        }
    }

    fn noise_scale_e(&self) -> f64 {
        self.read_noise_e / self.register.gain()
    }

    fn photon_variance_factor(&self) -> f64 {
        self.register.excess_noise_factor_sq()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::detector::readout::sampling::pixel_samples;
    use crate::stats::mean_var;

    #[test]
    fn stochastic_model_has_excess_noise_factor() {
        // Poisson input lambda: output/g has mean lambda, variance F^2 lambda + 0.01.
        let reg = EmRegister::new(500.0, 520).unwrap();
        let f2 = reg.excess_noise_factor_sq();
        let model = EmccdStochastic::new(reg, 50.0, false);
        let n = 200_000;
        let lambda = 2.0;
        let xs = pixel_samples(&model, lambda, n);
        let (m, v) = mean_var(&xs);
        let var = f2 * lambda + 0.01;
        assert!(
            (m - lambda).abs() < 4.0 * (var / n as f64).sqrt(),
            "mean {m}"
        );
        // Compound Poisson-exponential-like output: kurtosis ~ 3 + 6/lambda, SE(var) ~ var sqrt(8/N).
        assert!(
            (v - var).abs() < 4.0 * var * (8.0 / n as f64).sqrt(),
            "var {v} vs {var}"
        );
    }

    #[test]
    fn cascade_sampler_gives_the_same_moments() {
        // The per-stage cascade is the reference sampler: same mean and variance (4 SE as above).
        let reg = EmRegister::new(500.0, 520).unwrap();
        let var = reg.excess_noise_factor_sq() * 2.0 + 0.01;
        let model = EmccdStochastic::new(reg, 50.0, true);
        let n = 20_000;
        let (m, v) = mean_var(&pixel_samples(&model, 2.0, n));
        assert!((m - 2.0).abs() < 4.0 * (var / n as f64).sqrt(), "mean {m}");
        assert!((v - var).abs() < 4.0 * var * (8.0 / n as f64).sqrt(), "var {v}");
    }
}
