//! `detnoise darks`: per-pixel offset and read-noise maps from a dark stack.

use std::ops::Bound::{Excluded, Included, Unbounded};
use std::path::PathBuf;

use super::args::{real, whole};
use super::progress::Terminal;
use crate::calib::darks::{
    run as run_darks, Clip, DarkOptions, DarksRun, ExpectedDark, MAX_CLIP, MAX_SIGMA_CLIP,
};
use crate::camera::{CameraModel, OperatingPoint};
use crate::error::Result;
use crate::io::Checksum;

/// Options of `detnoise darks`.
#[derive(clap::Args, Debug)]
pub struct DarksArgs {
    /// Dark frames: FITS/TIFF/EXR files, directories or glob patterns (in stack order).
    #[arg(required = true)]
    pub stack: Vec<PathBuf>,
    /// Output directory, written only when the run succeeds; an existing directory is replaced
    /// only if detnoise wrote it.
    #[arg(long)]
    pub out: PathBuf,
    /// Write into an existing --out that holds other files (they are never replaced or deleted).
    #[arg(long)]
    pub force: bool,
    /// Conversion gain (e- per adu); when given, rms_e.fits is written too. Default: none.
    #[arg(long, value_parser = real(Excluded(0.0), Included(crate::settings::MAX_GAIN_E_PER_ADU), "e- per adu"))]
    pub gain_e_per_adu: Option<f64>,
    /// Clipping and common mode.
    #[command(flatten)]
    pub samples: SampleArgs,
    /// Hot-pixel threshold: offset above median + K robust sigmas of the offset map.
    #[arg(long, default_value_t = 5.0, value_parser = real(Excluded(0.0), Unbounded, "robust sigmas"))]
    pub hot_sigma: f64,
    /// Dead-pixel threshold: read noise below this fraction of the median read noise, [0, 1]
    /// (unitless).
    #[arg(long, default_value_t = 0.1, value_parser = real(Included(0.0), Included(1.0), ""))]
    pub dead_fraction: f64,
    /// Checksum of every input file recorded in summary.json (`inputs`), computed while the
    /// statistics run: blake3 (as `b3sum` prints it; ~0.17 CPU-s per GB) or sha256 (as
    /// `sha256sum` prints it; ~0.5 CPU-s per GB on one core, which then bounds the run).
    #[arg(long, value_enum, default_value = "blake3")]
    pub checksum: Checksum,
    /// Record no checksums of the inputs.
    #[arg(long)]
    pub no_checksums: bool,
    /// RTS threshold: von Neumann ratio below 1 - K/sqrt(frames) (K standard errors).
    #[arg(long, default_value_t = 5.0, value_parser = real(Excluded(0.0), Unbounded, "standard errors"))]
    pub rts_sigma: f64,
    /// Use frames that look illuminated (variance growing with the mean across pixels, or a
    /// level near the top of the stored range) as darks. Default: refuse them.
    #[arg(long)]
    pub accept_illuminated: bool,
    /// Measured camera model (a folder written by `campaign`, docs/camera.md) whose dark current
    /// and CIC the frames hold: the check for light takes that expected dark signal and its
    /// shot noise off first, so long darks are not read as light. Default: none (no dark
    /// signal expected).
    #[arg(long, value_name = "DIR", value_hint = clap::ValueHint::DirPath, requires = "exposure_s")]
    pub camera: Option<PathBuf>,
    /// Exposure time of each dark frame, s, > 0 and at most 86400 (with --camera).
    #[arg(long, value_parser = real(Excluded(0.0), Included(crate::camera::MAX_EXPOSURE_S), "s"), requires = "camera")]
    pub exposure_s: Option<f64>,
    /// Commanded EM gain of the dark frames, e-/e-, 1 to 10,000 (with --camera, of a camera
    /// with an EM register). Default: no multiplication.
    #[arg(long, value_parser = real(Included(1.0), Included(crate::detector::register::MAX_EM_GAIN), "e-/e-"), requires = "camera")]
    pub em_gain: Option<f64>,
    /// Sensor temperature of the dark frames, degrees C, -273.15 to 200 (with --camera). Default:
    /// the temperature the model's dark current was measured at.
    #[arg(long, value_parser = real(Included(-273.15), Included(200.0), "degrees C"), requires = "camera")]
    pub temperature_c: Option<f64>,
}

/// The options of a stack's per-pixel statistics shared by `darks` and `campaign`: sample
/// rejection per pixel and common-mode removal.
#[derive(clap::Args, Debug)]
pub struct SampleArgs {
    /// Reject the N highest and N lowest samples of each pixel (cosmic rays), N up to 100,000
    /// (and 2N + 2 at most the frame count of every stack). Default: 0.
    #[arg(long, conflicts_with = "sigma_clip", value_parser = whole::<usize>(0, MAX_CLIP as u64, "samples"))]
    pub clip: Option<usize>,
    /// Reject samples more than K standard deviations from the pixel mean (two passes), K > 0
    /// and at most 1000 (by Chebyshev's inequality at most one sample in a million lies that
    /// far out, so a larger K rejects nothing). Default: off.
    #[arg(long, value_parser = real(Excluded(0.0), Included(MAX_SIGMA_CLIP), "standard deviations"))]
    pub sigma_clip: Option<f64>,
    /// Subtract each frame's median (common-mode offset, adu; read between integer steps when
    /// values tie, so integer data leave no rounding residue) before accumulating. Default: off.
    #[arg(long)]
    pub common_mode: bool,
}

impl SampleArgs {
    /// The sample rejection asked for.
    pub fn clip(&self) -> Clip {
        match (self.clip, self.sigma_clip) {
            (Some(n), None) if n > 0 => Clip::Extremes(n),
            (_, Some(k)) => Clip::Sigma(k),
            _ => Clip::None,
        }
    }
}

/// Run `detnoise darks`.
pub fn run(args: &DarksArgs) -> Result<()> {
    let job = DarksRun {
        stack: args.stack.clone(),
        out: args.out.clone(),
        force: args.force,
        options: DarkOptions {
            clip: args.samples.clip(),
            common_mode: args.samples.common_mode,
            hot_sigma: args.hot_sigma,
            dead_fraction: args.dead_fraction,
            rts_sigma: args.rts_sigma,
        },
        gain_e_per_adu: args.gain_e_per_adu,
        checksum: (!args.no_checksums).then_some(args.checksum),
        accept_illuminated: args.accept_illuminated,
        expected_dark: expected_dark(args)?,
    };
    let r = run_darks(&job, &Terminal::default())?;
    let (bytes, secs) = (r.stored_bytes as f64, r.read_seconds);
    eprintln!(
        "read {} of samples in {secs:.3} s ({}/s)",
        decimal_size(bytes),
        decimal_size(bytes / secs.max(1e-9))
    );
    let s = &r.summary;
    eprintln!(
        "{} frames of {}x{}: median read noise {:.4} adu{}, split-half correlation {:.4}, {} flagged pixel{}; wrote {}",
        s.frames,
        s.shape[0],
        s.shape[1],
        s.rms_adu.median,
        s.rms_e.as_ref().map(|d| format!(" ({:.4} e-)", d.median)).unwrap_or_default(),
        s.split_half_correlation,
        s.flags.any,
        if s.flags.any == 1 { "" } else { "s" },
        r.out.display()
    );
    Ok(())
}

/// The dark signal the frames hold by --camera at the operating point of --exposure-s,
/// --em-gain and --temperature-c (None without --camera).
fn expected_dark(args: &DarksArgs) -> Result<Option<ExpectedDark>> {
    let (Some(dir), Some(exposure_s)) = (&args.camera, args.exposure_s) else {
        return Ok(None);
    };
    let at = CameraModel::read(dir)?.at(OperatingPoint {
        exposure_s,
        em_gain: args.em_gain,
        temperature_c: args.temperature_c,
    })?;
    Ok(Some(ExpectedDark::of_camera(
        &at,
        dir.display().to_string(),
    )))
}

/// A number of bytes in decimal units with three significant digits: "280 B", "1.64 MB",
/// "2.01 GB" (a small stack read in a millisecond is not "0.0 MB at 0 MB/s").
pub(crate) fn decimal_size(bytes: f64) -> String {
    let units = ["B", "kB", "MB", "GB", "TB"];
    let mut value = bytes;
    let mut unit = 0;
    while value >= 999.5 && unit + 1 < units.len() {
        value /= 1000.0;
        unit += 1;
    }
    let digits = match value {
        v if unit == 0 || v >= 99.95 => 0,
        v if v >= 9.995 => 1,
        _ => 2,
    };
    format!("{value:.digits$} {}", units[unit])
}

#[cfg(test)]
mod tests {
    use super::decimal_size;

    #[test]
    fn sizes_read_in_decimal_units_with_three_digits() {
        let cases = [
            (0.0, "0 B"),
            (280.0, "280 B"),
            (999.0, "999 B"),
            (999.6, "1.00 kB"),
            (9_996.0, "10.0 kB"),
            (12_345.0, "12.3 kB"),
            (99_960.0, "100 kB"),
            (1_638_400.0, "1.64 MB"),
            (1_048_579_200.0, "1.05 GB"),
            (2.29e9, "2.29 GB"),
            (3.0e15, "3000 TB"),
        ];
        for (bytes, want) in cases {
            assert_eq!(decimal_size(bytes), want, "{bytes} bytes");
        }
    }
}
