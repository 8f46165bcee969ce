//! The pixels' mean charges as a mixture: a histogram pools pixels whose dark charge differs
//! (dark current varies from pixel to pixel), and a Poisson law of one mean lambda has too few
//! multi-electron events for such a pool (E[n(n-1)] = E[lambda^2] > lambda-bar^2), which a
//! one-lambda fit reads as a higher gain. The mixture model has lambda r_b in a fraction w_b of
//! the pixels, the r_b of weighted mean 1 describing the spread, lambda the fitted mean.

use serde::{Deserialize, Serialize};

/// Pixels by relative mean charge: the histogram model's light term is
/// sum_b w_b Poisson(lambda r_b) instead of Poisson(lambda).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct LambdaMixture {
    /// Fraction of the pixel-samples in each group (sum 1).
    pub weights: Vec<f64>,
    /// Each group's mean charge relative to the pool's mean (weighted mean 1, all >= 0).
    pub relative: Vec<f64>,
}

/// Groups a mixture is built with by default (equal-count quantile groups).
pub const DEFAULT_MIXTURE_GROUPS: usize = 12;

impl LambdaMixture {
    /// The mixture of `groups` equal-count quantile groups of per-pixel charge estimates
    /// `values` (any unit proportional to electrons), whose estimation noise has mean
    /// variance `noise_var` (same unit squared; 0 for exact charges): each group two points of
    /// half its weight at its mean -+ its SD, so that mean and variance are the values'.
    ///
    /// Noise widens the spread of the estimates: each is first drawn towards their mean by
    /// k = sqrt(1 - noise_var / variance), so that their variance is the pixels' own (none
    /// when the noise explains it all). `None` when the values are fewer than the groups or
    /// their mean is not positive.
    pub fn from_estimates(values: &[f64], noise_var: f64, groups: usize) -> Option<Self> {
        let mut v: Vec<f64> = values.iter().copied().filter(|x| x.is_finite()).collect();
        let n = v.len();
        if groups == 0 || n < groups.max(2) {
            return None;
        }
        let mean = v.iter().sum::<f64>() / n as f64;
        if mean <= 0.0 {
            return None;
        }
        let var = v.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / (n - 1) as f64;
        let k = if var > 0.0 {
            (1.0 - noise_var.max(0.0) / var).max(0.0).sqrt()
        } else {
            0.0
        };
        v.sort_by(f64::total_cmp);
        let mut weights = Vec::with_capacity(2 * groups);
        let mut relative = Vec::with_capacity(2 * groups);
        for b in 0..groups {
            let g = &v[b * n / groups..(b + 1) * n / groups];
            let gm = g.iter().sum::<f64>() / g.len() as f64;
            let gsd = (g.iter().map(|x| (x - gm).powi(2)).sum::<f64>() / g.len() as f64).sqrt();
            // Two halves at the group's mean -+ its SD keep its variance (the upper groups of
            // a skewed spread are wide), so the mixture's second moment is the values'.
            for sign in [-1.0, 1.0] {
                let dev = (gm + sign * gsd) / mean - 1.0;
                weights.push(0.5 * g.len() as f64 / n as f64);
                // A point drawn below zero charge (a skewed spread) holds none.
                relative.push((1.0 + k * dev).max(0.0));
            }
        }
        let m: f64 = weights.iter().zip(&relative).map(|(w, r)| w * r).sum();
        relative.iter_mut().for_each(|r| *r /= m);
        Some(LambdaMixture { weights, relative })
    }

    /// Probability of no electron at mean `lambda` (e-): sum_b w_b exp(-lambda r_b).
    pub fn p_zero(&self, lambda: f64) -> f64 {
        self.weights
            .iter()
            .zip(&self.relative)
            .map(|(w, r)| w * (-lambda * r).exp())
            .sum()
    }

    /// d p_zero / d lambda at `lambda`.
    fn p_zero_slope(&self, lambda: f64) -> f64 {
        -self
            .weights
            .iter()
            .zip(&self.relative)
            .map(|(w, r)| w * r * (-lambda * r).exp())
            .sum::<f64>()
    }

    /// The mean charge (e-) whose probability of no electron is `p0` (0 < p0 < 1), and
    /// d lambda / d p0 there; `None` outside that range.
    pub fn lambda_of_p_zero(&self, p0: f64) -> Option<(f64, f64)> {
        if !(p0 > 0.0 && p0 < 1.0) {
            return None;
        }
        // p_zero is convex and decreasing from 1: Newton from the one-lambda answer, which
        // lies below the root (Jensen), climbs monotonically.
        let mut l = -p0.ln();
        for _ in 0..100 {
            let step = (self.p_zero(l) - p0) / self.p_zero_slope(l);
            l -= step;
            if step.abs() <= 1e-14 * l.max(1e-300) {
                break;
            }
        }
        let solved = l.is_finite() && l > 0.0 && (self.p_zero(l) - p0).abs() <= 1e-9 * p0;
        solved.then(|| (l, 1.0 / self.p_zero_slope(l)))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn groups_keep_the_mean_and_draw_the_noise_in() {
        // 1..=100 in 4 groups: means 13, 38, 63, 88 of 50.5, each of SD sqrt(624 / 12) =
        // 7.2111; noise of variance 400 of the values' 841.67 draws the deviations in by
        // sqrt(1 - 400 / 841.67) = 0.7246.
        let v: Vec<f64> = (1..=100).map(f64::from).collect();
        let exact = LambdaMixture::from_estimates(&v, 0.0, 4).unwrap();
        let noisy = LambdaMixture::from_estimates(&v, 400.0, 4).unwrap();
        let k = (1.0f64 - 400.0 / (841.0 + 2.0 / 3.0)).sqrt();
        let sd = 52f64.sqrt();
        for (b, g) in [13.0, 38.0, 63.0, 88.0].iter().enumerate() {
            for (j, x) in [g - sd, g + sd].iter().enumerate() {
                assert!((exact.relative[2 * b + j] - x / 50.5).abs() < 1e-12);
                let drawn = 1.0 + k * (x / 50.5 - 1.0);
                assert!((noisy.relative[2 * b + j] - drawn).abs() < 1e-12);
                assert_eq!(exact.weights[2 * b + j], 0.125);
            }
        }
        // Mean and (population) variance of the values.
        let var: f64 = exact
            .weights
            .iter()
            .zip(&exact.relative)
            .map(|(w, r)| w * (r - 1.0).powi(2))
            .sum();
        assert!((var * 50.5 * 50.5 / 833.25 - 1.0).abs() < 1e-12, "{var}");
        // All noise: one charge for all.
        let flat = LambdaMixture::from_estimates(&v, 1e4, 10).unwrap();
        assert!(flat.relative.iter().all(|r| (r - 1.0).abs() < 1e-12));
        assert!(LambdaMixture::from_estimates(&[-1.0, 0.5], 0.0, 2).is_none());
        assert!(LambdaMixture::from_estimates(&v[..5], 0.0, 8).is_none());
    }

    #[test]
    fn lambda_of_p_zero_inverts_p_zero() {
        let mix = LambdaMixture {
            weights: vec![0.5, 0.5],
            relative: vec![0.2, 1.8],
        };
        for l in [1e-3, 0.05, 0.7, 4.0] {
            let (back, dl) = mix.lambda_of_p_zero(mix.p_zero(l)).unwrap();
            assert!((back / l - 1.0).abs() < 1e-10, "{l} {back}");
            let h = 1e-6 * l;
            let num = 2.0 * h / (mix.p_zero(l + h) - mix.p_zero(l - h));
            assert!((dl / num - 1.0).abs() < 1e-5, "{dl} {num}");
        }
        assert!(mix.lambda_of_p_zero(1.0).is_none() && mix.lambda_of_p_zero(0.0).is_none());
    }
}
