//! `detnoise simulate`: the sub-aperture Monte-Carlo for one configuration or a sweep.

use super::args::{parse_models, CentroiderArgs, DetectorArgs, SweepArgs};
use super::progress::Terminal;
use crate::montecarlo::sweep_with;
use crate::output::{check_file, render, write_atomic, FileOut, TableFormat};
use crate::Result;
use std::path::PathBuf;

pub mod table;

/// Options of `detnoise simulate`.
#[derive(clap::Args, Debug)]
pub struct SimulateArgs {
    /// Readout model names, comma-separated (every model is listed with --help).
    #[arg(
        long,
        default_value = "emccd-simple,emccd-stochastic,emccd-distribution,scmos-median,scmos-mean,scmos-random"
    )]
    pub model: String,
    /// The Monte-Carlo sweep: sub-aperture sizes (px), spots, signals (photons), iterations, seed.
    #[command(flatten)]
    pub sweep: SweepArgs,
    /// Readout-model parameters: EM gain (e-/e-), read noise (e- rms), sCMOS pdf and map.
    #[command(flatten)]
    pub detector: DetectorArgs,
    /// The centroiders every model is read through.
    #[command(flatten)]
    pub centroiders: CentroiderArgs,
    /// Output format: table (for reading: the settings shared by every row stated once, only
    /// the columns that apply, at most 100 characters wide), csv (every column) or json (an
    /// array of records, with R at every level).
    #[arg(long, value_enum, default_value_t = TableFormat::Table)]
    pub format: TableFormat,
    /// Write the results to this file instead of standard output (.txt for --format table,
    /// .csv or .json for the others).
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// Also draw R against the swept axis, one line per model, to this .png or .svg file.
    #[arg(long)]
    pub plot: Option<PathBuf>,
    /// Replace existing --out and --plot files (never an input file).
    #[arg(long)]
    pub force: bool,
}

impl SimulateArgs {
    /// Check every option (models, detector, sweep lists) before any file is read.
    pub fn validate(&self) -> Result<()> {
        let specs = parse_models(&self.model)?;
        self.detector.validate(&specs)?;
        self.centroiders.specs()?;
        self.sweep.validate()
    }
}

/// Entry point of `detnoise simulate`.
pub fn run_cli(args: &SimulateArgs) -> Result<()> {
    args.validate()?;
    check_outputs(args)?;
    let (specs, params) = (parse_models(&args.model)?, args.detector.params()?);
    let records = sweep_with(
        &args.sweep.configs()?,
        &specs,
        &args.centroiders.specs()?,
        &params,
        &Terminal::default(),
    )?;
    let text = match args.format {
        TableFormat::Table => table::terminal_table(&records),
        format => render(&records, format)?,
    };
    match &args.out {
        Some(path) => write_atomic(path, text.as_bytes())?,
        None => print!("{text}"),
    }
    if let Some(path) = &args.plot {
        crate::charts::sweep::r_against_sweep(&records, path)?;
    }
    Ok(())
}

/// Check `--out` and `--plot` before any work.
fn check_outputs(args: &SimulateArgs) -> Result<()> {
    let table: (&[&str], &str) = match args.format {
        TableFormat::Table => (&["txt"], "a text table (--format table)"),
        TableFormat::Csv => (&["csv"], "CSV (--format csv)"),
        TableFormat::Json => (&["json"], "JSON (--format json)"),
    };
    let chart: (&[&str], &str) = (&["png", "svg"], "a chart (PNG or SVG)");
    let inputs = args.detector.input_files();
    for (path, option, (exts, what)) in [(&args.out, "--out", table), (&args.plot, "--plot", chart)]
    {
        if let Some(path) = path {
            let file = FileOut {
                path,
                option,
                exts,
                what,
            };
            check_file(&file, args.force, &inputs)?;
        }
    }
    Ok(())
}
