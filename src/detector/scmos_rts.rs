//! `scmos-rts`: the measured noise map plus the measured telegraph (RTS) pixels.

use std::sync::Arc;

use super::readout::{FrameInput, Readout};
use super::rts_table::RtsTable;
use super::telegraph::TelegraphPixels;
use super::scmos_map::ScmosMap;
use super::spec::{ModelEntry, ModelSpec, Sensor};
use crate::calib::Map;
use crate::rng::SimRng;
use crate::{Error, Result};

/// The registry entry of `scmos-rts`.
pub const ENTRY: ModelEntry = ModelEntry {
    name: "scmos-rts",
    arg: None,
    help: "scmos-map plus the measured telegraph pixels: each frame an RTS pixel takes a level by \
           its occupancy, plus that level's Gaussian width, instead of the map's sigma",
    sensor: Sensor::Scmos,
    params: &["map", "rts_table"],
    parse: ModelSpec::registered,
    build: |_, p, subap_px| {
        let map = p.map.clone().ok_or_else(|| {
            Error::invalid(
                "map",
                "scmos-rts needs the measured noise map the RTS pixels belong to: give `map` FILE",
            )
        })?;
        let table = p.rts_table.as_deref().ok_or_else(|| {
            Error::invalid(
                "rts_table",
                "scmos-rts needs the telegraph pixels: give `rts_table` FILE (rts.csv from darks)",
            )
        })?;
        Ok(Box::new(ScmosRts::new(map, table, subap_px)?))
    },
};

/// `scmos-rts`: each frame reads through a random window of the measured map (as `scmos-map`),
/// except at the telegraph pixels of `darks`' table: there the pixel takes level k with
/// probability occupancy_k, independently each frame (the Monte-Carlo's frames are
/// independent, so the dwell times do not enter), and adds the level plus its Gaussian width
/// times the frame's normal deviate. It replaces the map's sigma there rather than adding to
/// it: the map's rms at an RTS pixel already contains the telegraph variance
/// (sum_k occupancy_k (level_k^2 + width_k^2) about the pixel's offset).
#[derive(Debug, Clone)]
pub struct ScmosRts {
    map: ScmosMap,
    n: usize,
    telegraph: TelegraphPixels,
}

impl ScmosRts {
    /// Windows of `n` x `n` pixels of `map` (in e-) with the `ok` telegraph pixels of `table`;
    /// a pixel of the table outside the map is an error naming the table and its line.
    pub fn new(map: Arc<Map>, table: &RtsTable, n: usize) -> Result<Self> {
        let (rows, cols) = (map.rows, map.cols);
        let map_source = map.source.clone();
        let map = ScmosMap::new(map, n)?;
        let frame = format!("noise map {map_source}");
        let telegraph = TelegraphPixels::new(table, rows, cols, &frame)?;
        Ok(ScmosRts { map, n, telegraph })
    }

    /// Number of telegraph pixels simulated.
    pub fn rts_pixels(&self) -> usize {
        self.telegraph.len()
    }
}

impl Readout for ScmosRts {
    fn name(&self) -> String {
        "scmos-rts".into()
    }

    fn read(&self, input: &FrameInput, aux: &mut SimRng, out: &mut [f64]) {
        self.read_at(input, aux, out);
    }

    fn read_known(&self, input: &FrameInput, aux: &mut SimRng, out: &mut [f64], sigma_e: &mut [f64]) {
        // The measured map already holds each telegraph pixel's total rms.
        let at = self.read_at(input, aux, out);
        self.map.window_sigma(at, sigma_e);
    }

    fn median_sigma_e(&self) -> f64 {
        self.map.median_sigma_e()
    }

    fn noise_scale_e(&self) -> f64 {
        // The map's rms, telegraph variance included.
        self.map.noise_scale_e()
    }
}

impl ScmosRts {
    /// Read one frame (see [`Readout::read`]); the window's top-left (row, column) in the map.
    fn read_at(&self, input: &FrameInput, aux: &mut SimRng, out: &mut [f64]) -> (usize, usize) {
        use rand::RngExt;
        let n = self.n;
        let (r0, c0) = self.map.read_window(input, aux, out);
        // Then one uniform draw per telegraph pixel of the window, in pixel order.
        for i in 0..n {
            for (c, t) in self.telegraph.in_row(r0 + i, c0, n) {
                let j = i * n + (c - c0);
                let k = t.level(aux.random::<f64>());
                out[j] = input.photo_e[j] as f64 + t.level_e[k] + t.width_e[k] * input.normals[j];
            }
        }
        (r0, c0)
    }
}

#[cfg(test)]
mod tests;
