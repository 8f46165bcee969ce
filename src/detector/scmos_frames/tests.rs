//! Exact tests of `scmos-frames`: per-pixel moments equal the stack's, frames and windows are
//! drawn uniformly, and the errors name field or file.

use super::*;
use crate::detector::readout::sampling::dark_samples;
use crate::detector::ModelParams;
use crate::io::fits::write_cube;
use crate::rng::stream;
use crate::stats::mean_var;
use rand::RngExt;

/// Dark frames read from a u16 FITS cube of `frames` frames of `shape`, frame k from `f(k)`.
fn frames(
    shape: (usize, usize),
    count: usize,
    gain: f64,
    mut f: impl FnMut(usize) -> Vec<f64>,
) -> Arc<DarkFrames> {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("darks.fits");
    let mut k = 0;
    let mut next = || {
        k += 1;
        f(k - 1)
    };
    write_cube(&path, shape, count, true, &mut next, &[]).unwrap();
    Arc::new(DarkFrames::read(&[path], gain, 64.0).unwrap())
}

#[test]
fn each_pixel_has_the_variance_of_its_dark_frames() {
    // 50 frames of 3x3 px with integer noise of a different rms per pixel, gain 0.5; one 3x3
    // window, so the window is the whole frame. A pixel's output is a uniform draw from its 50
    // bias-subtracted values: every output is one of them, the mean is 0 and the variance
    // their population variance, within 4 SE (SE from their 4th moment).
    let mut rng = stream(3, 0, 0);
    let mut make = |_| -> Vec<f64> {
        (0..9)
            .map(|p| 200.0 + (rng.random::<f64>() * (2 + 3 * p) as f64).floor())
            .collect()
    };
    let d = frames((3, 3), 50, 0.5, &mut make);
    let m = ScmosFrames::new(d.clone(), 3).unwrap();
    assert_eq!(m.noise_scale_e(), d.rms_e());
    let n = 100_000;
    let px = dark_samples(&m, 3, n, 12);
    for (p, xs) in px.iter().enumerate() {
        let values: Vec<f64> = (0..50).map(|k| d.frame(k)[p] as f64).collect();
        assert!(xs.iter().all(|x| values.contains(x)), "pixel {p}");
        let var = values.iter().map(|v| v * v).sum::<f64>() / 50.0;
        let m4 = values.iter().map(|v| v.powi(4)).sum::<f64>() / 50.0;
        assert!(values.iter().sum::<f64>().abs() < 1e-4, "bias-subtracted: {values:?}");
        let (mean, v) = mean_var(xs);
        assert!(mean.abs() < 4.0 * (var / n as f64).sqrt(), "pixel {p}: mean {mean}");
        // Var(s^2) = (mu4 - (n - 3) / (n - 1) sigma^4) / n, exact for iid draws (pixel 0's
        // two values, +-0.25 e-, leave only the O(1/n^2) term).
        let nf = n as f64;
        let se = ((m4 - (nf - 3.0) / (nf - 1.0) * var * var) / nf).sqrt();
        assert!((v - var).abs() < 4.0 * se, "pixel {p}: var {v} vs {var}");
    }
}

#[test]
fn frames_and_windows_are_drawn_uniformly() {
    // 8 frames of 3x3 px; frame k holds 100 + s_k (1 + 3 r + c), s_k = +1 for even k, -1 for
    // odd: the stack mean is 100 and a bias-subtracted value (gain 1) names its pixel and the
    // frame's sign. Through 2x2 windows the top-left output names the window's place (4 of
    // them) and the sign: 8 outcomes of probability 1/8. Pearson's chi-square on 7 degrees of
    // freedom below 24.3 (p = 0.001).
    let d = frames((3, 3), 8, 1.0, |k| {
        let s = if k % 2 == 0 { 1.0 } else { -1.0 };
        (0..9).map(|p| 100.0 + s * (1 + p) as f64).collect()
    });
    let m = ScmosFrames::new(d, 2).unwrap();
    let n = 40_000;
    let first = &dark_samples(&m, 2, n, 2)[0];
    let mut counts = [0usize; 8];
    for &x in first {
        let (p, sign) = ((x.abs() as usize) - 1, usize::from(x < 0.0));
        let place = [0, 1, 3, 4].iter().position(|&q| q == p).expect("a window corner");
        counts[place * 2 + sign] += 1;
    }
    let expect = n as f64 / 8.0;
    let chi2: f64 = counts.iter().map(|&c| (c as f64 - expect).powi(2) / expect).sum();
    assert!(chi2 < 24.3, "chi-square {chi2}: {counts:?}");
}

#[test]
fn missing_frames_and_small_frames_are_errors() {
    let spec = ModelSpec::parse("scmos-frames").unwrap();
    let Err(e) = spec.build(&ModelParams::default(), 4) else {
        panic!("built without dark frames")
    };
    let msg = e.to_string();
    assert!(msg.starts_with("invalid `dark_frames`: "), "{msg}");
    assert!(msg.contains("`gain_e_per_adu`"), "{msg}");
    let d = frames((3, 5), 4, 1.0, |k| vec![10.0 + k as f64; 15]);
    let e = ScmosFrames::new(d.clone(), 4).unwrap_err().to_string();
    assert!(e.contains("darks.fits") && e.contains("3x5 px, smaller than the 4x4 px"), "{e}");
    let params = ModelParams {
        dark_frames: Some(d),
        ..ModelParams::default()
    };
    assert_eq!(spec.build(&params, 3).unwrap().name(), "scmos-frames");
}
