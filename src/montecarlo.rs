//! The Shack-Hartmann sub-aperture Monte-Carlo of Basden (2015), section 2.
//!
//! Per iteration: a random spot position, a noiseless image scaled to S x QE photo-electrons,
//! its centre of gravity as the truth, Poisson shot noise, a readout, then the centre of
//! gravity after subtracting each background level. All models of a run share the spot
//! positions, the photon draws and the read-noise deviates (common random numbers), and every
//! iteration has its own seeded streams, so results do not depend on the thread count.

use crate::centroid::{cog, BackgroundSweep, LevelSums};
use crate::detector::{FrameInput, Readout};
use crate::rng::stream;
use crate::spot::{Sampling, Spot, SpotRenderer};
use crate::stats::poisson;
use crate::{Error, Result};
use rand::RngExt;
use rayon::prelude::*;

/// Iterations per parallel work item (fixed, so sums are added in the same order always).
const CHUNK: u64 = 256;
/// Work items held in memory at once (their per-level sums), whatever the iteration count.
const BATCH_CHUNKS: u64 = 256;

/// Stream roles of one iteration.
const POSITION: u64 = 0;
const PHOTONS: u64 = 1;
const NOISE: u64 = 2;
const AUX: u64 = 3;

/// Background levels to sweep.
#[derive(Debug, Clone, PartialEq)]
pub enum BgGrid {
    /// A grid sized from the signal: fine near zero, up to the brightest expected pixel.
    Auto,
    /// `start:stop:step` in e-.
    Range {
        /// First level (e-).
        start: f64,
        /// Last level (e-, inclusive).
        stop: f64,
        /// Spacing (e-).
        step: f64,
    },
}

impl BgGrid {
    /// Most levels a `start:stop:step` grid may have: every frame walks all of them.
    pub const MAX_LEVELS: f64 = 100_000.0;

    /// Parse `auto` or `start:stop:step` (e-).
    pub fn parse(text: &str) -> Result<Self> {
        if text == "auto" {
            return Ok(BgGrid::Auto);
        }
        let bad = |why: String| Error::invalid("--bg-grid", format!("'{text}': {why}"));
        let form = || {
            bad(
                "expected auto or start:stop:step in e-, with 0 <= start <= stop and step > 0"
                    .into(),
            )
        };
        let parts: Vec<f64> = text
            .split(':')
            .map(|p| p.trim().parse::<f64>())
            .collect::<std::result::Result<_, _>>()
            .map_err(|_| form())?;
        let [start, stop, step] = parts[..] else {
            return Err(form());
        };
        if !(start >= 0.0 && stop >= start && step > 0.0 && stop.is_finite()) {
            return Err(form());
        }
        let levels = ((stop - start) / step + 1e-9).floor() + 1.0;
        if levels > Self::MAX_LEVELS {
            return Err(bad(format!(
                "{levels:.0} levels; at most {:.0} are allowed (every frame is evaluated at each \
                 level): use a larger step",
                Self::MAX_LEVELS
            )));
        }
        Ok(BgGrid::Range { start, stop, step })
    }

    /// The levels (e-) for a run whose brightest expected pixel holds `peak_e`; 0 is always included.
    pub fn levels(&self, peak_e: f64) -> Vec<f64> {
        let mut levels = vec![0.0];
        match self {
            BgGrid::Range { start, stop, step } => {
                let count = ((stop - start) / step + 1e-9).floor() as usize;
                levels.extend((0..=count).map(|k| start + k as f64 * step));
            }
            BgGrid::Auto => {
                // Fine where EMCCD (photon-counting units) and low-noise sCMOS optima lie,
                // coarser above, then 5 % steps up to the brightest pixel, beyond which
                // nearly every frame would be empty.
                for (lo, hi, step) in [
                    (0.0f64, 1.0f64, 0.05f64),
                    (1.0, 3.0, 0.1),
                    (3.0, 10.0, 0.25),
                    (10.0, 20.0, 0.5),
                    (20.0, 40.0, 1.0),
                ] {
                    let count = ((hi - lo) / step + 1e-9).round() as usize;
                    levels.extend((0..count).map(|k| lo + k as f64 * step));
                }
                let mut b: f64 = 40.0;
                let top = peak_e.max(60.0);
                while b < top * 1.05 {
                    levels.push(b);
                    b *= 1.05;
                }
            }
        }
        levels.sort_by(f64::total_cmp);
        levels.dedup_by(|a, b| (*a - *b).abs() < 1e-12);
        levels
    }
}

/// One Monte-Carlo configuration.
#[derive(Debug, Clone)]
pub struct SimConfig {
    /// Sub-aperture side (px).
    pub subap_px: usize,
    /// Spot shape.
    pub spot: Spot,
    /// Pixel sampling of the spot.
    pub sampling: Sampling,
    /// Photons per sub-aperture (before QE).
    pub signal_photons: f64,
    /// Quantum efficiency (photo-electrons per photon).
    pub qe: f64,
    /// Iterations (frames).
    pub iters: u64,
    /// Seed of all random streams.
    pub seed: u64,
    /// Background levels to sweep.
    pub bg_grid: BgGrid,
    /// Spot offsets are uniform in [-h, h) px in each axis, h = this half-width.
    pub position_half_range_px: f64,
    /// A level is eligible for the optimum when at most this fraction of frames is empty.
    pub max_empty_frac: f64,
}

impl SimConfig {
    /// The paper's defaults for one sub-aperture size: D = 2 px Airy, S = 50, QE 1, 10,000 frames.
    pub fn paper(subap_px: usize) -> Self {
        SimConfig {
            subap_px,
            spot: Spot::Airy { diameter_px: 2.0 },
            sampling: Sampling::Integrated,
            signal_photons: 50.0,
            qe: 1.0,
            iters: 10_000,
            seed: 1,
            bg_grid: BgGrid::Auto,
            position_half_range_px: 0.5,
            max_empty_frac: 0.01,
        }
    }

    /// Smallest sub-aperture side (px): a centroid inside one pixel carries no information.
    pub const MIN_SUBAP_PX: usize = 2;
    /// Largest sub-aperture side (px): the pixel-integrated spot table grows as the square of
    /// the side (0.14 GB at 128 px), and Shack-Hartmann sub-apertures are far smaller.
    pub const MAX_SUBAP_PX: usize = 128;
    /// Largest signal x QE (photo-electrons per sub-aperture). Photo-electron counts are 32-bit
    /// per pixel (at most 4.29e9) and the whole signal can fall into one pixel: the bound keeps a
    /// 4x margin. At 1e9 photons R is at its shot-noise limit, near 1e-5 px.
    pub const MAX_PHOTO_E: f64 = 1e9;
    /// Most iterations per configuration (1e9 frames of a 16x16 sub-aperture take days).
    pub const MAX_ITERS: u64 = 1_000_000_000;

    /// Largest spot offset half-range (px) for `subap_px`: a quarter of the side, so the spot
    /// centre stays in the central half of the sub-aperture and the spot mostly inside it.
    pub fn max_position_half_range_px(subap_px: usize) -> f64 {
        subap_px as f64 / 4.0
    }

    /// Check every value; the error names the option and its allowed range.
    pub fn validate(&self) -> Result<()> {
        let check = |ok: bool, option: &str, msg: String| {
            if ok {
                Ok(())
            } else {
                Err(Error::invalid(option, msg))
            }
        };
        let n = self.subap_px;
        check(
            (Self::MIN_SUBAP_PX..=Self::MAX_SUBAP_PX).contains(&n),
            "--subap",
            format!(
                "{n} px: sub-aperture sizes must be {} to {} px per side (a centroid inside one \
                 pixel carries no position information)",
                Self::MIN_SUBAP_PX,
                Self::MAX_SUBAP_PX
            ),
        )?;
        check(
            self.signal_photons.is_finite() && self.signal_photons > 0.0,
            "--signal",
            format!("{}: signals must be > 0 photons", self.signal_photons),
        )?;
        check(
            self.qe.is_finite() && self.qe > 0.0 && self.qe <= 1.0,
            "--qe",
            format!("{}: QE must be in (0, 1]", self.qe),
        )?;
        let photo_e = self.signal_photons * self.qe;
        check(
            photo_e <= Self::MAX_PHOTO_E,
            "--signal",
            format!(
                "{} photons x QE {} = {photo_e:e} photo-electrons per sub-aperture; at most {:e} \
                 are simulated: counts are 32-bit per pixel (4.29e9) and the whole signal can fall \
                 in one pixel, so above this R would silently go wrong (at 1e9, R is already at its \
                 shot-noise limit, about 1e-5 px)",
                self.signal_photons,
                self.qe,
                Self::MAX_PHOTO_E
            ),
        )?;
        check(
            (2..=Self::MAX_ITERS).contains(&self.iters),
            "--iters",
            format!(
                "{}: must be 2 to {:e} (a standard error needs two iterations)",
                self.iters,
                Self::MAX_ITERS as f64
            ),
        )?;
        let h_max = Self::max_position_half_range_px(n);
        check(
            self.position_half_range_px.is_finite()
                && (0.0..=h_max).contains(&self.position_half_range_px),
            "--position-range",
            format!(
                "{} px: the half-range must be 0 to {h_max} px for {n}x{n} px sub-apertures (a \
                 quarter of the side: the spot centre stays in the central half, so the spot stays \
                 mostly inside the sub-aperture)",
                self.position_half_range_px
            ),
        )?;
        check(
            (0.0..=1.0).contains(&self.max_empty_frac),
            "--max-empty-frac",
            format!("{}: must be in [0, 1]", self.max_empty_frac),
        )
    }
}

/// R and its statistics at one background level.
#[derive(Debug, Clone, serde::Serialize)]
pub struct LevelStats {
    /// Background level (e-).
    pub b_e: f64,
    /// Mean radial error (px).
    pub r_px: f64,
    /// Standard error of the mean radial error (px).
    pub r_se_px: f64,
    /// Frames with nothing above the level.
    pub empty_frames: u64,
}

/// The outcome for one readout model.
#[derive(Debug, Clone, serde::Serialize)]
pub struct SimResult {
    /// Model name.
    pub model: String,
    /// R: minimum over eligible levels of the mean radial error (px).
    pub r_px: f64,
    /// Standard error of R (px).
    pub r_se_px: f64,
    /// Background level at the minimum (e-).
    pub b_opt_e: f64,
    /// True when the optimum is the highest level of the grid (widen the grid).
    pub b_at_grid_edge: bool,
    /// True when no level met the empty-frame limit (the least-empty level is then reported).
    pub no_eligible_level: bool,
    /// Mean radial error with no background subtraction (b = 0; px).
    pub r0_px: f64,
    /// Standard error of R(0) (px).
    pub r0_se_px: f64,
    /// Frames with nothing above the optimum level.
    pub zero_frames: u64,
    /// R at every level.
    pub levels: Vec<LevelStats>,
}

/// Run the Monte-Carlo for every model; `on_progress` receives iteration counts as chunks finish.
pub fn run(
    cfg: &SimConfig,
    models: &[&dyn Readout],
    on_progress: &(dyn Fn(u64) + Sync),
) -> Result<Vec<SimResult>> {
    cfg.validate()?;
    let n = cfg.subap_px;
    let renderer = SpotRenderer::new(cfg.spot, cfg.sampling, n, cfg.position_half_range_px);
    let levels = cfg.bg_grid.levels(peak_expected_e(cfg, &renderer));
    let chunks = cfg.iters.div_ceil(CHUNK);
    let mut total = vec![LevelSums::new(levels.len()); models.len()];
    // Chunks run in parallel a batch at a time and are merged in chunk order, so the sums do
    // not depend on the thread count and memory does not grow with the iterations.
    for batch in (0..chunks).step_by(BATCH_CHUNKS as usize) {
        let partials: Vec<Vec<LevelSums>> = (batch..(batch + BATCH_CHUNKS).min(chunks))
            .into_par_iter()
            .map(|c| {
                let first = c * CHUNK;
                let last = (first + CHUNK).min(cfg.iters);
                let accs = run_chunk(cfg, &renderer, &levels, models, first..last);
                on_progress(last - first);
                accs
            })
            .collect();
        for part in &partials {
            for (t, p) in total.iter_mut().zip(part) {
                t.merge(p);
            }
        }
    }
    Ok(models
        .iter()
        .zip(&total)
        .map(|(m, acc)| summarise(m.name(), acc, &levels, cfg))
        .collect())
}

/// Brightest expected pixel (e-) of a centred spot: sizes the automatic background grid.
fn peak_expected_e(cfg: &SimConfig, renderer: &SpotRenderer) -> f64 {
    let mut img = vec![0.0; cfg.subap_px * cfg.subap_px];
    renderer.render(0.0, 0.0, &mut img);
    let total: f64 = img.iter().sum();
    let peak = img.iter().cloned().fold(0.0, f64::max);
    if total > 0.0 {
        peak / total * cfg.signal_photons * cfg.qe
    } else {
        0.0
    }
}

fn run_chunk(
    cfg: &SimConfig,
    renderer: &SpotRenderer,
    levels: &[f64],
    models: &[&dyn Readout],
    iters: std::ops::Range<u64>,
) -> Vec<LevelSums> {
    let n = cfg.subap_px;
    let npix = n * n;
    let mut accs = vec![LevelSums::new(levels.len()); models.len()];
    let mut sweep = BackgroundSweep::new(levels.to_vec(), n);
    let mut expected = vec![0.0; npix];
    let mut photons = vec![0u32; npix];
    let mut image = vec![0.0; npix];
    let h = cfg.position_half_range_px;
    for it in iters {
        let mut pos = stream(cfg.seed, it, POSITION);
        let (x0, y0) = (pos.random_range(-h..=h), pos.random_range(-h..=h));
        renderer.render(x0, y0, &mut expected);
        let total: f64 = expected.iter().sum();
        // A spot entirely outside the sub-aperture leaves nothing to measure.
        let scale = if total > 0.0 {
            cfg.signal_photons * cfg.qe / total
        } else {
            0.0
        };
        expected.iter_mut().for_each(|v| *v *= scale);
        let truth = cog(&expected, n).unwrap_or((0.0, 0.0));
        let mut ph = stream(cfg.seed, it, PHOTONS);
        for (k, lambda) in photons.iter_mut().zip(&expected) {
            *k = poisson(*lambda, &mut ph);
        }
        let input = FrameInput {
            subap_px: n,
            expected_e: &expected,
            photo_e: &photons,
        };
        for (model, acc) in models.iter().zip(accs.iter_mut()) {
            let mut noise = stream(cfg.seed, it, NOISE);
            let mut aux = stream(cfg.seed, it, AUX);
            model.read(&input, &mut noise, &mut aux, &mut image);
            sweep.accumulate(&image, truth, acc);
        }
    }
    accs
}

fn summarise(model: String, acc: &LevelSums, levels: &[f64], cfg: &SimConfig) -> SimResult {
    let n = cfg.iters as f64;
    let stats: Vec<LevelStats> = levels
        .iter()
        .zip(acc.finish())
        .map(|(&b, (sum, sum_sq, empty))| {
            let mean = sum / n;
            let var = ((sum_sq / n - mean * mean) * n / (n - 1.0)).max(0.0);
            LevelStats {
                b_e: b,
                r_px: mean,
                r_se_px: (var / n).sqrt(),
                empty_frames: empty,
            }
        })
        .collect();
    let limit = (cfg.max_empty_frac * n).floor() as u64;
    let eligible: Vec<usize> = (0..stats.len())
        .filter(|&k| stats[k].empty_frames <= limit)
        .collect();
    let no_eligible_level = eligible.is_empty();
    let candidates = if no_eligible_level {
        let fewest = stats.iter().map(|s| s.empty_frames).min().unwrap_or(0);
        (0..stats.len())
            .filter(|&k| stats[k].empty_frames == fewest)
            .collect()
    } else {
        eligible
    };
    let best = candidates
        .into_iter()
        .min_by(|&a, &b| stats[a].r_px.total_cmp(&stats[b].r_px))
        .expect("at least one level");
    SimResult {
        model,
        r_px: stats[best].r_px,
        r_se_px: stats[best].r_se_px,
        b_opt_e: stats[best].b_e,
        b_at_grid_edge: best + 1 == stats.len() && stats.len() > 1,
        no_eligible_level,
        r0_px: stats[0].r_px,
        r0_se_px: stats[0].r_se_px,
        zero_frames: stats[best].empty_frames,
        levels: stats,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::detector::{ModelParams, ModelSpec, ScmosConstant};

    fn models(names: &[&str], n: usize) -> Vec<Box<dyn Readout>> {
        names
            .iter()
            .map(|m| {
                ModelSpec::parse(m)
                    .unwrap()
                    .build(&ModelParams::default(), n)
                    .unwrap()
            })
            .collect()
    }

    fn refs(models: &[Box<dyn Readout>]) -> Vec<&dyn Readout> {
        models.iter().map(|m| m.as_ref()).collect()
    }

    /// R(0) of a noiseless readout at `signal` photons, 8x8 px, against the shot-noise limit:
    /// the centre of gravity of Poisson counts has per-axis variance var_x / S (var_x the
    /// spot's second moment in the sub-aperture), so R(0) = sqrt(pi/2) sqrt((var_x + var_y) / 2 / S)
    /// for this nearly isotropic error; within 4 SE.
    fn check_shot_noise_limit(signal: f64, iters: u64) {
        let mut cfg = SimConfig::paper(8);
        cfg.signal_photons = signal;
        cfg.iters = iters;
        cfg.position_half_range_px = 0.0;
        let m = ScmosConstant::new(0.0, "none".into());
        let r = &run(&cfg, &[&m], &|_| {}).unwrap()[0];
        let renderer = SpotRenderer::new(cfg.spot, cfg.sampling, 8, 0.0);
        let mut img = vec![0.0; 64];
        renderer.render(0.0, 0.0, &mut img);
        let total: f64 = img.iter().sum();
        let var: f64 = img
            .iter()
            .enumerate()
            .map(|(k, v)| {
                v / total * (((k % 8) as f64 - 3.5).powi(2) + ((k / 8) as f64 - 3.5).powi(2)) / 2.0
            })
            .sum();
        let expected = (std::f64::consts::PI / 2.0).sqrt() * (var / cfg.signal_photons).sqrt();
        assert!(
            (r.r0_px - expected).abs() < 4.0 * r.r0_se_px,
            "S = {signal}: R(0) = {} +- {}, expected {expected}",
            r.r0_px,
            r.r0_se_px
        );
        assert_eq!(r.zero_frames, 0);
    }

    #[test]
    fn noiseless_readout_error_is_the_shot_noise_limit() {
        check_shot_noise_limit(1e6, 4000);
    }

    #[test]
    fn precision_holds_up_to_the_signal_limit() {
        // At the largest accepted signal the counts still fit (32-bit per pixel) and R keeps
        // falling as 1/sqrt(S); above it the run is refused, naming --signal and the limit.
        check_shot_noise_limit(SimConfig::MAX_PHOTO_E, 1000);
        let mut cfg = SimConfig::paper(8);
        cfg.signal_photons = 2.0 * SimConfig::MAX_PHOTO_E;
        let msg = cfg.validate().unwrap_err().to_string();
        assert!(msg.contains("--signal") && msg.contains("1e9"), "{msg}");
        // The limit applies to photo-electrons: QE 0.4 brings 2e9 photons under it.
        cfg.qe = 0.4;
        cfg.validate().unwrap();
    }

    #[test]
    fn configurations_outside_the_engine_limits_are_refused() {
        type Spoil = fn(&mut SimConfig);
        let cases: [(&str, Spoil); 6] = [
            ("--subap", |c| c.subap_px = 1),
            ("--subap", |c| c.subap_px = SimConfig::MAX_SUBAP_PX + 1),
            ("--position-range", |c| c.position_half_range_px = 2.01),
            ("--position-range", |c| c.position_half_range_px = 1e9),
            ("--iters", |c| c.iters = 1),
            ("--max-empty-frac", |c| c.max_empty_frac = 1.5),
        ];
        for (option, spoil) in cases {
            let mut cfg = SimConfig::paper(8);
            spoil(&mut cfg);
            let err = cfg.validate().unwrap_err();
            assert_eq!(err.exit_code(), 2);
            assert!(err.to_string().contains(option), "{err}");
        }
        let mut cfg = SimConfig::paper(8);
        cfg.position_half_range_px = 2.0;
        cfg.validate().unwrap();
        SimConfig::paper(2).validate().unwrap();
    }

    #[test]
    fn sums_over_several_batches_do_not_depend_on_thread_count() {
        // More chunks than one batch holds: batches are merged in chunk order.
        let mut cfg = SimConfig::paper(2);
        cfg.iters = CHUNK * BATCH_CHUNKS + 300;
        let m = ScmosConstant::new(1.0, "one".into());
        let run_with = |threads| {
            let pool = rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .unwrap();
            pool.install(|| run(&cfg, &[&m], &|_| {}).unwrap().remove(0))
        };
        let (a, b) = (run_with(1), run_with(2));
        assert_eq!(a.r_px.to_bits(), b.r_px.to_bits());
        assert_eq!(a.r_se_px.to_bits(), b.r_se_px.to_bits());
    }

    #[test]
    fn results_do_not_depend_on_thread_count() {
        let mut cfg = SimConfig::paper(6);
        cfg.iters = 1000;
        let names = ["emccd-stochastic", "scmos-random", "emccd-simple"];
        let run_with = |threads| {
            let pool = rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .unwrap();
            pool.install(|| run(&cfg, &refs(&models(&names, 6)), &|_| {}).unwrap())
        };
        let (a, b) = (run_with(1), run_with(3));
        for (x, y) in a.iter().zip(&b) {
            assert_eq!(x.r_px.to_bits(), y.r_px.to_bits());
            assert_eq!(x.r_se_px.to_bits(), y.r_se_px.to_bits());
            assert_eq!(x.b_opt_e, y.b_opt_e);
        }
    }

    #[test]
    fn error_grows_with_read_noise_on_common_random_numbers() {
        // Same spots, photons and deviates: R(sigma) must be increasing.
        let mut cfg = SimConfig::paper(8);
        cfg.iters = 2000;
        let m = models(
            &[
                "scmos-constant:0.2",
                "scmos-constant:0.8",
                "scmos-constant:2",
                "scmos-constant:5",
            ],
            8,
        );
        let r: Vec<f64> = run(&cfg, &refs(&m), &|_| {})
            .unwrap()
            .iter()
            .map(|s| s.r_px)
            .collect();
        assert!(r.windows(2).all(|w| w[0] < w[1]), "{r:?}");
    }

    #[test]
    fn optimum_respects_empty_frame_limit() {
        // Heavy-tailed noise, large sub-aperture, faint spot: the raw minimum of R(b) lies
        // where most frames are empty (SPEC 3.7); the reported optimum must not.
        let mut cfg = SimConfig::paper(16);
        cfg.iters = 2000;
        let r = &run(&cfg, &refs(&models(&["scmos-random"], 16)), &|_| {}).unwrap()[0];
        assert!(r.zero_frames as f64 <= 0.01 * cfg.iters as f64);
        assert!(!r.b_at_grid_edge);
        let raw = r
            .levels
            .iter()
            .min_by(|a, b| a.r_px.total_cmp(&b.r_px))
            .unwrap();
        assert!(
            raw.b_e > r.b_opt_e,
            "raw minimum {} vs eligible {}",
            raw.b_e,
            r.b_opt_e
        );
    }

    #[test]
    fn bg_grid_parsing() {
        assert_eq!(
            BgGrid::parse("0:1:0.5").unwrap().levels(10.0),
            vec![0.0, 0.5, 1.0]
        );
        assert_eq!(
            BgGrid::parse("2:3:1").unwrap().levels(10.0),
            vec![0.0, 2.0, 3.0]
        );
        for bad in ["1:0:1", "0:1:0", "a:b:c", "0:1", "-1:2:1"] {
            assert!(BgGrid::parse(bad).is_err(), "{bad}");
        }
        // A well-formed grid with too many levels says so: the limit and its level count.
        let msg = BgGrid::parse("0:1000:0.001").unwrap_err().to_string();
        assert!(
            msg.contains("1000001 levels") && msg.contains("100000"),
            "{msg}"
        );
        assert_eq!(
            BgGrid::parse("0:99999:1").unwrap().levels(1.0).len(),
            100_000
        );
        let auto = BgGrid::Auto.levels(500.0);
        assert!(auto[0] == 0.0 && *auto.last().unwrap() >= 500.0);
        assert!(auto.windows(2).all(|w| w[0] < w[1]));
    }
}
