//! Dark calibration against known truth: recovery within the statistical error for the frame
//! count, identical maps from every format, exact clipping, common mode, split half, flags.

use std::path::{Path, PathBuf};

use detnoise::calib::darks::{
    dark_maps, Clip, DarkOptions, FLAG_DEAD, FLAG_HOT, FLAG_RTS, FLAG_SATURATED,
};
use detnoise::io::FrameStack;
use detnoise::synth::SynthFormat;
use detnoise::synth::{draw_truth, frame, write_synthetic, Camera, ScmosParams, SynthSpec};

fn spec(frames: usize, u16_samples: bool) -> SynthSpec {
    SynthSpec {
        camera: Camera::Scmos(ScmosParams::default()),
        shape: (48, 64),
        frames,
        light_e: 0.0,
        seed: 11,
        u16_samples,
    }
}

fn stack(paths: &[PathBuf]) -> FrameStack {
    FrameStack::open(paths).unwrap()
}

fn mean_std(z: &[f64]) -> (f64, f64) {
    let n = z.len() as f64;
    let m = z.iter().sum::<f64>() / n;
    (
        m,
        (z.iter().map(|x| (x - m) * (x - m)).sum::<f64>() / (n - 1.0)).sqrt(),
    )
}

/// Write frames (rows*cols each) as a FITS cube, float32 or uint16.
fn write_frames(path: &Path, shape: (usize, usize), frames: Vec<Vec<f64>>, u16_samples: bool) {
    let n = frames.len();
    let mut it = frames.into_iter();
    detnoise::io::fits::write_cube(path, shape, n, u16_samples, &mut || it.next().unwrap(), &[])
        .unwrap();
}

#[test]
fn darks_recover_truth_within_statistical_error() {
    let d = tempfile::tempdir().unwrap();
    let n = 400;
    let sp = spec(n, false);
    let pdf = detnoise::pdf::paper();
    let p = d.path().join("darks.fits");
    write_synthetic(&sp, &pdf, SynthFormat::Fits, &p).unwrap();
    let truth = draw_truth(&sp, &pdf);
    let sigma = truth.rms_adu();
    let maps = dark_maps(&stack(&[p]), &DarkOptions::default()).unwrap();
    assert_eq!(maps.stats.frames, n);
    let nf = n as f64;
    // Per pixel, Gaussian samples: the sample std has standard error sigma / sqrt(2 (n - 1)),
    // the sample mean sigma / sqrt(n). The z-scores over P = 3072 pixels then have mean 0 with
    // standard error 1/sqrt(P) = 0.018 and std 1 with standard error 1/sqrt(2P) = 0.013;
    // 5 standard errors give 0.09 and 0.064 (+0.02 for the O(1/n) bias of the sample std
    // and the large-n approximation of its error).
    let z_rms: Vec<f64> = (0..sigma.data.len())
        .map(|i| {
            (maps.rms_adu.data[i] - sigma.data[i]) / (sigma.data[i] / (2.0 * (nf - 1.0)).sqrt())
        })
        .collect();
    let z_off: Vec<f64> = (0..sigma.data.len())
        .map(|i| (maps.offset_adu.data[i] - truth.offset_adu.data[i]) / (sigma.data[i] / nf.sqrt()))
        .collect();
    let (m, s) = mean_std(&z_rms);
    eprintln!("rms z-scores: mean {m:.4} (tol 0.11), std {s:.4} (tol 1 +/- 0.084)");
    assert!(
        m.abs() < 0.09 + 0.02 && (s - 1.0).abs() < 0.064 + 0.02,
        "rms z: mean {m}, std {s}"
    );
    let (m, s) = mean_std(&z_off);
    eprintln!("offset z-scores: mean {m:.4} (tol 0.09), std {s:.4} (tol 1 +/- 0.084)");
    assert!(
        m.abs() < 0.09 && (s - 1.0).abs() < 0.064 + 0.02,
        "offset z: mean {m}, std {s}"
    );
    // Split half: expected correlation var(sigma) / (var(sigma) + mean sampling variance of
    // a std from n/2 frames). The estimate's standard error is about (1 - rho^2)/sqrt(P);
    // heavy tails make it larger, so the tolerance is 10 of those plus 0.01.
    let var_true = mean_std(&sigma.data).1.powi(2);
    let samp = sigma
        .data
        .iter()
        .map(|s| s * s / (2.0 * (nf / 2.0 - 1.0)))
        .sum::<f64>()
        / sigma.data.len() as f64;
    let rho = var_true / (var_true + samp);
    let tol = 10.0 * (1.0 - rho * rho) / (sigma.data.len() as f64).sqrt() + 0.01;
    eprintln!(
        "split half {:.5}, expected {rho:.5} +/- {tol:.5}",
        maps.split_half_correlation
    );
    assert!(
        (maps.split_half_correlation - rho).abs() < tol,
        "split half {} vs {rho} +/- {tol}",
        maps.split_half_correlation
    );
    assert_eq!(
        maps.flags
            .iter()
            .filter(|f| **f & (FLAG_HOT | FLAG_DEAD) != 0)
            .count(),
        0
    );
}

#[test]
fn every_format_gives_identical_maps() {
    let d = tempfile::tempdir().unwrap();
    let sp = spec(40, true);
    let pdf = detnoise::pdf::paper();
    let mut results = Vec::new();
    for (f, ext) in [
        (SynthFormat::Fits, "fits"),
        (SynthFormat::Tiff, "tif"),
        (SynthFormat::Exr, "exr"),
    ] {
        let p = d.path().join(format!("s.{ext}"));
        write_synthetic(&sp, &pdf, f, &p).unwrap();
        results.push(dark_maps(&stack(&[p]), &DarkOptions::default()).unwrap());
    }
    for r in &results[1..] {
        assert_eq!(r.offset_adu, results[0].offset_adu);
        assert_eq!(r.rms_adu, results[0].rms_adu);
        assert_eq!(r.flags, results[0].flags);
    }
}

/// Brute-force per-pixel (mean, std) of `samples` after dropping `n` highest and lowest.
fn trimmed(mut v: Vec<f64>, n: usize) -> (f64, f64) {
    v.sort_by(f64::total_cmp);
    let v = &v[n..v.len() - n];
    mean_std(v)
}

fn pixel_series(frames: &[Vec<f64>], i: usize) -> Vec<f64> {
    frames.iter().map(|f| f[i]).collect()
}

fn cosmic_ray_frames(n: usize, shape: (usize, usize)) -> Vec<Vec<f64>> {
    let sp = SynthSpec {
        shape,
        frames: n,
        ..spec(n, false)
    };
    let pdf = detnoise::pdf::paper();
    let truth = draw_truth(&sp, &pdf);
    let mut frames: Vec<Vec<f64>> = (0..n).map(|k| frame(&sp, &truth, None, k)).collect();
    // Cosmic rays: large positive hits on a deterministic scatter of (frame, pixel) pairs.
    for (k, f) in frames.iter_mut().enumerate() {
        for (i, x) in f.iter_mut().enumerate() {
            if (k * 31 + i * 17) % 97 == 0 {
                *x += 5000.0 + i as f64;
            }
        }
    }
    frames
}

#[test]
fn extremes_clipping_matches_brute_force() {
    let d = tempfile::tempdir().unwrap();
    let shape = (7, 9);
    let frames = cosmic_ray_frames(200, shape); // > 2 blocks of 64 per parity: Chan merges
    let p = d.path().join("cr.fits");
    write_frames(&p, shape, frames.clone(), false);
    // The FITS file stores float32: compare against the same rounding.
    let frames: Vec<Vec<f64>> = frames
        .iter()
        .map(|f| f.iter().map(|x| *x as f32 as f64).collect())
        .collect();
    for n in [1, 3] {
        let maps = dark_maps(
            &stack(std::slice::from_ref(&p)),
            &DarkOptions {
                clip: Clip::Extremes(n),
                ..Default::default()
            },
        )
        .unwrap();
        for i in 0..shape.0 * shape.1 {
            let (m, s) = trimmed(pixel_series(&frames, i), n);
            assert!(
                (maps.offset_adu.data[i] - m).abs() < 1e-9 * m.abs().max(1.0),
                "pixel {i}: mean {} vs {m}",
                maps.offset_adu.data[i]
            );
            assert!(
                (maps.rms_adu.data[i] - s).abs() < 1e-9 * s.max(1.0),
                "pixel {i}: std {} vs {s}",
                maps.rms_adu.data[i]
            );
        }
    }
}

#[test]
fn sigma_clipping_matches_brute_force() {
    let d = tempfile::tempdir().unwrap();
    let shape = (5, 6);
    let frames = cosmic_ray_frames(300, shape);
    let p = d.path().join("cr.fits");
    write_frames(&p, shape, frames.clone(), false);
    let frames: Vec<Vec<f64>> = frames
        .iter()
        .map(|f| f.iter().map(|x| *x as f32 as f64).collect())
        .collect();
    let k = 3.0;
    let maps = dark_maps(
        &stack(&[p]),
        &DarkOptions {
            clip: Clip::Sigma(k),
            ..Default::default()
        },
    )
    .unwrap();
    for i in 0..shape.0 * shape.1 {
        let v = pixel_series(&frames, i);
        let (m, s) = mean_std(&v);
        let kept: Vec<f64> = v.into_iter().filter(|x| (x - m).abs() <= k * s).collect();
        let (m2, s2) = mean_std(&kept);
        assert!(
            (maps.offset_adu.data[i] - m2).abs() < 1e-9 * m2.abs(),
            "pixel {i}"
        );
        assert!(
            (maps.rms_adu.data[i] - s2).abs() < 1e-9 * s2.max(1.0),
            "pixel {i}: {} vs {s2}",
            maps.rms_adu.data[i]
        );
    }
}

#[test]
fn common_mode_removal_restores_the_pixel_noise() {
    let d = tempfile::tempdir().unwrap();
    let n = 200;
    let sp = SynthSpec {
        shape: (32, 40),
        ..spec(n, false)
    };
    let pdf = detnoise::pdf::paper();
    let truth = draw_truth(&sp, &pdf);
    let clean: Vec<Vec<f64>> = (0..n).map(|k| frame(&sp, &truth, None, k)).collect();
    // A per-frame offset of +/-50 adu, far above the pixel noise (a few adu).
    let shifted: Vec<Vec<f64>> = clean
        .iter()
        .enumerate()
        .map(|(k, f)| {
            f.iter()
                .map(|x| x + 50.0 * ((k * 7919 % 13) as f64 - 6.0) / 6.0)
                .collect()
        })
        .collect();
    let (pc, ps) = (d.path().join("clean.fits"), d.path().join("shifted.fits"));
    write_frames(&pc, sp.shape, clean, false);
    write_frames(&ps, sp.shape, shifted, false);
    let base = dark_maps(&stack(&[pc]), &DarkOptions::default()).unwrap();
    let raw = dark_maps(&stack(std::slice::from_ref(&ps)), &DarkOptions::default()).unwrap();
    let cm = dark_maps(
        &stack(&[ps]),
        &DarkOptions {
            common_mode: true,
            ..Default::default()
        },
    )
    .unwrap();
    // The frame median of P = 1280 pixels carries noise ~1.25 sigma_typ / sqrt(P) = 0.035
    // sigma_typ, added in quadrature to each pixel (sigma >= 0.4 sigma_typ): under 0.4 %
    // of the variance; 1 % on the median rms is a safe bound.
    let med = |v: &[f64]| detnoise::stats::median(v);
    let (b, r, c) = (
        med(&base.rms_adu.data),
        med(&raw.rms_adu.data),
        med(&cm.rms_adu.data),
    );
    assert!((c / b - 1.0).abs() < 0.01, "common mode {c} vs clean {b}");
    assert!(
        r > 5.0 * b,
        "without removal the offset dominates: {r} vs {b}"
    );
    assert_eq!(cm.common_mode_adu.len(), n);
}

#[test]
fn hot_dead_rts_and_saturated_pixels_are_flagged() {
    let d = tempfile::tempdir().unwrap();
    let (rows, cols, n) = (16, 16, 400);
    let (hot, dead, rts, sat) = (17, 100, 200, 250);
    let pdf_sigma = 5.0;
    let mut rng = detnoise::rng::stream(3, 0, 0);
    use rand_distr::{Distribution, StandardNormal};
    let frames: Vec<Vec<f64>> = (0..n)
        .map(|k| {
            (0..rows * cols)
                .map(|i| {
                    let g: f64 = StandardNormal.sample(&mut rng);
                    match i {
                        _ if i == hot => 1300.0 + pdf_sigma * g,
                        _ if i == dead => 1000.0,
                        // Two levels 30 adu apart, switching every 40 frames.
                        _ if i == rts => 1000.0 + 30.0 * ((k / 40) % 2) as f64 + pdf_sigma * g,
                        _ if i == sat => 65530.0 + pdf_sigma * g,
                        _ => 1000.0 + pdf_sigma * g,
                    }
                })
                .collect()
        })
        .collect();
    let p = d.path().join("flags.fits");
    write_frames(&p, (rows, cols), frames, true);
    let maps = dark_maps(&stack(&[p]), &DarkOptions::default()).unwrap();
    assert!(maps.flags[hot] & FLAG_HOT != 0);
    assert!(maps.flags[dead] & FLAG_DEAD != 0);
    assert!(maps.flags[rts] & FLAG_RTS != 0);
    assert!(maps.flags[sat] & FLAG_SATURATED != 0);
    // The saturated pixel is also hot (high offset); no other pixel is flagged: the hot and
    // RTS tests are 5-sigma tests, false-alarm rate 3e-7 per pixel.
    let others = (0..rows * cols)
        .filter(|i| ![hot, dead, rts, sat].contains(i) && maps.flags[*i] != 0)
        .count();
    assert_eq!(others, 0);
}
