//! `detnoise darks`: per-pixel offset and read-noise maps from a dark stack.

use std::ops::Bound::{Excluded, Included, Unbounded};
use std::path::PathBuf;

use super::args::{real, whole};
use super::progress::Terminal;
use crate::calib::darks::{run as run_darks, Clip, DarkOptions, DarksRun};
use crate::error::Result;
use crate::io::Checksum;

/// Options of `detnoise darks`.
#[derive(clap::Args, Debug)]
pub struct DarksArgs {
    /// Dark frames: FITS/TIFF/EXR files, directories or glob patterns (in stack order).
    #[arg(required = true)]
    pub stack: Vec<PathBuf>,
    /// Output directory, written only when the run succeeds; an existing directory is replaced
    /// only if detnoise wrote it.
    #[arg(long)]
    pub out: PathBuf,
    /// Write into an existing --out that holds other files (they are never replaced or deleted).
    #[arg(long)]
    pub force: bool,
    /// Conversion gain (e- per adu); when given, rms_e.fits is written too. Default: none.
    #[arg(long, value_parser = real(Excluded(0.0), Unbounded, "e- per adu"))]
    pub gain_e_per_adu: Option<f64>,
    /// Reject the N highest and N lowest samples of each pixel (cosmic rays), N up to 100,000
    /// (and 2N + 2 at most the frame count). Default: 0.
    #[arg(long, conflicts_with = "sigma_clip", value_parser = whole::<usize>(0, MAX_CLIP, "samples"))]
    pub clip: Option<usize>,
    /// Reject samples more than K standard deviations from the pixel mean (two passes). Default: off.
    #[arg(long, value_parser = real(Excluded(0.0), Unbounded, "standard deviations"))]
    pub sigma_clip: Option<f64>,
    /// Subtract each frame's median (common-mode offset, adu) before accumulating. Default: off.
    #[arg(long)]
    pub common_mode: bool,
    /// Hot-pixel threshold: offset above median + K robust sigmas of the offset map.
    #[arg(long, default_value_t = 5.0, value_parser = real(Excluded(0.0), Unbounded, "robust sigmas"))]
    pub hot_sigma: f64,
    /// Dead-pixel threshold: read noise below this fraction of the median read noise, [0, 1]
    /// (unitless).
    #[arg(long, default_value_t = 0.1, value_parser = real(Included(0.0), Included(1.0), ""))]
    pub dead_fraction: f64,
    /// Checksum of every input file recorded in summary.json (`inputs`), computed while the
    /// statistics run: blake3 (as `b3sum` prints it; ~0.17 CPU-s per GB) or sha256 (as
    /// `sha256sum` prints it; ~0.5 CPU-s per GB on one core, which then bounds the run).
    #[arg(long, value_enum, default_value = "blake3")]
    pub checksum: Checksum,
    /// Record no checksums of the inputs.
    #[arg(long)]
    pub no_checksums: bool,
    /// RTS threshold: von Neumann ratio below 1 - K/sqrt(frames) (K standard errors).
    #[arg(long, default_value_t = 5.0, value_parser = real(Excluded(0.0), Unbounded, "standard errors"))]
    pub rts_sigma: f64,
    /// Use frames that look illuminated (variance growing with the mean across pixels, or a
    /// level near the top of the stored range) as darks. Default: refuse them.
    #[arg(long)]
    pub accept_illuminated: bool,
}

/// Largest `--clip` (samples rejected at each end of every pixel).
const MAX_CLIP: u64 = 100_000;

/// Run `detnoise darks`.
pub fn run(args: &DarksArgs) -> Result<()> {
    let clip = match (args.clip, args.sigma_clip) {
        (Some(n), None) if n > 0 => Clip::Extremes(n),
        (_, Some(k)) => Clip::Sigma(k),
        _ => Clip::None,
    };
    let job = DarksRun {
        stack: args.stack.clone(),
        out: args.out.clone(),
        force: args.force,
        options: DarkOptions {
            clip,
            common_mode: args.common_mode,
            hot_sigma: args.hot_sigma,
            dead_fraction: args.dead_fraction,
            rts_sigma: args.rts_sigma,
        },
        gain_e_per_adu: args.gain_e_per_adu,
        checksum: (!args.no_checksums).then_some(args.checksum),
        accept_illuminated: args.accept_illuminated,
    };
    let r = run_darks(&job, &Terminal::default())?;
    let (mb, secs) = (r.stored_bytes as f64 / 1e6, r.read_seconds);
    eprintln!(
        "read {mb:.1} MB of samples in {secs:.2} s ({:.0} MB/s)",
        mb / secs
    );
    let s = &r.summary;
    eprintln!(
        "{} frames of {}x{}: median read noise {:.4} adu{}, split-half correlation {:.4}, {} flagged pixels; wrote {}",
        s.frames,
        s.shape[0],
        s.shape[1],
        s.rms_adu.median,
        s.rms_e.as_ref().map(|d| format!(" ({:.4} e-)", d.median)).unwrap_or_default(),
        s.split_half_correlation,
        s.flags.any,
        r.out.display()
    );
    Ok(())
}
