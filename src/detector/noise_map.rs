//! A measured per-pixel read-noise map, the input of the `scmos-map` readout.

/// A measured per-pixel read-noise map (e-), row-major.
#[derive(Debug, Clone)]
pub struct NoiseMap {
    /// Rows of the map.
    pub rows: usize,
    /// Columns of the map.
    pub cols: usize,
    /// rms read noise per pixel (e-), row-major; non-finite values mark excluded pixels.
    pub rms_e: Vec<f64>,
    /// Where the map came from (file name), for labels.
    pub source: String,
}
