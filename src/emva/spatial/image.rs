//! The averaged image of a spatial stack and its per-pixel temporal variance, from one pass
//! over the frames (per-pixel sums of values and squares), O(frame) memory.

use std::path::{Path, PathBuf};

use rayon::prelude::*;

use crate::error::{Error, Result};
use crate::io::{read_batches, FrameData, FrameStack};

/// Pixels per rayon task when a frame is added to the sums.
const CHUNK: usize = 16_384;

/// Pixels of stored bytes decoded at a time inside a task (a block of f64 that stays in L1).
const BLOCK: usize = 1024;

/// A spatial stack reduced to per-pixel sums: what the standard's spatial evaluation needs.
#[derive(Clone, Debug)]
pub struct StackImage {
    /// Frame shape (rows M, columns N).
    pub shape: (usize, usize),
    /// Frames summed (L).
    pub frames: usize,
    /// Sum of the L frames per pixel, row-major (DN; exact for integer samples, so the
    /// standard's histograms of the sum image bin integers as it does).
    pub sum_dn: Vec<f64>,
    /// Per-pixel temporal variance over the L frames, ddof 1 (DN^2).
    pub temporal_var_dn2: Vec<f64>,
}

impl StackImage {
    /// The averaged image `<y>` (DN), row-major.
    pub fn mean_dn(&self) -> Vec<f64> {
        let l = self.frames as f64;
        self.sum_dn.iter().map(|s| s / l).collect()
    }

    /// sigma^2_y.stack: the mean over pixels of the temporal variance (DN^2).
    pub fn temporal_var_mean_dn2(&self) -> f64 {
        self.temporal_var_dn2.iter().sum::<f64>() / self.temporal_var_dn2.len() as f64
    }

    /// Reduce frames held in memory (row-major, `shape`), e.g. a test's synthetic stack.
    pub fn from_frames<'a>(
        shape: (usize, usize),
        frames: impl IntoIterator<Item = &'a [f64]>,
    ) -> Result<StackImage> {
        let mut acc = Accumulator::new(shape);
        for f in frames {
            acc.add_batch(&[FrameData::Values(f.to_vec())]);
        }
        acc.finish(Path::new("<memory>"))
    }
}

/// Per-pixel sums of a stack, shifted by the first frame so that the squares keep their
/// precision on large offsets (float samples; integer sums are exact either way).
struct Accumulator {
    shape: (usize, usize),
    frames: usize,
    first: Vec<f64>,
    s1: Vec<f64>,
    s2: Vec<f64>,
}

impl Accumulator {
    fn new(shape: (usize, usize)) -> Self {
        let n = shape.0 * shape.1;
        Accumulator {
            shape,
            frames: 0,
            first: Vec::new(),
            s1: vec![0.0; n],
            s2: vec![0.0; n],
        }
    }

    /// Add a batch of frames as read (stored bytes or values), pixels in parallel: each task
    /// walks its pixels a block at a time through every frame of the batch, so the sums are
    /// read and written once per batch, not once per frame (and every pixel's sums still run
    /// over the frames in their order, whatever the threads).
    fn add_batch(&mut self, frames: &[FrameData]) {
        let Some(first) = frames.first() else {
            return;
        };
        let n = self.s1.len();
        assert!(
            frames.iter().all(|f| f.pixels() == n),
            "frame of the wrong size"
        );
        if self.frames == 0 {
            let mut buf = vec![0.0; n];
            self.first = first.block(0, n, &mut buf).to_vec();
        }
        self.frames += frames.len();
        self.s1
            .par_chunks_mut(CHUNK)
            .zip(self.s2.par_chunks_mut(CHUNK))
            .zip(self.first.par_chunks(CHUNK))
            .enumerate()
            .for_each(|(task, ((s1, s2), y0))| add_task(s1, s2, y0, frames, task * CHUNK));
    }

    /// The sums as a [`StackImage`]; `source` names the stack in the error for fewer than
    /// two frames (no temporal variance).
    fn finish(self, source: &Path) -> Result<StackImage> {
        if self.frames < 2 {
            return Err(Error::input(
                source,
                format!(
                    "spatial stack has {} frame(s); its temporal variance needs at least 2",
                    self.frames
                ),
            ));
        }
        let l = self.frames as f64;
        let sum_dn = self
            .first
            .iter()
            .zip(&self.s1)
            .map(|(y0, s1)| y0 * l + s1)
            .collect();
        let temporal_var_dn2 = self
            .s1
            .iter()
            .zip(&self.s2)
            .map(|(s1, s2)| ((s2 - s1 * s1 / l) / (l - 1.0)).max(0.0))
            .collect();
        Ok(StackImage {
            shape: self.shape,
            frames: self.frames,
            sum_dn,
            temporal_var_dn2,
        })
    }
}

crate::io::widest! {
    /// Add `frames`' pixels `base..` (as many as `s1` holds) to a task's sums, a block at a
    /// time through every frame.
    fn add_task(s1: &mut [f64], s2: &mut [f64], y0: &[f64], frames: &[FrameData], base: usize) {
        let mut buf = [0.0; BLOCK];
        for start in (0..s1.len()).step_by(BLOCK) {
            let end = (start + BLOCK).min(s1.len());
            let (s1, s2, y0) = (&mut s1[start..end], &mut s2[start..end], &y0[start..end]);
            for f in frames {
                add_values(s1, s2, y0, f.block(base + start, base + end, &mut buf));
            }
        }
    }
}

/// Add one frame's `y` less the first frame's `y0` and its square to the sums.
#[inline(always)]
fn add_values(s1: &mut [f64], s2: &mut [f64], y0: &[f64], y: &[f64]) {
    for i in 0..s1.len() {
        let d = y[i] - y0[i];
        s1[i] += d;
        s2[i] += d * d;
    }
}

/// Read a spatial stack's files once, frame by frame (frames read on a thread of their own),
/// into its [`StackImage`].
pub fn read_stack_image(files: &[PathBuf]) -> Result<StackImage> {
    let first = files.first().ok_or_else(|| {
        Error::invalid(
            "spatial_stack",
            "the spatial stack names no files".to_string(),
        )
    })?;
    let stack = FrameStack::open(files)?;
    stack.require_frames(2, "a spatial stack's temporal variance")?;
    let mut acc = Accumulator::new(stack.shape);
    read_batches(&stack, None, |batch| {
        acc.add_batch(batch.frames());
        Ok(())
    })?;
    stack.require_all_read(acc.frames)?;
    acc.finish(first)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::io::fits::write_cube;

    #[test]
    fn stored_integer_stacks_give_the_same_bits_as_their_values() {
        let dir = tempfile::tempdir().unwrap();
        // 40,000 pixels: several tasks of CHUNK pixels, and a part block in the last one.
        let shape = (125, 320);
        let n = shape.0 * shape.1;
        let frames: Vec<Vec<f64>> = (0..5)
            .map(|k| {
                (0..n)
                    .map(|i| {
                        let h = ((i * 31 + k * 7907) as u64).wrapping_mul(0x9e37_79b9_7f4a_7c15);
                        (50_000 + (h >> 53)) as f64
                    })
                    .collect()
            })
            .collect();
        let files: Vec<PathBuf> = frames
            .iter()
            .enumerate()
            .map(|(k, f)| {
                let path = dir.path().join(format!("s{k}.fits"));
                let mut next = Some(f.clone());
                write_cube(&path, shape, 1, true, &mut || next.take().unwrap(), &[]).unwrap();
                path
            })
            .collect();
        let stack = FrameStack::open(&files).unwrap();
        let mut slot = FrameData::Values(Vec::new());
        stack.reader().next_frame_data(&mut slot).unwrap();
        assert!(matches!(slot, FrameData::Raw(..)), "read as stored bytes");
        let got = read_stack_image(&files).unwrap();
        let want = StackImage::from_frames(shape, frames.iter().map(|f| f.as_slice())).unwrap();
        assert_eq!(got.frames, 5);
        assert_eq!(got.sum_dn, want.sum_dn);
        assert_eq!(got.temporal_var_dn2, want.temporal_var_dn2);
    }
}
