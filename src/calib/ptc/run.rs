//! `detnoise ptc` as one library call: dark reference and flats in; per-pixel gain, gain error
//! and read-noise maps, the photon-transfer chart, its points (ptc_points.csv/.json) and
//! ptc.json written to an output directory that appears only when the run succeeds.

use std::path::{Path, PathBuf};

use serde::Serialize;

use super::excess::ExcessNoise;
use super::points::{write_points, POINTS_NAMES};
use super::transfer::{photon_transfer, DarkReference, Level, PtcOptions, PtcResult};
use crate::calib::darks::{pixel_stats, Clip};
use crate::calib::summary::{inputs, Checksum, Distribution, InputFile};
use crate::calib::{Map, Unit};
use crate::error::{Error, Result};
use crate::io::fits::{key, KeyValue};
use crate::io::FrameStack;
use crate::output::{DirPlan, OutputDir};
use crate::plot::ScatterFit;

/// Files `ptc` writes into its directory.
pub const OUTPUT_NAMES: [&str; 7] = [
    "gain_e_per_adu.fits",
    "gain_err_e_per_adu.fits",
    "read_noise_e.fits",
    "ptc.png",
    POINTS_NAMES[0],
    POINTS_NAMES[1],
    "ptc.json",
];

/// Where the dark reference comes from.
#[derive(Clone, Debug)]
pub enum DarkInput {
    /// A dark stack (file, directory or glob): its per-pixel mean and variance.
    Stack(PathBuf),
    /// An offset map and a read-noise map (adu; FITS/TIFF/EXR), e.g. from `darks`.
    Maps {
        /// Offset map (adu).
        offset: PathBuf,
        /// Read-noise map (adu rms).
        rms: PathBuf,
    },
}

/// A photon-transfer analysis to run.
#[derive(Clone, Debug)]
pub struct PtcRun {
    /// The dark reference.
    pub darks: DarkInput,
    /// Flat stacks, one per light level (each a file, directory or glob).
    pub flats: Vec<PathBuf>,
    /// Output directory (replaced only if detnoise wrote it).
    pub out: PathBuf,
    /// Write into an existing `out` that holds other files (never replacing them).
    pub force: bool,
    /// Flicker removal, saturation, EM gain and excess noise factor.
    pub options: PtcOptions,
}

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
    /// Reduced chi-square of the global fit; null with 1 or 2 levels (no degrees of freedom).
    pub reduced_chi2: Option<f64>,
    /// `checked` when the reduced chi-square exists, `no_degrees_of_freedom` when it does not.
    pub fit_check: &'static str,
    /// The flats' excess-noise signature (third-moment ratio, 1 shot noise, 1.5 EM register).
    pub excess_noise: ExcessNoise,
    /// Results to distrust (EM gain missing or not seen, a fit that cannot be checked).
    pub warnings: Vec<String>,
    /// Median read noise (e-) = median dark rms (adu) x global gain.
    pub read_noise_e_median: f64,
    /// Per-pixel gain distribution (e per adu).
    pub gain_map: Distribution,
    /// Per-pixel read noise distribution (e-).
    pub read_noise_e_map: Distribution,
    /// Light levels.
    pub levels: Vec<Level>,
    /// Dark inputs with BLAKE3.
    pub dark_inputs: Vec<InputFile>,
    /// Flat inputs with BLAKE3, per level.
    pub flat_inputs: Vec<Vec<InputFile>>,
    /// Files written.
    pub outputs: Vec<String>,
}

/// What a photon-transfer run produced.
#[derive(Debug)]
pub struct PtcRunResult {
    /// The analysis (maps, levels, notes on stacks split into levels).
    pub result: PtcResult,
    /// The content of ptc.json.
    pub summary: PtcSummary,
    /// The output directory written.
    pub out: PathBuf,
}

/// The input record (with checksum) of a single map file.
fn map_input(path: &Path) -> Result<InputFile> {
    let stack = FrameStack::open(&[path.to_path_buf()])?;
    Ok(inputs(&stack, Checksum::Blake3)?.remove(0))
}

/// The dark reference and its input records.
fn dark_reference(darks: &DarkInput) -> Result<(DarkReference, Vec<InputFile>)> {
    match darks {
        DarkInput::Stack(d) => {
            let stack = FrameStack::open(std::slice::from_ref(d))?;
            let stats = pixel_stats(&stack, Clip::None, None)?;
            Ok((
                DarkReference::from_stats(&stats),
                inputs(&stack, Checksum::Blake3)?,
            ))
        }
        DarkInput::Maps { offset, rms } => {
            let (off, r) = (Map::read(offset, Unit::Adu)?, Map::read(rms, Unit::Adu)?);
            if off.shape() != r.shape() {
                return Err(Error::input(
                    rms,
                    format!(
                        "frame 0: shape {}x{} differs from the offset map's {}x{}",
                        r.rows, r.cols, off.rows, off.cols
                    ),
                ));
            }
            Ok((
                DarkReference::from_maps(off, &r),
                vec![map_input(offset)?, map_input(rms)?],
            ))
        }
    }
}

/// Run a photon-transfer analysis and write its outputs.
pub fn run(job: &PtcRun) -> Result<PtcRunResult> {
    let dark_paths = match &job.darks {
        DarkInput::Stack(d) => vec![d.clone()],
        DarkInput::Maps { offset, rms } => vec![offset.clone(), rms.clone()],
    };
    let input_paths: Vec<PathBuf> = dark_paths.into_iter().chain(job.flats.clone()).collect();
    // Each stack checks only its own files: one file given as two flats (two light levels of
    // one) or as the darks and a flat is refused here, before any output.
    let mut stacks = job.flats.clone();
    if let DarkInput::Stack(d) = &job.darks {
        stacks.push(d.clone());
    }
    if !stacks.is_empty() {
        let files = crate::io::expand_inputs(&stacks)?;
        crate::io::check_distinct(&files, "the darks' and flats' files")?;
    }
    let dir = OutputDir::prepare(
        &job.out,
        DirPlan {
            command: "ptc",
            force: job.force,
            inputs: &input_paths,
            names: &OUTPUT_NAMES,
        },
    )?;
    let opts = &job.options;
    let (dark, dark_inputs) = dark_reference(&job.darks)?;
    let flats: Vec<FrameStack> = job
        .flats
        .iter()
        .map(|f| FrameStack::open(std::slice::from_ref(f)))
        .collect::<Result<_>>()?;
    let r = photon_transfer(&flats, &dark, opts)?;
    let flat_inputs = flats
        .iter()
        .map(|f| inputs(f, Checksum::Blake3))
        .collect::<Result<Vec<_>>>()?;
    let summary = PtcSummary {
        tool: format!("detnoise {}", env!("CARGO_PKG_VERSION")),
        command: "ptc",
        options: opts.clone(),
        gain_e_per_adu: r.gain_e_per_adu,
        gain_err_e_per_adu: r.gain_err_e_per_adu,
        intercept_adu2: r.intercept_adu2,
        reduced_chi2: r.reduced_chi2,
        fit_check: match r.reduced_chi2 {
            Some(_) => "checked",
            None => "no_degrees_of_freedom",
        },
        excess_noise: r.excess_noise,
        warnings: r.warnings.clone(),
        read_noise_e_median: r.read_noise_e_median,
        gain_map: Distribution::of(&r.gain_map.data),
        read_noise_e_map: Distribution::of(&r.read_noise_e_map.data),
        levels: r.levels.clone(),
        dark_inputs,
        flat_inputs,
        outputs: OUTPUT_NAMES.iter().map(|s| s.to_string()).collect(),
    };
    chart(&r, &dir.path("ptc.png"))?;
    write_points(&r, &dir.path(""))?;
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
    r.gain_map
        .write_fits(&dir.path("gain_e_per_adu.fits"), &keys)?;
    r.gain_err_map
        .write_fits(&dir.path("gain_err_e_per_adu.fits"), &keys)?;
    r.read_noise_e_map
        .write_fits(&dir.path("read_noise_e.fits"), &keys)?;
    crate::output::write_json(&dir.path("ptc.json"), &summary)?;
    Ok(PtcRunResult {
        result: r,
        summary,
        out: dir.commit()?,
    })
}

/// The photon-transfer chart (dark-subtracted variance against mean, log-log, with the fit)
/// written to `path` (PNG or SVG by extension), atomically.
pub fn chart(r: &PtcResult, path: &Path) -> Result<()> {
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
