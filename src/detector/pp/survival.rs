//! Survival of the EMCCD output given n input electrons, P(X > t | n), exact for the Gamma
//! register plus Gaussian read noise, and its Poisson averages over light levels.

use statrs::function::gamma::ln_gamma;

use crate::special::{ln_norm_cdf, norm_cdf, LN_2PI};

/// Largest photo-electron count tabulated for light levels up to `lambda_max` (12 sigma of the Poisson).
pub(super) fn n_max_for(lambda_max: f64) -> usize {
    (lambda_max + 12.0 * lambda_max.sqrt() + 30.0).ceil() as usize
}

/// P(X > t | n input electrons) for n = 0..=n_max, X = register output (Gamma(n, g), 0 for n = 0)
/// plus N(0, sigma^2) read noise, t in output electrons. Exact: the Gaussian integral of the
/// regularised upper incomplete gamma reduces to partial Gaussian moments with a 3-term recurrence.
pub fn survival_by_n(t_e: f64, gain: f64, read_noise_e: f64, n_max: usize) -> Vec<f64> {
    survival_with(t_e, gain, read_noise_e, &reciprocals(n_max + 1))
}

/// 1 / n for n = 0..=n_max (entry 0 is unused): the recurrences multiply instead of dividing,
/// which keeps divisions out of their dependency chains.
pub(super) fn reciprocals(n_max: usize) -> Vec<f64> {
    (0..=n_max).map(|n| 1.0 / n.max(1) as f64).collect()
}

/// [`survival_by_n`] for n = 0..inv.len() - 1, with the reciprocal table `inv`.
pub(super) fn survival_with(t_e: f64, gain: f64, read_noise_e: f64, inv: &[f64]) -> Vec<f64> {
    let n_max = inv.len() - 1;
    let sigma = read_noise_e;
    if sigma > 0.0 && (t_e - sigma * sigma / gain) < -0.5 * sigma {
        return survival_low_threshold(t_e, gain, sigma, inv);
    }
    let mut out = Vec::with_capacity(n_max + 1);
    let (base, mut ln_scale, mut m_prev2, mut m_prev, b) = if sigma > 0.0 {
        let mu = t_e - sigma * sigma / gain;
        let m0 = norm_cdf(mu / sigma);
        let m1 = mu / gain * m0 + sigma / gain * (-0.5 * (mu / sigma).powi(2) - 0.5 * LN_2PI).exp();
        (
            norm_cdf(-t_e / sigma),
            -t_e / gain + sigma * sigma / (2.0 * gain * gain),
            m0,
            m1,
            (sigma / gain).powi(2),
        )
    } else if t_e < 0.0 {
        return vec![1.0; n_max + 1];
    } else {
        (0.0, -t_e / gain, 1.0, t_e / gain, 0.0)
    };
    out.push(base);
    if n_max == 0 {
        return out;
    }
    let a = (t_e - sigma * sigma / gain) / gain;
    // cum = sum_{j < n} m_j, the terms scaled by e^(-ln_scale) to stay in range.
    let mut cum = m_prev2;
    let mut factor = ln_scale.exp();
    let value = |cum: f64, ln_scale: f64, factor: f64| {
        let tail = if factor > 0.0 {
            factor * cum
        } else if cum > 0.0 {
            (ln_scale + cum.ln()).exp()
        } else {
            0.0
        };
        (base + tail).clamp(0.0, 1.0)
    };
    out.push(value(cum, ln_scale, factor));
    for n in 2..=n_max {
        if n > 2 {
            let m = (a * m_prev + b * m_prev2) * inv[n - 1];
            m_prev2 = m_prev;
            m_prev = m;
        }
        cum += m_prev;
        if cum > 1e250 {
            cum *= 1e-250;
            m_prev *= 1e-250;
            m_prev2 *= 1e-250;
            ln_scale += 250.0 * std::f64::consts::LN_10;
            factor = ln_scale.exp();
        }
        let v = value(cum, ln_scale, factor);
        out.push(v);
        if v >= 1.0 - 1e-16 {
            out.resize(n_max + 1, 1.0);
            break;
        }
    }
    out
}

/// [`survival_with`] where mu = t - sigma^2 / g < -sigma / 2 (thresholds below about 0, or read
/// noise much larger than the gain). There the forward recurrence of the partial moments M_j
/// cancels catastrophically (M_j is its minimal solution; at mu = -5 sigma it is wrong by 1e5
/// within 40 terms), so the ratios r_j = M_j / M_(j-1) come from the backward recurrence
/// r_j = j sigma^2 / (r_(j+1) - mu), started at the mode of s^J N(s; mu, sigma) far enough out
/// that the start error has decayed (it shrinks like exp(-2 |mu| / sigma (sqrt J - sqrt j))),
/// and the (all positive) terms are summed in log space. Between -sigma / 2 and 0 the forward
/// recurrence loses at most ~1e-7 relative over 500 terms and is used instead.
fn survival_low_threshold(t_e: f64, gain: f64, sigma: f64, inv: &[f64]) -> Vec<f64> {
    let n_max = inv.len() - 1;
    let s2 = sigma * sigma;
    let mu = t_e - s2 / gain;
    let base = norm_cdf(-t_e / sigma);
    let mut out = Vec::with_capacity(n_max + 1);
    out.push(base);
    let m = (-mu / sigma).max(0.5);
    let j_start = ((n_max as f64).sqrt() + 12.0 / m).powi(2).ceil() as usize + 10;
    let mut r = 0.5 * (mu + (mu * mu + 4.0 * j_start as f64 * s2).sqrt());
    let mut ratios = vec![0.0; n_max.max(1)];
    for j in (1..j_start).rev() {
        r = j as f64 * s2 / (r - mu);
        if j < ratios.len() {
            ratios[j] = r;
        }
    }
    // ln of the j-th term e^(-t/g + s^2 / 2g^2) M_j / (g^j j!), starting at j = 0.
    let mut ln_term = -t_e / gain + s2 / (2.0 * gain * gain) + ln_norm_cdf(mu / sigma);
    let ln_g = gain.ln();
    let mut cum = 0.0;
    for n in 1..=n_max {
        let j = n - 1;
        if j >= 1 {
            ln_term += (ratios[j] * inv[j]).ln() - ln_g;
        }
        cum += ln_term.exp();
        let v = (base + cum).clamp(0.0, 1.0);
        out.push(v);
        if v >= 1.0 - 1e-16 {
            out.resize(n_max + 1, 1.0);
            break;
        }
    }
    out
}

/// Poisson pmf window: (first n, pmf values) covering all but ~1e-30 of the mass for mean `lambda`.
fn poisson_window(lambda: f64, n_max: usize) -> (usize, Vec<f64>) {
    if lambda == 0.0 {
        return (0, vec![1.0]);
    }
    let spread = 12.0 * lambda.sqrt() + 15.0;
    let lo = ((lambda - spread).floor().max(0.0) as usize).min(n_max);
    let hi = ((lambda + spread).ceil() as usize).min(n_max);
    let mut p = (-lambda + lo as f64 * lambda.ln() - ln_gamma(lo as f64 + 1.0)).exp();
    let mut v = Vec::with_capacity(hi - lo + 1);
    for n in lo..=hi {
        v.push(p);
        p *= lambda / (n + 1) as f64;
    }
    (lo, v)
}

/// P(X > t | lambda): probability that the output of a pixel with Poisson light level `lambda`
/// photo-electrons exceeds `t_over_g` (units of g), Gamma register plus Gaussian read noise.
pub fn p_exceed(t_over_g: f64, lambda: f64, gain: f64, read_noise_e: f64) -> f64 {
    let n_max = n_max_for(lambda);
    let s = survival_by_n(t_over_g * gain, gain, read_noise_e, n_max);
    let (lo, pmf) = poisson_window(lambda, n_max);
    pmf.iter().zip(&s[lo..]).map(|(p, s)| p * s).sum()
}

/// Poisson(lambda) average of a per-electron quantity tabulated for n = 0..=n_max (the table reaches
/// 12 sigma beyond lambda_max, so the truncated mass is negligible); `inv` holds 1 / n up to n_max + 1.
pub(super) fn mean_of(per_n: &[f64], lambda: f64, inv: &[f64]) -> f64 {
    if lambda == 0.0 {
        return per_n[0];
    }
    let n_max = per_n.len() - 1;
    // 8 sigma plus 20 terms either side leaves out less than 1e-15 of the mass.
    let spread = 8.0 * lambda.sqrt() + 20.0;
    let lo = ((lambda - spread).floor().max(0.0) as usize).min(n_max);
    let hi = ((lambda + spread).ceil() as usize).min(n_max);
    let mut p = (-lambda + lo as f64 * lambda.ln() - ln_gamma(lo as f64 + 1.0)).exp();
    let mut sum = 0.0;
    for n in lo..=hi {
        sum += p * per_n[n];
        p *= lambda * inv[n + 1];
    }
    sum
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::special::ln_gauss;

    const G: f64 = 500.0;
    const SIGMA: f64 = 50.0;

    #[test]
    fn survival_without_read_noise_is_gamma_ur() {
        use statrs::function::gamma::gamma_ur;
        for t in [0.05, 0.7, 3.0, 40.0] {
            let s = survival_by_n(t * G, G, 0.0, 60);
            assert_eq!(s[0], 0.0);
            for n in [1usize, 2, 5, 20, 60] {
                let want = gamma_ur(n as f64, t);
                assert!(
                    (s[n] - want).abs() < 1e-12,
                    "n {n} t {t}: {} vs {want}",
                    s[n]
                );
            }
        }
        // Huge thresholds underflow e^-u: the rescaled recurrence must still be right.
        let s = survival_by_n(900.0 * G, G, 0.0, 1000);
        assert!((s[900] - gamma_ur(900.0, 900.0)).abs() < 1e-9, "{}", s[900]);
    }

    #[test]
    fn survival_with_read_noise_matches_numerical_integral() {
        // P(Y_n + e > t) = Phi(-t/s) + int_{-12 s}^{t} Q(n, (t-e)/g) phi_s(e) de, the integral by
        // Simpson's rule on 20,000 intervals (the integrand is smooth there; error < 1e-10).
        // Cases cover both evaluation paths (mu = t - s^2/g below and above 0) and read noise far
        // above the gain (g = 10 and 1.5 e-), where the Gamma scale is resolved by 400,000 steps.
        use statrs::function::gamma::gamma_ur;
        let cases = [
            (G, -300.0),
            (G, -40.0),
            (G, 3.0),
            (G, 30.0),
            (G, 89.6),
            (G, 500.0),
            (G, 3000.0),
            (10.0, -100.0),
            (10.0, 60.0),
            (10.0, 400.0),
            (1.5, 20.0),
            (1.5, 2500.0),
        ];
        for (g, t) in cases {
            let s = survival_by_n(t, g, SIGMA, 8);
            assert!((s[0] - norm_cdf(-t / SIGMA)).abs() < 1e-15);
            for (n, &got) in s.iter().enumerate().skip(1) {
                let steps = if g < 100.0 { 400_000 } else { 20_000 };
                let (lo, hi) = (-12.0 * SIGMA, t.min(12.0 * SIGMA));
                let h = (hi - lo) / steps as f64;
                let mut sum = 0.0;
                for i in 0..=steps {
                    let e = lo + i as f64 * h;
                    let w = if i == 0 || i == steps {
                        1.0
                    } else if i % 2 == 1 {
                        4.0
                    } else {
                        2.0
                    };
                    let u = ((t - e) / g).max(0.0);
                    let q = if u == 0.0 { 1.0 } else { gamma_ur(n as f64, u) };
                    sum += w * q * ln_gauss(e, SIGMA).exp();
                }
                let want = norm_cdf(-t / SIGMA) + sum * h / 3.0;
                assert!(
                    (got - want).abs() < 1e-9,
                    "g {g} t {t} n {n}: {got} vs {want}"
                );
            }
        }
    }

    #[test]
    fn poisson_averages_have_the_poisson_moments() {
        // Averaging n and n^2 over Poisson(lambda) gives lambda and lambda + lambda^2; the
        // window and the table cut off less than 1e-15 of the mass.
        for lambda in [0.0, 0.05, 1.0, 7.5, 200.0] {
            let n_max = n_max_for(lambda);
            let inv = reciprocals(n_max + 1);
            let n: Vec<f64> = (0..=n_max).map(|n| n as f64).collect();
            let n2: Vec<f64> = n.iter().map(|n| n * n).collect();
            let (m1, m2) = (mean_of(&n, lambda, &inv), mean_of(&n2, lambda, &inv));
            assert!(
                (m1 - lambda).abs() <= 1e-12 * lambda.max(1.0),
                "{lambda}: {m1}"
            );
            let want = lambda + lambda * lambda;
            assert!((m2 - want).abs() <= 1e-12 * want.max(1.0), "{lambda}: {m2}");
            let (lo, pmf) = poisson_window(lambda, n_max);
            let mass: f64 = pmf.iter().sum();
            assert!((mass - 1.0).abs() < 1e-13, "{lambda}: mass {mass}");
            assert!(lo <= lambda as usize && lo + pmf.len() > lambda as usize);
        }
    }

    #[test]
    fn exceedance_without_read_noise_is_one_minus_the_zero_class() {
        // With no read noise, X > 0 exactly when at least one electron arrived: 1 - e^-lambda.
        // Far below 0 every output exceeds the threshold.
        for lambda in [0.01, 0.7, 5.0] {
            let p = p_exceed(0.0, lambda, G, 0.0);
            assert!((p - (1.0 - (-lambda).exp())).abs() < 1e-14, "{lambda}: {p}");
            assert!((p_exceed(-100.0, lambda, G, SIGMA) - 1.0).abs() < 1e-14);
        }
    }
}
