//! The centroider interface: what a centroider sees of a frame, the settings of its swept
//! parameters, and the per-setting sums of its position error over frames.

use super::sums::{ErrorMoments, LevelSums, LevelTotals};

/// What a centroider sees of one frame.
#[derive(Debug, Clone, Copy)]
pub struct CentroidFrame<'a> {
    /// The frame read out (e-), row-major n x n.
    pub image_e: &'a [f64],
    /// The true spot position (px from the sub-aperture centre), the error's reference.
    pub truth_px: (f64, f64),
    /// The read-noise sigma (e-) of each pixel known to the controller (its noise map).
    pub sigma_e: &'a [f64],
    /// The controller's mean spot image: expected photo-electrons per pixel of the centred
    /// spot.
    pub mean_e: &'a [f64],
    /// Output variance per expected photo-electron (e-^2 per e-): the readout's
    /// [`crate::detector::Readout::photon_variance_factor`].
    pub photon_variance_factor: f64,
}

/// One setting of a centroider's swept parameters.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Setting {
    /// The centroider's own parameter (see [`Centroider::param_name`]); None for those without.
    pub param: Option<f64>,
    /// Background level subtracted before centroiding (e-); 0 for centroiders without one.
    pub b_e: f64,
    /// The sweep it belongs to (settings of one part of [`SettingSums`]).
    pub part: usize,
}

/// Sums of the position error over frames for every setting of a centroider, in parts (one
/// per value of an outer parameter, each swept over its levels).
#[derive(Debug, Clone)]
pub struct SettingSums {
    parts: Vec<LevelSums>,
}

impl SettingSums {
    /// Zeroed sums for parts of `sizes` settings each.
    pub fn new(sizes: &[usize]) -> Self {
        SettingSums {
            parts: sizes.iter().map(|&n| LevelSums::new(n)).collect(),
        }
    }

    /// The sums of part `k`.
    pub fn part_mut(&mut self, k: usize) -> &mut LevelSums {
        &mut self.parts[k]
    }

    /// Add another set of sums (same parts).
    pub fn merge(&mut self, other: &SettingSums) {
        for (a, b) in self.parts.iter_mut().zip(&other.parts) {
            a.merge(b);
        }
    }

    /// Reset every sum to zero, keeping the allocations.
    pub fn clear(&mut self) {
        self.parts.iter_mut().for_each(LevelSums::clear);
    }

    /// Per-setting totals, parts one after the other (the order of [`Centroider::settings`]).
    pub fn finish(&self) -> LevelTotals {
        self.parts.iter().flat_map(LevelSums::finish).collect()
    }

    /// Per-setting sums of the error vector's terms beyond R's, in the order of
    /// [`Self::finish`].
    pub fn moments(&self) -> Vec<ErrorMoments> {
        self.parts.iter().flat_map(LevelSums::moments).collect()
    }
}

/// A centroiding method with swept parameters: for every frame it adds, at each of its
/// settings, the distance of its estimate from the truth.
pub trait Centroider: Send + Sync {
    /// Name as given on the command line and written in tables, e.g. `masked-cog`.
    fn name(&self) -> String;
    /// Name of its own parameter with its unit (e.g. `k_sigma`), None for plain `cog`.
    /// Default: none.
    fn param_name(&self) -> Option<&'static str> {
        None
    }
    /// Every setting swept, in the order of the sums. Default: one setting, no parameter and
    /// no background subtracted (a method that sweeps nothing).
    fn settings(&self) -> Vec<Setting> {
        vec![Setting {
            param: None,
            b_e: 0.0,
            part: 0,
        }]
    }
    /// Zeroed sums shaped for its settings. Default: the one setting of the default
    /// `settings`.
    fn sums(&self) -> SettingSums {
        SettingSums::new(&[1])
    }
    /// True when it uses the per-pixel read noise ([`CentroidFrame::sigma_e`]).
    fn needs_noise_map(&self) -> bool;
    /// A worker with its own scratch, for one thread.
    fn worker(&self) -> Box<dyn CentroidWorker + '_>;
}

/// One thread's centroider with its scratch.
pub trait CentroidWorker {
    /// Add the frame's error at every setting to `acc` (made by [`Centroider::sums`]).
    fn accumulate(&mut self, frame: &CentroidFrame, acc: &mut SettingSums);
    /// Add the errors of consecutive `frames` (at most [`crate::centroid::LANES`]): the same
    /// as [`CentroidWorker::accumulate`] for each, but for the order in which the frames'
    /// errors are summed (a worker may sweep the frames together, one per vector lane).
    fn accumulate_batch(&mut self, frames: &[CentroidFrame], acc: &mut SettingSums) {
        for f in frames {
            self.accumulate(f, acc);
        }
    }
}
