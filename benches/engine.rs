//! Monte-Carlo throughput: nanoseconds per pixel-frame per core for every readout model,
//! at 4x4 and 16x16 pixels, S = 50 photons, the default background grid (full sweep included).
//!
//! Run with `cargo bench --bench engine`. Target: at most 100 ns per pixel-frame per core.

use detnoise::detector::{ModelParams, ModelSpec, Readout};
use detnoise::montecarlo::{run, SimConfig};
use std::time::Instant;

const MODELS: [&str; 8] = [
    "emccd-simple",
    "emccd-stochastic",
    "emccd-distribution",
    "scmos-constant:1",
    "scmos-median",
    "scmos-mean",
    "scmos-fixed:0",
    "scmos-random",
];

/// Process CPU time (user + system) in seconds, from /proc/self/stat (Linux; 10 ms ticks).
fn cpu_seconds() -> Option<f64> {
    let stat = std::fs::read_to_string("/proc/self/stat").ok()?;
    let after = &stat[stat.rfind(')')? + 2..];
    let fields: Vec<&str> = after.split_whitespace().collect();
    let ticks: f64 = fields.get(11)?.parse::<f64>().ok()? + fields.get(12)?.parse::<f64>().ok()?;
    Some(ticks / 100.0)
}

fn main() {
    let threads = rayon::current_num_threads();
    println!("threads: {threads}; S = 50 photons, Airy D = 2 px, integrated, auto background grid");
    println!("ns/pixel-frame/core is CPU time per pixel-frame, so other load on the machine does not inflate it");
    println!(
        "{:>20} {:>6} {:>10} {:>16} {:>20}",
        "model", "subap", "iters", "pixel-frames/s", "ns/pixel-frame/core"
    );
    let params = ModelParams::default();
    for n in [4usize, 16] {
        let mut cfg = SimConfig::paper(n);
        cfg.iters = if n == 4 { 200_000 } else { 20_000 };
        for name in MODELS {
            let built: Box<dyn Readout> =
                ModelSpec::parse(name).unwrap().build(&params, n).unwrap();
            let model = [built.as_ref()];
            // Warm-up builds the spot table and touches the caches.
            let mut warm = cfg.clone();
            warm.iters = 1000;
            run(&warm, &model, &detnoise::progress::Silent).unwrap();
            let (t, c0) = (Instant::now(), cpu_seconds());
            run(&cfg, &model, &detnoise::progress::Silent).unwrap();
            let secs = t.elapsed().as_secs_f64();
            let cpu = match (c0, cpu_seconds()) {
                (Some(a), Some(b)) => b - a,
                _ => secs * threads as f64,
            };
            let pf = (cfg.iters as usize * n * n) as f64;
            println!(
                "{:>20} {:>6} {:>10} {:>16.3e} {:>20.1}",
                name,
                format!("{n}x{n}"),
                cfg.iters,
                pf / secs,
                cpu * 1e9 / pf
            );
        }
    }
}
