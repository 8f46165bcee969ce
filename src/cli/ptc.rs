//! `detnoise ptc`: photon transfer (conversion gain, global and per pixel) from darks and flats.

use std::ops::Bound::{Excluded, Included, Unbounded};
use std::path::PathBuf;

use super::args::real;
use crate::calib::ptc::{run as run_ptc, DarkInput, PtcOptions, PtcRun};
use crate::detector::register::MAX_EM_GAIN;
use crate::error::{Error, Result};

/// Options of `detnoise ptc`.
#[derive(clap::Args, Debug)]
pub struct PtcArgs {
    /// Dark stack (file, directory or glob). Alternative: --dark-offset with --dark-rms.
    #[arg(long, required_unless_present = "dark_offset")]
    pub darks: Option<PathBuf>,
    /// Dark offset map (adu; FITS/TIFF/EXR), used instead of --darks.
    #[arg(long, requires = "dark_rms", conflicts_with = "darks")]
    pub dark_offset: Option<PathBuf>,
    /// Dark read-noise map (adu; FITS/TIFF/EXR), used with --dark-offset.
    #[arg(long, requires = "dark_offset")]
    pub dark_rms: Option<PathBuf>,
    /// Flat stacks: one path per light level (a file, directory or glob; several after one
    /// --flats), or one stack holding several levels, split by its frames' mean signal.
    #[arg(long, required = true, num_args = 1..)]
    pub flats: Vec<PathBuf>,
    /// Output directory, written only when the run succeeds; an existing directory is replaced
    /// only if detnoise wrote it.
    #[arg(long)]
    pub out: PathBuf,
    /// Write into an existing --out that holds other files (they are never replaced or deleted).
    #[arg(long)]
    pub force: bool,
    /// Keep lamp flicker in the variances (default: remove it by normalising each frame's mean).
    #[arg(long)]
    pub no_flicker_removal: bool,
    /// Saturation level (adu). Default: largest value of the stored integer type.
    #[arg(long, value_parser = real(Excluded(0.0), Unbounded, "adu"))]
    pub saturation_adu: Option<f64>,
    /// EM gain of the frames (EMCCD; output e- per input e-), 1 to 10,000.
    #[arg(long, default_value_t = 1.0, value_parser = real(Included(1.0), Included(MAX_EM_GAIN), "e-/e-"))]
    pub em_gain: f64,
    /// Excess noise factor F^2 (EMCCD; 1 without EM gain, near 2 at high gain), [1, 2] (unitless).
    #[arg(long, default_value_t = 1.0, value_parser = real(Included(1.0), Included(2.0), ""))]
    pub excess_noise_factor_sq: f64,
}

/// Run `detnoise ptc`.
pub fn run(args: &PtcArgs) -> Result<()> {
    // Every value was range-checked while parsing; clap enforces which dark inputs go together.
    let darks = match (&args.darks, &args.dark_offset, &args.dark_rms) {
        (Some(d), _, _) => DarkInput::Stack(d.clone()),
        (None, Some(o), Some(r)) => DarkInput::Maps {
            offset: o.clone(),
            rms: r.clone(),
        },
        _ => {
            return Err(Error::invalid(
                "--darks",
                "give --darks or both --dark-offset and --dark-rms",
            ))
        }
    };
    let job = PtcRun {
        darks,
        flats: args.flats.clone(),
        out: args.out.clone(),
        force: args.force,
        options: PtcOptions {
            flicker: !args.no_flicker_removal,
            saturation_adu: args.saturation_adu,
            em_gain: args.em_gain,
            excess_noise_factor_sq: args.excess_noise_factor_sq,
        },
    };
    let r = run_ptc(&job)?;
    let p = &r.result;
    p.notes.iter().for_each(|n| eprintln!("{n}"));
    let chi2 = match p.reduced_chi2 {
        Some(c) => format!("reduced chi2 {c:.2}"),
        None => "reduced chi2 n/a: no degrees of freedom, the fit cannot be checked".into(),
    };
    eprintln!(
        "conversion gain {:.5} +/- {:.5} e/adu over {} levels ({chi2}); median read noise {:.3} e-; wrote {}",
        p.gain_e_per_adu,
        p.gain_err_e_per_adu,
        p.levels.len(),
        p.read_noise_e_median,
        r.out.display()
    );
    // Last, so they are not lost above the summary.
    p.warnings.iter().for_each(|w| eprintln!("{w}"));
    Ok(())
}
