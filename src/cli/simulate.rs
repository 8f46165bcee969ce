//! `detnoise simulate`: the sub-aperture Monte-Carlo for one configuration or a sweep.

use super::args::{parse_models, DetectorArgs, SweepArgs};
use super::progress::Progress;
use crate::detector::Readout;
use crate::montecarlo::{run, SimConfig, SimResult};
use crate::output::{check_file, render, write_atomic, FileOut, Format};
use crate::Result;
use std::path::PathBuf;

/// Options of `detnoise simulate`.
#[derive(clap::Args, Debug)]
pub struct SimulateArgs {
    /// Readout models, comma-separated: emccd-simple, emccd-stochastic, emccd-distribution,
    /// scmos-constant[:SIGMA_E], scmos-median, scmos-mean, scmos-fixed[:PATTERN], scmos-random.
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
    /// Output format: table (text), csv, or json (an array of records, with R at every level).
    #[arg(long, value_enum, default_value_t = Format::Table)]
    pub format: Format,
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
        self.sweep.validate()
    }
}

/// One row of simulation output: a configuration and its result.
#[derive(Debug, Clone, serde::Serialize)]
pub struct SimRecord {
    /// Readout model.
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
    /// EMCCD mean gain (e-/e-).
    pub gain: f64,
    /// Iterations.
    pub iters: u64,
    /// Seed.
    pub seed: u64,
    /// R: mean radial error at the best eligible background level (px).
    pub r_px: f64,
    /// Standard error of R (px).
    pub r_se_px: f64,
    /// Best background level (e-).
    pub b_opt_e: f64,
    /// The best level is the top of the grid.
    pub b_at_grid_edge: bool,
    /// No level met the empty-frame limit.
    pub no_eligible_level: bool,
    /// Mean radial error at b = 0 (px).
    pub r0_px: f64,
    /// Standard error of R(0) (px).
    pub r0_se_px: f64,
    /// Frames with nothing above the best level.
    pub zero_frames: u64,
    /// Background levels swept (e-).
    pub bg_levels_e: Vec<f64>,
    /// Mean radial error at each level (px).
    pub r_by_level_px: Vec<f64>,
}

impl SimRecord {
    /// Combine a configuration, the EM gain in use and one model's result.
    pub fn new(cfg: &SimConfig, gain: f64, r: SimResult) -> Self {
        SimRecord {
            model: r.model,
            subap_px: cfg.subap_px,
            spot: cfg.spot.label(),
            sampling: cfg.sampling.label().into(),
            signal_photons: cfg.signal_photons,
            qe: cfg.qe,
            gain,
            iters: cfg.iters,
            seed: cfg.seed,
            r_px: r.r_px,
            r_se_px: r.r_se_px,
            b_opt_e: r.b_opt_e,
            b_at_grid_edge: r.b_at_grid_edge,
            no_eligible_level: r.no_eligible_level,
            r0_px: r.r0_px,
            r0_se_px: r.r0_se_px,
            zero_frames: r.zero_frames,
            bg_levels_e: r.levels.iter().map(|l| l.b_e).collect(),
            r_by_level_px: r.levels.iter().map(|l| l.r_px).collect(),
        }
    }
}

/// Run every configuration of the sweep with every model (common random numbers within a configuration).
pub fn simulate(args: &SimulateArgs) -> Result<Vec<SimRecord>> {
    let specs = parse_models(&args.model)?;
    let params = args.detector.params()?;
    let configs = args.sweep.configs()?;
    let work: u64 = configs
        .iter()
        .map(|c| c.iters * (c.subap_px * c.subap_px * specs.len()) as u64)
        .sum();
    let progress = Progress::new("simulate", configs.iter().map(|c| c.iters).sum(), work);
    let mut records = Vec::new();
    for cfg in &configs {
        let models: Vec<Box<dyn Readout>> = specs
            .iter()
            .map(|s| s.build(&params, cfg.subap_px))
            .collect::<Result<_>>()?;
        let refs: Vec<&dyn Readout> = models.iter().map(|m| m.as_ref()).collect();
        for r in run(cfg, &refs, &|k| progress.inc(k))? {
            if r.b_at_grid_edge {
                eprintln!("warning: {} at {}x{} px, {}, S = {}: the optimum background is the top of the grid; widen --bg-grid", r.model, cfg.subap_px, cfg.subap_px, cfg.spot.label(), cfg.signal_photons);
            }
            records.push(SimRecord::new(cfg, params.gain, r));
        }
    }
    progress.finish();
    Ok(records)
}

/// Entry point of `detnoise simulate`.
pub fn run_cli(args: &SimulateArgs) -> Result<()> {
    args.validate()?;
    check_outputs(args)?;
    let records = simulate(args)?;
    let text = render(&records, args.format)?;
    match &args.out {
        Some(path) => write_atomic(path, text.as_bytes())?,
        None => print!("{text}"),
    }
    if let Some(path) = &args.plot {
        super::charts::r_against_sweep(&records, path)?;
    }
    Ok(())
}

/// Check `--out` and `--plot` before any work.
fn check_outputs(args: &SimulateArgs) -> Result<()> {
    let inputs = args.detector.input_files();
    if let Some(path) = &args.out {
        let (exts, what): (&[&str], &str) = match args.format {
            Format::Table => (&["txt"], "a text table (--format table)"),
            Format::Csv => (&["csv"], "CSV (--format csv)"),
            Format::Json => (&["json"], "JSON (--format json)"),
        };
        let out = FileOut {
            path,
            option: "--out",
            exts,
            what,
        };
        check_file(&out, args.force, &inputs)?;
    }
    if let Some(path) = &args.plot {
        let plot = FileOut {
            path,
            option: "--plot",
            exts: &["png", "svg"],
            what: "a chart (PNG or SVG)",
        };
        check_file(&plot, args.force, &inputs)?;
    }
    Ok(())
}
