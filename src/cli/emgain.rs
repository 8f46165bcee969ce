//! `detnoise emgain`: EM gain, bias, read noise and light level from EMCCD frames.

use std::ops::Bound::{Excluded, Included, Unbounded};
use std::path::PathBuf;

use super::args::{real, whole};
use crate::detector::register::MAX_STAGES;
use crate::error::Result;
use crate::fit::emgain::{run as run_emgain, EmgainRun};

/// Options of `detnoise emgain`.
#[derive(clap::Args, Debug)]
pub struct EmgainArgs {
    /// EMCCD dark or low-light frames: FITS/TIFF/EXR files, directories or glob patterns.
    #[arg(required = true)]
    pub stack: Vec<PathBuf>,
    /// Output directory: emgain.json and emgain.png, written only when the fit succeeds; an
    /// existing directory is replaced only if detnoise wrote it.
    #[arg(long)]
    pub out: PathBuf,
    /// Write into an existing --out that holds other files (they are never replaced or deleted).
    #[arg(long)]
    pub force: bool,
    /// Conversion gain (e- per adu): the EM gain is then reported in e-/e-. Default: none (adu/e-).
    #[arg(long, conflicts_with = "gain_map", value_parser = real(Excluded(0.0), Included(crate::settings::MAX_GAIN_E_PER_ADU), "e- per adu"))]
    pub gain_e_per_adu: Option<f64>,
    /// Conversion-gain map (e- per adu); its median is used as --gain-e-per-adu. Default: none.
    #[arg(long)]
    pub gain_map: Option<PathBuf>,
    /// Per-pixel bias map (adu), subtracted pixel by pixel (its mean is added back). Default: none.
    #[arg(long)]
    pub offset: Option<PathBuf>,
    /// Read-noise map (adu rms) from no-signal frames at the same gain (needs --offset): bias
    /// and read noise are then held fixed (bias = mean of the offset map, read noise = rms
    /// of this map), which bright frames need because their zero-electron peak is empty.
    /// Default: both fitted.
    #[arg(long, requires = "offset")]
    pub read_noise: Option<PathBuf>,
    /// Model the exact EM register with this many stages, 1 to 2000 (needs the conversion
    /// gain). Default: the Gamma/Erlang model of the paper (Eq. 2).
    #[arg(long, value_parser = whole::<u32>(1, MAX_STAGES as u64, "stages"))]
    pub stages: Option<u32>,
    /// Also fit serial clock-induced charge (electrons born inside the register; needs --stages).
    /// Default: off (parallel CIC is always part of lambda).
    #[arg(long, requires = "stages")]
    pub serial_cic: bool,
    /// Exclude values above this (adu; cosmics, hot pixels). Default: bias + 40 G (1 + lambda + 5 sqrt(lambda)) from the start values.
    #[arg(long, value_parser = real(Unbounded, Unbounded, "adu"))]
    pub max_value_adu: Option<f64>,
    /// Histogram bin width (adu). Default: 1 for integer data without --offset, else 0.25.
    #[arg(long, value_parser = real(Excluded(0.0), Unbounded, "adu"))]
    pub bin_width_adu: Option<f64>,
    /// Frames at unity EM gain under the same light, for the ratio-of-means cross-check. Default: none.
    #[arg(long, num_args = 1..)]
    pub reference_stack: Vec<PathBuf>,
    /// Bias map (adu) of the reference stack (required with --reference-stack).
    #[arg(long)]
    pub reference_offset: Option<PathBuf>,
}

impl EmgainArgs {
    /// The run these options ask for.
    pub fn job(&self) -> EmgainRun {
        EmgainRun {
            stack: self.stack.clone(),
            out: self.out.clone(),
            force: self.force,
            gain_e_per_adu: self.gain_e_per_adu,
            gain_map: self.gain_map.clone(),
            offset: self.offset.clone(),
            read_noise: self.read_noise.clone(),
            stages: self.stages,
            serial_cic: self.serial_cic,
            max_value_adu: self.max_value_adu,
            bin_width_adu: self.bin_width_adu,
            reference_stack: self.reference_stack.clone(),
            reference_offset: self.reference_offset.clone(),
        }
    }
}

/// Run `detnoise emgain`.
pub fn run(args: &EmgainArgs) -> Result<()> {
    let r = run_emgain(&args.job())?;
    print!("{}", r.report.summary_text());
    Ok(())
}
