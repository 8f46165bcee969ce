//! Spot rendering speed: nanoseconds per pixel per render for the four kinds (Airy and Gauss,
//! point and integrated sampling) at 4x4 and 16x16 px, offsets uniform in [-0.5, 0.5) px as in
//! the Monte-Carlo; and the cost of building a renderer (first build of a spot, and again).
//!
//! Run with `cargo bench --bench spot` (or `-- FILTER` to run the cases whose line contains
//! FILTER, e.g. `-- "integrated 16x16"`). Goal: integrated Airy no slower than 1.1x point Airy.
//! Figures are wall time on one thread, the best of several repeats (other load on the machine
//! inflates the slower repeats); builds are timed once each, on all threads.

use detnoise::spot::{Sampling, Spot, SpotRenderer};
use std::hint::black_box;
use std::time::Instant;

/// Renders per timed repeat at 16x16 px (4x4 renders 16 times as many: equal pixel counts).
const RENDERS_16: usize = 20_000;
/// Timed repeats; the best is printed.
const REPEATS: usize = 7;

/// Offsets in [-0.5, 0.5) px from a fixed linear congruential sequence.
fn offsets(count: usize) -> Vec<(f64, f64)> {
    let mut state = 0x2545_f491_4f6c_dd1d_u64;
    let mut next = || {
        state = state
            .wrapping_mul(6_364_136_223_846_793_005)
            .wrapping_add(1_442_695_040_888_963_407);
        (state >> 11) as f64 / (1u64 << 53) as f64 - 0.5
    };
    (0..count).map(|_| (next(), next())).collect()
}

fn main() {
    let filter = std::env::args().nth(1).filter(|a| a != "--bench");
    let airy = Spot::Airy { diameter_px: 2.0 };
    let gauss = Spot::Gauss {
        sigma_x_px: 1.0,
        sigma_y_px: 1.5,
    };
    let kinds = [
        (airy, Sampling::Point),
        (airy, Sampling::Integrated),
        (gauss, Sampling::Point),
        (gauss, Sampling::Integrated),
    ];
    println!(
        "ns per pixel per render (best of {REPEATS} repeats, the kinds taking turns); renderer \
         construction: first for its spot and size (builds the table), and again (cache hit)"
    );
    println!(
        "{:>12} {:>11} {:>6} {:>10} {:>15} {:>10}",
        "spot", "sampling", "subap", "ns/pixel", "first build ms", "again ms"
    );
    for n in [4usize, 16] {
        let renders = RENDERS_16 * 256 / (n * n);
        let offs = offsets(renders);
        let mut img = vec![0.0; n * n];
        let cases: Vec<_> = kinds
            .iter()
            .filter(|(spot, sampling)| {
                let case = format!("{} {} {n}x{n}", spot.label(), sampling.label());
                filter.as_ref().is_none_or(|f| case.contains(f.as_str()))
            })
            .map(|&(spot, sampling)| {
                let t0 = Instant::now();
                let renderer = SpotRenderer::new(spot, sampling, n, 0.5);
                let first = t0.elapsed().as_secs_f64();
                let t1 = Instant::now();
                black_box(SpotRenderer::new(spot, sampling, n, 0.5));
                (spot, sampling, renderer, first, t1.elapsed().as_secs_f64())
            })
            .collect();
        let mut best = vec![f64::INFINITY; cases.len()];
        for _ in 0..REPEATS {
            for (case, best) in cases.iter().zip(best.iter_mut()) {
                let t = Instant::now();
                for &(x0, y0) in &offs {
                    case.2.render(black_box(x0), black_box(y0), &mut img);
                    black_box(&img);
                }
                *best = best.min(t.elapsed().as_secs_f64() * 1e9 / (renders * n * n) as f64);
            }
        }
        for ((spot, sampling, _, first, again), ns) in cases.iter().zip(&best) {
            println!(
                "{:>12} {:>11} {:>6} {:>10.2} {:>15.2} {:>10.4}",
                spot.label(),
                sampling.label(),
                format!("{n}x{n}"),
                ns,
                first * 1e3,
                again * 1e3
            );
        }
        if best.len() == kinds.len() {
            println!(
                "{:>12} integrated / point at {n}x{n}: {:.2}",
                "airy:2",
                best[1] / best[0]
            );
        }
    }
}
