//! The Cramer-Rao floor of every sub-aperture of a noise map (`r_crlb_px.fits`): R_crlb (px)
//! for Poisson light read with the map's Gaussian read noise in the sub-aperture's window.
//! Analytic, so a 2048 x 2048 px map of 16 x 16 px windows takes seconds.

use super::outputs::SubapRow;
use super::part::{map_digest, PartHeader, PartRecord};
use crate::calib::{Map, Unit};
use crate::crlb::{Information, PixelNoise, SpotImages};
use crate::detector::PhotonNoise;
use crate::montecarlo::SimConfig;
use crate::spot::{Sampling, Spot};
use rayon::prelude::*;

/// The floor image's file name.
pub const FLOOR_NAME: &str = "r_crlb_px.fits";

/// R_crlb (px) of the `size` x `size` px windows of `map` whose first pixels are `origins`
/// (column, row), for configuration `cfg` (its `subap_px` is `size`); non-finite map pixels
/// read with the rms of the finite ones, as `scmos-map` reads them. None where infinite.
pub fn floor_map(map: &Map, origins: &[(usize, usize)], cfg: &SimConfig) -> Vec<Option<f64>> {
    let n = cfg.subap_px;
    let finite: Vec<f64> = map.data.iter().copied().filter(|v| v.is_finite()).collect();
    let fill = (finite.iter().map(|v| v * v).sum::<f64>() / finite.len().max(1) as f64).sqrt();
    let noise = PixelNoise::new(
        PhotonNoise::Poisson { thinning: 1.0 },
        Information::Exact,
        &[],
    );
    let images = SpotImages::new(cfg);
    origins
        .par_iter()
        .map_init(
            || vec![0.0; n * n],
            |window, &(x0, y0)| {
                for (i, row) in window.chunks_exact_mut(n).enumerate() {
                    let start = (y0 + i) * map.cols + x0;
                    for (w, &v) in row.iter_mut().zip(&map.data[start..start + n]) {
                        *w = if v.is_finite() { v } else { fill };
                    }
                }
                images.r_crlb_px(&noise, window)
            },
        )
        .collect()
}

/// The configuration a job's sub-apertures ran, from its binding.
fn job_config(h: &PartHeader) -> Option<SimConfig> {
    let b = &h.binding;
    let mut cfg = SimConfig::paper(b.grid.size_px);
    cfg.spot = Spot::parse(&b.spot).ok()?;
    cfg.sampling = Sampling::parse(&b.sampling)?;
    cfg.signal_photons = b.signal_photons;
    cfg.qe = b.qe;
    cfg.position_half_range_px = b.position_half_range_px;
    cfg.validate().ok().map(|_| cfg)
}

/// The floor image of a job (grid-shaped, NaN without a sub-aperture) and what it holds: the
/// map is read again from the header's source and must have the job's BLAKE3; when it cannot
/// be (a merge on another machine), the image is NaN and says so.
pub fn floor_image(h: &PartHeader, records: &[PartRecord]) -> (Vec<f64>, String) {
    let [gr, gc] = h.binding.grid_shape;
    let mut image = vec![f64::NAN; gr * gc];
    let map = Map::read_noise(&h.map_source, Unit::Electrons)
        .ok()
        .filter(|m| map_digest(m) == h.binding.map_blake3);
    let (Some(map), Some(cfg)) = (map, job_config(h)) else {
        let why = "Cramer-Rao floor not computed: the job's map is not at its source";
        return (image, why.into());
    };
    let origins: Vec<(usize, usize)> = records
        .iter()
        .map(|r| {
            let row = SubapRow::new(r, &h.binding);
            (row.x0_px, row.y0_px)
        })
        .collect();
    for (r, f) in records.iter().zip(floor_map(&map, &origins, &cfg)) {
        image[r.grid_row * gc + r.grid_col] = f.unwrap_or(f64::INFINITY);
    }
    // FITS string values hold 68 characters.
    let what = "Cramer-Rao floor of R (px); NaN where no sub-aperture";
    (image, what.into())
}
