//! The effective QE factor of the paper's simple EMCCD model: the q whose `emccd-simple:q` (with
//! the camera's read noise over its EM gain) has the R of a detector, to a stated precision.
//!
//! The paper recommends its simple model (QE halved, 0.1 e- read noise) for AO design; this
//! says which factor reproduces an EMCCD's R in each configuration, with its standard error
//! from the paired difference on common random numbers (the effective read noise's solver,
//! over the simple model's family).

use super::family::SimpleQe;
use super::precision::Precision;
use super::solve::{solve, Outcome, References};
use crate::centroid::CentroiderSpec;
use crate::detector::{EmccdSimple, Readout};
use crate::montecarlo::SimConfig;
use crate::progress::Observer;
use crate::{Error, Result};

/// How precise each effective QE factor must be, and the iteration cap per configuration. A
/// factor is `ok` when its standard error meets either target.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct QePrecision {
    /// Absolute target for the standard error of the QE factor (unitless); 0 turns it off.
    pub target_se: f64,
    /// Relative target: the standard error at most this fraction of the factor; 0 turns it off.
    pub target_rel: f64,
    /// Most iterations (frames) the final runs of one configuration may use.
    pub max_iters: u64,
}

impl Default for QePrecision {
    fn default() -> Self {
        QePrecision {
            target_se: Self::DEFAULT_TARGET_SE,
            target_rel: Precision::DEFAULT_TARGET_REL,
            max_iters: Precision::DEFAULT_MAX_ITERS,
        }
    }
}

impl QePrecision {
    /// Default absolute target of the QE factor's standard error (unitless): 2 SE then
    /// resolve a 0.02 departure from the paper's 0.5.
    pub const DEFAULT_TARGET_SE: f64 = 0.01;

    /// The absolute target `target_se` with the relative target and the cap of `precision`.
    pub fn with(precision: &Precision, target_se: f64) -> Self {
        QePrecision {
            target_se,
            target_rel: precision.target_rel,
            max_iters: precision.max_iters,
        }
    }

    /// The solver's precision (its arithmetic does not depend on the unit).
    fn as_precision(&self) -> Precision {
        Precision {
            target_se_e: self.target_se,
            target_rel: self.target_rel,
            max_iters: self.max_iters,
        }
    }

    /// Check the targets and the cap against the starting iterations `iters`; the error names
    /// the field (`qe_target_se`, `target_rel`, `max_iters`).
    pub fn validate(&self, iters: u64) -> Result<()> {
        if !(self.target_se.is_finite() && self.target_se >= 0.0) {
            return Err(Error::invalid(
                "qe_target_se",
                format!(
                    "{}: must be a number >= 0 (a QE factor's standard error; 0 turns the \
                     absolute target off)",
                    self.target_se
                ),
            ));
        }
        self.as_precision().validate(iters)
    }
}

/// How an effective QE factor was settled.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum QeStatus {
    /// Bracketed and interpolated, and its standard error meets the precision target.
    Ok,
    /// Bracketed and interpolated, but the iteration cap was reached first.
    Imprecise,
    /// The detector does at least as well as the simple model keeping every photo-electron.
    AboveRange,
    /// The detector does worse than the simple model at the smallest factor tried.
    BelowRange,
    /// No background level left at most `max_empty_frac` of the detector's frames empty.
    NoEligibleLevel,
}

impl QeStatus {
    /// Every status, in the order the help and the page explain them.
    pub const ALL: [QeStatus; 5] = [
        QeStatus::Ok,
        QeStatus::Imprecise,
        QeStatus::AboveRange,
        QeStatus::BelowRange,
        QeStatus::NoEligibleLevel,
    ];

    /// The status word of tables and pages.
    pub fn label(self) -> &'static str {
        match self {
            QeStatus::Ok => "ok",
            QeStatus::Imprecise => "imprecise",
            QeStatus::AboveRange => "above_range",
            QeStatus::BelowRange => "below_range",
            QeStatus::NoEligibleLevel => "no_eligible_level",
        }
    }

    /// What the status means, in one sentence (for `--help`, the README and the page).
    pub fn meaning(self) -> &'static str {
        match self {
            QeStatus::Ok => "the standard error meets the precision target: a result",
            QeStatus::Imprecise => {
                "the iteration cap was reached before the standard error met the target: \
                 value and SE shown for information, not a result"
            }
            QeStatus::AboveRange => {
                "the camera does at least as well as the simple model keeping every \
                 photo-electron: the factor is 1 or more (1 is given)"
            }
            QeStatus::BelowRange => {
                "the camera does worse than the simple model at the smallest factor tried \
                 (0.03): no value"
            }
            QeStatus::NoEligibleLevel => {
                "every background level leaves more frames empty than the empty-frame limit \
                 allows: no valid optimum, so no value"
            }
        }
    }

    /// Whether a factor is given (possibly as a bound or for information).
    pub fn has_value(self) -> bool {
        matches!(
            self,
            QeStatus::Ok | QeStatus::Imprecise | QeStatus::AboveRange
        )
    }
}

/// The effective QE factor of one configuration.
#[derive(Debug, Clone, serde::Serialize)]
pub struct QeFactor {
    /// QE factor q of `emccd-simple` giving the detector's R (unitless); NaN when `status`
    /// gives no value.
    pub qe_factor: f64,
    /// Its standard error, from the paired difference of the R values; NaN without a value.
    pub qe_factor_se: f64,
    /// The standard error the factor had to reach; None without a target or a value.
    pub target_se: Option<f64>,
    /// Read noise of the simple model (e-, referred to the input): the camera's over its gain.
    pub read_noise_e: f64,
    /// Iterations (frames) of the final runs the value rests on.
    pub iters: u64,
    /// The detector's R (px).
    pub r_px: f64,
    /// Standard error of the detector's R (px).
    pub r_se_px: f64,
    /// The detector's best background level (e-).
    pub b_opt_e: f64,
    /// QE factors of the final run, descending.
    pub qe_grid: Vec<f64>,
    /// R of the simple model at each of them (px).
    pub r_simple_px: Vec<f64>,
    /// How the value was settled.
    pub status: QeStatus,
}

impl QeFactor {
    /// The factor's departure from the paper's 0.5 in standard errors, for a value with a
    /// finite, positive SE (`ok` or `imprecise`).
    pub fn paper_z(&self) -> Option<f64> {
        let z = (self.qe_factor - EmccdSimple::PAPER_FACTOR) / self.qe_factor_se;
        (matches!(self.status, QeStatus::Ok | QeStatus::Imprecise) && z.is_finite()).then_some(z)
    }
}

/// Solve for the QE factor of `emccd-simple` with read noise `read_noise_e` (e-, referred to the
/// input: the camera's output read noise over its EM gain) whose R equals `detector`'s in
/// `cfg` (`cfg.iters` the starting count) to `precision`. `observer` is advanced in
/// pixel-frames (see [`super::planned_work`], the same plan) and grown by work added beyond
/// it; the caller begins and ends the stage.
pub fn effective_qe(
    cfg: &SimConfig,
    detector: &dyn Readout,
    read_noise_e: f64,
    precision: &QePrecision,
    observer: &dyn Observer,
) -> Result<QeFactor> {
    precision.validate(cfg.iters)?;
    // The family's references check the read noise; do it here, before any run.
    EmccdSimple::new(1.0, read_noise_e)?;
    let family = SimpleQe { read_noise_e };
    let s = solve(
        cfg,
        (detector, CentroiderSpec::default()),
        References::cog(),
        &family,
        &precision.as_precision(),
        observer,
    )?;
    Ok(QeFactor {
        qe_factor: s.value,
        qe_factor_se: s.se,
        target_se: s.target,
        read_noise_e,
        iters: s.iters,
        r_px: s.det.r_px,
        r_se_px: s.det.r_se_px,
        b_opt_e: s.det.b_opt_e,
        qe_grid: s.grid,
        r_simple_px: s.r_ref_px,
        status: match s.outcome {
            Outcome::Ok => QeStatus::Ok,
            Outcome::Imprecise => QeStatus::Imprecise,
            Outcome::AtFoot => QeStatus::AboveRange,
            Outcome::Beyond => QeStatus::BelowRange,
            Outcome::NoEligibleLevel => QeStatus::NoEligibleLevel,
        },
    })
}

#[cfg(test)]
mod tests;
