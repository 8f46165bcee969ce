//! `detnoise darks`: per-pixel offset and read-noise maps from a dark stack.

use std::ops::Bound::{Excluded, Included, Unbounded};
use std::path::PathBuf;

use super::args::{real, whole};
use super::progress::Terminal;
use crate::calib::darks::{run as run_darks, Clip, DarkOptions, DarksRun};
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
    /// Reject the N highest and N lowest samples of each pixel (cosmic rays), N up to 100,000
    /// (and 2N + 2 at most the frame count). Default: 0.
    #[arg(long, conflicts_with = "sigma_clip", value_parser = whole::<usize>(0, MAX_CLIP, "samples"))]
    pub clip: Option<usize>,
    /// Reject samples more than K standard deviations from the pixel mean (two passes). Default: off.
    #[arg(long, value_parser = real(Excluded(0.0), Unbounded, "standard deviations"))]
    pub sigma_clip: Option<f64>,
    /// Subtract each frame's median (common-mode offset, adu; read between integer steps when
    /// values tie, so integer data leave no rounding residue) before accumulating. Default: off.
    #[arg(long)]
    pub common_mode: bool,
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
}

/// Largest `--clip` (samples rejected at each end of every pixel).
const MAX_CLIP: u64 = 100_000;

/// Run `detnoise darks`.
pub fn run(args: &DarksArgs) -> Result<()> {
    let clip = match (args.clip, args.sigma_clip) {
        (Some(n), None) if n > 0 => Clip::Extremes(n),
        (_, Some(k)) => Clip::Sigma(k),
        _ => Clip::None,
    };
    let job = DarksRun {
        stack: args.stack.clone(),
        out: args.out.clone(),
        force: args.force,
        options: DarkOptions {
            clip,
            common_mode: args.common_mode,
            hot_sigma: args.hot_sigma,
            dead_fraction: args.dead_fraction,
            rts_sigma: args.rts_sigma,
        },
        gain_e_per_adu: args.gain_e_per_adu,
        checksum: (!args.no_checksums).then_some(args.checksum),
        accept_illuminated: args.accept_illuminated,
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
