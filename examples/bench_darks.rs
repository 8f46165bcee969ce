//! Benchmark of `detnoise darks`: a 512 x 512 x 2000 uint16 FITS cube (1 GiB) in the page
//! cache, calibrated as the command does (statistics, maps, outputs), with and without the
//! SHA-256 checksums of the inputs. Prints GB/s of file read (1 GB = 1e9 bytes), CPU seconds
//! and the peak resident memory (VmHWM) of each run, and the two floors of this machine: one
//! thread reading the file (`cat`) and one thread hashing it (SHA-256 of one file cannot be
//! split across cores, so it bounds `darks` with checksums).
//!
//! cargo run --release --example bench_darks [-- FRAMES [ROWS COLS]]
//! DETNOISE_BENCH_CUBE=PATH keeps the cube at PATH (reused when it has the right size);
//! DETNOISE_BENCH_RUNS=N runs each measurement N times (default 3) and reports the fastest.

use std::io::Read;
use std::path::{Path, PathBuf};
use std::time::Instant;

use detnoise::calib::darks::{run, DarkOptions, DarksRun};
use detnoise::calib::summary::sha256_file;
use detnoise::progress::Silent;

/// Peak resident memory of this process since the last reset (KiB).
fn vm_hwm_kib() -> u64 {
    let s = std::fs::read_to_string("/proc/self/status").unwrap_or_default();
    s.lines()
        .find(|l| l.starts_with("VmHWM:"))
        .and_then(|l| l.split_whitespace().nth(1)?.parse().ok())
        .unwrap_or(0)
}

/// Reset VmHWM to the current resident size (Linux: "5" to clear_refs), so that each run
/// reports its own peak.
fn reset_hwm() {
    let _ = std::fs::write("/proc/self/clear_refs", "5");
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

/// One measurement: wall seconds, CPU seconds, peak resident memory (MiB).
#[derive(Clone, Copy)]
struct Run {
    wall: f64,
    cpu: f64,
    hwm_mib: f64,
}

/// The fastest of `runs` runs of `f`.
fn best(runs: usize, mut f: impl FnMut()) -> Run {
    (0..runs)
        .map(|_| {
            reset_hwm();
            let (t, c) = (Instant::now(), cpu_seconds());
            f();
            Run {
                wall: t.elapsed().as_secs_f64(),
                cpu: cpu_seconds() - c,
                hwm_mib: vm_hwm_kib() as f64 / 1024.0,
            }
        })
        .min_by(|a, b| a.wall.total_cmp(&b.wall))
        .expect("at least one run")
}

fn line(what: &str, bytes: u64, r: Run) {
    println!(
        "  {what:<34} {:>5.2} GB/s  {:.3} s wall, {:.3} CPU s, peak {:.1} MiB",
        bytes as f64 / 1e9 / r.wall,
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
    let args: Vec<usize> = std::env::args()
        .skip(1)
        .filter_map(|a| a.parse().ok())
        .collect();
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

    let mut buf = vec![0u8; 1 << 20];
    let cat = best(runs, || {
        let mut f = std::fs::File::open(&cube).expect("open cube");
        while f.read(&mut buf).expect("read cube") > 0 {}
    });
    drop(buf);
    let hash = best(runs, || {
        sha256_file(&cube).expect("hash");
    });
    let darks = |checksums: bool| {
        let job = DarksRun {
            stack: vec![cube.clone()],
            out: dir.path().join("out"),
            force: false,
            options: DarkOptions::default(),
            gain_e_per_adu: Some(0.25),
            checksums,
            accept_illuminated: false,
        };
        move || {
            run(&job, &Silent).expect("darks");
        }
    };
    let with = best(runs, darks(true));
    let without = best(runs, darks(false));

    println!(
        "darks bench: {} ({:.3} GB), {frames} frames of {}x{} uint16, best of {runs} runs",
        cube.display(),
        bytes as f64 / 1e9,
        shape.0,
        shape.1
    );
    line("read alone (cat, one thread)", bytes, cat);
    line("SHA-256 alone (one thread)", bytes, hash);
    line("darks with checksums", bytes, with);
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
