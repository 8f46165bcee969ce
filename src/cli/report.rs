//! `detnoise report`: the command line of [`crate::report`] (clap options -> report options ->
//! `report::run` -> the lines on standard error).

use super::args::{parse_list, real, whole, DetectorArgs, PrecisionArgs};
use super::progress::Terminal;
use crate::montecarlo::SimConfig;
use crate::report::{OperatingPoint, ReportOptions};
use crate::settings::{self, Setting};
use crate::spot::Sampling;
use crate::spot::Spot;
use crate::Result;
use std::ops::Bound::{Excluded, Included};
use std::path::PathBuf;

use crate::report::DetectorKind;

/// Options of `detnoise report`.
#[derive(clap::Args, Debug)]
#[command(after_long_help = SIMULATION_OPTIONS_HELP)]
#[command(mut_arg("centroider", |a| a.default_value(crate::centroid::centroider_names())))]
#[command(mut_arg("gain_e_per_adu", |a| a.help(
    "Conversion gain, e- per adu, of --darks (needed when no flats are given) and of \
     --dark-frames"
)))]
pub struct ReportArgs {
    /// The camera type: scmos (effective read noise from the per-pixel noise) or emccd (EM gain
    /// fit with the exact register, then the comparison with the fitted gain and read noise,
    /// and the simple model's effective QE factor over the grid).
    #[arg(long = "detector", id = "detector_kind", value_enum, default_value_t = DetectorKind::Scmos)]
    pub kind: DetectorKind,
    /// Dark frames: files, a directory or a glob (FITS, TIFF, OpenEXR).
    #[arg(long, num_args = 1.., required = true)]
    pub darks: Vec<PathBuf>,
    /// Flat stacks at several light levels for photon transfer (it gives the gain): one path per
    /// level (a file, directory or glob; several after one --flats), or one stack holding
    /// several levels, split by its frames' mean signal.
    #[arg(long, num_args = 1..)]
    pub flats: Vec<PathBuf>,
    /// Sub-aperture sizes of the effective-noise table, px per side (2 to 128), comma-separated.
    #[arg(long, default_value = grid_default(&settings::SUBAP_PX), allow_hyphen_values = true)]
    pub subap: String,
    /// Airy spot diameters (first dark ring, px, >= 0.1) of the table: airy:D1,D2,...
    #[arg(long, default_value = grid_default(&settings::SPOT), allow_hyphen_values = true)]
    pub spot: String,
    /// Signal levels, photons per sub-aperture, comma-separated (signal x QE at most 1e9).
    #[arg(long, default_value = grid_default(&settings::SIGNAL_PHOTONS), allow_hyphen_values = true)]
    pub signal: String,
    /// The configuration of the headline numbers and of the comparison chart: sub-aperture
    /// size (px per side), spot (airy:D or gauss:SX,SY, px) and signal (photons), e.g.
    /// 12,airy:4,100. Simulated even when it is not in the grid. Default: 8,airy:2,50.
    #[arg(long, value_name = "SUBAP,SPOT,SIGNAL", allow_hyphen_values = true)]
    pub operating_point: Option<String>,
    /// Starting Monte-Carlo iterations (frames) per configuration of the effective-noise table,
    /// 2 to 1e9 (also the comparison's count): more are added, up to --max-iters, until each
    /// value meets the precision target.
    #[arg(long, default_value_t = 10_000, value_parser = whole::<u64>(2, SimConfig::MAX_ITERS, "frames"))]
    pub iters: u64,
    /// Precision target of each effective read noise and the iteration cap.
    #[command(flatten)]
    pub precision: PrecisionArgs,
    /// Seed of every random stream (a whole number, unitless).
    #[arg(long, default_value_t = 1, value_parser = whole::<u64>(0, u64::MAX, ""))]
    pub seed: u64,
    /// Spot sampling.
    #[arg(long, value_enum, default_value_t = Sampling::Integrated)]
    pub sampling: Sampling,
    /// Quantum efficiency of the sCMOS models (this camera in an sCMOS report, the cameras it is
    /// compared with in an EMCCD report), photo-electrons per photon, (0, 1].
    #[arg(long, default_value_t = 1.0, value_parser = real(Excluded(0.0), Included(1.0), ""))]
    pub qe: f64,
    /// Quantum efficiency of the EMCCD (the one compared with in an sCMOS report, this camera in
    /// an EMCCD report), photo-electrons per photon, (0, 1].
    #[arg(long, default_value_t = 1.0, value_parser = real(Excluded(0.0), Included(1.0), ""))]
    pub qe_emccd: f64,
    /// Use dark frames that look illuminated (variance growing with the mean across pixels, or a
    /// level near the top of the stored range); sCMOS reports only. Default: refuse them.
    #[arg(long)]
    pub accept_illuminated: bool,
    /// Fast preview (seconds for a small camera): at most 2,000 starting iterations and 24,000
    /// per configuration (--max-iters), and where left at their defaults, sub-apertures 4,8,16,
    /// spots airy:2,6 and signals 20,50,500 (stated in the report). The full grid takes about
    /// 30 s on two cores for the bundled 64x64 camera (docs/performance.md).
    #[arg(long)]
    pub quick: bool,
    /// Readout-model parameters: EM gain (e-/e-), read noise (e- rms), sCMOS pdf and map.
    #[command(flatten)]
    pub detector: DetectorArgs,
    /// Lenslet geometry of the per-sub-aperture map (sCMOS): with --subap-grid the report adds
    /// the effective read noise of every sub-aperture of its measured map at the operating
    /// point's spot and signal (subaps.* files and a section of the page).
    #[command(flatten)]
    pub subap_geometry: super::subaps::SubapGeometryArgs,
    /// The centroiders of the sCMOS report's centroider section (each at its best parameter,
    /// at the operating point and over the grid's sub-aperture sizes; cog is always the
    /// reference); the first reads the per-sub-aperture map of --subap-grid.
    #[command(flatten)]
    pub centroiders: super::args::CentroiderArgs,
    /// Run the measured map through every centroider over the whole grid (every sub-aperture,
    /// spot and signal: about as long again as the effective-noise table per centroider)
    /// instead of over the sub-aperture sizes at the operating point's spot and signal.
    #[arg(long)]
    pub centroider_full_grid: bool,
    /// Output directory, written only when the whole report succeeded; an existing directory is
    /// replaced only if detnoise wrote it.
    #[arg(long)]
    pub out: PathBuf,
    /// Write into an existing --out that holds other files (they are never replaced or deleted).
    #[arg(long)]
    pub force: bool,
}

/// What each simulation option does in a report, and which a report does not use (end of
/// `report --help`; every claim follows `crate::report`: the grid, the comparison groups and
/// the parameters the report replaces with what it measured).
pub const SIMULATION_OPTIONS_HELP: &str = "\
How a report uses the simulation options:
  --subap, --spot, --signal
      The grid. sCMOS: the effective read noise of every sub-aperture x spot x signal
      (effective_noise.csv/.json, one heatmap per signal). EMCCD: the QE factor of the
      paper's simple model (emccd-simple:q) that reproduces this camera's R, for every
      sub-aperture x spot x signal (effective_qe.csv/.json, a chart at the operating point's
      spot; --target-rel and --max-iters apply, the absolute target is 0.01). Both detectors: the comparison
      (r_vs_signal.*) runs every signal at the sub-aperture and spot of --operating-point
      (default 8,airy:2,50: the configuration of the headline numbers; its signal is added to
      the comparison, and the point simulated beside the grid, when the grid lacks them).
  --iters, --seed, --sampling
      Every Monte-Carlo run of the report, the table and the comparison (--quick caps --iters
      at 2,000).
  --qe, --qe-emccd
      Photo-electrons per photon of the sCMOS and of the EMCCD models. sCMOS report: --qe is
      this camera's (table and comparison), --qe-emccd the compared EMCCD's. EMCCD report:
      --qe-emccd is this camera's, --qe the compared sCMOS models'.
  --em-gain, --emccd-read-noise
      sCMOS report: the EMCCD of the comparison. EMCCD report: not used (the fitted EM gain
      and read noise replace them), but --em-gain must still be possible with --stages.
  --stages, --register
      The EM register of the EMCCD in the comparison; in an EMCCD report --stages is also the
      register of the EM-gain fit.
  --pdf, --pdf-model
      sCMOS report: not used (the pdf fitted to the darks replaces it; a file given is still
      read). EMCCD report: the per-pixel rms pdf of the compared sCMOS models (`paper` unless
      given).
  --map
      Not used (a file given is still read): an sCMOS report simulates its own measured map,
      an EMCCD report no map.
  --centroider, --mask-above, --centroider-full-grid
      sCMOS report: the centroiders of the centroider section (the measured map and the fitted
      pdf at the operating point, the map over the grid's sub-aperture sizes, or the whole grid
      with --centroider-full-grid, and the EMCCD
      comparison with each side's best); cog is always run as the reference, and every other
      table and chart of the report uses cog. The first centroider also reads --subap-grid's
      per-sub-aperture map. EMCCD report: not used.
  --rts-table, --row-noise-e, --column-noise-e, --frame-noise-e, --dark-frames,
  --dark-frames-max-mib
      The scmos-rts, scmos-correlated and scmos-frames models (see `detnoise simulate
      --help`); a file given is read and checked. Without them an sCMOS report takes what
      --darks measured (the row, column and frame-common noise, once each).
  --camera, --exposure-s, --temperature-c, --frame-rate-hz
      Both detectors: the camera model's section (camera_noise.*): the camera at its operating
      point (exposure 1 / frame rate unless --exposure-s; neither given: the campaign's
      shortest dark exposure), its effective read noise against frame rate, and the `camera`
      readout simulated at --operating-point (QE --qe-emccd when its EM register multiplies,
      else --qe). A point beyond the campaign is warned of and marked extrapolated.
  --gain-e-per-adu
      The conversion gain of --darks (needed when no --flats are given) and of --dark-frames.
  --sigma, --gaussian-switch, --pattern-seed, --pp-rule, --pp-lambda
      Not used: they set models a report does not run (scmos-constant, emccd-distribution,
      scmos-fixed, emccd-pp; see `detnoise simulate --help`).
A report has no --bg-grid, --position-range or --max-empty-frac: it subtracts the automatic
background levels, offsets spots by up to 0.5 px and allows at most 1 % empty frames, as
`simulate` does by default.";

/// The full grid's list of `setting` as typed on the command line (the registry's
/// `COMMAND_DEFAULTS`; the library's grid, see the test).
fn grid_default(setting: &Setting) -> &'static str {
    settings::default_in("report", setting).expect("the report's grid has a default")
}

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
            gain_e_per_adu: self.detector.gain_e_per_adu(),
            subaps_px: unless_default(&self.subap, grid_default(&settings::SUBAP_PX))
                .map(|s| parse_list(s, "--subap"))
                .transpose()?,
            spots: unless_default(&self.spot, grid_default(&settings::SPOT))
                .map(|s| Spot::parse_list(&[s.to_string()]))
                .transpose()?,
            signals_photons: unless_default(&self.signal, grid_default(&settings::SIGNAL_PHOTONS))
                .map(|s| parse_list(s, "--signal"))
                .transpose()?,
            operating_point: self
                .operating_point
                .as_deref()
                .map(OperatingPoint::parse)
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
        options.model_params.em_gain = self.detector.em_gain();
        options.model_params.stages = self.detector.stages();
        options.subaps = self.subap_geometry.geometry()?;
        options.centroiders = self.centroiders.specs()?;
        options.centroider_full_grid = self.centroider_full_grid;
        options
            .model_input_paths
            .extend(self.subap_geometry.subap_mask.iter().cloned());
        options.validate()?;
        options.model_params = self.detector.params()?;
        Ok(options)
    }
}

/// Entry point of `detnoise report`.
pub fn run_cli(args: &ReportArgs) -> Result<()> {
    let options = args.options()?;
    let camera = options
        .model_params
        .camera_choice
        .as_deref()
        .map(camera_line);
    let result = crate::report::run(&options, &Terminal::default())?;
    if let Some(line) = camera {
        eprintln!("{line}");
    }
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

/// The effective read noise of the camera model at the run's operating point, in one line:
/// the frame rate is 1 / exposure, the exposure as chosen (given, 1 / --frame-rate-hz, or the
/// campaign's shortest dark exposure), and whether the point extrapolates beyond the campaign.
fn camera_line(choice: &crate::camera::CameraChoice) -> String {
    let at = &choice.at;
    let op = at.point;
    let temperature = op
        .temperature_c
        .map_or(String::new(), |t| format!(", {t} C"));
    let gain = match op.em_gain {
        Some(g) => format!("EM gain {g} (actual {:.2})", at.em_gain),
        None => "no EM gain".into(),
    };
    let extrapolates = if choice.extrapolates.is_empty() {
        String::new()
    } else {
        format!(
            "; extrapolated beyond the campaign: {}",
            choice.extrapolates.join("; ")
        )
    };
    format!(
        "camera model at {:.6} Hz ({:.6} s exposure: {}, {gain}{temperature}): effective read \
         noise {:.4} e- rms (median over the pixels of read, telegraph, dark shot, CIC (parallel and serial), \
         row, column and frame noise and the adu rounding, input-referred){extrapolates}",
        1.0 / op.exposure_s,
        op.exposure_s,
        choice.exposure.describe(),
        at.effective_read_noise_e()
    )
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::report::{DEFAULT_AIRY_DIAMETERS_PX, DEFAULT_SIGNALS_PHOTONS, DEFAULT_SUBAPS_PX};

    #[test]
    fn the_camera_line_states_the_noise_at_the_frame_rate() {
        use crate::calib::{Map, Unit};
        let cam = crate::camera::CameraModel::new(
            Map::filled(1, 1, 100.0, Unit::Adu),
            1.0,
            Map::filled(1, 1, 3.0, Unit::Electrons),
            16,
        )
        .unwrap()
        .with_dark_current(crate::camera::DarkCurrent {
            map_e_per_s: Map::filled(1, 1, 800.0, Unit::Flags),
            reference_temperature_c: None,
            doubling_temperature_c: None,
        })
        .unwrap();
        // 100 Hz: 8 e- of dark signal, noise sqrt(9 + 8) e-.
        let rate = Some((0.01, crate::camera::ExposureChoice::FrameRate));
        let choice = crate::camera::CameraChoice::new(cam, rate, None, None).unwrap();
        let line = camera_line(&choice);
        assert!(
            line.starts_with(
                "camera model at 100.000000 Hz (0.010000 s exposure: 1 / the frame rate given"
            ),
            "{line}"
        );
        assert!(
            line.contains(&format!("noise {:.4} e- rms", (17f64 + 1.0 / 12.0).sqrt())),
            "{line}"
        );
    }

    #[test]
    fn the_stated_default_operating_point_is_the_librarys() {
        assert_eq!(OperatingPoint::DEFAULT_TEXT, "8,airy:2,50");
        assert_eq!(
            OperatingPoint::parse(OperatingPoint::DEFAULT_TEXT).unwrap(),
            OperatingPoint::default()
        );
        // The option's help states the same default.
        let cmd = <ReportArgs as clap::Args>::augment_args(clap::Command::new("report"));
        let help = cmd
            .get_arguments()
            .find(|a| a.get_id() == "operating_point")
            .and_then(|a| a.get_help())
            .map(|h| h.to_string())
            .unwrap_or_default();
        assert!(
            help.contains(&format!("Default: {}", OperatingPoint::DEFAULT_TEXT)),
            "{help}"
        );
    }

    #[test]
    fn the_default_lists_are_the_librarys_full_grid() {
        assert_eq!(
            parse_list::<usize>(grid_default(&settings::SUBAP_PX), "--subap").unwrap(),
            DEFAULT_SUBAPS_PX
        );
        let airy = |&diameter_px: &f64| crate::spot::Spot::Airy { diameter_px };
        let spots: Vec<_> = DEFAULT_AIRY_DIAMETERS_PX.iter().map(airy).collect();
        assert_eq!(
            Spot::parse_list(&[grid_default(&settings::SPOT).into()]).unwrap(),
            spots
        );
        assert_eq!(
            parse_list::<f64>(grid_default(&settings::SIGNAL_PHOTONS), "--signal").unwrap(),
            DEFAULT_SIGNALS_PHOTONS
        );
    }
}
