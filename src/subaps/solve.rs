//! One sub-aperture's effective read noise: its fixed window of the measured noise map read
//! as a per-pixel readout (`scmos-fixed` with that window), its R inverted on the job's
//! constant-sigma ladder (`ladder`) at the first checkpoint that meets the precision target,
//! with the paired standard error of `effective` (batch means of R_window - sum w_i R_i, the
//! window's blocks beside the ladder's: the same iterations, common random numbers).

use super::geometry::Subap;
use super::ladder::Ladder;
use crate::calib::{Map, Unit};
use crate::centroid::CentroiderSpec;
use crate::detector::{PerPixelSigma, Readout};
use crate::effective::{
    effective_sigma_with, invert, random_sigma_unpaired, Effective, EffectiveParts, Inversion,
    Outside, Precision, Status,
};
use crate::montecarlo::{Arm, Blocks, Experiment, SimConfig, SimResult, Term};
use crate::progress::Observer;
use crate::{Error, Result};
use std::ops::Range;

/// A measured noise map (e-) ready to be cut into windows: non-finite pixels read with the
/// rms of the map's finite pixels, as `scmos-map` reads them.
#[derive(Debug, Clone)]
pub struct NoiseMap<'a> {
    /// The map (e-).
    pub map: &'a Map,
    /// sqrt(mean sigma^2) of the finite pixels (e-): the value of a non-finite pixel.
    pub fill_e: f64,
    /// Median of the finite pixels (e-): masking is relative to the camera's median.
    pub median_e: f64,
}

impl<'a> NoiseMap<'a> {
    /// Check that `map` is in e- and has a finite pixel; errors name its source.
    pub fn new(map: &'a Map) -> Result<Self> {
        if map.unit != Unit::Electrons {
            return Err(Error::input(
                &map.source,
                format!(
                    "noise map is in {}, not e-: give a map in electrons (e.g. rms_e.fits from \
                     darks)",
                    map.unit.bunit()
                ),
            ));
        }
        let (sum, n) = map
            .data
            .iter()
            .filter(|v| v.is_finite())
            .fold((0.0, 0usize), |(s, n), v| (s + v * v, n + 1));
        if n == 0 {
            return Err(Error::input(&map.source, "noise map has no finite pixel"));
        }
        Ok(NoiseMap {
            map,
            fill_e: (sum / n as f64).sqrt(),
            median_e: crate::stats::median(&map.data),
        })
    }

    /// The raw map values of `s`'s `n` x `n` window, row-major (non-finite ones kept).
    pub fn window(&self, s: &Subap, n: usize) -> Vec<f64> {
        let cols = self.map.cols;
        (0..n)
            .flat_map(|i| {
                let start = (s.y0_px + i) * cols + s.x0_px;
                self.map.data[start..start + n].iter().copied()
            })
            .collect()
    }

    /// The readout of `s`'s window: each pixel's own sigma, a non-finite one `fill_e`.
    pub fn readout(&self, s: &Subap, n: usize) -> PerPixelSigma {
        let sigma = self
            .window(s, n)
            .into_iter()
            .map(|v| if v.is_finite() { v } else { self.fill_e })
            .collect();
        PerPixelSigma::new(sigma, format!("subap:{}", s.index)).with_median_e(self.median_e)
    }
}

/// What the map holds in one window: the median and rms of its finite pixels (e-) and how
/// many are not finite.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct WindowStats {
    /// Median of the finite pixels (e-; NaN when none).
    pub median_e: f64,
    /// sqrt(mean sigma^2) of the finite pixels (e-; NaN when none).
    pub rms_e: f64,
    /// Non-finite pixels (read with the map's rms).
    pub nonfinite_px: usize,
}

impl WindowStats {
    /// The statistics of `values` (one window).
    pub fn of(values: &[f64]) -> WindowStats {
        let finite: Vec<f64> = values.iter().copied().filter(|v| v.is_finite()).collect();
        let rms = if finite.is_empty() {
            f64::NAN
        } else {
            (finite.iter().map(|v| v * v).sum::<f64>() / finite.len() as f64).sqrt()
        };
        WindowStats {
            median_e: crate::stats::median(&finite),
            rms_e: rms,
            nonfinite_px: values.len() - finite.len(),
        }
    }
}

/// The effective read noise of sub-aperture `s` solved on its own: its window of `map` read as
/// a fixed per-pixel readout, solved in configuration `cfg` (its `subap_px` the window's side)
/// to `precision`, read through `centroider`, exactly as [`effective_sigma_with`] solves any
/// detector (its own references around its own estimate). A job solves its sub-apertures on
/// the shared ladder instead (the same value within the SE, at a fraction of the cost).
pub fn solve_subap(
    cfg: &SimConfig,
    map: &NoiseMap,
    s: &Subap,
    centroider: CentroiderSpec,
    precision: &Precision,
    observer: &dyn Observer,
) -> Result<Effective> {
    let detector = map.readout(s, cfg.subap_px);
    effective_sigma_with(cfg, &detector, centroider, precision, observer)
}

/// Check that `centroider` can read the windows of configuration `cfg` (e.g. brightest-n's N
/// below the window's pixels) by building it as each solve does, for `readout` (a window of
/// the map, or any window of its size when the map is not read yet), before any work.
pub fn check_centroider(
    cfg: &SimConfig,
    centroider: CentroiderSpec,
    readout: &dyn Readout,
) -> Result<()> {
    Experiment::with_arms(
        cfg,
        &[readout],
        &[Arm {
            model: 0,
            centroider,
        }],
    )
    .map(|_| ())
}

/// Most sub-apertures run together in one experiment: they share each frame's spot, photons
/// and deviates (drawn once for all), and each reads them through its own window.
pub(super) const GROUP: usize = 16;

/// Where a sub-aperture stands after a checkpoint: settled, or to be run again to a later
/// checkpoint (its index).
pub(super) enum Step {
    /// Settled.
    Done(Box<Effective>),
    /// Short of its target: run again to this checkpoint.
    More(usize),
}

/// Run the windows of `group` (sub-apertures of `map`, each with the checkpoint of `ladder`
/// it is to be evaluated at) beside each other, evaluating each at its checkpoint and then at
/// the later one it asks for, while at least half the group is still running (the others
/// ride along) and the ladder has reached it; the rest are sent on to a later round.
/// `observer` is advanced in pixel-frames.
///
/// Every run stops at the first checkpoint (the starting iterations, not always whole chunks)
/// and then only at whole chunks, so a window's sums at a checkpoint are the same bits however
/// its run got there.
pub(super) fn solve_group(
    (cfg, map, centroider): (&SimConfig, &NoiseMap, CentroiderSpec),
    ladder: &Ladder,
    group: &[(usize, Subap)],
    precision: &Precision,
    observer: &dyn Observer,
) -> Result<Vec<Step>> {
    let readouts: Vec<PerPixelSigma> = group
        .iter()
        .map(|(_, s)| map.readout(s, cfg.subap_px))
        .collect();
    let models: Vec<&dyn Readout> = readouts.iter().map(|r| r as &dyn Readout).collect();
    let arms: Vec<Arm> = (0..models.len())
        .map(|model| Arm { model, centroider })
        .collect();
    let mut exp = Experiment::with_arms(cfg, &models, &arms)?.with_blocks();
    let weight = (models.len() * cfg.subap_px * cfg.subap_px) as u64;
    let mut asked: Vec<Option<usize>> = group.iter().map(|g| Some(g.0)).collect();
    let mut steps: Vec<Option<Step>> = group.iter().map(|_| None).collect();
    while let Some(k) = asked.iter().flatten().min().copied() {
        let pending = asked.iter().flatten().count();
        let first = exp.iters() == 0;
        if !first && (2 * pending < group.len() || k >= ladder.reached()) {
            for (step, ask) in steps.iter_mut().zip(&mut asked) {
                if let Some(k) = ask.take() {
                    *step = Some(Step::More(k));
                }
            }
            break;
        }
        exp.extend_to(ladder.checkpoints[0], observer, weight)?;
        exp.extend_to(ladder.checkpoints[k], observer, weight)?;
        let at = Checkpoint {
            ladder,
            k,
            blocks: exp.blocks().expect("blocks are kept"),
        };
        for (arm, det) in exp.results()?.into_iter().enumerate() {
            if asked[arm] != Some(k) {
                continue;
            }
            match at.settle(arm, det, precision) {
                Step::More(next) => asked[arm] = Some(next),
                done => (steps[arm], asked[arm]) = (Some(done), None),
            }
        }
    }
    Ok(steps
        .into_iter()
        .map(|s| s.expect("every member settled or sent on"))
        .collect())
}

/// A group's run at one checkpoint of the ladder.
struct Checkpoint<'a> {
    ladder: &'a Ladder<'a>,
    k: usize,
    /// The group's per-block sums.
    blocks: &'a Blocks,
}

/// A window's R read on one set of the ladder's arms.
enum Reading {
    /// Inside the ladder: sigma (e-) and its paired standard error (e-).
    Inside(f64, f64),
    /// At or below the noiseless readout: 0, with the SE of the difference over the first slope.
    AtFoot(f64),
    /// Above the ladder's top: no value.
    Beyond,
}

impl Checkpoint<'_> {
    /// Settle the window of arm `arm` (its result `det`), or send it on.
    fn settle(&self, arm: usize, det: SimResult, precision: &Precision) -> Step {
        let iters = self.ladder.checkpoints[self.k];
        let (value, se, status) = if det.no_eligible_level {
            (f64::NAN, f64::NAN, Status::NoEligibleLevel)
        } else {
            match self.read(arm, &det, self.ladder.own()) {
                Reading::Beyond => (f64::NAN, f64::NAN, Status::Unreachable),
                Reading::AtFoot(se) => (0.0, se, Status::LowerBound),
                Reading::Inside(v, se) if precision.met(v, se) => (v, se, Status::Ok),
                Reading::Inside(v, se) if self.k + 1 == self.ladder.checkpoints.len() => {
                    (v, se, Status::Imprecise)
                }
                Reading::Inside(v, se) => {
                    let target = precision.target_for(v).expect("a target was missed");
                    let want = precision.next_iters(iters, se, target);
                    let next = (self.k + 1..self.ladder.checkpoints.len())
                        .find(|&j| self.ladder.checkpoints[j] >= want)
                        .unwrap_or(self.ladder.checkpoints.len() - 1);
                    return Step::More(next);
                }
            }
        };
        let has_value = !matches!(status, Status::Unreachable | Status::NoEligibleLevel);
        let (cog_e, cog_se_e) = if !has_value {
            (f64::NAN, f64::NAN)
        } else if !self.ladder.cog_arms {
            (value, se)
        } else {
            match self.read(arm, &det, self.ladder.cog()) {
                Reading::Inside(v, se) => (v, se),
                Reading::AtFoot(se) => (0.0, se),
                Reading::Beyond => (f64::NAN, f64::NAN),
            }
        };
        let own = &self.ladder.at(self.k).results[self.ladder.own()];
        let random = random_sigma_unpaired(&det, own, &self.ladder.sigmas);
        Step::Done(Box::new(Effective {
            sigma_eff_e: value,
            sigma_eff_se_e: se,
            target_se_e: precision.target_for(value).filter(|_| has_value),
            iters,
            r_px: det.r_px,
            r_se_px: det.r_se_px,
            b_opt_e: det.b_opt_e,
            param_name: det.param_name,
            param_opt: det.param_opt,
            sigma_grid_e: self.ladder.sigmas.clone(),
            r_const_px: own.iter().map(|r| r.r_px).collect(),
            status,
            sigma_cog_equiv_e: cog_e,
            sigma_cog_equiv_se_e: cog_se_e,
            parts: EffectiveParts::new(&det, random),
        }))
    }

    /// The window's R (arm `arm`, result `det`) inverted on the ladder's `arms`, with the
    /// paired SE of D = R_det - sum w_i R_i from the group's blocks beside the ladder's.
    fn read(&self, arm: usize, det: &SimResult, arms: Range<usize>) -> Reading {
        let snap = self.ladder.at(self.k);
        let refs = &snap.results[arms.clone()];
        let r: Vec<f64> = refs.iter().map(|c| c.r_px).collect();
        let sigmas = &self.ladder.sigmas;
        let (inv, at_foot) = match invert(det.r_px, &r, sigmas) {
            Ok(inv) => (inv, false),
            Err(Outside::Above) => return Reading::Beyond,
            Err(Outside::Below) => {
                let foot = Inversion {
                    x: sigmas[0],
                    slope: (r[1] - r[0]) / (sigmas[1] - sigmas[0]),
                    weights: vec![(0, 1.0)],
                };
                (foot, true)
            }
        };
        let se = if inv.slope > 0.0 {
            let own = [Term {
                model: arm,
                level: det.best,
                coef: 1.0,
            }];
            let references: Vec<Term> = inv
                .weights
                .iter()
                .map(|&(i, w)| Term {
                    model: arms.start + i,
                    level: 0,
                    coef: -w,
                })
                .collect();
            let parts = [(self.blocks, &own[..]), (&snap.blocks, &references[..])];
            Blocks::standard_error_across(&parts) / inv.slope
        } else {
            f64::INFINITY
        };
        if at_foot {
            Reading::AtFoot(se)
        } else {
            Reading::Inside(inv.x, se)
        }
    }
}
