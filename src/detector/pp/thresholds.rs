//! The PP boundaries between photon counts: Rule A (Poisson prior), Rule B (equal density), the
//! 0|1 boundary, and [`PpThresholds`], which bins an output and gives the mean count.

use super::density::{ln_emg, ln_output_density};
use super::survival::p_exceed;
use crate::error::{Error, Result};
use crate::special::{bisect, ln_gauss};

/// Checks that a light level (photo-electrons per pixel) is finite and >= 0; errors name `field`.
pub(super) fn check_lambda(lambda: f64, field: &str) -> Result<()> {
    if lambda.is_finite() && lambda >= 0.0 {
        Ok(())
    } else {
        Err(Error::invalid(
            field,
            format!("light level must be finite and >= 0, got {lambda}"),
        ))
    }
}

/// Output (in units of g) above which a pixel of mean `lambda_max` photo-electrons practically never lands:
/// mean `lambda`, variance about `2 lambda` (excess noise factor 2), plus 10 sigma and a margin.
pub(super) fn output_span_over_g(lambda_max: f64) -> f64 {
    lambda_max + 10.0 * (2.0 * lambda_max).sqrt() + 10.0
}

/// Rule A boundary between `n` and `n + 1` counts (`n >= 1`) in units of g: `n (n + 1) / lambda`.
pub fn rule_a_threshold_over_g(n: usize, lambda: f64) -> f64 {
    (n * (n + 1)) as f64 / lambda
}

/// Rule A boundaries in units of g: the 0|1 boundary `t0_over_g`, then `n (n + 1) / lambda` up to `u_max`.
pub(super) fn rule_a_thresholds(t0_over_g: f64, lambda: f64, u_max: f64) -> Vec<f64> {
    let mut t = vec![t0_over_g];
    let mut n = 1;
    loop {
        // With read noise comparable to the gain the 0|1 boundary can lie above some n(n+1)/lambda;
        // those boundaries are moved just above it (their bins stay empty), keeping the order.
        let tn = rule_a_threshold_over_g(n, lambda).max(t[t.len() - 1] * (1.0 + 1e-12) + 1e-12);
        t.push(tn);
        if tn >= u_max {
            return t;
        }
        n += 1;
    }
}

/// Rule A 0|1 boundary in output electrons for light level `lambda`: the x where
/// `N(x; 0, sigma)` equals `lambda * EMG(x)` (zero- and one-electron terms equally likely).
/// About 141 e- at lambda = 0.1 and 89.6 e- at lambda = 1 for g = 500, sigma = 50 e-.
/// Without read noise the boundary is 0.
pub fn zero_one_threshold_e(lambda: f64, gain: f64, read_noise_e: f64) -> Result<f64> {
    check_lambda(lambda, "pp_lambda")?;
    if lambda == 0.0 {
        return Err(Error::invalid(
            "pp_lambda",
            "the 0|1 boundary needs a light level > 0",
        ));
    }
    let sigma = read_noise_e;
    if sigma == 0.0 {
        return Ok(0.0);
    }
    // ln N - ln(lambda EMG) falls from +inf (far left, Gaussian tail ratio ~ |z|) to -inf.
    let f = |x: f64| ln_gauss(x, sigma) - lambda.ln() - ln_emg(x, gain, sigma);
    let (mut lo, mut hi) = (-sigma, sigma);
    while f(lo) <= 0.0 {
        lo *= 2.0;
        if lo < -1e7 * sigma {
            return Err(Error::Numeric(format!(
                "no 0|1 boundary found for lambda = {lambda}"
            )));
        }
    }
    while f(hi) >= 0.0 {
        hi *= 2.0;
        if hi > 1e7 * sigma {
            return Err(Error::Numeric(format!(
                "no 0|1 boundary found for lambda = {lambda}"
            )));
        }
    }
    Ok(bisect(f, lo, hi))
}

/// Rule B boundary in units of g between Poisson light levels `n` and `n + 1`, searched upward from `from_e`.
fn rule_b_boundary(n: usize, from_e: f64, gain: f64, sigma: f64) -> Result<f64> {
    let d = |x: f64| {
        ln_output_density(x, n as f64, gain, sigma)
            - ln_output_density(x, (n + 1) as f64, gain, sigma)
    };
    let mut lo = from_e;
    let mut steps = 0;
    while d(lo) <= 0.0 {
        lo -= 0.25 * gain;
        steps += 1;
        if steps > 100 {
            return Err(Error::Numeric(format!(
                "Rule B: no {n}|{} boundary below {from_e} e-",
                n + 1
            )));
        }
    }
    let mut hi = lo + 0.25 * gain;
    while d(hi) >= 0.0 {
        hi += 0.5 * gain;
        if hi > lo + 1e3 * gain {
            return Err(Error::Numeric(format!(
                "Rule B: no {n}|{} boundary above {lo} e-",
                n + 1
            )));
        }
    }
    Ok(bisect(d, lo, hi) / gain)
}

/// Rule B boundaries in units of g, from the first up to `u_max`.
pub(super) fn rule_b_thresholds(gain: f64, sigma: f64, u_max: f64) -> Result<Vec<f64>> {
    // Without read noise light level 0 is an atom at 0: any positive output is at least one count.
    let (mut t, first) = if sigma == 0.0 {
        (vec![0.0], 1)
    } else {
        (Vec::new(), 0)
    };
    let mut from = 0.0;
    for n in first.. {
        let tn = rule_b_boundary(n, from, gain, sigma)?;
        t.push(tn);
        if tn >= u_max {
            break;
        }
        from = tn * gain;
    }
    Ok(t)
}

/// A set of PP thresholds in units of the mean gain g, strictly increasing; `t_over_g[k]` is the
/// boundary between k and k + 1 counts.
#[derive(Clone, Debug, PartialEq)]
pub struct PpThresholds {
    /// Boundaries in units of g (output electrons / g); the first is the 0|1 boundary.
    pub t_over_g: Vec<f64>,
    /// Mean EM gain used to build them.
    pub gain: f64,
    /// Read noise in output electrons used to build them.
    pub read_noise_e: f64,
}

impl PpThresholds {
    /// Bin index (photon count) of an output `x_over_g` (output electrons / g): the number of
    /// boundaries below it, at most `t_over_g.len()`.
    pub fn count(&self, x_over_g: f64) -> usize {
        // Most pixels of a photon-counting frame read 0, below the first boundary: answered
        // without the search (and its mispredicted branches).
        match self.t_over_g.first() {
            Some(&t0) if x_over_g <= t0 => 0,
            _ => self.t_over_g.partition_point(|&t| t < x_over_g),
        }
    }

    /// P(X > `t_over_g[k]` g | lambda) for Poisson light level `lambda` photo-electrons.
    pub fn p_exceed(&self, k: usize, lambda: f64) -> f64 {
        p_exceed(self.t_over_g[k], lambda, self.gain, self.read_noise_e)
    }

    /// E[K | lambda] = sum_k P(X > t_k | lambda), the mean count at light level `lambda`.
    pub fn expected_count(&self, lambda: f64) -> f64 {
        (0..self.t_over_g.len())
            .map(|k| self.p_exceed(k, lambda))
            .sum()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const G: f64 = 500.0;
    const SIGMA: f64 = 50.0;

    #[test]
    fn zero_one_threshold_matches_reference_values() {
        let t01 = zero_one_threshold_e(0.1, G, SIGMA).unwrap();
        let t1 = zero_one_threshold_e(1.0, G, SIGMA).unwrap();
        eprintln!("T01(0.1) = {t01:.2} e-, T01(1) = {t1:.2} e-");
        assert!((t01 - 141.0).abs() < 1.0, "{t01}");
        assert!((89.5..=90.0).contains(&t1), "{t1}");
        // At the root the two weighted densities agree.
        let lhs = ln_gauss(t1, SIGMA);
        let rhs = ln_emg(t1, G, SIGMA);
        assert!((lhs - rhs).abs() < 1e-9);
    }

    #[test]
    fn rule_a_thresholds_stay_increasing_above_a_high_zero_one_boundary() {
        // A 0|1 boundary of 7 g at lambda 1 lies above 1|2 (2 g) and 2|3 (6 g): those move
        // just above it, in order; 3|4 (12 g) and later keep n (n + 1) / lambda.
        let t = rule_a_thresholds(7.0, 1.0, 30.0);
        assert!(t.windows(2).all(|w| w[0] < w[1]), "{t:?}");
        assert!(t[1] > 7.0 && t[2] > t[1] && t[2] < 7.0 + 1e-9);
        assert_eq!(&t[3..], &[12.0, 20.0, 30.0]);
        assert!(zero_one_threshold_e(0.0, G, SIGMA).is_err());
        assert_eq!(zero_one_threshold_e(1.0, G, 0.0).unwrap(), 0.0);
    }
}
