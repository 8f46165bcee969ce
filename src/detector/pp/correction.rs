//! The photometric correction: the mean count E[K | lambda] of a threshold set, tabulated over
//! light levels, and its inverse from a count back to photo-electrons.

use super::survival::{mean_of, n_max_for, reciprocals, survival_with};
use super::thresholds::PpThresholds;
use crate::error::{Error, Result};

/// The photometric correction: `E[K | lambda]` tabulated on a grid of light levels and its inverse.
#[derive(Clone, Debug)]
pub struct PhotometricCorrection {
    /// E[K | n photo-electrons] for n = 0..; the transfer curve is its Poisson average.
    count_given_n: Vec<f64>,
    /// Light levels of the table, photo-electrons per pixel, from 0 to `lambda_max` (quadratic spacing).
    lambda: Vec<f64>,
    /// E[K | lambda] at the table's light levels (non-decreasing).
    mean_count: Vec<f64>,
    /// Corrected light level for each integer count 0..=K_max.
    by_count: Vec<f64>,
}

impl PhotometricCorrection {
    /// Number of intervals of the light-level table.
    pub const GRID_INTERVALS: usize = 512;

    /// Tabulates E[K | lambda] for `thresholds` on [0, lambda_max] photo-electrons and its inverse.
    pub fn new(thresholds: &PpThresholds, lambda_max: f64) -> Result<Self> {
        if !(lambda_max.is_finite() && lambda_max > 0.0) {
            return Err(Error::invalid(
                "pp_lambda_max",
                format!("must be > 0, got {lambda_max}"),
            ));
        }
        let n_max = n_max_for(lambda_max);
        let inv = reciprocals(n_max + 1);
        let mut count_given_n = vec![0.0; n_max + 1];
        let (g, sigma) = (thresholds.gain, thresholds.read_noise_e);
        for &t in &thresholds.t_over_g {
            let s = survival_with(t * g, g, sigma, &inv[..=n_max]);
            for (c, s) in count_given_n.iter_mut().zip(s) {
                *c += s;
            }
        }
        let j_max = Self::GRID_INTERVALS;
        let lambda: Vec<f64> = (0..=j_max)
            .map(|j| lambda_max * (j as f64 / j_max as f64).powi(2))
            .collect();
        let mut mean_count: Vec<f64> = lambda
            .iter()
            .map(|&l| mean_of(&count_given_n, l, &inv))
            .collect();
        // Rounding can break monotonicity by ~1e-16 where the curve is flat; the inverse needs order.
        for j in 1..mean_count.len() {
            if mean_count[j] < mean_count[j - 1] {
                mean_count[j] = mean_count[j - 1];
            }
        }
        let mut c = PhotometricCorrection {
            count_given_n,
            lambda,
            mean_count,
            by_count: Vec::new(),
        };
        c.by_count = (0..=thresholds.t_over_g.len())
            .map(|k| c.invert(k as f64))
            .collect();
        Ok(c)
    }

    /// E[K | lambda] computed exactly from the per-electron table (lambda in photo-electrons, <= lambda_max).
    pub fn expected_count(&self, lambda: f64) -> f64 {
        let inv = reciprocals(self.count_given_n.len());
        mean_of(&self.count_given_n, lambda, &inv)
    }

    /// E[K | n] for n photo-electrons (n up to the table's end).
    pub fn count_given_n(&self) -> &[f64] {
        &self.count_given_n
    }

    /// Light level (photo-electrons) whose mean count is `mean_count`, by linear interpolation in the
    /// table; 0 below E[K | 0] (read-noise false positives) and `lambda_max` above the table.
    pub fn invert(&self, mean_count: f64) -> f64 {
        let f = &self.mean_count;
        if mean_count.is_nan() || mean_count <= f[0] {
            return 0.0;
        }
        let j = f.partition_point(|&v| v < mean_count);
        if j >= f.len() {
            return self.lambda[self.lambda.len() - 1];
        }
        let (f0, f1) = (f[j - 1], f[j]);
        let (l0, l1) = (self.lambda[j - 1], self.lambda[j]);
        if f1 <= f0 {
            return l1;
        }
        l0 + (l1 - l0) * (mean_count - f0) / (f1 - f0)
    }

    /// Corrected light level (photo-electrons) for an integer count `k` (precomputed lookup).
    pub fn lambda_for_count(&self, k: usize) -> f64 {
        self.by_count[k.min(self.by_count.len() - 1)]
    }

    /// The tabulated (lambda, E[K | lambda]) pairs.
    pub fn table(&self) -> impl Iterator<Item = (f64, f64)> + '_ {
        self.lambda
            .iter()
            .cloned()
            .zip(self.mean_count.iter().cloned())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn one_boundary_at_zero_without_read_noise_has_the_zero_class_curve() {
        // One boundary at 0 and no read noise: K = 1 exactly when an electron arrived, so
        // E[K | n] = [n >= 1] and E[K | lambda] = 1 - e^-lambda, inverted by -ln(1 - m).
        let t = PpThresholds {
            t_over_g: vec![0.0],
            gain: 500.0,
            read_noise_e: 0.0,
        };
        let c = PhotometricCorrection::new(&t, 50.0).unwrap();
        assert_eq!(c.count_given_n()[0], 0.0);
        assert!(c.count_given_n()[1..].iter().all(|&v| v == 1.0));
        for lambda in [0.0f64, 0.01, 0.5, 3.0, 12.0] {
            let want = 1.0 - (-lambda).exp();
            assert!((c.expected_count(lambda) - want).abs() < 1e-14, "{lambda}");
        }
        for m in [0.1, 0.5, 0.9] {
            // Linear interpolation between grid points of a concave curve: relative error
            // below 1e-3 on this 512-interval quadratic grid.
            let want = -(1.0f64 - m).ln();
            assert!(
                (c.invert(m) / want - 1.0).abs() < 1e-3,
                "m {m}: {}",
                c.invert(m)
            );
        }
        assert_eq!(c.lambda_for_count(0), 0.0);
        // A count of 1 is the curve's saturation, reached in f64 where e^-lambda < 2^-53
        // (lambda > 36.7); larger counts clamp to it, and means above the table give lambda_max.
        assert!((36.0..=50.0).contains(&c.lambda_for_count(1)));
        assert_eq!(c.lambda_for_count(7), c.lambda_for_count(1));
        assert_eq!(c.invert(2.0), 50.0);
        let (first, last) = (c.table().next().unwrap(), c.table().last().unwrap());
        assert_eq!(first, (0.0, 0.0));
        assert_eq!(last.0, 50.0);
        assert!(PhotometricCorrection::new(&t, 0.0).is_err());
    }
}
