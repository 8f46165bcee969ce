//! `datasheet` speed (issue 34: a 1 GiB EMVA dataset at the `darks` speed, O(frame) memory):
//! an EMVA 1288 dataset of single-frame uint16 FITS files of 1024 x 1024 px (2 MiB a frame),
//! or 512 x 512 with `-- 512px` (the frame of `darks`' own benchmark cube): 50 photon-transfer
//! points of a bright and a dark pair (200 frames) and spatial stacks of bright and dark
//! frames filling 1 GiB of samples (156 + 156 frames at 1024, 924 + 924 at 512), with its
//! descriptor. It is written once into `target/emva-bench-SIDE` (kept for the next run), read
//! once to warm the page cache, then
//!
//! - the whole `datasheet` run (`emva::run::run`: the frame checks, every frame read once,
//!   the per-pixel maps' second pass over the pairs, the fits, the effective read noise, the
//!   sheet's JSON, CSV, HTML, XML, figures and FITS maps),
//! - its two reading passes alone (`pairs::measure`, the spatial stacks' `read_stack_image`),
//! - `darks` (BLAKE3 checksums) on every file of the dataset as one stack (the same bytes as
//!   the datasheet), and `darks` (BLAKE3, and none) on the spatial stacks' files,
//!
//! each printed as GB/s of stored samples (1 GB = 1e9 bytes), wall and CPU seconds (CPU / 2 is
//! what 2 idle cores would take) and the peak resident memory (VmHWM, reset before each part)
//! in MB and in frames of f64.
//!
//! `cargo bench --bench emva` (`-- RUNS` repeats each measurement and prints every run,
//! `-- sheet` leaves `darks` out, `-- 512px` takes 512 x 512 frames).

use std::path::{Path, PathBuf};
use std::time::Instant;

use detnoise::calib::darks::{run as run_darks, DarkOptions, DarksRun};
use detnoise::emva::dataset::EmvaDataset;
use detnoise::emva::pairs::measure;
use detnoise::emva::run::{run, DatasheetInput, DatasheetRun};
use detnoise::emva::spatial::read_stack_image;
use detnoise::io::fits::write_cube;
use detnoise::io::Checksum;
use detnoise::progress::Silent;

mod support;
use support::{cpu_seconds, load, peak_mb, reset_peak};

/// Frame side (px): 1024, or 512 with `-- 512px` (darks' benchmark frames).
static SIDE: std::sync::OnceLock<usize> = std::sync::OnceLock::new();
/// Photon-transfer points (each a bright and a dark pair).
const POINTS: usize = 50;
/// Stored bytes of the whole dataset: 1 GiB.
const DATASET_BYTES: usize = 1 << 30;

/// Frame shape (rows, cols).
fn shape() -> (usize, usize) {
    let side = *SIDE.get_or_init(|| 1024);
    (side, side)
}

/// Frames of each spatial stack: what the photon-transfer pairs leave of 1 GiB (156 at
/// 1024 x 1024, 924 at 512 x 512).
fn spatial_frames() -> usize {
    let frame = shape().0 * shape().1 * 2;
    (DATASET_BYTES / frame - 4 * POINTS) / 2
}
/// Bits per sample the descriptor declares.
const BITS: u32 = 12;
/// Exposure step of the series (ns).
const STEP_NS: f64 = 1e6;
/// Photons per pixel per exposure step.
const PHOTONS_PER_STEP: f64 = 400.0;
/// The simulated camera: offset (DN), system gain (DN/e-), QE, dark noise (e-).
const OFFSET_DN: f64 = 100.0;
const K_DN_PER_E: f64 = 0.4;
const QE: f64 = 0.6;
const DARK_NOISE_E: f64 = 6.0;

/// SplitMix64: fast enough that writing the frames stays short, and without the short periods
/// of a power-of-two LCG's low bits (which would correlate a pair's two frames).
struct Rng(u64);

impl Rng {
    fn next(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9e37_79b9_7f4a_7c15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        z ^ (z >> 31)
    }

    /// About standard normal: the sum of four 16-bit uniforms, centred and scaled.
    fn normal(&mut self) -> f64 {
        let r = self.next();
        let s = (r & 0xffff) + ((r >> 16) & 0xffff) + ((r >> 32) & 0xffff) + (r >> 48);
        (s as f64 - 2.0 * 65535.0) * (3.0f64.sqrt() / 65536.0)
    }
}

/// A pixel's fixed gain pattern (PRNU about 1 %), from its index.
fn prnu(i: usize) -> f64 {
    let h = (i as u64 ^ 0x5851_f42d_4c95_7f2d).wrapping_mul(0x9e37_79b9_7f4a_7c15);
    1.0 + 0.0173 * ((h >> 40) as f64 / (1u64 << 24) as f64 - 0.5)
}

/// One frame at `photons` mean photons per pixel, clipped to the declared bits.
fn frame(photons: f64, rng: &mut Rng) -> Vec<f64> {
    let top = f64::from((1u32 << BITS) - 1);
    (0..shape().0 * shape().1)
        .map(|i| {
            let e = QE * photons * prnu(i);
            let sigma = (e + DARK_NOISE_E * DARK_NOISE_E).sqrt();
            (OFFSET_DN + K_DN_PER_E * (e + sigma * rng.normal()))
                .round()
                .clamp(0.0, top)
        })
        .collect()
}

/// Write the dataset into `dir` (unless a complete one is there) and return its descriptor.
fn dataset(dir: &Path) -> PathBuf {
    let descriptor = dir.join("EMVA1288descriptor.txt");
    let done = dir.join("complete");
    if done.exists() {
        return descriptor;
    }
    let t = Instant::now();
    std::fs::create_dir_all(dir.join("images")).expect("the dataset's folder");
    let mut text = format!(
        "# detnoise benches/emva.rs\nv 4.0\nn {BITS} {} {}\n",
        shape().1,
        shape().0
    );
    let mut rng = Rng(7);
    let mut k = 0;
    let mut images = |count: usize, photons: f64, text: &mut String| {
        for _ in 0..count {
            let name = format!("images/img{k:04}.fits");
            let mut next = || frame(photons, &mut rng);
            write_cube(&dir.join(&name), shape(), 1, true, &mut next, &[]).expect("a frame");
            text.push_str(&format!("i {name}\n"));
            k += 1;
        }
    };
    for p in 1..=POINTS {
        let (t_ns, photons) = (p as f64 * STEP_NS, p as f64 * PHOTONS_PER_STEP);
        text.push_str(&format!("b {t_ns:.1} {photons:.3}\n"));
        images(2, photons, &mut text);
        text.push_str(&format!("d {t_ns:.1}\n"));
        images(2, 0.0, &mut text);
    }
    // Half of saturation: the series saturates near point 42.
    let p = 21.0;
    text.push_str(&format!(
        "b {:.1} {:.3}\n",
        p * STEP_NS,
        p * PHOTONS_PER_STEP
    ));
    images(spatial_frames(), p * PHOTONS_PER_STEP, &mut text);
    text.push_str(&format!("d {:.1}\n", p * STEP_NS));
    images(spatial_frames(), 0.0, &mut text);
    std::fs::write(&descriptor, text).expect("the descriptor");
    std::fs::write(&done, "").expect("the marker");
    println!(
        "wrote the dataset ({k} frames) in {:.1} s",
        t.elapsed().as_secs_f64()
    );
    descriptor
}

/// Run `f`, printing `label`'s GB/s over `bytes`, wall and CPU seconds and peak memory.
fn timed<T>(label: &str, bytes: u64, f: impl FnOnce() -> T) -> T {
    reset_peak();
    let (t, cpu) = (Instant::now(), cpu_seconds());
    let out = f();
    let (wall, cpu) = (t.elapsed().as_secs_f64(), cpu_seconds() - cpu);
    let gb = bytes as f64 / 1e9;
    let mb = peak_mb();
    println!(
        "{label}: {gb:.2} GB, {:.2} GB/s ({wall:.2} s wall, {cpu:.2} CPU s: {:.2} GB/s on 2 idle \
         cores), {mb:.0} MB peak = {:.1} frames of f64; load {:.1}",
        gb / wall,
        gb / (cpu / 2.0),
        mb / (shape().0 * shape().1 * 8) as f64 * 1e6,
        load()
    );
    out
}

/// `darks` on `files` (one stack) into `out`; returns the seconds of its reading pass.
fn darks(files: &[PathBuf], out: PathBuf, checksum: Option<Checksum>) -> f64 {
    run_darks(
        &DarksRun {
            stack: files.to_vec(),
            out,
            force: false,
            options: DarkOptions::default(),
            gain_e_per_adu: Some(1.0 / K_DN_PER_E),
            checksum,
            accept_illuminated: true,
            expected_dark: None,
        },
        &Silent,
    )
    .expect("darks runs")
    .read_seconds
}

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let runs: usize = args.iter().find_map(|a| a.parse().ok()).unwrap_or(1);
    let with_darks = !args.iter().any(|a| a == "sheet");
    let side = if args.iter().any(|a| a == "512px") {
        512
    } else {
        1024
    };
    SIDE.set(side).expect("the frame side is set once");
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join(format!("target/emva-bench-{side}"));
    let descriptor = dataset(&dir);
    let data = EmvaDataset::from_descriptor(&descriptor).expect("the descriptor reads");
    let frame_bytes = (shape().0 * shape().1 * 2) as u64;
    let (sb, sd) = (
        data.spatial_bright.as_ref().expect("a bright stack"),
        data.spatial_dark.as_ref().expect("a dark stack"),
    );
    let pair_bytes = 4 * data.points.len() as u64 * frame_bytes;
    let spatial_bytes = (sb.files.len() + sd.files.len()) as u64 * frame_bytes;
    let all = pair_bytes + spatial_bytes;
    let out = tempfile::tempdir().expect("a temporary directory");
    let job = |k: usize| DatasheetRun {
        input: DatasheetInput::Descriptor(descriptor.clone()),
        out: out.path().join(format!("sheet{k}")),
        force: false,
        spatial: Default::default(),
        beyond: Default::default(),
    };
    println!(
        "EMVA dataset: {} points x 4 frames + 2 x {} spatial frames of {}x{} uint16, {:.2} GB; \
         {} threads",
        data.points.len(),
        sb.files.len(),
        shape().0,
        shape().1,
        all as f64 / 1e9,
        rayon::current_num_threads()
    );
    run(&job(0)).expect("the datasheet runs (warming the page cache)");
    for k in 1..=runs {
        let (sheet, _, _) = timed("datasheet (whole run)", all, || {
            run(&job(k)).expect("the datasheet runs")
        });
        if k == 1 {
            let t = &sheet.temporal;
            println!(
                "  K {:.4} DN/e- (simulated {K_DN_PER_E}), dark noise {:.2} e- ({DARK_NOISE_E})",
                t.system_gain_dn_per_e.value, t.dark_noise_e.value
            );
        }
        timed(
            "  photon-transfer pairs (pairs::measure)",
            pair_bytes,
            || measure(&data).expect("the pairs read"),
        );
        timed(
            "  spatial stacks (read_stack_image x 2)",
            spatial_bytes,
            || {
                read_stack_image(&sb.files).expect("the bright stack reads");
                read_stack_image(&sd.files).expect("the dark stack reads");
            },
        );
        if !with_darks {
            continue;
        }
        // The same bytes as the datasheet: every file of the dataset as one stack.
        let every: Vec<PathBuf> = data
            .points
            .iter()
            .flat_map(|p| p.bright.iter().chain(&p.dark).cloned())
            .chain(sb.files.iter().cloned())
            .chain(sd.files.iter().cloned())
            .collect();
        let reading = timed(
            "darks, checksums blake3, on every file of the dataset (one stack)",
            all,
            || {
                darks(
                    &every,
                    out.path().join(format!("dall{k}")),
                    Some(Checksum::Blake3),
                )
            },
        );
        println!(
            "  its reading pass: {:.2} GB/s ({reading:.2} s)",
            all as f64 / 1e9 / reading
        );
        for (name, sum) in [("blake3", Some(Checksum::Blake3)), ("none", None)] {
            let reading = timed(
                &format!("darks, checksums {name}, on the spatial stacks' files"),
                spatial_bytes,
                || {
                    darks(&sb.files, out.path().join(format!("db-{name}{k}")), sum)
                        + darks(&sd.files, out.path().join(format!("dd-{name}{k}")), sum)
                },
            );
            println!(
                "  its reading passes: {:.2} GB/s ({reading:.2} s; the rest is its per-pixel \
                 maps and files, which {} frames do not amortise)",
                spatial_bytes as f64 / 1e9 / reading,
                sb.files.len()
            );
        }
    }
}
