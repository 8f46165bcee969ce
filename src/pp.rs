//! Poisson-probability (PP) thresholding of EMCCD output (Basden, Haniff & Mackay 2003) and its
//! photometric correction: the thresholds, the bin count of a pixel, and the mean transfer curve.
//!
//! **This is a reconstruction.** The 2003 paper that defines the thresholds could not be read; SPEC
//! ("Poisson-probability thresholding") and notes section 2.5 fix the rule used here:
//!
//! * Rule A ([`PpRule::PoissonPrior`], the default): for a pixel of mean light level `lambda`
//!   photo-electrons the boundary between `n` and `n + 1` counts is where
//!   `Pois(n; lambda) p(x | n) = Pois(n + 1; lambda) p(x | n + 1)` with the Erlang register output
//!   `p(x | n)`, which is `x / g = n (n + 1) / lambda` for `n >= 1`. The 0|1 boundary is where the
//!   zero-electron Gaussian read-noise peak and the one-electron exponentially modified Gaussian are
//!   equally likely under the same prior ([`zero_one_threshold_e`]), or a fixed `k * sigma`.
//! * Rule B ([`PpRule::EqualDensity`]): the literal reading, fixed boundaries where the output
//!   densities of Poisson light levels `n` and `n + 1` are equal (about 0.203, 0.719, 1.896,
//!   2.936 g for g = 500, read noise 50 e-). It hardly reduces noise; it is kept as a documented
//!   alternative.
//!
//! The output model is the exact Gamma register (`Gamma(n, g)` for `n >= 1` input electrons, 0 for
//! none) plus Gaussian read noise, in output electrons; thresholds are in units of the mean gain
//! `g`, so a readout that divides by `g` can compare directly. The photometric correction inverts
//! the mean transfer curve `E[K | lambda] = sum_k P(X > t_k | lambda)` by interpolation on a
//! tabulated `lambda` grid; the per-count inverse is precomputed, so correcting a pixel is a lookup.
//!
//! Use in a readout (the register output plus read noise, divided by g, is `x_over_g`):
//!
//! ```
//! use detnoise::pp::{PpCache, PpConfig, PpRule};
//! let cache = PpCache::new(PpConfig::new(PpRule::PoissonPrior, 500.0, 50.0)?, 1024)?;
//! // Once per frame: the sub-aperture's photo-electrons per pixel.
//! let counter = cache.get(50.0 / 64.0)?;
//! let x_over_g = 1.3;
//! let photons = counter.count(x_over_g); // `emccd-pp-uncorrected`
//! let lambda_hat = counter.corrected(x_over_g); // `emccd-pp`
//! assert_eq!(photons, 1);
//! assert!(lambda_hat > 0.0);
//! # Ok::<(), detnoise::Error>(())
//! ```
//!
//! Cost (release build, `cargo run --release --example pp_cost`): a Rule A [`PpCounter`] takes
//! 0.4 ms (lambda_ref 0.05) to 1 ms (lambda_ref 20) to build with the default `lambda_max`, mostly
//! the exact per-electron transfer table; Rule B takes about 0.36 s, once per run. A readout whose
//! reference light level changes per frame should use [`PpCache`]: the sub-aperture mean
//! photo-electrons per pixel (total / pixels) takes few distinct values, so almost every frame
//! is a cache hit (about 1 us).

use std::collections::HashMap;
use std::sync::{Arc, Mutex, OnceLock};

use statrs::function::erf::erfc;
use statrs::function::gamma::ln_gamma;

use crate::error::{Error, Result};

const LN_2PI: f64 = 1.837_877_066_409_345_5;

/// Which boundaries between photon counts are used (see the module documentation).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum PpRule {
    /// Rule A: MAP boundaries under a Poisson prior of mean `lambda_ref`, `t_n / g = n (n + 1) / lambda_ref`.
    PoissonPrior,
    /// Rule B: fixed boundaries where the output densities of light levels `n` and `n + 1` are equal.
    EqualDensity,
}

/// How the 0|1 boundary is placed.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum ZeroOneRule {
    /// The rule's own equal-probability (Rule A) or equal-density (Rule B) boundary.
    Equal,
    /// A fixed boundary at `k` times the read noise (output electrons).
    KSigma(f64),
}

/// Everything that fixes a PP readout except the reference light level.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PpConfig {
    /// Threshold rule.
    pub rule: PpRule,
    /// Placement of the 0|1 boundary.
    pub zero_one: ZeroOneRule,
    /// Mean EM gain g (output electrons per photo-electron).
    pub gain: f64,
    /// Read noise in output electrons rms (before division by g).
    pub read_noise_e: f64,
    /// Largest mean photo-electrons per pixel the correction must cover; brighter pixels saturate.
    pub lambda_max: f64,
}

impl PpConfig {
    /// Default largest light level covered by the thresholds and the correction, photo-electrons per pixel.
    pub const DEFAULT_LAMBDA_MAX: f64 = 256.0;
    /// Reference light levels below this (photo-electrons per pixel) are raised to it (Rule A).
    pub const LAMBDA_MIN: f64 = 1e-6;

    /// A configuration with the rule's own 0|1 boundary and the default `lambda_max`; checks the values.
    pub fn new(rule: PpRule, gain: f64, read_noise_e: f64) -> Result<Self> {
        let cfg = PpConfig {
            rule,
            zero_one: ZeroOneRule::Equal,
            gain,
            read_noise_e,
            lambda_max: Self::DEFAULT_LAMBDA_MAX,
        };
        cfg.validate()?;
        Ok(cfg)
    }

    /// Checks that gain, read noise, `lambda_max` and `k` are finite and in range.
    pub fn validate(&self) -> Result<()> {
        if !(self.gain.is_finite() && self.gain > 0.0) {
            return Err(Error::invalid(
                "--gain",
                format!("EM gain must be > 0, got {}", self.gain),
            ));
        }
        if !(self.read_noise_e.is_finite() && self.read_noise_e >= 0.0) {
            return Err(Error::invalid(
                "--emccd-read-noise",
                format!("read noise must be >= 0 e-, got {}", self.read_noise_e),
            ));
        }
        if !(self.lambda_max.is_finite() && self.lambda_max > 0.0 && self.lambda_max <= 1e5) {
            return Err(Error::invalid(
                "--pp-lambda-max",
                format!(
                    "must be in (0, 1e5] photo-electrons, got {}",
                    self.lambda_max
                ),
            ));
        }
        if let ZeroOneRule::KSigma(k) = self.zero_one {
            if !(k.is_finite() && k > 0.0) || self.read_noise_e == 0.0 {
                return Err(Error::invalid(
                    "--pp-zero-one",
                    format!("k*sigma threshold needs k > 0 and read noise > 0, got k = {k}"),
                ));
            }
        }
        Ok(())
    }

    /// The thresholds for reference light level `lambda_ref` (photo-electrons per pixel, >= 0;
    /// ignored by Rule B).
    pub fn thresholds(&self, lambda_ref: f64) -> Result<PpThresholds> {
        self.validate()?;
        let u_max = output_span_over_g(self.lambda_max);
        let mut t = match self.rule {
            PpRule::PoissonPrior => {
                check_lambda(lambda_ref, "--pp-lambda")?;
                // A dark frame (lambda 0) gets the thresholds of a very faint one: practically
                // everything counts 0, which is the MAP answer.
                let lambda = lambda_ref.max(Self::LAMBDA_MIN);
                let t0 = zero_one_threshold_e(lambda, self.gain, self.read_noise_e)? / self.gain;
                rule_a_thresholds(t0, lambda, u_max)
            }
            PpRule::EqualDensity => rule_b_thresholds(self.gain, self.read_noise_e, u_max)?,
        };
        if let ZeroOneRule::KSigma(k) = self.zero_one {
            t[0] = k * self.read_noise_e / self.gain;
            if t.len() > 1 && t[0] >= t[1] {
                return Err(Error::invalid(
                    "--pp-zero-one",
                    format!("{k} sigma lies above the 1|2 boundary ({:.3} g)", t[1]),
                ));
            }
        }
        Ok(PpThresholds {
            t_over_g: t,
            gain: self.gain,
            read_noise_e: self.read_noise_e,
        })
    }

    /// Thresholds plus photometric correction for `lambda_ref` (photo-electrons per pixel).
    pub fn counter(&self, lambda_ref: f64) -> Result<PpCounter> {
        let thresholds = self.thresholds(lambda_ref)?;
        let correction = PhotometricCorrection::new(&thresholds, self.lambda_max)?;
        Ok(PpCounter {
            lambda_ref,
            thresholds,
            correction,
        })
    }
}

fn check_lambda(lambda: f64, option: &str) -> Result<()> {
    if lambda.is_finite() && lambda >= 0.0 {
        Ok(())
    } else {
        Err(Error::invalid(
            option,
            format!("light level must be finite and >= 0, got {lambda}"),
        ))
    }
}

/// Output (in units of g) above which a pixel of mean `lambda_max` photo-electrons practically never lands:
/// mean `lambda`, variance about `2 lambda` (excess noise factor 2), plus 10 sigma and a margin.
fn output_span_over_g(lambda_max: f64) -> f64 {
    lambda_max + 10.0 * (2.0 * lambda_max).sqrt() + 10.0
}

/// Largest photo-electron count tabulated for light levels up to `lambda_max` (12 sigma of the Poisson).
fn n_max_for(lambda_max: f64) -> usize {
    (lambda_max + 12.0 * lambda_max.sqrt() + 30.0).ceil() as usize
}

/// Rule A boundary between `n` and `n + 1` counts (`n >= 1`) in units of g: `n (n + 1) / lambda`.
pub fn rule_a_threshold_over_g(n: usize, lambda: f64) -> f64 {
    (n * (n + 1)) as f64 / lambda
}

fn rule_a_thresholds(t0_over_g: f64, lambda: f64, u_max: f64) -> Vec<f64> {
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

/// Standard normal cdf.
fn norm_cdf(z: f64) -> f64 {
    0.5 * erfc(-z / std::f64::consts::SQRT_2)
}

/// ln of the standard normal cdf, accurate far into the lower tail.
fn ln_norm_cdf(z: f64) -> f64 {
    if z > -37.0 {
        norm_cdf(z).ln()
    } else {
        // Asymptotic series of the Mills ratio; at |z| >= 37 the next term is below 1e-15.
        let q = 1.0 / (z * z);
        let series =
            1.0 - q * (1.0 - 3.0 * q * (1.0 - 5.0 * q * (1.0 - 7.0 * q * (1.0 - 9.0 * q))));
        -0.5 * z * z - (-z).ln() - 0.5 * LN_2PI + series.ln()
    }
}

/// ln of the N(0, sigma^2) density at x.
fn ln_gauss(x: f64, sigma: f64) -> f64 {
    -0.5 * (x / sigma).powi(2) - sigma.ln() - 0.5 * LN_2PI
}

/// ln of the one-electron output density (exponential of scale g convolved with N(0, sigma^2)), per electron.
fn ln_emg(x: f64, gain: f64, sigma: f64) -> f64 {
    -gain.ln() + sigma * sigma / (2.0 * gain * gain) - x / gain
        + ln_norm_cdf(x / sigma - sigma / gain)
}

/// Rule A 0|1 boundary in output electrons for light level `lambda`: the x where
/// `N(x; 0, sigma)` equals `lambda * EMG(x)` (zero- and one-electron terms equally likely).
/// About 141 e- at lambda = 0.1 and 89.6 e- at lambda = 1 for g = 500, sigma = 50 e-.
/// Without read noise the boundary is 0.
pub fn zero_one_threshold_e(lambda: f64, gain: f64, read_noise_e: f64) -> Result<f64> {
    check_lambda(lambda, "--pp-lambda")?;
    if lambda == 0.0 {
        return Err(Error::invalid(
            "--pp-lambda",
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

/// Root of `f` between `lo` (f > 0) and `hi` (f < 0), to the precision of f64.
fn bisect(f: impl Fn(f64) -> f64, mut lo: f64, mut hi: f64) -> f64 {
    for _ in 0..200 {
        let mid = 0.5 * (lo + hi);
        if mid <= lo || mid >= hi {
            break;
        }
        if f(mid) > 0.0 {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    0.5 * (lo + hi)
}

/// Gauss-Legendre nodes and weights on [-1, 1] (64 points), computed once.
fn gauss_legendre() -> &'static (Vec<f64>, Vec<f64>) {
    static GL: OnceLock<(Vec<f64>, Vec<f64>)> = OnceLock::new();
    GL.get_or_init(|| {
        let n = 64;
        let (mut x, mut w) = (vec![0.0; n], vec![0.0; n]);
        for i in 0..n {
            let mut z = (std::f64::consts::PI * (i as f64 + 0.75) / (n as f64 + 0.5)).cos();
            let mut dp = 1.0;
            for _ in 0..100 {
                let (mut p0, mut p1) = (1.0, z);
                for k in 2..=n {
                    let p2 = ((2 * k - 1) as f64 * z * p1 - (k - 1) as f64 * p0) / k as f64;
                    p0 = p1;
                    p1 = p2;
                }
                dp = n as f64 * (z * p1 - p0) / (z * z - 1.0);
                let dz = p1 / dp;
                z -= dz;
                if dz.abs() < 1e-15 {
                    break;
                }
            }
            x[i] = z;
            w[i] = 2.0 / ((1.0 - z * z) * dp * dp);
        }
        (x, w)
    })
}

/// ln I1(z) for z > 0 (modified Bessel function of the first kind, order 1).
fn ln_bessel_i1(z: f64) -> f64 {
    if z < 25.0 {
        let q = 0.25 * z * z;
        let (mut term, mut sum) = (1.0, 1.0);
        for k in 1..200 {
            term *= q / (k * (k + 1)) as f64;
            sum += term;
            if term < 1e-17 * sum {
                break;
            }
        }
        (0.5 * z).ln() + sum.ln()
    } else {
        // Hankel asymptotic expansion: I1(z) ~ e^z / sqrt(2 pi z) sum_k (-1)^k a_k(1) / z^k.
        let (mut term, mut sum) = (1.0, 1.0);
        for k in 1..10 {
            let odd = (2 * k - 1) as f64;
            term *= -(4.0 - odd * odd) / (k as f64 * 8.0 * z);
            sum += term;
        }
        z - 0.5 * (LN_2PI + z.ln()) + sum.ln()
    }
}

/// ln of the continuous part of the noiseless output density for Poisson light level `lam`,
/// per output electron at y > 0: `e^(-lam - u) sqrt(lam / u) I1(2 sqrt(lam u)) / g`, u = y / g.
fn ln_compound_density(y: f64, lam: f64, gain: f64) -> f64 {
    let u = y / gain;
    let z = 2.0 * (lam * u).sqrt();
    let ln_h = if z < 1e-6 {
        lam.ln()
    } else {
        0.5 * (lam / u).ln() + ln_bessel_i1(z)
    };
    -lam - u + ln_h - gain.ln()
}

/// ln of the output density (per electron) at x for Poisson light level `lam`, including read noise.
fn ln_output_density(x: f64, lam: f64, gain: f64, sigma: f64) -> f64 {
    if sigma == 0.0 {
        return ln_compound_density(x.max(f64::MIN_POSITIVE), lam, gain);
    }
    let (nodes, weights) = gauss_legendre();
    let a = (x - 10.0 * sigma).max(0.0);
    let b = x + 10.0 * sigma;
    let mut terms = vec![-lam + ln_gauss(x, sigma)];
    if b > a {
        let (mid, half) = (0.5 * (a + b), 0.5 * (b - a));
        for (z, w) in nodes.iter().zip(weights) {
            let y = mid + half * z;
            terms
                .push((w * half).ln() + ln_compound_density(y, lam, gain) + ln_gauss(x - y, sigma));
        }
    }
    log_sum_exp(&terms)
}

fn log_sum_exp(v: &[f64]) -> f64 {
    let m = v.iter().cloned().fold(f64::NEG_INFINITY, f64::max);
    if m == f64::NEG_INFINITY {
        return m;
    }
    m + v.iter().map(|x| (x - m).exp()).sum::<f64>().ln()
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

fn rule_b_thresholds(gain: f64, sigma: f64, u_max: f64) -> Result<Vec<f64>> {
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

/// P(X > t | n input electrons) for n = 0..=n_max, X = register output (Gamma(n, g), 0 for n = 0)
/// plus N(0, sigma^2) read noise, t in output electrons. Exact: the Gaussian integral of the
/// regularised upper incomplete gamma reduces to partial Gaussian moments with a 3-term recurrence.
pub fn survival_by_n(t_e: f64, gain: f64, read_noise_e: f64, n_max: usize) -> Vec<f64> {
    survival_with(t_e, gain, read_noise_e, &reciprocals(n_max + 1))
}

/// 1 / n for n = 0..=n_max (entry 0 is unused): the recurrences multiply instead of dividing,
/// which keeps divisions out of their dependency chains.
fn reciprocals(n_max: usize) -> Vec<f64> {
    (0..=n_max).map(|n| 1.0 / n.max(1) as f64).collect()
}

/// [`survival_by_n`] for n = 0..inv.len() - 1, with the reciprocal table `inv`.
fn survival_with(t_e: f64, gain: f64, read_noise_e: f64, inv: &[f64]) -> Vec<f64> {
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
        self.t_over_g.partition_point(|&t| t < x_over_g)
    }

    /// P(X > t_over_g[k] g | lambda) for Poisson light level `lambda` photo-electrons.
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

/// P(X > t | lambda): probability that the output of a pixel with Poisson light level `lambda`
/// photo-electrons exceeds `t_over_g` (units of g), Gamma register plus Gaussian read noise.
pub fn p_exceed(t_over_g: f64, lambda: f64, gain: f64, read_noise_e: f64) -> f64 {
    let n_max = n_max_for(lambda);
    let s = survival_by_n(t_over_g * gain, gain, read_noise_e, n_max);
    let (lo, pmf) = poisson_window(lambda, n_max);
    pmf.iter().zip(&s[lo..]).map(|(p, s)| p * s).sum()
}

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
                "--pp-lambda-max",
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

/// Poisson(lambda) average of a per-electron quantity tabulated for n = 0..=n_max (the table reaches
/// 12 sigma beyond lambda_max, so the truncated mass is negligible); `inv` holds 1 / n up to n_max + 1.
fn mean_of(per_n: &[f64], lambda: f64, inv: &[f64]) -> f64 {
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

/// A ready PP readout for one reference light level: thresholds and photometric correction.
#[derive(Clone, Debug)]
pub struct PpCounter {
    /// Reference light level the thresholds were built for, photo-electrons per pixel.
    pub lambda_ref: f64,
    /// The boundaries.
    pub thresholds: PpThresholds,
    /// The inverse transfer curve for these boundaries.
    pub correction: PhotometricCorrection,
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
}

/// Thread-safe cache of [`PpCounter`]s keyed by the exact reference light level, for readouts whose
/// reference changes per frame. It is cleared when it exceeds `capacity` entries.
#[derive(Debug)]
pub struct PpCache {
    config: PpConfig,
    capacity: usize,
    map: Mutex<HashMap<u64, Arc<PpCounter>>>,
}

impl PpCache {
    /// A cache for `config` holding at most `capacity` counters.
    pub fn new(config: PpConfig, capacity: usize) -> Result<Self> {
        config.validate()?;
        Ok(PpCache {
            config,
            capacity: capacity.max(1),
            map: Mutex::new(HashMap::new()),
        })
    }

    /// The counter for `lambda_ref` photo-electrons per pixel, built on first use.
    pub fn get(&self, lambda_ref: f64) -> Result<Arc<PpCounter>> {
        // Rule B does not depend on the light level: one entry serves all.
        let key = match self.config.rule {
            PpRule::EqualDensity => 0,
            PpRule::PoissonPrior => lambda_ref.to_bits(),
        };
        if let Some(c) = self.lock().get(&key) {
            return Ok(Arc::clone(c));
        }
        let counter = Arc::new(self.config.counter(lambda_ref)?);
        let mut map = self.lock();
        if map.len() >= self.capacity {
            map.clear();
        }
        map.insert(key, Arc::clone(&counter));
        Ok(counter)
    }

    fn lock(&self) -> std::sync::MutexGuard<'_, HashMap<u64, Arc<PpCounter>>> {
        // A panic while holding the lock cannot leave the map inconsistent (inserts are atomic).
        self.map.lock().unwrap_or_else(|e| e.into_inner())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rng::stream;
    use rand_distr::{Distribution, Gamma, Normal, Poisson};

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
    fn rule_a_thresholds_are_n_n_plus_1_over_lambda() {
        let cfg = PpConfig::new(PpRule::PoissonPrior, G, SIGMA).unwrap();
        let t = cfg.thresholds(1.0).unwrap();
        assert!(
            (t.t_over_g[0] - 0.179).abs() < 0.001,
            "{:?}",
            &t.t_over_g[..4]
        );
        for (n, want) in [(1, 2.0), (2, 6.0), (3, 12.0), (4, 20.0)] {
            assert_eq!(t.t_over_g[n], want);
        }
        assert!(t.t_over_g.windows(2).all(|w| w[0] < w[1]));
        assert!(*t.t_over_g.last().unwrap() >= output_span_over_g(cfg.lambda_max));
        assert_eq!(t.count(0.1), 0);
        assert_eq!(t.count(0.5), 1);
        assert_eq!(t.count(5.0), 2);
        assert_eq!(t.count(1e9), t.t_over_g.len());
    }

    #[test]
    fn rule_b_thresholds_match_reference_values() {
        let mut cfg = PpConfig::new(PpRule::EqualDensity, G, SIGMA).unwrap();
        cfg.lambda_max = 4.0;
        let t = cfg.thresholds(0.0).unwrap();
        eprintln!("Rule B: {:?}", &t.t_over_g[..6]);
        for (k, want) in [0.203, 0.719, 1.896, 2.936, 3.953, 4.963]
            .into_iter()
            .enumerate()
        {
            assert!(
                (t.t_over_g[k] - want).abs() < 0.002,
                "t_{k} = {} vs {want}",
                t.t_over_g[k]
            );
        }
    }

    #[test]
    fn bessel_series_and_asymptotic_agree() {
        // Both branches evaluated on either side of the switch at z = 25.
        let series = |z: f64| {
            let q = 0.25 * z * z;
            let (mut term, mut sum) = (1.0f64, 1.0f64);
            for k in 1..400 {
                term *= q / (k * (k + 1)) as f64;
                sum += term;
            }
            (0.5 * z).ln() + sum.ln()
        };
        for z in [25.0, 30.0, 60.0] {
            assert!((ln_bessel_i1(z) - series(z)).abs() < 1e-10, "z = {z}");
        }
        // I1(1) = 0.565159103992485.
        assert!((ln_bessel_i1(1.0) - 0.565_159_103_992_485f64.ln()).abs() < 1e-13);
    }

    #[test]
    fn ln_norm_cdf_is_accurate_in_the_far_tail() {
        // Both branches agree where both are representable (the switch is at -37).
        for z in [-36.0, -37.5, -38.0] {
            let direct = norm_cdf(z).ln();
            assert!(
                (ln_norm_cdf(z) - direct).abs() < 1e-9 * direct.abs(),
                "z = {z}"
            );
        }
        assert!(ln_norm_cdf(-100.0).is_finite());
    }

    #[test]
    fn low_gain_thresholds_stay_ordered_and_invertible() {
        // Read noise 50 e- at gain 10: at lambda 0.3 the 0|1 boundary (about 20.2 g) lies above
        // the 1|2 and 2|3 boundaries (6.7 g, 20 g). The set must stay increasing, and the
        // correction must still invert the transfer curve (and the survival stays accurate
        // where mu = t - sigma^2 / g is far below 0 for every threshold).
        let cfg = PpConfig::new(PpRule::PoissonPrior, 10.0, SIGMA).unwrap();
        for lambda in [0.3, 3.0, 30.0] {
            let c = cfg.counter(lambda).unwrap();
            let t = &c.thresholds.t_over_g;
            assert!(t.windows(2).all(|w| w[0] < w[1]));
            if lambda == 0.3 {
                assert!(
                    t[0] > 20.0 && t[1] > t[0] && t[2] > t[1] && t[3] == 40.0,
                    "{:?}",
                    &t[..4]
                );
            }
            let back = c.correction.invert(c.correction.expected_count(lambda));
            assert!(
                (back - lambda).abs() < 5e-3 * lambda,
                "lambda {lambda} -> {back}"
            );
        }
    }

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

    fn rule_a_ref1() -> PpCounter {
        PpConfig::new(PpRule::PoissonPrior, G, SIGMA)
            .unwrap()
            .counter(1.0)
            .unwrap()
    }

    #[test]
    fn transfer_curve_matches_reference_values() {
        let c = rule_a_ref1();
        // Reference values (notes 2.5) neglect read noise for n >= 1; here it is exact, which moves
        // E[K] by < 0.003 (the EMG shift e^(sigma^2 / 2 g^2) = 1.005 on the one-electron term).
        for (lambda, want) in [(0.1, 0.128), (1.0, 0.777), (5.0, 2.174), (20.0, 4.444)] {
            let table = c.correction.expected_count(lambda);
            let direct = c.thresholds.expected_count(lambda);
            eprintln!("E[K | {lambda}] = {table:.4} (direct {direct:.4}), reference {want}");
            assert!((table - want).abs() < 0.004, "lambda {lambda}: {table}");
            assert!((table - direct).abs() < 1e-10);
        }
    }

    #[test]
    fn transfer_curve_matches_monte_carlo() {
        // Exact output model: k ~ Poisson(lambda), X = Gamma(k, g) (0 for k = 0) + N(0, sigma).
        // The sample mean of K has standard error sd(K) / sqrt(N), with sd(K) estimated from the same
        // sample (N = 400,000, sd(K) <= 2.5, so SE <= 0.004). Tolerance: 5 SE, a false-alarm rate of
        // 6e-7 per check if the analytic curve is right, while a wrong threshold convention
        // (e.g. counting x >= t_k vs > t_k is immaterial, but an off-by-one bin is not) shifts E[K]
        // by 0.1-1, i.e. 25-250 SE.
        let c = rule_a_ref1();
        let normal = Normal::new(0.0, SIGMA).unwrap();
        for (i, lambda) in [0.1, 1.0, 5.0, 20.0].into_iter().enumerate() {
            let n = 400_000;
            let mut rng = stream(2026, i as u64, 0x99);
            let pois = Poisson::new(lambda).unwrap();
            let (mut s1, mut s2) = (0.0, 0.0);
            for _ in 0..n {
                let k = pois.sample(&mut rng) as u64;
                let reg = if k == 0 {
                    0.0
                } else {
                    Gamma::new(k as f64, G).unwrap().sample(&mut rng)
                };
                let x = (reg + normal.sample(&mut rng)) / G;
                let kk = c.count(x) as f64;
                s1 += kk;
                s2 += kk * kk;
            }
            let mean = s1 / n as f64;
            let sd = (s2 / n as f64 - mean * mean).sqrt();
            let se = sd / (n as f64).sqrt();
            let want = c.correction.expected_count(lambda);
            eprintln!("lambda {lambda}: MC {mean:.4} +- {se:.4}, analytic {want:.4}");
            assert!(
                (mean - want).abs() < 5.0 * se,
                "lambda {lambda}: {mean} vs {want} (se {se})"
            );
        }
    }

    #[test]
    fn correction_inverts_transfer_curve() {
        let c = rule_a_ref1();
        let mut worst: f64 = 0.0;
        for lambda in [0.05, 0.3, 1.0, 2.5, 7.0, 20.0, 60.0, 200.0] {
            let back = c.correction.invert(c.correction.expected_count(lambda));
            let rel = (back - lambda).abs() / lambda;
            worst = worst.max(rel);
            // Linear interpolation on a quadratic grid of 512 intervals: relative error well below 1 %.
            assert!(rel < 5e-3, "lambda {lambda} -> {back}");
        }
        eprintln!("worst relative inversion error {worst:.2e}");
        assert_eq!(c.correction.invert(0.0), 0.0);
        assert_eq!(c.correction.invert(c.correction.expected_count(0.0)), 0.0);
        // Per-count lookup is monotone and starts at 0.
        let k_max = c.thresholds.t_over_g.len();
        assert_eq!(c.correction.lambda_for_count(0), 0.0);
        assert!((1..=k_max)
            .all(|k| c.correction.lambda_for_count(k) >= c.correction.lambda_for_count(k - 1)));
        assert!(c.corrected(2.5) > 1.0);
    }

    #[test]
    fn k_sigma_option_and_bad_values() {
        let mut cfg = PpConfig::new(PpRule::PoissonPrior, G, SIGMA).unwrap();
        cfg.zero_one = ZeroOneRule::KSigma(5.0);
        let t = cfg.thresholds(1.0).unwrap();
        assert_eq!(t.t_over_g[0], 0.5);
        assert!(cfg.thresholds(-1.0).is_err());
        assert!(cfg.thresholds(f64::NAN).is_err());
        // A dark reference gives a counter that counts read noise as 0.
        cfg.zero_one = ZeroOneRule::Equal;
        let dark = cfg.counter(0.0).unwrap();
        assert_eq!(dark.count(0.5), 0);
        assert!(dark.thresholds.t_over_g[0] > 0.5);
        cfg.zero_one = ZeroOneRule::KSigma(5.0);
        cfg.zero_one = ZeroOneRule::KSigma(50.0);
        assert!(cfg.thresholds(1.0).is_err());
        assert!(PpConfig::new(PpRule::PoissonPrior, -1.0, SIGMA).is_err());
        assert!(PpConfig::new(PpRule::PoissonPrior, G, f64::INFINITY).is_err());
    }

    #[test]
    fn cache_reuses_counters() {
        let cache =
            PpCache::new(PpConfig::new(PpRule::PoissonPrior, G, SIGMA).unwrap(), 8).unwrap();
        let a = cache.get(1.5).unwrap();
        let b = cache.get(1.5).unwrap();
        assert!(Arc::ptr_eq(&a, &b));
        let c = cache.get(2.0).unwrap();
        assert_eq!(c.thresholds.t_over_g[1], 1.0);
    }
}
