//! `detnoise paper`: regenerate every figure of Basden (2015).

use super::args::whole;
use super::progress::Terminal;
use crate::montecarlo::SimConfig;
use crate::output::{DirPlan, OutputDir};
use crate::paper::{generate, write_index, PaperOptions};
use crate::spot::Sampling;
use crate::Result;
use std::path::PathBuf;

/// Options of `detnoise paper`.
#[derive(clap::Args, Debug)]
pub struct PaperArgs {
    /// Output directory: figNN-*.png/.svg/.csv for the 14 figures, index.html and README.md.
    /// Written only when every figure succeeded; an existing directory is replaced only if
    /// detnoise wrote it.
    #[arg(long)]
    pub out: PathBuf,
    /// Write into an existing --out that holds other files (they are never replaced or deleted).
    #[arg(long)]
    pub force: bool,
    /// Monte-Carlo iterations (frames) per point, 2 to 1e9 (the paper used 10,000).
    #[arg(long, default_value_t = 10_000, value_parser = whole::<u64>(2, SimConfig::MAX_ITERS, "frames"))]
    pub iters: u64,
    /// Fast smoke run: coarse grids and 200 iterations (same files).
    #[arg(long)]
    pub quick: bool,
    /// Spot sampling: point (pixel centres, as the paper most likely did) or integrated.
    #[arg(long, value_enum, default_value_t = Sampling::Point)]
    pub sampling: Sampling,
    /// Seed of every random stream (a whole number, unitless).
    #[arg(long, default_value_t = 1, value_parser = whole::<u64>(0, u64::MAX, ""))]
    pub seed: u64,
}

/// Entry point of `detnoise paper`.
pub fn run_cli(args: &PaperArgs) -> Result<()> {
    // Every option of `paper` is a single value, range-checked while parsing.
    let dir = OutputDir::prepare(
        &args.out,
        DirPlan {
            command: "paper",
            force: args.force,
            inputs: &[],
            names: &["fig[0-9][0-9]-*", "index.html", "README.md"],
        },
    )?;
    let opts = PaperOptions {
        iters: if args.quick {
            args.iters.min(200)
        } else {
            args.iters
        },
        seed: args.seed,
        sampling: args.sampling,
        quick: args.quick,
    };
    let figures = generate(&opts, &dir.path(""), &Terminal::default())?;
    write_index(&dir.path(""), &figures, &opts)?;
    let path = dir.commit()?;
    eprintln!(
        "wrote {} figures to {} (open index.html)",
        figures.len(),
        path.display()
    );
    Ok(())
}
