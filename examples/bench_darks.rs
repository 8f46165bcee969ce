//! Benchmark of `detnoise darks`: a 512 x 512 x 2000 uint16 FITS cube (1 GiB) in the page
//! cache, calibrated as the command does (statistics, maps, outputs), with the default BLAKE3
//! checksums of the inputs, with SHA-256 ones, and without. Prints GB/s of file read (1 GB =
//! 1e9 bytes), CPU seconds and the peak resident memory (VmHWM) of each run, and the floors of
//! this machine: one thread reading the file (`cat`), one thread reading and hashing it, and
//! each hash of data already in cache on one core (the hash of one file runs on one core, so
//! that bounds `darks` with checksums). Every measurement runs in a fresh process of this
//! program, as the command would, so that its peak memory is its own.
//!
//! cargo run --release --example bench_darks [-- FRAMES [ROWS COLS]]
//! DETNOISE_BENCH_CUBE=PATH keeps the cube at PATH (reused when it has the right size);
//! DETNOISE_BENCH_RUNS=N runs each measurement N times (default 3) and reports the fastest.

use std::hint::black_box;
use std::io::Read;
use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::Instant;

use detnoise::calib::darks::{run, DarkOptions, DarksRun};
use detnoise::calib::summary::{checksum_file, Checksum};
use detnoise::progress::Silent;
use sha2::{Digest, Sha256};

/// Peak resident memory of this process (KiB).
fn vm_hwm_kib() -> u64 {
    let s = std::fs::read_to_string("/proc/self/status").unwrap_or_default();
    s.lines()
        .find(|l| l.starts_with("VmHWM:"))
        .and_then(|l| l.split_whitespace().nth(1)?.parse().ok())
        .unwrap_or(0)
}

/// CPU time (user + system) of this process so far, in seconds.
fn cpu_seconds() -> f64 {
    let s = std::fs::read_to_string("/proc/self/stat").unwrap_or_default();
    let after = s.rsplit(')').next().unwrap_or("");
    let f: Vec<f64> = after
        .split_whitespace()
        .filter_map(|x| x.parse().ok())
        .collect();
    // utime and stime are fields 14 and 15 of stat: the 11th and 12th numbers after the
    // command name (the state letter, field 3, is not a number).
    let ticks = f.get(10).copied().unwrap_or(0.0) + f.get(11).copied().unwrap_or(0.0);
    ticks / 100.0
}

/// One measurement: wall seconds, CPU seconds, peak resident memory of the process (MiB),
/// and the seconds of the reading phase (statistics and checksums) of a darks run.
#[derive(Clone, Copy, Debug)]
struct Run {
    wall: f64,
    cpu: f64,
    hwm_mib: f64,
    reading: Option<f64>,
}

/// `algorithm` of `bytes` bytes of data in L2 cache (a 1 MiB buffer, hashed repeatedly).
fn hash_in_cache(bytes: u64, algorithm: Checksum) {
    let buf = vec![0x5au8; 1 << 20];
    let pieces = bytes.div_ceil(buf.len() as u64);
    match algorithm {
        Checksum::Sha256 => {
            let mut h = Sha256::new();
            (0..pieces).for_each(|_| h.update(black_box(&buf)));
            black_box(h.finalize());
        }
        Checksum::Blake3 => {
            let mut h = blake3::Hasher::new();
            (0..pieces).for_each(|_| {
                h.update(black_box(&buf));
            });
            black_box(h.finalize());
        }
    }
}

/// The algorithm a measurement's name ends with (`-sha256`; else BLAKE3).
fn algorithm_of(what: &str) -> Checksum {
    if what.ends_with("-sha256") {
        Checksum::Sha256
    } else {
        Checksum::Blake3
    }
}

/// Run measurement `what` on `cube` in this process and print it as one line (child side).
fn measure(what: &str, cube: &Path, out: &Path) {
    let bytes = std::fs::metadata(cube).expect("cube").len();
    let (t, c) = (Instant::now(), cpu_seconds());
    let reading = match what {
        "cat" => {
            let mut buf = vec![0u8; 1 << 20];
            let mut f = std::fs::File::open(cube).expect("open cube");
            while f.read(&mut buf).expect("read cube") > 0 {}
            None
        }
        "hash" | "hash-sha256" => {
            checksum_file(cube, algorithm_of(what)).expect("hash");
            None
        }
        "cached" | "cached-sha256" => {
            hash_in_cache(bytes, algorithm_of(what));
            None
        }
        "darks" | "darks-sha256" | "darks-no-checksums" => {
            let job = DarksRun {
                stack: vec![cube.to_path_buf()],
                out: out.to_path_buf(),
                force: false,
                options: DarkOptions::default(),
                gain_e_per_adu: Some(0.25),
                checksum: (what != "darks-no-checksums").then(|| algorithm_of(what)),
                accept_illuminated: false,
                expected_dark: None,
            };
            Some(run(&job, &Silent).expect("darks").read_seconds)
        }
        other => panic!("unknown measurement {other}"),
    };
    println!(
        "{} {} {} {}",
        t.elapsed().as_secs_f64(),
        cpu_seconds() - c,
        vm_hwm_kib() as f64 / 1024.0,
        reading.unwrap_or(f64::NAN)
    );
}

/// The fastest of `runs` child processes measuring `what`.
fn best(runs: usize, what: &str, cube: &Path, out: &Path) -> Run {
    let exe = std::env::current_exe().expect("own path");
    (0..runs)
        .map(|_| {
            let _ = std::fs::remove_dir_all(out);
            let o = Command::new(&exe)
                .arg(format!("--measure={what}"))
                .arg(cube)
                .arg(out)
                .output()
                .expect("run a measurement");
            assert!(o.status.success(), "{what}: {o:?}");
            let v: Vec<f64> = String::from_utf8_lossy(&o.stdout)
                .split_whitespace()
                .map(|x| x.parse().expect("a number"))
                .collect();
            Run {
                wall: v[0],
                cpu: v[1],
                hwm_mib: v[2],
                reading: Some(v[3]).filter(|r| r.is_finite()),
            }
        })
        .min_by(|a, b| a.wall.total_cmp(&b.wall))
        .expect("at least one run")
}

fn line(what: &str, bytes: u64, r: Run) {
    let gbs = |s: f64| bytes as f64 / 1e9 / s;
    let reading = r.reading.map_or(String::new(), |s| {
        format!(" (reading: {s:.3} s = {:.2} GB/s)", gbs(s))
    });
    println!(
        "  {what:<36} {:>5.2} GB/s  {:.3} s wall, {:.3} CPU s, peak {:.1} MiB{reading}",
        gbs(r.wall),
        r.wall,
        r.cpu,
        r.hwm_mib
    );
}

/// Write the benchmark cube at `path` (cheap deterministic noise around 100 adu: the bench
/// measures reading, not simulation), unless a file of the expected size is there already.
fn ensure_cube(path: &Path, shape: (usize, usize), frames: usize) {
    let npix = shape.0 * shape.1;
    let data = (npix * frames * 2) as u64;
    if std::fs::metadata(path).is_ok_and(|m| m.len() >= data && m.len() < data + 2 * 2880 * 4) {
        return;
    }
    let mut state = 0x9e37_79b9_7f4a_7c15u64;
    let mut next = || {
        (0..npix)
            .map(|_| {
                state ^= state << 13;
                state ^= state >> 7;
                state ^= state << 17;
                100.0 + (state & 0xf) as f64 + ((state >> 8) & 0x7) as f64
            })
            .collect::<Vec<f64>>()
    };
    let t = Instant::now();
    detnoise::io::fits::write_cube(path, shape, frames, true, &mut next, &[]).expect("write cube");
    eprintln!(
        "wrote {} in {:.1} s",
        path.display(),
        t.elapsed().as_secs_f64()
    );
}

fn main() {
    let all: Vec<String> = std::env::args().skip(1).collect();
    if let Some(what) = all.first().and_then(|a| a.strip_prefix("--measure=")) {
        return measure(what, Path::new(&all[1]), Path::new(&all[2]));
    }
    let args: Vec<usize> = all.iter().filter_map(|a| a.parse().ok()).collect();
    let frames = args.first().copied().unwrap_or(2000);
    let shape = (
        args.get(1).copied().unwrap_or(512),
        args.get(2).copied().unwrap_or(512),
    );
    let runs: usize = std::env::var("DETNOISE_BENCH_RUNS")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(3)
        .max(1);
    let dir = tempfile::tempdir().expect("temp dir");
    let cube = std::env::var_os("DETNOISE_BENCH_CUBE")
        .map(PathBuf::from)
        .unwrap_or_else(|| dir.path().join("cube.fits"));
    ensure_cube(&cube, shape, frames);
    let bytes = std::fs::metadata(&cube).expect("cube").len();
    // Warm the page cache.
    best(1, "cat", &cube, &dir.path().join("out"));
    let m = |what: &str| best(runs, what, &cube, &dir.path().join("out"));
    let (cat, hash, cached) = (m("cat"), m("hash"), m("cached"));
    let (hash_sha, cached_sha) = (m("hash-sha256"), m("cached-sha256"));
    let (with, with_sha, without) = (m("darks"), m("darks-sha256"), m("darks-no-checksums"));

    println!(
        "darks bench: {} ({:.3} GB), {frames} frames of {}x{} uint16, best of {runs} runs",
        cube.display(),
        bytes as f64 / 1e9,
        shape.0,
        shape.1
    );
    line("read alone (cat, one thread)", bytes, cat);
    line("read and BLAKE3 (one thread)", bytes, hash);
    line("BLAKE3 of data in cache (one core)", bytes, cached);
    line("read and SHA-256 (one thread)", bytes, hash_sha);
    line("SHA-256 of data in cache (one core)", bytes, cached_sha);
    line("darks with checksums (BLAKE3, default)", bytes, with);
    line("darks with SHA-256 checksums", bytes, with_sha);
    line("darks without checksums", bytes, without);
    let load = std::fs::read_to_string("/proc/loadavg").unwrap_or_default();
    println!(
        "  cores: {}, load average: {}",
        std::thread::available_parallelism().map_or(0, |n| n.get()),
        load.split_whitespace()
            .take(3)
            .collect::<Vec<_>>()
            .join(" ")
    );
    println!(
        "  one frame: {:.2} MiB stored, {:.2} MiB as f64",
        (shape.0 * shape.1 * 2) as f64 / 1048576.0,
        (shape.0 * shape.1 * 8) as f64 / 1048576.0
    );
}
