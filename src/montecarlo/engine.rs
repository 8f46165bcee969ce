//! The Shack-Hartmann sub-aperture Monte-Carlo of Basden (2015), section 2.
//!
//! Per iteration: a random spot position, a noiseless image scaled to S x QE photo-electrons,
//! its centre of gravity as the truth, Poisson shot noise, a readout, then the centre of
//! gravity after subtracting each background level. All models of a run share the spot
//! positions, the photon draws and the read-noise deviates (common random numbers), and every
//! iteration has its own seeded streams, so results do not depend on the thread count.

use super::config::SimConfig;
use crate::centroid::{cog, BackgroundSweep, LevelSums};
use crate::detector::{FrameInput, Readout};
use crate::progress::Observer;
use crate::rng::stream;
use crate::spot::SpotRenderer;
use crate::stats::poisson;
use crate::Result;
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

/// Run the Monte-Carlo for every model; `observer` is advanced by the iterations of each chunk
/// as it finishes (the caller begins and ends the stage).
pub fn run(
    cfg: &SimConfig,
    models: &[&dyn Readout],
    observer: &dyn Observer,
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
                observer.advance(last - first);
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
    use crate::progress::{Recorder, Silent};

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
        let r = &run(&cfg, &[&m], &Silent).unwrap()[0];
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
        // falling as 1/sqrt(S); above it the run is refused, naming the signal and the limit.
        check_shot_noise_limit(SimConfig::MAX_PHOTO_E, 1000);
        let mut cfg = SimConfig::paper(8);
        cfg.signal_photons = 2.0 * SimConfig::MAX_PHOTO_E;
        let msg = cfg.validate().unwrap_err().to_string();
        assert!(
            msg.contains("`signal_photons`") && msg.contains("1e9"),
            "{msg}"
        );
        // The limit applies to photo-electrons: QE 0.4 brings 2e9 photons under it.
        cfg.qe = 0.4;
        cfg.validate().unwrap();
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
            pool.install(|| run(&cfg, &[&m], &Silent).unwrap().remove(0))
        };
        let (a, b) = (run_with(1), run_with(2));
        assert_eq!(a.r_px.to_bits(), b.r_px.to_bits());
        assert_eq!(a.r_se_px.to_bits(), b.r_se_px.to_bits());
    }

    #[test]
    fn observer_is_advanced_by_every_iteration_once() {
        // Chunks of a partial last batch and a partial last chunk: the counts add up exactly,
        // and `run` leaves beginning and ending the stage to its caller.
        let mut cfg = SimConfig::paper(2);
        cfg.iters = 3 * CHUNK + 7;
        let m = ScmosConstant::new(1.0, "one".into());
        let recorder = Recorder::default();
        run(&cfg, &[&m], &recorder).unwrap();
        let advanced = recorder.advanced.load(std::sync::atomic::Ordering::Relaxed);
        assert_eq!(advanced, cfg.iters);
        assert!(recorder.stages.lock().unwrap().is_empty());
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
            pool.install(|| run(&cfg, &refs(&models(&names, 6)), &Silent).unwrap())
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
        let r: Vec<f64> = run(&cfg, &refs(&m), &Silent)
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
        let r = &run(&cfg, &refs(&models(&["scmos-random"], 16)), &Silent).unwrap()[0];
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
}
