//! `campaign` speed: two generated campaigns of 9 uint16 FITS dark stacks (512 x 512 x 200
//! frames each, ~0.94 GB) in a temporary folder, run by `campaign` with BLAKE3 checksums:
//!
//! - sCMOS-like: 9 exposure times, no EM gain;
//! - EMCCD: 3 EM gains x 3 exposure times with the EM-gain histogram fits on, which read the
//!   darks a second time (the fits need the offsets the decomposition gives: see
//!   `campaign::measure`);
//!
//! then `darks` on the EMCCD stacks one by one for comparison, and the per-pixel decomposition
//! alone on 9 synthetic conditions of 2048 x 2048 pixels (no files). Prints GB/s of stored
//! samples over the reading (checksums included) and over the whole run (decomposition and
//! output files included), the seconds of each part, and the peak resident memory of each
//! part (VmHWM, reset before it) against the size of one frame as f64.
//!
//! `cargo bench --bench campaign`, or `-- FRAMES` for another frame count per stack, or
//! `-- decomposition` for the decomposition alone.
//! Target (issue 31): >= 2 GB/s with checksums.

use std::path::{Path, PathBuf};
use std::time::Instant;

use detnoise::calib::darks::{run as run_darks, DarkOptions, DarksRun};
use detnoise::campaign::fit::{decompose, DecomposeOptions, TemperatureTerm};
use detnoise::campaign::{
    check_campaign, measure_campaign, run, CampaignInput, CampaignRun, Condition, ConditionStats,
    MeasureOptions, StackKind,
};
use detnoise::io::fits::write_cube;
use detnoise::io::Checksum;
use detnoise::progress::Silent;

mod support;
use support::{cpu_seconds, peak_mb, reset_peak};

/// Frame shape (rows, cols) of the stacks.
const SHAPE: (usize, usize) = (512, 512);

/// Frame side of the decomposition-only figure.
const DECOMPOSE_SIDE: usize = 2048;

/// A 64-bit linear congruential generator: fast enough that writing the stacks stays short.
struct Lcg(u64);

impl Lcg {
    fn next(&mut self) -> u64 {
        self.0 = self
            .0
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        self.0
    }

    /// Uniform in (0, 1).
    fn unit(&mut self) -> f64 {
        ((self.next() >> 11) as f64 + 0.5) / (1u64 << 53) as f64
    }
}

/// Write one stack of `frames` dark frames: offset 1000 adu, a triangular read noise of
/// about 5 adu rms, the dark signal `dark_adu` and, behind an EM register of gain `em`
/// (adu per event), 0.05 events per pixel and frame.
fn write_stack(path: &Path, frames: usize, dark_adu: f64, em: Option<f64>, rng: &mut Lcg) {
    let mut next = || -> Vec<f64> {
        (0..SHAPE.0 * SHAPE.1)
            .map(|_| {
                let r = rng.next();
                let noise = ((r >> 59) + ((r >> 54) & 31)) as f64 - 31.0;
                let events = match em {
                    Some(g) if rng.unit() < 0.05 => -g * rng.unit().ln(),
                    _ => 0.0,
                };
                (1000.0 + dark_adu + noise + events).min(65535.0)
            })
            .collect()
    };
    write_cube(path, SHAPE, frames, true, &mut next, &[]).expect("write a stack");
}

/// Write a campaign of 9 stacks (`gains` x `times`, or `times` alone) and its manifest into
/// `dir`; returns the manifest and the stacks.
fn write_campaign(dir: &Path, frames: usize, gains: &[Option<f64>]) -> (PathBuf, Vec<PathBuf>) {
    let mut manifest = String::from("file,kind,exposure_s,em_gain,temperature_c,light_level\n");
    let mut files = Vec::new();
    let mut rng = Lcg(0x9e37_79b9_7f4a_7c15);
    let times: &[f64] = if gains.len() == 1 {
        &[0.01, 0.02, 0.05, 0.1, 0.2, 0.5, 1.0, 2.0, 5.0]
    } else {
        &[0.01, 0.1, 1.0]
    };
    for &gain in gains {
        for &t in times {
            let name = format!("dark_g{}_t{t}.fits", gain.unwrap_or(1.0));
            let path = dir.join(&name);
            write_stack(&path, frames, 4.0 * t, gain, &mut rng);
            let g = gain.map_or(String::new(), |g| g.to_string());
            manifest += &format!("{name},dark,{t},{g},,\n");
            files.push(path);
        }
    }
    let m = dir.join("campaign.csv");
    std::fs::write(&m, manifest).expect("write the manifest");
    (m, files)
}

/// Peak memory as text: MB, and in frames of `pixels` f64.
fn peak_text(pixels: usize) -> String {
    let mb = peak_mb();
    format!(
        "{mb:.0} MB peak = {:.0} frames of f64",
        mb / (pixels as f64 * 8.0 / 1e6)
    )
}

/// Run the campaign of `manifest` (EM fits on when `em_fit`) once to warm the page cache,
/// then timed; prints its figures.
fn bench_campaign(label: &str, dir: &Path, manifest: &Path, em_fit: bool) {
    let job = |out: &str| CampaignRun {
        input: CampaignInput::Manifest(manifest.to_path_buf()),
        out: dir.join(out),
        force: false,
        measure: MeasureOptions {
            gain_e_per_adu: 1.0,
            checksum: Some(Checksum::Blake3),
            em_fit,
            clip: detnoise::calib::darks::Clip::None,
            common_mode: false,
        },
        temperature: TemperatureTerm::Off,
        thresholds: Default::default(),
    };
    run(&job(&format!("{label}-warm")), &Silent).expect("campaign runs");
    reset_peak();
    let (t, cpu) = (Instant::now(), cpu_seconds());
    let r = run(&job(label), &Silent).expect("campaign runs");
    let wall = t.elapsed().as_secs_f64();
    let cpu = cpu_seconds() - cpu;
    let gb = r.stored_bytes as f64 / 1e9;
    println!(
        "campaign {label}: 9 stacks of {}x{}x{} uint16 ({gb:.2} GB), blake3: {:.2} GB/s reading \
         ({:.2} s), {:.2} GB/s wall ({wall:.2} s: decomposition {:.2} s, files {:.2} s{}); \
         {cpu:.2} CPU s; {}",
        SHAPE.0,
        SHAPE.1,
        r.stacks[0].stats.frames,
        gb / r.read_seconds,
        r.read_seconds,
        gb / wall,
        r.decompose_seconds,
        r.write_seconds,
        if r.em_fit_bytes > 0 {
            format!(
                ", EM fits' second pass {:.2} GB at {:.2} GB/s",
                r.em_fit_bytes as f64 / 1e9,
                r.em_fit_bytes as f64 / 1e9 / r.em_fit_seconds
            )
        } else {
            String::new()
        },
        peak_text(SHAPE.0 * SHAPE.1)
    );
    // The reading alone again, for its CPU time: on 2 idle cores its wall time is at least
    // half of it (what the GB/s above would be with nothing else running).
    let plan = check_campaign(job("").input.read().expect("the manifest reads")).expect("a plan");
    let (t, cpu) = (Instant::now(), cpu_seconds());
    measure_campaign(&plan, &job("").measure, &Silent).expect("the stacks read");
    let (wall, cpu) = (t.elapsed().as_secs_f64(), cpu_seconds() - cpu);
    println!(
        "campaign {label}: reading alone {:.2} GB/s ({wall:.2} s), {cpu:.2} CPU s: {:.2} GB/s \
         if 2 idle cores did that work",
        gb / wall,
        gb / (cpu / 2.0)
    );
}

/// Run `darks` on each of `files` in turn; prints the figures.
fn bench_darks(dir: &Path, files: &[PathBuf]) {
    let t = Instant::now();
    let (mut read, mut bytes) = (0.0, 0u64);
    for (k, f) in files.iter().enumerate() {
        let d = run_darks(
            &DarksRun {
                stack: vec![f.clone()],
                out: dir.join(format!("darks{k}")),
                force: false,
                options: DarkOptions::default(),
                gain_e_per_adu: Some(1.0),
                checksum: Some(Checksum::Blake3),
                accept_illuminated: true,
                expected_dark: None,
            },
            &Silent,
        )
        .expect("darks runs");
        read += d.read_seconds;
        bytes += d.stored_bytes;
    }
    let wall = t.elapsed().as_secs_f64();
    let gb = bytes as f64 / 1e9;
    println!(
        "darks: the EMCCD stacks one by one, blake3: {:.2} GB/s reading, {:.2} GB/s wall ({wall:.2} s)",
        gb / read,
        gb / wall
    );
}

/// Synthetic per-pixel moments of `side` x `side` pixels at 3 EM gains x 3 exposure times
/// (`em`) or 9 exposure times: offset, CIC and dark current varying from pixel to pixel.
fn synthetic_stats(side: usize, em: bool) -> Vec<ConditionStats> {
    let n = side * side;
    let mut rng = Lcg(7);
    let offset: Vec<f64> = (0..n).map(|_| 1000.0 + 20.0 * rng.unit()).collect();
    let dark: Vec<f64> = (0..n).map(|_| 2.0 * rng.unit()).collect();
    let conds: Vec<(Option<f64>, f64)> = if em {
        [10.0, 100.0, 300.0]
            .iter()
            .flat_map(|&g| [0.01, 0.1, 1.0].map(|t| (Some(g), t)))
            .collect()
    } else {
        [0.01, 0.02, 0.05, 0.1, 0.2, 0.5, 1.0, 2.0, 5.0]
            .map(|t| (None, t))
            .to_vec()
    };
    conds
        .into_iter()
        .map(|(g, t)| {
            let gain = g.unwrap_or(1.0);
            let signal: Vec<f64> = dark.iter().map(|d| gain * (0.02 + t * d)).collect();
            ConditionStats {
                file: PathBuf::from(format!("g{gain}_t{t}.fits")),
                condition: Condition {
                    exposure_s: t,
                    em_gain: g,
                    temperature_c: None,
                    kind: StackKind::Dark,
                    light_level: None,
                },
                frames: 200,
                rows: side,
                cols: side,
                mean_adu: (offset.iter().zip(&signal))
                    .map(|(f, s)| f + s + 0.3 * (rng.unit() - 0.5))
                    .collect(),
                var_adu2: signal
                    .iter()
                    .map(|s| 25.0 + 2.0 * gain * s * (0.9 + 0.2 * rng.unit()))
                    .collect(),
                temporal: Default::default(),
            }
        })
        .collect()
}

/// Time the decomposition alone on synthetic moments; prints the figures.
fn bench_decomposition(side: usize, em: bool) {
    let stats = synthetic_stats(side, em);
    reset_peak();
    let t = Instant::now();
    let mut opts = DecomposeOptions::new(1.0);
    opts.fit_cic = em;
    let d = decompose(&stats, &opts).expect("the decomposition runs");
    let secs = t.elapsed().as_secs_f64();
    let fitted = d
        .dark_current_e_per_s
        .iter()
        .filter(|v| v.is_finite())
        .count();
    println!(
        "decomposition {}: {side}x{side} pixels x 9 conditions: {secs:.2} s ({fitted} pixels \
         fitted); {} (the 9 conditions' moments alone: 18)",
        if em { "EMCCD" } else { "sCMOS" },
        peak_text(side * side)
    );
}

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    if args.iter().any(|a| a == "decomposition") {
        bench_decomposition(DECOMPOSE_SIDE, false);
        bench_decomposition(DECOMPOSE_SIDE, true);
        return;
    }
    let frames: usize = args.iter().find_map(|a| a.parse().ok()).unwrap_or(200);
    let dir = tempfile::tempdir().expect("a temporary directory");
    let scmos = dir.path().join("scmos");
    let emccd = dir.path().join("emccd");
    std::fs::create_dir_all(&scmos).expect("a folder");
    std::fs::create_dir_all(&emccd).expect("a folder");
    let (manifest, _) = write_campaign(&scmos, frames, &[None]);
    bench_campaign("sCMOS", &scmos, &manifest, false);
    std::fs::remove_dir_all(&scmos).expect("remove the sCMOS stacks");
    let gains = [Some(10.0), Some(100.0), Some(300.0)];
    let (manifest, files) = write_campaign(&emccd, frames, &gains);
    bench_campaign("EMCCD", &emccd, &manifest, true);
    bench_darks(&emccd, &files);
    drop(dir);
    bench_decomposition(DECOMPOSE_SIDE, false);
    bench_decomposition(DECOMPOSE_SIDE, true);
}
