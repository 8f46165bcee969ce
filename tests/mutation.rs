//! Mutation test of the readers (issue 9): a few thousand structure-aware mutants of small
//! FITS, TIFF and EXR stacks and maps (fixed seed) go through the library entry points of
//! `darks`, `emgain` and `fit-pdf`. Every outcome must be Ok or an error that names the
//! file: no panic (caught and listed), no hang (a watchdog aborts naming the mutant after
//! the per-file budget), no allocation beyond what the file can hold (a guarding allocator
//! records the largest one, and aborts naming the mutant above 1 GiB).
//!
//! Failing mutants are written to `<target tmp>/mutation-failures/` to be replayed with
//! the binary. `DETNOISE_MUTANTS=N` changes the number of mutants per seed.

mod mutants;

use std::time::{Duration, Instant};

use mutants::fixtures::{seeds, Kind, Role};
use mutants::run::{judge, Watchdog};
use mutants::{exr, fits, tiff, Mutant, Rng};

/// Mutants per seed file (23 seeds: about 3,200 in all).
const PER_SEED: usize = 140;
/// Wall-clock budget of one mutant through all its entry points (the real work is
/// milliseconds; the EM-gain fit of the EMCCD seed about 0.1 s).
const BUDGET: Duration = Duration::from_secs(20);

#[test]
fn mutants_of_every_format_fail_cleanly() {
    let per_seed = std::env::var("DETNOISE_MUTANTS")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(PER_SEED);
    let dir = tempfile::tempdir().unwrap();
    let scratch = dir.path().join("scratch");
    std::fs::create_dir(&scratch).unwrap();
    let failures_dir = std::path::Path::new(env!("CARGO_TARGET_TMPDIR")).join("mutation-failures");
    let _ = std::fs::remove_dir_all(&failures_dir);
    let mut rng = Rng::new(0x15_5e9);
    let watchdog = Watchdog::start(BUDGET);
    let (mut total, mut failures, mut slowest) = (0, Vec::new(), Vec::new());
    let mut largest = 0usize;
    let t0 = Instant::now();
    let mut per_seed_secs = Vec::new();
    for seed in seeds(dir.path()) {
        let t_seed = Instant::now();
        let list: Vec<Mutant> = match seed.kind {
            Kind::Fits => fits::mutants(&seed.bytes, &mut rng, per_seed),
            Kind::FitsGz => fits::gz_mutants(&seed.bytes, &mut rng, per_seed),
            Kind::Tiff => tiff::mutants(&seed.bytes, &mut rng, per_seed),
            Kind::Exr => exr::mutants(&seed.bytes, &mut rng, per_seed),
        };
        // The unmutated seed must go through cleanly too (and, except maps of one frame
        // and stacks too small for an EM fit, succeed: checked by the other tests).
        let all = std::iter::once(Mutant::new("unmutated", seed.bytes.clone())).chain(list);
        for (i, m) in all.enumerate() {
            let path = dir.path().join(format!("m{i}.{}", seed.ext));
            std::fs::write(&path, &m.bytes).unwrap();
            let label = format!("{} #{i}: {}", seed.name, m.label);
            watchdog.begin(&label);
            let t = Instant::now();
            let bad = judge(&path, seed.role, &scratch);
            let secs = t.elapsed().as_secs_f64();
            largest = largest.max(mutants::alloc::largest());
            watchdog.end();
            total += 1;
            keep_slowest(
                &mut slowest,
                (secs, label.clone(), m.bytes.clone(), seed.ext),
            );
            if let Some(why) = bad {
                std::fs::create_dir_all(&failures_dir).unwrap();
                let name = format!("{}-{i}.{}", seed.name.replace('/', "_"), seed.ext);
                std::fs::write(failures_dir.join(&name), &m.bytes).unwrap();
                failures.push(format!("{label} [{name}]: {why}"));
            }
        }
        per_seed_secs.push(format!(
            "{} {:.1} s",
            seed.name,
            t_seed.elapsed().as_secs_f64()
        ));
    }
    eprintln!("time per seed: {}", per_seed_secs.join(", "));
    drop(watchdog);
    // The slowest mutants are kept too, to time them with the binary.
    let slow_dir = failures_dir.with_file_name("mutation-slowest");
    let _ = std::fs::remove_dir_all(&slow_dir);
    std::fs::create_dir_all(&slow_dir).unwrap();
    for (k, (_, _, bytes, ext)) in slowest.iter().enumerate() {
        std::fs::write(slow_dir.join(format!("slow{k}.{ext}")), bytes).unwrap();
    }
    let times: Vec<(f64, &str)> = slowest.iter().map(|s| (s.0, s.1.as_str())).collect();
    eprintln!(
        "{total} mutants in {:.1} s ({} were read and processed by some entry point without error); largest allocation {largest} bytes; slowest (in {}): {times:?}",
        t0.elapsed().as_secs_f64(),
        mutants::run::ALL_OK.load(std::sync::atomic::Ordering::Relaxed),
        slow_dir.display()
    );
    assert!(
        failures.is_empty(),
        "{} of {total} mutants failed (files in {}):\n{}",
        failures.len(),
        failures_dir.display(),
        failures.join("\n")
    );
    assert!(
        per_seed != PER_SEED || total >= 3000,
        "only {total} mutants"
    );
}

/// One timed mutant: seconds, label, bytes, extension.
type Timed = (f64, String, Vec<u8>, &'static str);

/// Keep the five slowest mutants, slowest first.
fn keep_slowest(list: &mut Vec<Timed>, t: Timed) {
    if list.len() < 5 || t.0 > list[list.len() - 1].0 {
        list.push(t);
        list.sort_by(|a, b| b.0.total_cmp(&a.0));
        list.truncate(5);
    }
}

#[test]
fn unmutated_seeds_are_read_in_full() {
    // The mutation test is only meaningful if its seeds work: every stack seed opens and
    // gives dark maps (if it has 2 frames), every map seed gives a pdf fit.
    let dir = tempfile::tempdir().unwrap();
    for seed in seeds(dir.path()) {
        let path = dir.path().join(format!("seed.{}", seed.ext));
        std::fs::write(&path, &seed.bytes).unwrap();
        match seed.role {
            Role::Stack => {
                let stack = detnoise::io::FrameStack::open(std::slice::from_ref(&path))
                    .unwrap_or_else(|e| panic!("{}: {e}", seed.name));
                if stack.frames >= 2 {
                    detnoise::calib::darks::dark_maps(&stack, &Default::default())
                        .unwrap_or_else(|e| panic!("{}: {e}", seed.name));
                }
            }
            Role::Map => {
                let map =
                    detnoise::calib::Map::read(&path, detnoise::calib::Unit::Electrons).unwrap();
                let r = detnoise::fit::fit_pdf(&map.data, &Default::default())
                    .unwrap_or_else(|e| panic!("{}: {e}", seed.name));
                assert!(r.failures.is_empty(), "{}: {:?}", seed.name, r.failures);
            }
        }
    }
}
