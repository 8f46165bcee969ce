//! The camera's own dark frames for `scmos-frames`: a stack read once, streaming, into a bounded
//! reservoir of bias-subtracted frames in e-.
//!
//! The per-pixel offset is the pixel's mean over the whole stack, accumulated while the frames
//! stream past (O(frame) memory besides the reservoir). The frames kept are a uniform sample
//! of the stack (Algorithm R with a fixed seed, so a run is reproducible) of at most
//! `dark_frames_max_mib` MiB; every frame is kept when the stack fits.

use std::path::PathBuf;

use rand::RngExt;

use crate::io::{read_batches, FrameData, FrameStack};
use crate::rng::{stream, SimRng};
use crate::{Error, Result};

/// Default memory bound of the kept frames (MiB).
pub const DEFAULT_MAX_MIB: f64 = 512.0;

/// Seed of the reservoir's choice of frames: fixed, so that the same stack and bound always
/// keep the same frames.
const RESERVOIR_SEED: u64 = 2015;

/// Bytes per kept sample (f32 e-).
const SAMPLE_BYTES: usize = std::mem::size_of::<f32>();

/// Bias-subtracted dark frames in e-, a uniform sample of a stack.
#[derive(Clone)]
pub struct DarkFrames {
    /// Frame rows.
    pub rows: usize,
    /// Frame columns.
    pub cols: usize,
    /// Frames in the stack read.
    pub total: usize,
    /// Conversion gain the frames were converted with (e- per adu).
    pub gain_e_per_adu: f64,
    /// Memory bound of the kept frames (MiB), as given.
    pub max_mib: f64,
    /// The stack's first file, for messages.
    pub source: PathBuf,
    /// Kept frames, each rows x cols row-major, as (value - pixel offset) x gain (e-); f32
    /// keeps twice as many frames in the bound, at a relative rounding of 6e-8.
    data: Vec<f32>,
    /// Rms of the kept values (e-).
    rms_e: f64,
    /// Rms of each pixel's kept values (e-), row-major: the camera's own noise map.
    pixel_rms_e: Vec<f64>,
}

impl std::fmt::Debug for DarkFrames {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "DarkFrames({})", self.summary())
    }
}

/// Algorithm R: which slot of a reservoir of `capacity` items the next offered item takes.
#[derive(Debug, Clone)]
pub(super) struct Reservoir {
    capacity: usize,
    seen: usize,
    rng: SimRng,
}

impl Reservoir {
    /// A reservoir of `capacity` items choosing with `rng`.
    pub(super) fn new(capacity: usize, rng: SimRng) -> Self {
        Reservoir {
            capacity,
            seen: 0,
            rng,
        }
    }

    /// Offer the next item: the slot it takes (filling the reservoir first, then replacing a
    /// uniformly chosen item with probability capacity / items seen), or None.
    pub(super) fn offer(&mut self) -> Option<usize> {
        let i = self.seen;
        self.seen += 1;
        if i < self.capacity {
            return Some(i);
        }
        let j = self.rng.random_range(0..=i);
        (j < self.capacity).then_some(j)
    }
}

/// Frames below which a stack is too short to stand for its camera (see [`DarkFrames::few_frames`]):
/// each pixel's rms is then known to worse than 1 / sqrt(2 (100 - 1)) = 7 %.
pub const FEW_FRAMES: usize = 100;

impl DarkFrames {
    /// A warning for a stack of fewer than [`FEW_FRAMES`] frames (None from that many on): the
    /// (N - 1) / N bias is corrected, but each pixel's noise is still only N values, so its rms is
    /// known to about 1 / sqrt(2 (N - 1)) and its tails and telegraph levels hardly at all.
    pub fn few_frames(&self) -> Option<String> {
        let n = self.total;
        (n < FEW_FRAMES).then(|| {
            let rel = 100.0 / (2.0 * (n as f64 - 1.0)).sqrt();
            format!(
                "{}: only {n} dark frames: each pixel's rms is known to about {rel:.0} % and its \
                 tails and telegraph levels hardly at all (the mean's share of the variance, \
                 (N - 1) / N, is corrected); `scmos-frames` needs {FEW_FRAMES} frames or more to \
                 stand for the camera",
                self.source.display()
            )
        })
    }

    /// Read the stack `paths` (files, directories or globs; any format the stack reader
    /// reads), subtract each pixel's mean over the stack, convert with `gain_e_per_adu`
    /// (e- per adu) and keep a uniform sample of at most `max_mib` MiB of frames.
    pub fn read(paths: &[PathBuf], gain_e_per_adu: f64, max_mib: f64) -> Result<DarkFrames> {
        if !(gain_e_per_adu.is_finite() && gain_e_per_adu > 0.0) {
            return Err(Error::invalid(
                "gain_e_per_adu",
                format!(
                    "{gain_e_per_adu}: the conversion gain of `dark_frames` must be > 0 e- per adu"
                ),
            ));
        }
        if !(max_mib.is_finite() && max_mib > 0.0) {
            return Err(Error::invalid(
                "dark_frames_max_mib",
                format!("{max_mib}: must be a number of MiB > 0"),
            ));
        }
        let stack = FrameStack::open(paths)?;
        stack.require_frames(2, "a bias-subtracted dark frame")?;
        let (rows, cols) = stack.shape;
        let npx = stack.pixels();
        let max_bytes = (max_mib * 1024.0 * 1024.0) as u64;
        let frame_bytes = (npx * SAMPLE_BYTES) as u64;
        let capacity = (max_bytes / frame_bytes).min(stack.frames as u64) as usize;
        if capacity == 0 {
            return Err(Error::invalid(
                "dark_frames_max_mib",
                format!(
                    "{max_mib} MiB holds no frame of `dark_frames` ({rows}x{cols} px, {:.1} MiB \
                     each as f32): raise it",
                    frame_bytes as f64 / MIB
                ),
            ));
        }
        let mut data = vec![0f32; capacity * npx];
        // Kept values are stored relative to the first frame (exact for integer samples), so
        // that the f32 holds a noise-sized difference rather than the offset.
        let mut reference = vec![0f64; npx];
        let mut sum = vec![0f64; npx];
        let mut values = vec![0f64; npx];
        let mut reservoir = Reservoir::new(capacity, stream(RESERVOIR_SEED, 0, 0));
        let mut read = 0usize;
        read_batches(&stack, None, |batch| {
            for frame in batch.frames() {
                let v: &[f64] = match frame {
                    FrameData::Values(v) => v,
                    FrameData::Raw(bytes, layout) => {
                        layout.decode(bytes, &mut values);
                        &values
                    }
                };
                if read == 0 {
                    reference.copy_from_slice(v);
                }
                for ((s, x), r) in sum.iter_mut().zip(v).zip(&reference) {
                    *s += x - r;
                }
                if let Some(slot) = reservoir.offer() {
                    let kept = &mut data[slot * npx..(slot + 1) * npx];
                    for ((k, x), r) in kept.iter_mut().zip(v).zip(&reference) {
                        *k = (x - r) as f32;
                    }
                }
                read += 1;
            }
            Ok(())
        })?;
        stack.require_all_read(read)?;
        // value - offset = (value - reference) - (mean - reference), then to e-.
        let offset: Vec<f64> = sum.iter().map(|s| s / read as f64).collect();
        let mut power = 0.0;
        let mut pixel_power = vec![0.0; npx];
        for frame in data.chunks_exact_mut(npx) {
            for ((k, o), p) in frame.iter_mut().zip(&offset).zip(&mut pixel_power) {
                let e = (*k as f64 - o) * gain_e_per_adu;
                *k = e as f32;
                power += e * e;
                *p += e * e;
            }
        }
        let kept = (data.len() / npx.max(1)).max(1) as f64;
        Ok(DarkFrames {
            rows,
            cols,
            total: read,
            gain_e_per_adu,
            max_mib,
            source: stack.sources[0].path.clone(),
            rms_e: (power / data.len() as f64).sqrt(),
            pixel_rms_e: pixel_power.iter().map(|p| (p / kept).sqrt()).collect(),
            data,
        })
    }

    /// Number of frames kept.
    pub fn kept(&self) -> usize {
        self.data.len() / (self.rows * self.cols)
    }

    /// Memory of the kept frames (bytes).
    pub fn bytes(&self) -> u64 {
        (self.data.len() * SAMPLE_BYTES) as u64
    }

    /// Rms of the kept bias-subtracted values (e-).
    pub fn rms_e(&self) -> f64 {
        self.rms_e
    }

    /// Rms of each pixel over the kept frames (e-), rows x cols row-major.
    pub fn pixel_rms_e(&self) -> &[f64] {
        &self.pixel_rms_e
    }

    /// Kept frame `k` (rows x cols, row-major, e-).
    pub fn frame(&self, k: usize) -> &[f32] {
        let npx = self.rows * self.cols;
        &self.data[k * npx..(k + 1) * npx]
    }

    /// One line for the user: frames kept of the stack, their shape and memory, and the bound.
    pub fn summary(&self) -> String {
        format!(
            "{} of {} dark frames of {}x{} px kept from {} ({:.1} MiB in memory as f32 e-, \
             bound {} MiB{}), bias-subtracted by each pixel's mean over the {} frames and \
             converted at {} e-/adu",
            self.kept(),
            self.total,
            self.rows,
            self.cols,
            self.source.display(),
            self.bytes() as f64 / MIB,
            self.max_mib,
            if self.kept() < self.total {
                ", a uniform sample"
            } else {
                ""
            },
            self.total,
            self.gain_e_per_adu
        )
    }
}

/// Bytes per MiB.
const MIB: f64 = 1024.0 * 1024.0;

#[cfg(test)]
mod tests {
    use super::*;
    use crate::io::fits::write_cube;

    /// A FITS cube of `frames` frames of `shape` (f32 samples unless `u16`), frame k from `f(k)`.
    pub(crate) fn cube(
        path: &std::path::Path,
        shape: (usize, usize),
        frames: usize,
        u16: bool,
        f: impl Fn(usize) -> Vec<f64>,
    ) {
        let mut k = 0;
        let mut next = || {
            k += 1;
            f(k - 1)
        };
        write_cube(path, shape, frames, u16, &mut next, &[]).unwrap();
    }

    #[test]
    fn frames_are_bias_subtracted_by_the_stack_mean_and_converted() {
        // 6 frames of 2x3 px, values exact in f32: every frame kept, in stack order, as
        // (value - pixel mean) x gain.
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("darks.fits");
        let value =
            |k: usize, p: usize| 100.0 + p as f64 * 10.0 + ((k * 7 + p * 3) % 5) as f64 * 0.25;
        cube(&path, (2, 3), 6, false, |k| {
            (0..6).map(|p| value(k, p)).collect()
        });
        let d = DarkFrames::read(std::slice::from_ref(&path), 0.5, DEFAULT_MAX_MIB).unwrap();
        assert_eq!((d.rows, d.cols, d.total, d.kept()), (2, 3, 6, 6));
        assert_eq!(d.bytes(), 6 * 6 * 4);
        let mut power = 0.0;
        for p in 0..6 {
            let mean = (0..6).map(|k| value(k, p)).sum::<f64>() / 6.0;
            for k in 0..6 {
                let e = (value(k, p) - mean) * 0.5;
                assert_eq!(d.frame(k)[p], e as f32, "frame {k} pixel {p}");
                power += e * e;
            }
        }
        assert!((d.rms_e() - (power / 36.0).sqrt()).abs() < 1e-7);
        let s = d.summary();
        assert!(
            s.starts_with("6 of 6 dark frames of 2x3 px kept from"),
            "{s}"
        );
        assert!(
            s.contains("darks.fits") && s.contains("bound 512 MiB") && !s.contains("sample"),
            "{s}"
        );
    }

    #[test]
    fn a_stack_larger_than_the_bound_keeps_a_uniform_sample_with_the_full_offsets() {
        // 40 frames of 4x4 px (64 bytes each as f32) under a bound of 10 frames. Frame k holds
        // 1000 + k at every pixel, u16: the offset is the mean over all 40 (1019.5), so a kept
        // frame reads (k - 19.5) x gain everywhere and names its k; the 10 are distinct.
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("big.fits");
        cube(&path, (4, 4), 40, true, |k| vec![1000.0 + k as f64; 16]);
        let mib = 640.0 / MIB;
        let d = DarkFrames::read(std::slice::from_ref(&path), 2.0, mib).unwrap();
        assert_eq!((d.total, d.kept(), d.bytes()), (40, 10, 640));
        let mut kept: Vec<usize> = (0..10)
            .map(|j| {
                let f = d.frame(j);
                assert!(f.iter().all(|&v| v == f[0]));
                let k = f[0] as f64 / 2.0 + 19.5;
                assert_eq!(k.fract(), 0.0);
                k as usize
            })
            .collect();
        kept.sort_unstable();
        kept.dedup();
        assert_eq!(kept.len(), 10);
        assert!(
            d.summary().starts_with("10 of 40 dark frames")
                && d.summary().contains("a uniform sample")
        );
        // The same stack and bound keep the same frames (fixed seed).
        let again = DarkFrames::read(std::slice::from_ref(&path), 2.0, mib).unwrap();
        assert_eq!(again.data, d.data);
    }

    #[test]
    fn algorithm_r_keeps_every_item_with_equal_probability() {
        // 5 slots, 20 items, 4000 independent reservoirs: each item ends in the reservoir with
        // probability 5/20, within 4 binomial SE.
        let (slots, items, runs) = (5, 20, 4000);
        let mut kept = vec![0usize; items];
        for run in 0..runs {
            let mut r = Reservoir::new(slots, stream(77, run, 0));
            let mut held = vec![usize::MAX; slots];
            for item in 0..items {
                if let Some(s) = r.offer() {
                    held[s] = item;
                }
            }
            held.iter().for_each(|&i| kept[i] += 1);
        }
        let p = slots as f64 / items as f64;
        let se = (runs as f64 * p * (1.0 - p)).sqrt();
        for (i, &k) in kept.iter().enumerate() {
            assert!(
                (k as f64 - runs as f64 * p).abs() < 4.0 * se,
                "item {i}: {k}"
            );
        }
    }

    #[test]
    fn bad_settings_and_stacks_are_errors_naming_field_or_file() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("d.fits");
        cube(&path, (4, 4), 3, true, |k| vec![10.0 + k as f64; 16]);
        let paths = std::slice::from_ref(&path);
        for gain in [0.0, -1.0, f64::NAN] {
            let e = DarkFrames::read(paths, gain, 1.0).unwrap_err();
            assert!(
                e.to_string().starts_with("invalid `gain_e_per_adu`: "),
                "{e}"
            );
        }
        let e = DarkFrames::read(paths, 1.0, 0.0).unwrap_err();
        assert!(
            e.to_string().starts_with("invalid `dark_frames_max_mib`: "),
            "{e}"
        );
        let e = DarkFrames::read(paths, 1.0, 32.0 / MIB)
            .unwrap_err()
            .to_string();
        assert!(e.contains("holds no frame of `dark_frames` (4x4 px"), "{e}");
        let one = dir.path().join("one.fits");
        cube(&one, (4, 4), 1, true, |_| vec![10.0; 16]);
        let e = DarkFrames::read(&[one], 1.0, 1.0).unwrap_err().to_string();
        assert!(e.contains("one.fits") && e.contains("at least 2"), "{e}");
        let e = DarkFrames::read(&[dir.path().join("none.fits")], 1.0, 1.0).unwrap_err();
        assert!(e.to_string().contains("none.fits"), "{e}");
    }
}
