//! Fisher information about the mean of one EMCCD pixel: Poisson electrons through the EM
//! register, read with Gaussian noise, all in input electrons (output / gain).
//!
//! The register is the paper's Eq. 2: k >= 1 electrons give Gamma(k, 1) (excess-noise factor
//! F^2 = 2; the exact 520-stage register has 1.974 at gain 500), k = 0 gives 0. With
//! K ~ Poisson(lambda) the output X has an atom e^-lambda at 0 and the density
//! c(x) = e^(-lambda-x) sqrt(lambda / x) I1(2 sqrt(lambda x)); its derivative in lambda is
//! -e^-lambda at 0 and d(x) - c(x) with d(x) = e^(-lambda-x) I0(2 sqrt(lambda x)).
//! Y = X + N(0, sigma^2) and J = int (dp/dlambda)^2 / p dy. Exact for read noise up to
//! [`EXACT_SIGMA_MAX_E`] (the EMCCD case: 50 e- / gain 500 = 0.1 e-); above it, and above
//! [`LAMBDA_MAX_E`], the excess-noise (Gaussian) form with F^2 = 2 is used, stated as such.

use super::poisson_gauss::gaussian_info;
use crate::special::{gauss_legendre, ln_bessel_i1, LN_2PI};
use std::sync::{Arc, Mutex};

/// Largest read noise (input e-) computed exactly; above, the excess-noise approximation.
pub const EXACT_SIGMA_MAX_E: f64 = 1.0;
/// Smallest read noise (input e-) the quadrature resolves; below, this value is used (a read
/// noise under 0.01 e- already separates the atom at 0 from the first electron completely).
const SIGMA_MIN_E: f64 = 0.01;
/// Tabulated means (e-): 1e-3 to 300, 6 nodes per e-fold (cubic interpolation); above 300 the
/// Gaussian form (relative error about 1 / lambda).
const LAMBDA_MIN_E: f64 = 1e-3;
/// Largest tabulated mean (e-).
pub const LAMBDA_MAX_E: f64 = 300.0;
const LN_LAMBDA_STEP: f64 = 1.0 / 6.0;
/// Step of the read-noise grid of [`EmInfo::shared`] in ln sigma (4 nodes per e-fold).
const LN_SIGMA_STEP: f64 = 0.25;
/// Excess-noise factor of the Gamma register.
pub const F2: f64 = 2.0;

/// ln I0(z) for z >= 0: the power series below z = 25, the Hankel expansion above (the form
/// and accuracy of [`ln_bessel_i1`]).
fn ln_bessel_i0(z: f64) -> f64 {
    if z < 25.0 {
        let q = 0.25 * z * z;
        let (mut term, mut sum) = (1.0, 1.0);
        for k in 1..200 {
            term *= q / (k * k) as f64;
            sum += term;
            if term < 1e-17 * sum {
                break;
            }
        }
        sum.ln()
    } else {
        let (mut term, mut sum) = (1.0, 1.0);
        for k in 1..10 {
            let odd = (2 * k - 1) as f64;
            term *= odd * odd / (k as f64 * 8.0 * z);
            sum += term;
        }
        z - 0.5 * (LN_2PI + z.ln()) + sum.ln()
    }
}

/// Density c(x) and d(x) - c(x) of the register output at x > 0 for mean `lambda`.
fn continuous(lambda: f64, x: f64) -> (f64, f64) {
    let z = 2.0 * (lambda * x).sqrt();
    let base = -lambda - x;
    let c = (base + 0.5 * (lambda / x).ln() + ln_bessel_i1(z)).exp();
    let d = (base + ln_bessel_i0(z)).exp();
    (c, d - c)
}

/// Exact J(lambda, sigma) (per e-^2 of lambda) of the Gamma register read with noise sigma.
pub fn exact_info(lambda: f64, sigma: f64) -> f64 {
    let sigma = sigma.max(SIGMA_MIN_E);
    let atom = (-lambda).exp();
    let xmax = lambda + 12.0 * (2.0 * lambda).sqrt() + 40.0;
    let (nodes, weights) = gauss_legendre();
    let norm = 1.0 / (sigma * (2.0 * std::f64::consts::PI).sqrt());
    let phi = |d: f64| norm * (-0.5 * (d / sigma).powi(2)).exp();
    // p(y) and dp/dlambda(y): the atom, then the continuous part over x in y -+ 8 sigma.
    let density = |y: f64| -> (f64, f64) {
        let (mut p, mut q) = (atom * phi(y), -atom * phi(y));
        let (a, b) = ((y - 8.0 * sigma).max(0.0), (y + 8.0 * sigma).min(xmax));
        if b > a {
            let half = 0.5 * (b - a);
            for (t, w) in nodes.iter().zip(weights) {
                let x = a + half * (1.0 + t);
                let (c, dc) = continuous(lambda, x);
                let k = w * half * phi(y - x);
                p += c * k;
                q += dc * k;
            }
        }
        (p, q)
    };
    // Panels 8 sigma wide about the atom, then 4 e- wide (the density varies on the scale of
    // one electron or more there).
    let mut edges = vec![-8.0 * sigma, 0.0, 8.0 * sigma];
    let mut e = 8.0 * sigma;
    while e < xmax + 8.0 * sigma {
        e += 4.0;
        edges.push(e);
    }
    let mut total = 0.0;
    for w in edges.windows(2) {
        let half = 0.5 * (w[1] - w[0]);
        for (t, wt) in nodes.iter().zip(weights) {
            let (p, q) = density(w[0] + half * (1.0 + t));
            if p > 0.0 {
                total += wt * half * q * q / p;
            }
        }
    }
    total
}

/// ln of J (lambda + sigma^2) at the tabulated means for read noise `sigma` (input e-).
fn exact_row(sigma: f64) -> Vec<f64> {
    let columns = ((LAMBDA_MAX_E / LAMBDA_MIN_E).ln() / LN_LAMBDA_STEP).ceil() as usize + 1;
    use rayon::prelude::*;
    (0..columns)
        .into_par_iter()
        .map(|i| {
            let lambda = LAMBDA_MIN_E * (i as f64 * LN_LAMBDA_STEP).exp();
            (exact_info(lambda, sigma) * (lambda + sigma * sigma)).ln()
        })
        .collect()
}

/// J(lambda) of the Gamma register at one read noise, tabulated in ln lambda.
#[derive(Debug, Clone)]
pub struct EmInfo {
    sigma: f64,
    /// ln of J (lambda + sigma^2) at the nodes; empty above [`EXACT_SIGMA_MAX_E`].
    ln_ratio: Vec<f64>,
}

impl EmInfo {
    /// The table for read noise `sigma`, shared across the process: cubic interpolation in
    /// ln sigma between exact tables at fixed read noises (built once each), so a map whose
    /// every pixel has its own read noise (a camera model) costs a few tables, not one per
    /// pixel (that took 190 s for an 8x8 window).
    pub fn shared(sigma: f64) -> Arc<EmInfo> {
        static TABLES: Mutex<Vec<(u64, Arc<EmInfo>)>> = Mutex::new(Vec::new());
        let mut tables = TABLES.lock().unwrap_or_else(|e| e.into_inner());
        if let Some((_, t)) = tables.iter().find(|(b, _)| *b == sigma.to_bits()) {
            return Arc::clone(t);
        }
        let table = Arc::new(EmInfo::interpolated(sigma));
        tables.push((sigma.to_bits(), Arc::clone(&table)));
        table
    }

    /// The ln-ratio row of the exact table at node `j` of the read-noise grid
    /// (SIGMA_MIN_E x e^(j LN_SIGMA_STEP)), built once per process.
    fn node_row(j: usize) -> Arc<Vec<f64>> {
        static ROWS: Mutex<Vec<(usize, Arc<Vec<f64>>)>> = Mutex::new(Vec::new());
        if let Some((_, r)) = ROWS
            .lock()
            .unwrap_or_else(|e| e.into_inner())
            .iter()
            .find(|(k, _)| *k == j)
        {
            return Arc::clone(r);
        }
        let sigma = SIGMA_MIN_E * (j as f64 * LN_SIGMA_STEP).exp();
        let row = Arc::new(exact_row(sigma));
        let mut rows = ROWS.lock().unwrap_or_else(|e| e.into_inner());
        rows.push((j, Arc::clone(&row)));
        row
    }

    /// The table for read noise `sigma`, its ln-ratio row interpolated (cubic in ln sigma)
    /// from the exact rows at the four nearest grid read noises.
    fn interpolated(sigma: f64) -> Self {
        if sigma > EXACT_SIGMA_MAX_E {
            return EmInfo::new(sigma);
        }
        let u = (sigma.max(SIGMA_MIN_E) / SIGMA_MIN_E).ln() / LN_SIGMA_STEP;
        let k = (u.floor() as usize).max(1);
        let w = super::poisson_gauss::lagrange4(u - k as f64);
        let rows: Vec<Arc<Vec<f64>>> = (k - 1..k + 3).map(EmInfo::node_row).collect();
        let ln_ratio = (0..rows[0].len())
            .map(|i| (0..4).map(|r| w[r] * rows[r][i]).sum())
            .collect();
        EmInfo { sigma, ln_ratio }
    }

    /// The table for read noise `sigma` (input e-: the read noise over the gain).
    pub fn new(sigma: f64) -> Self {
        let ln_ratio = if sigma <= EXACT_SIGMA_MAX_E {
            exact_row(sigma)
        } else {
            Vec::new()
        };
        EmInfo { sigma, ln_ratio }
    }

    /// Whether the information is exact (tabulated) rather than the excess-noise form.
    pub fn is_exact(&self) -> bool {
        !self.ln_ratio.is_empty()
    }

    /// J(lambda) (per e-^2), 0 without light; below 1e-3 e- the ratio to
    /// 1 / (lambda + sigma^2) is held (conservative).
    pub fn info(&self, lambda: f64) -> f64 {
        if lambda <= 0.0 || lambda.is_nan() {
            return 0.0;
        }
        if !self.is_exact() || lambda > LAMBDA_MAX_E {
            return gaussian_info(lambda, self.sigma, F2);
        }
        let row = &self.ln_ratio;
        let u = ((lambda.max(LAMBDA_MIN_E) / LAMBDA_MIN_E).ln() / LN_LAMBDA_STEP).max(0.0);
        let k = (u.floor() as usize).clamp(1, row.len() - 3);
        let w = super::poisson_gauss::lagrange4(u - k as f64);
        let ln_c = w[0] * row[k - 1] + w[1] * row[k] + w[2] * row[k + 1] + w[3] * row[k + 2];
        ln_c.exp() / (lambda + self.sigma * self.sigma)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_register_information_has_its_limits() {
        // Dim light with a clean zero: photon counting, J -> e^-lambda / (1 - e^-lambda) ~ 1/lambda,
        // twice the excess-noise form's 1 / (2 lambda).
        let lambda = 0.01;
        let j = exact_info(lambda, 0.01);
        let counting = (-lambda).exp() / -(-lambda).exp_m1();
        assert!(j < counting && j > 0.95 * counting, "{j} vs {counting}");
        // Bright light: the Gaussian form with F^2 = 2.
        let j = exact_info(200.0, 0.1);
        let g = gaussian_info(200.0, 0.1, F2);
        assert!((j / g - 1.0).abs() < 0.01, "{j} vs {g}");
    }

    #[test]
    fn the_shared_table_between_grid_read_noises_follows_the_exact_information() {
        // Off-grid read noises, low to high: the interpolation in ln sigma holds 1e-3.
        for sigma in [0.013, 0.1, 0.37, 0.93] {
            let table = EmInfo::shared(sigma);
            for lambda in [0.002, 0.04, 0.5, 3.3, 40.0] {
                let rel = table.info(lambda) / exact_info(lambda, sigma) - 1.0;
                assert!(rel.abs() < 1e-3, "sigma {sigma}, lambda {lambda}: {rel}");
            }
        }
    }

    #[test]
    fn the_register_table_follows_the_exact_information() {
        let table = EmInfo::new(0.1);
        for lambda in [0.002, 0.04, 0.5, 3.3, 40.0, 250.0] {
            let rel = table.info(lambda) / exact_info(lambda, 0.1) - 1.0;
            assert!(rel.abs() < 1e-3, "{lambda}: {rel}");
        }
    }
}
