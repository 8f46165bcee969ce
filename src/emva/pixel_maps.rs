//! What the standard does not give: the system gain and the dark current of every pixel, with
//! their standard errors, from the same pairs as the datasheet (a second pass over the points
//! the sensitivity fit uses, and over every dark pair).
//!
//! A pixel's photon-transfer point is its signal (bright less dark pair mean) and its temporal
//! variance from the pair differences, each corrected for the frames' mean drift (one degree of
//! freedom per pair); its K is the fit through the origin over the datasheet's sensitivity
//! range. A pixel's dark current is the slope of its dark pair mean with exposure time. SEs are
//! the pixel's own (from the datasheet's variances), without the global K's error.

use serde::Serialize;

use super::dataset::EmvaDataset;
use super::pairs::{frame_shape, read_pair, PointStats};
use super::temporal::TemporalResult;
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
    /// Dark current per pixel (e-/s; NaN with fewer than 2 exposure times).
    pub dark_current_e_per_s: Vec<f64>,
    /// Its standard error (e-/s).
    pub dark_current_se_e_per_s: Vec<f64>,
}

/// Running per-pixel sums of the maps: O(pixels) memory whatever the number of points.
#[derive(Clone, Debug)]
pub struct MapAccumulator {
    xy: Vec<f64>,
    xx: Vec<f64>,
    xxv: Vec<f64>,
    dark_m: Vec<f64>,
    dark_tm: Vec<f64>,
    exposures: Vec<f64>,
    dark_mean_var: Vec<f64>,
}

impl MapAccumulator {
    /// Empty sums for frames of `pixels` pixels.
    pub fn new(pixels: usize) -> Self {
        MapAccumulator {
            xy: vec![0.0; pixels],
            xx: vec![0.0; pixels],
            xxv: vec![0.0; pixels],
            dark_m: vec![0.0; pixels],
            dark_tm: vec![0.0; pixels],
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
            // One pair's variance estimate is sigma^2 chi^2_1: variance 2 sigma^4.
            let v = 2.0 * (k * x + s2_dark).powi(2) + 2.0 * s2_dark * s2_dark;
            self.xy[j] += x * y;
            self.xx[j] += x * x;
            self.xxv[j] += x * x * v;
        }
    }

    /// Add one dark pair (`da`, `db`) to the dark-current map.
    pub fn add_dark_point(&mut self, da: &[f64], db: &[f64], stats: &PointStats) {
        let t = stats.exposure_s;
        for j in 0..self.dark_m.len() {
            let m = (da[j] + db[j]) / 2.0;
            self.dark_m[j] += m;
            self.dark_tm[j] += t * m;
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
        let gain_se_dn_per_e = self
            .xxv
            .iter()
            .zip(&self.xx)
            .map(|(v, xx)| v.sqrt() / xx)
            .collect();
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
        let usable = stt > 0.0;
        let dark_current_e_per_s = self
            .dark_tm
            .iter()
            .zip(&self.dark_m)
            .map(|(stm, sm)| {
                if usable {
                    (stm - tm * sm) / stt / k
                } else {
                    f64::NAN
                }
            })
            .collect();
        let se = if usable { slope_se / k } else { f64::NAN };
        PixelMaps {
            shape,
            gain_dn_per_e,
            gain_se_dn_per_e,
            dark_current_e_per_s,
            dark_current_se_e_per_s: vec![se; self.dark_m.len()],
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
