//! The per-sub-aperture maps of the error's parts: the static offset as a vector map
//! (`static_x_px.fits`, `static_y_px.fits`) and the random part's effective sigma
//! (`sigma_random_e.fits`), each sub-aperture's from its [`EffectiveParts`]. A real
//! sub-aperture reads the same pixels every frame, so its noisy pixels bias its centroid the
//! same way every frame: the offset a loop's reference slopes remove when taken with the camera
//! at the operating flux, and keep otherwise.
//!
//! Wiring (for the job's writer, [`super::outputs::write_outputs`]): each record carries the
//! [`crate::effective::Effective::parts`] of its solve, and the writer calls [`write_maps`]
//! with the cells and its FITS keys.

use crate::effective::EffectiveParts;
use crate::io::fits::{key, write_image, ImageData, KeyValue, Keyword};
use crate::Result;
use std::path::{Path, PathBuf};

/// The files [`write_maps`] writes (in an output directory).
pub const STATIC_MAP_NAMES: [&str; 3] = [
    "static_x_px.fits",
    "static_y_px.fits",
    "sigma_random_e.fits",
];

/// Write [`STATIC_MAP_NAMES`] into `dir` for a grid of `shape` (rows, columns) from `cells`
/// ((grid row, grid column, parts) per sub-aperture; NaN elsewhere), each image with `keys`
/// and its BUNIT (pixel for the offsets, electron for the sigma); the paths written.
pub fn write_maps(
    dir: &Path,
    (rows, cols): (usize, usize),
    cells: &[(usize, usize, EffectiveParts)],
    keys: &[Keyword],
) -> Result<Vec<PathBuf>> {
    let image = |f: fn(&EffectiveParts) -> f64| {
        let mut v = vec![f64::NAN; rows * cols];
        for (r, c, p) in cells {
            v[r * cols + c] = f(p);
        }
        v
    };
    let maps: [(Vec<f64>, &str, &str); 3] = [
        (
            image(|p| p.static_x_px),
            "pixel",
            "static centroid offset along x (mean error, estimate - truth)",
        ),
        (
            image(|p| p.static_y_px),
            "pixel",
            "static centroid offset along y (mean error, estimate - truth)",
        ),
        (
            image(|p| p.sigma_random_e),
            "electron",
            "constant read noise reproducing the random (frame-to-frame) error",
        ),
    ];
    let mut written = Vec::new();
    for ((data, unit, what), name) in maps.iter().zip(STATIC_MAP_NAMES) {
        let mut k = keys.to_vec();
        k.push(key(
            "CONTENT",
            KeyValue::Str((*what).into()),
            "what the pixels hold",
        ));
        let path = dir.join(name);
        write_image(&path, (rows, cols), ImageData::F64(data), unit, &k)?;
        written.push(path);
    }
    Ok(written)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn maps_hold_each_sub_aperture_s_parts_with_their_units() {
        let dir = tempfile::tempdir().unwrap();
        let parts = EffectiveParts {
            static_x_px: 0.25,
            static_y_px: -0.5,
            sigma_random_e: 1.5,
            ..EffectiveParts::default()
        };
        let written = write_maps(dir.path(), (2, 3), &[(1, 2, parts)], &[]).unwrap();
        assert_eq!(written.len(), 3);
        for (path, want, unit) in [
            (&written[0], 0.25, "pixel"),
            (&written[1], -0.5, "pixel"),
            (&written[2], 1.5, "electron"),
        ] {
            let image = crate::io::read_image(path).unwrap();
            assert_eq!(image.bunit.as_deref(), Some(unit));
            assert_eq!(image.shape, (2, 3));
            let data = &image.data;
            assert_eq!(data[5], want);
            assert!(data[..5].iter().all(|v| v.is_nan()));
        }
    }
}
