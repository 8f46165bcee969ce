//! The chart of the per-sub-aperture map: sigma_eff over the detector with a labelled colour
//! bar. A small grid is a heatmap with each value printed and the cells that are not results
//! hatched with their status word; a large one an image whose grey cells hold no `ok` value.

use super::part::{PartHeader, PartRecord};
use crate::effective::Status;
use crate::plot::{Heatmap, Image, ImageGrid};
use crate::Result;
use std::path::Path;

/// Largest grid side drawn as a heatmap with printed values.
const HEATMAP_MAX_SIDE: usize = 24;

/// Draw the map of `records` (a job under `header`) to `path` (.png or .svg).
pub fn subaps_chart(header: &PartHeader, records: &[PartRecord], path: &Path) -> Result<()> {
    let b = &header.binding;
    let [gr, gc] = b.grid_shape;
    let title = format!(
        "Effective read noise per {}x{} px sub-aperture, {}, {} photons",
        b.grid.size_px, b.grid.size_px, b.spot, b.signal_photons
    );
    let colour = "σ_eff (e⁻)";
    let not_ok = records.iter().filter(|r| r.status != Status::Ok).count();
    let absent = gr * gc - records.len();
    if gr.max(gc) <= HEATMAP_MAX_SIDE {
        let mut values = vec![vec![f64::NAN; gc]; gr];
        let mut marks = vec![vec![None; gc]; gr];
        for r in records {
            let (j, i) = (r.grid_row, r.grid_col);
            if r.status == Status::Ok {
                values[j][i] = r.sigma_eff_e;
            } else {
                marks[j][i] = Some(r.status.label().replace('_', "\n"));
            }
        }
        let g = &b.grid;
        let mut h = Heatmap::new(
            title,
            "sub-aperture's first pixel, x (px)",
            "sub-aperture's first pixel, y (px)",
            (0..gc)
                .map(|c| (g.x0_px + c * g.pitch_px).to_string())
                .collect(),
            (0..gr)
                .map(|r| (g.y0_px + r * g.pitch_px).to_string())
                .collect(),
            values,
            colour,
        );
        h.marks = marks;
        h.note = format!(
            "Grey hatched: not a result (status word; {not_ok} sub-apertures). –: no \
             sub-aperture (masked or not fitting the map; {absent} cells)."
        );
        h.save(path)
    } else {
        // Row 0 of an image is drawn at the top: flip so that grid row 0 (the map's first
        // rows) is at the bottom, as in the FITS image and the heatmap.
        let mut data = vec![f64::NAN; gr * gc];
        for r in records.iter().filter(|r| r.status == Status::Ok) {
            data[(gr - 1 - r.grid_row) * gc + r.grid_col] = r.sigma_eff_e;
        }
        let image = Image {
            title: format!(
                "grey: no ok value ({not_ok} not ok, {absent} absent); grid row 0 at the bottom"
            ),
            width: gc,
            height: gr,
            data,
        };
        let mut grid = ImageGrid::new(title, vec![image], colour);
        grid.panel_px = 720;
        grid.save(path)
    }
}
