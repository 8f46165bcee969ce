//! `detnoise darks`: per-pixel offset and read-noise maps from a dark stack.

use std::ops::Bound::{Excluded, Included, Unbounded};
use std::path::{Path, PathBuf};

use serde::Serialize;

use super::args::{real, whole};
use crate::calib::darks::{
    dark_maps, require_dark, Clip, DarkMaps, DarkOptions, FLAG_DEAD, FLAG_HOT, FLAG_NO_DATA,
    FLAG_RTS, FLAG_SATURATED,
};
use crate::calib::summary::{with_inputs_hashed, Distribution, InputFile};
use crate::error::{Error, Result};
use crate::io::FrameStack;
use crate::maps::{key, write_fits_flags, write_fits_map, write_json, KeyValue, Keyword, Map};
use crate::output::{DirPlan, OutputDir};
use crate::plot::{Bins, HistNorm, Histogram};

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
    /// Conversion gain (e per adu); when given, rms_e.fits is written too. Default: none.
    #[arg(long, value_parser = real(Excluded(0.0), Unbounded, "e- per adu"))]
    pub gain_e_per_adu: Option<f64>,
    /// Reject the N highest and N lowest samples of each pixel (cosmic rays), N up to 100,000
    /// (and 2N + 2 at most the frame count). Default: 0.
    #[arg(long, conflicts_with = "sigma_clip", value_parser = whole::<usize>(0, MAX_CLIP, "samples"))]
    pub clip: Option<usize>,
    /// Reject samples more than K standard deviations from the pixel mean (two passes). Default: off.
    #[arg(long, value_parser = real(Excluded(0.0), Unbounded, "standard deviations"))]
    pub sigma_clip: Option<f64>,
    /// Subtract each frame's median (common-mode offset, adu) before accumulating. Default: off.
    #[arg(long)]
    pub common_mode: bool,
    /// Hot-pixel threshold: offset above median + K robust sigmas of the offset map. Default: 5.
    #[arg(long, default_value_t = 5.0, value_parser = real(Excluded(0.0), Unbounded, "robust sigmas"))]
    pub hot_sigma: f64,
    /// Dead-pixel threshold: read noise below this fraction of the median read noise, [0, 1].
    /// Default: 0.1.
    #[arg(long, default_value_t = 0.1, value_parser = real(Included(0.0), Included(1.0), ""))]
    pub dead_fraction: f64,
    /// Skip the SHA-256 checksums of the inputs in summary.json (saves ~0.8 CPU-s per GB).
    #[arg(long)]
    pub no_checksums: bool,
    /// RTS threshold: von Neumann ratio below 1 - K/sqrt(frames) (K standard errors). Default: 5.
    #[arg(long, default_value_t = 5.0, value_parser = real(Excluded(0.0), Unbounded, "standard errors"))]
    pub rts_sigma: f64,
    /// Use frames that look illuminated (variance growing with the mean across pixels, or a
    /// level near the top of the stored range) as darks. Default: refuse them.
    #[arg(long)]
    pub accept_illuminated: bool,
}

/// Files `darks` writes into its directory.
const OUTPUT_NAMES: [&str; 6] = [
    "offset_adu.fits",
    "rms_adu.fits",
    "rms_e.fits",
    "flags.fits",
    "rms_hist.png",
    "summary.json",
];
/// Largest `--clip` (samples rejected at each end of every pixel).
const MAX_CLIP: u64 = 100_000;

/// Flag counts per kind.
#[derive(Debug, Serialize)]
pub struct FlagCounts {
    /// Hot pixels (high offset).
    pub hot: usize,
    /// Dead pixels (read noise near 0).
    pub dead: usize,
    /// Random-telegraph / multi-level pixels (correlated successive samples).
    pub rts: usize,
    /// Pixels that reached the stored type's largest value.
    pub saturated: usize,
    /// Pixels with fewer than 2 samples after clipping.
    pub no_data: usize,
    /// Pixels with any flag.
    pub any: usize,
    /// Bit values in flags.fits.
    pub bits: std::collections::BTreeMap<&'static str, i32>,
}

/// Contents of summary.json.
#[derive(Debug, Serialize)]
pub struct DarkSummary {
    /// Tool and version.
    pub tool: String,
    /// Subcommand.
    pub command: &'static str,
    /// Options used.
    pub options: DarkOptions,
    /// Conversion gain used (e per adu), if any.
    pub gain_e_per_adu: Option<f64>,
    /// Input files with SHA-256.
    pub inputs: Vec<InputFile>,
    /// Frames read.
    pub frames: usize,
    /// Frame shape [rows, cols].
    pub shape: [usize; 2],
    /// Read noise distribution over pixels (adu).
    pub rms_adu: Distribution,
    /// Read noise distribution over pixels (e-), if a gain is known.
    pub rms_e: Option<Distribution>,
    /// Read noise distribution over unflagged pixels (adu).
    pub rms_adu_unflagged: Distribution,
    /// Offset distribution over pixels (adu).
    pub offset_adu: Distribution,
    /// Flag counts.
    pub flags: FlagCounts,
    /// Correlation of the even-frame and odd-frame noise maps (repeatability).
    pub split_half_correlation: f64,
    /// Standard deviation of the removed per-frame common-mode offsets (adu), if removed.
    pub common_mode_std_adu: Option<f64>,
    /// Files written.
    pub outputs: Vec<String>,
}

fn count(flags: &[i32], bit: i32) -> usize {
    flags.iter().filter(|f| **f & bit != 0).count()
}

/// The dark options; every value was range-checked while parsing, so this is the whole
/// validation of `darks` and runs before any frame is read.
fn options(args: &DarksArgs) -> Result<DarkOptions> {
    let clip = match (args.clip, args.sigma_clip) {
        (Some(n), None) if n > 0 => Clip::Extremes(n),
        (_, Some(k)) => Clip::Sigma(k),
        _ => Clip::None,
    };
    Ok(DarkOptions {
        clip,
        common_mode: args.common_mode,
        hot_sigma: args.hot_sigma,
        dead_fraction: args.dead_fraction,
        rts_sigma: args.rts_sigma,
    })
}

/// Provenance keywords of the dark maps.
fn keywords(maps: &DarkMaps, stack: &FrameStack, opts: &DarkOptions) -> Vec<Keyword> {
    let mut k = vec![
        key(
            "NFRAMES",
            KeyValue::I64(maps.stats.frames as i64),
            "frames in the dark stack",
        ),
        key(
            "DNCLIP",
            KeyValue::Str(format!("{:?}", opts.clip)),
            "per-pixel sample rejection",
        ),
        key(
            "DNCMODE",
            KeyValue::Str(opts.common_mode.to_string()),
            "per-frame common-mode offset removed",
        ),
        key(
            "NINPUTS",
            KeyValue::I64(stack.sources.len() as i64),
            "input files (see summary.json)",
        ),
    ];
    for (i, s) in stack.sources.iter().take(99).enumerate() {
        let name = s
            .path
            .file_name()
            .map(|n| n.to_string_lossy().into_owned())
            .unwrap_or_default();
        k.push(key(
            &format!("INPUT{}", i + 1),
            KeyValue::Str(name),
            "input file",
        ));
    }
    k
}

/// Write the outputs of a dark calibration to `out`, the summary as `summary_name` (all computed
/// before the first write).
pub fn write_outputs(
    out: &Path,
    stack: &FrameStack,
    maps: &DarkMaps,
    opts: &DarkOptions,
    gain: Option<f64>,
    inputs: Vec<InputFile>,
    summary_name: &str,
) -> Result<DarkSummary> {
    std::fs::create_dir_all(out).map_err(|e| Error::io(out, e))?;
    let rms_e = gain.map(|g| {
        Map::new(
            maps.rms_adu.rows,
            maps.rms_adu.cols,
            maps.rms_adu.data.iter().map(|r| r * g).collect(),
        )
    });
    let (hist_values, hist_unit) = match &rms_e {
        Some(m) => (&m.data, "read noise (e-)"),
        None => (&maps.rms_adu.data, "read noise (adu)"),
    };
    let unflagged: Vec<f64> = maps
        .rms_adu
        .data
        .iter()
        .zip(&maps.flags)
        .filter(|(_, f)| **f == 0)
        .map(|(r, _)| *r)
        .collect();
    let flags = FlagCounts {
        hot: count(&maps.flags, FLAG_HOT),
        dead: count(&maps.flags, FLAG_DEAD),
        rts: count(&maps.flags, FLAG_RTS),
        saturated: count(&maps.flags, FLAG_SATURATED),
        no_data: count(&maps.flags, FLAG_NO_DATA),
        any: maps.flags.iter().filter(|f| **f != 0).count(),
        bits: [
            ("hot", FLAG_HOT),
            ("dead", FLAG_DEAD),
            ("rts", FLAG_RTS),
            ("saturated", FLAG_SATURATED),
            ("no_data", FLAG_NO_DATA),
        ]
        .into_iter()
        .collect(),
    };
    let cm = &maps.common_mode_adu;
    let common_mode_std_adu = (!cm.is_empty()).then(|| {
        let m = cm.iter().sum::<f64>() / cm.len() as f64;
        (cm.iter().map(|x| (x - m) * (x - m)).sum::<f64>() / (cm.len().max(2) - 1) as f64).sqrt()
    });
    let mut outputs = vec![
        "offset_adu.fits",
        "rms_adu.fits",
        "flags.fits",
        "rms_hist.png",
        summary_name,
    ];
    if rms_e.is_some() {
        outputs.insert(2, "rms_e.fits");
    }
    let summary = DarkSummary {
        tool: format!("detnoise {}", env!("CARGO_PKG_VERSION")),
        command: "darks",
        options: opts.clone(),
        gain_e_per_adu: gain,
        inputs,
        frames: maps.stats.frames,
        shape: [stack.shape.0, stack.shape.1],
        rms_adu: Distribution::of(&maps.rms_adu.data),
        rms_e: rms_e.as_ref().map(|m| Distribution::of(&m.data)),
        rms_adu_unflagged: Distribution::of(&unflagged),
        offset_adu: Distribution::of(&maps.offset_adu.data),
        flags,
        split_half_correlation: maps.split_half_correlation,
        common_mode_std_adu,
        outputs: outputs.iter().map(|s| s.to_string()).collect(),
    };
    // The chart goes first: if it fails, nothing has been written.
    let mut hist = Histogram::new(
        format!("per-pixel read noise, {} frames", maps.stats.frames),
        hist_unit,
        "pixels",
        hist_values.clone(),
    );
    hist.norm = HistNorm::Count;
    hist.log_y = true;
    hist.bins = Bins::Count(100);
    hist.save(out.join("rms_hist.png"))?;
    let keys = keywords(maps, stack, opts);
    write_fits_map(&out.join("offset_adu.fits"), &maps.offset_adu, "adu", &keys)?;
    write_fits_map(&out.join("rms_adu.fits"), &maps.rms_adu, "adu", &keys)?;
    if let (Some(m), Some(g)) = (&rms_e, gain) {
        let mut k = keys.clone();
        k.push(key(
            "GAIN",
            KeyValue::F64(g),
            "conversion gain used (e/adu)",
        ));
        write_fits_map(&out.join("rms_e.fits"), m, "electron", &k)?;
    }
    let mut fk = keys.clone();
    for (name, bit, what) in [
        ("FLAGHOT", FLAG_HOT, "hot pixel"),
        ("FLAGDEAD", FLAG_DEAD, "dead pixel"),
        ("FLAGRTS", FLAG_RTS, "random-telegraph pixel"),
        ("FLAGSAT", FLAG_SATURATED, "saturated pixel"),
        ("FLAGNONE", FLAG_NO_DATA, "too few samples"),
    ] {
        fk.push(key(
            name,
            KeyValue::I64(bit as i64),
            &format!("bit: {what}"),
        ));
    }
    write_fits_flags(
        &out.join("flags.fits"),
        stack.shape.0,
        stack.shape.1,
        &maps.flags,
        &fk,
    )?;
    write_json(&out.join(summary_name), &summary)?;
    Ok(summary)
}

/// Run `detnoise darks`.
pub fn run(args: &DarksArgs) -> Result<()> {
    let opts = options(args)?;
    let dir = OutputDir::prepare(
        &args.out,
        DirPlan {
            command: "darks",
            force: args.force,
            inputs: &args.stack,
            names: &OUTPUT_NAMES,
        },
    )?;
    let stack = FrameStack::open(&args.stack)?;
    let t = std::time::Instant::now();
    let (maps, inputs) = if args.no_checksums {
        let maps = dark_maps(&stack, &opts)?;
        (maps, crate::calib::summary::unhashed(&stack))
    } else {
        with_inputs_hashed(&stack, || dark_maps(&stack, &opts))?
    };
    let secs = t.elapsed().as_secs_f64();
    let mb = stack.stored_bytes() as f64 / 1e6;
    eprintln!(
        "read {mb:.1} MB of samples in {secs:.2} s ({:.0} MB/s)",
        mb / secs
    );
    if let Some(warning) = require_dark(&stack, &maps, args.accept_illuminated)? {
        eprintln!("warning: {warning}");
    }
    let s = write_outputs(
        &dir.path(""),
        &stack,
        &maps,
        &opts,
        args.gain_e_per_adu,
        inputs,
        "summary.json",
    )?;
    let out = dir.commit()?;
    eprintln!(
        "{} frames of {}x{}: median read noise {:.4} adu{}, split-half correlation {:.4}, {} flagged pixels; wrote {}",
        s.frames,
        s.shape[0],
        s.shape[1],
        s.rms_adu.median,
        s.rms_e.as_ref().map(|d| format!(" ({:.4} e-)", d.median)).unwrap_or_default(),
        s.split_half_correlation,
        s.flags.any,
        out.display()
    );
    Ok(())
}
