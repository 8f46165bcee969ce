//! Wall time of a whole per-sub-aperture map (`detnoise subaps`, in memory): a detector's noise
//! map drawn from the paper's sCMOS pdf, 16x16 px sub-apertures, S = 50 photons, Airy D = 2 px,
//! the paper's configuration, `cog`, the default precision target (10,000 starting frames, up to
//! 80,000), on every core rayon is given.
//!
//! `cargo bench --bench subaps` runs a 2048x2048 detector (16,384 sub-apertures; issue 32's
//! target: at most 10 minutes on two cores). `DETNOISE_SUBAPS_BENCH_PX=512` runs a 512x512
//! one (1,024 sub-apertures) instead, for a shared machine: extrapolate by the sub-aperture
//! count (the constant-sigma references are run once per job, so a small job overstates the
//! time per sub-aperture a little). It first times the map of Cramer-Rao floors alone (every
//! window's `r_crlb_px`; 16,384 windows took 8.6 s on two cores).

use detnoise::calib::{Map, Unit};
use detnoise::detector::ModelParams;
use detnoise::effective::{Precision, Status};
use detnoise::montecarlo::SimConfig;
use detnoise::progress::Silent;
use detnoise::subaps::{solve_all, Geometry, GridSpec, SubapsJob};
use std::time::Instant;

mod support;
use support::cpu_seconds;

/// Side of the sub-apertures (px).
const SUBAP_PX: usize = 16;

/// A `side` x `side` map (e-) drawn from the paper's sCMOS pdf.
fn bench_map(side: usize) -> Map {
    let params = ModelParams::default();
    let mut rng = detnoise::rng::stream(11, 0, 0);
    let data = (0..side * side)
        .map(|_| params.pdf.sample(&mut rng))
        .collect();
    Map::new(side, side, data, Unit::Electrons).with_source("bench map")
}

fn main() {
    let side: usize = std::env::var("DETNOISE_SUBAPS_BENCH_PX")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(2048);
    let map = bench_map(side);
    let geometry = Geometry {
        grid: GridSpec::parse(&SUBAP_PX.to_string()).expect("a valid grid"),
        mask: None,
    };
    let job = SubapsJob {
        map: &map,
        geometry: &geometry,
        config: SimConfig::paper(SUBAP_PX),
        precision: Precision::default(),
        centroider: Default::default(),
    };
    let origins: Vec<(usize, usize)> = (0..side / SUBAP_PX)
        .flat_map(|r| (0..side / SUBAP_PX).map(move |c| (c * SUBAP_PX, r * SUBAP_PX)))
        .collect();
    let start = Instant::now();
    let floors = detnoise::subaps::crlb::floor_map(&map, &origins, &job.config);
    println!(
        "Cramer-Rao floor map: {} windows of {SUBAP_PX}x{SUBAP_PX} px in {:.2} s",
        floors.len(),
        start.elapsed().as_secs_f64()
    );
    let (start, cpu0) = (Instant::now(), cpu_seconds());
    let (_, records) = solve_all(&job, &Silent).expect("the bench job runs");
    let seconds = start.elapsed().as_secs_f64();
    let cpu = cpu_seconds() - cpu0;
    let threads = rayon::current_num_threads();
    let n = records.len();
    println!(
        "subaps {side}x{side} px, {n} sub-apertures of {SUBAP_PX}x{SUBAP_PX} px, S = 50, cog, \
         {threads} threads",
    );
    println!(
        "wall {seconds:.1} s, {:.2} sub-apertures/s; at 16,384 sub-apertures (2048x2048): \
         {:.1} min",
        n as f64 / seconds,
        16_384.0 / (n as f64 / seconds) / 60.0
    );
    // Alone on its cores the job would take its CPU time over the threads.
    let alone = cpu / threads as f64;
    println!(
        "cpu {cpu:.1} s ({alone:.1} s over {threads} threads); at 16,384 sub-apertures: {:.1} min",
        alone * 16_384.0 / n as f64 / 60.0
    );
    for status in Status::ALL {
        let of: Vec<_> = records.iter().filter(|r| r.status == status).collect();
        if of.is_empty() {
            continue;
        }
        let iters = of.iter().map(|r| r.iters as f64).sum::<f64>() / of.len() as f64;
        println!(
            "  {:<18} {:>6} sub-apertures, mean final iterations {iters:.0}",
            status.label(),
            of.len()
        );
    }
}
