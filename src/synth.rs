//! Synthetic frame stacks with known truth: sCMOS darks/flats (per-pixel offset, gain and
//! read noise drawn from an rms pdf) and EMCCD darks/low-light frames (exact EM register).
//!
//! Per-pixel truth is drawn from `stream(seed, pixel, PURPOSE_PIXELS)`, so stacks made
//! with one seed at several light levels share their pixels (a photon-transfer series);
//! frame noise comes from `stream(seed, frame, purpose)` with a purpose that depends on
//! the light level, so each level has independent noise. Results do not depend on the
//! thread count.

use std::path::{Path, PathBuf};

use rand_distr::{Distribution, StandardNormal};
use rayon::prelude::*;
use serde::Serialize;

use crate::detector::register::EmRegister;
use crate::error::{Error, Result};
use crate::maps::{key, write_fits_map, write_json, KeyValue, Map};
use crate::pdf::RmsPdf;
use crate::rng::{stream, SimRng};
use crate::stats::poisson;

const PURPOSE_PIXELS: u64 = 0x5059_5845_4c53; // "PIXELS"
const PURPOSE_FRAMES: u64 = 0x4652_414d_4553; // "FRAMES"

/// Output file format of a synthetic stack.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[cfg_attr(feature = "cli", derive(clap::ValueEnum))]
#[serde(rename_all = "lowercase")]
pub enum StackFormat {
    /// FITS cube (one HDU, NAXIS3 = frames).
    Fits,
    /// Multi-page TIFF.
    Tiff,
    /// OpenEXR, one layer per frame.
    Exr,
}

/// sCMOS camera parameters.
#[derive(Clone, Debug, Serialize)]
pub struct ScmosParams {
    /// Mean offset (adu).
    pub offset_adu: f64,
    /// Pixel-to-pixel spread (standard deviation) of the offset (adu).
    pub offset_spread_adu: f64,
    /// Mean conversion gain (e per adu).
    pub gain_e_per_adu: f64,
    /// Relative pixel-to-pixel spread of the gain (standard deviation / mean).
    pub gain_spread: f64,
}

impl Default for ScmosParams {
    fn default() -> Self {
        ScmosParams {
            offset_adu: 100.0,
            offset_spread_adu: 2.0,
            gain_e_per_adu: 0.25,
            gain_spread: 0.02,
        }
    }
}

/// EMCCD camera parameters.
#[derive(Clone, Debug, Serialize)]
pub struct EmccdParams {
    /// Mean EM gain (output e- per input e-).
    pub em_gain: f64,
    /// Number of multiplication stages.
    pub stages: u32,
    /// Bias level (adu).
    pub bias_adu: f64,
    /// Output-amplifier read noise (e-, after the register).
    pub read_noise_e: f64,
    /// Clock-induced charge (mean input e- per pixel per frame).
    pub cic_e: f64,
    /// Conversion factor of the output amplifier (e per adu).
    pub conversion_e_per_adu: f64,
}

impl Default for EmccdParams {
    fn default() -> Self {
        EmccdParams {
            em_gain: 300.0,
            stages: 520,
            bias_adu: 500.0,
            read_noise_e: 50.0,
            cic_e: 0.005,
            conversion_e_per_adu: 10.0,
        }
    }
}

/// The camera being simulated.
#[derive(Clone, Debug, Serialize)]
#[serde(tag = "detector", rename_all = "lowercase")]
pub enum Camera {
    /// sCMOS with per-pixel offset, gain and read noise.
    Scmos(ScmosParams),
    /// EMCCD with an exact EM register.
    Emccd(EmccdParams),
}

/// What to simulate.
#[derive(Clone, Debug, Serialize)]
pub struct SynthSpec {
    /// Camera model and parameters.
    pub camera: Camera,
    /// Frame shape (rows, cols).
    pub shape: (usize, usize),
    /// Number of frames.
    pub frames: usize,
    /// Mean light per pixel per frame (photo-electrons; 0 for darks).
    pub light_e: f64,
    /// Seed of all random draws.
    pub seed: u64,
    /// Store unsigned 16-bit integers (true) or 32-bit floats.
    pub u16_samples: bool,
}

/// Per-pixel truth of a synthetic camera.
#[derive(Clone, Debug)]
pub struct Truth {
    /// Offset (adu).
    pub offset_adu: Map,
    /// Read noise (e-).
    pub rms_e: Map,
    /// Conversion gain (e per adu).
    pub gain_e_per_adu: Map,
}

impl Truth {
    /// Read noise in adu (rms_e / gain).
    pub fn rms_adu(&self) -> Map {
        let d = self
            .rms_e
            .data
            .iter()
            .zip(&self.gain_e_per_adu.data)
            .map(|(r, g)| r / g)
            .collect();
        Map::new(self.rms_e.rows, self.rms_e.cols, d)
    }
}

fn normal(rng: &mut SimRng) -> f64 {
    StandardNormal.sample(rng)
}

/// Draw the per-pixel truth. sCMOS read noise comes from `pdf`; EMCCD pixels share one
/// read noise, bias and conversion factor.
pub fn draw_truth(spec: &SynthSpec, pdf: &dyn RmsPdf) -> Truth {
    let (rows, cols) = spec.shape;
    let n = rows * cols;
    let mut offset = vec![0.0; n];
    let mut rms = vec![0.0; n];
    let mut gain = vec![0.0; n];
    for i in 0..n {
        let mut rng = stream(spec.seed, i as u64, PURPOSE_PIXELS);
        match &spec.camera {
            Camera::Scmos(p) => {
                offset[i] = p.offset_adu + p.offset_spread_adu * normal(&mut rng);
                gain[i] = p.gain_e_per_adu * (1.0 + p.gain_spread * normal(&mut rng)).max(0.1);
                rms[i] = pdf.sample(&mut rng);
            }
            Camera::Emccd(p) => {
                offset[i] = p.bias_adu;
                gain[i] = p.conversion_e_per_adu;
                rms[i] = p.read_noise_e;
            }
        }
    }
    Truth {
        offset_adu: Map::new(rows, cols, offset),
        rms_e: Map::new(rows, cols, rms),
        gain_e_per_adu: Map::new(rows, cols, gain),
    }
}

/// Frame `k` of the stack in adu (before rounding to the stored type).
pub fn frame(spec: &SynthSpec, truth: &Truth, register: Option<&EmRegister>, k: usize) -> Vec<f64> {
    let purpose = PURPOSE_FRAMES ^ spec.light_e.to_bits().rotate_left(17);
    let mut rng = stream(spec.seed, k as u64, purpose);
    let n = spec.shape.0 * spec.shape.1;
    let mut out = vec![0.0; n];
    for (i, o) in out.iter_mut().enumerate() {
        let electrons = match &spec.camera {
            Camera::Scmos(_) => {
                poisson(spec.light_e, &mut rng) as f64 + truth.rms_e.data[i] * normal(&mut rng)
            }
            Camera::Emccd(p) => {
                let k_in = poisson(spec.light_e + p.cic_e, &mut rng) as u64;
                let reg = register.expect("EMCCD needs a register");
                reg.sample(k_in, &mut rng) + p.read_noise_e * normal(&mut rng)
            }
        };
        *o = truth.offset_adu.data[i] + electrons / truth.gain_e_per_adu.data[i];
    }
    out
}

/// Manifest of a synthetic stack: the spec, the truth summary and the truth map files.
#[derive(Debug, Serialize)]
pub struct Manifest {
    /// Tool name and version.
    pub tool: String,
    /// The stack file.
    pub stack: PathBuf,
    /// Its format.
    pub format: StackFormat,
    /// What was simulated.
    pub spec: SynthSpec,
    /// Label of the read-noise pdf used (sCMOS).
    pub rms_pdf: String,
    /// Truth map files (FITS), by quantity.
    pub truth_maps: std::collections::BTreeMap<String, PathBuf>,
    /// Median of the per-pixel read noise (e-).
    pub rms_e_median: f64,
    /// Mean of the per-pixel read noise (e-).
    pub rms_e_mean: f64,
    /// EM register excess noise factor squared (EMCCD).
    pub excess_noise_factor_sq: Option<f64>,
    /// Note on how integer storage changes the measured noise.
    pub note: String,
}

/// Simulate `spec` and write the stack to `out` in `format`, its truth maps beside it
/// (`<out stem>.truth-<quantity>.fits`) and `<out stem>.manifest.json`. Returns the manifest.
pub fn write_synthetic(
    spec: &SynthSpec,
    pdf: &dyn RmsPdf,
    format: StackFormat,
    out: &Path,
) -> Result<Manifest> {
    let here = out.parent().unwrap_or(Path::new(""));
    write_synthetic_in(spec, pdf, format, out, here)
}

/// Quantities of the truth maps written beside a synthetic stack.
const TRUTH_MAPS: [&str; 4] = ["offset_adu", "rms_e", "rms_adu", "gain_e_per_adu"];

/// Every file [`write_synthetic`] writes for the stack `out`: the stack, its truth maps and
/// its manifest.
pub fn output_files(out: &Path) -> Vec<PathBuf> {
    let stem = stack_stem(out);
    let beside = |suffix: &str| stem.with_file_name(format!("{}.{suffix}", file_name(&stem)));
    std::iter::once(out.to_path_buf())
        .chain(
            TRUTH_MAPS
                .iter()
                .map(|q| beside(&format!("truth-{q}.fits"))),
        )
        .chain([beside("manifest.json")])
        .collect()
}

/// [`write_synthetic`] with every file written into the directory `dir` under its final name
/// (a staging directory moved into place by the caller); the manifest names the final paths.
pub fn write_synthetic_in(
    spec: &SynthSpec,
    pdf: &dyn RmsPdf,
    format: StackFormat,
    out: &Path,
    dir: &Path,
) -> Result<Manifest> {
    let staged = |p: &Path| dir.join(p.file_name().unwrap_or_default());
    let files = output_files(out);
    if spec.frames == 0 || spec.shape.0 == 0 || spec.shape.1 == 0 {
        return Err(Error::invalid(
            "--shape/--frames",
            "need at least one row, column and frame",
        ));
    }
    let truth = draw_truth(spec, pdf);
    let register = match &spec.camera {
        Camera::Emccd(p) => {
            EmRegister::check(p.em_gain, p.stages, "--em-gain")?;
            Some(EmRegister::new(p.em_gain, p.stages)?)
        }
        Camera::Scmos(_) => None,
    };
    // Frames are generated in parallel batches (each from its own stream) and written in order.
    let batch = 32;
    let mut queue: std::collections::VecDeque<Vec<f64>> = Default::default();
    let mut next_k = 0usize;
    let mut next = || {
        if queue.is_empty() {
            let end = (next_k + batch).min(spec.frames);
            let frames: Vec<Vec<f64>> = (next_k..end)
                .into_par_iter()
                .map(|k| frame(spec, &truth, register.as_ref(), k))
                .collect();
            queue.extend(frames);
            next_k = end;
        }
        queue
            .pop_front()
            .expect("frame count checked by the writer")
    };
    let keys = vec![
        key(
            "DNSEED",
            KeyValue::I64(spec.seed as i64),
            "detnoise synth seed",
        ),
        key(
            "DNLIGHT",
            KeyValue::F64(spec.light_e),
            "mean light per pixel per frame (e-)",
        ),
        key(
            "DNDET",
            KeyValue::Str(match spec.camera {
                Camera::Scmos(_) => "scmos".into(),
                Camera::Emccd(_) => "emccd".into(),
            }),
            "simulated detector",
        ),
    ];
    let stack_file = staged(out);
    match format {
        StackFormat::Fits => crate::io::fits::write_cube(
            &stack_file,
            spec.shape,
            spec.frames,
            spec.u16_samples,
            &mut next,
            &keys,
        )?,
        StackFormat::Tiff => crate::io::tiff::write_pages(
            &stack_file,
            spec.shape,
            spec.frames,
            spec.u16_samples,
            &mut next,
        )?,
        StackFormat::Exr => crate::io::exr::write_layers(
            &stack_file,
            spec.shape,
            spec.frames,
            spec.u16_samples,
            &mut next,
        )?,
    }
    let mut truth_maps = std::collections::BTreeMap::new();
    let rms_adu = truth.rms_adu();
    let maps = [
        (&truth.offset_adu, "adu"),
        (&truth.rms_e, "electron"),
        (&rms_adu, "adu"),
        (&truth.gain_e_per_adu, "electron/adu"),
    ];
    for ((name, (map, unit)), p) in TRUTH_MAPS.iter().zip(maps).zip(&files[1..]) {
        write_fits_map(&staged(p), map, unit, &keys)?;
        truth_maps.insert(name.to_string(), p.clone());
    }
    let manifest = Manifest {
        tool: format!("detnoise {}", env!("CARGO_PKG_VERSION")),
        stack: out.to_path_buf(),
        format,
        spec: spec.clone(),
        rms_pdf: pdf.label(),
        truth_maps,
        rms_e_median: crate::calib::darks::median(&truth.rms_e.data),
        rms_e_mean: truth.rms_e.data.iter().sum::<f64>() / truth.rms_e.data.len() as f64,
        excess_noise_factor_sq: register.as_ref().map(|r| r.excess_noise_factor_sq()),
        note: "Integer storage rounds each sample: the measured variance in adu is about rms_adu^2 + 1/12 (quantisation) for rms_adu above ~0.5 adu.".into(),
    };
    write_json(&staged(&files[5]), &manifest)?;
    Ok(manifest)
}

fn file_name(p: &Path) -> String {
    p.file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_default()
}

/// `out` without its stack extension (`.fits`, `.tif`, `.tiff`, `.exr`).
pub fn stack_stem(out: &Path) -> PathBuf {
    match out.extension().and_then(|e| e.to_str()) {
        Some("fits" | "fit" | "tif" | "tiff" | "exr") => out.with_extension(""),
        _ => out.to_path_buf(),
    }
}
