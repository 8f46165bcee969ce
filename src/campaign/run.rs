//! `detnoise campaign` as one library call: the input read and checked, every stack
//! streamed once, and conditions.csv and campaign.json written to an output directory that
//! appears only when the run succeeds.

use std::path::PathBuf;

use super::checks::{check_campaign, Design};
use super::fit::{
    self, DecomposeOptions, Decomposition, EmGainFit, FitThresholds, TemperatureTerm,
};
use super::input::CampaignInput;
use super::measure::{fit_em_gains, measure_campaign, MeasureOptions, StackMeasurement};
use super::outputs::{
    campaign_output_names, write_campaign_outputs, CampaignSummary, StackSummary, CAMERA_DIR,
};
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
    /// The temperature law of the dark current in the decomposition.
    pub temperature: TemperatureTerm,
    /// The decomposition's warm/hot pixel classes and bad-fit p-value.
    pub thresholds: FitThresholds,
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
    job.thresholds.check()?;
    job.measure.clip.check()?;
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
            names: &campaign_output_names(),
        },
    )?;
    let plan = check_campaign(listing)?;
    for note in &plan.design.notes {
        observer.warn(note);
    }
    let mut stacks = measure_campaign(&plan, &job.measure, observer)?;
    let mut decomposition = decompose(&plan.design, &stacks, job)?;
    if job.measure.em_fit && !plan.design.dark_em_gains.is_empty() {
        // The offsets do not depend on the gains' scale: fit the histograms with them, then
        // decompose again with the gains measured.
        let keep: Vec<bool> = decomposition
            .hot_class
            .iter()
            .map(|c| *c == fit::HotClass::Normal)
            .collect();
        let offsets = &decomposition.offset_adu;
        fit_em_gains(&plan, &mut stacks, offsets, &keep, &job.measure, observer)?;
        decomposition = decompose(&plan.design, &stacks, job)?;
        if decomposition.summary.em_gain_curve.is_none() {
            observer.warn(
                "the decomposition takes the commanded EM gains as exact: the histogram fit did \
                 not measure every gain",
            );
        }
    }
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
        decomposition: Some(serde_json::to_value(&decomposition.summary).map_err(|e| {
            Error::Numeric(format!("cannot encode the decomposition's summary: {e}"))
        })?),
    };
    write_campaign_outputs(&dir.path(""), &stacks, &summary)?;
    fit::write_outputs(&decomposition, &dir.path(""), &[])?;
    // A campaign the model cannot describe (no pixel fitted) still has its measurements.
    match super::camera_model(&plan, &stacks, &decomposition, gain) {
        Ok(model) => model.write_files(&dir.path(CAMERA_DIR))?,
        Err(e) => observer.warn(&format!("no camera model written: {e}")),
    }
    Ok(CampaignRunResult {
        stored_bytes: stacks.iter().map(|m| m.stored_bytes).sum(),
        read_seconds: stacks.iter().map(|m| m.read_seconds).sum(),
        stacks,
        design: plan.design,
        out: dir.commit()?,
    })
}

/// The per-pixel decomposition of the darks' mean signal, with the EM gains the histogram fits
/// measured (the commanded gains, with a warning, when any gain has no fit).
fn decompose(
    design: &Design,
    stacks: &[StackMeasurement],
    job: &CampaignRun,
) -> Result<Decomposition> {
    let stats: Vec<_> = stacks.iter().map(|m| m.stats.clone()).collect();
    let mut opts =
        DecomposeOptions::new(job.measure.gain_e_per_adu).with_thresholds(job.thresholds);
    opts.fit_cic = design.cic_separable == Some(true);
    opts.em_gains = fitted_em_gains(design, stacks);
    opts.temperature = job.temperature;
    fit::decompose(&stats, &opts)
}

/// One fitted gain (e-/e-) per commanded gain of the darks: the inverse-variance mean of its
/// stacks' histogram fits; empty when any commanded gain has no usable fit.
fn fitted_em_gains(design: &Design, stacks: &[StackMeasurement]) -> Vec<EmGainFit> {
    let mut out = Vec::with_capacity(design.dark_em_gains.len());
    for &commanded in &design.dark_em_gains {
        let (mut sw, mut swg) = (0.0, 0.0);
        for m in stacks {
            let c = &m.stats.condition;
            if c.em_gain != Some(commanded) || c.kind != super::StackKind::Dark {
                continue;
            }
            if let Some(Ok(f)) = &m.em_fit {
                if f.gain_e_per_adu.is_some() && f.em_gain_se > 0.0 && f.em_gain_se.is_finite() {
                    let w = f.em_gain_se.powi(-2);
                    sw += w;
                    swg += w * f.em_gain;
                }
            }
        }
        if sw == 0.0 {
            return Vec::new();
        }
        out.push(EmGainFit {
            commanded,
            gain: swg / sw,
            se: sw.powf(-0.5),
        });
    }
    out
}
