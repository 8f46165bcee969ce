//! The `camera` readout on the command line: `simulate --model camera --camera DIR` at an
//! operating point runs, and the operating point's refusals name their option.

mod common;

use common::detnoise;
use detnoise::calib::{Map, Unit};
use detnoise::camera::{CameraModel, DarkCurrent};

fn write_camera(dir: &std::path::Path) {
    CameraModel::new(
        Map::filled(16, 16, 100.0, Unit::Adu),
        0.5,
        Map::filled(16, 16, 1.2, Unit::Electrons),
        16,
    )
    .unwrap()
    .with_common_noise(0.1, 0.1, 0.2)
    .unwrap()
    .with_dark_current(DarkCurrent {
        map_e_per_s: Map::filled(16, 16, 50.0, Unit::Flags),
        reference_temperature_c: None,
        doubling_temperature_c: None,
    })
    .unwrap()
    .write(dir, false, &[])
    .unwrap();
}

#[test]
fn simulate_reads_through_the_camera_at_its_frame_rate() {
    let d = tempfile::tempdir().unwrap();
    let cam = d.path().join("cam");
    write_camera(&cam);
    let out = d.path().join("r.txt");
    detnoise()
        .args(["simulate", "--model", "camera", "--camera"])
        .arg(&cam)
        .args(["--frame-rate-hz", "100", "--subap", "8", "--signal", "100"])
        .args(["--iters", "1000"])
        .arg("--out")
        .arg(&out)
        .assert()
        .success();
    let table = std::fs::read_to_string(&out).unwrap();
    eprintln!("{table}");
    assert!(table.contains("camera"), "{table}");
}

#[test]
fn the_operating_point_is_refused_naming_its_option() {
    let d = tempfile::tempdir().unwrap();
    let cam = d.path().join("cam");
    write_camera(&cam);
    for (extra, says) in [
        (
            vec![],
            "invalid option --exposure-s: the camera model is read at an operating point",
        ),
        (
            vec!["--exposure-s", "1", "--em-gain", "10"],
            "invalid option --em-gain: 10: this camera has no EM register",
        ),
        (
            vec!["--exposure-s", "1", "--temperature-c", "5"],
            "invalid option --temperature-c",
        ),
    ] {
        let a = detnoise()
            .args(["simulate", "--model", "camera", "--camera"])
            .arg(&cam)
            .args(&extra)
            .args(["--iters", "1000"])
            .assert()
            .failure();
        let err = String::from_utf8_lossy(&a.get_output().stderr).into_owned();
        assert!(err.contains(says), "{extra:?}: {err}");
    }
    let a = detnoise()
        .args(["simulate", "--exposure-s", "1"])
        .args(["--iters", "1000"])
        .assert()
        .failure();
    let err = String::from_utf8_lossy(&a.get_output().stderr).into_owned();
    assert!(err.contains("applies only with --camera"), "{err}");
}
