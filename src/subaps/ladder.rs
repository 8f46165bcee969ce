//! The constant-sigma ladder of a job: the references every sub-aperture is matched against,
//! run once for the whole map instead of once per sub-aperture.
//!
//! Every sub-aperture of a job has the same configuration and seed, and the engine draws each
//! frame's random numbers from the iteration alone (not from the other models of the run, nor
//! the thread), so a constant-sigma reference reads the same frames beside any sub-aperture.
//! The ladder runs its references once, on a fixed grid of sigmas covering the map, and keeps
//! their results and per-block sums at fixed iteration counts (checkpoints); a sub-aperture
//! then runs only its own window to a checkpoint, inverts its R on the ladder there, and takes
//! its paired standard error from its blocks beside the ladder's.
//!
//! The references are read through the job's centroider, each at its own best setting (the
//! same-centroider effective noise); with a centroider other than `cog` a second set of arms
//! reads the same references through `cog`, for the cog-equivalent sigma.

use super::solve::NoiseMap;
use crate::centroid::CentroiderSpec;
use crate::detector::{Readout, ScmosConstant};
use crate::effective::Precision;
use crate::montecarlo::{Arm, Blocks, Experiment, SimConfig, SimResult, CHUNK};
use crate::progress::Observer;
use crate::Result;
use std::ops::Range;

/// Ratio of neighbouring sigmas: the quadratic inversion's error over a 10 % step is far below
/// any precision target (0.3 % of sigma for a linear one over a 10 % bracket).
const RATIO: f64 = 1.1;
/// Most sigmas of the geometric part; a map of a wider range gets a larger ratio.
const MAX_POINTS: usize = 120;
/// The bottom of the geometric part: this fraction of the map's 1st percentile (e-)...
const LOW_FRACTION: f64 = 0.5;
/// ...that percentile...
const LOW_PERCENTILE: f64 = 1.0;
/// ...and its floor (e-): a map of zeros still gets a ladder.
const LOW_FLOOR_E: f64 = 1e-3;
/// The top: this factor times the map's largest sigma (e-). Few noisy pixels can pull the
/// centroid more than uniform noise of their sigma; R of uniform noise saturates above that.
const TOP_FACTOR: f64 = 4.0;
/// Growth of the iteration count between checkpoints (before rounding to whole chunks): a
/// sub-aperture short of its target goes to the first checkpoint at or above what the 1/sqrt(N)
/// law asks for (at least twice its count), so it overshoots that by at most this factor.
const CHECKPOINT_GROWTH: f64 = std::f64::consts::SQRT_2;

/// The ladder's sigmas (e-), ascending: 0 (the noiseless readout, the foot) and a geometric
/// grid from half the map's 1st percentile to 4 times its largest sigma (the fill of its
/// non-finite pixels included). They depend on the whole map only, so every shard has them.
pub(super) fn ladder_sigmas(noise: &NoiseMap) -> Vec<f64> {
    let low =
        (LOW_FRACTION * crate::stats::percentile(&noise.map.data, LOW_PERCENTILE)).max(LOW_FLOOR_E);
    let largest = noise
        .map
        .data
        .iter()
        .copied()
        .filter(|v| v.is_finite())
        .fold(noise.fill_e, f64::max);
    let top = (TOP_FACTOR * largest).max(low * RATIO);
    let steps = ((top / low).ln() / RATIO.ln()).ceil().max(1.0) as usize;
    let steps = steps.min(MAX_POINTS - 1);
    let ratio = (top / low).powf(1.0 / steps as f64);
    std::iter::once(0.0)
        .chain((0..=steps).map(|k| low * ratio.powi(k as i32)))
        .collect()
}

/// The iteration counts at which sub-apertures are evaluated: the starting `iters`, then
/// growing by [`CHECKPOINT_GROWTH`] in whole chunks, up to the cap (the last).
pub(super) fn checkpoints(iters: u64, precision: &Precision) -> Vec<u64> {
    let cap = precision.max_iters.max(iters);
    let mut out = vec![iters];
    while let Some(&last) = out.last().filter(|&&n| n < cap) {
        let next = ((last as f64 * CHECKPOINT_GROWTH).ceil() as u64).div_ceil(CHUNK) * CHUNK;
        out.push(next.clamp(last + 1, cap));
    }
    out
}

/// The constant-sigma readouts of `sigmas` (e-).
pub(super) fn references(sigmas: &[f64]) -> Vec<ScmosConstant> {
    sigmas
        .iter()
        .map(|&s| ScmosConstant::new(s, format!("scmos-constant:{s}")))
        .collect()
}

/// The ladder's results at one checkpoint.
pub(super) struct Snapshot {
    /// Every arm's result (the job's centroider's arms, then `cog`'s, if any).
    pub results: Vec<SimResult>,
    /// Their per-block sums at each arm's best setting (arm i of the results is arm i here,
    /// its one setting 0).
    pub blocks: Blocks,
}

/// The references of a job run once, with their snapshots at the checkpoints reached so far.
pub(super) struct Ladder<'m> {
    /// Sigmas of the references (e-), ascending from 0.
    pub sigmas: Vec<f64>,
    /// Iteration counts of the checkpoints.
    pub checkpoints: Vec<u64>,
    /// Whether `cog` arms follow the centroider's (the centroider is not `cog`).
    pub cog_arms: bool,
    exp: Experiment<'m>,
    snapshots: Vec<Snapshot>,
}

impl<'m> Ladder<'m> {
    /// The ladder of `references` (at `sigmas`) in configuration `cfg`, read through
    /// `centroider` (and `cog`), evaluated at `checkpoints`; nothing run yet.
    pub fn new(
        cfg: &SimConfig,
        (sigmas, references): (Vec<f64>, &'m [ScmosConstant]),
        centroider: CentroiderSpec,
        checkpoints: Vec<u64>,
    ) -> Result<Self> {
        let models: Vec<&dyn Readout> = references.iter().map(|r| r as &dyn Readout).collect();
        let cog_arms = centroider != CentroiderSpec::default();
        let readings: &[CentroiderSpec] = if cog_arms {
            &[centroider, CentroiderSpec::default()]
        } else {
            &[centroider]
        };
        let arms: Vec<Arm> = readings
            .iter()
            .flat_map(|&centroider| (0..models.len()).map(move |model| Arm { model, centroider }))
            .collect();
        Ok(Ladder {
            exp: Experiment::with_arms(cfg, &models, &arms)?.with_blocks(),
            sigmas,
            checkpoints,
            cog_arms,
            snapshots: Vec::new(),
        })
    }

    /// Arms of the reading through the job's centroider.
    pub fn own(&self) -> Range<usize> {
        0..self.sigmas.len()
    }

    /// Arms of the reading through `cog` (the same as [`Ladder::own`] for `cog`).
    pub fn cog(&self) -> Range<usize> {
        if self.cog_arms {
            self.sigmas.len()..2 * self.sigmas.len()
        } else {
            self.own()
        }
    }

    /// Run the references up to checkpoint `k`, keeping a snapshot at every checkpoint passed
    /// (each the same whenever it is reached: the run only ever grows in the same steps).
    /// `observer` is advanced by `weight` x the iterations run.
    pub fn reach(&mut self, k: usize, observer: &dyn Observer, weight: u64) -> Result<()> {
        while self.snapshots.len() <= k {
            let to = self.checkpoints[self.snapshots.len()];
            self.exp.extend_to(to, observer, weight)?;
            let results = self.exp.results()?;
            let best: Vec<(usize, usize)> = results.iter().map(|r| r.best).enumerate().collect();
            let blocks = self.exp.blocks().expect("the ladder keeps blocks");
            self.snapshots.push(Snapshot {
                blocks: blocks.select(&best),
                results,
            });
        }
        Ok(())
    }

    /// Checkpoints reached (their snapshots kept).
    pub fn reached(&self) -> usize {
        self.snapshots.len()
    }

    /// The snapshot at checkpoint `k` (reached).
    pub fn at(&self, k: usize) -> &Snapshot {
        &self.snapshots[k]
    }
}
