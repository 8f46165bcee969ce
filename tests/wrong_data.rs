//! The wrong kind of data is recognised before the work (issue 9, section 3): flats given as
//! darks, sCMOS frames given to the EM-gain fit, and several light levels in one `--flats`.

mod common;

use common::{data, detnoise, open};

use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

use detnoise::calib::darks::{dark_maps, pixel_stats, Clip, DarkOptions, Illumination};
use detnoise::calib::ptc::{light_levels, photon_transfer, DarkReference, PtcOptions};
use detnoise::fit::emgain::{EmSignature, Verdict};
use detnoise::io::FrameStack;
use detnoise::synth::SynthFormat;
use detnoise::synth::{
    draw_truth, frame, write_synthetic, Camera, EmccdParams, ScmosParams, SynthSpec,
};

const FLATS: [&str; 4] = [
    "scmos-flat-64x64-100e.fits",
    "scmos-flat-64x64-400e.fits",
    "scmos-flat-64x64-1600e.fits",
    "scmos-flat-64x64-6400e.fits",
];
const SCMOS_DARKS: [&str; 3] = [
    "scmos-darks-64x64.fits",
    "scmos-darks-64x64.tif",
    "scmos-darks-64x64.exr",
];
const EMCCD: [&str; 2] = ["emccd-darks-32x48.fits", "emccd-lowlight-32x48.fits"];

fn lanl(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/data/lanl-emccd/gain-GS")
        .join(name)
}

/// The exit code the project gives bad input data.
/// Exit code of bad data, as the README and `--help` document it.
fn data_error_code() -> i32 {
    1
}

fn stderr(a: &assert_cmd::assert::Assert) -> String {
    String::from_utf8_lossy(&a.get_output().stderr).into_owned()
}

fn illumination(p: &Path) -> Illumination {
    let stack = open(p);
    let maps = dark_maps(&stack, &DarkOptions::default()).unwrap();
    Illumination::measure(
        &maps.offset_adu.data,
        &maps.rms_adu.data,
        stack.saturation_value(),
    )
}

fn scmos(frames: usize, light_e: f64, seed: u64, u16_samples: bool) -> SynthSpec {
    SynthSpec {
        camera: Camera::Scmos(ScmosParams::default()),
        shape: (64, 64),
        frames,
        light_e,
        seed,
        u16_samples,
    }
}

fn emccd(frames: usize, light_e: f64, cic_e: f64) -> SynthSpec {
    SynthSpec {
        camera: Camera::Emccd(EmccdParams {
            cic_e,
            ..EmccdParams::default()
        }),
        shape: (32, 48),
        frames,
        light_e,
        seed: 9,
        u16_samples: true,
    }
}

fn write(spec: &SynthSpec, path: &Path) -> PathBuf {
    write_synthetic(spec, &detnoise::pdf::paper(), SynthFormat::Fits, path).unwrap();
    path.to_path_buf()
}

// ---- 1. A flat given as darks ----

#[test]
fn every_bundled_flat_given_as_darks_is_refused_with_what_was_seen() {
    let dir = tempfile::tempdir().unwrap();
    for name in FLATS {
        let out = dir.path().join("out");
        let a = detnoise()
            .arg("darks")
            .arg(data(name))
            .arg("--out")
            .arg(&out)
            .assert()
            .code(data_error_code());
        let err = stderr(&a);
        for want in [
            name,
            "look illuminated",
            "variance grows with the mean",
            "photoelectrons per pixel and frame",
            "--accept-illuminated",
        ] {
            assert!(err.contains(want), "{name}: no '{want}' in {err}");
        }
        assert!(!out.exists(), "{name}: output written");
    }
}

#[test]
fn bundled_darks_and_emccd_frames_pass_the_dark_check() {
    for name in SCMOS_DARKS.iter().chain(&EMCCD) {
        let seen = illumination(&data(name));
        assert!(!seen.illuminated, "{name}: {}", seen.describe());
    }
    // The real EMCCD stacks (3x3 pixels: too few for the slope) at EM gain 1 to 100 pass.
    for g in [1, 5, 25, 100] {
        let seen = illumination(&lanl(&format!("{g}x-gain.tif")));
        assert!(!seen.illuminated, "{g}x: {}", seen.describe());
    }
    // At 300x the frames sit at 25,689 adu (39 % of uint16) over a 566 adu bias (its
    // no-signal map): light, refused as darks. `emgain` uses them with --offset and
    // --read-noise and never applies this check (tests/fit_cli.rs, real_emccd_gain_routes_agree).
    let bright = illumination(&lanl("300x-gain.tif"));
    assert!(bright.illuminated && bright.level_fraction_of_range.unwrap() > 0.25);
    let dir = tempfile::tempdir().unwrap();
    for name in ["scmos-darks-64x64.fits", "emccd-darks-32x48.fits"] {
        let out = dir.path().join(name);
        let a = detnoise()
            .arg("darks")
            .arg(data(name))
            .arg("--out")
            .arg(&out)
            .assert()
            .success();
        assert!(!stderr(&a).contains("illuminated"), "{name}");
        assert!(out.join("rms_adu.fits").exists());
    }
}

#[test]
fn synthetic_darks_of_every_kind_pass_and_dim_short_flats_are_caught() {
    let dir = tempfile::tempdir().unwrap();
    let p = |i: usize| dir.path().join(format!("s{i}.fits"));
    let mut i = 0;
    let mut next = || {
        i += 1;
        p(i)
    };
    // sCMOS darks: integer and float storage, 5 to 100 frames, several seeds.
    for (frames, seed, u16_samples) in [
        (5, 1, true),
        (20, 2, true),
        (100, 3, true),
        (20, 4, false),
        (100, 5, false),
    ] {
        let f = write(&scmos(frames, 0.0, seed, u16_samples), &next());
        let seen = illumination(&f);
        assert!(
            !seen.illuminated,
            "{frames} frames seed {seed}: {}",
            seen.describe()
        );
    }
    // EMCCD frames with ten times the bundled CIC, or 0.5 e- of light: events on a dark
    // level (the slope implies well under a photoelectron), not a flat.
    for (light, cic) in [(0.0, 0.05), (0.5, 0.005)] {
        let f = write(&emccd(200, light, cic), &next());
        let seen = illumination(&f);
        assert!(
            !seen.illuminated,
            "EMCCD {light} {cic}: {}",
            seen.describe()
        );
    }
    // Flats of 20 frames at 100 and 400 e-: caught by the photon-transfer slope alone.
    for light in [100.0, 400.0] {
        let f = write(&scmos(20, light, 6, true), &next());
        let seen = illumination(&f);
        assert!(seen.illuminated, "{light} e-: {}", seen.describe());
        assert!(seen.level_fraction_of_range.unwrap() < 0.25);
    }
}

#[test]
fn accept_illuminated_uses_a_flat_as_darks_with_a_warning() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("out");
    let a = detnoise()
        .arg("darks")
        .arg(data(FLATS[0]))
        .arg("--accept-illuminated")
        .arg("--out")
        .arg(&out)
        .assert()
        .success();
    let err = stderr(&a);
    assert!(
        err.contains("warning") && err.contains("--accept-illuminated"),
        "{err}"
    );
    assert!(out.join("rms_adu.fits").exists());
}

#[test]
fn report_refuses_a_flat_as_darks_before_the_simulation() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("rep");
    let t = Instant::now();
    let a = detnoise()
        .args(["report", "--gain-e-per-adu", "0.25", "--quick", "--darks"])
        .arg(data(FLATS[1]))
        .arg("--out")
        .arg(&out)
        .assert()
        .code(data_error_code());
    assert!(t.elapsed() < Duration::from_secs(30), "{:?}", t.elapsed());
    let err = stderr(&a);
    assert!(
        err.contains("look illuminated") && err.contains(FLATS[1]),
        "{err}"
    );
    assert!(!out.exists());
}

// ---- 2. No EM signature ----

#[test]
fn emccd_report_and_emgain_refuse_scmos_frames_in_seconds() {
    // Before: 124 s of fitting, then "the fit did not converge".
    let dir = tempfile::tempdir().unwrap();
    let darks = data(SCMOS_DARKS[0]);
    let out = dir.path().join("out");
    let runs: [Vec<&str>; 2] = [
        vec![
            "report",
            "--detector",
            "emccd",
            "--gain-e-per-adu",
            "0.25",
            "--quick",
            "--darks",
        ],
        vec!["emgain"],
    ];
    for args in runs {
        let t = Instant::now();
        let a = detnoise()
            .args(&args)
            .arg(&darks)
            .arg("--out")
            .arg(&out)
            .assert()
            .code(data_error_code());
        assert!(
            t.elapsed() < Duration::from_secs(30),
            "{args:?}: {:?}",
            t.elapsed()
        );
        let err = stderr(&a);
        for want in [SCMOS_DARKS[0], "no EM signal", "scatter alike", "sCMOS"] {
            assert!(err.contains(want), "{args:?}: no '{want}' in {err}");
        }
        assert!(!out.exists());
    }
}

#[test]
fn em_signature_is_present_in_emccd_frames_and_absent_in_scmos_frames() {
    for name in EMCCD {
        let s = EmSignature::measure(&open(&data(name))).unwrap();
        assert_eq!(s.verdict, Verdict::Present, "{name}: {}", s.describe());
        assert!(s.whole_stack);
    }
    for name in SCMOS_DARKS {
        let s = EmSignature::measure(&open(&data(name))).unwrap();
        assert_eq!(s.verdict, Verdict::Absent, "{name}: {}", s.describe());
        // Symmetric tails: the counts agree within 3 Poisson standard errors.
        let (a, b) = (s.above as f64, s.below as f64);
        assert!((a - b).abs() < 3.0 * (a + b).sqrt(), "{name}: {a} vs {b}");
    }
    // Flats have no zero-electron peak with a tail at all: refused, naming the file.
    for name in FLATS {
        let e = EmSignature::measure(&open(&data(name)))
            .unwrap_err()
            .to_string();
        assert!(e.contains(name) && e.contains("no EM signal"), "{e}");
    }
}

/// sCMOS darks or EMCCD darks (per `spec`) with every 50th pixel hot (+400 adu, every frame).
fn with_hot_pixels(spec: &SynthSpec, path: &Path) -> PathBuf {
    let truth = draw_truth(spec, &detnoise::pdf::paper());
    let register = match &spec.camera {
        Camera::Emccd(p) => Some(
            detnoise::detector::register::EmRegister::new(p.em_gain, p.stages)
                .expect("the bundled EMCCD spec has a valid register"),
        ),
        Camera::Scmos(_) => None,
    };
    let mut k = 0;
    let mut next = || {
        let mut f = frame(spec, &truth, register.as_ref(), k);
        k += 1;
        f.iter_mut().step_by(50).for_each(|v| *v += 400.0);
        f
    };
    detnoise::io::fits::write_cube(path, spec.shape, spec.frames, true, &mut next, &[]).unwrap();
    path.to_path_buf()
}

#[test]
fn hot_pixels_neither_make_nor_hide_an_em_signature() {
    let dir = tempfile::tempdir().unwrap();
    let scmos_hot = with_hot_pixels(&scmos(50, 0.0, 7, true), &dir.path().join("s.fits"));
    let s = EmSignature::measure(&open(&scmos_hot)).unwrap();
    assert_eq!(s.verdict, Verdict::Absent, "{}", s.describe());
    assert!(s.persistent_pixels >= 64 * 64 / 50, "{}", s.describe());
    let emccd_hot = with_hot_pixels(&emccd(200, 0.0, 0.005), &dir.path().join("e.fits"));
    let s = EmSignature::measure(&open(&emccd_hot)).unwrap();
    assert_eq!(s.verdict, Verdict::Present, "{}", s.describe());
}

// ---- 3. Several light levels in one --flats ----

#[test]
fn one_flats_holding_four_levels_is_split_and_matches_four_stacks() {
    let dark = DarkReference::from_stats(
        &pixel_stats(&open(&data(SCMOS_DARKS[0])), Clip::None, None).unwrap(),
    );
    let opts = PtcOptions::default();
    let separate: Vec<FrameStack> = FLATS.iter().map(|n| open(&data(n))).collect();
    let reference = photon_transfer(&separate, &dark, &opts).unwrap();
    // '*00e' matches the four stacks but not the truth maps beside them.
    let glob = data("scmos-flat-64x64-*00e.fits");
    let merged = open(&glob);
    assert_eq!(merged.frames, 200);
    let split = photon_transfer(&[merged], &dark, &opts).unwrap();
    assert_eq!(split.levels.len(), 4);
    assert!(split.notes[0].contains("split 200 frames into 4 light levels"));
    // Same frames in the same order per level: the same numbers up to summation order.
    let rel = (split.gain_e_per_adu / reference.gain_e_per_adu - 1.0).abs();
    assert!(
        rel < 1e-12,
        "{} vs {}",
        split.gain_e_per_adu,
        reference.gain_e_per_adu
    );
    let mut by_mean = reference.levels.clone();
    by_mean.sort_by(|a, b| a.mean_adu.total_cmp(&b.mean_adu));
    for (s, r) in split.levels.iter().zip(&by_mean) {
        assert_eq!(s.frames, r.frames);
        assert!((s.var_adu2 / r.var_adu2 - 1.0).abs() < 1e-12);
    }
    // Before: "photon transfer slope -1676872 adu is not positive".
    let dir = tempfile::tempdir().unwrap();
    let a = detnoise()
        .arg("ptc")
        .arg("--darks")
        .arg(data(SCMOS_DARKS[0]))
        .arg("--flats")
        .arg(&glob)
        .arg("--out")
        .arg(dir.path().join("p"))
        .assert()
        .success();
    assert!(stderr(&a).contains("split 200 frames into 4 light levels"));
}

#[test]
fn levels_that_do_not_separate_cleanly_are_listed_with_frame_counts() {
    // 20 frames at 100 e- and a single frame at 400 e- in one directory.
    let dir = tempfile::tempdir().unwrap();
    let flats = dir.path().join("flats");
    std::fs::create_dir(&flats).unwrap();
    // synth writes truth maps beside a stack: only the stacks go into the directory.
    for (name, frames, light) in [("a.fits", 20, 100.0), ("b.fits", 1, 400.0)] {
        let f = write(&scmos(frames, light, 8, true), &dir.path().join(name));
        std::fs::rename(f, flats.join(name)).unwrap();
    }
    let dark = write(&scmos(20, 0.0, 8, true), &dir.path().join("dark.fits"));
    let out = dir.path().join("p");
    let a = detnoise()
        .arg("ptc")
        .arg("--darks")
        .arg(&dark)
        .arg("--flats")
        .arg(&flats)
        .arg("--out")
        .arg(&out)
        .assert()
        .code(data_error_code());
    let err = stderr(&a);
    for want in [
        "2 light levels that are not cleanly separated",
        "20 frame(s) at",
        "from a.fits",
        "1 frame(s) at",
        "from b.fits",
        "one --flats per light level",
    ] {
        assert!(err.contains(want), "no '{want}' in {err}");
    }
    assert!(!out.exists());
}

#[test]
fn light_levels_split_at_gaps_not_at_drift_or_noise() {
    // Noise of 1 adu about 1000 adu: one level.
    let noisy: Vec<f64> = (0..40)
        .map(|k| 1000.0 + ((k * 7) % 5) as f64 - 2.0)
        .collect();
    assert_eq!(light_levels(&noisy).len(), 1);
    // A lamp drifting by 30 % in small steps: one level (flicker removal handles it).
    let drift: Vec<f64> = (0..40)
        .map(|k| 1000.0 * (1.0 + 0.0075 * k as f64))
        .collect();
    assert_eq!(light_levels(&drift).len(), 1);
    // Two levels acquired one after the other, then interleaved with a third.
    let mut two: Vec<f64> = noisy.clone();
    two.extend(noisy.iter().map(|v| v * 2.0));
    let l = light_levels(&two);
    assert_eq!(l.len(), 2);
    assert_eq!(l[0].frames, (0..40).collect::<Vec<_>>());
    assert!((l[1].mean_adu / l[0].mean_adu - 2.0).abs() < 1e-3);
}

#[test]
fn an_8_bit_dark_with_its_offset_high_in_the_range_is_a_dark() {
    // Issue 31: an 8-bit camera whose offset sits at 80 adu (31 % of 255) was refused as
    // illuminated by the level alone. 50 frames of 64x64 px, offsets 80 +- 2 adu, 1.5 adu of
    // Gaussian noise, rounded to uint8 (fixed seed).
    use rand::SeedableRng;
    use rand_distr::{Distribution, Normal};
    use tiff::encoder::{colortype, TiffEncoder};
    let d = tempfile::tempdir().unwrap();
    let p = d.path().join("darks-u8.tif");
    let mut rng = rand::rngs::StdRng::seed_from_u64(31);
    let offsets: Vec<f64> = (0..64 * 64)
        .map(|_| Normal::new(80.0, 2.0).unwrap().sample(&mut rng))
        .collect();
    let noise = Normal::new(0.0, 1.5).unwrap();
    let mut enc = TiffEncoder::new(std::fs::File::create(&p).unwrap()).unwrap();
    for _ in 0..50 {
        let frame: Vec<u8> = offsets
            .iter()
            .map(|o| (o + noise.sample(&mut rng)).round().clamp(0.0, 255.0) as u8)
            .collect();
        enc.write_image::<colortype::Gray8>(64, 64, &frame).unwrap();
    }
    drop(enc);
    let seen = illumination(&p);
    assert!(seen.level_fraction_of_range.unwrap() > 0.3);
    assert!(!seen.illuminated, "{}", seen.describe());
    let out = d.path().join("out");
    let a = detnoise()
        .arg("darks")
        .arg(&p)
        .arg("--out")
        .arg(&out)
        .assert()
        .success();
    assert!(!stderr(&a).contains("illuminated"));
    assert!(out.join("rms_adu.fits").exists());
}
