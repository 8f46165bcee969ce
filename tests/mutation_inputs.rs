//! Mutation test of the newer inputs (issue 30): structure-aware mutants (fixed seed) of
//! sub-aperture part files, RTS tables, masks of valid sub-apertures and read-noise maps go
//! through the library entry points that load them. Every outcome must be Ok with what the
//! mutant allows (`mutants::expect::Expect`: the seed's result, or any result, or none
//! where the mutant changes the meaning), or an error naming the file: no panic (caught and
//! listed), no hang (a watchdog aborts naming the mutant), no slow load (over
//! [`SLOW`]), no allocation beyond what the file can hold. Each mutator's module says which
//! outcomes it allows.
//!
//! Failing mutants are written to `<target tmp>/mutation-inputs-failures/` to be replayed
//! with the binary, with `failures.txt` listing them; the assertion lists them by class,
//! three examples each.

mod mutants;

use std::collections::BTreeMap;
use std::path::Path;
use std::sync::Arc;
use std::time::{Duration, Instant};

use mutants::expect::{Case, Expect};
use mutants::run::{allowed_bytes, Watchdog};
use mutants::{images, part, rts, Mutant, Rng};

/// Mutants per part-file seed (two seeds).
const PART_PER_SEED: usize = 300;
/// Mutants of the RTS table.
const RTS_MUTANTS: usize = 1000;
/// Image mutants per mask seed (three formats).
const MASK_PER_SEED: usize = 120;
/// Image mutants per map seed (three formats).
const MAP_PER_SEED: usize = 200;
/// Wall-clock budget of one mutant before the watchdog aborts (the table of many rows
/// loaded in quadratic time takes seconds).
const BUDGET: Duration = Duration::from_secs(60);
/// Longest a mutant may take through its entry points (the real work is milliseconds; a
/// resume recomputes at most 16 small sub-apertures).
const SLOW: Duration = Duration::from_secs(3);

/// Mutants run, failures and times.
struct Tally {
    failures_dir: std::path::PathBuf,
    total: usize,
    failures: Vec<(String, String)>,
    times: Vec<String>,
    slowest: (Duration, String),
    watchdog: Watchdog,
}

impl Tally {
    /// Run `judge` on `case` written to `path`, keeping its failures.
    fn run(
        &mut self,
        label: String,
        case: &Case,
        path: &Path,
        judge: impl FnOnce() -> Vec<String>,
    ) {
        std::fs::write(path, &case.bytes).unwrap();
        self.watchdog.begin(&label);
        mutants::alloc::reset_largest();
        let t = Instant::now();
        let mut bad = judge();
        let secs = t.elapsed();
        self.watchdog.end();
        let largest = mutants::alloc::largest();
        if largest > allowed_bytes(case.bytes.len()) {
            bad.push(format!(
                "allocated {largest} bytes at once for a {}-byte file",
                case.bytes.len()
            ));
        }
        if secs > SLOW {
            bad.push(format!("slow: {:.1} s", secs.as_secs_f64()));
        }
        self.total += 1;
        if secs > self.slowest.0 {
            self.slowest = (secs, label.clone());
        }
        if !bad.is_empty() {
            std::fs::create_dir_all(&self.failures_dir).unwrap();
            let ext = path
                .extension()
                .map_or(String::new(), |e| e.to_string_lossy().into_owned());
            let name = format!("{}.{ext}", self.failures.len());
            std::fs::write(self.failures_dir.join(&name), &case.bytes).unwrap();
            for why in bad {
                self.failures.push((why, format!("{label} [{name}]")));
            }
        }
    }

    fn timed(&mut self, group: &str, t: Instant, before: usize) {
        self.times.push(format!(
            "{group}: {} in {:.1} s",
            self.total - before,
            t.elapsed().as_secs_f64()
        ));
    }
}

/// A failure's class: its text with numbers, paths and quoted values blanked.
fn class(why: &str) -> String {
    let mut out = String::new();
    let mut quoted = false;
    for w in why.split_whitespace() {
        let w = if w.contains('/') && !w.contains("e-/") {
            "<path>"
        } else {
            w
        };
        if w.starts_with('"') || w.starts_with('\'') {
            quoted = !(w.len() > 1 && (w.ends_with('"') || w.ends_with('\'')));
            out.push_str("<v> ");
            continue;
        }
        if quoted {
            quoted = !(w.ends_with('"') || w.ends_with('\''));
            continue;
        }
        // Every number, whatever its digits, as one `#`.
        let mut w: String = w
            .chars()
            .map(|c| if c.is_ascii_digit() { '#' } else { c })
            .collect();
        while w.contains("##") || w.contains("#.#") {
            w = w.replace("##", "#").replace("#.#", "#");
        }
        out.push_str(&w);
        out.push(' ');
    }
    out.chars().take(150).collect()
}

#[test]
fn mutants_of_parts_tables_masks_and_maps_fail_cleanly() {
    let dir = tempfile::tempdir().unwrap();
    let scratch = dir.path().join("scratch");
    std::fs::create_dir(&scratch).unwrap();
    let failures_dir = Path::new(env!("CARGO_TARGET_TMPDIR")).join("mutation-inputs-failures");
    let _ = std::fs::remove_dir_all(&failures_dir);
    let mut tally = Tally {
        failures_dir: failures_dir.clone(),
        total: 0,
        failures: Vec::new(),
        times: Vec::new(),
        slowest: (Duration::ZERO, String::new()),
        watchdog: Watchdog::start(BUDGET),
    };
    let mut rng = Rng::new(0x30_1e5);
    let unmutated =
        |bytes: &[u8]| Case::new(Mutant::new("unmutated", bytes.to_vec()), Expect::Kept);
    let t0 = Instant::now();

    // Part files, through the resume and the merge.
    let (t, before) = (Instant::now(), tally.total);
    let job = part::PartJob::new();
    for seed in part::seeds(&job, &dir.path().join("jobs")) {
        let same = part::PartCase {
            case: unmutated(&seed.bytes),
            merge: Expect::Kept,
        };
        let list = std::iter::once(same)
            .chain(part::forged_geometry(&seed))
            .chain(part::mutants(&seed, &mut rng, PART_PER_SEED));
        for (i, c) in list.enumerate() {
            let label = format!("{} #{i}: {}", seed.name, c.case.label);
            let path = scratch.join("m.part");
            tally.run(label, &c.case, &path, || {
                part::judge(&job, &seed, &c, &scratch)
            });
        }
    }
    tally.timed("part files", t, before);

    // RTS tables, with the camera's map.
    let (t, before) = (Instant::now(), tally.total);
    let seed = std::fs::read_to_string(rts::repo(rts::SEED)).unwrap();
    let map = Arc::new(
        detnoise::calib::Map::read(rts::repo(rts::MAP_FILE), detnoise::calib::Unit::Electrons)
            .unwrap(),
    );
    let pixels = rts::seed_pixels();
    let list = std::iter::once(unmutated(seed.as_bytes())).chain(rts::mutants(
        &seed,
        &mut rng,
        RTS_MUTANTS,
    ));
    for (i, c) in list.enumerate() {
        let path = scratch.join("rts.csv");
        let label = format!("rts #{i}: {}", c.label);
        tally.run(label, &c, &path, || {
            rts::judge(&path, c.expect, &map, &pixels)
                .into_iter()
                .collect()
        });
    }
    tally.timed("RTS tables", t, before);

    // Masks.
    let (t, before) = (Instant::now(), tally.total);
    let seeds_dir = dir.path().join("seeds");
    std::fs::create_dir(&seeds_dir).unwrap();
    for seed in images::mask_seeds(&seeds_dir) {
        let list = std::iter::once(unmutated(&seed.bytes))
            .chain(images::mask_meanings(&seeds_dir, &seed))
            .chain(images::mutants(&seed, &mut rng, MASK_PER_SEED));
        for (i, c) in list.enumerate() {
            let path = scratch.join(format!("mask.{}", seed.ext));
            let label = format!("{} #{i}: {}", seed.name, c.label);
            tally.run(label, &c, &path, || {
                images::judge_mask(&path, c.expect, seed.kind)
                    .into_iter()
                    .collect()
            });
        }
    }
    tally.timed("masks", t, before);

    // Noise maps.
    let (t, before) = (Instant::now(), tally.total);
    for seed in images::map_seeds(&seeds_dir) {
        let data = images::seed_data(&seeds_dir, &seed);
        let list = std::iter::once(unmutated(&seed.bytes))
            .chain(images::map_meanings(&seeds_dir, &seed))
            .chain(images::mutants(&seed, &mut rng, MAP_PER_SEED));
        for (i, c) in list.enumerate() {
            let path = scratch.join(format!("map.{}", seed.ext));
            let label = format!("{} #{i}: {}", seed.name, c.label);
            tally.run(label, &c, &path, || {
                images::judge_map(&path, c.expect, seed.kind, &data)
            });
        }
    }
    tally.timed("maps", t, before);

    eprintln!(
        "{} mutants in {:.1} s ({}); slowest {:.2} s: {}",
        tally.total,
        t0.elapsed().as_secs_f64(),
        tally.times.join(", "),
        tally.slowest.0.as_secs_f64(),
        tally.slowest.1
    );
    // By class, with three examples each; every failure in the directory's `failures.txt`.
    let mut classes: BTreeMap<String, Vec<String>> = BTreeMap::new();
    for (why, label) in &tally.failures {
        classes
            .entry(class(why))
            .or_default()
            .push(format!("{label}: {why}"));
    }
    let listed: Vec<String> = classes
        .iter()
        .map(|(c, all)| {
            let eg: Vec<String> = all
                .iter()
                .take(3)
                .map(|e| format!("    e.g. {}", e.chars().take(400).collect::<String>()))
                .collect();
            format!("{} x {c}\n{}", all.len(), eg.join("\n"))
        })
        .collect();
    if !tally.failures.is_empty() {
        let all: Vec<String> = tally
            .failures
            .iter()
            .map(|(w, l)| format!("{l}: {w}"))
            .collect();
        std::fs::write(failures_dir.join("failures.txt"), all.join("\n")).unwrap();
    }
    assert!(
        tally.failures.is_empty(),
        "{} failures of {} mutants (files and failures.txt in {}), {} classes:\n{}",
        tally.failures.len(),
        tally.total,
        failures_dir.display(),
        classes.len(),
        listed.join("\n")
    );
    assert!(tally.total >= 2500, "only {} mutants", tally.total);
}
