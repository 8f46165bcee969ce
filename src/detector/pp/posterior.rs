//! The posterior correction: per count, the mean photo-electron number of a pixel given its
//! count, under a Poisson prior at the counter's reference light level,
//! E[n | K = k] = sum_n n Pois(n; lambda) P(K = k | n) / sum_n Pois(n; lambda) P(K = k | n).
//!
//! Unlike the inverse transfer curve (the light level whose *mean* count is k), it stays finite
//! where the counter saturates: with the pixel prior a dark pixel's counter has one boundary
//! (0|1), so its inverse maps a single photon to `lambda_max`, while E[n | K = 1] is about 1.

use super::survival::{n_max_for, reciprocals, survival_with};
use super::thresholds::PpThresholds;

/// E[n | K = k] for k = 0..=K_max under a Poisson(`lambda_ref`) prior, n up to the table of
/// `lambda_max`; a count the prior makes impossible (weight underflowing to 0) gets `fallback(k)`.
pub fn posterior_by_count(
    thresholds: &PpThresholds,
    lambda_ref: f64,
    lambda_max: f64,
    fallback: impl Fn(usize) -> f64,
) -> Vec<f64> {
    let n_max = n_max_for(lambda_max.max(lambda_ref));
    let inv = reciprocals(n_max + 1);
    // Poisson weights relative to the largest (log space: e^-lambda underflows above 745).
    let ln_l = lambda_ref.max(f64::MIN_POSITIVE).ln();
    let mut ln_fact = 0.0;
    let log_w: Vec<f64> = (0..=n_max)
        .map(|n| {
            if n > 0 {
                ln_fact += (n as f64).ln();
            }
            n as f64 * ln_l - ln_fact
        })
        .collect();
    let top = log_w.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    let w: Vec<f64> = log_w.iter().map(|l| (l - top).exp()).collect();
    let (g, sigma) = (thresholds.gain, thresholds.read_noise_e);
    let mut above = vec![1.0; n_max + 1];
    let bins = thresholds.t_over_g.len() + 1;
    (0..bins)
        .map(|k| {
            let next = match thresholds.t_over_g.get(k) {
                Some(&t) => survival_with(t * g, g, sigma, &inv[..=n_max]),
                None => vec![0.0; n_max + 1],
            };
            let (mut num, mut den) = (0.0, 0.0);
            for (n, ((a, b), w)) in above.iter().zip(&next).zip(&w).enumerate() {
                let p = w * (a - b).max(0.0);
                num += n as f64 * p;
                den += p;
            }
            above = next;
            if den > 0.0 {
                num / den
            } else {
                fallback(k)
            }
        })
        .collect()
}
