//! The Cramer-Rao floor of a sub-aperture: the least mean radial error any unbiased centroid
//! can reach for a known spot, signal and per-pixel noise.
//!
//! The Fisher information of the spot position (x0, y0) is the sum over pixels of
//! J_i (d mu_i / d theta)(d mu_i / d theta)', with mu_i the expected photo-electrons (`image`)
//! and J_i the information per e-^2 of a pixel's mean: exact Poisson plus Gaussian read noise
//! (`poisson_gauss`) or the EM register's output (`em_register`). The truth of the Monte-Carlo
//! is the noiseless image's centre of gravity t(theta), so the floor of its error covariance is
//! T I^-1 T' (T = dt/dtheta); R_crlb is the mean of E|e| for e ~ N(0, T I^-1 T') (`radial`,
//! the Hoyt mean radius) over spot positions uniform in [-h, h)^2 (6 x 6 Gauss-Legendre), in
//! the units of R.

pub mod em_register;
mod image;
pub mod poisson_gauss;
pub mod radial;

use crate::detector::{FrameInput, PhotonNoise, Readout};
use crate::montecarlo::SimConfig;
pub use image::{Position, SpotImages};
use std::sync::Arc;

/// Per-pixel information: exact, or the common approximation 1 / (F^2 mu + sigma^2).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Information {
    /// Exact Poisson-Gaussian, or the Gamma register's exact output (read noise <= 1 e- in
    /// input units, else the excess-noise form).
    Exact,
    /// (d mu)^2 / (F^2 mu + sigma^2) for every model.
    Approximate,
}

/// How one camera's pixels carry information about their mean, for the read noises it has.
#[derive(Debug, Clone)]
pub struct PixelNoise {
    photon: PhotonNoise,
    mode: Information,
    /// Gamma-register tables by read-noise bits (EM register models only).
    em: Vec<(u64, Arc<em_register::EmInfo>)>,
}

impl PixelNoise {
    /// The information of `photon` noise read with the read noises in `sigmas_e` (e-, input
    /// units; every value a pixel will use must be listed for an EM register).
    pub fn new(photon: PhotonNoise, mode: Information, sigmas_e: &[f64]) -> Self {
        let mut em: Vec<(u64, Arc<em_register::EmInfo>)> = Vec::new();
        if photon == PhotonNoise::EmRegister && mode == Information::Exact {
            for &s in sigmas_e {
                if !em.iter().any(|(b, _)| *b == s.to_bits()) {
                    em.push((s.to_bits(), em_register::EmInfo::shared(s)));
                }
            }
        }
        PixelNoise { photon, mode, em }
    }

    /// Information (per e-^2 of the expected photo-electrons) of a pixel expecting `mu` e-,
    /// read with noise `sigma` e-.
    pub fn info(&self, mu: f64, sigma: f64) -> f64 {
        match (self.photon, self.mode) {
            (PhotonNoise::Poisson { thinning: q }, Information::Exact) => {
                // Counts of q mu: the information about mu is q^2 that about q mu.
                q * q * poisson_gauss::info(q * mu, sigma)
            }
            (PhotonNoise::Poisson { thinning: q }, Information::Approximate) => {
                if mu > 0.0 {
                    q * q / (q * mu + sigma * sigma)
                } else {
                    0.0
                }
            }
            (PhotonNoise::EmRegister, Information::Exact) => {
                match self.em.iter().find(|(b, _)| *b == sigma.to_bits()) {
                    Some((_, t)) => t.info(mu),
                    None => em_register::EmInfo::shared(sigma).info(mu),
                }
            }
            (PhotonNoise::EmRegister, Information::Approximate) => {
                excess(mu, sigma, em_register::F2)
            }
            (PhotonNoise::Excess { f2 }, _) => excess(mu, sigma, f2),
        }
    }
}

/// The excess-noise approximation 1 / (F^2 mu + sigma^2) (0 without light).
fn excess(mu: f64, sigma: f64, f2: f64) -> f64 {
    if mu > 0.0 {
        1.0 / (f2 * mu + sigma * sigma)
    } else {
        0.0
    }
}

impl SpotImages {
    /// R_crlb (px): the position average of the floor's mean radial error for a window of
    /// per-pixel read noise `sigma_e` (e-, row-major); None when some position carries no
    /// information about one axis (the floor is infinite).
    pub fn r_crlb_px(&self, noise: &PixelNoise, sigma_e: &[f64]) -> Option<f64> {
        let mut r = 0.0;
        for p in &self.positions {
            let f = p.fisher(|i, mu| noise.info(mu, sigma_e[i]));
            r += p.weight * radial::mean_radius(p.truth_covariance(f)?);
        }
        Some(r)
    }
}

/// Read-noise windows (e-, input units) sampled from a readout for the floor of a run: the
/// sigmas a controller knowing the camera assigns to `count` frames of its own streams
/// (seeded by `cfg.seed`), deduplicated (a constant or fixed camera gives one window).
pub fn sigma_windows(cfg: &SimConfig, readout: &dyn Readout, count: u64) -> Vec<Vec<f64>> {
    let npx = cfg.subap_px * cfg.subap_px;
    let (zeros_e, zeros, normals) = (vec![0.0; npx], vec![0u32; npx], vec![0.0; npx]);
    let input = FrameInput {
        subap_px: cfg.subap_px,
        expected_e: &zeros_e,
        mean_e: &zeros_e,
        photo_e: &zeros,
        normals: &normals,
    };
    let (mut out, mut sigma) = (vec![0.0; npx], vec![0.0; npx]);
    let mut windows: Vec<Vec<f64>> = Vec::new();
    for w in 0..count {
        // A stream role of its own ("crlb"), apart from the Monte-Carlo's.
        let mut aux = crate::rng::stream(cfg.seed, w, 0x6372_6c62);
        readout.read_known(&input, &mut aux, &mut out, &mut sigma);
        windows.push(sigma.clone());
    }
    if windows.windows(2).all(|p| p[0] == p[1]) {
        windows.truncate(1);
    }
    windows
}

/// Windows sampled for the floor of a camera whose read noise varies from frame to frame.
pub const WINDOWS: u64 = 32;

/// R_crlb (px) of `readout` in configuration `cfg` with per-pixel information `mode`: the
/// mean over [`WINDOWS`] sampled read-noise windows (one for a constant or fixed camera);
/// None when the floor is infinite.
pub fn r_crlb_of_readout(cfg: &SimConfig, readout: &dyn Readout, mode: Information) -> Option<f64> {
    let windows = sigma_windows(cfg, readout, WINDOWS);
    let mut sigmas: Vec<f64> = windows.iter().flatten().copied().collect();
    sigmas.sort_by(f64::total_cmp);
    sigmas.dedup();
    let noise = PixelNoise::new(readout.photon_noise(), mode, &sigmas);
    let images = SpotImages::new(cfg);
    let mut total = 0.0;
    for w in &windows {
        total += images.r_crlb_px(&noise, w)?;
    }
    Some(total / windows.len() as f64)
}

/// Whether R (px, standard error `r_se_px`) lies below the floor by more than 3 standard
/// errors: a centroid that beats the Cramer-Rao bound is biased.
pub fn below_floor(r_px: f64, r_se_px: f64, r_crlb_px: f64) -> bool {
    r_px < r_crlb_px - 3.0 * r_se_px
}
