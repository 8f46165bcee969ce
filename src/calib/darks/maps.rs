//! The maps of a dark stack: offset and read noise (adu), pixel flags, split-half correlation,
//! the common-mode offsets removed, and the telegraph fits of the RTS pixels.

use super::accumulate::{stats_tapped, FrameHook, PixelStats};
use super::common_mode::{mean_common_level, take_common_level};
use super::flags::flag_pixels;
use super::options::DarkOptions;
use super::rts::{fit_rts, RtsFits};
use crate::calib::summary::{with_inputs_hashed, Checksum, InputFile};
use crate::calib::{Map, Unit};
use crate::error::Result;
use crate::io::{ByteTap, FrameStack};
use crate::stats::correlation;

/// Dark-stack calibration: offset and read-noise maps, flags and summary figures.
#[derive(Clone, Debug)]
pub struct DarkMaps {
    /// Per-pixel statistics.
    pub stats: PixelStats,
    /// Per-pixel offset (adu), including the mean common-mode level when removed.
    pub offset_adu: Map,
    /// Per-pixel read noise (adu).
    pub rms_adu: Map,
    /// Flag bits per pixel (`FLAG_*`).
    pub flags: Vec<i32>,
    /// Correlation of the even-frame and odd-frame noise maps.
    pub split_half_correlation: f64,
    /// Per-frame common-mode offsets removed (adu; empty when not requested).
    pub common_mode_adu: Vec<f64>,
    /// Telegraph fits of the RTS-flagged pixels (a second pass over the stack when any).
    pub rts: RtsFits,
}

/// Compute dark maps of `stack` with `opts`.
pub fn dark_maps(stack: &FrameStack, opts: &DarkOptions) -> Result<DarkMaps> {
    maps(stack, opts, None)
}

/// [`dark_maps`] with the `algorithm` digest of every input file, computed on another thread
/// while the statistics run (the frames read for them are hashed from memory, not read again).
pub fn dark_maps_hashed(
    stack: &FrameStack,
    opts: &DarkOptions,
    algorithm: Checksum,
) -> Result<(DarkMaps, Vec<InputFile>)> {
    with_inputs_hashed(stack, algorithm, |tap| maps(stack, opts, Some(tap)))
}

/// Dark maps, handing the frames read to `tap`.
fn maps(stack: &FrameStack, opts: &DarkOptions, tap: Option<&ByteTap>) -> Result<DarkMaps> {
    let hook: Option<FrameHook> = if opts.common_mode {
        Some(&take_common_level)
    } else {
        None
    };
    let stats = stats_tapped(stack, opts.clip, hook, None, tap)?;
    let common_mode_adu = stats.per_frame.clone();
    let cm_mean = mean_common_level(&common_mode_adu);
    let offset: Vec<f64> = stats.mean.data.iter().map(|m| m + cm_mean).collect();
    let source = stack.sources[0].path.display().to_string();
    let offset_adu =
        Map::new(stats.mean.rows, stats.mean.cols, offset, Unit::Adu).with_source(&source);
    let rms_adu = stats.rms.clone().with_source(source);
    let flags = flag_pixels(
        &stats,
        &offset_adu.data,
        stack.saturation_value().map(|s| s - cm_mean.max(0.0)),
        opts,
    );
    let split_half_correlation = correlation(&stats.rms_even.data, &stats.rms_odd.data);
    let rts = fit_rts(stack, &stats, &flags)?;
    Ok(DarkMaps {
        stats,
        offset_adu,
        rms_adu,
        flags,
        split_half_correlation,
        common_mode_adu,
        rts,
    })
}
