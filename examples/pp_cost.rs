//! Benchmark (not a test): cost of building Poisson-probability counters, per frame or cached.
//!
//! `cargo run --release --example pp_cost`

use std::time::Instant;

use detnoise::detector::pp::{PpCache, PpConfig, PpRule};

fn main() -> detnoise::Result<()> {
    let rule_a = PpConfig::new(PpRule::PoissonPrior, 500.0, 50.0)?;
    for lambda in [0.05, 0.2, 1.0, 4.0, 20.0] {
        let reps = 200;
        let t = Instant::now();
        let mut k = 0;
        for i in 0..reps {
            // A slightly different lambda each time defeats any caching.
            let c = rule_a.counter(lambda * (1.0 + 1e-6 * i as f64))?;
            k += c.thresholds.t_over_g.len();
        }
        let per = t.elapsed().as_secs_f64() / reps as f64;
        println!(
            "Rule A, lambda_ref {lambda:>5}: {:>4} thresholds, build {:.3} ms per counter",
            k / reps,
            per * 1e3
        );
    }
    let t = Instant::now();
    let b = PpConfig::new(PpRule::EqualDensity, 500.0, 50.0)?.counter(0.0)?;
    println!(
        "Rule B: {} thresholds, build {:.1} ms (once per run)",
        b.thresholds.t_over_g.len(),
        t.elapsed().as_secs_f64() * 1e3
    );
    // Frames of a 16x16 sub-aperture with about 50 photo-electrons: lambda = total / 256 takes
    // few distinct values, so a cache serves almost every frame.
    let cache = PpCache::new(rule_a, 4096)?;
    let t = Instant::now();
    let frames = 10_000;
    for f in 0..frames {
        let total = 50 + (f * 7919 % 29) as i64 - 14;
        cache.get(total as f64 / 256.0)?;
    }
    println!(
        "cached, {frames} frames of 36..64 photo-electrons: {:.3} ms per frame",
        t.elapsed().as_secs_f64() * 1e3 / frames as f64
    );
    Ok(())
}
