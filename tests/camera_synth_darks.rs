//! A camera model's dark frames at an operating point (`synth --camera`), measured by `darks`:
//! offset (with the dark signal), rms (read + dark shot + CIC + common noise) and mean dark
//! signal within 4 SE of `CameraModel::at`; and `synth --camera`'s refusals.

mod common;

use std::path::Path;

use common::detnoise;
use detnoise::calib::{Map, Unit};
use detnoise::camera::{CameraModel, DarkCurrent, OperatingPoint};

const GAIN: f64 = 0.5;

/// An 8x8 camera: offsets, read noise and dark current vary over the pixels; CIC, row, column
/// and frame noise; the dark current doubles every 6 C from -20 C.
fn camera() -> CameraModel {
    let n = 64;
    let offset = (0..n).map(|i| 100.0 + 0.5 * i as f64).collect();
    let rn = (0..n).map(|i| 1.0 + 0.1 * (i % 5) as f64).collect();
    let dark = (0..n).map(|i| 0.2 + 0.02 * i as f64).collect();
    CameraModel::new(
        Map::new(8, 8, offset, Unit::Adu),
        GAIN,
        Map::new(8, 8, rn, Unit::Electrons),
        16,
    )
    .unwrap()
    .with_common_noise(0.2, 0.1, 0.3)
    .unwrap()
    .with_dark_current(DarkCurrent {
        map_e_per_s: Map::new(8, 8, dark, Unit::Flags),
        reference_temperature_c: Some(-20.0),
        doubling_temperature_c: Some(6.0),
    })
    .unwrap()
    .with_cic(Map::filled(8, 8, 0.05, Unit::Electrons))
    .unwrap()
}

fn read_map(p: &Path) -> Vec<f64> {
    detnoise::io::read_image(p).unwrap().data
}

#[test]
fn darks_of_synthesised_frames_recover_the_operating_point() {
    let d = tempfile::tempdir().unwrap();
    let model = d.path().join("cam");
    camera().write(&model, false, &[]).unwrap();
    let stack = d.path().join("s.fits");
    let frames = 2000;
    detnoise()
        .args(["synth", "--camera"])
        .arg(&model)
        .args([
            "--exposure-s",
            "4",
            "--temperature-c",
            "-14",
            "--frames",
            "2000",
            "--float",
        ])
        .arg("--out")
        .arg(&stack)
        .assert()
        .success();
    let out = d.path().join("d");
    detnoise()
        .arg("darks")
        .arg(&stack)
        .arg("--out")
        .arg(&out)
        .assert()
        .success();
    let op = OperatingPoint {
        exposure_s: 4.0,
        em_gain: None,
        temperature_c: Some(-14.0),
    };
    let at = camera().at(op).unwrap();
    let offset = read_map(&out.join("offset_adu.fits"));
    let rms = read_map(&out.join("rms_adu.fits"));
    let n = frames as f64;
    let (mut worst_mean, mut worst_rms): (f64, f64) = (0.0, 0.0);
    for p in 0..at.pixels() {
        let sigma = at.noise_adu(p);
        worst_mean = worst_mean.max((offset[p] - at.mean_adu(p)).abs() / (sigma / n.sqrt()));
        // SE of an rms: sigma / sqrt(2 N), widened for the dark signal's Poisson tail.
        worst_rms = worst_rms.max((rms[p] - sigma).abs() / (1.2 * sigma / (2.0 * n).sqrt()));
    }
    eprintln!("worst pixel: offset {worst_mean:.2} SE, rms {worst_rms:.2} SE");
    assert!(worst_mean < 4.0, "offset off by {worst_mean} SE");
    assert!(worst_rms < 4.0, "rms off by {worst_rms} SE");
    // The mean dark signal over the pixels, e-: the frame and line noise do not average out
    // over the pixels of a frame, so its SE keeps them whole.
    let npx = at.pixels() as f64;
    let measured: f64 = (0..at.pixels())
        .map(|p| (offset[p] - at.offset_adu[p]) * GAIN)
        .sum::<f64>()
        / npx;
    let truth: f64 = at.dark_e.iter().sum::<f64>() / npx;
    let own: f64 = (0..at.pixels())
        .map(|p| at.pixel_variance_e2(p))
        .sum::<f64>()
        / npx;
    let se = ((own / npx + at.common_variance_e2()) / n).sqrt();
    assert!(
        (measured - truth).abs() < 4.0 * se,
        "dark {measured} vs {truth} e- (se {se})"
    );
    // The master dark beside the stack, and its standard error (e-).
    let master = read_map(&d.path().join("s.master_dark_adu.fits"));
    for p in 0..at.pixels() {
        assert!(
            (master[p] - offset[p]).abs() < 1e-3,
            "{p}: {} vs {}",
            master[p],
            offset[p]
        );
    }
    let se_e = read_map(&d.path().join("s.master_dark_se_e.fits"));
    assert!((se_e[0] - (at.total_variance_e2(0) / n).sqrt()).abs() < 1e-12);
}

#[test]
fn synth_refuses_operating_points_the_camera_cannot_run_at() {
    let d = tempfile::tempdir().unwrap();
    let model = d.path().join("cam");
    let plain = CameraModel::new(
        Map::filled(4, 4, 100.0, Unit::Adu),
        1.0,
        Map::filled(4, 4, 1.0, Unit::Electrons),
        16,
    )
    .unwrap();
    plain.write(&model, false, &[]).unwrap();
    let out = d.path().join("s.fits");
    for (extra, says) in [
        (vec!["--exposure-s", "1", "--em-gain", "100"], "invalid option --em-gain: 100: this camera has no EM register"),
        (vec!["--exposure-s", "1", "--temperature-c", "0"], "invalid option --temperature-c: 0 degrees C: the camera model has no dark current temperature law"),
        (vec!["--exposure-s", "0"], "--exposure-s"),
        (vec![], "--exposure-s"),
    ] {
        let assert = detnoise()
            .args(["synth", "--frames", "2", "--camera"])
            .arg(&model)
            .args(&extra)
            .arg("--out")
            .arg(&out)
            .assert()
            .failure();
        let err = String::from_utf8_lossy(&assert.get_output().stderr).into_owned();
        assert!(err.contains(says), "{extra:?}: {err}");
        assert!(!out.exists(), "{extra:?} wrote the stack");
    }
}
