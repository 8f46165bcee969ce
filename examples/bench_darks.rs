//! Benchmark of `darks`: writes a 512 x 512 x 2000 uint16 FITS cube (1 GiB) to a temporary
//! directory, reads it once to warm the page cache, then runs the dark calibration and its
//! outputs, printing throughput (MB/s of stored samples) and peak resident memory (VmHWM).
//!
//! cargo run --release --example bench_darks [-- FRAMES [ROWS COLS]]
//! For an external view of memory: /usr/bin/time -v target/release/examples/bench_darks

use std::io::Read;
use std::time::Instant;

use detnoise::calib::darks::{dark_maps, DarkOptions};
use detnoise::io::FrameStack;

fn vm_hwm_kib() -> Option<u64> {
    let s = std::fs::read_to_string("/proc/self/status").ok()?;
    s.lines()
        .find(|l| l.starts_with("VmHWM:"))?
        .split_whitespace()
        .nth(1)?
        .parse()
        .ok()
}

/// CPU time (user + system) of this process so far, in seconds.
fn cpu_seconds() -> f64 {
    let s = std::fs::read_to_string("/proc/self/stat").unwrap_or_default();
    let after = s.rsplit(')').next().unwrap_or("");
    let f: Vec<f64> = after
        .split_whitespace()
        .filter_map(|x| x.parse().ok())
        .collect();
    // Fields 14 and 15 of stat (utime, stime); the state letter (field 3) is not numeric, so they are the 11th and 12th numbers after the command name.
    (f.get(10).copied().unwrap_or(0.0) + f.get(11).copied().unwrap_or(0.0)) / 100.0
}

fn main() {
    let args: Vec<usize> = std::env::args()
        .skip(1)
        .filter_map(|a| a.parse().ok())
        .collect();
    let frames = args.first().copied().unwrap_or(2000);
    let (rows, cols) = (
        args.get(1).copied().unwrap_or(512),
        args.get(2).copied().unwrap_or(512),
    );
    let dir = tempfile::tempdir().expect("temp dir");
    let cube = dir.path().join("cube.fits");
    let npix = rows * cols;
    // Cheap deterministic noise (xorshift): the bench measures reading, not simulation.
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
    detnoise::io::fits::write_cube(&cube, (rows, cols), frames, true, &mut next, &[])
        .expect("write cube");
    let bytes = std::fs::metadata(&cube).unwrap().len();
    eprintln!(
        "wrote {} ({:.1} MB) in {:.1} s",
        cube.display(),
        bytes as f64 / 1e6,
        t.elapsed().as_secs_f64()
    );
    // Warm the page cache.
    let mut f = std::fs::File::open(&cube).unwrap();
    let mut buf = vec![0u8; 1 << 22];
    while f.read(&mut buf).unwrap() > 0 {}
    drop(buf);
    let hwm_before = vm_hwm_kib().unwrap_or(0);

    let stack = FrameStack::open(std::slice::from_ref(&cube)).unwrap();
    let (t, c) = (Instant::now(), cpu_seconds());
    let mut frame = vec![0.0; npix];
    let mut reader = stack.reader();
    while reader.next_frame(&mut frame).unwrap().is_some() {}
    let t_read = t.elapsed().as_secs_f64();
    let c_read = cpu_seconds() - c;
    drop(frame);

    let (t, c) = (Instant::now(), cpu_seconds());
    let opts = DarkOptions::default();
    let maps = dark_maps(&stack, &opts).unwrap();
    let t_maps = t.elapsed().as_secs_f64();
    let c_maps = cpu_seconds() - c;
    let (_, inputs) = detnoise::calib::summary::with_inputs_hashed(&stack, || Ok(())).unwrap();
    let t_hash = t.elapsed().as_secs_f64() - t_maps;
    detnoise::calib::darks::write_outputs(
        &dir.path().join("out"),
        &stack,
        &maps,
        &opts,
        None,
        inputs,
        "summary.json",
    )
    .unwrap();
    let t_all = t.elapsed().as_secs_f64();
    let mb = stack.stored_bytes() as f64 / 1e6;
    println!("darks bench: {frames} frames of {rows}x{cols} uint16, {mb:.1} MB of samples");
    println!("  reading alone (one thread, decode to f64): {t_read:.2} s = {:.0} MB/s ({c_read:.2} CPU s)", mb / t_read);
    println!(
        "  statistics: {t_maps:.2} s = {:.0} MB/s ({c_maps:.2} CPU s, {:.0} MB per CPU-second)",
        mb / t_maps,
        mb / c_maps
    );
    let load = std::fs::read_to_string("/proc/loadavg").unwrap_or_default();
    println!(
        "  load average (2 cores): {}",
        load.split_whitespace()
            .take(3)
            .collect::<Vec<_>>()
            .join(" ")
    );
    println!("  SHA-256 of inputs (run alone here; the CLI overlaps it with the statistics): {t_hash:.2} s = {:.0} MB/s", mb / t_hash);
    println!(
        "  statistics + hash + outputs: {t_all:.2} s = {:.0} MB/s",
        mb / t_all
    );
    println!("  peak resident memory (VmHWM): {:.1} MiB (before the run: {:.1} MiB); one f64 frame = {:.1} MiB",
        vm_hwm_kib().unwrap_or(0) as f64 / 1024.0, hwm_before as f64 / 1024.0, (npix * 8) as f64 / 1048576.0);
}
