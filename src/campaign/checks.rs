//! The checks of a campaign before any frame is read: every file present and given once,
//! every stack opened (headers only) and of one frame shape, the darks' conditions enough
//! for the decomposition (two exposure times at least, EM gain given for all darks or none).
//! What is refused is an error naming the file and what is missing; what only limits the
//! decomposition (one EM gain: clock-induced charge not separable from the offset) is a
//! note in the plan, reported and written to campaign.json.

use std::path::PathBuf;

use serde::Serialize;

use super::condition::StackKind;
use super::input::{CampaignStack, Listing};
use crate::error::{Error, Result};
use crate::io::{check_distinct, FrameStack};

/// Distinct exposure times the darks need: dark current is a slope in t.
pub const MIN_DARK_EXPOSURES: usize = 2;

/// Distinct EM gains EMCCD darks need for clock-induced charge (g C) to be told from the
/// fixed offset F.
pub const MIN_CIC_GAINS: usize = 2;

/// A campaign that passed the checks: its stacks opened (headers only), in input order.
#[derive(Debug)]
pub struct CampaignPlan {
    /// The stacks as listed.
    pub stacks: Vec<CampaignStack>,
    /// Each stack opened (headers read), same order.
    pub opened: Vec<FrameStack>,
    /// Frame shape (rows, cols) of every stack.
    pub shape: (usize, usize),
    /// What the campaign can and cannot separate.
    pub design: Design,
}

/// What the darks' conditions let the decomposition separate.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Design {
    /// Distinct exposure times of the darks (s), ascending.
    pub dark_exposures_s: Vec<f64>,
    /// Distinct commanded EM gains of the darks (e-/e-), ascending; empty without an EM
    /// register.
    pub dark_em_gains: Vec<f64>,
    /// Distinct temperatures of the darks (deg C), ascending; empty when not given.
    pub dark_temperatures_c: Vec<f64>,
    /// Whether clock-induced charge can be separated from the fixed offset (EMCCD darks at
    /// two gains or more); None without an EM register.
    pub cic_separable: Option<bool>,
    /// Notes on what cannot be separated, for the user.
    pub notes: Vec<String>,
}

/// Check `listing` and open its stacks (headers only), before any frame is read.
pub fn check_campaign(listing: Listing) -> Result<CampaignPlan> {
    let stacks = listing.stacks;
    for s in &stacks {
        for f in &s.files {
            if std::fs::metadata(f).is_err() {
                return Err(Error::input(
                    f,
                    format!(
                        "not found: the stack file listed{} is missing",
                        s.listed_in.describe()
                    ),
                ));
            }
        }
    }
    let files: Vec<PathBuf> = stacks.iter().flat_map(|s| s.files.clone()).collect();
    check_distinct(&files, "the campaign's stacks")?;
    let design = design_of(&stacks)?;
    let opened = stacks
        .iter()
        .map(|s| FrameStack::open(&s.files))
        .collect::<Result<Vec<FrameStack>>>()?;
    let shape = match listing.declared_shape {
        Some(shape) => shape,
        None => opened[0].shape,
    };
    for (s, o) in stacks.iter().zip(&opened) {
        if o.shape != shape {
            let first = match listing.declared_shape {
                Some(_) => "the descriptor's `n` line declares".to_string(),
                None => format!("{} has", stacks[0].files[0].display()),
            };
            return Err(Error::input(
                &s.files[0],
                format!(
                    "frames of {}x{} (rows x cols), but {first} {}x{}: a campaign is of one camera and one frame shape",
                    o.shape.0, o.shape.1, shape.0, shape.1
                ),
            ));
        }
        o.require_frames(2, "a temporal variance")?;
    }
    Ok(CampaignPlan {
        stacks,
        opened,
        shape,
        design,
    })
}

/// An error naming the first dark without `field` (`what` it is) when another gives it: the
/// decomposition needs it for every dark or for none (`none_means`).
fn all_or_none(
    darks: &[&CampaignStack],
    field: &str,
    what: &str,
    none_means: &str,
    get: impl Fn(&CampaignStack) -> Option<f64>,
) -> Result<()> {
    let with = darks.iter().find(|s| get(s).is_some());
    let without = darks.iter().find(|s| get(s).is_none());
    let (Some(with), Some(without)) = (with, without) else {
        return Ok(());
    };
    Err(Error::input(
        &without.files[0],
        format!(
            "{field} is missing{} while {}{} gives one: give {what} of every dark, or of none ({none_means})",
            without.listed_in.describe(),
            with.files[0].display(),
            with.listed_in.describe(),
        ),
    ))
}

/// The distinct values of `values`, ascending.
fn distinct(values: impl Iterator<Item = f64>) -> Vec<f64> {
    let mut v: Vec<f64> = values.collect();
    v.sort_by(f64::total_cmp);
    v.dedup();
    v
}

/// What the darks of `stacks` separate; an error for darks that cannot give a decomposition.
fn design_of(stacks: &[CampaignStack]) -> Result<Design> {
    let darks: Vec<&CampaignStack> = stacks
        .iter()
        .filter(|s| s.condition.kind == StackKind::Dark)
        .collect();
    let Some(first) = darks.first() else {
        return Err(Error::input(
            &stacks[0].listed_in.source,
            "no dark stack: the decomposition of the dark signal needs darks at two exposure times or more",
        ));
    };
    all_or_none(
        &darks,
        "em_gain",
        "the EM gain",
        "a camera without an EM register",
        |s| s.condition.em_gain,
    )?;
    all_or_none(
        &darks,
        "temperature_c",
        "the temperature",
        "no temperature term",
        |s| s.condition.temperature_c,
    )?;
    let dark_exposures_s = distinct(darks.iter().map(|s| s.condition.exposure_s));
    if dark_exposures_s.len() < MIN_DARK_EXPOSURES {
        return Err(Error::input(
            &first.listed_in.source,
            format!(
                "every dark is at exposure {} s: dark current is the slope of the dark signal in exposure time and needs darks at {MIN_DARK_EXPOSURES} exposure times or more",
                dark_exposures_s[0]
            ),
        ));
    }
    let dark_em_gains = distinct(darks.iter().filter_map(|s| s.condition.em_gain));
    let dark_temperatures_c = distinct(darks.iter().filter_map(|s| s.condition.temperature_c));
    let mut notes = Vec::new();
    let cic_separable = (!dark_em_gains.is_empty()).then_some(dark_em_gains.len() >= MIN_CIC_GAINS);
    if cic_separable == Some(false) {
        notes.push(format!(
            "every EMCCD dark is at EM gain {}: clock-induced charge (g C) is not separable from the fixed offset F, which then holds it; darks at {MIN_CIC_GAINS} gains or more separate them",
            dark_em_gains[0]
        ));
    }
    Ok(Design {
        dark_exposures_s,
        dark_em_gains,
        dark_temperatures_c,
        cic_separable,
        notes,
    })
}
