//! The shot noise of the dark current against D (EMVA 1288's second method): per pixel, the
//! temporal variance against exposure time, `var_adu2 = a_G + (G^2 F^2 / K^2) t D(T) D_var`
//! with one intercept per EM gain (read noise, and CIC's shot noise, which depends on G), and
//! the mean over pixels of D_var compared with that of D from the mean dark.

use rayon::prelude::*;
use serde::Serialize;

use super::design::Design;
use super::pixels::{Maps, PixelGain, CHUNK};
use super::wls::Normal;

/// Most parameters of one variance fit: one intercept per EM gain and the slope.
const MAX_P: usize = 8;
use crate::detector::register::excess_noise_factor_sq;

/// A ratio more than this many SEs from 1 is not `consistent`.
const STATUS_SE: f64 = 3.0;

/// The excess noise factor of one EM gain.
#[derive(Clone, Debug, Serialize, PartialEq)]
pub struct GainNoiseFactor {
    /// EM gain used (e-/e-; 1 without a register).
    pub em_gain: f64,
    /// The register's F^2 at that gain (1 without a register).
    pub excess_noise_factor_sq: f64,
}

/// The dark current's shot noise checked against D.
#[derive(Clone, Debug, Serialize, PartialEq)]
pub struct ShotNoiseCheck {
    /// How it is measured, in one sentence.
    pub method: String,
    /// Pixels averaged (fitted by both the mean and the variance).
    pub pixels: usize,
    /// F^2 used at each EM gain.
    pub excess_noise_factors: Vec<GainNoiseFactor>,
    /// Mean over pixels of D from the variance slope (e-/s).
    pub dark_current_from_variance_e_per_s: f64,
    /// Its SE (e-/s).
    pub dark_current_from_variance_se_e_per_s: f64,
    /// Mean over the same pixels of D from the mean dark (e-/s).
    pub dark_current_from_mean_e_per_s: f64,
    /// Its SE (e-/s).
    pub dark_current_from_mean_se_e_per_s: f64,
    /// From variance / from mean (1 for Poisson dark current with the right G, F^2 and K).
    pub ratio: f64,
    /// Its SE, from the per-pixel pairs (delta method).
    pub ratio_se: f64,
    /// `consistent` (within 3 SE of 1), `excess` (more noise than D's shot noise: e.g. a
    /// wrong F^2 or K, or RTS) or `deficit`.
    pub status: String,
}

/// The check, or why it cannot be made (for the notes).
pub(super) fn check(
    design: &Design,
    k: &PixelGain,
    factors: &[f64],
    maps: &Maps,
    stages: u32,
) -> std::result::Result<ShotNoiseCheck, String> {
    let mut gains: Vec<f64> = design.conds.iter().map(|c| c.g).collect();
    gains.sort_by(f64::total_cmp);
    gains.dedup();
    let group: Vec<usize> = design
        .conds
        .iter()
        .map(|c| gains.iter().position(|g| *g == c.g).unwrap_or(0))
        .collect();
    let sloped = (0..gains.len()).any(|gi| {
        let mut x: Vec<f64> = (0..design.conds.len())
            .filter(|&i| group[i] == gi)
            .map(|i| design.conds[i].t * factors[i])
            .collect();
        x.sort_by(f64::total_cmp);
        x.dedup();
        x.len() >= 2
    });
    if !sloped {
        return Err(
            "dark-current shot noise not checked: no EM gain has darks at two exposure times"
                .into(),
        );
    }
    if gains.len() + 1 > MAX_P {
        return Err(format!(
            "dark-current shot noise not checked: {} EM gains, at most {} in one variance fit",
            gains.len(),
            MAX_P - 1
        ));
    }
    let f2: Vec<f64> = gains
        .iter()
        .map(|&g| {
            if design.register {
                excess_noise_factor_sq(g, stages)
            } else {
                1.0
            }
        })
        .collect();
    // Weights from each condition's typical variance, not the pixel's own (a pixel's variance
    // as its own weight biases its slope low).
    let w: Vec<f64> = design
        .conds
        .iter()
        .zip(&design.typical)
        .map(|(c, t)| (c.stats.frames as f64 - 1.0) / (2.0 * t[1] * t[1]))
        .collect();
    let np = gains.len() + 1;
    // The smallest solver that holds the parameters (a fit per pixel: its size is the cost).
    fn solve<const P: usize>(
        np: usize,
        rows: impl Iterator<Item = (usize, f64, f64, f64)>,
    ) -> Option<f64> {
        let mut n = Normal::<P>::new(np);
        let mut x = [0.0; P];
        for (g, s, y, w) in rows {
            x.fill(0.0);
            x[g] = 1.0;
            x[np - 1] = s;
            n.add(&x, y, w);
        }
        Some(n.solve()?.x[np - 1])
    }
    let slope = |p: usize| -> Option<f64> {
        let kp = k.at(p);
        let rows = design.conds.iter().enumerate().map(|(i, c)| {
            let s = c.g * c.g * f2[group[i]] * kp * kp * c.t * factors[i];
            (group[i], s, c.stats.var_adu2[p], w[i])
        });
        if np <= 4 {
            solve::<4>(np, rows)
        } else {
            solve::<MAX_P>(np, rows)
        }
    };
    // Per chunk: n, sum Dv, sum D, sum Dv^2, sum D^2, sum Dv D.
    let parts: Vec<[f64; 6]> = (0..design.npix.div_ceil(CHUNK))
        .into_par_iter()
        .map(|ch| {
            let mut s = [0.0; 6];
            for p in ch * CHUNK..((ch + 1) * CHUNK).min(design.npix) {
                let d = maps.d[p];
                let Some(dv) = slope(p).filter(|v| v.is_finite() && d.is_finite()) else {
                    continue;
                };
                for (a, b) in s.iter_mut().zip([1.0, dv, d, dv * dv, d * d, dv * d]) {
                    *a += b;
                }
            }
            s
        })
        .collect();
    let mut s = [0.0; 6];
    for part in &parts {
        for (a, b) in s.iter_mut().zip(part) {
            *a += b;
        }
    }
    let n = s[0];
    if n < 2.0 {
        return Err("dark-current shot noise not checked: fewer than 2 pixels fitted".into());
    }
    let (mv, md) = (s[1] / n, s[2] / n);
    let var_v = (s[3] / n - mv * mv) * n / (n - 1.0);
    let var_d = (s[4] / n - md * md) * n / (n - 1.0);
    let cov = (s[5] / n - mv * md) * n / (n - 1.0);
    let ratio = mv / md;
    let ratio_se =
        ((var_v + ratio * ratio * var_d - 2.0 * ratio * cov).max(0.0) / n).sqrt() / md.abs();
    let status = if (ratio - 1.0).abs() <= STATUS_SE * ratio_se {
        "consistent"
    } else if ratio > 1.0 {
        "excess"
    } else {
        "deficit"
    };
    Ok(ShotNoiseCheck {
        method: "per pixel, the temporal variance against G^2 F^2 t D(T)/K^2 with one intercept \
                 per EM gain (weights from each condition's median variance), the slope D_var \
                 averaged over pixels and divided by the mean of D from the mean dark over the \
                 same pixels"
            .into(),
        pixels: n as usize,
        excess_noise_factors: gains
            .iter()
            .zip(&f2)
            .map(|(&em_gain, &f)| GainNoiseFactor {
                em_gain,
                excess_noise_factor_sq: f,
            })
            .collect(),
        dark_current_from_variance_e_per_s: mv,
        dark_current_from_variance_se_e_per_s: (var_v / n).sqrt(),
        dark_current_from_mean_e_per_s: md,
        dark_current_from_mean_se_e_per_s: (var_d / n).sqrt(),
        ratio,
        ratio_se,
        status: status.into(),
    })
}
