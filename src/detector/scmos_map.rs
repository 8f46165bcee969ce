//! `scmos-map`: per-pixel read-noise sigmas from random windows of a measured noise map.

use std::sync::Arc;


use crate::calib::{Map, Unit};
use super::readout::{FrameInput, Readout};
use super::spec::{ModelEntry, ModelSpec, Sensor};
use crate::rng::SimRng;

/// The registry entry of `scmos-map`.
pub const ENTRY: ModelEntry = ModelEntry {
    name: "scmos-map",
    arg: None,
    help: "sCMOS with per-pixel sigmas from a random window of a measured noise map, every frame",
    sensor: Sensor::Scmos,
    params: &["map"],
    parse: |_, _| Ok(ModelSpec::ScmosMap),
    build: |_, p, subap_px| match &p.map {
        Some(map) => Ok(Box::new(ScmosMap::new(map.clone(), subap_px)?)),
        None => Err(crate::Error::invalid(
            "map",
            "scmos-map needs a measured noise map: give `map` FILE",
        )),
    },
};

/// `scmos-map`: each frame reads through an n x n window of a measured noise map at a random
/// place, so the simulation sees the camera's own spatial mix of quiet and noisy pixels.
#[derive(Debug, Clone)]
pub struct ScmosMap {
    map: Arc<Map>,
    n: usize,
    rms_e: f64,
    median_e: f64,
}

impl ScmosMap {
    /// Windows of `n` x `n` pixels of `map`; the map must be at least that large.
    pub fn new(map: Arc<Map>, n: usize) -> crate::Result<Self> {
        if map.unit != Unit::Electrons {
            return Err(crate::Error::input(
                &map.source,
                format!("noise map is in {}, not e-: convert it first", map.unit.bunit()),
            ));
        }
        if map.rows < n || map.cols < n {
            return Err(crate::Error::input(
                &map.source,
                format!(
                    "noise map is {}x{} px, smaller than the {n}x{n} px sub-aperture",
                    map.rows, map.cols
                ),
            ));
        }
        // Excluded (non-finite) pixels read as the map's median: a flagged pixel is replaced
        // the way a pipeline would interpolate it, rather than breaking the frame.
        let finite: Vec<f64> = map
            .data
            .iter()
            .copied()
            .filter(|v| v.is_finite())
            .collect();
        if finite.is_empty() {
            return Err(crate::Error::input(
                &map.source,
                "noise map has no finite pixel",
            ));
        }
        let rms_e = (finite.iter().map(|v| v * v).sum::<f64>() / finite.len() as f64).sqrt();
        let median_e = crate::stats::median(&finite);
        Ok(ScmosMap {
            map,
            n,
            rms_e,
            median_e,
        })
    }
}

impl ScmosMap {
    /// Read `input` through a window of the map at a random place (two draws from `aux`):
    /// photo-electrons plus sigma x normal per pixel, into `out` (e-). Returns the window's
    /// top-left (row, column) in the map, for the models that add to the map's noise.
    pub(super) fn read_window(
        &self,
        input: &FrameInput,
        aux: &mut SimRng,
        out: &mut [f64],
    ) -> (usize, usize) {
        use rand::RngExt;
        let n = self.n;
        let r0 = aux.random_range(0..=self.map.rows - n);
        let c0 = aux.random_range(0..=self.map.cols - n);
        for (i, ((orow, krow), zrow)) in out
            .chunks_exact_mut(n)
            .zip(input.photo_e.chunks_exact(n))
            .zip(input.normals.chunks_exact(n))
            .enumerate()
        {
            let mrow = &self.map.data[(r0 + i) * self.map.cols + c0..][..n];
            for (((o, &k), &s), &z) in orow.iter_mut().zip(krow).zip(mrow).zip(zrow) {
                let s = if s.is_finite() { s } else { self.rms_e };
                *o = k as f64 + s * z;
            }
        }
        (r0, c0)
    }

    /// The sigmas (e-) of the window at (`r0`, `c0`) into `sigma_e`, excluded pixels as the
    /// map's rms (as [`Self::read_window`] reads them).
    pub(super) fn window_sigma(&self, (r0, c0): (usize, usize), sigma_e: &mut [f64]) {
        let n = self.n;
        for (i, srow) in sigma_e.chunks_exact_mut(n).enumerate() {
            let mrow = &self.map.data[(r0 + i) * self.map.cols + c0..][..n];
            for (s, &m) in srow.iter_mut().zip(mrow) {
                *s = if m.is_finite() { m } else { self.rms_e };
            }
        }
    }
}

impl Readout for ScmosMap {
    fn name(&self) -> String {
        "scmos-map".into()
    }

    fn read(&self, input: &FrameInput, aux: &mut SimRng, out: &mut [f64]) {
        self.read_window(input, aux, out);
    }

    fn noise_scale_e(&self) -> f64 {
        self.rms_e
    }

    fn read_known(&self, input: &FrameInput, aux: &mut SimRng, out: &mut [f64], sigma_e: &mut [f64]) {
        let at = self.read_window(input, aux, out);
        self.window_sigma(at, sigma_e);
    }

    fn median_sigma_e(&self) -> f64 {
        self.median_e
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::detector::readout::sampling::dark_samples;
    use crate::stats::mean_var;

    #[test]
    fn map_windows_cover_the_map_and_reproduce_its_noise_power() {
        // A 3x4 map with two noise levels; 2x2 windows. Zero light: output variance over
        // many frames = mean of sigma^2 over the window positions' pixels.
        let map = Map::new(3, 4, vec![1.0, 1.0, 3.0, 3.0, 1.0, 1.0, 3.0, 3.0, 1.0, 1.0, 3.0, 3.0], Unit::Electrons).with_source("t");
        let m = ScmosMap::new(Arc::new(map), 2).unwrap();
        let n = 100_000;
        let left = dark_samples(&m, 2, n, 8).remove(0);
        // Top-left pixel of a window sits in column 0, 1 or 2: sigma^2 = 1, 1, 9 equally often.
        let (_, v) = mean_var(&left);
        let expect = (1.0 + 1.0 + 9.0) / 3.0;
        // Mixture variance SE from its 4th moment: E[x^4] = 3 E[s^4] = 3 (1 + 1 + 81)/3.
        let se = ((83.0 - expect * expect) / n as f64).sqrt();
        assert!((v - expect).abs() < 4.0 * se, "{v} vs {expect}");
        let small = Map::new(1, 8, vec![1.0; 8], Unit::Electrons).with_source("small.fits");
        let err = ScmosMap::new(Arc::new(small), 2).unwrap_err();
        assert!(err.to_string().contains("small.fits"));
    }

    #[test]
    fn excluded_pixels_read_with_the_map_rms() {
        // A 2x2 map with one NaN pixel and a 2x2 window: the NaN pixel reads with the rms of
        // the finite ones, sqrt((4 + 4 + 16) / 3) = sqrt(8); variance within 4 SE, SE = v sqrt(2/N).
        let map = Map::new(2, 2, vec![2.0, f64::NAN, 2.0, 4.0], Unit::Electrons).with_source("t");
        let m = ScmosMap::new(Arc::new(map), 2).unwrap();
        assert_eq!(m.noise_scale_e(), 8f64.sqrt());
        let n = 50_000;
        let (_, v) = mean_var(&dark_samples(&m, 2, n, 3)[1]);
        assert!((v - 8.0).abs() < 4.0 * 8.0 * (2.0 / n as f64).sqrt(), "var {v}");
        let dark = Map::new(2, 2, vec![f64::NAN; 4], Unit::Electrons).with_source("nan.fits");
        assert!(ScmosMap::new(Arc::new(dark), 2).is_err());
        // A map in adu is refused, naming its file: the readout needs electrons.
        let adu = Map::new(2, 2, vec![1.0; 4], Unit::Adu).with_source("adu.fits");
        let err = ScmosMap::new(Arc::new(adu), 2).unwrap_err();
        assert!(err.to_string().contains("adu.fits"), "{err}");
    }
}
