//! `detnoise report`: the command line of [`crate::report`] (clap options -> report options ->
//! `report::run` -> the lines on standard error).

use super::args::{parse_list, real, whole, DetectorArgs};
use super::effective::PrecisionArgs;
use super::progress::Terminal;
use crate::montecarlo::SimConfig;
use crate::report::ReportOptions;
use crate::spot::Sampling;
use crate::spot::Spot;
use crate::Result;
use std::ops::Bound::{Excluded, Included, Unbounded};
use std::path::PathBuf;

use crate::report::DetectorKind;

/// Options of `detnoise report`.
#[derive(clap::Args, Debug)]
pub struct ReportArgs {
    /// The camera type: scmos (effective read noise from the per-pixel noise) or emccd (EM gain
    /// fit with the exact register, then the comparison with the fitted gain and read noise).
    #[arg(long = "detector", id = "detector_kind", value_enum, default_value_t = DetectorKind::Scmos)]
    pub kind: DetectorKind,
    /// Dark frames: files, a directory or a glob (FITS, TIFF, OpenEXR).
    #[arg(long, num_args = 1.., required = true)]
    pub darks: Vec<PathBuf>,
    /// Flat stacks at several light levels, one option per level (photon transfer gives the gain).
    #[arg(long, num_args = 1..)]
    pub flats: Vec<PathBuf>,
    /// Conversion gain, e- per adu (needed when no flats are given).
    #[arg(long, value_parser = real(Excluded(0.0), Unbounded, "e- per adu"))]
    pub gain_e_per_adu: Option<f64>,
    /// Sub-aperture sizes of the effective-noise table, px per side (2 to 128), comma-separated.
    #[arg(long, default_value = DEFAULT_SUBAP, allow_hyphen_values = true)]
    pub subap: String,
    /// Airy spot diameters (first dark ring, px, >= 0.1) of the table: airy:D1,D2,...
    #[arg(long, default_value = DEFAULT_SPOT, allow_hyphen_values = true)]
    pub spot: String,
    /// Signal levels, photons per sub-aperture, comma-separated (signal x QE at most 1e9).
    #[arg(long, default_value = DEFAULT_SIGNAL, allow_hyphen_values = true)]
    pub signal: String,
    /// Starting Monte-Carlo iterations per configuration of the effective-noise table, 2 to 1e9
    /// (also the comparison's count): more are added, up to --max-iters, until each value meets
    /// the precision target.
    #[arg(long, default_value_t = 10_000, value_parser = whole::<u64>(2, SimConfig::MAX_ITERS, "frames"))]
    pub iters: u64,
    /// Precision target of each effective read noise and the iteration cap.
    #[command(flatten)]
    pub precision: PrecisionArgs,
    /// Seed of every random stream.
    #[arg(long, default_value_t = 1, value_parser = whole::<u64>(0, u64::MAX, ""))]
    pub seed: u64,
    /// Spot sampling.
    #[arg(long, value_enum, default_value_t = Sampling::Integrated)]
    pub sampling: Sampling,
    /// Quantum efficiency of this (sCMOS) camera in the comparison chart, (0, 1].
    #[arg(long, default_value_t = 1.0, value_parser = real(Excluded(0.0), Included(1.0), ""))]
    pub qe: f64,
    /// Quantum efficiency of the EMCCD it is compared with, (0, 1].
    #[arg(long, default_value_t = 1.0, value_parser = real(Excluded(0.0), Included(1.0), ""))]
    pub qe_emccd: f64,
    /// Use dark frames that look illuminated (variance growing with the mean across pixels, or a
    /// level near the top of the stored range); sCMOS reports only. Default: refuse them.
    #[arg(long)]
    pub accept_illuminated: bool,
    /// Fast preview (seconds for a small camera): at most 2,000 starting iterations and 24,000
    /// per configuration (--max-iters), and where left at their defaults, sub-apertures 4,8,16,
    /// spots airy:2,6 and signals 20,50,500 (stated in the report). The full grid takes a few
    /// minutes.
    #[arg(long)]
    pub quick: bool,
    /// Readout-model parameters: EM gain (e-/e-), read noise (e- rms), sCMOS pdf and map.
    #[command(flatten)]
    pub detector: DetectorArgs,
    /// Output directory, written only when the whole report succeeded; an existing directory is
    /// replaced only if detnoise wrote it.
    #[arg(long)]
    pub out: PathBuf,
    /// Write into an existing --out that holds other files (they are never replaced or deleted).
    #[arg(long)]
    pub force: bool,
}

/// The full grid's lists as typed on the command line (the library's defaults, see the test).
const DEFAULT_SUBAP: &str = "4,6,8,10,12,16";
const DEFAULT_SPOT: &str = "airy:1,2,4,6,8,10";
const DEFAULT_SIGNAL: &str = "20,50,100,200,500,1000";

impl ReportArgs {
    /// The report's options without the readout-model parameters (they read files): a list
    /// left at its default stays unset, so that `--quick` shrinks it.
    fn grid_options(&self) -> Result<ReportOptions> {
        fn unless_default<'a>(given: &'a str, default: &str) -> Option<&'a str> {
            (given != default).then_some(given)
        }
        Ok(ReportOptions {
            detector: self.kind,
            darks_paths: self.darks.clone(),
            flats_paths: self.flats.clone(),
            gain_e_per_adu: self.gain_e_per_adu,
            subaps_px: unless_default(&self.subap, DEFAULT_SUBAP)
                .map(|s| parse_list(s, "--subap"))
                .transpose()?,
            spots: unless_default(&self.spot, DEFAULT_SPOT)
                .map(|s| Spot::parse_list(&[s.to_string()]))
                .transpose()?,
            signals_photons: unless_default(&self.signal, DEFAULT_SIGNAL)
                .map(|s| parse_list(s, "--signal"))
                .transpose()?,
            iters: self.iters,
            precision: self.precision.precision(self.iters),
            seed: self.seed,
            sampling: self.sampling,
            qe: self.qe,
            qe_emccd: self.qe_emccd,
            accept_illuminated: self.accept_illuminated,
            quick: self.quick,
            model_input_paths: self.detector.input_files(),
            out_dir: self.out.clone(),
            force: self.force,
            ..ReportOptions::default()
        })
    }

    /// Check every option before any frame is read, and read the model parameters' files.
    pub fn options(&self) -> Result<ReportOptions> {
        let mut options = self.grid_options()?;
        // The register is checked with the user's gain and stages before any file is read.
        options.model_params.em_gain = self.detector.em_gain;
        options.model_params.stages = self.detector.stages;
        options.validate()?;
        options.model_params = self.detector.params()?;
        Ok(options)
    }
}

/// Entry point of `detnoise report`.
pub fn run_cli(args: &ReportArgs) -> Result<()> {
    let options = args.options()?;
    let result = crate::report::run(&options, &Terminal::default())?;
    if let Some(s) = result.scmos() {
        eprintln!(
            "report: {} dark frames of {}x{} px",
            s.frames, s.shape[0], s.shape[1]
        );
    }
    eprintln!(
        "report written to {} (open index.html)",
        result.out_dir.display()
    );
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::report::{DEFAULT_AIRY_DIAMETERS_PX, DEFAULT_SIGNALS_PHOTONS, DEFAULT_SUBAPS_PX};

    #[test]
    fn the_default_lists_are_the_librarys_full_grid() {
        assert_eq!(
            parse_list::<usize>(DEFAULT_SUBAP, "--subap").unwrap(),
            DEFAULT_SUBAPS_PX
        );
        let airy = |&diameter_px: &f64| crate::spot::Spot::Airy { diameter_px };
        let spots: Vec<_> = DEFAULT_AIRY_DIAMETERS_PX.iter().map(airy).collect();
        assert_eq!(Spot::parse_list(&[DEFAULT_SPOT.into()]).unwrap(), spots);
        assert_eq!(
            parse_list::<f64>(DEFAULT_SIGNAL, "--signal").unwrap(),
            DEFAULT_SIGNALS_PHOTONS
        );
    }
}
