//! Dark calibration: per-pixel offset (mean, adu) and read noise (sample standard deviation,
//! adu) of a dark stack, with clipping, common-mode removal, split-half maps and pixel flags;
//! the check that the stack saw no light; and the outputs of `detnoise darks`.
//!
//! Layout: `accumulate` computes the per-pixel statistics of any stack (its per-pixel sums in
//! `tile`, its inner loop in `kernel`, every frame's row and column sums in `lines`), `maps`
//! turns those of a dark stack into its maps (`common_mode` the level taken off each frame), `flags` flags pixels, `decompose` splits the
//! temporal noise into pixel, row, column and frame parts, `kurtosis` gives the per-pixel excess
//! kurtosis, `rts` reads and fits (`telegraph`) the RTS pixels and `rts_table` writes their
//! table, `illumination` refuses flats given as darks, `outputs` writes the maps and summary,
//! and `run` is the whole `darks` command as one call.

mod accumulate;
mod common_mode;
mod decompose;
mod flags;
mod illumination;
mod kernel;
mod kurtosis;
mod lines;
mod maps;
mod options;
mod outputs;
mod rts;
mod rts_table;
mod run;
mod telegraph;
mod tile;

pub use accumulate::{pixel_stats, pixel_stats_hashed, pixel_stats_of, FrameHook, PixelStats};
pub use common_mode::{mean_common_level, take_common_level};
pub use decompose::{rms_of, TemporalNoise, TemporalNoiseSummary};
pub use flags::{
    FlagCounts, FLAG_BITS, FLAG_DEAD, FLAG_HOT, FLAG_NO_DATA, FLAG_RTS, FLAG_SATURATED,
};
pub use illumination::{require_dark, require_dark_expecting, ExpectedDark, Illumination};
pub use kurtosis::{kurtosis_se, KurtosisSummary, KURTOSIS_SIGMAS};
pub use lines::LineVariances;
pub use maps::{dark_maps, dark_maps_hashed, DarkMaps};
pub use options::{Clip, DarkOptions, MAX_CLIP, MAX_SIGMA_CLIP};
pub use outputs::{summarise, write_outputs, DarkSummary, OUTPUT_NAMES};
pub use rts::{
    RtsFits, RtsPixel, RtsSummary, EXAMPLE_FRAMES, EXAMPLE_PIXELS, MAX_RTS_PIXELS, MAX_RTS_SAMPLES,
};
pub use rts_table::{
    rts_columns, rts_csv, write_rts_csv, write_rts_fits, RtsLevelRow, RtsRow, MAX_LEVELS,
};
pub use run::{run, DarksRun, DarksRunResult};
pub use telegraph::{fit_telegraph, FitStatus, Level, TelegraphFit, MIN_RUNS};

#[cfg(test)]
mod tests;
