//! EMCCD readout models of the paper (section 2.2): simple, stochastic and distribution.

use super::{EmRegister, FrameInput, Readout};
use crate::rng::SimRng;
use crate::stats::binomial_half;
use rand_distr::{Binomial, Distribution, Gamma, StandardNormal};

/// Photo-electrons above which `emccd-simple` halves the count with one Binomial(k, 1/2) draw
/// (constant cost) instead of counting k random bits (cost k/64 draws); both are exact.
const BINOMIAL_ABOVE_E: u32 = 1 << 16;

/// `emccd-simple`: the excess noise as a halved QE (Poisson of half the flux), plus
/// Normal(0, 0.1 e-) read noise. Halving is done by binomial thinning of the shared
/// photon draws, which is exactly Poisson(0.5 lambda) and keeps common random numbers.
#[derive(Debug, Clone)]
pub struct EmccdSimple {
    read_noise_e: f64,
}

impl EmccdSimple {
    /// The paper's version: read noise 0.1 e- (50 e- / gain 500).
    pub fn paper() -> Self {
        EmccdSimple { read_noise_e: 0.1 }
    }
}

impl Readout for EmccdSimple {
    fn name(&self) -> String {
        "emccd-simple".into()
    }

    fn read(&self, input: &FrameInput, noise: &mut SimRng, aux: &mut SimRng, out: &mut [f64]) {
        for (o, &k) in out.iter_mut().zip(input.photo_e) {
            let kept = match k {
                0 => 0,
                k if k > BINOMIAL_ABOVE_E => Binomial::new(k as u64, 0.5)
                    .expect("p = 1/2 is a probability")
                    .sample(aux) as u32,
                k => binomial_half(k, aux),
            };
            let z: f64 = StandardNormal.sample(noise);
            *o = kept as f64 + self.read_noise_e * z;
        }
    }

    fn noise_scale_e(&self) -> f64 {
        self.read_noise_e
    }
}

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

    fn read(&self, input: &FrameInput, noise: &mut SimRng, aux: &mut SimRng, out: &mut [f64]) {
        let g = self.register.gain();
        for (o, &k) in out.iter_mut().zip(input.photo_e) {
            let em = match (k, self.cascade) {
                (0, _) => 0.0,
                (k, false) => self.register.sample(k as u64, aux),
                (k, true) => self.register.sample_cascade(k as u64, aux),
            };
            let z: f64 = StandardNormal.sample(noise);
            *o = (em + self.read_noise_e * z) / g;
        }
    }

    fn noise_scale_e(&self) -> f64 {
        self.read_noise_e / self.register.gain()
    }
}

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

    fn read(&self, input: &FrameInput, noise: &mut SimRng, aux: &mut SimRng, out: &mut [f64]) {
        for (o, &k) in out.iter_mut().zip(input.photo_e) {
            let em = if k == 0 {
                0.0
            } else {
                self.register_output(k, aux)
            };
            let z: f64 = StandardNormal.sample(noise);
            *o = (em + self.read_noise_e * z) / self.gain;
        }
    }

    fn noise_scale_e(&self) -> f64 {
        self.read_noise_e / self.gain
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rng::stream;
    use crate::stats::{mean_var, poisson};

    fn pixel_samples(model: &dyn Readout, lambda: f64, n: usize) -> Vec<f64> {
        let mut rng = stream(21, 0, 0);
        let mut noise = stream(21, 0, 1);
        let mut aux = stream(21, 0, 2);
        let expected = [lambda];
        let mut out = [0.0];
        (0..n)
            .map(|_| {
                let k = [poisson(lambda, &mut rng)];
                let input = FrameInput {
                    subap_px: 1,
                    expected_e: &expected,
                    photo_e: &k,
                };
                model.read(&input, &mut noise, &mut aux, &mut out);
                out[0]
            })
            .collect()
    }

    #[test]
    fn simple_model_variance_is_half_lambda_plus_read_noise() {
        // Per-pixel variance 0.5 lambda + 0.01 and mean 0.5 lambda; SE(var) ~ var sqrt(2/N).
        // The last level lies above BINOMIAL_ABOVE_E, where one Binomial(k, 1/2) draw replaces
        // k coin flips (both exact).
        let n = 200_000;
        for lambda in [0.2, 3.0, 40.0, 4.0 * BINOMIAL_ABOVE_E as f64] {
            let xs = pixel_samples(&EmccdSimple::paper(), lambda, n);
            let (m, v) = mean_var(&xs);
            let var = 0.5 * lambda + 0.01;
            assert!(
                (m - 0.5 * lambda).abs() < 4.0 * (var / n as f64).sqrt(),
                "mean {m}"
            );
            assert!(
                (v - var).abs() < 4.0 * var * (3.0 / n as f64).sqrt(),
                "{lambda}: var {v}"
            );
        }
    }

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
}
