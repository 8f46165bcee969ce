//! The Shack-Hartmann sub-aperture Monte-Carlo of Basden (2015), section 2.
//!
//! Per iteration: a random spot position, a noiseless image scaled to S x QE photo-electrons,
//! its centre of gravity as the truth, Poisson shot noise, a readout, then the centre of
//! gravity after subtracting each background level. All models of a run share the spot
//! positions, the photon draws and the read-noise deviates (common random numbers), and every
//! iteration has its own seeded streams, so results do not depend on the thread count.
//!
//! An [`Experiment`] keeps its accumulated sums, so it can be continued: iterations N..N' use
//! the streams of iterations N..N', so a longer run is the same experiment with more frames.

use super::blocks::{Blocks, Term, SUB_BLOCK};
use super::config::SimConfig;
use crate::centroid::{
    CentroidContext, Centroider, CentroiderSpec, ErrorMoments, Setting, SettingSums, LANES,
};
use crate::detector::Readout;
use crate::progress::Observer;
use crate::spot::SpotRenderer;
use crate::{Error, Result};
use frames::{BatchFrames, Scene};
pub use parts::ErrorParts;
use rayon::prelude::*;

mod frames;
mod parts;

/// Iterations per parallel work item: chunk c holds iterations [c CHUNK, (c + 1) CHUNK) of the
/// run (fixed, so sums are added in the same order always, whatever the thread count).
pub const CHUNK: u64 = 256;
/// Work items held in memory at once (their per-level sums), whatever the iteration count.
const BATCH_CHUNKS: u64 = 64;

/// Stream roles of one iteration.
const POSITION: u64 = 0;
const PHOTONS: u64 = 1;
const NOISE: u64 = 2;
const AUX: u64 = 3;

/// R and its statistics at one setting of the centroider (a background level for `cog`).
#[derive(Debug, Clone, serde::Serialize)]
pub struct LevelStats {
    /// The centroider's own parameter at this setting (see [`SimResult::param_name`]).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub param: Option<f64>,
    /// Background level (e-).
    pub b_e: f64,
    /// Mean radial error (px).
    pub r_px: f64,
    /// Standard error of the mean radial error (px).
    pub r_se_px: f64,
    /// Frames with nothing above the level.
    pub empty_frames: u64,
}

/// The outcome for one readout model read through one centroider.
#[derive(Debug, Clone, serde::Serialize)]
pub struct SimResult {
    /// Model name.
    pub model: String,
    /// Centroider, as `--centroider` takes it (`cog` for the paper's).
    pub centroider: String,
    /// Name (with unit) of the centroider's own parameter; None for `cog` and `ivw-cog`.
    pub param_name: Option<&'static str>,
    /// The centroider's parameter at the optimum.
    pub param_opt: Option<f64>,
    /// R: minimum over eligible settings of the mean radial error (px).
    pub r_px: f64,
    /// Standard error of R (px).
    pub r_se_px: f64,
    /// Background level at the minimum (e-; 0 for centroiders without one).
    pub b_opt_e: f64,
    /// True when the optimum is the last setting of its sweep (widen the grid).
    pub b_at_grid_edge: bool,
    /// True when no setting met the empty-frame limit (the least-empty one is then reported).
    pub no_eligible_level: bool,
    /// Mean radial error at the first setting of the optimum's parameter: no background
    /// subtraction (b = 0) for background-swept centroiders (px).
    pub r0_px: f64,
    /// Standard error of R(0) (px).
    pub r0_se_px: f64,
    /// Frames with nothing above the optimum setting.
    pub zero_frames: u64,
    /// The error's static part (mean error vector) and random part (spread about it) at the
    /// optimum setting (px).
    #[serde(flatten)]
    pub parts: ErrorParts,
    /// Index of the optimum in `levels` (for [`Term`]s of paired standard errors).
    #[serde(skip)]
    pub best: usize,
    /// R at every setting.
    pub levels: Vec<LevelStats>,
}

/// A per-frame quantity whose sums per block an experiment with blocks keeps beside the radial
/// error's ([`Experiment::paired_se_moments`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Moment {
    /// The squared error |e|^2 (px^2).
    SquaredError,
    /// The error's x component (px).
    ErrorX,
    /// The error's y component (px).
    ErrorY,
}

impl Moment {
    /// Every moment kept, in the order of the block sums.
    const ALL: [Moment; 3] = [Moment::SquaredError, Moment::ErrorX, Moment::ErrorY];

    /// The moment's per-setting sums from finished totals and moments.
    fn sums(self, totals: &[(f64, f64, u64)], moments: &[ErrorMoments]) -> Vec<f64> {
        match self {
            Moment::SquaredError => totals.iter().map(|t| t.1).collect(),
            Moment::ErrorX => moments.iter().map(|m| m.sum_x).collect(),
            Moment::ErrorY => moments.iter().map(|m| m.sum_y).collect(),
        }
    }
}

/// One term of a linear combination of means of [`Moment`]s: `coef` x the mean of `moment` of
/// arm `arm` at setting `setting`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MomentTerm {
    /// The per-frame quantity.
    pub moment: Moment,
    /// Index of the arm in the run.
    pub arm: usize,
    /// Index of the setting in the arm's settings.
    pub setting: usize,
    /// Coefficient (per unit of the moment).
    pub coef: f64,
}

/// One arm of a run: a model of the run read through a centroider.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Arm {
    /// Index of the readout model in the run's models.
    pub model: usize,
    /// The centroider.
    pub centroider: CentroiderSpec,
}

/// Run the Monte-Carlo for every model; `observer` is advanced by the iterations of each chunk
/// as it finishes (the caller begins and ends the stage).
pub fn run(
    cfg: &SimConfig,
    models: &[&dyn Readout],
    observer: &dyn Observer,
) -> Result<Vec<SimResult>> {
    let mut experiment = Experiment::new(cfg, models)?;
    experiment.extend_to(cfg.iters, observer, 1)?;
    experiment.results()
}

/// A Monte-Carlo run of several readout models on common random numbers that can be continued:
/// it keeps every arm's per-setting sums (and, with [`Experiment::with_blocks`], their sums per
/// block of iterations for paired standard errors).
pub struct Experiment<'m> {
    cfg: SimConfig,
    models: Vec<&'m dyn Readout>,
    arms: Vec<BuiltArm>,
    renderer: SpotRenderer,
    /// The centred spot's expected photo-electrons per pixel (the controller's mean image).
    mean_e: Vec<f64>,
    totals: Vec<SettingSums>,
    blocks: Option<Blocks>,
    /// Block sums of the [`Moment`]s, kept with `blocks`: one pseudo-arm per moment and arm,
    /// moment-major.
    moment_blocks: Option<Blocks>,
    done: u64,
}

/// An arm with its centroider built for the run.
struct BuiltArm {
    model: usize,
    label: String,
    centroider: Box<dyn Centroider>,
    settings: Vec<Setting>,
}

/// What one chunk of iterations adds: per-arm sums, and the sums of its sub-blocks
/// `(first iteration, iterations, arms x settings sums, moments x arms x settings sums)` when
/// blocks are kept.
struct ChunkSums {
    totals: Vec<SettingSums>,
    blocks: Vec<(u64, u64, Vec<f64>, Vec<f64>)>,
}

impl<'m> Experiment<'m> {
    /// An experiment of configuration `cfg` (validated; its `iters` is not used) for `models`,
    /// each read through the paper's centre of gravity, with no iteration run yet.
    pub fn new(cfg: &SimConfig, models: &[&'m dyn Readout]) -> Result<Self> {
        let arms: Vec<Arm> = (0..models.len())
            .map(|model| Arm {
                model,
                centroider: CentroiderSpec::default(),
            })
            .collect();
        Self::with_arms(cfg, models, &arms)
    }

    /// An experiment of `cfg` whose results are `arms` (each a model of `models` read through a
    /// centroider): every model is read once per frame, and its arms centroid that frame.
    pub fn with_arms(cfg: &SimConfig, models: &[&'m dyn Readout], arms: &[Arm]) -> Result<Self> {
        cfg.validate()?;
        let renderer = SpotRenderer::new(
            cfg.spot,
            cfg.sampling,
            cfg.subap_px,
            cfg.position_half_range_px,
        );
        let levels = cfg.bg_grid.levels(peak_expected_e(cfg, &renderer));
        let mean_e = mean_spot_e(cfg, &renderer);
        let arms = arms
            .iter()
            .map(|a| {
                let readout = models.get(a.model).ok_or_else(|| {
                    Error::invalid(
                        "models",
                        format!("arm of model {} of {}", a.model, models.len()),
                    )
                })?;
                let ctx = CentroidContext {
                    subap_px: cfg.subap_px,
                    levels_e: &levels,
                    mean_e: &mean_e,
                    spot: cfg.spot,
                    sampling: cfg.sampling,
                    median_sigma_e: readout.median_sigma_e(),
                };
                let centroider = a.centroider.build(&ctx)?;
                Ok(BuiltArm {
                    model: a.model,
                    label: a.centroider.label(),
                    settings: centroider.settings(),
                    centroider,
                })
            })
            .collect::<Result<Vec<_>>>()?;
        Ok(Experiment {
            cfg: cfg.clone(),
            models: models.to_vec(),
            totals: arms.iter().map(|a| a.centroider.sums()).collect(),
            arms,
            renderer,
            mean_e,
            blocks: None,
            moment_blocks: None,
            done: 0,
        })
    }

    /// Also keep the sums per block of iterations, for [`Experiment::paired_se`].
    pub fn with_blocks(mut self) -> Self {
        let sizes: Vec<usize> = self.arms.iter().map(|a| a.settings.len()).collect();
        self.blocks = Some(Blocks::new(&sizes));
        let moment_sizes: Vec<usize> = Moment::ALL.iter().flat_map(|_| sizes.clone()).collect();
        self.moment_blocks = Some(Blocks::new(&moment_sizes));
        self
    }

    /// Iterations run so far.
    pub fn iters(&self) -> u64 {
        self.done
    }

    /// Run iterations up to `iters` (from those already run; at most [`SimConfig::MAX_ITERS`]).
    /// `observer` is advanced by `weight` x the iterations of each chunk as it finishes (the
    /// caller begins and ends the stage and chooses the unit).
    pub fn extend_to(&mut self, iters: u64, observer: &dyn Observer, weight: u64) -> Result<()> {
        if iters > SimConfig::MAX_ITERS {
            return Err(Error::invalid(
                "iters",
                format!(
                    "{iters}: at most {:e} iterations",
                    SimConfig::MAX_ITERS as f64
                ),
            ));
        }
        let (start, end) = (self.done, iters.max(self.done));
        // Chunks are aligned on multiples of CHUNK from the start of the run; the first may be
        // partial when the experiment is continued.
        let chunks = (start / CHUNK)..end.div_ceil(CHUNK);
        let sub = if self.blocks.is_some() {
            SUB_BLOCK
        } else {
            CHUNK
        };
        // Chunks run in parallel a batch at a time and are merged in chunk order, so the sums do
        // not depend on the thread count and memory does not grow with the iterations.
        for batch in chunks.clone().step_by(BATCH_CHUNKS as usize) {
            if observer.cancelled() {
                // Batches already merged stay: the experiment is consistent, only shorter.
                return Err(Error::Interrupted);
            }
            let this = &*self;
            let partials: Vec<ChunkSums> = (batch..(batch + BATCH_CHUNKS).min(chunks.end))
                .into_par_iter()
                .map(|c| {
                    let first = (c * CHUNK).max(start);
                    let last = ((c + 1) * CHUNK).min(end);
                    let sums = this.run_chunk(first..last, sub);
                    observer.advance((last - first) * weight);
                    sums
                })
                .collect();
            for part in partials {
                for (t, p) in self.totals.iter_mut().zip(&part.totals) {
                    t.merge(p);
                }
                if let (Some(blocks), Some(moments)) =
                    (self.blocks.as_mut(), self.moment_blocks.as_mut())
                {
                    for (first, count, sums, moment_sums) in &part.blocks {
                        blocks.add(*first, *count, sums);
                        moments.add(*first, *count, moment_sums);
                    }
                }
            }
            self.done = ((batch + BATCH_CHUNKS) * CHUNK).min(end);
        }
        self.done = end;
        Ok(())
    }

    /// Every arm's result over the iterations run so far (with [`Experiment::new`], one per
    /// model). An error when an arm's mean radial error is not finite at some setting: its
    /// readout's values overflowed the centroid sums (an amplitude beyond any camera's), and
    /// an empty R with SE 0 is no result.
    pub fn results(&self) -> Result<Vec<SimResult>> {
        self.arms
            .iter()
            .zip(&self.totals)
            .map(|(a, acc)| {
                let readout = self.models[a.model];
                let head = Head {
                    model: readout.name(),
                    centroider: a.label.clone(),
                    param_name: a.centroider.param_name(),
                };
                let result = summarise(head, acc, &a.settings, &self.cfg, self.done);
                finite(result, readout.noise_scale_e())
            })
            .collect()
    }

    /// Standard error (px) of the linear combination sum(coef x R) of `terms` (arms at
    /// settings, e.g. a result's [`SimResult::best`]), from the scatter of block means: it
    /// carries the correlation of arms run on common random numbers. Infinite without blocks
    /// kept or with fewer than two blocks.
    pub fn paired_se(&self, terms: &[Term]) -> f64 {
        self.blocks
            .as_ref()
            .map_or(f64::INFINITY, |b| b.standard_error(terms))
    }

    /// The per-block sums kept (with [`Experiment::with_blocks`]), for standard errors of
    /// combinations across runs of the same iterations ([`Blocks::standard_error_across`]).
    pub(crate) fn blocks(&self) -> Option<&Blocks> {
        self.blocks.as_ref()
    }

    /// Standard error of the linear combination sum(coef x mean moment) of `terms`, from the
    /// scatter of block means as [`Experiment::paired_se`] (in the moments' units). Infinite
    /// without blocks kept or with fewer than two blocks.
    pub fn paired_se_moments(&self, terms: &[MomentTerm]) -> f64 {
        let arms = self.arms.len();
        let terms: Vec<Term> = terms
            .iter()
            .map(|t| Term {
                model: t.moment as usize * arms + t.arm,
                level: t.setting,
                coef: t.coef,
            })
            .collect();
        self.moment_blocks
            .as_ref()
            .map_or(f64::INFINITY, |b| b.standard_error(&terms))
    }

    /// Run iterations `iters` for every arm, in sub-blocks of `sub` iterations (aligned on
    /// multiples of `sub`).
    fn run_chunk(&self, iters: std::ops::Range<u64>, sub: u64) -> ChunkSums {
        let scene = Scene {
            cfg: &self.cfg,
            renderer: &self.renderer,
            models: &self.models,
            mean_e: &self.mean_e,
        };
        let mut out = ChunkSums {
            totals: self.arms.iter().map(|a| a.centroider.sums()).collect(),
            blocks: Vec::new(),
        };
        let mut accs = out.totals.clone();
        let mut workers: Vec<_> = self.arms.iter().map(|a| a.centroider.worker()).collect();
        let mut batch = BatchFrames::new(&scene, &self.arms);
        let (mut first, mut block_start) = (iters.start, iters.start);
        while first < iters.end {
            // Batches of consecutive frames within a sub-block: the centroiders take a batch at
            // a time (the plain centre of gravity sweeps it in vector lanes).
            let end = (first + LANES as u64)
                .min((first / sub + 1) * sub)
                .min(iters.end);
            for (lane, it) in (first..end).enumerate() {
                batch.simulate(&scene, it, lane);
            }
            batch.centroid(&scene, (end - first) as usize, &mut workers, &mut accs);
            first = end;
            if end.is_multiple_of(sub) || end == iters.end {
                // A sub-block ends: its sums join the chunk's (into zeros when it is the whole
                // chunk, which leaves them exact) and, when kept, the block list.
                if self.blocks.is_some() {
                    let finished: Vec<_> = accs.iter().map(|a| (a.finish(), a.moments())).collect();
                    let sums = finished
                        .iter()
                        .flat_map(|(t, _)| t.iter().map(|&(s, _, _)| s))
                        .collect();
                    let moment_sums = Moment::ALL
                        .iter()
                        .flat_map(|m| finished.iter().flat_map(|(t, ms)| m.sums(t, ms)))
                        .collect();
                    out.blocks
                        .push((block_start, end - block_start, sums, moment_sums));
                }
                for (t, a) in out.totals.iter_mut().zip(accs.iter_mut()) {
                    t.merge(a);
                    a.clear();
                }
                block_start = end;
            }
        }
        out
    }
}

/// Expected photo-electrons per pixel of the spot at the sub-aperture centre, scaled to S x QE
/// in the sub-aperture (zeros when nothing of it falls inside).
pub(crate) fn mean_spot_e(cfg: &SimConfig, renderer: &SpotRenderer) -> Vec<f64> {
    let mut img = vec![0.0; cfg.subap_px * cfg.subap_px];
    renderer.render(0.0, 0.0, &mut img);
    let total: f64 = img.iter().sum();
    let scale = if total > 0.0 {
        cfg.signal_photons * cfg.qe / total
    } else {
        0.0
    };
    img.iter_mut().for_each(|v| *v *= scale);
    img
}

/// Brightest expected pixel (e-) of a centred spot: sizes the automatic background grid.
fn peak_expected_e(cfg: &SimConfig, renderer: &SpotRenderer) -> f64 {
    let mut img = vec![0.0; cfg.subap_px * cfg.subap_px];
    renderer.render(0.0, 0.0, &mut img);
    let total: f64 = img.iter().sum();
    let peak = img.iter().cloned().fold(0.0, f64::max);
    if total > 0.0 {
        peak / total * cfg.signal_photons * cfg.qe
    } else {
        0.0
    }
}

/// `result` if its R is finite at every setting; else an error naming the model, the setting
/// and the readout's noise scale (`scale_e`, e-).
fn finite(result: SimResult, scale_e: f64) -> Result<SimResult> {
    let Some(bad) = result
        .levels
        .iter()
        .find(|l| !(l.r_px.is_finite() && l.r_se_px.is_finite()))
    else {
        return Ok(result);
    };
    let at = match bad.param {
        Some(p) => format!("parameter {p}, background {} e-", bad.b_e),
        None => format!("background {} e-", bad.b_e),
    };
    Err(Error::Numeric(format!(
        "{} through {}: the mean radial error is not finite ({at}): the readout's values \
         (noise scale {scale_e:e} e-) overflow the centroid sums; no camera reads that noisily, \
         check the amplitudes given (noise map, RTS levels, gains)",
        result.model, result.centroider
    )))
}

/// What names a result: its model, centroider and the centroider's parameter name.
struct Head {
    model: String,
    centroider: String,
    param_name: Option<&'static str>,
}

/// The result of one arm from its sums over `iters` iterations at `settings`.
fn summarise(
    head: Head,
    acc: &SettingSums,
    settings: &[Setting],
    cfg: &SimConfig,
    iters: u64,
) -> SimResult {
    let n = iters as f64;
    let totals = acc.finish();
    let stats: Vec<LevelStats> = settings
        .iter()
        .zip(totals.iter().copied())
        .map(|(s, (sum, sum_sq, empty))| {
            let mean = sum / n;
            let var = ((sum_sq / n - mean * mean) * n / (n - 1.0)).max(0.0);
            LevelStats {
                param: s.param,
                b_e: s.b_e,
                r_px: mean,
                r_se_px: (var / n).sqrt(),
                empty_frames: empty,
            }
        })
        .collect();
    let limit = (cfg.max_empty_frac * n).floor() as u64;
    let eligible: Vec<usize> = (0..stats.len())
        .filter(|&k| stats[k].empty_frames <= limit)
        .collect();
    let no_eligible_level = eligible.is_empty();
    let candidates = if no_eligible_level {
        let fewest = stats.iter().map(|s| s.empty_frames).min().unwrap_or(0);
        (0..stats.len())
            .filter(|&k| stats[k].empty_frames == fewest)
            .collect()
    } else {
        eligible
    };
    let best = candidates
        .into_iter()
        .min_by(|&a, &b| stats[a].r_px.total_cmp(&stats[b].r_px))
        .expect("at least one level");
    // The optimum's sweep: the settings of its part (one background sweep, or the whole
    // parameter sweep of `tcog` and `brightest-n`).
    let part = settings[best].part;
    let first = settings.iter().position(|s| s.part == part).unwrap_or(best);
    let last_of_sweep = settings.get(best + 1).is_none_or(|s| s.part != part);
    SimResult {
        model: head.model,
        centroider: head.centroider,
        param_name: head.param_name,
        param_opt: settings[best].param,
        r_px: stats[best].r_px,
        r_se_px: stats[best].r_se_px,
        b_opt_e: stats[best].b_e,
        b_at_grid_edge: last_of_sweep && stats.len() > 1,
        no_eligible_level,
        r0_px: stats[first].r_px,
        r0_se_px: stats[first].r_se_px,
        zero_frames: stats[best].empty_frames,
        parts: ErrorParts::of(totals[best].1, &acc.moments()[best], n),
        best,
        levels: stats,
    }
}

#[cfg(test)]
mod tests;
