//! `detnoise fit-pdf`: fit models of the per-pixel read-noise pdf to a measured noise map.

use std::ops::Bound::{Excluded, Included, Unbounded};
use std::path::PathBuf;

use super::args::real;
use crate::calib::Unit;
use crate::error::Result;
use crate::fit::pdf_fit::{run as run_fit, FitPdfRun};
use crate::fit::PdfModel;

/// Unit of the map's values.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum MapUnit {
    /// Electrons rms.
    E,
    /// adu rms (needs --gain-e-per-adu).
    Adu,
}

/// Options of `detnoise fit-pdf`.
#[derive(clap::Args, Debug)]
pub struct FitPdfArgs {
    /// Per-pixel read-noise map (FITS/TIFF/EXR, first frame), e.g. rms_e.fits from `darks`.
    pub map: PathBuf,
    /// Output directory: pdf_fit.json and pdf_fit.png, written only when the fit succeeds; an
    /// existing directory is replaced only if detnoise wrote it.
    #[arg(long)]
    pub out: PathBuf,
    /// Write into an existing --out that holds other files (they are never replaced or deleted).
    #[arg(long)]
    pub force: bool,
    /// Unit of the map values.
    #[arg(long, value_enum, default_value = "e")]
    pub unit: MapUnit,
    /// Conversion gain (e- per adu) for --unit adu. Default: none.
    #[arg(long, value_parser = real(Excluded(0.0), Included(crate::settings::MAX_GAIN_E_PER_ADU), "e- per adu"))]
    pub gain_e_per_adu: Option<f64>,
    /// Flag map (non-zero = hot/dead/RTS pixel, excluded). Default: flags.fits beside MAP if present.
    #[arg(long)]
    pub flags: Option<PathBuf>,
    /// Keep flagged pixels in the fit. Default: off.
    #[arg(long)]
    pub keep_flagged: bool,
    /// Names of the models to fit, comma separated (paper-scaled, paper-family, lognormal+tail, empirical). Default: all.
    #[arg(long, value_delimiter = ',')]
    pub models: Vec<String>,
    /// Upper cut of the support (e-); larger values are excluded. Default: the map's largest value.
    #[arg(long, value_parser = real(Excluded(0.0), Unbounded, "e-"))]
    pub upper_cut_e: Option<f64>,
}

impl FitPdfArgs {
    /// The run these options ask for; an unknown model name is refused here, before any file
    /// is read.
    pub fn job(&self) -> Result<FitPdfRun> {
        Ok(FitPdfRun {
            map: self.map.clone(),
            out: self.out.clone(),
            force: self.force,
            unit: match self.unit {
                MapUnit::E => Unit::Electrons,
                MapUnit::Adu => Unit::Adu,
            },
            gain_e_per_adu: self.gain_e_per_adu,
            flags: self.flags.clone(),
            keep_flagged: self.keep_flagged,
            models: PdfModel::parse_list(&self.models)?,
            upper_cut_e: self.upper_cut_e,
        })
    }
}

/// Run `detnoise fit-pdf`.
pub fn run(args: &FitPdfArgs) -> Result<()> {
    let r = run_fit(&args.job()?)?;
    print!("{}", r.report.summary_text());
    Ok(())
}
