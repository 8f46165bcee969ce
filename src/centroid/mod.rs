//! Centroiders: the centre of gravity with background subtraction swept over background
//! levels (the paper's), and the methods that use the camera's known noise map or the spot's
//! shape, behind the [`Centroider`] trait of `centroider`.
//!
//! At level b each pixel contributes v = max(x - b, 0) (the Durham platform's "subtract and
//! clip"). Positions are in pixels from the sub-aperture centre (n-1)/2.
//!
//! The registry [`CENTROIDERS`] lists every centroider's [`CentroiderEntry`] (name, one-line
//! help, its parameter's name, unit, meaning, range and sweep grid, and its builder);
//! [`CentroiderSpec::parse`], [`centroider_names`], [`centroiders_help`] and
//! [`centroider_units`] are generated from it. Adding a centroider is two edits:
//! 1. a new file `src/centroid/NAME.rs` with its [`Centroider`] and [`CentroidWorker`] impls,
//!    its test against a direct definition, and `pub const ENTRY: CentroiderEntry`;
//! 2. one line `NAME: [ENTRY],` in the `centroiders!` list below (it declares the module and
//!    registers the entry).
//!
//! The other files: `spec` (specs, entries, the run's context), `registry` (names, help and
//! parsing over the table), `sweep`, `levels` and `sums` (the background sweep and its sums).

mod centroider;
mod image;
mod levels;
mod registry;
mod spec;
mod sums;
mod sweep;

pub use centroider::{CentroidFrame, CentroidWorker, Centroider, Setting, SettingSums};
pub use image::{cog, ImageSums};
pub use spec::{
    BuildFn, CentroidContext, CentroiderEntry, CentroiderParam, CentroiderSpec, ParamRange,
};
pub use sums::{ErrorMoments, LevelSums, LevelTotals, LANES};
pub use sweep::{BackgroundSweep, PixelTerms, Plain, Scaled, Weighted};

/// Declares each centroider module and lists its entries, in order, in [`CENTROIDERS`].
macro_rules! centroiders {
    ($($module:ident: [$($entry:ident),+],)+) => {
        $(mod $module;)+
        /// The registry: every centroider, in the order of `--centroider`'s help and of tables.
        pub const CENTROIDERS: &[CentroiderEntry] = &[$($($module::$entry),+),+];
    };
}

centroiders! {
    thresholded: [COG, TCOG, MASKED_COG, IVW_COG, WCOG],
    brightest: [ENTRY],
    matched_filter: [ENTRY],
    correlation: [ENTRY],
}

// Parsing and the default spec live beside the table, so that the registry's machinery and
// the spec's own file need neither the table nor its entries' files.
impl Default for CentroiderSpec {
    /// Plain `cog`, the paper's.
    fn default() -> Self {
        CentroiderSpec::of(&thresholded::COG)
    }
}

impl CentroiderSpec {
    /// Parse `NAME[:PARAM]` (e.g. `masked-cog:3`); errors name the `centroider` field.
    pub fn parse(text: &str) -> crate::Result<Self> {
        registry::parse(CENTROIDERS, text)
    }
}

/// Every centroider's name, comma-separated as `--centroider` takes them (the report's
/// default: `cog,tcog,...`).
pub fn centroider_names() -> &'static str {
    static NAMES: std::sync::LazyLock<String> =
        std::sync::LazyLock::new(|| registry::names(CENTROIDERS, ","));
    &NAMES
}

/// The centroiders of a comma-separated `NAME[:PARAM]` list (`centroider`), with `mask_above`
/// (times the median sigma) the parameter of those whose entry takes it (masked-cog) unless
/// fixed in the list: the one parser of the command line and Python.
pub fn parse_specs(text: &str, mask_above: Option<f64>) -> crate::Result<Vec<CentroiderSpec>> {
    use crate::Error;
    let mut specs: Vec<CentroiderSpec> = text
        .split(',')
        .filter(|s| !s.trim().is_empty())
        .map(|s| CentroiderSpec::parse(s.trim()))
        .collect::<crate::Result<_>>()?;
    if specs.is_empty() {
        return Err(Error::invalid("centroider", "no centroider given"));
    }
    if let Some(m) = mask_above {
        let mut takers = specs.iter_mut().filter(|s| s.entry.mask_above).peekable();
        if takers.peek().is_none() {
            let names: Vec<&str> = CENTROIDERS
                .iter()
                .filter(|e| e.mask_above)
                .map(|e| e.name)
                .collect();
            return Err(Error::invalid(
                "mask_above",
                format!("applies to {}: add it to `centroider`", names.join(" or ")),
            ));
        }
        for s in takers {
            s.param.get_or_insert(m);
        }
    }
    let mut seen = std::collections::HashSet::new();
    for s in &specs {
        if !seen.insert(s.label()) {
            return Err(Error::invalid(
                "centroider",
                format!("{} is given twice", s.label()),
            ));
        }
    }
    Ok(specs)
}

/// The methods of `--centroider`'s long help: a line per centroider, its name and what it does.
pub fn centroiders_help() -> String {
    registry::help(CENTROIDERS)
}

/// What a fixed parameter is in, per centroider that takes one: `K in sigmas, M in ...`.
pub fn centroider_units() -> String {
    registry::units(CENTROIDERS)
}

#[cfg(test)]
mod tests;

#[cfg(test)]
mod sweep_tests {
    use super::*;

    #[test]
    fn known_images_give_known_centroids() {
        // A single bright pixel at (row 1, col 3) of a 4x4: CoG at (3 - 1.5, 1 - 1.5).
        let mut img = vec![0.0; 16];
        img[4 + 3] = 5.0;
        assert_eq!(cog(&img, 4), Some((1.5, -0.5)));
        // Two equal pixels: midpoint.
        img[4 + 1] = 5.0;
        assert_eq!(cog(&img, 4), Some((0.5, -0.5)));
        assert_eq!(cog(&[0.0; 9], 3), None);
    }

    #[test]
    fn image_sums_are_the_plain_sums_to_rounding() {
        // Sizes 1-9 and 16 (rows of whole groups of four, remainders, and none): each sum
        // within rounding of a plain running sum (n^2 terms >= 0 of size ~1, ~n: a relative
        // n^2 eps bound on each).
        use rand::RngExt;
        let mut rng = crate::rng::stream(9, 0, 0);
        for n in (1..=9).chain([16]) {
            let img: Vec<f64> = (0..n * n).map(|_| rng.random::<f64>()).collect();
            let (mut s, mut sx, mut sy) = (0.0, 0.0, 0.0);
            for (p, &v) in img.iter().enumerate() {
                s += v;
                sx += v * (p % n) as f64;
                sy += v * (p / n) as f64;
            }
            let got = ImageSums::of(&img, n);
            let tol = |x: f64| 2.0 * (n * n) as f64 * f64::EPSILON * x;
            assert!((got.total - s).abs() <= tol(s), "{n}: total");
            assert!((got.col - sx).abs() <= tol(sx), "{n}: col");
            assert!((got.row - sy).abs() <= tol(sy), "{n}: row");
        }
    }

    #[test]
    fn sweep_matches_direct_cog_over_many_frames_sizes_and_grids() {
        // Random frames accumulated one after another (the scratch must be left clean) at
        // sizes 1-9 px, values from -3 to 40 e- with ties on levels, against the direct
        // thresholded centre of gravity per frame and level: relative error below 1e-6.
        use rand::RngExt;
        let mut rng = crate::rng::stream(4, 0, 0);
        let auto = crate::montecarlo::BgGrid::Auto.levels(30.0);
        for (t, levels) in [auto, vec![0.0, 0.5, 0.5000001, 7.0], vec![0.0]]
            .into_iter()
            .enumerate()
        {
            for n in 1..10 {
                let mut sweep = BackgroundSweep::new(levels.clone(), n);
                let mut acc = LevelSums::new(levels.len());
                let mut want = vec![(0.0, 0.0, 0u64); levels.len()];
                for _ in 0..40 {
                    let img: Vec<f64> = (0..n * n)
                        .map(|_| match rng.random_range(0..4) {
                            0 => levels[rng.random_range(0..levels.len())],
                            _ => rng.random_range(-3.0..40.0),
                        })
                        .collect();
                    let truth = (rng.random_range(-0.5..0.5), rng.random_range(-0.5..0.5));
                    sweep.accumulate(&img, truth, &mut acc);
                    for (w, b) in want.iter_mut().zip(&levels) {
                        let v: Vec<f64> = img.iter().map(|x| (x - b).max(0.0)).collect();
                        super::tests::add_error(w, cog(&v, n), truth);
                    }
                }
                for (k, (got, w)) in acc.finish().iter().zip(&want).enumerate() {
                    assert!(
                        (got.0 - w.0).abs() <= 1e-6 * w.0
                            && (got.1 - w.1).abs() <= 2e-6 * w.1
                            && got.2 == w.2,
                        "grid {t}, {n}x{n}, level {k}: {got:?} vs {w:?}"
                    );
                }
            }
        }
    }

    #[test]
    fn batches_sum_what_frames_sum() {
        // Frames swept in batches of LANES (a short batch at the end, and batches with frames
        // past other frames' brightest pixel) against the same frames one by one: each frame's
        // error per level is the same, only the order of the sums differs. Summing 103
        // non-negative terms in another order moves the total by at most ~103 ulp (1.2e-14
        // relative): 1e-13 bounds it; empty counts equal. Merged and cleared batch sums behave
        // like frame sums.
        use rand::RngExt;
        let mut rng = crate::rng::stream(6, 0, 0);
        let levels = crate::montecarlo::BgGrid::Auto.levels(60.0);
        for n in [2, 4, 7] {
            let frames: Vec<(Vec<f64>, (f64, f64))> = (0..4 * 25 + 3)
                .map(|k| {
                    let bright = [3.0, 60.0, 0.5][k % 3];
                    let img = (0..n * n).map(|_| rng.random_range(-2.0..bright)).collect();
                    (
                        img,
                        (rng.random_range(-0.5..0.5), rng.random_range(-0.5..0.5)),
                    )
                })
                .collect();
            let (mut one, mut batched) = (
                BackgroundSweep::new(levels.clone(), n),
                BackgroundSweep::new(levels.clone(), n),
            );
            let (mut want, mut got) = (LevelSums::new(levels.len()), LevelSums::new(levels.len()));
            let views: Vec<CentroidFrame> = frames
                .iter()
                .map(|(img, truth)| CentroidFrame {
                    image_e: img,
                    truth_px: *truth,
                    sigma_e: &[],
                    mean_e: &[],
                    photon_variance_factor: 1.0,
                })
                .collect();
            for batch in views.chunks(LANES) {
                batched.accumulate_batch(batch, &mut got);
            }
            for (img, truth) in &frames {
                one.accumulate(img, *truth, &mut want);
            }
            let mut merged = LevelSums::new(levels.len());
            merged.merge(&got);
            for ((g, w), m) in got.finish().iter().zip(want.finish()).zip(merged.finish()) {
                assert!((g.0 - w.0).abs() <= 1e-13 * w.0, "{n}: {g:?} vs {w:?}");
                assert!((g.1 - w.1).abs() <= 1e-13 * w.1, "{n}: {g:?} vs {w:?}");
                assert_eq!((g.2, *g), (w.2, m), "{n}");
            }
            got.clear();
            assert!(got.finish().iter().all(|&t| t == (0.0, 0.0, 0)));
        }
    }

    #[test]
    fn sweep_matches_direct_thresholded_cog() {
        let n = 5;
        let img: Vec<f64> = (0..25)
            .map(|k| ((k * 37 % 11) as f64 - 3.0) * 0.7)
            .collect();
        let levels = vec![0.0, 0.5, 1.0, 2.2, 4.0, 4.9, 100.0];
        let mut sweep = BackgroundSweep::new(levels.clone(), n);
        let truth = (0.1, -0.2);
        let mut acc = LevelSums::new(levels.len());
        sweep.accumulate(&img, truth, &mut acc);
        // A second, merged copy doubles every sum.
        let mut twice = acc.clone();
        twice.merge(&acc);
        for ((b, (d, d2, empty)), (d_2, _, e_2)) in
            levels.iter().zip(acc.finish()).zip(twice.finish())
        {
            let v: Vec<f64> = img.iter().map(|x| (x - b).max(0.0)).collect();
            let want = match cog(&v, n) {
                Some((x, y)) => {
                    assert_eq!(empty, 0, "level {b}");
                    (x - truth.0).hypot(y - truth.1)
                }
                None => {
                    assert_eq!(empty, 1, "level {b}");
                    truth.0.hypot(truth.1)
                }
            };
            // The distance is computed in single precision from double sums: relative error
            // a few f32 ulps (1e-6 bounds it with margin).
            assert!(
                (d - want).abs() <= 1e-6 * want && (d2 - want * want).abs() <= 2e-6 * want * want,
                "level {b}: {d} vs {want}"
            );
            assert!((d_2 - 2.0 * d).abs() < 1e-12 && e_2 == 2 * empty);
        }
        // Cleared sums are zero and merge like fresh ones.
        twice.clear();
        assert!(twice
            .finish()
            .iter()
            .all(|&(d, d2, e)| d == 0.0 && d2 == 0.0 && e == 0));
        twice.merge(&acc);
        assert_eq!(twice.finish(), acc.finish());
    }
}
