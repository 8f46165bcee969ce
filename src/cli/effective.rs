//! `detnoise effective`: the effective Gaussian read noise over a grid of configurations.

use super::args::{DetectorArgs, SweepArgs};
use super::progress::Progress;
use crate::detector::{ModelSpec, Readout};
use crate::effective::effective_sigma;
use crate::montecarlo::SimConfig;
use crate::output::{render, write_atomic, DirPlan, Format, OutputDir};
use crate::Result;
use std::path::PathBuf;

/// Options of `detnoise effective`.
#[derive(clap::Args, Debug)]
#[command(mut_arg("subap", |a| a.default_value("4,6,8,10,12,14,16")))]
#[command(mut_arg("spot", |a| a.default_values(["airy:1,2,4,6,8,10"])))]
#[command(mut_arg("signal", |a| a.default_value("20,50,100,200,500,1000")))]
pub struct EffectiveArgs {
    /// The detector whose effective read noise is wanted: scmos-random (the rms pdf, default),
    /// scmos-map (needs --map), scmos-fixed:K, or any other model name.
    #[arg(long, default_value = "scmos-random")]
    pub model: String,
    /// The Monte-Carlo sweep: sub-aperture sizes (px), spots, signals (photons), iterations, seed.
    #[command(flatten)]
    pub sweep: SweepArgs,
    /// Readout-model parameters: EM gain (e-/e-), read noise (e- rms), sCMOS pdf and map.
    #[command(flatten)]
    pub detector: DetectorArgs,
    /// Output directory: effective_noise.csv, effective_noise.json and one heatmap per signal
    /// (effective_noise_S<signal>.png and .svg). Written only when the run succeeds; an existing
    /// directory is replaced only if detnoise wrote it.
    #[arg(long)]
    pub out: PathBuf,
    /// Write into an existing --out that holds other files (they are never replaced or deleted).
    #[arg(long)]
    pub force: bool,
}

/// Files `effective` writes into its directory (glob patterns).
pub const OUTPUT_NAMES: [&str; 4] = [
    "effective_noise.csv",
    "effective_noise.json",
    "effective_noise_S*.png",
    "effective_noise_S*.svg",
];
impl EffectiveArgs {
    /// Check every option (model, detector, sweep lists) before any file is read.
    pub fn validate(&self) -> Result<()> {
        let spec = ModelSpec::parse(&self.model)?;
        self.detector.validate(std::slice::from_ref(&spec))?;
        self.sweep.validate()
    }
}

/// One configuration's effective read noise.
#[derive(Debug, Clone, serde::Serialize)]
pub struct EffectiveRecord {
    /// The detector model.
    pub model: String,
    /// Sub-aperture side (px).
    pub subap_px: usize,
    /// Spot, e.g. `airy:2`.
    pub spot: String,
    /// Spot sampling.
    pub sampling: String,
    /// Photons per sub-aperture before QE.
    pub signal_photons: f64,
    /// Quantum efficiency.
    pub qe: f64,
    /// Iterations.
    pub iters: u64,
    /// Seed.
    pub seed: u64,
    /// Effective Gaussian read noise (e-).
    pub sigma_eff_e: f64,
    /// Its standard error (e-).
    pub sigma_eff_se_e: f64,
    /// The detector's R (px).
    pub r_px: f64,
    /// Standard error of R (px).
    pub r_se_px: f64,
    /// The detector's best background level (e-).
    pub b_opt_e: f64,
    /// ok, lower_bound (sigma_eff = 0) or unreachable (no constant sigma gives this R; sigma_eff null).
    pub status: crate::effective::Status,
}

/// Solve every configuration of the sweep for `detector_spec`.
pub fn effective_table(
    spec: &ModelSpec,
    sweep: &SweepArgs,
    detector: &DetectorArgs,
    label: &str,
) -> Result<Vec<EffectiveRecord>> {
    let params = detector.params()?;
    let configs = sweep.configs()?;
    // Pilot (10 %) plus the detector and four constant sigmas in the final run.
    let work: u64 = configs
        .iter()
        .map(|c| c.iters * (c.subap_px * c.subap_px) as u64 * 6)
        .sum();
    let progress = Progress::new(label, configs.iter().map(|c| c.iters).sum(), work);
    let mut out = Vec::with_capacity(configs.len());
    for cfg in &configs {
        let model = spec.build(&params, cfg.subap_px)?;
        out.push(solve(cfg, model.as_ref(), &progress)?);
    }
    progress.finish();
    Ok(out)
}

fn solve(cfg: &SimConfig, model: &dyn Readout, progress: &Progress) -> Result<EffectiveRecord> {
    let e = effective_sigma(cfg, model, &|k| progress.inc(k))?;
    Ok(EffectiveRecord::new(model.name(), cfg, &e))
}

impl EffectiveRecord {
    /// The record of `model` (a label) in configuration `cfg`.
    pub fn new(model: String, cfg: &SimConfig, e: &crate::effective::Effective) -> Self {
        EffectiveRecord {
            model,
            subap_px: cfg.subap_px,
            spot: cfg.spot.label(),
            sampling: cfg.sampling.label().into(),
            signal_photons: cfg.signal_photons,
            qe: cfg.qe,
            iters: cfg.iters,
            seed: cfg.seed,
            sigma_eff_e: e.sigma_eff_e,
            sigma_eff_se_e: e.sigma_eff_se_e,
            r_px: e.r_px,
            r_se_px: e.r_se_px,
            b_opt_e: e.b_opt_e,
            status: e.status,
        }
    }
}

/// Write the table (CSV, JSON) and the heatmaps into `dir`.
pub fn write_outputs(records: &[EffectiveRecord], dir: &OutputDir) -> Result<Vec<PathBuf>> {
    write_atomic(
        &dir.path("effective_noise.csv"),
        render(records, Format::Csv)?.as_bytes(),
    )?;
    write_atomic(
        &dir.path("effective_noise.json"),
        render(records, Format::Json)?.as_bytes(),
    )?;
    super::charts::effective_heatmaps(records, dir)
}

/// Entry point of `detnoise effective`.
pub fn run_cli(args: &EffectiveArgs) -> Result<()> {
    args.validate()?;
    let dir = OutputDir::prepare(
        &args.out,
        DirPlan {
            command: "effective",
            force: args.force,
            inputs: &args.detector.input_files(),
            names: &OUTPUT_NAMES,
        },
    )?;
    let spec = ModelSpec::parse(&args.model)?;
    let records = effective_table(&spec, &args.sweep, &args.detector, "effective")?;
    write_outputs(&records, &dir)?;
    print!("{}", render(&records, Format::Table)?);
    let path = dir.commit()?;
    eprintln!("wrote {}", path.display());
    Ok(())
}
