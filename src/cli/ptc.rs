//! `detnoise ptc`: photon transfer (conversion gain, global and per pixel) from darks and flats.

use std::ops::Bound::{Excluded, Included, Unbounded};
use std::path::PathBuf;

use serde::Serialize;

use super::args::real;
use crate::calib::darks::{pixel_stats, Clip};
use crate::calib::ptc::{photon_transfer, DarkReference, Level, PtcOptions};
use crate::calib::summary::{inputs, Distribution, InputFile};
use crate::detector::register::MAX_EM_GAIN;
use crate::error::{Error, Result};
use crate::io::FrameStack;
use crate::maps::{key, read_map, write_fits_map, write_json, KeyValue};
use crate::output::{DirPlan, OutputDir};
use crate::plot::ScatterFit;

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
    /// Flat stacks, one per light level (each a file, directory or glob).
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
    /// EM gain of the frames (EMCCD; output e- per input e-), 1 to 10,000. Default: 1.
    #[arg(long, default_value_t = 1.0, value_parser = real(Included(1.0), Included(MAX_EM_GAIN), "e-/e-"))]
    pub em_gain: f64,
    /// Excess noise factor F^2 (EMCCD; 1 without EM gain, near 2 at high gain), [1, 2]. Default: 1.
    #[arg(long, default_value_t = 1.0, value_parser = real(Included(1.0), Included(2.0), ""))]
    pub excess_noise_factor_sq: f64,
}

/// Files `ptc` writes into its directory.
const OUTPUTS: [&str; 5] = [
    "gain_e_per_adu.fits",
    "gain_err_e_per_adu.fits",
    "read_noise_e.fits",
    "ptc.png",
    "ptc.json",
];

/// Contents of ptc.json.
#[derive(Debug, Serialize)]
pub struct PtcSummary {
    /// Tool and version.
    pub tool: String,
    /// Subcommand.
    pub command: &'static str,
    /// Options used.
    pub options: PtcOptions,
    /// Global conversion gain (e per adu).
    pub gain_e_per_adu: f64,
    /// Its standard error (e per adu).
    pub gain_err_e_per_adu: f64,
    /// Fitted intercept of dark-subtracted variance vs mean (adu^2).
    pub intercept_adu2: f64,
    /// Reduced chi-square of the global fit.
    pub reduced_chi2: f64,
    /// Median read noise (e-) = median dark rms (adu) x global gain.
    pub read_noise_e_median: f64,
    /// Per-pixel gain distribution (e per adu).
    pub gain_map: Distribution,
    /// Per-pixel read noise distribution (e-).
    pub read_noise_e_map: Distribution,
    /// Light levels.
    pub levels: Vec<Level>,
    /// Dark inputs with SHA-256.
    pub dark_inputs: Vec<InputFile>,
    /// Flat inputs with SHA-256, per level.
    pub flat_inputs: Vec<Vec<InputFile>>,
    /// Files written.
    pub outputs: Vec<String>,
}

fn map_input(path: &PathBuf) -> Result<InputFile> {
    let stack = FrameStack::open(std::slice::from_ref(path))?;
    Ok(inputs(&stack)?.remove(0))
}

/// Run `detnoise ptc`.
pub fn run(args: &PtcArgs) -> Result<()> {
    // Every value was range-checked while parsing; clap enforces which dark inputs go together.
    let input_paths: Vec<PathBuf> = args
        .darks
        .iter()
        .chain(&args.dark_offset)
        .chain(&args.dark_rms)
        .chain(&args.flats)
        .cloned()
        .collect();
    let dir = OutputDir::prepare(
        &args.out,
        DirPlan {
            command: "ptc",
            force: args.force,
            inputs: &input_paths,
            names: &OUTPUTS,
        },
    )?;
    let opts = PtcOptions {
        flicker: !args.no_flicker_removal,
        saturation_adu: args.saturation_adu,
        em_gain: args.em_gain,
        excess_noise_factor_sq: args.excess_noise_factor_sq,
    };
    let (dark, dark_inputs) = match (&args.darks, &args.dark_offset, &args.dark_rms) {
        (Some(d), _, _) => {
            let stack = FrameStack::open(std::slice::from_ref(d))?;
            let stats = pixel_stats(&stack, Clip::None, None)?;
            (DarkReference::from_stats(&stats), inputs(&stack)?)
        }
        (None, Some(o), Some(r)) => {
            let (off, rms) = (read_map(o)?, read_map(r)?);
            if (off.rows, off.cols) != (rms.rows, rms.cols) {
                return Err(Error::input(
                    r,
                    format!(
                        "frame 0: shape {}x{} differs from the offset map's {}x{}",
                        rms.rows, rms.cols, off.rows, off.cols
                    ),
                ));
            }
            (
                DarkReference::from_maps(off, &rms),
                vec![map_input(o)?, map_input(r)?],
            )
        }
        _ => {
            return Err(Error::invalid(
                "--darks",
                "give --darks or both --dark-offset and --dark-rms",
            ))
        }
    };
    let flats: Vec<FrameStack> = args
        .flats
        .iter()
        .map(|f| FrameStack::open(std::slice::from_ref(f)))
        .collect::<Result<_>>()?;
    let r = photon_transfer(&flats, &dark, &opts)?;
    r.notes.iter().for_each(|n| eprintln!("{n}"));
    let flat_inputs = flats.iter().map(inputs).collect::<Result<Vec<_>>>()?;
    let summary = PtcSummary {
        tool: format!("detnoise {}", env!("CARGO_PKG_VERSION")),
        command: "ptc",
        options: opts.clone(),
        gain_e_per_adu: r.gain_e_per_adu,
        gain_err_e_per_adu: r.gain_err_e_per_adu,
        intercept_adu2: r.intercept_adu2,
        reduced_chi2: r.reduced_chi2,
        read_noise_e_median: r.read_noise_e_median,
        gain_map: Distribution::of(&r.gain_map.data),
        read_noise_e_map: Distribution::of(&r.read_noise_e_map.data),
        levels: r.levels.clone(),
        dark_inputs,
        flat_inputs,
        outputs: OUTPUTS.iter().map(|s| s.to_string()).collect(),
    };
    chart(&r, &dir.path("ptc.png"))?;
    let keys = vec![
        key(
            "NLEVELS",
            KeyValue::I64(r.levels.len() as i64),
            "flat light levels",
        ),
        key(
            "GAIN",
            KeyValue::F64(r.gain_e_per_adu),
            "global conversion gain (e/adu)",
        ),
        key(
            "GAINERR",
            KeyValue::F64(r.gain_err_e_per_adu),
            "standard error of GAIN (e/adu)",
        ),
        key(
            "DNFLICK",
            KeyValue::Str(opts.flicker.to_string()),
            "lamp flicker removed",
        ),
    ];
    write_fits_map(
        &dir.path("gain_e_per_adu.fits"),
        &r.gain_map,
        "electron/adu",
        &keys,
    )?;
    write_fits_map(
        &dir.path("gain_err_e_per_adu.fits"),
        &r.gain_err_map,
        "electron/adu",
        &keys,
    )?;
    write_fits_map(
        &dir.path("read_noise_e.fits"),
        &r.read_noise_e_map,
        "electron",
        &keys,
    )?;
    write_json(&dir.path("ptc.json"), &summary)?;
    let out = dir.commit()?;
    eprintln!(
        "conversion gain {:.5} +/- {:.5} e/adu over {} levels (reduced chi2 {:.2}); median read noise {:.3} e-; wrote {}",
        r.gain_e_per_adu,
        r.gain_err_e_per_adu,
        r.levels.len(),
        r.reduced_chi2,
        r.read_noise_e_median,
        out.display()
    );
    Ok(())
}

/// The photon-transfer chart (dark-subtracted variance against mean, log-log, with the fit)
/// written to `path` (PNG or SVG by extension), atomically.
pub fn chart(r: &crate::calib::ptc::PtcResult, path: &std::path::Path) -> Result<()> {
    let points: Vec<(f64, f64)> = r.levels.iter().map(|l| (l.mean_adu, l.var_adu2)).collect();
    let (a, slope) = (r.intercept_adu2, r.slope);
    ScatterFit::new(
        format!(
            "photon transfer: {:.4} ± {:.4} e⁻/adu",
            r.gain_e_per_adu, r.gain_err_e_per_adu
        ),
        "dark-subtracted mean (adu)",
        "dark-subtracted variance (adu²)",
        points,
        "light levels (mean over pixels)",
    )
    .with_fit_fn(
        format!("fit: variance = {a:.3} + {slope:.5} × mean"),
        move |m| a + slope * m,
    )
    .save(path)
}
