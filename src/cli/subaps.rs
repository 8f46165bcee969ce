//! `detnoise subaps` and `detnoise subaps-merge`: the effective read noise of every
//! sub-aperture of a real detector, resumable and shardable, and the merge of the shards.

use super::args::{parse_list, CentroiderArgs, PrecisionArgs, SweepArgs};
use super::progress::Terminal;
use crate::centroid::CentroiderSpec;
use crate::montecarlo::SimConfig;
use crate::settings::Value;
use crate::subaps::{
    merge_into_dir, run_into_dir, DirTarget, Geometry, GridSpec, Shard, SubapsJob, SubapsSummary,
    ValidMask,
};
use crate::{Error, Result};
use std::path::PathBuf;

/// The lenslet geometry: the grid of sub-apertures, and optionally the mask of valid ones
/// (`subaps` and `report`).
#[derive(clap::Args, Debug, Clone, Default)]
pub struct SubapGeometryArgs {
    /// Lenslet grid over the detector: `SIZE[,PITCH[,X0,Y0]]` in px (e.g. 16, or 16,18,4,4):
    /// square sub-apertures of SIZE px per side, PITCH px apart (the size if left out), the
    /// first one's first pixel at column X0, row Y0 (0,0 if left out). The grid holds every
    /// sub-aperture that fits the map.
    #[arg(long, value_name = "SIZE[,PITCH[,X0,Y0]]")]
    pub subap_grid: Option<String>,
    /// Mask of the valid sub-apertures (FITS/TIFF/EXR path): one pixel per cell of
    /// --subap-grid, non-zero = valid; a mask of another shape than the grid on the map is
    /// refused.
    #[arg(long, value_name = "FILE", requires = "subap_grid")]
    pub subap_mask: Option<PathBuf>,
}

impl SubapGeometryArgs {
    /// The grid, checked (None when no grid is given).
    pub fn grid(&self) -> Result<Option<GridSpec>> {
        self.subap_grid.as_deref().map(GridSpec::parse).transpose()
    }

    /// The geometry, the mask read (None when no grid is given).
    pub fn geometry(&self) -> Result<Option<Geometry>> {
        let Some(grid) = self.grid()? else {
            return Ok(None);
        };
        let mask = self
            .subap_mask
            .as_deref()
            .map(ValidMask::read)
            .transpose()?;
        Ok(Some(Geometry { grid, mask }))
    }
}

/// Options of `detnoise subaps`.
#[derive(clap::Args, Debug)]
#[command(mut_arg("subap", |a| a.hide(true).default_value(GRID_SIZE)))]
#[command(mut_arg("spot", |a| a.help(
    "The spot of every sub-aperture (one): airy:D (first-dark-ring diameter D px) or \
     gauss:SX,SY (standard deviations in px); sizes >= 0.1 px"
)))]
#[command(mut_arg("signal", |a| a.help(
    "The signal of every sub-aperture (one), photons per sub-aperture before QE; signal x QE at \
     most 1e9 photo-electrons"
)))]
#[command(mut_arg("iters", |a| a.help(
    "Starting Monte-Carlo iterations (frames) per sub-aperture, 2 to 1e9: more are added, up \
     to --max-iters, until the precision target is met"
)))]
pub struct SubapsArgs {
    /// Measured read-noise map in e- (FITS/TIFF/EXR path, e.g. rms_e.fits from `darks`); a FITS
    /// map whose BUNIT is not electrons is refused. Non-finite pixels read with the rms of the
    /// map's finite pixels, as in the scmos-map model.
    #[arg(long, value_name = "FILE")]
    pub map: PathBuf,
    /// The lenslet geometry.
    #[command(flatten)]
    pub geometry: SubapGeometryArgs,
    /// The configuration of every sub-aperture: one spot, one signal (photons), iterations,
    /// seed (shared by all sub-apertures); the sub-aperture size is the grid's.
    #[command(flatten)]
    pub sweep: SweepArgs,
    /// Precision target of each value and the iteration cap.
    #[command(flatten)]
    pub precision: PrecisionArgs,
    /// The centroider every sub-aperture is read through (one; the constant-sigma references
    /// are read through it too, each at its own best setting).
    #[command(flatten)]
    pub centroiders: CentroiderArgs,
    /// Run only shard K of N (K/N, unitless whole numbers, 1 <= K <= N): the sub-apertures
    /// whose index is K-1 modulo N. The shard writes only its part file
    /// (subaps-K-of-N.part) into --out; `detnoise subaps-merge` combines the parts.
    #[arg(long, value_name = "K/N")]
    pub shard: Option<String>,
    /// Output directory: the part file (each finished sub-aperture appended as it completes; a
    /// rerun with the same options resumes it), and for an unsharded run subaps.csv,
    /// subaps_sigma_eff_e.fits, subaps_sigma_eff_se_e.fits, subaps_status.fits,
    /// subaps_sigma_eff.png/.svg and subaps_summary.json. Shards may share it.
    #[arg(long)]
    pub out: PathBuf,
    /// Write into an existing --out that holds other files (they are never replaced or deleted).
    #[arg(long)]
    pub force: bool,
}

/// The hidden `--subap` of `subaps`: the size is the grid's.
const GRID_SIZE: &str = "grid";

impl SubapsArgs {
    /// The one centroider.
    pub fn centroider(&self) -> Result<CentroiderSpec> {
        match self.centroiders.specs()?[..] {
            [one] => Ok(one),
            _ => Err(Error::invalid(
                "--centroider",
                "subaps reads every sub-aperture through one centroider: give one",
            )),
        }
    }

    /// Check every option before any file is read: the grid, the one configuration, the
    /// precision and the shard.
    pub fn validate(&self) -> Result<(GridSpec, SimConfig, Shard)> {
        let grid = self.geometry.grid()?.ok_or_else(|| {
            Error::invalid(
                "subap_grid",
                "give the lenslet grid: SIZE[,PITCH[,X0,Y0]] in px",
            )
        })?;
        let subap = self.sweep.subap_text();
        if subap != GRID_SIZE && parse_list::<usize>(&subap, "--subap")? != [grid.size_px] {
            return Err(Error::invalid(
                "--subap",
                "the sub-aperture size is the SIZE of --subap-grid: leave --subap out",
            ));
        }
        let mut sweep = self.sweep.clone();
        let size = Value::Text(grid.size_px.to_string());
        sweep.values.set(&crate::settings::SUBAP_PX, size);
        let configs = sweep.configs()?;
        let [cfg] = &configs[..] else {
            return Err(Error::invalid(
                if crate::spot::Spot::parse_list(&self.sweep.spot_texts())?.len() > 1 {
                    "--spot"
                } else {
                    "--signal"
                },
                format!(
                    "subaps solves one configuration: give one spot and one signal ({} given)",
                    configs.len()
                ),
            ));
        };
        self.precision.precision(cfg.iters).validate(cfg.iters)?;
        self.centroider()?;
        let shard = self
            .shard
            .as_deref()
            .map(Shard::parse)
            .transpose()?
            .unwrap_or(Shard::ALL);
        Ok((grid, cfg.clone(), shard))
    }
}

/// Entry point of `detnoise subaps`.
pub fn run_cli(args: &SubapsArgs) -> Result<()> {
    let (_, cfg, shard) = args.validate()?;
    let map = crate::calib::Map::read_noise(&args.map, crate::calib::Unit::Electrons)?;
    let geometry = args
        .geometry
        .geometry()?
        .expect("validated: a grid is given");
    let job = SubapsJob {
        map: &map,
        geometry: &geometry,
        precision: args.precision.precision(cfg.iters),
        centroider: args.centroider()?,
        config: cfg,
    };
    let plan = job.plan()?;
    let l = &plan.layout;
    eprintln!(
        "subaps: {} sub-apertures of {}x{} px on the {}x{} px map (grid {}x{}{}); shard {}/{}: {}",
        l.subaps.len(),
        geometry.grid.size_px,
        geometry.grid.size_px,
        map.rows,
        map.cols,
        l.grid_rows,
        l.grid_cols,
        if l.masked > 0 {
            format!(", {} masked", l.masked)
        } else {
            String::new()
        },
        shard.k,
        shard.n,
        l.shard(shard.k, shard.n).len()
    );
    let inputs: Vec<PathBuf> = [Some(args.map.clone()), args.geometry.subap_mask.clone()]
        .into_iter()
        .flatten()
        .collect();
    let target = DirTarget {
        out: &args.out,
        force: args.force,
        inputs: &inputs,
    };
    let run = run_into_dir(&job, shard, &target, &Terminal::default())?;
    eprintln!(
        "subaps: {} of {} sub-apertures computed, {} resumed from {}",
        run.computed,
        run.in_shard,
        run.resumed,
        run.part.display()
    );
    match &run.summary {
        Some(s) => {
            print_summary(s);
            eprintln!("wrote {}", args.out.display());
        }
        None => eprintln!(
            "shard {}/{} done: merge every shard's part with `detnoise subaps-merge {} --out DIR`",
            shard.k,
            shard.n,
            args.out.display()
        ),
    }
    Ok(())
}

/// Options of `detnoise subaps-merge`.
#[derive(clap::Args, Debug)]
pub struct SubapsMergeArgs {
    /// Part files written by `detnoise subaps --shard K/N` (paths), or directories holding
    /// them: every shard's part of one job, each sub-aperture exactly once.
    #[arg(required = true, value_name = "PART")]
    pub parts: Vec<PathBuf>,
    /// Output directory of the merged map (a directory of its own, not one holding the
    /// parts): the files an unsharded `subaps` run writes, identical to them.
    #[arg(long)]
    pub out: PathBuf,
    /// Write into an existing --out that holds other files (they are never replaced or deleted).
    #[arg(long)]
    pub force: bool,
}

/// Entry point of `detnoise subaps-merge`.
pub fn run_merge_cli(args: &SubapsMergeArgs) -> Result<()> {
    let (merged, summary) = merge_into_dir(&args.parts, &args.out, args.force)?;
    eprintln!(
        "subaps-merge: {} sub-apertures from {} part files",
        merged.records.len(),
        merged.parts.len()
    );
    print_summary(&summary);
    eprintln!("wrote {}", args.out.display());
    Ok(())
}

/// The summary on standard output: counts by status and the spread of the `ok` values.
fn print_summary(s: &SubapsSummary) {
    let counts: Vec<String> = s
        .counts
        .iter()
        .filter(|(_, n)| n.as_u64() != Some(0))
        .map(|(w, n)| format!("{n} {w}"))
        .collect();
    println!("sub-apertures: {}", counts.join(", "));
    match &s.sigma_eff_ok {
        Some(o) => println!(
            "sigma_eff over the {} ok sub-apertures (e-): median {:.3}, min {:.3}, max {:.3}, \
             10-90 % {:.3} to {:.3}",
            o.ok, o.median_e, o.min_e, o.max_e, o.p10_e, o.p90_e
        ),
        None => println!("no sub-aperture has an ok value"),
    }
}
