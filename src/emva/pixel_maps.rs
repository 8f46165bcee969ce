//! What the standard does not give: the system gain and the dark current of every pixel, with
//! their standard errors, from the same pairs as the datasheet (a second pass over the points
//! the sensitivity fit uses, and over every dark pair).
//!
//! A pixel's photon-transfer point is its signal (bright less dark pair mean) and its temporal
//! variance from the pair differences, each corrected for the frames' mean drift (one degree of
//! freedom per pair); its K is the weighted fit through the origin over the datasheet's
//! sensitivity range. A pixel's dark current is the slope of its dark pair mean with exposure time. A
//! pixel's temporal dark noise is the mean of its dark pairs' drift-corrected variances, less
//! its own dark current's shot noise at their mean exposure (the noise at zero exposure, as
//! the datasheet's sigma_d) and less the quantisation variance 1/12 DN^2, over K. SEs are the
//! pixel's own (from the datasheet's variances), without the global K's error.

use serde::Serialize;

use super::dataset::EmvaDataset;
use super::pairs::{frame_shape, read_pair, PointStats};
use super::temporal::{TemporalResult, MIN_DARK_EXPOSURES, QUANTISATION_VARIANCE_DN2};
use crate::error::Result;

/// Per-pixel maps, row-major, of `shape`.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct PixelMaps {
    /// Frame shape (rows, cols).
    pub shape: (usize, usize),
    /// System gain per pixel (DN/e-).
    pub gain_dn_per_e: Vec<f64>,
    /// Its standard error (DN/e-).
    pub gain_se_dn_per_e: Vec<f64>,
    /// Dark current per pixel (e-/s; NaN with fewer than 3 exposure times).
    pub dark_current_e_per_s: Vec<f64>,
    /// Its standard error (e-/s).
    pub dark_current_se_e_per_s: Vec<f64>,
    /// Temporal dark noise per pixel at zero exposure, quantisation removed (e- rms; at the
    /// dark pairs' mean exposure when the dark current is not measured).
    pub dark_noise_e: Vec<f64>,
    /// Its standard error (e-).
    pub dark_noise_se_e: Vec<f64>,
    /// Whether the dark current map was measured (dark pairs at 3 exposure times or more).
    pub has_dark_current: bool,
}

/// Running per-pixel sums of the maps: O(pixels) memory whatever the number of points.
#[derive(Clone, Debug)]
pub struct MapAccumulator {
    xy: Vec<f64>,
    xx: Vec<f64>,
    dark_m: Vec<f64>,
    dark_tm: Vec<f64>,
    dark_v: Vec<f64>,
    exposures: Vec<f64>,
    dark_mean_var: Vec<f64>,
}

impl MapAccumulator {
    /// Empty sums for frames of `pixels` pixels.
    pub fn new(pixels: usize) -> Self {
        MapAccumulator {
            xy: vec![0.0; pixels],
            xx: vec![0.0; pixels],
            dark_m: vec![0.0; pixels],
            dark_tm: vec![0.0; pixels],
            dark_v: vec![0.0; pixels],
            exposures: Vec::new(),
            dark_mean_var: Vec::new(),
        }
    }

    /// Add one point of the sensitivity range to the gain map: bright frames `a`, `b`, dark
    /// frames `da`, `db`, the point's reduced `stats` and the datasheet's gain `k` (DN/e-, for
    /// the SEs).
    pub fn add_gain_point(&mut self, [a, b, da, db]: [&[f64]; 4], stats: &PointStats, k: f64) {
        let (drift, dark_drift) = (stats.bright.drift_dn, stats.dark.drift_dn);
        let s2_dark = stats.dark.variance_dn2;
        for j in 0..self.xy.len() {
            let x = (a[j] + b[j] - da[j] - db[j]) / 2.0;
            let d = a[j] - b[j] - drift;
            let dd = da[j] - db[j] - dark_drift;
            let y = (d * d - dd * dd) / 2.0;
            // One pair's variance estimate is sigma^2 chi^2_1: variance 2 sigma^4. Weighted by
            // its inverse (from the datasheet's K, not the pixel's own noisy values), every
            // point counts about equally and the pixel's K is as precise as it can be.
            let v = 2.0 * (k * x + s2_dark).powi(2) + 2.0 * s2_dark * s2_dark;
            self.xy[j] += x * y / v;
            self.xx[j] += x * x / v;
        }
    }

    /// Add one dark pair (`da`, `db`) to the dark-current map.
    pub fn add_dark_point(&mut self, da: &[f64], db: &[f64], stats: &PointStats) {
        let t = stats.exposure_s;
        let drift = stats.dark.drift_dn;
        for j in 0..self.dark_m.len() {
            let m = (da[j] + db[j]) / 2.0;
            let d = da[j] - db[j] - drift;
            self.dark_m[j] += m;
            self.dark_tm[j] += t * m;
            self.dark_v[j] += d * d / 2.0;
        }
        self.exposures.push(t);
        self.dark_mean_var.push(stats.dark.variance_dn2 / 2.0);
    }

    /// The maps of `shape`, the dark current converted to e- with the datasheet's `k`.
    pub fn finish(self, shape: (usize, usize), k: f64) -> PixelMaps {
        let gain_dn_per_e = self
            .xy
            .iter()
            .zip(&self.xx)
            .map(|(xy, xx)| xy / xx)
            .collect();
        let gain_se_dn_per_e = self.xx.iter().map(|xx| 1.0 / xx.sqrt()).collect();
        let n = self.exposures.len() as f64;
        let tm = self.exposures.iter().sum::<f64>() / n;
        let stt: f64 = self.exposures.iter().map(|t| (t - tm).powi(2)).sum();
        let slope_se = self
            .exposures
            .iter()
            .zip(&self.dark_mean_var)
            .map(|(t, v)| ((t - tm) / stt).powi(2) * v)
            .sum::<f64>()
            .sqrt();
        let mut distinct = self.exposures.clone();
        distinct.sort_by(f64::total_cmp);
        distinct.dedup();
        let usable = distinct.len() >= MIN_DARK_EXPOSURES && stt > 0.0;
        // Dark signal slope per pixel (DN/s), 0 when not measured (nothing is subtracted).
        let slope_dn: Vec<f64> = self
            .dark_tm
            .iter()
            .zip(&self.dark_m)
            .map(|(stm, sm)| if usable { (stm - tm * sm) / stt } else { 0.0 })
            .collect();
        let dark_current_e_per_s = slope_dn
            .iter()
            .map(|s| if usable { s / k } else { f64::NAN })
            .collect();
        let se = if usable { slope_se / k } else { f64::NAN };
        // The dark current's shot noise at the mean exposure is K^2 D t = K slope t (DN^2).
        let (noise, noise_se): (Vec<f64>, Vec<f64>) = self
            .dark_v
            .iter()
            .zip(&slope_dn)
            .map(|(v, s)| {
                let raw = v / n;
                let shot_se = if usable { k * tm * slope_se } else { 0.0 };
                let var = (raw - k * s * tm - QUANTISATION_VARIANCE_DN2).max(0.0);
                // Each pair's variance estimate is sigma^2 chi^2_1 (variance 2 sigma^4).
                let var_se = (2.0 * raw * raw / n + shot_se * shot_se).sqrt();
                let rms = var.sqrt();
                (rms / k, var_se / (2.0 * rms).max(var_se.sqrt()) / k)
            })
            .unzip();
        PixelMaps {
            shape,
            gain_dn_per_e,
            gain_se_dn_per_e,
            dark_current_e_per_s,
            dark_current_se_e_per_s: vec![se; self.dark_m.len()],
            dark_noise_e: noise,
            dark_noise_se_e: noise_se,
            has_dark_current: usable,
        }
    }
}

/// The per-pixel maps of `dataset`, from its reduced points `stats` and datasheet `result`
/// (a second pass: the sensitivity range's bright pairs and every dark pair, one point at a
/// time).
pub fn pixel_maps(
    dataset: &EmvaDataset,
    stats: &[PointStats],
    result: &TemporalResult,
) -> Result<PixelMaps> {
    let first = &dataset.points[0];
    let shape = frame_shape(&first.bright[0])?;
    let k = result.system_gain_dn_per_e.value;
    let mut acc = MapAccumulator::new(shape.0 * shape.1);
    let (mut a, mut b, mut da, mut db) = (Vec::new(), Vec::new(), Vec::new(), Vec::new());
    let [_, last] = result.sensitivity_fit;
    for (i, (point, s)) in dataset.points.iter().zip(stats).enumerate() {
        read_pair(&point.dark, shape, &mut da, &mut db)?;
        acc.add_dark_point(&da, &db, s);
        if i <= last {
            read_pair(&point.bright, shape, &mut a, &mut b)?;
            acc.add_gain_point([&a, &b, &da, &db], s, k);
        }
    }
    Ok(acc.finish(shape, k))
}

#[cfg(test)]
mod tests;
