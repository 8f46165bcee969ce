//! The statistics of integer stacks against brute force from the samples: exact sums give
//! the correctly rounded mean, the variance rounded from its exact value, exact clipping;
//! and the checksummed calibration gives the same maps with the files' BLAKE3 / SHA-256.

use std::path::Path;

use super::*;
use crate::io::{Checksum, FrameStack};

const SHAPE: (usize, usize) = (5, 7);
const FRAMES: usize = 41;

/// Sample of frame `k`, pixel `i`: near the top of the uint16 range, with a spread of a few
/// hundred adu, a cosmic ray in pixel 3 and a constant pixel 8.
fn sample(k: usize, i: usize) -> i64 {
    let h = (k as u64 * 2_654_435_761 + i as u64 * 40_503).wrapping_mul(0x9e37_79b9) >> 7;
    let ray = if i == 3 && k == 17 { 900 } else { 0 };
    if i == 8 {
        64_000
    } else {
        64_000 + (h % 601) as i64 - 300 + ray
    }
}

/// The stack written as a uint16 FITS cube (read raw) at `path`.
fn write(path: &Path) -> FrameStack {
    let npix = SHAPE.0 * SHAPE.1;
    let mut k = 0;
    let mut next = || {
        k += 1;
        (0..npix).map(|i| sample(k - 1, i) as f64).collect()
    };
    crate::io::fits::write_cube(path, SHAPE, FRAMES, true, &mut next, &[]).unwrap();
    FrameStack::open(&[path.to_path_buf()]).unwrap()
}

/// Correctly rounded mean and variance (exact integer numerators, rounded once, then one
/// division) of integer samples.
fn exact(x: &[i64]) -> (f64, f64) {
    let n = x.len() as i128;
    let s1: i128 = x.iter().map(|v| *v as i128).sum();
    let s2: i128 = x.iter().map(|v| (*v as i128).pow(2)).sum();
    let var = (n * s2 - s1 * s1) as f64 / (n * (n - 1)) as f64;
    (s1 as f64 / n as f64, var)
}

#[test]
fn integer_stacks_give_exact_means_variances_and_ratios() {
    let d = tempfile::tempdir().unwrap();
    let stack = write(&d.path().join("s.fits"));
    // Every third frame left out: the rest are numbered among themselves (parity).
    let select: Vec<bool> = (0..FRAMES).map(|k| k % 3 != 1).collect();
    let used: Vec<usize> = (0..FRAMES).filter(|k| select[*k]).collect();
    let s = pixel_stats_of(&stack, Clip::None, None, Some(&select)).unwrap();
    assert_eq!(s.frames, used.len());
    for i in 0..SHAPE.0 * SHAPE.1 {
        let x: Vec<i64> = used.iter().map(|k| sample(*k, i)).collect();
        let (mean, var) = exact(&x);
        assert_eq!(s.mean.data[i], mean, "pixel {i}");
        assert_eq!(s.rms.data[i], var.sqrt(), "pixel {i}");
        let even: Vec<i64> = x.iter().step_by(2).copied().collect();
        let odd: Vec<i64> = x.iter().skip(1).step_by(2).copied().collect();
        assert_eq!(s.rms_even.data[i], exact(&even).1.sqrt(), "pixel {i}");
        assert_eq!(s.rms_odd.data[i], exact(&odd).1.sqrt(), "pixel {i}");
        assert_eq!(s.count[i], x.len() as f64);
        assert_eq!(s.max[i], *x.iter().max().unwrap() as f64);
        let vn: i64 = x.windows(2).map(|w| (w[1] - w[0]).pow(2)).sum();
        let n = x.len() as f64;
        if i == 8 {
            assert!(var == 0.0 && s.von_neumann[i].is_nan());
        } else {
            assert_eq!(s.von_neumann[i], vn as f64 / (n - 1.0) / (2.0 * var));
        }
    }
}

#[test]
fn clipping_takes_exactly_the_rejected_samples_out() {
    let d = tempfile::tempdir().unwrap();
    let stack = write(&d.path().join("s.fits"));
    let s = pixel_stats(&stack, Clip::Extremes(2), None).unwrap();
    let k = 2.5;
    let sigma = pixel_stats(&stack, Clip::Sigma(k), None).unwrap();
    for i in 0..SHAPE.0 * SHAPE.1 {
        let mut x: Vec<i64> = (0..FRAMES).map(|f| sample(f, i)).collect();
        // Sigma clipping keeps samples within k standard deviations of the first pass's mean.
        let (m, var) = exact(&x);
        let (lo, hi) = (m - k * var.sqrt(), m + k * var.sqrt());
        let kept: Vec<i64> = x
            .iter()
            .copied()
            .filter(|v| (lo..=hi).contains(&(*v as f64)))
            .collect();
        let (mean, var) = exact(&kept);
        assert_eq!(sigma.count[i], kept.len() as f64, "pixel {i}");
        assert_eq!((sigma.mean.data[i], sigma.rms.data[i]), (mean, var.sqrt()));
        x.sort_unstable();
        let (mean, var) = exact(&x[2..FRAMES - 2]);
        assert_eq!(s.count[i], (FRAMES - 4) as f64);
        assert_eq!(
            (s.mean.data[i], s.rms.data[i]),
            (mean, var.sqrt()),
            "pixel {i}"
        );
    }
    // The cosmic ray is one of the samples sigma clipping rejects.
    assert!(sigma.count[3] < FRAMES as f64);
}

#[test]
fn checksummed_maps_are_the_maps_with_the_files_digests() {
    let d = tempfile::tempdir().unwrap();
    let (a, b) = (d.path().join("a.fits"), d.path().join("b.fits"));
    write(&a);
    write(&b);
    let paths = vec![a, b];
    let stack = FrameStack::open(&paths).unwrap();
    for (clip, common_mode, algorithm) in [
        (Clip::None, false, Checksum::Blake3),
        (Clip::Extremes(3), false, Checksum::Sha256),
        (Clip::Sigma(3.0), false, Checksum::Blake3),
        (Clip::None, true, Checksum::Sha256),
    ] {
        let opts = DarkOptions {
            clip,
            common_mode,
            ..DarkOptions::default()
        };
        let plain = dark_maps(&stack, &opts).unwrap();
        let (maps, inputs) = dark_maps_hashed(&stack, &opts, algorithm).unwrap();
        assert_eq!(maps.offset_adu, plain.offset_adu, "{clip:?}");
        assert_eq!(maps.rms_adu, plain.rms_adu, "{clip:?}");
        assert_eq!(maps.flags, plain.flags, "{clip:?}");
        assert_eq!(maps.common_mode_adu, plain.common_mode_adu, "{clip:?}");
        let digests: Vec<Option<String>> = inputs
            .into_iter()
            .map(|i| match algorithm {
                Checksum::Blake3 => i.blake3.filter(|_| i.sha256.is_none()),
                Checksum::Sha256 => i.sha256.filter(|_| i.blake3.is_none()),
            })
            .collect();
        let want: Vec<Option<String>> = paths
            .iter()
            .map(|p| Some(crate::io::one_shot_digest(p, algorithm)))
            .collect();
        assert_eq!(digests, want, "{clip:?}");
    }
}

/// The temporal noise `darks --common-mode` finds in 40 x 48 pixels, 100 frames: a fixed
/// pattern of 0-50 adu, 4 adu of pixel noise, 3 adu common to each frame, no row or column
/// noise; stored as integers (rounded) or as floats, from the same draws.
fn common_mode_noise(integers: bool) -> TemporalNoise {
    use rand_distr::{Distribution, StandardNormal};
    let shape = (40, 48);
    let npix = shape.0 * shape.1;
    let mut rng = crate::rng::stream(31, 0, 0xc0);
    let mut g = move || -> f64 { StandardNormal.sample(&mut rng) };
    let pattern: Vec<f64> = (0..npix)
        .map(|i| ((i * 7919) % 5003) as f64 / 100.0)
        .collect();
    let d = tempfile::tempdir().unwrap();
    let path = d.path().join("cm.fits");
    let mut next = || {
        let common = 3.0 * g();
        pattern
            .iter()
            .map(|o| 1000.0 + o + common + 4.0 * g())
            .collect()
    };
    crate::io::fits::write_cube(&path, shape, 100, integers, &mut next, &[]).unwrap();
    let stack = FrameStack::open(&[path]).unwrap();
    let opts = DarkOptions {
        common_mode: true,
        ..DarkOptions::default()
    };
    dark_maps(&stack, &opts).unwrap().stats.temporal
}

#[test]
fn common_mode_on_integer_frames_leaves_no_rounding_residue() {
    let (t, float) = (common_mode_noise(true), common_mode_noise(false));
    let (row, col) = (t.row.unwrap(), t.column.unwrap());
    assert!(row.0.abs() < 4.0 * row.1, "{t:?}");
    assert!(col.0.abs() < 4.0 * col.1, "{t:?}");
    // What the level's own sampling noise leaves common to the frames (0.040 adu^2 here: a
    // median is noisy over a broad fixed pattern) is that of the float frames; integer
    // medians added the rounding's 1 / 12 adu^2 (0.113 adu^2 in all).
    let (f, f_float) = (t.frame.unwrap().0, float.frame.unwrap().0);
    assert!((f - f_float).abs() < 0.25 / 12.0, "{t:?} vs {float:?}");
    // Pixel noise: 16 adu^2 and the rounding's 1 / 12.
    assert!(
        (t.pixel.0 - 16.0 - 1.0 / 12.0).abs() < 4.0 * t.pixel.1,
        "{t:?}"
    );
}
