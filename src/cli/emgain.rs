//! `detnoise emgain`: EM gain, bias, read noise and light level from EMCCD frames.

use std::ops::Bound::{Excluded, Included, Unbounded};
use std::path::PathBuf;

use super::args::{real, whole};
use crate::detector::register::MAX_STAGES;
use crate::error::Result;
use crate::fit::emgain::{run as run_emgain, EmLaw, EmgainRun, SerialCic};

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
    /// Stages of the EM register (a count, unitless), 1 to 2000. Default: 604.
    #[arg(long, value_parser = whole::<u32>(1, MAX_STAGES as u64, "stages"))]
    pub stages: Option<u32>,
    /// Law of the register output for one input electron: `register` (exact, needs the
    /// conversion gain), `gamma` (a Gamma law with the register's F^2) or `exponential` (the
    /// paper's Eq. 2, F^2 = 2). Default: register when the conversion gain is given, else gamma.
    #[arg(long, value_enum)]
    pub law: Option<EmLaw>,
    /// Serial clock-induced charge (electrons born inside the register, with partial gain):
    /// `auto` fits with and without it and keeps the model with the lower BIC; `on` (also
    /// the bare flag) or `off` force it (parallel CIC is always part of lambda).
    #[arg(long, value_enum, num_args = 0..=1, default_missing_value = "on", default_value = "auto")]
    pub serial_cic: SerialCic,
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
            law: self.law,
            serial_cic: self.serial_cic == SerialCic::On,
            no_serial_cic: self.serial_cic == SerialCic::Off,
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
