//! Exact samplers of the discrete laws the simulation draws from (Poisson, Binomial(k, 1/2)).

use crate::rng::SimRng;
use rand::RngExt;
use rand_distr::{Distribution, Poisson};

/// Mean at which Poisson sampling switches from inversion to rand_distr's rejection method.
const POISSON_INVERSION_MAX: f64 = 30.0;

/// One Poisson(lambda) draw; lambda <= 0 gives 0.
///
/// Inversion by sequential search below lambda = 30 (exact, and cheap for the small means
/// of most sub-aperture pixels); rand_distr's PTRS rejection sampler above.
pub fn poisson(lambda: f64, rng: &mut SimRng) -> u32 {
    if lambda <= 0.0 {
        return 0;
    }
    if lambda >= POISSON_INVERSION_MAX {
        return Poisson::new(lambda)
            .expect("finite positive mean")
            .sample(rng) as u32;
    }
    let u: f64 = rng.random();
    let mut p = (-lambda).exp();
    let mut cdf = p;
    let mut k = 0u32;
    // The bound only guards against u within round-off of 1.
    while u > cdf && k < 1000 {
        k += 1;
        p *= lambda / k as f64;
        cdf += p;
    }
    k
}

/// One Binomial(k, 1/2) draw: the number of set bits among k fair random bits.
pub fn binomial_half(k: u32, rng: &mut SimRng) -> u32 {
    let mut left = k;
    let mut total = 0;
    while left > 0 {
        let take = left.min(64);
        let bits: u64 = rng.random();
        let mask = if take == 64 {
            u64::MAX
        } else {
            (1u64 << take) - 1
        };
        total += (bits & mask).count_ones();
        left -= take;
    }
    total
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rng::stream;
    use crate::stats::mean_var;

    #[test]
    fn poisson_moments_both_regimes() {
        // Mean and variance both equal lambda; SE(mean) = sqrt(lambda/N),
        // SE(var) ~ lambda * sqrt(2/N) (excess kurtosis 1/lambda is small); 4 SE.
        let n = 200_000;
        for (i, lambda) in [0.05, 0.7, 5.0, 29.0, 31.0, 400.0].into_iter().enumerate() {
            let mut rng = stream(5, i as u64, 0);
            let xs: Vec<f64> = (0..n).map(|_| poisson(lambda, &mut rng) as f64).collect();
            let (m, v) = mean_var(&xs);
            assert!(
                (m - lambda).abs() < 4.0 * (lambda / n as f64).sqrt(),
                "{lambda}: mean {m}"
            );
            let se_v = lambda * ((2.0 + 1.0 / lambda) / n as f64).sqrt();
            assert!((v - lambda).abs() < 4.0 * se_v, "{lambda}: var {v}");
        }
        assert_eq!(poisson(0.0, &mut stream(1, 1, 1)), 0);
    }

    #[test]
    fn binomial_half_moments() {
        // Binomial(k, 1/2): mean k/2, variance k/4; 4 SE.
        let n = 100_000;
        let mut rng = stream(9, 0, 0);
        for k in [1u32, 7, 64, 65, 300] {
            let xs: Vec<f64> = (0..n).map(|_| binomial_half(k, &mut rng) as f64).collect();
            let (m, v) = mean_var(&xs);
            let var = k as f64 / 4.0;
            assert!((m - k as f64 / 2.0).abs() < 4.0 * (var / n as f64).sqrt());
            assert!((v - var).abs() < 4.0 * var * (2.0 / n as f64).sqrt());
            assert!(xs.iter().all(|x| *x <= k as f64));
        }
    }
}
