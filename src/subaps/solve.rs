//! One sub-aperture's effective read noise: its fixed window of the measured noise map read
//! as a per-pixel readout (`scmos-fixed` with that window), solved like `effective`.

use super::geometry::Subap;
use crate::calib::{Map, Unit};
use crate::centroid::CentroiderSpec;
use crate::detector::{PerPixelSigma, Readout};
use crate::effective::{effective_sigma_with, Effective, Precision};
use crate::montecarlo::{Arm, Experiment, SimConfig};
use crate::progress::Observer;
use crate::{Error, Result};

/// A measured noise map (e-) ready to be cut into windows: non-finite pixels read with the
/// rms of the map's finite pixels, as `scmos-map` reads them.
#[derive(Debug, Clone)]
pub struct NoiseMap<'a> {
    /// The map (e-).
    pub map: &'a Map,
    /// sqrt(mean sigma^2) of the finite pixels (e-): the value of a non-finite pixel.
    pub fill_e: f64,
    /// Median of the finite pixels (e-): masking is relative to the camera's median.
    pub median_e: f64,
}

impl<'a> NoiseMap<'a> {
    /// Check that `map` is in e- and has a finite pixel; errors name its source.
    pub fn new(map: &'a Map) -> Result<Self> {
        if map.unit != Unit::Electrons {
            return Err(Error::input(
                &map.source,
                format!(
                    "noise map is in {}, not e-: give a map in electrons (e.g. rms_e.fits from \
                     darks)",
                    map.unit.bunit()
                ),
            ));
        }
        let (sum, n) = map
            .data
            .iter()
            .filter(|v| v.is_finite())
            .fold((0.0, 0usize), |(s, n), v| (s + v * v, n + 1));
        if n == 0 {
            return Err(Error::input(&map.source, "noise map has no finite pixel"));
        }
        Ok(NoiseMap {
            map,
            fill_e: (sum / n as f64).sqrt(),
            median_e: crate::stats::median(&map.data),
        })
    }

    /// The raw map values of `s`'s `n` x `n` window, row-major (non-finite ones kept).
    pub fn window(&self, s: &Subap, n: usize) -> Vec<f64> {
        let cols = self.map.cols;
        (0..n)
            .flat_map(|i| {
                let start = (s.y0_px + i) * cols + s.x0_px;
                self.map.data[start..start + n].iter().copied()
            })
            .collect()
    }

    /// The readout of `s`'s window: each pixel's own sigma, a non-finite one `fill_e`.
    pub fn readout(&self, s: &Subap, n: usize) -> PerPixelSigma {
        let sigma = self
            .window(s, n)
            .into_iter()
            .map(|v| if v.is_finite() { v } else { self.fill_e })
            .collect();
        PerPixelSigma::new(sigma, format!("subap:{}", s.index)).with_median_e(self.median_e)
    }
}

/// What the map holds in one window: the median and rms of its finite pixels (e-) and how
/// many are not finite.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct WindowStats {
    /// Median of the finite pixels (e-; NaN when none).
    pub median_e: f64,
    /// sqrt(mean sigma^2) of the finite pixels (e-; NaN when none).
    pub rms_e: f64,
    /// Non-finite pixels (read with the map's rms).
    pub nonfinite_px: usize,
}

impl WindowStats {
    /// The statistics of `values` (one window).
    pub fn of(values: &[f64]) -> WindowStats {
        let finite: Vec<f64> = values.iter().copied().filter(|v| v.is_finite()).collect();
        let rms = if finite.is_empty() {
            f64::NAN
        } else {
            (finite.iter().map(|v| v * v).sum::<f64>() / finite.len() as f64).sqrt()
        };
        WindowStats {
            median_e: crate::stats::median(&finite),
            rms_e: rms,
            nonfinite_px: values.len() - finite.len(),
        }
    }
}

/// The effective read noise of sub-aperture `s`: its window of `map` read as a fixed
/// per-pixel readout, solved in configuration `cfg` (its `subap_px` the window's side) to
/// `precision`, read through `centroider`, exactly as [`effective_sigma_with`] solves any
/// detector.
pub fn solve_subap(
    cfg: &SimConfig,
    map: &NoiseMap,
    s: &Subap,
    centroider: CentroiderSpec,
    precision: &Precision,
    observer: &dyn Observer,
) -> Result<Effective> {
    let detector = map.readout(s, cfg.subap_px);
    effective_sigma_with(cfg, &detector, centroider, precision, observer)
}

/// Check that `centroider` can read the windows of configuration `cfg` (e.g. brightest-n's N
/// below the window's pixels) by building it as each solve does, for `readout` (a window of
/// the map, or any window of its size when the map is not read yet), before any work.
pub fn check_centroider(
    cfg: &SimConfig,
    centroider: CentroiderSpec,
    readout: &dyn Readout,
) -> Result<()> {
    Experiment::with_arms(
        cfg,
        &[readout],
        &[Arm {
            model: 0,
            centroider,
        }],
    )
    .map(|_| ())
}
