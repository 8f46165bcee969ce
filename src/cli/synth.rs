//! `detnoise synth`: write a synthetic sCMOS or EMCCD stack with a manifest of its truth.

use std::path::PathBuf;

use crate::error::{Error, Result};
use crate::output::{FileOut, StagedFiles};
use crate::pdf::RmsPdf;
use crate::synth::{
    output_files, write_synthetic_in, Camera, EmccdParams, ScmosParams, StackFormat, SynthSpec,
};

/// Detector family to simulate.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum DetectorKind {
    /// sCMOS: per-pixel offset, gain and read noise.
    Scmos,
    /// EMCCD: exact EM register, CIC, output read noise.
    Emccd,
}

/// Options of `detnoise synth`.
#[derive(clap::Args, Debug)]
pub struct SynthArgs {
    /// Detector to simulate.
    #[arg(long, value_enum)]
    pub detector: DetectorKind,
    /// Frame shape ROWSxCOLS (pixels), e.g. 64x48.
    #[arg(long, value_parser = parse_shape)]
    pub shape: (usize, usize),
    /// Number of frames.
    #[arg(long)]
    pub frames: usize,
    /// Output file format.
    #[arg(long, value_enum, default_value = "fits")]
    pub format: StackFormat,
    /// Output stack path (.fits/.fit, .tif/.tiff or .exr as --format); the manifest and truth
    /// maps go beside it. All are written only when the run succeeds.
    #[arg(long)]
    pub out: PathBuf,
    /// Replace existing output files (the stack, its truth maps and manifest; never an input).
    #[arg(long)]
    pub force: bool,
    /// Seed of all random draws (same seed = same pixels at every light level).
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Mean light per pixel per frame (photo-electrons); 0 gives darks.
    #[arg(long, default_value_t = 0.0)]
    pub light_e: f64,
    /// Store 32-bit floats instead of unsigned 16-bit integers (no quantisation).
    #[arg(long)]
    pub float: bool,
    /// sCMOS per-pixel read noise: `paper` (Basden 2015 Eq. 3 on [0, 10] e-), or a
    /// constant in e- (e.g. `1.5`), or a noise map file (FITS/TIFF/EXR, e-) sampled empirically.
    #[arg(long, default_value = "paper")]
    pub rms_pdf: String,
    /// sCMOS mean offset (adu).
    #[arg(long, default_value_t = 100.0)]
    pub offset_adu: f64,
    /// sCMOS pixel-to-pixel offset spread, standard deviation (adu).
    #[arg(long, default_value_t = 2.0)]
    pub offset_spread_adu: f64,
    /// sCMOS mean conversion gain (e per adu); EMCCD: output conversion factor (e per adu, default 10).
    #[arg(long)]
    pub gain_e_per_adu: Option<f64>,
    /// sCMOS relative pixel-to-pixel gain spread (standard deviation / mean).
    #[arg(long, default_value_t = 0.02)]
    pub gain_spread: f64,
    /// EMCCD mean EM gain (output e- per input e-).
    #[arg(long, default_value_t = 300.0)]
    pub em_gain: f64,
    /// EMCCD number of register stages.
    #[arg(long, default_value_t = 520)]
    pub stages: u32,
    /// EMCCD bias (adu).
    #[arg(long, default_value_t = 500.0)]
    pub bias_adu: f64,
    /// EMCCD output read noise (e-).
    #[arg(long, default_value_t = 50.0)]
    pub read_noise_e: f64,
    /// EMCCD clock-induced charge (e- per pixel per frame).
    #[arg(long, default_value_t = 0.005)]
    pub cic_e: f64,
}

/// Parse `ROWSxCOLS`.
pub fn parse_shape(s: &str) -> std::result::Result<(usize, usize), String> {
    let (r, c) = s
        .split_once(['x', 'X'])
        .ok_or_else(|| format!("expected ROWSxCOLS, got {s}"))?;
    let r: usize = r
        .trim()
        .parse()
        .map_err(|_| format!("bad row count in {s}"))?;
    let c: usize = c
        .trim()
        .parse()
        .map_err(|_| format!("bad column count in {s}"))?;
    if r == 0 || c == 0 {
        return Err(format!("empty shape {s}"));
    }
    Ok((r, c))
}

/// Build the read-noise pdf named by `--rms-pdf`.
pub fn rms_pdf(spec: &str) -> Result<Box<dyn RmsPdf>> {
    if spec == "paper" {
        return Ok(Box::new(crate::pdf::paper()));
    }
    if let Ok(v) = spec.parse::<f64>() {
        if !(v >= 0.0 && v.is_finite()) {
            return Err(Error::usage(
                "--rms-pdf",
                "constant read noise must be finite and >= 0",
            ));
        }
        return Ok(Box::new(
            crate::pdf::EmpiricalPdf::new(&[v], &format!("constant {v} e-"))
                .ok_or_else(|| Error::usage("--rms-pdf", "bad constant"))?,
        ));
    }
    let map = crate::maps::read_map(spec)?;
    let values: Vec<f64> = map.data.into_iter().filter(|v| v.is_finite()).collect();
    let pdf = crate::pdf::EmpiricalPdf::new(&values, &format!("map {spec}"))
        .ok_or_else(|| Error::input(spec, "frame 0: noise map has no finite value"))?;
    Ok(Box::new(pdf))
}

/// Build the simulation spec from the options.
pub fn spec(args: &SynthArgs) -> Result<SynthSpec> {
    if !(args.light_e >= 0.0 && args.light_e.is_finite()) {
        return Err(Error::usage("--light-e", "must be finite and >= 0"));
    }
    if args
        .gain_e_per_adu
        .is_some_and(|g| !(g > 0.0 && g.is_finite()))
    {
        return Err(Error::usage("--gain-e-per-adu", "must be finite and > 0"));
    }
    let camera = match args.detector {
        DetectorKind::Scmos => Camera::Scmos(ScmosParams {
            offset_adu: args.offset_adu,
            offset_spread_adu: args.offset_spread_adu,
            gain_e_per_adu: args.gain_e_per_adu.unwrap_or(0.25),
            gain_spread: args.gain_spread,
        }),
        DetectorKind::Emccd => Camera::Emccd(EmccdParams {
            em_gain: args.em_gain,
            stages: args.stages,
            bias_adu: args.bias_adu,
            read_noise_e: args.read_noise_e,
            cic_e: args.cic_e,
            conversion_e_per_adu: args.gain_e_per_adu.unwrap_or(10.0),
        }),
    };
    Ok(SynthSpec {
        camera,
        shape: args.shape,
        frames: args.frames,
        light_e: args.light_e,
        seed: args.seed,
        u16_samples: !args.float,
    })
}

/// Run `detnoise synth`.
pub fn run(args: &SynthArgs) -> Result<()> {
    let staged = prepare_outputs(args)?;
    let spec = spec(args)?;
    let pdf = rms_pdf(&args.rms_pdf)?;
    let m = write_synthetic_in(&spec, pdf.as_ref(), args.format, &args.out, staged.dir())?;
    staged.commit()?;
    eprintln!(
        "wrote {} ({} frames of {}x{}), median read noise {:.3} e-, truth maps and manifest beside it",
        args.out.display(),
        spec.frames,
        spec.shape.0,
        spec.shape.1,
        m.rms_e_median
    );
    Ok(())
}

/// Check the stack path and the files beside it before any work, and stage them.
fn prepare_outputs(args: &SynthArgs) -> Result<StagedFiles> {
    let (exts, what): (&[&str], &str) = match args.format {
        StackFormat::Fits => (&["fits", "fit"], "a FITS stack (--format fits)"),
        StackFormat::Tiff => (&["tif", "tiff"], "a TIFF stack (--format tiff)"),
        StackFormat::Exr => (&["exr"], "an OpenEXR stack (--format exr)"),
    };
    let files = output_files(&args.out);
    let outs: Vec<FileOut> = files
        .iter()
        .enumerate()
        .map(|(i, path)| FileOut {
            path,
            option: "--out",
            exts: if i == 0 { exts } else { &[] },
            what,
        })
        .collect();
    let inputs: Vec<PathBuf> = std::fs::symlink_metadata(&args.rms_pdf)
        .is_ok()
        .then(|| PathBuf::from(&args.rms_pdf))
        .into_iter()
        .collect();
    StagedFiles::prepare(&outs, args.force, &inputs)
}
