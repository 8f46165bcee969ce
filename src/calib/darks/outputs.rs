//! The outputs of a dark calibration: offset, read-noise (adu, and e- with a gain) and flag
//! maps as FITS with provenance keywords, the read-noise histogram, and summary.json.

use std::path::Path;

use serde::Serialize;

use super::decompose::TemporalNoiseSummary;
use super::flags::{FlagCounts, FLAG_BITS, FLAG_RTS};
use super::kurtosis::KurtosisSummary;
use super::maps::DarkMaps;
use super::options::DarkOptions;
use super::rts::RtsSummary;
use super::rts_table::{write_rts_csv, write_rts_fits};
use crate::calib::summary::{Distribution, InputFile};
use crate::calib::Unit;
use crate::error::{Error, Result};
use crate::io::fits::{key, write_image, ImageData, KeyValue, Keyword};
use crate::io::FrameStack;
use crate::plot::{Bins, HistNorm, Histogram};
use crate::stats::mean_var;

/// Files a dark calibration writes into its directory (rms_e.fits only with a gain).
pub const OUTPUT_NAMES: [&str; 10] = [
    "offset_adu.fits",
    "rms_adu.fits",
    "rms_e.fits",
    "flags.fits",
    "rms_hist.png",
    "summary.json",
    "excess_kurtosis.fits",
    "rts.csv",
    "rts.fits",
    "rts-series.csv",
];

/// The files of the non-Gaussian noise, written after the maps (in this order).
const NOISE_FILES: [&str; 4] = [
    "excess_kurtosis.fits",
    "rts.csv",
    "rts.fits",
    "rts-series.csv",
];

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
    /// Input files with their checksums.
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
    /// The temporal noise split into pixel, row and column components.
    pub temporal_noise: TemporalNoiseSummary,
    /// The per-pixel excess kurtosis map (excess_kurtosis.fits).
    pub excess_kurtosis: KurtosisSummary,
    /// The telegraph fits of the RTS pixels (rts.csv, rts.fits, rts-series.csv).
    pub rts: RtsSummary,
    /// Files written.
    pub outputs: Vec<String>,
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

/// The summary of a dark calibration (the content of summary.json, the summary named
/// `summary_name` in its list of outputs), without writing anything. `gain` (e- per adu) adds
/// the e- figures.
pub fn summarise(
    stack: &FrameStack,
    maps: &DarkMaps,
    opts: &DarkOptions,
    gain: Option<f64>,
    inputs: Vec<InputFile>,
    summary_name: &str,
) -> DarkSummary {
    let rms_e = gain.map(|g| maps.rms_adu.to_electrons(g));
    let unflagged: Vec<f64> = maps
        .rms_adu
        .data
        .iter()
        .zip(&maps.flags)
        .filter(|(_, f)| **f == 0)
        .map(|(r, _)| *r)
        .collect();
    let cm = &maps.common_mode_adu;
    let common_mode_std_adu = (!cm.is_empty()).then(|| mean_var(cm).1.sqrt());
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
    outputs.extend(NOISE_FILES);
    let cols = stack.shape.1;
    DarkSummary {
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
        flags: FlagCounts::of(&maps.flags),
        split_half_correlation: maps.split_half_correlation,
        common_mode_std_adu,
        temporal_noise: maps.stats.temporal.summary(gain),
        excess_kurtosis: KurtosisSummary::of(&maps.stats.excess_kurtosis, maps.stats.frames, |i| {
            maps.flags[i] & FLAG_RTS != 0
        }),
        rts: maps.rts.summary(cols, gain),
        outputs: outputs.iter().map(|s| s.to_string()).collect(),
    }
}

/// Write the outputs of a dark calibration to `out`, the summary as `summary_name` (all computed
/// before the first write). `gain` (e- per adu) adds rms_e.fits and the e- figures.
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
    let summary = summarise(stack, maps, opts, gain, inputs, summary_name);
    let rms_e = gain.map(|g| maps.rms_adu.to_electrons(g));
    let (hist_values, hist_unit) = match &rms_e {
        Some(m) => (&m.data, "read noise (e-)"),
        None => (&maps.rms_adu.data, "read noise (adu)"),
    };
    // The chart goes first: if it fails, nothing has been written.
    rms_histogram(hist_values, hist_unit, maps.stats.frames).save(out.join("rms_hist.png"))?;
    let keys = keywords(maps, stack, opts);
    maps.offset_adu
        .write_fits(&out.join("offset_adu.fits"), &keys)?;
    maps.rms_adu.write_fits(&out.join("rms_adu.fits"), &keys)?;
    if let (Some(m), Some(g)) = (&rms_e, gain) {
        let mut k = keys.clone();
        k.push(key(
            "GAIN",
            KeyValue::F64(g),
            "conversion gain used (e/adu)",
        ));
        m.write_fits(&out.join("rms_e.fits"), &k)?;
    }
    let mut fk = keys;
    for (_, name, bit, what) in FLAG_BITS {
        fk.push(key(
            name,
            KeyValue::I64(bit as i64),
            &format!("bit: {what}"),
        ));
    }
    write_image(
        &out.join("flags.fits"),
        stack.shape,
        ImageData::I32(&maps.flags),
        Unit::Flags.bunit(),
        &fk,
    )?;
    let mut kk = keywords(maps, stack, opts);
    kk.push(key("BUNIT", KeyValue::Str(String::new()), "dimensionless"));
    kk.push(key(
        "DNWHAT",
        KeyValue::Str("excess kurtosis G2 per pixel".into()),
        "0 for Gaussian noise, SE ~ sqrt(24/NFRAMES)",
    ));
    write_image(
        &out.join("excess_kurtosis.fits"),
        stack.shape,
        ImageData::F64(&maps.stats.excess_kurtosis),
        "",
        &kk,
    )?;
    let cols = stack.shape.1;
    let rows = maps.rts.rows(cols, gain);
    write_rts_csv(&out.join("rts.csv"), &rows)?;
    write_rts_fits(&out.join("rts.fits"), &rows)?;
    crate::output::write_atomic(
        &out.join("rts-series.csv"),
        maps.rts.series_csv(cols).as_bytes(),
    )?;
    crate::output::write_json(&out.join(summary_name), &summary)?;
    Ok(summary)
}

/// The chart `rms_hist.png`: pixels per read-noise bin (log counts) from 0 (an rms is never
/// negative) to the largest value; `x_label` names the unit.
fn rms_histogram(values: &[f64], x_label: &str, frames: usize) -> Histogram {
    let mut hist = Histogram::new(
        format!("per-pixel read noise, {frames} frames"),
        x_label,
        "pixels",
        values.to_vec(),
    );
    hist.norm = HistNorm::Count;
    hist.log_y = true;
    hist.bins = Bins::Count(100);
    hist.from_zero = true;
    hist
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_read_noise_histogram_starts_at_zero_and_counts_every_pixel() {
        // Read noise between 0.3 and 10.4 e-: the axis still starts at 0.
        let values: Vec<f64> = (0..1000).map(|i| 0.3 + 0.0101 * i as f64).collect();
        let (edges, counts) = rms_histogram(&values, "read noise (e-)", 100)
            .binned()
            .unwrap();
        assert_eq!(edges[0], 0.0);
        assert_eq!(*edges.last().unwrap(), values[999]);
        assert_eq!(counts.iter().sum::<f64>(), 1000.0);
        // Nothing below the smallest value.
        let first = edges.partition_point(|&e| e <= 0.3) - 1;
        assert!(counts[..first].iter().all(|&c| c == 0.0));
    }
}
