//! Monte-Carlo throughput on one core: nanoseconds per pixel-frame for every readout model, at
//! 4x4 and 16x16 px, point and integrated sampling, S = 50 photons, Airy D = 2 px, the automatic
//! background grid (the full sweep included), as in issue 12's table.
//!
//! `cargo bench --bench engine` (all models, 100,000 frames at 16x16 and 400,000 at 4x4);
//! `cargo bench --bench engine -- quick` runs a tenth of the frames; `point` or `integrated`
//! runs that sampling only, `4x4` or `16x16` that size only; any other argument keeps only the models whose name contains it.
//! Target: at most 20 ns per pixel-frame for every model, size and sampling; integrated at
//! most 10 % above point.
//!
//! Each figure is the best of three runs (`DETNOISE_BENCH_RUNS=N` for N; a shared virtual
//! machine's speed drifts, and more runs bring the best closer to the machine's own) of the
//! worker thread's CPU time (Linux), so other load
//! on the machine inflates it less; a run includes everything `montecarlo::run` does.

use detnoise::calib::{Map, Unit};
use detnoise::detector::{DarkFrames, ModelParams, ModelSpec, Readout, RtsTable, MODELS};
use detnoise::montecarlo::{run, SimConfig};
use detnoise::progress::Silent;
use detnoise::spot::Sampling;
use std::sync::Arc;

/// CPU time of the calling thread in seconds (nanosecond resolution).
fn thread_cpu_seconds() -> f64 {
    let mut ts = libc::timespec {
        tv_sec: 0,
        tv_nsec: 0,
    };
    // SAFETY: clock_gettime writes one timespec through a valid pointer.
    unsafe { libc::clock_gettime(libc::CLOCK_THREAD_CPUTIME_ID, &mut ts) };
    ts.tv_sec as f64 + ts.tv_nsec as f64 * 1e-9
}

/// The model names of the registry with their default argument, for the bench.
fn model_names() -> Vec<String> {
    MODELS
        .iter()
        .filter(|m| !m.name.starts_with("test-"))
        .map(|m| match m.name {
            "scmos-constant" => "scmos-constant:1".to_string(),
            "scmos-fixed" => "scmos-fixed:0".to_string(),
            n => n.to_string(),
        })
        .collect()
}

/// A 64x64 noise map (e-) drawn from the paper's pdf, for `scmos-map`.
fn bench_map(params: &ModelParams) -> Arc<Map> {
    let mut rng = detnoise::rng::stream(7, 0, 0);
    let data = (0..64 * 64).map(|_| params.pdf.sample(&mut rng)).collect();
    Arc::new(Map::new(64, 64, data, Unit::Electrons).with_source("bench map"))
}

/// Inputs of the models of the camera's real noise: 41 two-level telegraph pixels (1 % of the
/// 64x64 map, levels -1.5 / +0.5 e-), row and column noise of 0.3 e-, and the bundled
/// synthetic dark stack as dark frames.
fn real_noise_inputs(params: &mut ModelParams) {
    let mut text = String::from("x_px,y_px,n_levels,status");
    for k in 1..=3 {
        text.push_str(&format!(
            ",level_{k}_adu,level_{k}_se_adu,level_{k}_e,occupancy_{k},occupancy_{k}_se,\
             width_{k}_adu,width_{k}_e,dwell_{k}_frames,dwell_{k}_se_frames"
        ));
    }
    for p in (0..64 * 64).step_by(100) {
        text.push_str(&format!(
            "\n{},{},2,ok,-6,0.1,-1.5,0.25,0.01,4,1,10,1,2,0.1,0.5,0.75,0.01,4,1,30,2,,,,,,,,,",
            p % 64,
            p / 64
        ));
    }
    let table = RtsTable::parse(&text, std::path::Path::new("bench rts.csv")).expect("rts table");
    params.rts_table = Some(Arc::new(table));
    params.row_noise_e = Some(0.3);
    params.column_noise_e = Some(0.3);
    let darks = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("data-synthetic/scmos-darks-64x64.fits");
    let frames = DarkFrames::read(&[darks], 0.25, 64.0).expect("bundled dark frames");
    params.dark_frames = Some(Arc::new(frames));
}

/// Runs per figure: `DETNOISE_BENCH_RUNS` (at least 1), else 3.
fn runs() -> usize {
    std::env::var("DETNOISE_BENCH_RUNS")
        .ok()
        .and_then(|v| v.parse().ok())
        .map_or(3, |n: usize| n.max(1))
}

/// Best-of-[`runs`] CPU nanoseconds per pixel-frame of `model` under `cfg`.
fn ns_per_pixel_frame(cfg: &SimConfig, model: &dyn Readout) -> f64 {
    let pf = (cfg.iters as usize * cfg.subap_px * cfg.subap_px) as f64;
    (0..runs())
        .map(|_| {
            let c0 = thread_cpu_seconds();
            run(cfg, &[model], &Silent).expect("valid configuration");
            (thread_cpu_seconds() - c0) * 1e9 / pf
        })
        .fold(f64::INFINITY, f64::min)
}

/// The other sampling (an argument naming one sampling skips the other).
fn other(s: Sampling) -> Sampling {
    match s {
        Sampling::Point => Sampling::Integrated,
        Sampling::Integrated => Sampling::Point,
    }
}

fn main() {
    let args: Vec<String> = std::env::args()
        .skip(1)
        .filter(|a| a != "--bench")
        .collect();
    let quick = args.iter().any(|a| a == "quick");
    let samplings: Vec<Sampling> = [Sampling::Point, Sampling::Integrated]
        .into_iter()
        .filter(|s| !args.iter().any(|a| a == other(*s).label()))
        .collect();
    let filters: Vec<&String> = args
        .iter()
        .filter(|a| !["quick", "point", "integrated", "4x4", "16x16"].contains(&a.as_str()))
        .collect();
    let sizes: Vec<usize> = [4usize, 16]
        .into_iter()
        .filter(|n| {
            let other = if *n == 4 { "16x16" } else { "4x4" };
            !args.iter().any(|a| a == other)
        })
        .collect();
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(1)
        .build()
        .expect("one-thread pool");
    let mut params = ModelParams::default();
    params.map = Some(bench_map(&params));
    real_noise_inputs(&mut params);
    println!(
        "one core; S = 50 photons, Airy D = 2 px, automatic background grid; CPU ns per pixel-frame, best of {}",
        runs()
    );
    println!(
        "{:>22} {:>6} {:>9} {:>8} {:>11} {:>6}",
        "model", "subap", "frames", "point", "integrated", "ratio"
    );
    let mut worst: f64 = 0.0;
    for &n in &sizes {
        for name in model_names() {
            if !filters.is_empty() && !filters.iter().any(|f| name.contains(f.as_str())) {
                continue;
            }
            let built = ModelSpec::parse(&name)
                .and_then(|s| s.build(&params, n))
                .expect("bench models build");
            let mut figures = [f64::NAN; 2];
            let mut iters = 0;
            for &sampling in &samplings {
                let mut cfg = SimConfig::paper(n);
                cfg.sampling = sampling;
                cfg.signal_photons = 50.0;
                cfg.iters = if n == 4 { 400_000 } else { 100_000 };
                if quick {
                    cfg.iters /= 10;
                }
                iters = cfg.iters;
                figures[(sampling == Sampling::Integrated) as usize] =
                    pool.install(|| ns_per_pixel_frame(&cfg, built.as_ref()));
            }
            worst = figures
                .iter()
                .copied()
                .filter(|f| f.is_finite())
                .fold(worst, f64::max);
            println!(
                "{:>22} {:>6} {:>9} {:>8.1} {:>11.1} {:>6.2}",
                name,
                format!("{n}x{n}"),
                iters,
                figures[0],
                figures[1],
                figures[1] / figures[0]
            );
        }
    }
    println!("slowest: {worst:.1} ns per pixel-frame (target 20)");
}
