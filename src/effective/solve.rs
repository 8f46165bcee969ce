//! The solver: the constant sigma whose Monte-Carlo error R equals a detector's, to a stated
//! precision.
//!
//! R grows monotonically with a constant sigma. A short pilot run on a wide geometric grid
//! (with sigma = 0, the noiseless readout, at its foot) locates the answer; the final runs then
//! evaluate the detector beside four constant sigmas tightly around the pilot estimate, all on
//! common random numbers (same spots, photons and Gaussian deviates), and interpolate inside
//! the bracket. Until the standard error meets the [`Precision`] target, the same experiment is
//! continued with more iterations (up to the cap). Where the answer leaves that bracket (R too
//! flat in sigma for the pilot to place it: high signal, shot noise dominates), a wide grid
//! decides, continued the same way.
//!
//! The standard error is that of the paired difference D = R_det - [(1 - t) R_lo + t R_hi]
//! (batch means over blocks of iterations, so the strong positive correlation that common
//! random numbers give the two sides is counted), divided by the slope of R in sigma.

use super::invert::{invert, Inversion, Outside};
use super::precision::Precision;
use super::status::Status;
use crate::centroid::CentroiderSpec;
use crate::detector::{Readout, ScmosConstant};
use crate::montecarlo::{Arm, Experiment, SimConfig, SimResult, Term};
use crate::progress::Observer;
use crate::Result;

/// Pilot grid: sigma = 0 (noiseless readout) and 1/4 to 4 times the detector's noise scale.
const PILOT_FACTORS: [f64; 8] = [0.0, 0.25, 0.397, 0.63, 1.0, 1.587, 2.52, 4.0];
/// Final grid around the pilot estimate.
const FINAL_FACTORS: [f64; 4] = [0.85, 0.95, 1.05, 1.18];
/// Fallback grid when R is too flat in sigma for the narrow bracket: 0 and 0.1 to 16 times the scale.
const WIDE_FACTORS: [f64; 12] = [0.0, 0.1, 0.2, 0.35, 0.5, 0.7, 1.0, 1.4, 2.0, 3.0, 6.0, 16.0];
/// Fraction of the starting iterations used by the pilot run...
const PILOT_FRACTION: f64 = 0.1;
/// ...and its least number of frames (never more than the starting iterations).
const PILOT_MIN_ITERS: u64 = 500;

/// The effective read noise of one configuration.
#[derive(Debug, Clone, serde::Serialize)]
pub struct Effective {
    /// Constant sigma giving the detector's R (e-); NaN when `status` gives no value.
    pub sigma_eff_e: f64,
    /// Standard error of sigma_eff (e-), from the paired difference of the R values; NaN when
    /// `status` gives no value.
    pub sigma_eff_se_e: f64,
    /// The standard error the value had to reach (e-): the larger of the absolute target and
    /// the relative one times the value; None without a target or without a value.
    pub target_se_e: Option<f64>,
    /// Iterations (frames) of the final runs the value rests on.
    pub iters: u64,
    /// The detector's R (px).
    pub r_px: f64,
    /// Standard error of the detector's R (px).
    pub r_se_px: f64,
    /// The detector's best background level (e-).
    pub b_opt_e: f64,
    /// Name (with unit) of the detector's centroider parameter; None for `cog`.
    pub param_name: Option<&'static str>,
    /// The centroider's parameter at the detector's optimum.
    pub param_opt: Option<f64>,
    /// Constant sigmas of the final run (e-), ascending.
    pub sigma_grid_e: Vec<f64>,
    /// R of the constant-sigma model at each of them (px).
    pub r_const_px: Vec<f64>,
    /// How the value was settled (ok, imprecise, lower_bound, unreachable, no_eligible_level).
    pub status: Status,
}

/// Pixels of one frame of `cfg`: a model-frame costs about this many pixel operations.
fn pixels(cfg: &SimConfig) -> u64 {
    (cfg.subap_px * cfg.subap_px) as u64
}

fn pilot_iters(cfg: &SimConfig) -> u64 {
    ((cfg.iters as f64 * PILOT_FRACTION) as u64)
        .max(PILOT_MIN_ITERS)
        .min(cfg.iters)
}

/// Work (pixel-frames: iterations x models x pixels) that solving `cfg` is sure to spend: the
/// pilot and the first final run. [`effective_sigma`] grows its observer's stage by any work it
/// adds (fallback grid, extra iterations), so a stage begun with the sum of these ends with
/// exactly its total advanced.
pub fn planned_work(cfg: &SimConfig) -> u64 {
    let pilot = pilot_iters(cfg) * (1 + PILOT_FACTORS.len() as u64);
    let first = cfg.iters * (1 + FINAL_FACTORS.len() as u64);
    (pilot + first) * pixels(cfg)
}

/// Solve for the effective read noise of `detector` in configuration `cfg` (`cfg.iters` is the
/// starting iteration count) to `precision`. `observer` is advanced in pixel-frames (see
/// [`planned_work`]) and grown by the work added beyond the plan; the caller begins and ends
/// the stage.
pub fn effective_sigma(
    cfg: &SimConfig,
    detector: &dyn Readout,
    precision: &Precision,
    observer: &dyn Observer,
) -> Result<Effective> {
    effective_sigma_with(
        cfg,
        detector,
        CentroiderSpec::default(),
        precision,
        observer,
    )
}

/// [`effective_sigma`] for `detector` read through `centroider`: the constant sigma whose
/// plain-`cog` R equals the detector's R under that centroider ("with masking, this camera
/// behaves like a uniform 1.4 e- camera"). The constant-sigma references always use `cog`.
pub fn effective_sigma_with(
    cfg: &SimConfig,
    detector: &dyn Readout,
    centroider: CentroiderSpec,
    precision: &Precision,
    observer: &dyn Observer,
) -> Result<Effective> {
    cfg.validate()?;
    precision.validate(cfg.iters)?;
    centroider.validate()?;
    let scale = detector.noise_scale_e().max(1e-3);
    let s = Solver {
        cfg,
        detector,
        centroider,
        precision,
        observer,
    };
    let guess = s.pilot(scale)?;
    let mut budget = Budget {
        prepaid: cfg.iters * (1 + FINAL_FACTORS.len() as u64) * pixels(cfg),
    };
    let mut start = cfg.iters;
    if guess > 0.0 {
        let grid = scaled(&FINAL_FACTORS, guess);
        let constants = constants(&grid);
        let models = with_detector(detector, &constants);
        match s.refine(&models, &grid, start, &mut budget)? {
            Refined::Settled(e) => return Ok(e),
            Refined::Outside(_, exp) => start = exp.iters(),
        }
    }
    let grid = scaled(&WIDE_FACTORS, scale.max(guess));
    let constants = constants(&grid);
    let models = with_detector(detector, &constants);
    Ok(match s.refine(&models, &grid, start, &mut budget)? {
        Refined::Settled(e) => e,
        Refined::Outside(side, exp) => s.bound(side, &exp, &grid),
    })
}

/// What one solve works with.
struct Solver<'a> {
    cfg: &'a SimConfig,
    detector: &'a dyn Readout,
    centroider: CentroiderSpec,
    precision: &'a Precision,
    observer: &'a dyn Observer,
}

/// Work planned before the solve began and not yet spent (pixel-frames).
struct Budget {
    prepaid: u64,
}

impl Budget {
    /// About to spend `work`: what the plan does not cover grows the observer's stage.
    fn spend(&mut self, work: u64, observer: &dyn Observer) {
        let covered = work.min(self.prepaid);
        self.prepaid -= covered;
        if work > covered {
            observer.grow(work - covered);
        }
    }
}

/// The outcome of the runs on one grid.
enum Refined<'m> {
    /// A value (or a status) was settled.
    Settled(Effective),
    /// The detector's R left the grid; the experiment as it stood.
    Outside(Outside, Box<Experiment<'m>>),
}

fn scaled(factors: &[f64], s: f64) -> Vec<f64> {
    factors.iter().map(|f| f * s).collect()
}

fn constants(grid: &[f64]) -> Vec<ScmosConstant> {
    grid.iter()
        .map(|s| ScmosConstant::new(*s, format!("scmos-constant:{s}")))
        .collect()
}

/// The models of a run: the detector first, then the constants.
fn with_detector<'m>(
    detector: &'m dyn Readout,
    constants: &'m [ScmosConstant],
) -> Vec<&'m dyn Readout> {
    std::iter::once(detector)
        .chain(constants.iter().map(|c| c as &dyn Readout))
        .collect()
}

/// The detector's result and the constants', from an experiment's results.
fn split(mut results: Vec<SimResult>) -> (SimResult, Vec<SimResult>) {
    let det = results.remove(0);
    (det, results)
}

impl Solver<'_> {
    /// An experiment of `models` (the detector first, then constants): the detector read
    /// through the chosen centroider, the constants through `cog`.
    fn experiment<'m>(
        &self,
        cfg: &SimConfig,
        models: &[&'m dyn Readout],
    ) -> Result<Experiment<'m>> {
        let arms: Vec<Arm> = (0..models.len())
            .map(|model| Arm {
                model,
                centroider: if model == 0 {
                    self.centroider
                } else {
                    CentroiderSpec::default()
                },
            })
            .collect();
        Experiment::with_arms(cfg, models, &arms)
    }

    /// The pilot's estimate of sigma_eff (e-): 0 below its grid, its top above it. The pilot
    /// uses other streams than the final runs, so its noise does not bias the final grid.
    fn pilot(&self, scale: f64) -> Result<f64> {
        let cfg = SimConfig {
            iters: pilot_iters(self.cfg),
            seed: self.cfg.seed ^ 0x0091_1107,
            ..self.cfg.clone()
        };
        let grid = scaled(&PILOT_FACTORS, scale);
        let constants = constants(&grid);
        let models = with_detector(self.detector, &constants);
        let mut exp = self.experiment(&cfg, &models)?;
        let weight = models.len() as u64 * pixels(&cfg);
        exp.extend_to(cfg.iters, self.observer, weight)?;
        let (det, consts) = split(exp.results());
        Ok(match invert(det.r_px, &r_values(&consts), &grid) {
            Ok(inv) => inv.sigma,
            Err(Outside::Below) => 0.0,
            Err(Outside::Above) => grid[grid.len() - 1],
        })
    }

    /// Run `models` (the detector, then constants at `grid`) from `start` iterations, and
    /// continue the experiment until the value meets the target or the cap is reached.
    fn refine<'m>(
        &self,
        models: &[&'m dyn Readout],
        grid: &[f64],
        start: u64,
        budget: &mut Budget,
    ) -> Result<Refined<'m>> {
        let weight = models.len() as u64 * pixels(self.cfg);
        let mut exp = self.experiment(self.cfg, models)?.with_blocks();
        let mut to = start;
        loop {
            budget.spend((to - exp.iters()) * weight, self.observer);
            exp.extend_to(to, self.observer, weight)?;
            let runs = split(exp.results());
            let (det, consts) = (&runs.0, &runs.1);
            if det.no_eligible_level {
                let none = (f64::NAN, f64::NAN);
                let e = self.assemble(&exp, &runs, grid, none, Status::NoEligibleLevel);
                return Ok(Refined::Settled(e));
            }
            let inv = match invert(det.r_px, &r_values(consts), grid) {
                Ok(inv) => inv,
                Err(side) => return Ok(Refined::Outside(side, Box::new(exp))),
            };
            let (sigma, se) = (inv.sigma, paired_se(&exp, det, consts, &inv));
            let status = if self.precision.met(sigma, se) {
                Status::Ok
            } else if exp.iters() >= self.precision.max_iters {
                Status::Imprecise
            } else {
                let target = self
                    .precision
                    .target_for(sigma)
                    .expect("a target was missed");
                to = self.precision.next_iters(exp.iters(), se, target);
                continue;
            };
            let e = self.assemble(&exp, &runs, grid, (sigma, se), status);
            return Ok(Refined::Settled(e));
        }
    }

    /// The result when the detector's R lies outside R of the whole wide `grid` (`grid[0]` =
    /// 0): a lower bound of 0 below it, unreachable above it.
    fn bound(&self, side: Outside, exp: &Experiment, grid: &[f64]) -> Effective {
        let runs = split(exp.results());
        let (det, consts) = (&runs.0, &runs.1);
        match side {
            Outside::Below => {
                // The SE of a value at the foot of the grid: R_det - R(0) over the first slope.
                let at_zero = Inversion {
                    sigma: 0.0,
                    slope: (consts[1].r_px - consts[0].r_px) / (grid[1] - grid[0]),
                    weights: vec![(0, 1.0)],
                };
                let se = paired_se(exp, det, consts, &at_zero);
                self.assemble(exp, &runs, grid, (0.0, se), Status::LowerBound)
            }
            Outside::Above => {
                let none = (f64::NAN, f64::NAN);
                self.assemble(exp, &runs, grid, none, Status::Unreachable)
            }
        }
    }

    /// A result from the experiment on `grid`, its results `(detector, constants)` and the
    /// solved (sigma, SE) in e-.
    fn assemble(
        &self,
        exp: &Experiment,
        (det, consts): &(SimResult, Vec<SimResult>),
        grid: &[f64],
        (sigma, se): (f64, f64),
        status: Status,
    ) -> Effective {
        let has_value = !matches!(status, Status::Unreachable | Status::NoEligibleLevel);
        Effective {
            sigma_eff_e: sigma,
            sigma_eff_se_e: se,
            target_se_e: self.precision.target_for(sigma).filter(|_| has_value),
            iters: exp.iters(),
            r_px: det.r_px,
            r_se_px: det.r_se_px,
            b_opt_e: det.b_opt_e,
            param_name: det.param_name,
            param_opt: det.param_opt,
            sigma_grid_e: grid.to_vec(),
            r_const_px: consts.iter().map(|c| c.r_px).collect(),
            status,
        }
    }
}

/// R of each result (px).
fn r_values(results: &[SimResult]) -> Vec<f64> {
    results.iter().map(|r| r.r_px).collect()
}

/// Standard error of sigma (e-) from the paired difference D = R_det - sum w_i R_i (each at
/// its own best level) over the slope; infinite where R is flat.
fn paired_se(exp: &Experiment, det: &SimResult, consts: &[SimResult], inv: &Inversion) -> f64 {
    if inv.slope <= 0.0 {
        return f64::INFINITY;
    }
    let term = |model: usize, r: &SimResult, coef: f64| Term {
        model,
        level: r.best,
        coef,
    };
    let terms: Vec<Term> = std::iter::once(term(0, det, 1.0))
        .chain(
            inv.weights
                .iter()
                .map(|&(i, w)| term(i + 1, &consts[i], -w)),
        )
        .collect();
    exp.paired_se(&terms) / inv.slope
}

#[cfg(test)]
mod tests;
