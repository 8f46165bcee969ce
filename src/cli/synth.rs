//! `detnoise synth`: write a synthetic sCMOS or EMCCD stack with a manifest of its truth.

use std::ops::Bound::{Excluded, Included, Unbounded};
use std::path::PathBuf;

use super::args::{real, whole};
use crate::detector::register::{MAX_EM_GAIN, MAX_STAGES};
use crate::detector::EmRegister;
use crate::error::Result;
use crate::output::{FileOut, StagedFiles};
use crate::synth::{
    output_files_for, parse_shape, rms_pdf, write_synthetic_in, Camera, Defects, EmccdParams,
    RtsParams, ScmosParams, SynthFormat, SynthSpec, MAX_FRAMES, MAX_LIGHT_E,
};

/// sCMOS conversion gain without `--gain-e-per-adu`, e- per adu (stated in its help).
const SCMOS_GAIN_E_PER_ADU: f64 = 0.25;
/// EMCCD mean EM gain without `--em-gain`, e-/e- (stated in its help).
const DEFAULT_EM_GAIN: f64 = 300.0;
/// EMCCD output conversion factor without `--gain-e-per-adu`, e- per adu (stated in its help).
const EMCCD_GAIN_E_PER_ADU: f64 = 10.0;

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
    /// Detector to simulate (not with --camera, which states it).
    #[arg(
        long,
        value_enum,
        required_unless_present = "camera",
        conflicts_with = "camera"
    )]
    pub detector: Option<DetectorKind>,
    /// Frame shape ROWSxCOLS (pixels), e.g. 64x48; at most 16,777,216 pixels (4096x4096)
    /// (not with --camera: its maps' shape).
    #[arg(long, value_parser = parse_shape, required_unless_present = "camera", conflicts_with = "camera")]
    pub shape: Option<(usize, usize)>,
    /// Dark frames of this measured camera model (a folder with camera.json and its maps,
    /// docs/camera.md) at the operating point of --exposure-s, --em-gain, --temperature-c,
    /// with the master dark (`<stem>.master_dark_adu.fits`, adu) and its standard error per
    /// pixel (`<stem>.master_dark_se_e.fits`, e-) beside the stack.
    #[arg(long, value_name = "FILE", requires = "exposure_s")]
    pub camera: Option<PathBuf>,
    /// Exposure time of each frame of --camera, s, > 0 and at most 86400.
    #[arg(long, value_parser = real(Excluded(0.0), Included(crate::camera::MAX_EXPOSURE_S), "s"), requires = "camera")]
    pub exposure_s: Option<f64>,
    /// Sensor temperature of --camera, degrees C (its dark current scaled by the model's
    /// doubling temperature); default: the temperature its dark current was measured at.
    #[arg(long, value_parser = real(Included(-273.15), Included(200.0), "degrees C"), requires = "camera")]
    pub temperature_c: Option<f64>,
    /// Number of frames, 1 to 1,000,000.
    #[arg(long, value_parser = whole::<usize>(1, MAX_FRAMES, "frames"))]
    pub frames: usize,
    /// Output file format.
    #[arg(long, value_enum, default_value = "fits")]
    pub format: SynthFormat,
    /// Output stack path (.fits/.fit, .tif/.tiff or .exr as --format); the manifest and truth
    /// maps go beside it. All are written only when the run succeeds.
    #[arg(long)]
    pub out: PathBuf,
    /// Replace existing output files (the stack, its truth maps and manifest; never an input).
    #[arg(long)]
    pub force: bool,
    /// Seed of all random draws (same seed = same pixels at every light level).
    #[arg(long, default_value_t = 1, value_parser = whole::<u64>(0, u64::MAX, ""))]
    pub seed: u64,
    /// Mean light per pixel per frame (photo-electrons), 0 to 1e6 (above any pixel's full
    /// well); 0 gives darks.
    #[arg(long, default_value_t = 0.0, value_parser = real(Included(0.0), Included(MAX_LIGHT_E), "e-"))]
    pub light_e: f64,
    /// Store 32-bit floats instead of unsigned 16-bit integers (no quantisation).
    #[arg(long)]
    pub float: bool,
    /// sCMOS per-pixel read noise: `paper` (Basden 2015 Eq. 3 on [0, 10] e-), or a
    /// constant in e- (e.g. `1.5`), or a noise map file (FITS/TIFF/EXR, e-) sampled empirically.
    #[arg(long, default_value = "paper")]
    pub rms_pdf: String,
    /// sCMOS mean offset (adu).
    #[arg(long, default_value_t = 100.0, value_parser = real(Unbounded, Unbounded, "adu"))]
    pub offset_adu: f64,
    /// sCMOS pixel-to-pixel offset spread, standard deviation (adu).
    #[arg(long, default_value_t = 2.0, value_parser = real(Included(0.0), Unbounded, "adu"))]
    pub offset_spread_adu: f64,
    /// Conversion gain, e- per adu: sCMOS, the mean over the pixels (default 0.25); EMCCD, the
    /// output conversion factor (default 10).
    #[arg(long, value_parser = real(Excluded(0.0), Included(crate::settings::MAX_GAIN_E_PER_ADU), "e- per adu"))]
    pub gain_e_per_adu: Option<f64>,
    /// sCMOS relative pixel-to-pixel gain spread (standard deviation / mean, unitless), [0, 1].
    #[arg(long, default_value_t = 0.02, value_parser = real(Included(0.0), Included(1.0), ""))]
    pub gain_spread: f64,
    /// EMCCD mean EM gain (output e- per input e-), 1 to 10,000; default 300. With --camera,
    /// the commanded gain of its register (its gain curve gives the actual one); default none
    /// (no multiplication).
    #[arg(long, value_parser = real(Included(1.0), Included(MAX_EM_GAIN), "e-/e-"))]
    pub em_gain: Option<f64>,
    /// EMCCD number of register stages, 1 to 2000 and at least log2(--em-gain).
    #[arg(long, default_value_t = 520, value_parser = whole::<u32>(1, MAX_STAGES as u64, "stages"))]
    pub stages: u32,
    /// EMCCD bias (adu).
    #[arg(long, default_value_t = 500.0, value_parser = real(Unbounded, Unbounded, "adu"))]
    pub bias_adu: f64,
    /// EMCCD output read noise (e-).
    #[arg(long, default_value_t = 50.0, value_parser = real(Included(0.0), Unbounded, "e-"))]
    pub read_noise_e: f64,
    /// EMCCD clock-induced charge (e- per pixel per frame), 0 to 1e6.
    #[arg(long, default_value_t = 0.005, value_parser = real(Included(0.0), Included(MAX_LIGHT_E), "e-"))]
    pub cic_e: f64,
    /// sCMOS fraction of random-telegraph (RTS) pixels, [0, 1] (unitless); their truth goes
    /// to `<stem>.truth-rts.csv` (the columns of `darks`' rts.csv).
    #[arg(long, default_value_t = 0.0, value_parser = real(Included(0.0), Included(1.0), ""))]
    pub rts_fraction: f64,
    /// sCMOS RTS level heights above the lowest level (e-), ascending, comma-separated: one
    /// for two levels, two for three (as many as --rts-dwell-frames has values, less one).
    #[arg(long, value_delimiter = ',', default_value = "8")]
    pub rts_steps_e: Vec<f64>,
    /// sCMOS relative pixel-to-pixel spread of the RTS heights (standard deviation / mean,
    /// unitless), [0, 1).
    #[arg(long, default_value_t = 0.25, value_parser = real(Included(0.0), Excluded(1.0), ""))]
    pub rts_step_spread: f64,
    /// sCMOS mean dwell time of each RTS level (frames, >= 1), comma-separated: two or three
    /// values, the number of levels.
    #[arg(long, value_delimiter = ',', default_value = "30,10")]
    pub rts_dwell_frames: Vec<f64>,
    /// sCMOS occupancy of each RTS level (unitless fractions summing to 1), comma-separated.
    /// Without it: proportional to --rts-dwell-frames (with two levels it must be).
    #[arg(long, value_delimiter = ',')]
    pub rts_occupancy: Option<Vec<f64>>,
    /// sCMOS row noise (e-): one normal draw per row and frame, shared by the row.
    #[arg(long, default_value_t = 0.0, value_parser = real(Included(0.0), Included(crate::settings::MAX_NOISE_E), "e-"))]
    pub row_noise_e: f64,
    /// sCMOS column noise (e-): one normal draw per column and frame, shared by the column.
    #[arg(long, default_value_t = 0.0, value_parser = real(Included(0.0), Included(crate::settings::MAX_NOISE_E), "e-"))]
    pub column_noise_e: f64,
    /// sCMOS fraction of hot pixels, [0, 1] (unitless); their dark signal goes to
    /// `<stem>.truth-hot_dark_e.fits`.
    #[arg(long, default_value_t = 0.0, value_parser = real(Included(0.0), Included(1.0), ""))]
    pub hot_fraction: f64,
    /// sCMOS dark signal of a hot pixel (e- per frame, Poisson), 0 to 1e6.
    #[arg(long, default_value_t = 50.0, value_parser = real(Included(0.0), Included(MAX_LIGHT_E), "e- per frame"))]
    pub hot_dark_e: f64,
}

impl SynthArgs {
    /// Check the options together before anything is written (single values are
    /// range-checked while parsing; `--rms-pdf` when the pdf is built).
    pub fn validate(&self) -> Result<()> {
        if self.detector == Some(DetectorKind::Emccd) {
            EmRegister::check(self.em_gain(), self.stages, "--em-gain")?;
        } else {
            defects(self).check()?;
        }
        Ok(())
    }
}

impl SynthArgs {
    /// The EM gain of a synthetic EMCCD (e-/e-): --em-gain, else the bundled stacks' 300.
    fn em_gain(&self) -> f64 {
        self.em_gain.unwrap_or(DEFAULT_EM_GAIN)
    }
}

/// Build the simulation spec from the options.
pub fn spec(args: &SynthArgs) -> Result<SynthSpec> {
    let (Some(detector), Some(shape)) = (args.detector, args.shape) else {
        return Err(crate::Error::invalid(
            "--detector",
            "give --detector and --shape (or --camera)",
        ));
    };
    let camera = match detector {
        DetectorKind::Scmos => Camera::Scmos(ScmosParams {
            offset_adu: args.offset_adu,
            offset_spread_adu: args.offset_spread_adu,
            gain_e_per_adu: args.gain_e_per_adu.unwrap_or(SCMOS_GAIN_E_PER_ADU),
            gain_spread: args.gain_spread,
            defects: defects(args),
        }),
        DetectorKind::Emccd => Camera::Emccd(EmccdParams {
            em_gain: args.em_gain(),
            stages: args.stages,
            bias_adu: args.bias_adu,
            read_noise_e: args.read_noise_e,
            cic_e: args.cic_e,
            conversion_e_per_adu: args.gain_e_per_adu.unwrap_or(EMCCD_GAIN_E_PER_ADU),
        }),
    };
    Ok(SynthSpec {
        camera,
        shape,
        frames: args.frames,
        light_e: args.light_e,
        seed: args.seed,
        u16_samples: !args.float,
    })
}

/// The sCMOS defects the options ask for (none by default).
fn defects(args: &SynthArgs) -> Defects {
    Defects {
        rts: (args.rts_fraction > 0.0).then(|| RtsParams {
            fraction: args.rts_fraction,
            steps_e: args.rts_steps_e.clone(),
            step_spread: args.rts_step_spread,
            dwell_frames: args.rts_dwell_frames.clone(),
            occupancy: args.rts_occupancy.clone(),
        }),
        row_noise_e: args.row_noise_e,
        column_noise_e: args.column_noise_e,
        hot_fraction: args.hot_fraction,
        hot_dark_e: if args.hot_fraction > 0.0 {
            args.hot_dark_e
        } else {
            0.0
        },
    }
}

/// Run `detnoise synth`.
pub fn run(args: &SynthArgs) -> Result<()> {
    if let Some(dir) = &args.camera {
        return run_camera(args, dir);
    }
    args.validate()?;
    let spec = spec(args)?;
    let staged = prepare_outputs(args, &spec)?;
    let pdf = rms_pdf(&args.rms_pdf)?;
    let m = write_synthetic_in(&spec, pdf.as_ref(), args.format, &args.out, staged.dir())?;
    staged.commit()?;
    let defects = m
        .defects
        .as_ref()
        .map(|d| format!(", {} RTS and {} hot pixels", d.rts_pixels, d.hot_pixels))
        .unwrap_or_default();
    eprintln!(
        "wrote {} ({} frames of {}x{}), median read noise {:.3} e-{defects}, truth maps and manifest beside it",
        args.out.display(),
        spec.frames,
        spec.shape.0,
        spec.shape.1,
        m.rms_e_median
    );
    Ok(())
}

/// `synth --camera`: dark frames of the camera model at the operating point, with the master
/// dark and its error map.
fn run_camera(args: &SynthArgs, dir: &std::path::Path) -> Result<()> {
    if args.format != SynthFormat::Fits {
        return Err(crate::Error::invalid(
            "--format",
            "--camera writes a FITS stack (with its master dark): give --format fits",
        ));
    }
    if args.light_e > 0.0 {
        return Err(crate::Error::invalid(
            "--light-e",
            "--camera writes dark frames: give no light",
        ));
    }
    let op = crate::camera::OperatingPoint {
        exposure_s: args.exposure_s.expect("clap requires it with --camera"),
        em_gain: args.em_gain,
        temperature_c: args.temperature_c,
    };
    let at = crate::camera::CameraModel::read(dir)
        .and_then(|m| m.at(op))
        .map_err(|e| match e {
            crate::Error::Usage { field, message } => {
                crate::Error::invalid(format!("--{}", field.replace('_', "-")), message)
            }
            other => other,
        })?;
    let files = crate::synth::camera_dark_files(&args.out);
    let outs: Vec<FileOut> = files
        .iter()
        .enumerate()
        .map(|(i, path)| FileOut {
            path,
            option: "--out",
            exts: if i == 0 { &["fits", "fit"] } else { &[] },
            what: "a FITS stack",
        })
        .collect();
    let inputs = [dir.to_path_buf()];
    let staged = StagedFiles::prepare(&outs, args.force, &inputs)?;
    let s = crate::synth::write_camera_darks(
        &at,
        args.frames,
        args.seed,
        args.float,
        &args.out,
        staged.dir(),
    )?;
    staged.commit()?;
    eprintln!(
        "wrote {} ({} dark frames of {}x{} at {} s, EM gain {}), dark signal median {:.4} e- per \
         frame, noise median {:.3} e- rms; master dark and its standard error beside it",
        args.out.display(),
        args.frames,
        at.shape.0,
        at.shape.1,
        op.exposure_s,
        at.em_gain,
        s.dark_e_median,
        s.noise_e_median
    );
    Ok(())
}

/// Check the stack path and the files beside it before any work, and stage them.
fn prepare_outputs(args: &SynthArgs, spec: &SynthSpec) -> Result<StagedFiles> {
    let what = match args.format {
        SynthFormat::Fits => "a FITS stack (--format fits)",
        SynthFormat::Tiff => "a TIFF stack (--format tiff)",
        SynthFormat::Exr => "an OpenEXR stack (--format exr)",
    };
    let exts = args.format.extensions();
    let files = output_files_for(&args.out, spec);
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

#[cfg(test)]
mod tests {
    use super::*;
    use clap::CommandFactory;

    #[derive(clap::Parser)]
    struct Wrap {
        #[command(flatten)]
        synth: SynthArgs,
    }

    #[test]
    fn the_conversion_gain_help_states_both_defaults_the_run_uses() {
        let help = Wrap::command()
            .get_arguments()
            .find(|a| a.get_id() == "gain_e_per_adu")
            .and_then(|a| a.get_help().map(|h| h.to_string()))
            .expect("--gain-e-per-adu help");
        for (detector, gain) in [
            ("scmos", SCMOS_GAIN_E_PER_ADU),
            ("emccd", EMCCD_GAIN_E_PER_ADU),
        ] {
            assert!(help.contains(&format!("(default {gain})")), "{help}");
            let args = [
                "synth",
                "--detector",
                detector,
                "--shape",
                "4x4",
                "--frames",
                "2",
                "--out",
                "x.fits",
            ];
            let a = <Wrap as clap::Parser>::parse_from(args).synth;
            let used = match spec(&a).unwrap().camera {
                Camera::Scmos(p) => p.gain_e_per_adu,
                Camera::Emccd(p) => p.conversion_e_per_adu,
            };
            assert_eq!(used, gain, "{detector}");
        }
    }
}
