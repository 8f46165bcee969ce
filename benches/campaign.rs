//! `campaign` streaming speed: a generated campaign of 9 uint16 FITS stacks (3 exposure times
//! x 3 EM gains of darks, 512 x 512 x 200 frames each, ~0.94 GB) in a temporary folder, read
//! by `campaign` with BLAKE3 checksums (the EM histogram fit off, so the figure is the
//! stream's), then by `darks` on the same stacks one by one for comparison. Prints GB/s of
//! stored samples over the wall time of the reading (the files are in the page cache: the
//! first read warms it).
//!
//! `cargo bench --bench campaign`, or `-- FRAMES` for another frame count per stack.
//! Target (issue 31): >= 2 GB/s with checksums.

use std::path::PathBuf;
use std::time::Instant;

use detnoise::calib::darks::{run as run_darks, DarkOptions, DarksRun};
use detnoise::campaign::{run, CampaignInput, CampaignRun, MeasureOptions};
use detnoise::io::fits::write_cube;
use detnoise::io::Checksum;
use detnoise::progress::Silent;

/// Frame shape (rows, cols).
const SHAPE: (usize, usize) = (512, 512);

/// Write the campaign's 9 stacks of `frames` frames and its manifest into `dir`.
fn write_campaign(dir: &std::path::Path, frames: usize) -> (PathBuf, Vec<PathBuf>) {
    let mut manifest = String::from("file,kind,exposure_s,em_gain,temperature_c,light_level\n");
    let mut files = Vec::new();
    let mut state = 0x9e37_79b9_7f4a_7c15_u64;
    for gain in [10.0, 100.0, 300.0] {
        for t in [0.01, 0.1, 1.0] {
            let name = format!("dark_g{gain}_t{t}.fits");
            let path = dir.join(&name);
            let mut next = || -> Vec<f64> {
                (0..SHAPE.0 * SHAPE.1)
                    .map(|_| {
                        state = state
                            .wrapping_mul(6364136223846793005)
                            .wrapping_add(1442695040888963407);
                        1000.0 + ((state >> 58) as f64) + 40.0 * t
                    })
                    .collect()
            };
            write_cube(&path, SHAPE, frames, true, &mut next, &[]).expect("write a stack");
            manifest += &format!("{name},dark,{t},{gain},,\n");
            files.push(path);
        }
    }
    let m = dir.join("campaign.csv");
    std::fs::write(&m, manifest).expect("write the manifest");
    (m, files)
}

fn main() {
    let frames: usize = std::env::args()
        .skip(1)
        .find_map(|a| a.parse().ok())
        .unwrap_or(200);
    let dir = tempfile::tempdir().expect("a temporary directory");
    let (manifest, files) = write_campaign(dir.path(), frames);
    let job = |out: &str| CampaignRun {
        input: CampaignInput::Manifest(manifest.clone()),
        out: dir.path().join(out),
        force: false,
        measure: MeasureOptions {
            gain_e_per_adu: 1.0,
            checksum: Some(Checksum::Blake3),
            em_fit: false,
            clip: detnoise::calib::darks::Clip::None,
            common_mode: false,
        },
        temperature: detnoise::campaign::fit::TemperatureTerm::Off,
        thresholds: Default::default(),
    };
    // Warm the page cache (and the thread pool).
    run(&job("warm"), &Silent).expect("campaign runs");
    let t = Instant::now();
    let r = run(&job("out"), &Silent).expect("campaign runs");
    let wall = t.elapsed().as_secs_f64();
    let gb = r.stored_bytes as f64 / 1e9;
    println!(
        "campaign: 9 stacks of {}x{}x{frames} uint16 ({gb:.2} GB), blake3: {:.2} GB/s reading, {:.2} GB/s wall ({wall:.2} s)",
        SHAPE.0,
        SHAPE.1,
        gb / r.read_seconds,
        gb / wall
    );
    let t = Instant::now();
    let mut read = 0.0;
    for (k, f) in files.iter().enumerate() {
        let d = run_darks(
            &DarksRun {
                stack: vec![f.clone()],
                out: dir.path().join(format!("darks{k}")),
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
    }
    let wall = t.elapsed().as_secs_f64();
    println!(
        "darks:    the same 9 stacks one by one, blake3: {:.2} GB/s reading, {:.2} GB/s wall ({wall:.2} s)",
        gb / read,
        gb / wall
    );
}
