//! `detnoise effective`: the effective Gaussian read noise over a grid of configurations.

use super::args::{DetectorArgs, SweepArgs};
use super::progress::Terminal;
use crate::detector::ModelSpec;
use crate::effective::{effective_table, write_tables, EffectiveRecord, TABLE_NAMES};
use crate::output::{render, DirPlan, OutputDir, TableFormat};
use crate::Result;
use std::path::PathBuf;

/// Options of `detnoise effective`.
#[derive(clap::Args, Debug)]
#[command(mut_arg("subap", |a| a.default_value("4,6,8,10,12,14,16")))]
#[command(mut_arg("spot", |a| a.default_values(["airy:1,2,4,6,8,10"])))]
#[command(mut_arg("signal", |a| a.default_value("20,50,100,200,500,1000")))]
pub struct EffectiveArgs {
    /// The detector whose effective read noise is wanted: scmos-random (the rms pdf),
    /// scmos-map (needs --map), or any other model (every model is listed with --help).
    #[arg(long, default_value = "scmos-random")]
    pub model: String,
    /// The Monte-Carlo sweep: sub-aperture sizes (px), spots, signals (photons), iterations, seed.
    #[command(flatten)]
    pub sweep: SweepArgs,
    /// Readout-model parameters: EM gain (e-/e-), read noise (e- rms), sCMOS pdf and map.
    #[command(flatten)]
    pub detector: DetectorArgs,
    /// Output directory: effective_noise.csv, effective_noise.json and one heatmap per signal
    /// (e.g. effective_noise_S50.png and .svg for 50 photons). Written only when the run succeeds; an existing
    /// directory is replaced only if detnoise wrote it.
    #[arg(long)]
    pub out: PathBuf,
    /// Write into an existing --out that holds other files (they are never replaced or deleted).
    #[arg(long)]
    pub force: bool,
}

/// Files `effective` writes into its directory (glob patterns).
pub const OUTPUT_NAMES: [&str; 4] = [
    TABLE_NAMES[0],
    TABLE_NAMES[1],
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

/// Write the table (CSV, JSON) and the heatmaps into `dir`; returns the heatmaps' paths.
pub fn write_outputs(records: &[EffectiveRecord], dir: &OutputDir) -> Result<Vec<PathBuf>> {
    write_tables(records, &dir.path(""))?;
    crate::report::charts::effective_heatmaps(records, dir)
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
    let specs = [ModelSpec::parse(&args.model)?];
    let params = args.detector.params()?;
    let configs = args.sweep.configs()?;
    let records = effective_table(&configs, &specs, &params, &Terminal::default())?;
    write_outputs(&records, &dir)?;
    print!("{}", render(&records, TableFormat::Table)?);
    let path = dir.commit()?;
    eprintln!("wrote {}", path.display());
    Ok(())
}
