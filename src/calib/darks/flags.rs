//! Pixel flags of a dark calibration: hot, dead, random-telegraph, saturated, too few samples;
//! and their counts for the summary.

use std::collections::BTreeMap;

use serde::Serialize;

use super::accumulate::PixelStats;
use super::options::DarkOptions;
use crate::stats::{median, median_and_robust_sigma};

/// Flag bit: hot pixel (offset far above the frame's typical offset).
pub const FLAG_HOT: i32 = 1;
/// Flag bit: dead pixel (read noise far below typical, e.g. a stuck value).
pub const FLAG_DEAD: i32 = 2;
/// Flag bit: multi-level / random-telegraph pixel (successive samples correlated).
pub const FLAG_RTS: i32 = 4;
/// Flag bit: the pixel reached the largest value of the stored type.
pub const FLAG_SATURATED: i32 = 8;
/// Flag bit: fewer than two samples left after clipping.
pub const FLAG_NO_DATA: i32 = 16;

/// Every flag bit: (name in summary.json, FITS keyword in flags.fits, bit, meaning).
pub const FLAG_BITS: [(&str, &str, i32, &str); 5] = [
    ("hot", "FLAGHOT", FLAG_HOT, "hot pixel"),
    ("dead", "FLAGDEAD", FLAG_DEAD, "dead pixel"),
    ("rts", "FLAGRTS", FLAG_RTS, "random-telegraph pixel"),
    ("saturated", "FLAGSAT", FLAG_SATURATED, "saturated pixel"),
    ("no_data", "FLAGNONE", FLAG_NO_DATA, "too few samples"),
];

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
    pub bits: BTreeMap<&'static str, i32>,
}

impl FlagCounts {
    /// Count the pixels of `flags` (one bit field per pixel) by kind.
    pub fn of(flags: &[i32]) -> FlagCounts {
        let count = |bit: i32| flags.iter().filter(|f| **f & bit != 0).count();
        FlagCounts {
            hot: count(FLAG_HOT),
            dead: count(FLAG_DEAD),
            rts: count(FLAG_RTS),
            saturated: count(FLAG_SATURATED),
            no_data: count(FLAG_NO_DATA),
            any: flags.iter().filter(|f| **f != 0).count(),
            bits: FLAG_BITS
                .iter()
                .map(|(name, _, bit, _)| (*name, *bit))
                .collect(),
        }
    }
}

/// The flag bits of every pixel from its statistics and offset (adu), with saturation at
/// `saturation` (adu; none for float data).
pub(super) fn flag_pixels(
    stats: &PixelStats,
    offset: &[f64],
    saturation: Option<f64>,
    opts: &DarkOptions,
) -> Vec<i32> {
    // (Two selections in a row, and a third beside them.)
    let ((off_med, off_sigma), rms_med) = rayon::join(
        || median_and_robust_sigma(offset),
        || median(&stats.rms.data),
    );
    let n = stats.frames as f64;
    // Von Neumann ratio of white noise: mean 1, standard error close to 1/sqrt(n).
    let rts_limit = 1.0 - opts.rts_sigma / n.sqrt();
    (0..offset.len())
        .map(|i| {
            let mut f = 0;
            let rms = stats.rms.data[i];
            if stats.count[i] < 2.0 || !rms.is_finite() {
                f |= FLAG_NO_DATA;
            }
            if off_sigma > 0.0 && offset[i] > off_med + opts.hot_sigma * off_sigma {
                f |= FLAG_HOT;
            }
            if rms.is_nan() || rms < opts.dead_fraction * rms_med {
                f |= FLAG_DEAD;
            }
            if n >= 25.0 && stats.von_neumann[i] < rts_limit {
                f |= FLAG_RTS;
            }
            if saturation.is_some_and(|s| stats.max[i] >= s) {
                f |= FLAG_SATURATED;
            }
            f
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::calib::{Map, Unit};

    fn stats(
        rms: Vec<f64>,
        count: Vec<f64>,
        vn: Vec<f64>,
        max: Vec<f64>,
        frames: usize,
    ) -> PixelStats {
        let n = rms.len();
        let map = |v: Vec<f64>| Map::new(1, n, v, Unit::Adu);
        PixelStats {
            frames,
            mean: map(vec![0.0; n]),
            rms: map(rms.clone()),
            rms_even: map(rms.clone()),
            rms_odd: map(rms),
            count,
            von_neumann: vn,
            max,
            excess_kurtosis: vec![0.0; n],
            temporal: crate::calib::darks::TemporalNoise {
                frames,
                total: (0.0, 0.0),
                pixel: (0.0, 0.0),
                row: None,
                column: None,
                frame: None,
            },
            per_frame: vec![],
        }
    }

    #[test]
    fn each_flag_follows_its_threshold() {
        // Offsets 100 +- 1 (robust sigma 1.4826 x MAD 1), one at 120: hot beyond 5 sigmas.
        // Read noise 2 adu, one at 0.1 (< 0.1 x median): dead. Von Neumann ratio 0.5 with 100
        // frames: below 1 - 5/10 only if < 0.5, so 0.4 is RTS. One pixel saturates at 65535;
        // one has a single sample.
        let offset = [99.0, 101.0, 100.0, 120.0, 99.0, 101.0, 100.0];
        let s = stats(
            vec![2.0, 2.0, 0.1, 2.0, 2.0, 2.0, f64::NAN],
            vec![100.0, 100.0, 100.0, 100.0, 100.0, 100.0, 1.0],
            vec![1.0, 0.4, 1.0, 1.0, 0.5, 1.0, 1.0],
            vec![110.0, 110.0, 110.0, 130.0, 110.0, 65535.0, 110.0],
            100,
        );
        let f = flag_pixels(&s, &offset, Some(65535.0), &DarkOptions::default());
        assert_eq!(
            f,
            [
                0,
                FLAG_RTS,
                FLAG_DEAD,
                FLAG_HOT,
                0,
                FLAG_SATURATED,
                FLAG_NO_DATA | FLAG_DEAD
            ]
        );
        let c = FlagCounts::of(&f);
        assert_eq!(
            (c.hot, c.dead, c.rts, c.saturated, c.no_data, c.any),
            (1, 2, 1, 1, 1, 5)
        );
        assert_eq!(c.bits["no_data"], 16);
        // Fewer than 25 frames: no RTS test (the ratio's error is too large).
        let s = stats(vec![2.0; 2], vec![10.0; 2], vec![0.1; 2], vec![0.0; 2], 10);
        assert_eq!(
            flag_pixels(&s, &[1.0, 1.0], None, &DarkOptions::default()),
            [0, 0]
        );
    }
}
