//! `detnoise campaign` as one library call: the input read and checked, every stack
//! streamed once, and conditions.csv and campaign.json written to an output directory that
//! appears only when the run succeeds.

use std::path::PathBuf;
use std::time::Instant;

use super::checks::{check_campaign, Design};
use super::condition::ConditionStats;
use super::fit::{
    self, DecomposeOptions, Decomposition, EmGainFit, FitThresholds, TemperatureTerm,
};
use super::input::CampaignInput;
use super::measure::{
    fit_em_gains, measure_campaign, wants_em_fit, MeasureOptions, StackMeasurement,
};
use super::outputs::{
    campaign_output_names, write_campaign_outputs, CampaignSummary, StackSummary, CAMERA_DIR,
    DATASHEET_DIR,
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
    /// Wall-clock seconds spent reading and accumulating the stacks (stacks overlap, so this
    /// is less than the sum of theirs).
    pub read_seconds: f64,
    /// Bytes of sample data read again by the EM-gain histogram fits (EMCCD darks; 0 without).
    pub em_fit_bytes: u64,
    /// Wall-clock seconds of that second pass, the fits included.
    pub em_fit_seconds: f64,
    /// Wall-clock seconds of the per-pixel decomposition (both, when the EM fits ran).
    pub decompose_seconds: f64,
    /// Wall-clock seconds spent writing the output files.
    pub write_seconds: f64,
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
    // An EMVA 1288 dataset also gets its datasheet; one the datasheet refuses (too few
    // points, no dark pairs) is still a campaign.
    let emva = match &job.input {
        CampaignInput::Emva(d) => Some(crate::emva::EmvaDataset::from_descriptor(d)),
        _ => None,
    };
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
    // Every stack must hold the frames the clipping needs, before the first is read.
    if let crate::calib::darks::Clip::Extremes(n) = job.measure.clip {
        for (entry, stack) in plan.stacks.iter().zip(&plan.opened) {
            if 2 * n + 2 > stack.frames {
                return Err(Error::invalid(
                    "clip",
                    format!(
                        "rejecting {n} high and {n} low samples leaves fewer than 2 of the {} \
                         frames of {}",
                        stack.frames,
                        entry.files[0].display()
                    ),
                ));
            }
        }
    }
    for note in &plan.design.notes {
        observer.warn(note);
    }
    let t = Instant::now();
    let mut stacks = measure_campaign(&plan, &job.measure, observer)?;
    let read_seconds = t.elapsed().as_secs_f64();
    let t = Instant::now();
    let mut decomposition = decompose(&plan.design, &mut stacks, job)?;
    let mut decompose_seconds = t.elapsed().as_secs_f64();
    let (mut em_fit_bytes, mut em_fit_seconds) = (0, 0.0);
    if job.measure.em_fit && !plan.design.dark_em_gains.is_empty() {
        // The offsets do not depend on the gains' scale: fit the histograms with them, then
        // decompose again with the gains measured.
        let keep: Vec<bool> = decomposition
            .hot_class
            .iter()
            .map(|c| *c == fit::HotClass::Normal)
            .collect();
        let offsets = &decomposition.offset_adu;
        let t = Instant::now();
        fit_em_gains(&plan, &mut stacks, offsets, &keep, &job.measure, observer)?;
        em_fit_seconds = t.elapsed().as_secs_f64();
        em_fit_bytes = (stacks.iter().zip(&plan.stacks))
            .filter(|(_, s)| wants_em_fit(s, &job.measure))
            .map(|(m, _)| m.stored_bytes)
            .sum();
        let t = Instant::now();
        decomposition = decompose(&plan.design, &mut stacks, job)?;
        decompose_seconds += t.elapsed().as_secs_f64();
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
    let t = Instant::now();
    write_campaign_outputs(&dir.path(""), &stacks, &summary)?;
    fit::write_outputs(&decomposition, &dir.path(""), &[])?;
    // A campaign the model cannot describe (no pixel fitted) still has its measurements.
    match super::camera_model(&plan, &stacks, &decomposition, gain) {
        Ok(model) => model.write_files(&dir.path(CAMERA_DIR))?,
        Err(e) => observer.warn(&format!("no camera model written: {e}")),
    }
    if let Some(dataset) = emva {
        let written = dataset.and_then(|d| write_datasheet(&d, &dir.path(DATASHEET_DIR)));
        if let Err(e) = written {
            observer.warn(&format!("no EMVA 1288 datasheet written: {e}"));
        }
    }
    let write_seconds = t.elapsed().as_secs_f64();
    Ok(CampaignRunResult {
        stored_bytes: stacks.iter().map(|m| m.stored_bytes).sum(),
        read_seconds,
        em_fit_bytes,
        em_fit_seconds,
        decompose_seconds,
        write_seconds,
        stacks,
        design: plan.design,
        out: dir.commit()?,
    })
}

/// The datasheet of an EMVA 1288 dataset (as `detnoise datasheet` writes it, with its default
/// settings) into `dir`.
fn write_datasheet(dataset: &crate::emva::EmvaDataset, dir: &std::path::Path) -> Result<()> {
    std::fs::create_dir_all(dir).map_err(|e| Error::io(dir, e))?;
    crate::emva::run::write_all(dataset, &Default::default(), &Default::default(), dir)?;
    Ok(())
}

/// The per-pixel decomposition of the darks' mean signal, with the EM gains the histogram fits
/// measured (the commanded gains, with a warning, when any gain has no fit).
fn decompose(
    design: &Design,
    stacks: &mut [StackMeasurement],
    job: &CampaignRun,
) -> Result<Decomposition> {
    let mut opts =
        DecomposeOptions::new(job.measure.gain_e_per_adu).with_thresholds(job.thresholds);
    opts.fit_cic = design.cic_separable == Some(true);
    opts.em_gains = fitted_em_gains(design, stacks);
    opts.temperature = job.temperature;
    // The maps are lent to the fit and given back, not copied: they are most of a campaign's
    // memory (two f64 per pixel and stack; 600 MB for 9 stacks of 2048 x 2048).
    let stats: Vec<ConditionStats> = stacks.iter_mut().map(|m| lend(&mut m.stats)).collect();
    let result = fit::decompose(&stats, &opts);
    for (m, s) in stacks.iter_mut().zip(stats) {
        m.stats = s;
    }
    result
}

/// `stats` moved out, leaving it with empty maps.
fn lend(stats: &mut ConditionStats) -> ConditionStats {
    let mean_adu = std::mem::take(&mut stats.mean_adu);
    let var_adu2 = std::mem::take(&mut stats.var_adu2);
    ConditionStats {
        mean_adu,
        var_adu2,
        ..stats.clone()
    }
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
