//! The solver: the constant sigma whose Monte-Carlo error R equals a detector's.
//!
//! R grows monotonically with a constant sigma. A short pilot run on a wide geometric grid
//! (with sigma = 0, the noiseless readout, at its foot) locates the answer; the full run then
//! evaluates the detector beside four constant sigmas tightly around the pilot estimate, all on
//! common random numbers (same spots, photons and Gaussian deviates), and interpolates inside
//! the bracket. Where R is too flat in sigma for that bracket (high signal: shot noise
//! dominates), a wide grid at full iterations decides.

use crate::detector::{Readout, ScmosConstant};
use crate::montecarlo::{run, SimConfig, SimResult};
use crate::progress::{Observer, Silent};
use crate::{Error, Result};

/// Pilot grid: sigma = 0 (noiseless readout) and 1/4 to 4 times the detector's noise scale.
const PILOT_FACTORS: [f64; 8] = [0.0, 0.25, 0.397, 0.63, 1.0, 1.587, 2.52, 4.0];
/// Final grid around the pilot estimate.
const FINAL_FACTORS: [f64; 4] = [0.85, 0.95, 1.05, 1.18];
/// Fallback grid when R is too flat in sigma for the narrow bracket: 0 and 0.1 to 16 times the scale.
const WIDE_FACTORS: [f64; 12] = [0.0, 0.1, 0.2, 0.35, 0.5, 0.7, 1.0, 1.4, 2.0, 3.0, 6.0, 16.0];
/// Fraction of the iterations used by the pilot run (at least 500 frames).
const PILOT_FRACTION: f64 = 0.1;

/// The effective read noise of one configuration.
#[derive(Debug, Clone, serde::Serialize)]
pub struct Effective {
    /// Constant sigma giving the detector's R (e-).
    pub sigma_eff_e: f64,
    /// Standard error of sigma_eff (e-), from the standard errors of both R values.
    pub sigma_eff_se_e: f64,
    /// The detector's R (px).
    pub r_px: f64,
    /// Standard error of the detector's R (px).
    pub r_se_px: f64,
    /// The detector's best background level (e-).
    pub b_opt_e: f64,
    /// Constant sigmas of the final run (e-), ascending.
    pub sigma_grid_e: Vec<f64>,
    /// R of the constant-sigma model at each of them (px).
    pub r_const_px: Vec<f64>,
    /// Whether sigma_eff was found, is 0, or does not exist.
    pub status: Status,
}

/// How the effective read noise was settled. Only `Ok` values are results; the others are
/// printed as their status word (and, for `Imprecise`, the value with its SE beside it).
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Status {
    /// Bracketed and interpolated, and its standard error meets the precision target.
    Ok,
    /// Bracketed and interpolated, but the iteration cap was reached before the standard error
    /// met the target: R is too flat in sigma here for the value to be used.
    Imprecise,
    /// The detector's R is at or below that of a noiseless readout: sigma_eff is 0.
    LowerBound,
    /// The detector's R exceeds R of every constant sigma (up to 16x its noise scale): a few very
    /// noisy pixels pull the centroid more than any uniform noise does, so no Gaussian read
    /// noise reproduces it. sigma_eff is NaN (empty in CSV, null in JSON).
    Unreachable,
    /// No background level left at most `max_empty_frac` of the detector's frames empty, so its
    /// R is not a valid optimum and no sigma_eff is given.
    NoEligibleLevel,
}

impl Status {
    /// Every status, in the order the README and the page explain them.
    pub const ALL: [Status; 5] = [
        Status::Ok,
        Status::Imprecise,
        Status::LowerBound,
        Status::Unreachable,
        Status::NoEligibleLevel,
    ];

    /// The status word of tables and pages (`ok`, `imprecise`, `lower_bound`, ...).
    pub fn label(self) -> &'static str {
        match self {
            Status::Ok => "ok",
            Status::Imprecise => "imprecise",
            Status::LowerBound => "lower_bound",
            Status::Unreachable => "unreachable",
            Status::NoEligibleLevel => "no_eligible_level",
        }
    }

    /// What the status means, in one sentence (for `--help`, the README and the page).
    pub fn meaning(self) -> &'static str {
        match self {
            Status::Ok => "the standard error meets the precision target: a result",
            Status::Imprecise => {
                "the iteration cap was reached before the standard error met the target: \
                 value and SE shown for information, not a result"
            }
            Status::LowerBound => {
                "the camera does at least as well as a noiseless readout: sigma_eff is 0"
            }
            Status::Unreachable => {
                "no constant sigma gives an error as large as this camera's (a few very noisy \
                 pixels dominate): simulate the measured map or the fitted pdf instead"
            }
            Status::NoEligibleLevel => {
                "no background level leaves at most `max_empty_frac` of the frames empty: no \
                 valid optimum, so no value"
            }
        }
    }
}

#[cfg(test)]
mod status_tests {
    use super::Status;

    #[test]
    fn labels_are_the_serialised_words() {
        for s in Status::ALL {
            assert_eq!(serde_json::to_value(s).unwrap(), s.label());
            assert!(!s.meaning().is_empty());
        }
    }
}

/// Solve for the effective read noise of `detector` in configuration `cfg`. `observer` is
/// advanced by the iterations of the full-length runs (not the pilot); the caller begins and
/// ends the stage.
pub fn effective_sigma(
    cfg: &SimConfig,
    detector: &dyn Readout,
    observer: &dyn Observer,
) -> Result<Effective> {
    let scale = detector.noise_scale_e().max(1e-3);
    let grid_of = |factors: &[f64], s: f64| -> Vec<f64> { factors.iter().map(|f| f * s).collect() };
    let mut pilot_cfg = cfg.clone();
    pilot_cfg.iters = ((cfg.iters as f64 * PILOT_FRACTION) as u64)
        .max(500)
        .min(cfg.iters);
    // The pilot uses other streams than the final run, so its noise does not bias the final grid.
    pilot_cfg.seed = cfg.seed ^ 0x0091_1107;
    let guess = match solve_on_grid(
        &pilot_cfg,
        detector,
        grid_of(&PILOT_FACTORS, scale),
        &Silent,
    ) {
        Ok(e) => e.sigma_eff_e,
        Err(Outside::Below) => 0.0,
        Err(Outside::Above) => PILOT_FACTORS[PILOT_FACTORS.len() - 1] * scale,
        Err(Outside::Failed(e)) => return Err(e),
    };
    if guess > 0.0 {
        match solve_on_grid(cfg, detector, grid_of(&FINAL_FACTORS, guess), observer) {
            Ok(e) => return Ok(e),
            Err(Outside::Failed(e)) => return Err(e),
            Err(Outside::Below) | Err(Outside::Above) => {}
        }
    }
    let wide = grid_of(&WIDE_FACTORS, scale.max(guess));
    let (det, consts) = run_grid(cfg, detector, &wide, observer)?;
    match interpolate(&det, &consts, &wide) {
        Ok(e) => Ok(e),
        Err(Outside::Below) => Ok(bound(&det, &consts, &wide, Status::LowerBound)),
        Err(Outside::Above) => Ok(bound(&det, &consts, &wide, Status::Unreachable)),
        Err(Outside::Failed(e)) => Err(e),
    }
}

/// The result when the detector's R lies outside R of the whole wide `grid` (`grid[0]` = 0).
fn bound(det: &SimResult, consts: &[SimResult], grid: &[f64], status: Status) -> Effective {
    let slope = (consts[1].r_px - consts[0].r_px) / (grid[1] - grid[0]);
    let (sigma, se) = match status {
        Status::LowerBound if slope > 0.0 => (
            0.0,
            (det.r_se_px.powi(2) + consts[0].r_se_px.powi(2)).sqrt() / slope,
        ),
        Status::LowerBound => (0.0, f64::INFINITY),
        _ => (f64::NAN, f64::NAN),
    };
    effective(det, consts, grid, (sigma, se), status)
}

/// Assemble a result from the runs on `grid` and the solved (sigma, SE) in e-.
fn effective(
    det: &SimResult,
    consts: &[SimResult],
    grid: &[f64],
    (sigma, se): (f64, f64),
    status: Status,
) -> Effective {
    Effective {
        sigma_eff_e: sigma,
        sigma_eff_se_e: se,
        r_px: det.r_px,
        r_se_px: det.r_se_px,
        b_opt_e: det.b_opt_e,
        sigma_grid_e: grid.to_vec(),
        r_const_px: consts.iter().map(|c| c.r_px).collect(),
        status,
    }
}

/// Run the detector beside constant-sigma models on `grid` (common random numbers).
fn run_grid(
    cfg: &SimConfig,
    detector: &dyn Readout,
    grid: &[f64],
    observer: &dyn Observer,
) -> Result<(SimResult, Vec<SimResult>)> {
    let constants: Vec<ScmosConstant> = grid
        .iter()
        .map(|s| ScmosConstant::new(*s, format!("scmos-constant:{s}")))
        .collect();
    let mut models: Vec<&dyn Readout> = vec![detector];
    models.extend(constants.iter().map(|c| c as &dyn Readout));
    let mut results = run(cfg, &models, observer)?;
    let det = results.remove(0);
    Ok((det, results))
}

/// Why a grid did not give an answer.
enum Outside {
    /// The detector's R is below R at the smallest sigma.
    Below,
    /// The detector's R is above R at the largest sigma.
    Above,
    /// The simulation itself failed.
    Failed(Error),
}

impl From<Error> for Outside {
    fn from(e: Error) -> Self {
        Outside::Failed(e)
    }
}

fn solve_on_grid(
    cfg: &SimConfig,
    detector: &dyn Readout,
    grid: Vec<f64>,
    observer: &dyn Observer,
) -> std::result::Result<Effective, Outside> {
    let (det, consts) = run_grid(cfg, detector, &grid, observer)?;
    interpolate(&det, &consts, &grid)
}

fn interpolate(
    det: &SimResult,
    consts: &[SimResult],
    grid: &[f64],
) -> std::result::Result<Effective, Outside> {
    // Monte-Carlo noise can make neighbouring R values cross; a running maximum keeps the
    // curve monotone (as it is in expectation) before inversion.
    let mut r: Vec<f64> = consts.iter().map(|c| c.r_px).collect();
    for k in 1..r.len() {
        r[k] = r[k].max(r[k - 1]);
    }
    if det.r_px < r[0] {
        return Err(Outside::Below);
    }
    if det.r_px > r[r.len() - 1] {
        return Err(Outside::Above);
    }
    let k = (1..r.len()).find(|&k| r[k] >= det.r_px).expect("bracketed");
    let slope = (r[k] - r[k - 1]) / (grid[k] - grid[k - 1]);
    let t = if r[k] > r[k - 1] {
        (det.r_px - r[k - 1]) / (r[k] - r[k - 1])
    } else {
        0.5
    };
    let sigma = grid[k - 1] + t * (grid[k] - grid[k - 1]);
    // Treating the two R estimates as independent overstates the error a little: common
    // random numbers correlate them positively.
    let se_const = (1.0 - t) * consts[k - 1].r_se_px + t * consts[k].r_se_px;
    let se = if slope > 0.0 {
        (det.r_se_px.powi(2) + se_const.powi(2)).sqrt() / slope
    } else {
        f64::INFINITY
    };
    Ok(effective(det, consts, grid, (sigma, se), Status::Ok))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn constant_detector_has_its_own_sigma() {
        // A detector that is itself constant-sigma must come back at that sigma: with common
        // random numbers the identical model reproduces R exactly at sigma, so the only error
        // is the interpolation across the 10 % bracket, far below the reported SE.
        let mut cfg = SimConfig::paper(6);
        cfg.iters = 3000;
        for sigma in [0.7, 1.6] {
            let det = ScmosConstant::new(sigma, "det".into());
            let e = effective_sigma(&cfg, &det, &Silent).unwrap();
            assert!(
                e.sigma_eff_se_e > 0.0 && e.sigma_eff_se_e < 0.2 * sigma,
                "se {}",
                e.sigma_eff_se_e
            );
            assert!(
                (e.sigma_eff_e - sigma).abs() < 2.0 * e.sigma_eff_se_e,
                "{sigma}: {e:?}"
            );
        }
    }

    #[test]
    fn paper_pdf_is_worse_than_its_median_for_large_subapertures() {
        // The paper's finding: the median (0.79 e-) is optimistic; the heavy tail matters more
        // the more pixels a sub-aperture has.
        let mut cfg = SimConfig::paper(12);
        cfg.iters = 3000;
        let det = crate::detector::ScmosRandom::new(std::sync::Arc::new(crate::pdf::paper()));
        let e = effective_sigma(&cfg, &det, &Silent).unwrap();
        assert!(e.sigma_eff_e - 3.0 * e.sigma_eff_se_e > 0.7944, "{e:?}");
    }
}
