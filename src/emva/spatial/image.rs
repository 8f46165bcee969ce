//! The averaged image of a spatial stack and its per-pixel temporal variance, from one pass
//! over the frames (per-pixel sums of values and squares), O(frame) memory.

use std::path::{Path, PathBuf};

use rayon::prelude::*;

use crate::error::{Error, Result};
use crate::io::{read_batches, FrameData, FrameStack};

/// Pixels per rayon task when a frame is added to the sums.
const CHUNK: usize = 16_384;

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
            acc.add(f);
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

    fn add(&mut self, frame: &[f64]) {
        assert_eq!(frame.len(), self.s1.len(), "frame of the wrong size");
        if self.frames == 0 {
            self.first = frame.to_vec();
        }
        self.frames += 1;
        self.s1
            .par_chunks_mut(CHUNK)
            .zip(self.s2.par_chunks_mut(CHUNK))
            .zip(self.first.par_chunks(CHUNK).zip(frame.par_chunks(CHUNK)))
            .for_each(|((s1, s2), (y0, y))| {
                for i in 0..s1.len() {
                    let d = y[i] - y0[i];
                    s1[i] += d;
                    s2[i] += d * d;
                }
            });
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
    let mut scratch = vec![0.0; stack.pixels()];
    read_batches(&stack, None, |batch| {
        for frame in batch.frames() {
            match frame {
                FrameData::Values(v) => acc.add(v),
                FrameData::Raw(bytes, layout) => {
                    layout.decode(bytes, &mut scratch);
                    acc.add(&scratch);
                }
            }
        }
        Ok(())
    })?;
    stack.require_all_read(acc.frames)?;
    acc.finish(first)
}
