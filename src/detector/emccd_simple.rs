//! `emccd-simple` (paper section 2.2): the EM register's excess noise as a halved QE.

use rand_distr::{Binomial, Distribution};

use super::readout::{FrameInput, Readout};
use super::spec::{ModelEntry, ModelSpec, Sensor};
use crate::rng::SimRng;
use crate::stats::binomial_half;

/// The registry entry of `emccd-simple`.
pub const ENTRY: ModelEntry = ModelEntry {
    name: "emccd-simple",
    arg: None,
    help: "EMCCD as half the flux, Poisson, + 0.1 e- read noise (the paper's simple model)",
    sensor: Sensor::Emccd,
    params: &[],
    parse: |_, _| Ok(ModelSpec::EmccdSimple),
    build: |_, _, _| Ok(Box::new(EmccdSimple::paper())),
};

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

    fn read(&self, input: &FrameInput, aux: &mut SimRng, out: &mut [f64]) {
        for ((o, &k), &z) in out.iter_mut().zip(input.photo_e).zip(input.normals) {
            let kept = match k {
                0 => 0,
                k if k > BINOMIAL_ABOVE_E => Binomial::new(k as u64, 0.5)
                    .expect("p = 1/2 is a probability")
                    .sample(aux) as u32,
                k => binomial_half(k, aux),
            };
            *o = kept as f64 + self.read_noise_e * z;
        }
    }

    fn noise_scale_e(&self) -> f64 {
        self.read_noise_e
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::detector::readout::sampling::pixel_samples;
    use crate::stats::mean_var;

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
}
