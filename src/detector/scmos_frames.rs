//! `scmos-frames`: the camera's own bias-subtracted dark frames as the read noise.

use std::sync::Arc;

use super::dark_frames::DarkFrames;
use super::readout::{FrameInput, Readout};
use super::spec::{ModelEntry, ModelSpec, Sensor};
use crate::rng::SimRng;
use crate::{Error, Result};

/// The registry entry of `scmos-frames`.
pub const ENTRY: ModelEntry = ModelEntry {
    name: "scmos-frames",
    arg: None,
    help: "sCMOS read through the camera's own dark frames: every frame adds a random window of a \
           random bias-subtracted dark frame, converted to e- with `gain_e_per_adu`, so all the \
           camera's noise: RTS pixels, rows, columns, tails",
    sensor: Sensor::Scmos,
    params: &["dark_frames"],
    parse: ModelSpec::registered,
    build: |_, p, subap_px| match &p.dark_frames {
        Some(frames) => Ok(Box::new(ScmosFrames::new(frames.clone(), subap_px)?)),
        None => Err(Error::invalid(
            "dark_frames",
            "scmos-frames needs the camera's dark frames: give `dark_frames` FILE... and their \
             conversion gain `gain_e_per_adu`",
        )),
    },
};

/// `scmos-frames`: each frame adds to the photo-electrons an n x n window, at a random place, of
/// a random kept dark frame (bias-subtracted with each pixel's mean over the stack, in e-).
/// It carries everything the camera does that a dark frame shows: per-pixel noise, telegraph
/// pixels, row and column noise, heavy tails. It does not use the frame's normal deviates
/// (three uniform draws from `aux` per frame: the dark frame, the window's row, its column).
///
/// A frame of a stack of N, less the stack's own per-pixel mean, has (N - 1) / N of the
/// pixel's variance (the mean took its share): with 2 frames half of it, and R came out
/// 0.204 px where the camera's map gives 0.269. Every value read is therefore scaled by
/// sqrt(N / (N - 1)), which makes each pixel's variance the unbiased (sample) one, and so
/// are the sigmas the model reports (`read_known`, the median and the noise scale).
#[derive(Debug, Clone)]
pub struct ScmosFrames {
    frames: Arc<DarkFrames>,
    n: usize,
    median_e: f64,
    /// sqrt(N / (N - 1)) for the stack's N frames: undoes the bias of its mean's subtraction.
    unbias: f64,
}

/// sqrt(N / (N - 1)): the factor that makes the variance of values centred on the mean of
/// their `n` frames (n >= 2) unbiased.
pub fn unbias_factor(n: usize) -> f64 {
    let n = n as f64;
    (n / (n - 1.0)).sqrt()
}

impl ScmosFrames {
    /// Windows of `n` x `n` pixels of `frames`; the frames must be at least that large, and two
    /// or more.
    pub fn new(frames: Arc<DarkFrames>, n: usize) -> Result<Self> {
        if frames.total < 2 {
            return Err(Error::input(
                &frames.source,
                "one dark frame: a bias-subtracted frame needs the mean of two or more",
            ));
        }
        if frames.rows < n || frames.cols < n {
            return Err(Error::input(
                &frames.source,
                format!(
                    "dark frames are {}x{} px, smaller than the {n}x{n} px sub-aperture",
                    frames.rows, frames.cols
                ),
            ));
        }
        let unbias = unbias_factor(frames.total);
        let median_e = crate::stats::median(frames.pixel_rms_e()) * unbias;
        Ok(ScmosFrames {
            frames,
            n,
            median_e,
            unbias,
        })
    }
}

impl Readout for ScmosFrames {
    fn name(&self) -> String {
        "scmos-frames".into()
    }

    fn read(&self, input: &FrameInput, aux: &mut SimRng, out: &mut [f64]) {
        self.read_at(input, aux, out);
    }

    fn read_known(&self, input: &FrameInput, aux: &mut SimRng, out: &mut [f64], sigma_e: &mut [f64]) {
        // The controller's map: each pixel's rms over the camera's own kept frames.
        let (r0, c0) = self.read_at(input, aux, out);
        let (n, d) = (self.n, &*self.frames);
        for (i, srow) in sigma_e.chunks_exact_mut(n).enumerate() {
            let rms = &d.pixel_rms_e()[(r0 + i) * d.cols + c0..][..n];
            for (s, r) in srow.iter_mut().zip(rms) {
                *s = r * self.unbias;
            }
        }
    }

    fn median_sigma_e(&self) -> f64 {
        self.median_e
    }

    fn noise_scale_e(&self) -> f64 {
        self.frames.rms_e() * self.unbias
    }
}

impl ScmosFrames {
    /// Read one frame (see [`Readout::read`]); the window's top-left (row, column).
    fn read_at(&self, input: &FrameInput, aux: &mut SimRng, out: &mut [f64]) -> (usize, usize) {
        use rand::RngExt;
        let (n, d) = (self.n, &*self.frames);
        let frame = d.frame(aux.random_range(0..d.kept()));
        let r0 = aux.random_range(0..=d.rows - n);
        let c0 = aux.random_range(0..=d.cols - n);
        for (i, (orow, krow)) in out
            .chunks_exact_mut(n)
            .zip(input.photo_e.chunks_exact(n))
            .enumerate()
        {
            let drow = &frame[(r0 + i) * d.cols + c0..][..n];
            for ((o, &k), &e) in orow.iter_mut().zip(krow).zip(drow) {
                *o = k as f64 + e as f64 * self.unbias;
            }
        }
        (r0, c0)
    }
}

#[cfg(test)]
mod tests;
