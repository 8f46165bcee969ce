//! The photon-transfer series reduced pair by pair: the mean of each pair of frames and the
//! temporal variance from their difference, corrected for the drift of the mean between the two
//! frames (EMVA 1288 release 4.0), with the standard errors the datasheet's fits need.
//!
//! Each point's four frames are read once; memory is four frames per point being read (points
//! are read in parallel, one per worker).

use std::path::{Path, PathBuf};

use rayon::prelude::*;

use super::dataset::{EmvaDataset, PairPoint};
use crate::error::{Error, Result};
use crate::io::FrameStack;

/// The mean and temporal variance of one pair of frames (A, B) of the same scene.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub struct PairStats {
    /// Mean of both frames over all pixels (DN).
    pub mean_dn: f64,
    /// Temporal standard error of that mean: sqrt(variance / (2 pixels)) (DN).
    pub mean_se_dn: f64,
    /// Mean of A minus mean of B (DN): the drift the variance is corrected for.
    pub drift_dn: f64,
    /// Temporal variance of one frame: half the variance of A - B about its own mean, i.e. the
    /// mean of (A - B)^2 / 2 less drift^2 / 2 (DN^2).
    pub variance_dn2: f64,
    /// Standard error of that variance, from the fourth moment of A - B (DN^2).
    pub variance_se_dn2: f64,
    /// Pixels per frame.
    pub pixels: usize,
}

/// One point of the series reduced: its bright and dark pairs.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct PointStats {
    /// Exposure time (s).
    pub exposure_s: f64,
    /// Mean photons per pixel of the bright pair, when the input gives it.
    pub photons_per_px: Option<f64>,
    /// The bright pair.
    pub bright: PairStats,
    /// The dark pair at the same exposure.
    pub dark: PairStats,
}

/// Mean and drift-corrected temporal variance of frames `a` and `b` (same length, at least 2
/// pixels). The drift correction of release 4.0 (subtracting half the squared difference of the
/// frame means) is the same as taking the variance of A - B about its own mean, which is how it
/// is computed here (two passes over the pixels, no cancellation).
pub fn pair_stats(a: &[f64], b: &[f64]) -> PairStats {
    assert_eq!(a.len(), b.len(), "a pair's frames differ in length");
    let n = a.len() as f64;
    let (sa, sb) = a
        .iter()
        .zip(b)
        .fold((0.0, 0.0), |(sa, sb), (x, y)| (sa + x, sb + y));
    let (mean_a, mean_b) = (sa / n, sb / n);
    let drift = mean_a - mean_b;
    let (m2, m4) = a.iter().zip(b).fold((0.0, 0.0), |(m2, m4), (x, y)| {
        let e = (x - y) - drift;
        let e2 = e * e;
        (m2 + e2, m4 + e2 * e2)
    });
    let (m2, m4) = (m2 / n, m4 / n);
    let variance = m2 / 2.0;
    PairStats {
        mean_dn: (mean_a + mean_b) / 2.0,
        mean_se_dn: (variance / (2.0 * n)).sqrt(),
        drift_dn: drift,
        variance_dn2: variance,
        variance_se_dn2: ((m4 - m2 * m2).max(0.0) / n).sqrt() / 2.0,
        pixels: a.len(),
    }
}

/// Reduce every point of `dataset`, reading each frame once (points in parallel). Fails naming
/// the file when a frame cannot be read or its shape differs from the first point's.
pub fn measure(dataset: &EmvaDataset) -> Result<Vec<PointStats>> {
    let Some(first) = dataset.points.first() else {
        return Err(Error::input(
            &dataset.source,
            "the dataset has no photon-transfer point",
        ));
    };
    let shape = frame_shape(&first.bright[0])?;
    dataset
        .points
        .par_iter()
        .map(|p| measure_point(p, shape))
        .collect()
}

/// The bright and dark pairs of one point, each frame read once.
pub fn measure_point(point: &PairPoint, shape: (usize, usize)) -> Result<PointStats> {
    let mut a = Vec::new();
    let mut b = Vec::new();
    read_pair(&point.bright, shape, &mut a, &mut b)?;
    let bright = pair_stats(&a, &b);
    read_pair(&point.dark, shape, &mut a, &mut b)?;
    let dark = pair_stats(&a, &b);
    Ok(PointStats {
        exposure_s: point.exposure_s,
        photons_per_px: point.photons_per_px,
        bright,
        dark,
    })
}

/// The frame shape (rows, cols) of the file at `path`.
pub(super) fn frame_shape(path: &Path) -> Result<(usize, usize)> {
    Ok(FrameStack::open(&[path.to_path_buf()])?.shape)
}

/// Read a pair's two frames into `a` and `b`: the first frame of each file, or frames 0 and 1
/// when both are the same file.
pub(super) fn read_pair(
    paths: &[PathBuf; 2],
    shape: (usize, usize),
    a: &mut Vec<f64>,
    b: &mut Vec<f64>,
) -> Result<()> {
    if paths[0] == paths[1] {
        let stack = open_shaped(&paths[0], shape)?;
        stack.require_frames(2, "a pair of frames from one file")?;
        let mut reader = stack.reader();
        read_next(&mut reader, &paths[0], a)?;
        return read_next(&mut reader, &paths[0], b);
    }
    for (path, out) in paths.iter().zip([a, b]) {
        let stack = open_shaped(path, shape)?;
        read_next(&mut stack.reader(), path, out)?;
    }
    Ok(())
}

fn open_shaped(path: &Path, shape: (usize, usize)) -> Result<FrameStack> {
    let stack = FrameStack::open(&[path.to_path_buf()])?;
    if stack.shape != shape {
        return Err(Error::input(
            path,
            format!(
                "frames of {}x{} px (rows x cols), the dataset's first frame has {}x{}",
                stack.shape.0, stack.shape.1, shape.0, shape.1
            ),
        ));
    }
    Ok(stack)
}

fn read_next(
    reader: &mut crate::io::StackReader<'_>,
    path: &Path,
    out: &mut Vec<f64>,
) -> Result<()> {
    out.resize(reader.stack().pixels(), 0.0);
    match reader.next_frame(out)? {
        Some(_) => Ok(()),
        None => Err(Error::input(path, "frame 0: the file holds no frame")),
    }
}
