//! Photon transfer against known truth: the global gain within its stated uncertainty,
//! per-pixel gains with correct errors, and lamp flicker removal.

mod common;

use common::open;

use std::path::{Path, PathBuf};

use detnoise::calib::darks::{pixel_stats, Clip};
use detnoise::calib::ptc::{photon_transfer, write_points, DarkReference, PtcOptions};
use detnoise::io::FrameStack;
use detnoise::synth::SynthFormat;
use detnoise::synth::{draw_truth, frame, write_synthetic, Camera, ScmosParams, SynthSpec};

const LEVELS: [f64; 4] = [100.0, 400.0, 1600.0, 6400.0];

fn spec(frames: usize, light_e: f64) -> SynthSpec {
    SynthSpec {
        camera: Camera::Scmos(ScmosParams::default()),
        shape: (40, 56),
        frames,
        light_e,
        seed: 5,
        u16_samples: true,
    }
}

/// Darks and flats written by `synth`; returns (dark path, flat paths).
fn series(dir: &Path, frames: usize) -> (PathBuf, Vec<PathBuf>) {
    let pdf = detnoise::pdf::paper();
    let dark = dir.join("dark.fits");
    write_synthetic(&spec(frames, 0.0), &pdf, SynthFormat::Fits, &dark).unwrap();
    let flats = LEVELS
        .iter()
        .map(|l| {
            let p = dir.join(format!("flat-{l}.fits"));
            write_synthetic(&spec(frames, *l), &pdf, SynthFormat::Fits, &p).unwrap();
            p
        })
        .collect();
    (dark, flats)
}

/// The gain a pixel-averaged PTC measures when pixel gains g differ:
/// mean(m) / mean(v) = mean(1/g) / mean(1/g^2) (signal n e-: m = n/g, v = n/g^2).
fn ptc_equivalent_gain(g: &[f64]) -> f64 {
    let a = g.iter().map(|g| 1.0 / g).sum::<f64>();
    let b = g.iter().map(|g| 1.0 / (g * g)).sum::<f64>();
    a / b
}

#[test]
fn global_and_per_pixel_gain_match_truth() {
    let d = tempfile::tempdir().unwrap();
    let (dark, flats) = series(d.path(), 100);
    let dref = DarkReference::from_stats(&pixel_stats(&open(&dark), Clip::None, None).unwrap());
    let flats: Vec<FrameStack> = flats.iter().map(|p| open(p)).collect();
    let r = photon_transfer(&flats, &dref, &PtcOptions::default()).unwrap();
    let truth = draw_truth(&spec(1, 0.0), &detnoise::pdf::paper());
    let g_true = ptc_equivalent_gain(&truth.gain_e_per_adu.data);
    let pull = (r.gain_e_per_adu - g_true) / r.gain_err_e_per_adu;
    eprintln!(
        "global gain {:.5} +/- {:.5} e/adu, truth {g_true:.5}, pull {pull:.2}",
        r.gain_e_per_adu, r.gain_err_e_per_adu
    );
    // Within 3 stated standard errors (a 0.3 % chance of failing were the error exact).
    assert!(pull.abs() < 3.0);
    // Per-pixel pulls: mean 0 and std 1 over P = 2240 pixels, standard errors
    // 1/sqrt(P) = 0.021 and 1/sqrt(2P) = 0.015; 5 of them plus 0.05 for the Gaussian
    // approximation of the variance error (Poisson + read noise, 100 frames).
    let z: Vec<f64> = (0..r.gain_map.data.len())
        .map(|i| (r.gain_map.data[i] - truth.gain_e_per_adu.data[i]) / r.gain_err_map.data[i])
        .collect();
    let n = z.len() as f64;
    let m = z.iter().sum::<f64>() / n;
    let s = (z.iter().map(|x| (x - m) * (x - m)).sum::<f64>() / (n - 1.0)).sqrt();
    eprintln!("per-pixel gain pulls: mean {m:.3} (tol 0.16), std {s:.3} (tol 1 +/- 0.13)");
    assert!(m.abs() < 0.105 + 0.05 && (s - 1.0).abs() < 0.075 + 0.05);
    assert!(r.levels.iter().all(|l| l.saturated_pixels == 0));
}

#[test]
fn lamp_flicker_is_removed() {
    let d = tempfile::tempdir().unwrap();
    let frames = 100;
    let pdf = detnoise::pdf::paper();
    let dark = d.path().join("dark.fits");
    write_synthetic(&spec(frames, 0.0), &pdf, SynthFormat::Fits, &dark).unwrap();
    let truth = draw_truth(&spec(frames, 0.0), &pdf);
    // Each frame's signal scaled by 1 + 2 % x (a fixed pseudo-random pattern): the
    // flicker adds (0.02 m)^2 to every variance, 8x the shot noise at m = 6400 e- / 0.25.
    let flats: Vec<FrameStack> = LEVELS
        .iter()
        .map(|&l| {
            let sp = spec(frames, l);
            let fr: Vec<Vec<f64>> = (0..frames)
                .map(|k| {
                    let s = 1.0 + 0.02 * (((k * 7919) % 101) as f64 / 50.0 - 1.0);
                    frame(&sp, &truth, None, k)
                        .iter()
                        .zip(&truth.offset_adu.data)
                        .map(|(x, o)| o + (x - o) * s)
                        .collect()
                })
                .collect();
            let p = d.path().join(format!("flicker-{l}.fits"));
            let mut it = fr.into_iter();
            detnoise::io::fits::write_cube(
                &p,
                sp.shape,
                frames,
                true,
                &mut || it.next().unwrap(),
                &[],
            )
            .unwrap();
            open(&p)
        })
        .collect();
    let dref = DarkReference::from_stats(&pixel_stats(&open(&dark), Clip::None, None).unwrap());
    let g_true = ptc_equivalent_gain(&truth.gain_e_per_adu.data);
    let with = photon_transfer(&flats, &dref, &PtcOptions::default()).unwrap();
    let without = photon_transfer(
        &flats,
        &dref,
        &PtcOptions {
            flicker: false,
            ..Default::default()
        },
    )
    .unwrap();
    let pull = (with.gain_e_per_adu - g_true) / with.gain_err_e_per_adu;
    eprintln!(
        "flicker: removed {:.5} +/- {:.5}, kept {:.5}, truth {g_true:.5}",
        with.gain_e_per_adu, with.gain_err_e_per_adu, without.gain_e_per_adu
    );
    assert!(pull.abs() < 3.0, "pull {pull}");
    assert!(
        without.gain_e_per_adu < 0.8 * g_true,
        "flicker inflates variance, so the kept-flicker gain is low"
    );
    assert!(
        with.levels.iter().all(|l| l.flicker_fraction > 0.005),
        "flicker is reported"
    );
}

#[test]
fn saturated_pixels_are_masked() {
    let d = tempfile::tempdir().unwrap();
    let (dark, _) = series(d.path(), 20);
    // 60000 e- at 0.25 e/adu is 240000 adu: every pixel saturates the uint16 range.
    let sp = spec(20, 60000.0);
    let p = d.path().join("bright.fits");
    write_synthetic(&sp, &detnoise::pdf::paper(), SynthFormat::Fits, &p).unwrap();
    let dref = DarkReference::from_stats(&pixel_stats(&open(&dark), Clip::None, None).unwrap());
    let e = photon_transfer(&[open(&p)], &dref, &PtcOptions::default())
        .unwrap_err()
        .to_string();
    assert!(e.contains("saturated"), "{e}");
}

#[test]
fn the_written_points_reproduce_the_fitted_gain_and_each_level_measures_it() {
    let d = tempfile::tempdir().unwrap();
    let (dark, flats) = series(d.path(), 100);
    let dref = DarkReference::from_stats(&pixel_stats(&open(&dark), Clip::None, None).unwrap());
    let flats: Vec<FrameStack> = flats.iter().map(|p| open(p)).collect();
    let r = photon_transfer(&flats, &dref, &PtcOptions::default()).unwrap();
    let out = d.path().join("points");
    std::fs::create_dir(&out).unwrap();
    let written = write_points(&r, &out).unwrap();
    assert_eq!(
        written,
        [out.join("ptc_points.csv"), out.join("ptc_points.json")]
    );
    let csv = std::fs::read_to_string(&written[0]).unwrap();
    let mut lines = csv.lines();
    assert_eq!(
        lines.next(),
        Some(
            "level,frames,pixels,mean_adu,var_adu2,var_se_adu2,gain_e_per_adu,\
             gain_se_e_per_adu,flicker_fraction,saturated_pixels"
        )
    );
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&written[1]).unwrap()).unwrap();
    let json = json.as_array().unwrap();
    assert_eq!((json.len(), lines.count()), (LEVELS.len(), LEVELS.len()));
    // (mean, variance, its SE, level gain, its SE) as written in full precision (JSON; the
    // CSV rounds to 6 decimals).
    let rows: Vec<[f64; 5]> = json
        .iter()
        .enumerate()
        .map(|(k, p)| {
            assert_eq!(p["level"], k + 1);
            assert_eq!(p["frames"], 100, "frames used");
            let f = |c: &str| p[c].as_f64().unwrap();
            [
                f("mean_adu"),
                f("var_adu2"),
                f("var_se_adu2"),
                f("gain_e_per_adu"),
                f("gain_se_e_per_adu"),
            ]
        })
        .collect();
    // The weighted straight line through the written points is the fit that gave the gain.
    let (mut s, mut sx, mut sy, mut sxx, mut sxy) = (0.0, 0.0, 0.0, 0.0, 0.0);
    for [m, v, se, _, _] in &rows {
        let w = 1.0 / (se * se);
        s += w;
        sx += w * m;
        sy += w * v;
        sxx += w * m * m;
        sxy += w * m * v;
    }
    let slope = (s * sxy - sx * sy) / (s * sxx - sx * sx);
    let refit = 1.0 / slope;
    assert!(
        ((refit - r.gain_e_per_adu) / r.gain_e_per_adu).abs() < 1e-12,
        "refit {refit} against {}",
        r.gain_e_per_adu
    );
    // Each level's own gain m / v measures the same truth within its stated error: 4 SE per
    // level (a 6e-5 chance each were the errors exact); the dark subtraction leaves no
    // intercept to bias m / v beyond that.
    let truth = draw_truth(&spec(1, 0.0), &detnoise::pdf::paper());
    let g_true = ptc_equivalent_gain(&truth.gain_e_per_adu.data);
    for [m, v, _, g, se] in &rows {
        assert!(
            (g - m / v).abs() < 1e-12 * g,
            "gain column is mean / variance"
        );
        let pull = (g - g_true) / se;
        eprintln!(
            "level at {m:.0} adu: gain {g:.5} +/- {se:.5}, truth {g_true:.5}, pull {pull:.2}"
        );
        assert!(pull.abs() < 4.0, "pull {pull}");
    }
}

/// Frames of `shape` written as a uint16 FITS cube at `p`, each pixel `offset + draw() / k`
/// (adu; `draw` gives electrons, read noise included).
fn write_flat(
    p: &Path,
    shape: (usize, usize),
    frames: usize,
    k: f64,
    mut draw: impl FnMut() -> f64,
) -> PathBuf {
    let mut next = || {
        (0..shape.0 * shape.1)
            .map(|_| (500.0 + draw() / k).round())
            .collect()
    };
    detnoise::io::fits::write_cube(p, shape, frames, true, &mut next, &[]).unwrap();
    p.to_path_buf()
}

/// A `ptc` run of darks and flats at `levels` (mean e- per pixel) made here, not by `synth`:
/// 64x64 pixels, 64 frames, conversion gain `k` (e/adu), read noise `read_e` (e-), and an EM
/// register of gain `em` when given (each photo-electron's output Gamma/exponential, F^2 = 2).
fn own_flats_run(
    dir: &Path,
    levels: &[f64],
    k: f64,
    read_e: f64,
    em: Option<f64>,
    options: PtcOptions,
) -> detnoise::calib::ptc::PtcRunResult {
    use rand_distr::{Distribution, Gamma, Normal, Poisson};
    let (shape, frames) = ((64, 64), 64);
    let mut rng = detnoise::rng::stream(31, 0, 0);
    let read = Normal::new(0.0, read_e).unwrap();
    let darks = write_flat(&dir.join("dark.fits"), shape, frames, k, || {
        read.sample(&mut rng)
    });
    let flats = levels
        .iter()
        .map(|&l| {
            let light = Poisson::new(l).unwrap();
            write_flat(
                &dir.join(format!("flat-{l}.fits")),
                shape,
                frames,
                k,
                || {
                    let n: f64 = light.sample(&mut rng);
                    let e = match em {
                        Some(g) if n > 0.0 => Gamma::new(n, g).unwrap().sample(&mut rng),
                        Some(_) => 0.0,
                        None => n,
                    };
                    e + read.sample(&mut rng)
                },
            )
        })
        .collect();
    detnoise::calib::ptc::run(&detnoise::calib::ptc::PtcRun {
        darks: detnoise::calib::ptc::DarkInput::Stack(darks),
        flats,
        out: dir.join("out"),
        force: false,
        options,
    })
    .unwrap()
}

#[test]
fn emccd_flats_without_em_gain_are_flagged_and_with_it_give_the_gain() {
    use detnoise::calib::ptc::ExcessVerdict;
    // K = 10 e/adu, read noise 50 e-, G = 100: without --em-gain the slope is G F^2 / K, the
    // gain 10 / 200 = 0.05 e/adu.
    let levels = [20.0, 50.0, 100.0, 200.0];
    let d = tempfile::tempdir().unwrap();
    let r = own_flats_run(
        d.path(),
        &levels,
        10.0,
        50.0,
        Some(100.0),
        PtcOptions::default(),
    );
    let (p, s) = (&r.result, &r.summary);
    let x = &p.excess_noise;
    eprintln!(
        "no --em-gain: gain {:.5} e/adu, excess ratio {:.3} +/- {:.3}, {:?}",
        p.gain_e_per_adu, x.ratio, x.ratio_se, x.verdict
    );
    assert!(
        (p.gain_e_per_adu / 0.05 - 1.0).abs() < 0.1,
        "the trap is real"
    );
    assert_eq!(x.verdict, ExcessVerdict::EmRegister);
    assert!(
        p.warnings.iter().any(|w| w.contains("--em-gain")),
        "{:?}",
        p.warnings
    );
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(r.out.join("ptc.json")).unwrap()).unwrap();
    assert_eq!(json["excess_noise"]["verdict"], "em_register");
    assert_eq!(json["warnings"].as_array().unwrap().len(), s.warnings.len());
    assert!(json["warnings"][0].as_str().unwrap().contains("--em-gain"));
    // Told the EM gain and F^2, the same flats give K = 10 and no warning.
    let d = tempfile::tempdir().unwrap();
    let told = PtcOptions {
        em_gain: 100.0,
        excess_noise_factor_sq: 2.0,
        ..Default::default()
    };
    let p = own_flats_run(d.path(), &levels, 10.0, 50.0, Some(100.0), told).result;
    let pull = (p.gain_e_per_adu - 10.0) / p.gain_err_e_per_adu;
    eprintln!(
        "--em-gain 100: gain {:.4} +/- {:.4} e/adu (pull {pull:.2}), {:?}",
        p.gain_e_per_adu, p.gain_err_e_per_adu, p.excess_noise.verdict
    );
    assert!(pull.abs() < 4.0, "pull {pull}");
    assert_eq!(p.excess_noise.verdict, ExcessVerdict::EmRegister);
    assert!(p.warnings.is_empty(), "{:?}", p.warnings);
}

#[test]
fn one_light_level_has_no_reduced_chi2_and_says_so() {
    use detnoise::calib::ptc::ExcessVerdict;
    // sCMOS: K = 0.5 e/adu, read noise 1.5 e-, one level of 100 e-.
    let d = tempfile::tempdir().unwrap();
    let r = own_flats_run(d.path(), &[100.0], 0.5, 1.5, None, PtcOptions::default());
    let p = &r.result;
    eprintln!(
        "one level: gain {:.4} +/- {:.4} e/adu, excess ratio {:.3} +/- {:.3}",
        p.gain_e_per_adu, p.gain_err_e_per_adu, p.excess_noise.ratio, p.excess_noise.ratio_se
    );
    assert_eq!(p.reduced_chi2, None);
    assert!((p.gain_e_per_adu - 0.5).abs() < 4.0 * p.gain_err_e_per_adu);
    // Plain shot noise is told apart from an EM register, so no EM warning.
    assert_eq!(p.excess_noise.verdict, ExcessVerdict::ShotNoise);
    assert_eq!(p.warnings.len(), 1, "{:?}", p.warnings);
    assert!(p.warnings[0].contains("cannot be checked"));
    let text = std::fs::read_to_string(r.out.join("ptc.json")).unwrap();
    assert!(!text.contains("NaN"));
    let json: serde_json::Value = serde_json::from_str(&text).unwrap();
    assert!(json["reduced_chi2"].is_null());
    assert_eq!(json["fit_check"], "no_degrees_of_freedom");
}

#[test]
fn em_gain_given_for_plain_shot_noise_flats_is_warned_of() {
    // sCMOS flats (K = 0.5 e/adu) analysed as if an EM register of G = 100 had amplified them.
    let d = tempfile::tempdir().unwrap();
    let told = PtcOptions {
        em_gain: 100.0,
        excess_noise_factor_sq: 2.0,
        ..Default::default()
    };
    let p = own_flats_run(d.path(), &[50.0, 100.0, 200.0], 0.5, 1.5, None, told).result;
    eprintln!(
        "sCMOS told G = 100: excess ratio {:.3} +/- {:.3}",
        p.excess_noise.ratio, p.excess_noise.ratio_se
    );
    assert_eq!(p.warnings.len(), 1, "{:?}", p.warnings);
    assert!(p.warnings[0].contains("plain shot noise"));
}
