//! `detnoise report`: a camera's dark (and flat) frames in, effective read-noise tables and
//! charts out, with one page (`index.html`) that reads offline.

use super::args::{real, whole, DetectorArgs};
use super::effective::write_outputs as write_effective;
use super::progress::Terminal;
use crate::calib::darks::{dark_maps, require_dark, DarkOptions};
use crate::calib::ptc::{photon_transfer, DarkReference, PtcOptions, PtcResult};
use crate::calib::summary::inputs;
use crate::detector::{ModelParams, ModelSpec, NoiseMap, Readout};
use crate::effective::{effective_sigma, EffectiveRecord};
use crate::fit::pdf_fit::{fit_pdf, PdfFitOptions};
use crate::io::FrameStack;
use crate::montecarlo::{run, BgGrid, SimConfig, SimRecord};
use crate::output::{render, write_atomic, write_json, DirPlan, OutputDir, TableFormat};
use crate::plot::{LineChart, Series};
use crate::spot::{Sampling, Spot};
use crate::{Error, Result};
use std::ops::Bound::{Excluded, Included, Unbounded};
use std::path::{Path, PathBuf};
use std::sync::Arc;

/// The kind of camera a report is about.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum DetectorKind {
    /// sCMOS: per-pixel read noise, fitted distribution, effective read noise.
    Scmos,
    /// EMCCD: EM gain, read noise and mean electrons fitted to the frames' histogram.
    Emccd,
}

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
    /// Monte-Carlo iterations per configuration, 2 to 1e9.
    #[arg(long, default_value_t = 10_000, value_parser = whole::<u64>(2, SimConfig::MAX_ITERS, "frames"))]
    pub iters: u64,
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
    /// Fast preview (under a minute for a small camera): at most 2,000 iterations, and where left
    /// at their defaults, sub-apertures 4,8,16, spots airy:2,6 and signals 20,50,500 (stated in
    /// the report). The full grid takes several minutes.
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

/// Files a report writes into its directory (glob patterns).
const OUTPUT_NAMES: [&str; 19] = [
    "offset_adu.fits",
    "rms_adu.fits",
    "rms_e.fits",
    "flags.fits",
    "rms_hist.png",
    "darks_summary.json",
    "pdf_fit.json",
    "pdf_fit.png",
    "effective_noise.csv",
    "effective_noise.json",
    "effective_noise_S*.png",
    "effective_noise_S*.svg",
    "r_vs_signal.csv",
    "r_vs_signal.png",
    "r_vs_signal.svg",
    "ptc.png",
    "emgain.png",
    "summary.json",
    "index.html",
];

/// The key numbers of a report, written to `summary.json`.
#[derive(Debug, serde::Serialize)]
pub struct ReportSummary {
    /// Tool and version.
    pub tool: String,
    /// Inputs with SHA-256.
    pub inputs: Vec<crate::calib::summary::InputFile>,
    /// Dark frames used.
    pub frames: usize,
    /// Frame shape [rows, cols].
    pub shape: [usize; 2],
    /// Conversion gain used (e-/adu) and where it came from.
    pub gain_e_per_adu: f64,
    /// `ptc` or `given`.
    pub gain_source: String,
    /// Standard error of the gain (e-/adu; photon transfer only).
    pub gain_se_e_per_adu: Option<f64>,
    /// Pixels used for the noise statistics (unflagged).
    pub pixels_used: usize,
    /// Pixels excluded by the dark flags (hot, dead, saturated, no data).
    pub pixels_flagged: usize,
    /// Median per-pixel read noise (e-).
    pub median_rms_e: f64,
    /// Mean per-pixel read noise (e-).
    pub mean_rms_e: f64,
    /// sqrt(mean(rms^2)) (e-), the noise-power equivalent single value.
    pub rms_rms_e: f64,
    /// Fraction of pixels above 3x the median.
    pub frac_above_3x_median: f64,
    /// Best pdf model by AIC.
    pub pdf_best_model: String,
    /// Split-half correlation of the noise maps (odd vs even frames).
    pub split_half_correlation: f64,
    /// The operating point of the headline numbers.
    pub operating_point: OperatingPoint,
    /// Monte-Carlo settings.
    pub iters: u64,
    /// Seed.
    pub seed: u64,
    /// Spot sampling.
    pub sampling: String,
    /// True for the reduced `--quick` grid.
    pub quick: bool,
}

/// The headline configuration and its numbers.
#[derive(Debug, serde::Serialize)]
pub struct OperatingPoint {
    /// Sub-aperture (px).
    pub subap_px: usize,
    /// Spot.
    pub spot: String,
    /// Signal (photons).
    pub signal_photons: f64,
    /// Effective read noise with the fitted pdf (e-).
    pub sigma_eff_fitted_pdf_e: f64,
    /// Its standard error (e-).
    pub sigma_eff_fitted_pdf_se_e: f64,
    /// Effective read noise with the measured map (e-).
    pub sigma_eff_map_e: f64,
    /// Its standard error (e-).
    pub sigma_eff_map_se_e: f64,
}

struct Grid {
    subaps: Vec<usize>,
    spots: Vec<Spot>,
    signals: Vec<f64>,
    iters: u64,
}

const DEFAULT_SUBAP: &str = "4,6,8,10,12,16";
const DEFAULT_SPOT: &str = "airy:1,2,4,6,8,10";
const DEFAULT_SIGNAL: &str = "20,50,100,200,500,1000";

fn grid(args: &ReportArgs) -> Result<Grid> {
    // --quick shrinks only what the user left at its default.
    let pick = |given: &str, default: &str, quick: &'static str| {
        if args.quick && given == default {
            quick.to_string()
        } else {
            given.to_string()
        }
    };
    Ok(Grid {
        subaps: super::args::parse_list(&pick(&args.subap, DEFAULT_SUBAP, "4,8,16"), "--subap")?,
        spots: Spot::parse_list(&[pick(&args.spot, DEFAULT_SPOT, "airy:2,6")])?,
        signals: super::args::parse_list(
            &pick(&args.signal, DEFAULT_SIGNAL, "20,50,500"),
            "--signal",
        )?,
        iters: if args.quick {
            args.iters.min(2000)
        } else {
            args.iters
        },
    })
}

impl ReportArgs {
    /// Check every option (grid lists, conversion gain, detector) before any frame is read.
    pub fn validate(&self) -> Result<()> {
        let grid = grid(self)?;
        // The comparison chart runs the EMCCD at its own QE.
        for cfg in configs(self, &grid) {
            let qe = self.qe_emccd;
            SimConfig { qe, ..cfg.clone() }.validate()?;
            cfg.validate()?;
        }
        self.detector.validate(&[])?;
        gain_source(self).map(|_| ())
    }
}

/// Where the conversion gain comes from: `Some(g)` given (e- per adu), `None` photon transfer
/// on the flats; an error when neither or both are given (or flats for an EMCCD).
fn gain_source(args: &ReportArgs) -> Result<Option<f64>> {
    match (args.gain_e_per_adu, args.flats.is_empty(), args.kind) {
        (Some(g), true, _) => Ok(Some(g)),
        (None, false, DetectorKind::Scmos) => Ok(None),
        (Some(_), false, DetectorKind::Scmos) => Err(Error::invalid(
            "--gain-e-per-adu",
            "give either --flats (photon transfer) or --gain-e-per-adu, not both",
        )),
        (_, false, DetectorKind::Emccd) => Err(Error::invalid(
            "--flats",
            "an EMCCD report takes the conversion gain from --gain-e-per-adu (photon transfer at \
             unity EM gain, or the data sheet), not from flats",
        )),
        (None, true, DetectorKind::Scmos) => Err(Error::invalid(
            "--gain-e-per-adu",
            "no conversion gain: give --gain-e-per-adu G (e- per adu, from the camera's data sheet) or flat stacks with --flats so photon transfer can measure it",
        )),
        (None, true, DetectorKind::Emccd) => Err(Error::invalid(
            "--gain-e-per-adu",
            "an EMCCD report needs the conversion gain in e- per adu (photon transfer at unity EM gain, or the data sheet)",
        )),
    }
}

/// Entry point of `detnoise report`.
pub fn run_cli(args: &ReportArgs) -> Result<()> {
    args.validate()?;
    let grid = grid(args)?;
    let input_paths: Vec<PathBuf> = args
        .darks
        .iter()
        .chain(&args.flats)
        .cloned()
        .chain(args.detector.input_files())
        .collect();
    let dir = OutputDir::prepare(
        &args.out,
        DirPlan {
            command: "report",
            force: args.force,
            inputs: &input_paths,
            names: &OUTPUT_NAMES,
        },
    )?;
    let stack = FrameStack::open(&args.darks)?;
    stack.require_frames(2, "a read-noise map")?;
    if args.kind == DetectorKind::Emccd {
        return run_emccd(args, &grid, &stack, dir);
    }
    eprintln!(
        "report: {} dark frames of {}x{} px",
        stack.frames, stack.shape.0, stack.shape.1
    );
    let dark_opts = DarkOptions::default();
    let maps = dark_maps(&stack, &dark_opts)?;
    if let Some(warning) = require_dark(&stack, &maps, args.accept_illuminated)? {
        eprintln!("warning: {warning}");
    }
    let (gain, gain_source, gain_se, ptc) = conversion_gain(args, &maps)?;
    let dark_summary = super::darks::write_outputs(
        &dir.path(""),
        &stack,
        &maps,
        &dark_opts,
        Some(gain),
        inputs(&stack)?,
        "darks_summary.json",
    )?;
    // Noise map in e-, flagged pixels excluded (NaN) from the statistics and the windows.
    let rms_e: Vec<f64> = maps
        .rms_adu
        .data
        .iter()
        .zip(&maps.flags)
        .map(|(r, f)| if *f == 0 { r * gain } else { f64::NAN })
        .collect();
    let values: Vec<f64> = rms_e
        .iter()
        .copied()
        .filter(|v| v.is_finite() && *v > 0.0)
        .collect();
    if values.len() < 16 {
        return Err(Error::input(
            &args.darks[0],
            format!(
                "only {} unflagged pixels with a positive noise: too few to fit a distribution",
                values.len()
            ),
        ));
    }
    let fit = fit_pdf(&values, &PdfFitOptions::default())?;
    fit.write_json(&dir.path("pdf_fit.json"))?;
    super::fit_pdf::chart(&fit, &values, &dir.path("pdf_fit.png"))?;
    let pdf = fit.pdf(None)?;
    let map = Arc::new(NoiseMap {
        rows: maps.rms_adu.rows,
        cols: maps.rms_adu.cols,
        rms_e,
        source: args.darks[0].display().to_string(),
    });
    let mut params = args.detector.params()?;
    params.pdf = pdf.clone();
    params.map = Some(map.clone());
    let configs = configs(args, &grid);
    let work: u64 = configs
        .iter()
        .map(|c| c.iters * (c.subap_px * c.subap_px) as u64 * 12)
        .sum();
    let progress = Terminal::default();
    crate::progress::Observer::begin(
        &progress,
        "report",
        2 * configs.iter().map(|c| c.iters).sum::<u64>(),
        work,
    );
    let mut effective = Vec::new();
    for spec in [ModelSpec::ScmosRandom, ModelSpec::ScmosMap] {
        for cfg in &configs {
            let model = spec.build(&params, cfg.subap_px)?;
            let e = effective_sigma(cfg, model.as_ref(), &progress)?;
            let label = if spec == ModelSpec::ScmosRandom {
                "scmos-random (fitted pdf)"
            } else {
                "scmos-map (measured map)"
            };
            effective.push(EffectiveRecord::new(label.into(), cfg, &e));
        }
    }
    crate::progress::Observer::end(&progress);
    let fitted: Vec<EffectiveRecord> = effective
        .iter()
        .filter(|r| r.model.starts_with("scmos-random"))
        .cloned()
        .collect();
    let heatmaps = write_effective(&fitted, &dir)?;
    write_atomic(
        &dir.path("effective_noise.csv"),
        render(&effective, TableFormat::Csv)?.as_bytes(),
    )?;
    write_atomic(
        &dir.path("effective_noise.json"),
        render(&effective, TableFormat::Json)?.as_bytes(),
    )?;
    let op = operating_point(&grid);
    let comparison = compare(args, &params, &grid, op)?;
    write_atomic(
        &dir.path("r_vs_signal.csv"),
        render(&comparison, TableFormat::Csv)?.as_bytes(),
    )?;
    comparison_chart(&comparison, &dir.path("r_vs_signal.png"), &SCMOS_LABELS)?;
    comparison_chart(&comparison, &dir.path("r_vs_signal.svg"), &SCMOS_LABELS)?;
    if let Some(p) = &ptc {
        super::ptc::chart(p, &dir.path("ptc.png"))?;
    }
    let pick = |model: &str| {
        effective
            .iter()
            .find(|r| {
                r.model.starts_with(model)
                    && r.config.subap_px == op.0
                    && r.config.spot == op.1
                    && r.config.signal_photons == op.2
            })
            .expect("operating point is in the grid")
    };
    let (fr, mr) = (pick("scmos-random"), pick("scmos-map"));
    let summary = ReportSummary {
        tool: format!("detnoise {}", env!("CARGO_PKG_VERSION")),
        inputs: dark_summary.inputs.clone(),
        frames: stack.frames,
        shape: [stack.shape.0, stack.shape.1],
        gain_e_per_adu: gain,
        gain_source,
        gain_se_e_per_adu: gain_se,
        pixels_used: values.len(),
        pixels_flagged: maps.flags.iter().filter(|f| **f != 0).count(),
        median_rms_e: fit.data.median_e,
        mean_rms_e: fit.data.mean_e,
        rms_rms_e: fit.data.rms_e,
        frac_above_3x_median: fit.data.frac_above_3x_median,
        pdf_best_model: fit.best_model.clone(),
        split_half_correlation: maps.split_half_correlation,
        operating_point: OperatingPoint {
            subap_px: op.0,
            spot: op.1.label(),
            signal_photons: op.2,
            sigma_eff_fitted_pdf_e: fr.effective.sigma_eff_e,
            sigma_eff_fitted_pdf_se_e: fr.effective.sigma_eff_se_e,
            sigma_eff_map_e: mr.effective.sigma_eff_e,
            sigma_eff_map_se_e: mr.effective.sigma_eff_se_e,
        },
        iters: grid.iters,
        seed: args.seed,
        sampling: args.sampling.label().into(),
        quick: args.quick,
    };
    write_json(&dir.path("summary.json"), &summary)?;
    let page = super::report_page::index_html(
        &summary,
        &fit,
        &effective,
        &comparison,
        &heatmaps,
        ptc.is_some(),
    );
    write_atomic(&dir.path("index.html"), page.as_bytes())?;
    let path = dir.commit()?;
    eprintln!("report written to {} (open index.html)", path.display());
    Ok(())
}

/// The key numbers of an EMCCD report, written to `summary.json`.
#[derive(Debug, serde::Serialize)]
pub struct EmccdSummary {
    /// Tool and version.
    pub tool: String,
    /// Inputs with SHA-256.
    pub inputs: Vec<crate::calib::summary::InputFile>,
    /// Frames used.
    pub frames: usize,
    /// Frame shape [rows, cols].
    pub shape: [usize; 2],
    /// Conversion gain used (e-/adu).
    pub gain_e_per_adu: f64,
    /// Read noise before the EM gain divides it (output e-).
    pub read_noise_output_e: f64,
    /// The EM-gain fit (gain in e-/e-, bias and read noise in adu, lambda in e-).
    pub emgain: crate::fit::emgain::EmGainFit,
    /// Operating point of the comparison: sub-aperture (px).
    pub subap_px: usize,
    /// Operating point: spot.
    pub spot: String,
    /// Monte-Carlo iterations.
    pub iters: u64,
    /// Seed.
    pub seed: u64,
    /// True for the reduced `--quick` grid.
    pub quick: bool,
}

/// The EMCCD report: EM-gain fit on the frames, then R against signal for an EMCCD with the
/// fitted gain and read noise beside the sCMOS models (the paper's pdf, median and mean).
fn run_emccd(args: &ReportArgs, grid: &Grid, stack: &FrameStack, dir: OutputDir) -> Result<()> {
    use crate::fit::emgain::{fit_emgain, EmGainOptions, EmShape};
    let Some(conv) = gain_source(args)? else {
        return Err(Error::invalid("--flats", "an EMCCD report takes no flats"));
    };
    crate::fit::em_signature::require_em_signature(stack)?;
    let (hist, _) = super::emgain::accumulate(stack, None, None)?;
    let opts = EmGainOptions {
        shape: EmShape::Register {
            stages: args.detector.stages,
        },
        gain_e_per_adu: Some(conv),
        ..EmGainOptions::default()
    };
    let fit = fit_emgain(&hist, &opts).map_err(|e| match e {
        Error::Numeric(m) => Error::input(&stack.sources[0].path, m),
        other => other,
    })?;
    super::emgain::chart(&hist, &fit, &dir.path("emgain.png"))?;
    let mut params = args.detector.params()?;
    params.gain = fit.em_gain.max(1.0);
    params.emccd_read_noise_e = fit.read_noise_adu * conv;
    crate::detector::EmRegister::check(params.gain, params.stages, "--gain").map_err(|e| {
        Error::input(
            &stack.sources[0].path,
            format!("the fitted EM gain cannot be simulated: {e}"),
        )
    })?;
    let op = operating_point(grid);
    let groups: [(&[&str], f64); 2] = [
        (&["scmos-random", "scmos-median", "scmos-mean"], args.qe),
        (&["emccd-stochastic"], args.qe_emccd),
    ];
    let comparison = compare_models(args, &params, grid, op, &groups)?;
    write_atomic(
        &dir.path("r_vs_signal.csv"),
        render(&comparison, TableFormat::Csv)?.as_bytes(),
    )?;
    comparison_chart(&comparison, &dir.path("r_vs_signal.png"), &EMCCD_LABELS)?;
    comparison_chart(&comparison, &dir.path("r_vs_signal.svg"), &EMCCD_LABELS)?;
    let summary = EmccdSummary {
        tool: format!("detnoise {}", env!("CARGO_PKG_VERSION")),
        inputs: inputs(stack)?,
        frames: stack.frames,
        shape: [stack.shape.0, stack.shape.1],
        gain_e_per_adu: conv,
        read_noise_output_e: params.emccd_read_noise_e,
        emgain: fit,
        subap_px: op.0,
        spot: op.1.label(),
        iters: grid.iters,
        seed: args.seed,
        quick: args.quick,
    };
    write_json(&dir.path("summary.json"), &summary)?;
    write_atomic(
        &dir.path("index.html"),
        super::report_page::emccd_html(&summary, &comparison).as_bytes(),
    )?;
    let path = dir.commit()?;
    eprintln!("report written to {} (open index.html)", path.display());
    Ok(())
}

/// The gain: from photon transfer when flats are given, else the user's; never guessed.
fn conversion_gain(
    args: &ReportArgs,
    maps: &crate::calib::darks::DarkMaps,
) -> Result<(f64, String, Option<f64>, Option<PtcResult>)> {
    match gain_source(args)? {
        Some(g) => Ok((g, "given".into(), None, None)),
        None => {
            let flats: Vec<FrameStack> = args
                .flats
                .iter()
                .map(|f| FrameStack::open(std::slice::from_ref(f)))
                .collect::<Result<_>>()?;
            let dark = DarkReference::from_stats(&maps.stats);
            let p = photon_transfer(&flats, &dark, &PtcOptions::default())?;
            Ok((
                p.gain_e_per_adu,
                "ptc".into(),
                Some(p.gain_err_e_per_adu),
                Some(p),
            ))
        }
    }
}

fn configs(args: &ReportArgs, grid: &Grid) -> Vec<SimConfig> {
    let mut out = Vec::new();
    for &n in &grid.subaps {
        for &spot in &grid.spots {
            for &signal_photons in &grid.signals {
                out.push(SimConfig {
                    spot,
                    sampling: args.sampling,
                    signal_photons,
                    qe: args.qe,
                    iters: grid.iters,
                    seed: args.seed,
                    bg_grid: BgGrid::Auto,
                    ..SimConfig::paper(n)
                });
            }
        }
    }
    out
}

/// The headline configuration: 8x8 px (or the nearest size), D = 2 px (or the first spot), 50 photons (or the nearest).
fn operating_point(grid: &Grid) -> (usize, Spot, f64) {
    let nearest_usize =
        |v: &[usize], t: usize| *v.iter().min_by_key(|x| x.abs_diff(t)).expect("non-empty");
    let nearest_f = |v: &[f64], t: f64| {
        *v.iter()
            .min_by(|a, b| (*a - t).abs().total_cmp(&(*b - t).abs()))
            .expect("non-empty")
    };
    let spot = grid
        .spots
        .iter()
        .copied()
        .find(|s| *s == Spot::Airy { diameter_px: 2.0 })
        .unwrap_or(grid.spots[0]);
    (
        nearest_usize(&grid.subaps, 8),
        spot,
        nearest_f(&grid.signals, 50.0),
    )
}

/// R against signal at the operating point's sub-aperture and spot for this camera (fitted pdf,
/// measured map), the one-number models, and an EMCCD.
fn compare(
    args: &ReportArgs,
    params: &ModelParams,
    grid: &Grid,
    op: (usize, Spot, f64),
) -> Result<Vec<SimRecord>> {
    let groups: [(&[&str], f64); 2] = [
        (
            &["scmos-random", "scmos-map", "scmos-median", "scmos-mean"],
            args.qe,
        ),
        (&["emccd-stochastic"], args.qe_emccd),
    ];
    compare_models(args, params, grid, op, &groups)
}

/// R against signal for groups of models, each group at its own QE.
fn compare_models(
    args: &ReportArgs,
    params: &ModelParams,
    grid: &Grid,
    op: (usize, Spot, f64),
    groups: &[(&[&str], f64)],
) -> Result<Vec<SimRecord>> {
    let mut out = Vec::new();
    for &signal_photons in &grid.signals {
        for &(names, qe) in groups {
            let cfg = SimConfig {
                spot: op.1,
                sampling: args.sampling,
                signal_photons,
                qe,
                iters: grid.iters,
                seed: args.seed,
                ..SimConfig::paper(op.0)
            };
            let built: Vec<Box<dyn Readout>> = names
                .iter()
                .map(|n| ModelSpec::parse(n)?.build(params, op.0))
                .collect::<Result<_>>()?;
            let refs: Vec<&dyn Readout> = built.iter().map(|m| m.as_ref()).collect();
            for r in run(&cfg, &refs, &crate::progress::Silent)? {
                out.push(SimRecord::new(&cfg, params.gain, r));
            }
        }
    }
    Ok(out)
}

/// Legend labels of the comparison chart for an sCMOS camera.
const SCMOS_LABELS: [(&str, &str); 5] = [
    ("scmos-random", "this camera (fitted pdf)"),
    ("scmos-map", "this camera (measured map)"),
    ("scmos-median", "one number: median"),
    ("scmos-mean", "one number: mean"),
    ("emccd-stochastic", "EMCCD (g = 500, 50 e- read noise)"),
];
/// Legend labels of the comparison chart for an EMCCD camera.
const EMCCD_LABELS: [(&str, &str); 4] = [
    (
        "emccd-stochastic",
        "this EMCCD (fitted gain and read noise)",
    ),
    ("scmos-random", "sCMOS, the paper's pdf"),
    ("scmos-median", "sCMOS, one number: median"),
    ("scmos-mean", "sCMOS, one number: mean"),
];

fn comparison_chart(records: &[SimRecord], path: &Path, labels: &[(&str, &str)]) -> Result<()> {
    let first = &records[0];
    let mut chart = LineChart::new(
        format!(
            "R against signal, {}x{} px, {}",
            first.config.subap_px,
            first.config.subap_px,
            first.config.spot.label()
        ),
        "signal (photons per sub-aperture)",
        "R, mean radial error (px)",
    );
    chart.log_x = true;
    chart.log_y = true;
    let mut names: Vec<String> = Vec::new();
    for r in records {
        if !names.contains(&r.result.model) {
            names.push(r.result.model.clone());
        }
    }
    chart.series = names
        .iter()
        .map(|n| {
            let label = labels
                .iter()
                .find(|(m, _)| m == n)
                .map_or(n.as_str(), |(_, l)| l);
            Series::with_errors(
                label,
                records
                    .iter()
                    .filter(|r| &r.result.model == n)
                    .map(|r| (r.config.signal_photons, r.result.r_px, r.result.r_se_px)),
            )
        })
        .collect();
    chart.save(path)
}
