//! A ready PP readout for one reference light level: its thresholds and photometric correction.

use super::correction::PhotometricCorrection;
use super::thresholds::PpThresholds;

/// A ready PP readout for one reference light level: thresholds and photometric correction.
#[derive(Clone, Debug)]
pub struct PpCounter {
    /// Reference light level the thresholds were built for, photo-electrons per pixel.
    pub lambda_ref: f64,
    /// The boundaries.
    pub thresholds: PpThresholds,
    /// The inverse transfer curve for these boundaries.
    pub correction: PhotometricCorrection,
    /// E[n | K = k] per count k under a Poisson prior at `lambda_ref`
    /// ([`super::posterior_by_count`]).
    pub posterior: Vec<f64>,
}

impl PpCounter {
    /// Uncorrected photon count of an output `x_over_g` (output electrons / g).
    pub fn count(&self, x_over_g: f64) -> usize {
        self.thresholds.count(x_over_g)
    }

    /// Photometrically corrected light level (photo-electrons) of an output `x_over_g`.
    pub fn corrected(&self, x_over_g: f64) -> f64 {
        self.correction.lambda_for_count(self.count(x_over_g))
    }

    /// Posterior mean photo-electrons E[n | K] of an output `x_over_g` under the counter's prior.
    pub fn posterior(&self, x_over_g: f64) -> f64 {
        let k = self.count(x_over_g);
        self.posterior[k.min(self.posterior.len() - 1)]
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn counts_bin_the_output_and_corrections_look_the_count_up() {
        // Boundaries at 0 and 1 g without read noise: outputs below 0 count 0, in (0, 1] count
        // 1, above 1 count 2; the corrected level is the correction's value for that count.
        let thresholds = PpThresholds {
            t_over_g: vec![0.0, 1.0],
            gain: 500.0,
            read_noise_e: 0.0,
        };
        let correction = PhotometricCorrection::new(&thresholds, 20.0).unwrap();
        let c = PpCounter {
            lambda_ref: 1.0,
            posterior: vec![0.0, 1.0, 2.0],
            thresholds,
            correction,
        };
        for (x, k) in [(-0.5, 0), (0.0, 0), (0.3, 1), (1.0, 1), (1.2, 2), (1e9, 2)] {
            assert_eq!(c.count(x), k, "x {x}");
            assert_eq!(c.corrected(x), c.correction.lambda_for_count(k), "x {x}");
        }
        assert_eq!(c.corrected(-1.0), 0.0);
        assert!(c.corrected(0.3) > 0.0 && c.corrected(0.3) < c.corrected(5.0));
    }
}
