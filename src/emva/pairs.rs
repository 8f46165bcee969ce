//! The photon-transfer series reduced pair by pair: the mean of each pair of frames and the
//! temporal variance from their difference, corrected for the drift of the mean between the two
//! frames (EMVA 1288 release 4.0), with the standard errors the datasheet's fits need.
//!
//! Each point's four frames are read once; memory is two frames' stored bytes per worker
//! (points are read in parallel, one per worker; the buffers are reused from point to point, so
//! no frame-sized allocation is faulted in per point). Stored integer frames are decoded a few
//! thousand pixels at a time as they are summed, never into whole frames of f64.

use std::path::{Path, PathBuf};

use rayon::prelude::*;

use super::dataset::{EmvaDataset, PairPoint};
use crate::error::{Error, Result};
use crate::io::{FrameData, FrameStack};

/// Pixels decoded at a time from stored bytes (two such blocks of f64 stay in L1).
pub(super) const CHUNK: usize = 2048;

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
    stats_of(a, b, a.len())
}

crate::io::widest! {
    /// [`pair_stats`] of two frames as read (stored bytes or values), with the same result
    /// bit for bit: the same sums in the same order, over blocks of [`CHUNK`] decoded pixels.
    fn pair_stats_data(a: &FrameData, b: &FrameData) -> PairStats {
        let n = a.pixels();
        assert_eq!(n, b.pixels(), "a pair's frames differ in length");
        stats_of(a, b, n)
    }
}

/// A frame handed out a block of pixels at a time.
trait Blocks {
    /// Pixels `start..end` (decoded into `buf` where stored as bytes).
    fn block<'a>(&'a self, start: usize, end: usize, buf: &'a mut [f64; CHUNK]) -> &'a [f64];
}

impl Blocks for [f64] {
    #[inline(always)]
    fn block<'a>(&'a self, start: usize, end: usize, _: &'a mut [f64; CHUNK]) -> &'a [f64] {
        &self[start..end]
    }
}

impl Blocks for FrameData {
    #[inline(always)]
    fn block<'a>(&'a self, start: usize, end: usize, buf: &'a mut [f64; CHUNK]) -> &'a [f64] {
        FrameData::block(self, start, end, buf)
    }
}

/// Running sums in [`LANES`] lanes, pixel i into lane i mod LANES (blocks start at multiples
/// of LANES), added up lane by lane at the end: a fixed order whatever the blocks, with
/// LANES independent additions per step instead of one chain (the chain's latency bound the
/// pass), and exact for integer values whose sums stay below 2^53.
const LANES: usize = 8;

/// Add the values of frames `a` and `b` to their lanes.
#[inline(always)]
fn add_values(sa: &mut [f64; LANES], sb: &mut [f64; LANES], a: &[f64], b: &[f64]) {
    let (mut ca, mut cb) = (a.chunks_exact(LANES), b.chunks_exact(LANES));
    for (xa, xb) in (&mut ca).zip(&mut cb) {
        for k in 0..LANES {
            sa[k] += xa[k];
            sb[k] += xb[k];
        }
    }
    for (k, (x, y)) in ca.remainder().iter().zip(cb.remainder()).enumerate() {
        sa[k] += x;
        sb[k] += y;
    }
}

/// Add e^2 and e^4, e = a - b - `drift`, to their lanes.
#[inline(always)]
fn add_moments(m2: &mut [f64; LANES], m4: &mut [f64; LANES], a: &[f64], b: &[f64], drift: f64) {
    let (mut ca, mut cb) = (a.chunks_exact(LANES), b.chunks_exact(LANES));
    for (xa, xb) in (&mut ca).zip(&mut cb) {
        for k in 0..LANES {
            let e = (xa[k] - xb[k]) - drift;
            m2[k] += e * e;
            m4[k] += e * e * (e * e);
        }
    }
    for (k, (x, y)) in ca.remainder().iter().zip(cb.remainder()).enumerate() {
        let e = (x - y) - drift;
        m2[k] += e * e;
        m4[k] += e * e * (e * e);
    }
}

/// The statistics of a pair of `n` pixels (see [`PairStats`]).
#[inline(always)]
fn stats_of<F: Blocks + ?Sized>(fa: &F, fb: &F, n: usize) -> PairStats {
    let (mut ba, mut bb) = ([0.0; CHUNK], [0.0; CHUNK]);
    let (mut sa, mut sb) = ([0.0; LANES], [0.0; LANES]);
    for start in (0..n).step_by(CHUNK) {
        let end = (start + CHUNK).min(n);
        let (a, b) = (fa.block(start, end, &mut ba), fb.block(start, end, &mut bb));
        add_values(&mut sa, &mut sb, a, b);
    }
    let nf = n as f64;
    let (mean_a, mean_b) = (sa.iter().sum::<f64>() / nf, sb.iter().sum::<f64>() / nf);
    let drift = mean_a - mean_b;
    let (mut m2, mut m4) = ([0.0; LANES], [0.0; LANES]);
    for start in (0..n).step_by(CHUNK) {
        let end = (start + CHUNK).min(n);
        let (a, b) = (fa.block(start, end, &mut ba), fb.block(start, end, &mut bb));
        add_moments(&mut m2, &mut m4, a, b, drift);
    }
    let (m2, m4) = (m2.iter().sum::<f64>() / nf, m4.iter().sum::<f64>() / nf);
    let variance = m2 / 2.0;
    PairStats {
        mean_dn: (mean_a + mean_b) / 2.0,
        mean_se_dn: (variance / (2.0 * nf)).sqrt(),
        drift_dn: drift,
        variance_dn2: variance,
        variance_se_dn2: ((m4 - m2 * m2).max(0.0) / nf).sqrt() / 2.0,
        pixels: n,
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
        .map_init(PairBuffers::default, |buf, p| measure_point(p, shape, buf))
        .collect()
}

/// A worker's two frames as read (stored bytes or values), reused from pair to pair.
#[derive(Debug)]
pub struct PairBuffers([FrameData; 2]);

impl PairBuffers {
    /// The pair's two frames as last read.
    pub fn frames(&self) -> [&FrameData; 2] {
        [&self.0[0], &self.0[1]]
    }
}

impl Default for PairBuffers {
    fn default() -> Self {
        PairBuffers([FrameData::Values(Vec::new()), FrameData::Values(Vec::new())])
    }
}

/// The bright and dark pairs of one point, each frame read once into `buf`.
pub fn measure_point(
    point: &PairPoint,
    shape: (usize, usize),
    buf: &mut PairBuffers,
) -> Result<PointStats> {
    read_pair_data(&point.bright, shape, buf)?;
    let bright = pair_stats_data(&buf.0[0], &buf.0[1]);
    read_pair_data(&point.dark, shape, buf)?;
    let dark = pair_stats_data(&buf.0[0], &buf.0[1]);
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

/// Read a pair's two frames into `buf`, as stored bytes where the files allow it: the first
/// frame of each file, or frames 0 and 1 when both are the same file.
pub(super) fn read_pair_data(
    paths: &[PathBuf; 2],
    shape: (usize, usize),
    buf: &mut PairBuffers,
) -> Result<()> {
    let [a, b] = &mut buf.0;
    if paths[0] == paths[1] {
        let stack = open_shaped(&paths[0], shape)?;
        stack.require_frames(2, "a pair of frames from one file")?;
        let mut reader = stack.reader();
        next_data(&mut reader, &paths[0], a)?;
        return next_data(&mut reader, &paths[0], b);
    }
    for (path, out) in paths.iter().zip([a, b]) {
        let stack = open_shaped(path, shape)?;
        next_data(&mut stack.reader(), path, out)?;
    }
    Ok(())
}

fn next_data(
    reader: &mut crate::io::StackReader<'_>,
    path: &Path,
    out: &mut FrameData,
) -> Result<()> {
    match reader.next_frame_data(out)? {
        Some(_) => Ok(()),
        None => Err(Error::input(path, "frame 0: the file holds no frame")),
    }
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::io::fits::write_cube;

    /// `frames` uint16 frames of `shape`, numbered from `first`, written as one FITS cube at
    /// `path` (values from a hash of pixel and number, above 32,767 so that BZERO matters);
    /// returns them.
    fn write_u16(path: &Path, shape: (usize, usize), first: usize, frames: usize) -> Vec<Vec<f64>> {
        let n = shape.0 * shape.1;
        let all: Vec<Vec<f64>> = (first..first + frames)
            .map(|k| {
                (0..n)
                    .map(|i| {
                        let h =
                            ((i * 7919 + k * 104_729) as u64).wrapping_mul(0x9e37_79b9_7f4a_7c15);
                        (40_000 + (h >> 52)) as f64
                    })
                    .collect()
            })
            .collect();
        let mut next = all.iter().cloned();
        write_cube(path, shape, frames, true, &mut || next.next().unwrap(), &[]).unwrap();
        all
    }

    #[test]
    fn stored_integer_pairs_give_the_same_bits_as_their_values() {
        let dir = tempfile::tempdir().unwrap();
        // 2,501 pixels: more than one block of CHUNK pixels, and a remainder of the lanes.
        let shape = (41, 61);
        let files: Vec<PathBuf> = (0..4)
            .map(|k| dir.path().join(format!("f{k}.fits")))
            .collect();
        let frames: Vec<Vec<f64>> = files
            .iter()
            .enumerate()
            .map(|(k, f)| write_u16(f, shape, k, 1).remove(0))
            .collect();
        let point = PairPoint {
            exposure_s: 1.0,
            photons_per_px: None,
            bright: [files[0].clone(), files[1].clone()],
            dark: [files[2].clone(), files[3].clone()],
        };
        let mut buf = PairBuffers::default();
        let got = measure_point(&point, shape, &mut buf).unwrap();
        assert!(
            matches!(buf.0[0], FrameData::Raw(..)),
            "read as stored bytes"
        );
        assert_eq!(got.bright, pair_stats(&frames[0], &frames[1]));
        assert_eq!(got.dark, pair_stats(&frames[2], &frames[3]));
        assert!(got.bright.variance_dn2 > 0.0 && got.bright.drift_dn != 0.0);
        // A pair from one two-frame file, into the same (reused) buffers.
        let cube = dir.path().join("pair.fits");
        let two = write_u16(&cube, shape, 4, 2);
        let point = PairPoint {
            bright: [cube.clone(), cube.clone()],
            dark: [cube.clone(), cube],
            ..point
        };
        let got = measure_point(&point, shape, &mut buf).unwrap();
        assert_eq!(got.bright, pair_stats(&two[0], &two[1]));
    }

    #[test]
    fn integer_sums_are_exact_and_the_variance_is_the_direct_sums() {
        // 10,001 pixels: several blocks and a remainder of the lanes.
        let n = 10_001;
        let a: Vec<f64> = (0..n)
            .map(|i| ((i * 7919) % 4093 + 40_000) as f64)
            .collect();
        let b: Vec<f64> = (0..n)
            .map(|i| ((i * 104_729) % 4091 + 40_000) as f64)
            .collect();
        let got = pair_stats(&a, &b);
        let exact = |v: &[f64]| v.iter().map(|&x| x as i64).sum::<i64>() as f64 / n as f64;
        let drift = exact(&a) - exact(&b);
        assert_eq!(got.drift_dn, drift);
        assert_eq!(got.mean_dn, (exact(&a) + exact(&b)) / 2.0);
        let direct = a
            .iter()
            .zip(&b)
            .map(|(x, y)| (x - y - drift).powi(2))
            .sum::<f64>()
            / n as f64
            / 2.0;
        assert!((got.variance_dn2 / direct - 1.0).abs() < 1e-13);
    }
}
