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
    // Every value is scaled by sqrt(50 / 49): the variance is the sample one (over 49).
    let d = frames((3, 3), 50, 0.5, &mut make);
    let m = ScmosFrames::new(d.clone(), 3).unwrap();
    let c = (50.0f64 / 49.0).sqrt();
    assert_eq!(m.noise_scale_e(), d.rms_e() * c);
    let n = 100_000;
    let px = dark_samples(&m, 3, n, 12);
    for (p, xs) in px.iter().enumerate() {
        let values: Vec<f64> = (0..50).map(|k| d.frame(k)[p] as f64 * c).collect();
        assert!(xs.iter().all(|x| values.contains(x)), "pixel {p}");
        let var = values.iter().map(|v| v * v).sum::<f64>() / 50.0;
        let sample: Vec<f64> = (0..50).map(|k| d.frame(k)[p] as f64).collect();
        let s2 = sample.iter().map(|v| v * v).sum::<f64>() / 49.0;
        assert!((var - s2).abs() <= 1e-12 * s2, "pixel {p}: {var} vs {s2}");
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
    let c = unbias_factor(8);
    for &x in first {
        let (p, sign) = (((x / c).abs().round() as usize) - 1, usize::from(x < 0.0));
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

#[test]
fn few_frames_give_the_r_of_the_cameras_map() {
    // A Gaussian camera, sigmas uniform in [1, 3] e-; stacks of 2, 10 and 100 of its dark
    // frames (f32, gain 1). Without the sqrt(N / (N - 1)) scale a 2-frame stack has half the
    // variance (R 0.204 px against the map's 0.269 in issue 30) and 10 frames 90 %; with it,
    // R through each stack equals R through the camera's true map within 4 combined SE
    // (40,000 frames, 8x8 px, Airy D = 2 px, S = 50). A stack is a finite set of noise
    // fields, whose own scatter the SE does not hold: the frames are larger the fewer they
    // are (512, 256, 128 px a side), so that each stack holds 8,000 or more independent
    // windows and that scatter stays well below the SE.
    use crate::calib::{Map, Unit};
    use crate::detector::scmos_map::ScmosMap;
    use rand_distr::{Distribution, StandardNormal};
    let mut cfg = crate::montecarlo::SimConfig::paper(8);
    cfg.signal_photons = 50.0;
    cfg.iters = 40_000;
    let r = |m: &dyn Readout| {
        let r = crate::montecarlo::run(&cfg, &[m], &crate::progress::Silent).unwrap();
        (r[0].r_px, r[0].r_se_px)
    };
    for (k, (count, side)) in [(2usize, 512usize), (10, 256), (100, 128)]
        .into_iter()
        .enumerate()
    {
        let mut rng = stream(11, k as u64, 0);
        let sigma: Vec<f64> = (0..side * side)
            .map(|_| rng.random_range(1.0..3.0))
            .collect();
        let mut next = || -> Vec<f64> {
            sigma
                .iter()
                .map(|s| {
                    let g: f64 = StandardNormal.sample(&mut rng);
                    1000.0 + s * g
                })
                .collect()
        };
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("darks.fits");
        write_cube(&path, (side, side), count, false, &mut next, &[]).unwrap();
        let d = Arc::new(DarkFrames::read(&[path], 1.0, 64.0).unwrap());
        let map = Arc::new(Map::new(side, side, sigma, Unit::Electrons).with_source("truth"));
        let (r_map, se_map) = r(&ScmosMap::new(map, 8).unwrap());
        let (r_frames, se) = r(&ScmosFrames::new(d.clone(), 8).unwrap());
        let se = se.hypot(se_map);
        assert!(
            (r_frames - r_map).abs() < 4.0 * se,
            "{count} frames: R {r_frames} against the map's {r_map} (SE {se})"
        );
        // The few-frame warning names the stack and its count, below 100 frames only.
        let warning = d.few_frames();
        assert_eq!(warning.is_some(), count < crate::detector::dark_frames::FEW_FRAMES, "{count}: {warning:?}");
        if let Some(w) = warning {
            assert!(w.contains("darks.fits") && w.contains(&format!("only {count} dark frames")));
        }
    }
}
