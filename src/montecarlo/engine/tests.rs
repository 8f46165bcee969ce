use super::*;
use crate::detector::{ModelParams, ModelSpec, ScmosConstant};
use crate::montecarlo::Term;
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

/// Every model's R, SE and optimum, as bits.
fn bits(results: &[SimResult]) -> Vec<(u64, u64, u64, u64)> {
    results
        .iter()
        .map(|r| {
            let empty = r.levels.iter().map(|l| l.empty_frames).sum();
            (
                r.r_px.to_bits(),
                r.r_se_px.to_bits(),
                r.b_opt_e.to_bits(),
                empty,
            )
        })
        .collect()
}

#[test]
fn a_continued_experiment_is_the_same_experiment() {
    // Extended on chunk boundaries, sums are added in the same order as one long run: the
    // results are identical bit for bit, with and without blocks; extended elsewhere, the same
    // frames are summed in another grouping, equal to rounding.
    let mut cfg = SimConfig::paper(4);
    cfg.iters = 3 * CHUNK + 100;
    let m = models(&["scmos-random", "scmos-constant:1"], 4);
    let m = refs(&m);
    let whole = run(&cfg, &m, &Silent).unwrap();
    let mut parts = Experiment::new(&cfg, &m).unwrap();
    parts.extend_to(2 * CHUNK, &Silent, 1).unwrap();
    parts.extend_to(cfg.iters, &Silent, 1).unwrap();
    assert_eq!(parts.iters(), cfg.iters);
    assert_eq!(bits(&parts.results().unwrap()), bits(&whole));
    let blocked = |steps: &[u64]| {
        let mut e = Experiment::new(&cfg, &m).unwrap().with_blocks();
        for &s in steps {
            e.extend_to(s, &Silent, 1).unwrap();
        }
        e
    };
    let (one, two) = (blocked(&[cfg.iters]), blocked(&[CHUNK, cfg.iters]));
    assert_eq!(bits(&one.results().unwrap()), bits(&two.results().unwrap()));
    let terms = [
        Term {
            model: 0,
            level: 3,
            coef: 1.0,
        },
        Term {
            model: 1,
            level: 5,
            coef: -1.0,
        },
    ];
    assert_eq!(
        one.paired_se(&terms).to_bits(),
        two.paired_se(&terms).to_bits()
    );
    let odd = blocked(&[300, 301, 777, cfg.iters]);
    for (a, b) in odd.results().unwrap().iter().zip(&whole) {
        assert!(
            (a.r_px - b.r_px).abs() < 1e-12 * b.r_px,
            "{} {}",
            a.r_px,
            b.r_px
        );
        assert_eq!(a.b_opt_e, b.b_opt_e);
    }
    assert!((odd.paired_se(&terms) / one.paired_se(&terms) - 1.0).abs() < 1e-9);
}

#[test]
fn blocks_of_a_continued_experiment_do_not_depend_on_thread_count() {
    // Several batches and enough blocks to double their size: the paired SE is the same bit
    // for bit on one thread and three.
    let mut cfg = SimConfig::paper(2);
    cfg.iters = 40_000;
    let m = models(&["scmos-random", "scmos-constant:0.5"], 2);
    let m = refs(&m);
    let terms = [
        Term {
            model: 0,
            level: 0,
            coef: 1.0,
        },
        Term {
            model: 1,
            level: 2,
            coef: -0.5,
        },
    ];
    let run_with = |threads| {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap();
        pool.install(|| {
            let mut e = Experiment::new(&cfg, &m).unwrap().with_blocks();
            e.extend_to(1000, &Silent, 1).unwrap();
            e.extend_to(cfg.iters, &Silent, 1).unwrap();
            (bits(&e.results().unwrap()), e.paired_se(&terms).to_bits())
        })
    };
    let (a, b) = (run_with(1), run_with(3));
    assert_eq!(a, b);
    assert!(f64::from_bits(a.1).is_finite());
}

#[test]
fn extensions_advance_the_observer_by_their_weighted_iterations() {
    let cfg = SimConfig::paper(2);
    let m = ScmosConstant::new(1.0, "one".into());
    let recorder = Recorder::default();
    let mut e = Experiment::new(&cfg, &[&m]).unwrap();
    e.extend_to(300, &recorder, 4).unwrap();
    e.extend_to(300, &recorder, 4).unwrap();
    e.extend_to(1000, &recorder, 4).unwrap();
    assert_eq!(
        recorder.advanced.load(std::sync::atomic::Ordering::Relaxed),
        4000
    );
    let err = e
        .extend_to(SimConfig::MAX_ITERS + 1, &recorder, 1)
        .unwrap_err();
    assert!(err.to_string().contains("`iters`"), "{err}");
}

#[test]
fn a_cancelled_run_stops_between_batches_and_can_be_continued() {
    // An observer that asks to stop once the first batch has advanced: the run returns
    // `Interrupted`, keeps the batch it merged (iters() says so), and continuing it gives the
    // same sums as an uninterrupted run.
    struct StopAfter(std::sync::atomic::AtomicU64, u64);
    impl crate::progress::Observer for StopAfter {
        fn advance(&self, n: u64) {
            self.0.fetch_add(n, std::sync::atomic::Ordering::Relaxed);
        }
        fn cancelled(&self) -> bool {
            self.0.load(std::sync::atomic::Ordering::Relaxed) >= self.1
        }
    }
    let mut cfg = SimConfig::paper(2);
    cfg.iters = 2 * CHUNK * BATCH_CHUNKS + 5;
    let m = ScmosConstant::new(1.0, "one".into());
    let mut exp = Experiment::new(&cfg, &[&m]).unwrap();
    let stop = StopAfter(Default::default(), 1);
    let err = exp.extend_to(cfg.iters, &stop, 1).unwrap_err();
    assert!(matches!(err, Error::Interrupted));
    assert_eq!(exp.iters(), CHUNK * BATCH_CHUNKS);
    exp.extend_to(cfg.iters, &Silent, 1).unwrap();
    let whole = run(&cfg, &[&m], &Silent).unwrap().remove(0);
    assert_eq!(
        exp.results().unwrap()[0].r_px.to_bits(),
        whole.r_px.to_bits()
    );
}

#[test]
fn a_readout_that_overflows_the_sums_is_an_error_not_an_empty_r() {
    // Issue 30: 1e20 e- of read noise overflowed the single-precision centroid sums, and the
    // run exited 0 with R empty, SE 0 and no_eligible_level false. Now an error naming the
    // model, the setting and the noise scale; a sane model in the same run changes nothing.
    let mut cfg = SimConfig::paper(8);
    cfg.iters = 600;
    let absurd = ScmosConstant::new(1e20, "scmos-constant:1e20".into());
    let sane = ScmosConstant::new(1.0, "scmos-constant:1".into());
    let err = run(&cfg, &[&sane, &absurd], &Silent).unwrap_err();
    let msg = err.to_string();
    assert!(
        msg.starts_with("scmos-constant:1e20 through cog: the mean radial error is not finite")
            && msg.contains("noise scale 1e20 e-"),
        "{msg}"
    );
    assert_eq!(err.exit_code(), 1);
    let alone = run(&cfg, &[&sane], &Silent).unwrap();
    assert!(alone[0].r_px.is_finite() && alone[0].r_se_px > 0.0);
    // The effective read noise refuses the same way, before any value is settled.
    let precision = crate::effective::Precision {
        max_iters: 600,
        ..crate::effective::Precision::default()
    };
    let e = crate::effective::effective_sigma(&cfg, &absurd, &precision, &Silent).unwrap_err();
    assert!(e.to_string().contains("is not finite"), "{e}");
}

/// E[v] and E[v^2] of v = max(k + sigma Z - b, 0) for k ~ Poisson(mu), Z ~ N(0, 1): the
/// clipped value of a pixel of mean mu photo-electrons and read noise sigma (e-) at background
/// level b (e-). For m = k - b: E[max(m + sigma Z, 0)] = m Phi + sigma phi and
/// E[max(m + sigma Z, 0)^2] = (m^2 + sigma^2) Phi + m sigma phi (Phi, phi at m / sigma).
fn clipped_moments(mu: f64, sigma: f64, b: f64) -> (f64, f64) {
    use crate::special::norm_cdf;
    let phi = |z: f64| (-0.5 * z * z).exp() / (2.0 * std::f64::consts::PI).sqrt();
    let (mut p, mut first, mut second) = ((-mu).exp(), 0.0, 0.0);
    for k in 0..(mu + 12.0 * mu.sqrt() + 20.0) as u64 {
        if k > 0 {
            p *= mu / k as f64;
        }
        let m = k as f64 - b;
        let (cdf, pdf) = (norm_cdf(m / sigma), phi(m / sigma));
        first += p * (m * cdf + sigma * pdf);
        second += p * ((m * m + sigma * sigma) * cdf + m * sigma * pdf);
    }
    (first, second)
}
#[test]
fn a_uniform_camera_has_no_static_part_and_the_parts_add_up() {
    // Uniform 1 e- camera, spots uniform in [-0.5, 0.5) px: by symmetry the mean error is 0,
    // so each component lies within 3 SE of it (fixed seed); the random and static parts add
    // up to the mean squared error: random^2 + static^2 = E|e|^2 (population moments).
    let mut cfg = SimConfig::paper(8);
    cfg.iters = 8000;
    let m = ScmosConstant::new(1.0, "uniform".into());
    let r = &run(&cfg, &[&m], &Silent).unwrap()[0];
    let p = &r.parts;
    assert!(p.static_x_px.abs() < 3.0 * p.static_x_se_px, "{p:?}");
    assert!(p.static_y_px.abs() < 3.0 * p.static_y_se_px, "{p:?}");
    assert!(
        p.static_px < 3.0 * p.static_se_px && p.static_se_px > 0.0,
        "{p:?}"
    );
    let ms = r.levels[r.best].r_se_px.powi(2) * (cfg.iters - 1) as f64 + r.r_px.powi(2);
    let sum = p.random_rms_px.powi(2) + p.static_px.powi(2);
    assert!((sum - p.rms_px.powi(2)).abs() < 1e-12 * sum, "{p:?}");
    // E|e|^2 from R and its SE: var d = E d^2 - R^2.
    assert!(
        (p.rms_px.powi(2) - ms).abs() < 1e-9 * ms,
        "{} vs {ms}",
        p.rms_px.powi(2)
    );
    assert!(p.random_rms_se_px > 0.0 && p.random_rms_se_px < 0.05 * p.random_rms_px);
}

#[test]
fn one_noisy_pixel_gives_the_static_offset_its_clipped_excess_predicts() {
    // 8x8 px uniform 1 e- but one pixel at 10 e-, off-centre (row 3, column 6: lever arm
    // (2.5, -0.5) px), a centred spot (no position jitter: truth 0). At the optimum level b the
    // noisy pixel's expected clipped value E[max(k + n - b, 0)] (k Poisson, n Gaussian) exceeds
    // a uniform pixel's; to first order the centroid's mean offset is that excess times its
    // lever arm over the expected clipped total (the uniform camera's first moment is 0 by
    // symmetry): E[A] / E[B] with A = sum v_i x_i, B = sum v_i. The noisy pixel's clipped value
    // scatters by a good part of the total, so the ratio's second-order terms matter (first
    // order overshoots by ~20 %): E[A / B] = E[A] / E[B] - cov(A, B) / E[B]^2 + E[A] var(B) /
    // E[B]^3, with independent pixels cov(A, B) = sum var(v_i) x_i, var(B) = sum var(v_i).
    // Within 3 SE per axis.
    let n = 8;
    let mut cfg = SimConfig::paper(n);
    cfg.iters = 6000;
    cfg.position_half_range_px = 0.0;
    let (row, col) = (3, 6);
    let mut sigma = vec![1.0; n * n];
    sigma[row * n + col] = 10.0;
    let m = crate::detector::PerPixelSigma::new(sigma.clone(), "one noisy pixel".into());
    let r = &run(&cfg, &[&m], &Silent).unwrap()[0];
    let renderer = SpotRenderer::new(cfg.spot, cfg.sampling, n, 0.0);
    let mean = mean_spot_e(&cfg, &renderer);
    let b = r.b_opt_e;
    let c = (n as f64 - 1.0) / 2.0;
    let moments: Vec<(f64, f64)> = (0..n * n)
        .map(|i| clipped_moments(mean[i], sigma[i], b))
        .collect();
    let total: f64 = moments.iter().map(|v| v.0).sum();
    let var = |v: &(f64, f64)| v.1 - v.0 * v.0;
    let var_total: f64 = moments.iter().map(var).sum();
    let p = row * n + col;
    let excess = moments[p].0 - clipped_moments(mean[p], 1.0, b).0;
    let first = |lever: f64| excess * lever / total;
    let predict = |axis: fn(usize) -> f64| {
        let ea = excess * axis(p);
        let cov: f64 = moments
            .iter()
            .enumerate()
            .map(|(i, v)| var(v) * axis(i))
            .sum();
        ea / total - cov / total.powi(2) + ea * var_total / total.powi(3)
    };
    let lever_x = |i: usize| (i % 8) as f64 - 3.5;
    let lever_y = |i: usize| (i / 8) as f64 - 3.5;
    let want = (predict(lever_x), predict(lever_y));
    let parts = &r.parts;
    println!(
        "b {b} e-: excess {excess:.3} e- of {total:.2}; static ({:.4} +- {:.4}, {:.4} +- {:.4}) px, \
         predicted ({:.4}, {:.4}), first order ({:.4}, {:.4}); random rms {:.4} px",
        parts.static_x_px,
        parts.static_x_se_px,
        parts.static_y_px,
        parts.static_y_se_px,
        want.0,
        want.1,
        first(col as f64 - c),
        first(row as f64 - c),
        parts.random_rms_px
    );
    assert!(parts.static_resolved && want.0 > 0.05, "{parts:?}");
    assert!((parts.static_x_px - want.0).abs() < 3.0 * parts.static_x_se_px);
    assert!((parts.static_y_px - want.1).abs() < 3.0 * parts.static_y_se_px);
}
