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

use rayon::prelude::*;
use serde::Serialize;

use super::dataset::EmvaDataset;
use super::pairs::{frame_shape, read_pair_data, PairBuffers, PointStats, CHUNK};
use super::temporal::{TemporalResult, MIN_DARK_EXPOSURES, QUANTISATION_VARIANCE_DN2};
use crate::error::Result;
use crate::io::FrameData;

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
    /// [`FIELDS`] sums per pixel, stored a block of [`CHUNK`] pixels at a time, field after
    /// field (so that each field of a block is contiguous and the loops vectorise).
    sums: Vec<f64>,
    pixels: usize,
    exposures: Vec<f64>,
    dark_mean_var: Vec<f64>,
}

/// Sums per pixel, in this order: the gain fit's weighted x y and x x, and its dark pairs'
/// means, means times exposure and halved squared differences.
const FIELDS: usize = 5;

/// What one point adds to every pixel, apart from the pixel's own values.
#[derive(Clone, Copy, Debug)]
struct PointTerms {
    exposure_s: f64,
    drift: f64,
    dark_drift: f64,
    s2_dark: f64,
    k: f64,
}

impl MapAccumulator {
    /// Empty sums for frames of `pixels` pixels.
    pub fn new(pixels: usize) -> Self {
        MapAccumulator {
            sums: vec![0.0; pixels.div_ceil(CHUNK) * FIELDS * CHUNK],
            pixels,
            exposures: Vec::new(),
            dark_mean_var: Vec::new(),
        }
    }

    /// Add one point: its dark pair to the dark-current map and, when the point is in the
    /// sensitivity range, its `bright` pair to the gain map; `stats` is the point reduced, `k`
    /// the datasheet's gain (DN/e-, for the gain fit's weights). Frames as read (stored bytes
    /// or values), blocks of pixels in parallel: every pixel's sums run over the points in
    /// their order, whatever the number of threads.
    pub fn add_point(
        &mut self,
        dark: [&FrameData; 2],
        bright: Option<[&FrameData; 2]>,
        stats: &PointStats,
        k: f64,
    ) {
        let terms = PointTerms {
            exposure_s: stats.exposure_s,
            drift: stats.bright.drift_dn,
            dark_drift: stats.dark.drift_dn,
            s2_dark: stats.dark.variance_dn2,
            k,
        };
        let n = self.pixels;
        self.sums
            .par_chunks_mut(FIELDS * CHUNK)
            .enumerate()
            .for_each(|(block, sums)| {
                let from = block * CHUNK;
                add_block(sums, dark, bright, &terms, from, (from + CHUNK).min(n));
            });
        self.exposures.push(stats.exposure_s);
        self.dark_mean_var.push(stats.dark.variance_dn2 / 2.0);
    }

    /// The maps of `shape`, the dark current converted to e- with the datasheet's `k`.
    pub fn finish(self, shape: (usize, usize), k: f64) -> PixelMaps {
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
        // Each map pixel by pixel, in parallel (every pixel's value is its own).
        let map = |f: &(dyn Fn(usize) -> f64 + Sync)| -> Vec<f64> {
            (0..self.pixels).into_par_iter().map(f).collect()
        };
        let gain_dn_per_e = map(&|j| self.at(0, j) / self.at(1, j));
        let gain_se_dn_per_e = map(&|j| 1.0 / self.at(1, j).sqrt());
        // Dark signal slope per pixel (DN/s), 0 when not measured (nothing is subtracted).
        let slope_dn = map(&|j| match usable {
            true => (self.at(3, j) - tm * self.at(2, j)) / stt,
            false => 0.0,
        });
        let dark_current_e_per_s = map(&|j| if usable { slope_dn[j] / k } else { f64::NAN });
        let se = if usable { slope_se / k } else { f64::NAN };
        // The dark current's shot noise at the mean exposure is K^2 D t = K slope t (DN^2).
        let (noise, noise_se): (Vec<f64>, Vec<f64>) = (0..self.pixels)
            .into_par_iter()
            .map(|j| {
                let raw = self.at(4, j) / n;
                let shot_se = if usable { k * tm * slope_se } else { 0.0 };
                let var = (raw - k * slope_dn[j] * tm - QUANTISATION_VARIANCE_DN2).max(0.0);
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
            dark_current_se_e_per_s: vec![se; self.pixels],
            dark_noise_e: noise,
            dark_noise_se_e: noise_se,
            has_dark_current: usable,
        }
    }

    /// Sum `field` (0..FIELDS, in [`FIELDS`]' order) of pixel `j`.
    fn at(&self, field: usize, j: usize) -> f64 {
        self.sums[(j / CHUNK * FIELDS + field) * CHUNK + j % CHUNK]
    }
}

crate::io::widest! {
    /// Add a point's pixels `from..to` to their block of sums (see [`MapAccumulator`]).
    fn add_block(
        sums: &mut [f64],
        dark: [&FrameData; 2],
        bright: Option<[&FrameData; 2]>,
        p: &PointTerms,
        from: usize,
        to: usize,
    ) {
        let len = to - from;
        let mut fields = sums.chunks_exact_mut(CHUNK).map(|f| &mut f[..len]);
        let mut next = || fields.next().expect("FIELDS fields");
        let (xy, xx, m, tm, v) = (next(), next(), next(), next(), next());
        let mut bufs = [[0.0; CHUNK]; 4];
        let [ba, bb, bda, bdb] = &mut bufs;
        let (da, db) = (dark[0].block(from, to, bda), dark[1].block(from, to, bdb));
        for j in 0..len {
            let mean = (da[j] + db[j]) / 2.0;
            let d = da[j] - db[j] - p.dark_drift;
            m[j] += mean;
            tm[j] += p.exposure_s * mean;
            v[j] += d * d / 2.0;
        }
        let Some([a, b]) = bright else {
            return;
        };
        let (a, b) = (a.block(from, to, ba), b.block(from, to, bb));
        for j in 0..len {
            let x = (a[j] + b[j] - da[j] - db[j]) / 2.0;
            let d = a[j] - b[j] - p.drift;
            let dd = da[j] - db[j] - p.dark_drift;
            let y = (d * d - dd * dd) / 2.0;
            // One pair's variance estimate is sigma^2 chi^2_1: variance 2 sigma^4. Weighted by
            // its inverse (from the datasheet's K, not the pixel's own noisy values), every
            // point counts about equally and the pixel's K is as precise as it can be.
            let w = 2.0 * (p.k * x + p.s2_dark).powi(2) + 2.0 * p.s2_dark * p.s2_dark;
            xy[j] += x * y / w;
            xx[j] += x * x / w;
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
    let [_, last] = result.sensitivity_fit;
    let points = &dataset.points;
    let read = |i: usize, buf: &mut PointBuffers| -> Result<()> {
        read_pair_data(&points[i].dark, shape, &mut buf.dark)?;
        if i <= last {
            read_pair_data(&points[i].bright, shape, &mut buf.bright)?;
        }
        Ok(())
    };
    // The next point is read while this one is added.
    let (mut this, mut next) = (PointBuffers::default(), PointBuffers::default());
    read(0, &mut this)?;
    for (i, s) in stats.iter().enumerate().take(points.len()) {
        let (read_next, ()) = rayon::join(
            || match i + 1 < points.len() {
                true => read(i + 1, &mut next),
                false => Ok(()),
            },
            || {
                let bright = (i <= last).then(|| this.bright.frames());
                acc.add_point(this.dark.frames(), bright, s, k)
            },
        );
        read_next?;
        std::mem::swap(&mut this, &mut next);
    }
    Ok(acc.finish(shape, k))
}

/// One point's dark and bright pairs as read.
#[derive(Debug, Default)]
struct PointBuffers {
    dark: PairBuffers,
    bright: PairBuffers,
}

#[cfg(test)]
mod tests;
