//! `detnoise campaign` as one library call: the input read and checked, every stack
//! streamed once, and conditions.csv and campaign.json written to an output directory that
//! appears only when the run succeeds.

use std::path::PathBuf;

use super::checks::{check_campaign, Design};
use super::input::CampaignInput;
use super::measure::{measure_campaign, MeasureOptions, StackMeasurement};
use super::outputs::{write_campaign_outputs, CampaignSummary, StackSummary, CAMPAIGN_OUTPUTS};
use crate::error::{Error, Result};
use crate::output::{DirPlan, OutputDir};
use crate::progress::Observer;

/// A campaign to measure.
#[derive(Clone, Debug)]
pub struct CampaignRun {
    /// Where the stacks and their conditions come from.
    pub input: CampaignInput,
    /// Output directory (replaced only if detnoise wrote it).
    pub out: PathBuf,
    /// Write into an existing `out` that holds other files (never replacing them).
    pub force: bool,
    /// How to measure each stack (conversion gain, checksums, EM fit).
    pub measure: MeasureOptions,
}

/// What a campaign run produced.
#[derive(Debug)]
pub struct CampaignRunResult {
    /// Every stack's measurement, in input order.
    pub stacks: Vec<StackMeasurement>,
    /// What the darks' conditions separate.
    pub design: Design,
    /// The output directory written.
    pub out: PathBuf,
    /// Bytes of sample data read, as stored.
    pub stored_bytes: u64,
    /// Wall-clock seconds spent reading and accumulating the stacks.
    pub read_seconds: f64,
}

/// Run a campaign: every check (input, output directory, stacks' headers) before any frame
/// is read; notes on what the design cannot separate and failed EM fits are reported to
/// `observer` as warnings.
pub fn run(job: &CampaignRun, observer: &dyn Observer) -> Result<CampaignRunResult> {
    let gain = job.measure.gain_e_per_adu;
    if !(gain > 0.0 && gain.is_finite()) {
        return Err(Error::invalid(
            "gain_e_per_adu",
            format!("{gain} is not a positive conversion gain (e- per adu)"),
        ));
    }
    let listing = job.input.read()?;
    let mut inputs: Vec<PathBuf> = listing
        .stacks
        .iter()
        .flat_map(|s| s.files.clone())
        .collect();
    inputs.extend(job.input.listing().map(PathBuf::from));
    let dir = OutputDir::prepare(
        &job.out,
        DirPlan {
            command: "campaign",
            force: job.force,
            inputs: &inputs,
            names: &CAMPAIGN_OUTPUTS,
        },
    )?;
    let plan = check_campaign(listing)?;
    for note in &plan.design.notes {
        observer.warn(note);
    }
    let stacks = measure_campaign(&plan, &job.measure, observer)?;
    // LEAD: the per-pixel decomposition goes here, after the merge:
    //   let stats: Vec<ConditionStats> = stacks.iter().map(|m| m.stats.clone()).collect();
    //   let decomposition = crate::campaign::fit::decompose(&stats, &DecomposeOptions { .. })?;
    // and its maps are written into `dir` (add their names to CAMPAIGN_OUTPUTS) with its
    // summary in `CampaignSummary::decomposition`.
    let decomposition = None;
    let summary = CampaignSummary {
        command: "campaign",
        version: env!("CARGO_PKG_VERSION"),
        input: match &job.input {
            CampaignInput::Manifest(_) => "manifest",
            CampaignInput::Emva(_) => "emva1288",
            CampaignInput::Keywords { .. } => "keywords",
        },
        listing: job.input.listing().map(|p| p.display().to_string()),
        gain_e_per_adu: gain,
        shape: [plan.shape.0, plan.shape.1],
        design: plan.design.clone(),
        stacks: stacks
            .iter()
            .zip(&plan.stacks)
            .map(|(m, s)| StackSummary::of(m, &s.files))
            .collect(),
        decomposition,
    };
    write_campaign_outputs(&dir.path(""), &stacks, &summary)?;
    Ok(CampaignRunResult {
        stored_bytes: stacks.iter().map(|m| m.stored_bytes).sum(),
        read_seconds: stacks.iter().map(|m| m.read_seconds).sum(),
        stacks,
        design: plan.design,
        out: dir.commit()?,
    })
}
