//! The solver: the reference readout (a constant sigma, or the simple EMCCD model's QE factor:
//! see `family`) whose Monte-Carlo error R equals a detector's, to a stated precision.
//!
//! R grows monotonically along the family's abscissa. A short pilot run on a wide grid (with
//! the family's foot, e.g. sigma = 0, the noiseless readout) locates the answer; the final
//! runs then evaluate the detector beside four references tightly around the pilot estimate,
//! all on common random numbers (same spots, photons and Gaussian deviates), and interpolate
//! inside the bracket. Until the standard error meets the [`Precision`] target, the same
//! experiment is continued with more iterations (up to the cap). Where the answer leaves that
//! bracket (R too flat for the pilot to place it: high signal, shot noise dominates), a wide
//! grid decides, continued the same way.
//!
//! The standard error is that of the paired difference D = R_det - [(1 - t) R_lo + t R_hi]
//! (batch means over blocks of iterations, so the strong positive correlation that common
//! random numbers give the two sides is counted), divided by the slope of R along the grid.

use super::family::{ConstantSigma, Family, FINAL_POINTS, PILOT_POINTS};
use super::invert::{invert, Inversion, Outside};
use super::precision::Precision;
use super::status::Status;
use crate::centroid::CentroiderSpec;
use crate::detector::Readout;
use crate::montecarlo::{Arm, Experiment, SimConfig, SimResult, Term};
use crate::progress::Observer;
use crate::Result;

/// Fraction of the starting iterations used by the pilot run...
const PILOT_FRACTION: f64 = 0.1;
/// ...and its least number of frames (never more than the starting iterations).
const PILOT_MIN_ITERS: u64 = 500;

/// The effective read noise of one configuration.
#[derive(Debug, Clone, serde::Serialize)]
pub struct Effective {
    /// Constant sigma whose R under the detector's own centroider (its parameter re-optimised
    /// at that sigma) equals the detector's R (e-): the read noise for a simulator that runs
    /// that centroider. NaN when `status` gives no value.
    pub sigma_eff_e: f64,
    /// Standard error of sigma_eff (e-), from the paired difference of the R values; NaN when
    /// `status` gives no value.
    pub sigma_eff_se_e: f64,
    /// Cog-equivalent (e-): the constant sigma whose plain-`cog` R equals the detector's R
    /// under its centroider, from the same experiment (common random numbers); equal to
    /// sigma_eff for `cog`. 0 when the detector does at least as well as a noiseless `cog`
    /// readout; NaN when no constant sigma reaches it or the detector has no value.
    pub sigma_cog_equiv_e: f64,
    /// Standard error of the cog-equivalent (e-), from its paired difference; NaN without a
    /// value. The precision target drives sigma_eff only.
    pub sigma_cog_equiv_se_e: f64,
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
    /// The detector's static offset and the constant sigma of its random part (flattened in
    /// tables: `sigma_random_e`, `static_px`, ...).
    #[serde(flatten)]
    pub parts: super::random::EffectiveParts,
}

/// How a solve over a family ended.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) enum Outcome {
    /// Bracketed, and the standard error meets the target.
    Ok,
    /// Bracketed, but the cap was reached first.
    Imprecise,
    /// The detector does at least as well as the family's foot: the value is the foot's.
    AtFoot,
    /// The detector does worse than every reference of the wide grid: no value.
    Beyond,
    /// The detector has no eligible background level: no value.
    NoEligibleLevel,
}

/// A solve over a family, in the family's values.
#[derive(Debug, Clone)]
pub(super) struct Solved {
    /// The value (the family's parameter); NaN without one.
    pub value: f64,
    /// Its standard error; NaN without a value.
    pub se: f64,
    /// The standard error the value had to reach; None without a target or a value.
    pub target: Option<f64>,
    /// Iterations of the final runs.
    pub iters: u64,
    /// The detector's result.
    pub det: SimResult,
    /// The references' parameters of the final run, in the order of the abscissa.
    pub grid: Vec<f64>,
    /// R of each reference (px).
    pub r_ref_px: Vec<f64>,
    /// The cog-equivalent (value, SE) where the references are read through another
    /// centroider than `cog` (NaN without a value); None when they are read through `cog`.
    pub cog_equiv: Option<(f64, f64)>,
    /// How it ended.
    pub outcome: Outcome,
    /// The detector's static offset and random sigma against the final grid's references.
    pub parts: super::random::EffectiveParts,
}

/// Pixels of one frame of `cfg`: an arm-frame (a model's frame read through one centroider)
/// costs about this many pixel operations.
fn pixels(cfg: &SimConfig) -> u64 {
    (cfg.subap_px * cfg.subap_px) as u64
}

fn pilot_iters(cfg: &SimConfig) -> u64 {
    ((cfg.iters as f64 * PILOT_FRACTION) as u64)
        .max(PILOT_MIN_ITERS)
        .min(cfg.iters)
}

/// References of the cog-equivalent's final grid besides the [`FINAL_POINTS`] around its
/// estimate: the family's foot and the top of its wide grid, so that the grid always brackets.
const COG_EXTRA_POINTS: usize = 2;

/// Work (pixel-frames: iterations x arms x pixels) that solving `cfg` with the detector and
/// the references read through `cog` is sure to spend (for the effective read noise and the
/// effective QE factor alike): the pilot and the first final run. [`effective_sigma`] grows
/// its observer's stage by any work it adds (fallback grid, extra iterations), so a stage
/// begun with the sum of these ends with exactly its total advanced.
pub fn planned_work(cfg: &SimConfig) -> u64 {
    planned_work_with(cfg, &CentroiderSpec::default())
}

/// [`planned_work`] for a detector read through `centroider`: another centroider than `cog`
/// adds the cog-equivalent's arms (the pilot's references read through `cog` too, and a final
/// grid of their own).
pub fn planned_work_with(cfg: &SimConfig, centroider: &CentroiderSpec) -> u64 {
    let extra = u64::from(!is_cog(centroider));
    let pilot = pilot_iters(cfg) * (1 + PILOT_POINTS as u64 * (1 + extra)) * pixels(cfg);
    pilot + first_run_work(cfg, extra == 1)
}

/// Work of the first final run (pixel-frames), with or without the cog-equivalent's arms.
fn first_run_work(cfg: &SimConfig, cog_equiv: bool) -> u64 {
    let cog_points = usize::from(cog_equiv) * (FINAL_POINTS + COG_EXTRA_POINTS);
    cfg.iters * (1 + FINAL_POINTS + cog_points) as u64 * pixels(cfg)
}

fn is_cog(centroider: &CentroiderSpec) -> bool {
    *centroider == CentroiderSpec::default()
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

/// [`effective_sigma`] for `detector` read through `centroider`: the constant sigma whose R
/// under the same centroider (its parameter and background re-optimised per sigma, as the
/// detector's are) equals the detector's R: the number for a simulator that runs that
/// centroider. For another centroider than `cog`, the same experiment also reads the
/// references through `cog` and gives the cog-equivalent with its paired SE. `observer` is
/// advanced as [`planned_work_with`] plans.
pub fn effective_sigma_with(
    cfg: &SimConfig,
    detector: &dyn Readout,
    centroider: CentroiderSpec,
    precision: &Precision,
    observer: &dyn Observer,
) -> Result<Effective> {
    let family = ConstantSigma {
        scale_e: detector.noise_scale_e().max(1e-3),
    };
    let refs = References {
        via: centroider,
        cog_equiv: !is_cog(&centroider),
    };
    let s = solve(
        cfg,
        (detector, centroider),
        refs,
        &family,
        precision,
        observer,
    )?;
    Ok(Effective {
        sigma_eff_e: s.value,
        sigma_eff_se_e: s.se,
        sigma_cog_equiv_e: s.cog_equiv.map_or(s.value, |c| c.0),
        sigma_cog_equiv_se_e: s.cog_equiv.map_or(s.se, |c| c.1),
        target_se_e: s.target,
        iters: s.iters,
        r_px: s.det.r_px,
        r_se_px: s.det.r_se_px,
        b_opt_e: s.det.b_opt_e,
        param_name: s.det.param_name,
        param_opt: s.det.param_opt,
        sigma_grid_e: s.grid,
        r_const_px: s.r_ref_px,
        status: match s.outcome {
            Outcome::Ok => Status::Ok,
            Outcome::Imprecise => Status::Imprecise,
            Outcome::AtFoot => Status::LowerBound,
            Outcome::Beyond => Status::Unreachable,
            Outcome::NoEligibleLevel => Status::NoEligibleLevel,
        },
        parts: s.parts,
    })
}

/// How the references of a solve are read.
#[derive(Debug, Clone, Copy)]
pub(super) struct References {
    /// The centroider the references are read through (the value is solved against them).
    pub via: CentroiderSpec,
    /// Whether the same experiment also reads references through `cog` for the
    /// cog-equivalent (on a grid of its own, around its own pilot estimate).
    pub cog_equiv: bool,
}

impl References {
    /// Every reference read through `cog`, no cog-equivalent (the QE factor's family).
    pub fn cog() -> Self {
        References {
            via: CentroiderSpec::default(),
            cog_equiv: false,
        }
    }
}

/// Solve for the reference of `family` whose R equals `detector`'s in `cfg`, to `precision`
/// (in the family's values), the detector read through its centroider and the references as
/// `refs` says; `observer` as for [`effective_sigma`].
pub(super) fn solve(
    cfg: &SimConfig,
    (detector, centroider): (&dyn Readout, CentroiderSpec),
    refs: References,
    family: &dyn Family,
    precision: &Precision,
    observer: &dyn Observer,
) -> Result<Solved> {
    cfg.validate()?;
    precision.validate(cfg.iters)?;
    centroider.validate()?;
    refs.via.validate()?;
    let s = Solver {
        cfg,
        detector,
        centroider,
        refs,
        family,
        precision,
        observer,
    };
    let (guess, cog_guess) = s.pilot()?;
    let cog_grid = cog_guess.map(|g| s.cog_grid(g));
    let mut budget = Budget {
        prepaid: first_run_work(cfg, refs.cog_equiv),
    };
    let mut start = cfg.iters;
    // A pilot estimate at either end of its grid brackets nothing: below the foot there is
    // nothing to bracket, and above the top the value may lie anywhere up the wide grid (a
    // bracket around the top of the pilot grid was tried, and missed, in 40 of the 40 such
    // solves of the default report), so the wide grid is run at once.
    let pilot_top = family.pilot().last().copied().unwrap_or(f64::INFINITY);
    if !family.at_foot(guess) && guess < pilot_top {
        let grids = Grids {
            main: family.around(guess),
            cog: cog_grid.clone(),
        };
        let references = grids.references(family);
        let models = with_detector(detector, &references);
        match s.refine(&models, &grids, start, &mut budget)? {
            Refined::Settled(e) => return Ok(*e),
            Refined::Outside(_, exp) => start = exp.iters(),
        }
    }
    let grids = Grids {
        main: family.wide(guess),
        cog: cog_grid,
    };
    let references = grids.references(family);
    let models = with_detector(detector, &references);
    Ok(match s.refine(&models, &grids, start, &mut budget)? {
        Refined::Settled(e) => *e,
        Refined::Outside(side, exp) => s.bound(side, &exp, &grids)?,
    })
}

/// What one solve works with.
struct Solver<'a> {
    cfg: &'a SimConfig,
    detector: &'a dyn Readout,
    centroider: CentroiderSpec,
    refs: References,
    family: &'a dyn Family,
    precision: &'a Precision,
    observer: &'a dyn Observer,
}

/// The abscissae of a run's references: those the value is solved on, then (for the
/// cog-equivalent) those read through `cog`.
#[derive(Debug, Clone)]
struct Grids {
    main: Vec<f64>,
    cog: Option<Vec<f64>>,
}

impl Grids {
    /// The family's references at every abscissa, main grid first.
    fn references(&self, family: &dyn Family) -> Vec<Box<dyn Readout>> {
        let cog = self.cog.as_deref().unwrap_or(&[]);
        references(family, &[&self.main[..], cog].concat())
    }
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
    Settled(Box<Solved>),
    /// The detector's R left the grid; the experiment as it stood.
    Outside(Outside, Box<Experiment<'m>>),
}

/// The family's references at the abscissae `grid`.
fn references(family: &dyn Family, grid: &[f64]) -> Vec<Box<dyn Readout>> {
    grid.iter().map(|&x| family.reference(x)).collect()
}

/// The models of a run: the detector first, then the references.
fn with_detector<'m>(
    detector: &'m dyn Readout,
    references: &'m [Box<dyn Readout>],
) -> Vec<&'m dyn Readout> {
    std::iter::once(detector)
        .chain(references.iter().map(|c| c.as_ref()))
        .collect()
}

/// An experiment's results by role: the detector's (arm 0), the references' the value is
/// solved on (arms 1..), and those read through `cog` for the cog-equivalent (the last arms).
struct Runs {
    det: SimResult,
    refs: Vec<SimResult>,
    cogs: Vec<SimResult>,
}

impl Runs {
    /// Split `results` with `main` references before the cog-equivalent's.
    fn split(mut results: Vec<SimResult>, main: usize) -> Self {
        let cogs = results.split_off(1 + main);
        let refs = results.split_off(1);
        Runs {
            det: results.remove(0),
            refs,
            cogs,
        }
    }
}

impl Solver<'_> {
    /// An experiment of `models` (the detector first, then `main` references, then any for
    /// the cog-equivalent): the detector read through its centroider, the `main` references
    /// through `refs.via`, and the cog-equivalent's through `cog`. With `cog_twice`, the
    /// `main` references are read through `cog` as well (the pilot's shared grid), as arms
    /// after all the others.
    fn experiment<'m>(
        &self,
        cfg: &SimConfig,
        models: &[&'m dyn Readout],
        main: usize,
        cog_twice: bool,
    ) -> Result<Experiment<'m>> {
        let arm = |model: usize, centroider: CentroiderSpec| Arm { model, centroider };
        let cog = CentroiderSpec::default();
        let mut arms = vec![arm(0, self.centroider)];
        arms.extend((1..=main).map(|m| arm(m, self.refs.via)));
        arms.extend((1 + main..models.len()).map(|m| arm(m, cog)));
        if cog_twice {
            arms.extend((1..=main).map(|m| arm(m, cog)));
        }
        Experiment::with_arms(cfg, models, &arms)
    }

    /// The pilot's estimates (abscissae) of the value and, with a cog-equivalent, of the
    /// cog-equivalent: the foot below its grid, its top above it. The pilot uses other streams
    /// than the final runs, so its noise does not bias the final grid.
    fn pilot(&self) -> Result<(f64, Option<f64>)> {
        let cfg = SimConfig {
            iters: pilot_iters(self.cfg),
            seed: self.cfg.seed ^ 0x0091_1107,
            ..self.cfg.clone()
        };
        let grid = self.family.pilot();
        let references = references(self.family, &grid);
        let models = with_detector(self.detector, &references);
        let mut exp = self.experiment(&cfg, &models, grid.len(), self.refs.cog_equiv)?;
        let weight = (1 + grid.len() * (1 + usize::from(self.refs.cog_equiv))) as u64;
        exp.extend_to(cfg.iters, self.observer, weight * pixels(&cfg))?;
        let runs = Runs::split(exp.results()?, grid.len());
        let estimate = |refs: &[SimResult]| match invert(runs.det.r_px, &r_values(refs), &grid) {
            Ok(inv) => inv.x,
            Err(Outside::Below) => grid[0],
            Err(Outside::Above) => grid[grid.len() - 1],
        };
        let cog = self.refs.cog_equiv.then(|| estimate(&runs.cogs));
        Ok((estimate(&runs.refs), cog))
    }

    /// The cog-equivalent's final grid given its pilot estimate `x`: the references around it
    /// between the family's foot and the top of its wide grid, so that it always brackets a
    /// reachable value (coarsely where the pilot missed); the wide grid when the estimate is at
    /// either end of the pilot's.
    fn cog_grid(&self, x: f64) -> Vec<f64> {
        let wide = self.family.wide(x);
        let pilot_top = self.family.pilot().last().copied().unwrap_or(f64::INFINITY);
        if self.family.at_foot(x) || x >= pilot_top {
            return wide;
        }
        let mut grid = vec![wide[0]];
        grid.extend(self.family.around(x));
        grid.push(wide[wide.len() - 1]);
        grid
    }

    /// Run `models` (the detector, then references at `grids`) from `start` iterations, and
    /// continue the experiment until the value meets the target or the cap is reached.
    fn refine<'m>(
        &self,
        models: &[&'m dyn Readout],
        grids: &Grids,
        start: u64,
        budget: &mut Budget,
    ) -> Result<Refined<'m>> {
        let weight = models.len() as u64 * pixels(self.cfg);
        let main = grids.main.len();
        let mut exp = self
            .experiment(self.cfg, models, main, false)?
            .with_blocks();
        let mut to = start;
        loop {
            budget.spend((to - exp.iters()) * weight, self.observer);
            exp.extend_to(to, self.observer, weight)?;
            let runs = Runs::split(exp.results()?, main);
            if runs.det.no_eligible_level {
                let none = (f64::NAN, f64::NAN);
                let e = self.assemble(&exp, &runs, grids, none, Outcome::NoEligibleLevel);
                return Ok(Refined::Settled(Box::new(e)));
            }
            let inv = match invert(runs.det.r_px, &r_values(&runs.refs), &grids.main) {
                Ok(inv) => inv,
                Err(side) => return Ok(Refined::Outside(side, Box::new(exp))),
            };
            let value = self.family.value(inv.x);
            let se = paired_se(&exp, &runs.det, (1, &runs.refs), &inv);
            let outcome = if self.precision.met(value, se) {
                Outcome::Ok
            } else if exp.iters() >= self.precision.max_iters {
                Outcome::Imprecise
            } else {
                let target = self
                    .precision
                    .target_for(value)
                    .expect("a target was missed");
                to = self.precision.next_iters(exp.iters(), se, target);
                continue;
            };
            let e = self.assemble(&exp, &runs, grids, (value, se), outcome);
            return Ok(Refined::Settled(Box::new(e)));
        }
    }

    /// The result when the detector's R lies outside R of the whole wide main grid (its first
    /// abscissa the foot): the foot's value below it, none above it.
    fn bound(&self, side: Outside, exp: &Experiment, grids: &Grids) -> Result<Solved> {
        let runs = Runs::split(exp.results()?, grids.main.len());
        Ok(match side {
            Outside::Below => {
                let (value, se) = self.at_foot(exp, &runs.det, (1, &runs.refs), &grids.main);
                self.assemble(exp, &runs, grids, (value, se), Outcome::AtFoot)
            }
            Outside::Above => {
                let none = (f64::NAN, f64::NAN);
                self.assemble(exp, &runs, grids, none, Outcome::Beyond)
            }
        })
    }

    /// The foot's value for a detector below R of every reference of `grid` (its first
    /// abscissa the foot; the references' results `refs` from arm `first` on), with the SE of
    /// R_det - R(foot) over the first slope.
    fn at_foot(
        &self,
        exp: &Experiment,
        det: &SimResult,
        (first, refs): (usize, &[SimResult]),
        grid: &[f64],
    ) -> (f64, f64) {
        let at_foot = Inversion {
            x: grid[0],
            slope: (refs[1].r_px - refs[0].r_px) / (grid[1] - grid[0]),
            weights: vec![(0, 1.0)],
        };
        let se = paired_se(exp, det, (first, refs), &at_foot);
        (self.family.value(grid[0]), se)
    }

    /// The cog-equivalent (value, SE) from the references read through `cog` (on
    /// `grids.cog`), None without them: NaN when the detector has no eligible level or does
    /// worse than every one of them, the foot's value when it does better.
    fn cog_equivalent(&self, exp: &Experiment, runs: &Runs, grids: &Grids) -> Option<(f64, f64)> {
        let grid = grids.cog.as_deref()?;
        let none = (f64::NAN, f64::NAN);
        if runs.det.no_eligible_level {
            return Some(none);
        }
        let first = 1 + grids.main.len();
        Some(match invert(runs.det.r_px, &r_values(&runs.cogs), grid) {
            Ok(inv) => {
                let se = paired_se(exp, &runs.det, (first, &runs.cogs), &inv);
                (self.family.value(inv.x), se)
            }
            Err(Outside::Below) => self.at_foot(exp, &runs.det, (first, &runs.cogs), grid),
            Err(Outside::Above) => none,
        })
    }

    /// A result from the experiment on `grids`, its results `runs` and the solved (value, SE).
    fn assemble(
        &self,
        exp: &Experiment,
        runs: &Runs,
        grids: &Grids,
        (value, se): (f64, f64),
        outcome: Outcome,
    ) -> Solved {
        let has_value = !matches!(outcome, Outcome::Beyond | Outcome::NoEligibleLevel);
        let grid_values: Vec<f64> = grids.main.iter().map(|&x| self.family.value(x)).collect();
        // The main references are arms 1..; the cog arms (if any) follow them.
        let random = super::random::random_sigma(exp, &runs.det, &runs.refs, &grid_values);
        Solved {
            value,
            se,
            target: self.precision.target_for(value).filter(|_| has_value),
            iters: exp.iters(),
            det: runs.det.clone(),
            grid: grid_values,
            r_ref_px: runs.refs.iter().map(|c| c.r_px).collect(),
            cog_equiv: self.cog_equivalent(exp, runs, grids),
            outcome,
            parts: super::random::EffectiveParts::new(&runs.det, random),
        }
    }
}

/// R of each result (px).
fn r_values(results: &[SimResult]) -> Vec<f64> {
    results.iter().map(|r| r.r_px).collect()
}

/// Standard error of the solved abscissa from the paired difference D = R_det - sum w_i R_i
/// (each at its own best level; the detector is arm 0, reference i of `refs` arm `first + i`)
/// over the slope; infinite where R is flat.
fn paired_se(
    exp: &Experiment,
    det: &SimResult,
    (first, refs): (usize, &[SimResult]),
    inv: &Inversion,
) -> f64 {
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
                .map(|&(i, w)| term(first + i, &refs[i], -w)),
        )
        .collect();
    exp.paired_se(&terms) / inv.slope
}

#[cfg(test)]
pub(super) mod tests;
