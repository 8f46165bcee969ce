//! `report --camera` (issue 31): the report's camera section on a camera model folder. Without
//! --exposure-s or --frame-rate-hz the camera runs at its campaign's shortest dark exposure,
//! said on the terminal and in the report; its numbers are the library's `CameraAt`'s; a point
//! beyond the campaign is warned of.

mod common;

use common::{data, detnoise};
use detnoise::calib::{Map, Unit};
use detnoise::camera::{CameraChoice, CameraModel, DarkCurrent, OperatingRange};

/// A 16x16 sCMOS camera measured by a campaign of darks at 0.01, 0.1 and 1 s.
fn camera() -> CameraModel {
    let rn: Vec<f64> = (0..256).map(|i| 1.0 + 0.01 * (i % 37) as f64).collect();
    CameraModel::new(
        Map::filled(16, 16, 100.0, Unit::Adu),
        0.25,
        Map::new(16, 16, rn, Unit::Electrons),
        16,
    )
    .unwrap()
    .with_common_noise(0.1, 0.15, 0.3)
    .unwrap()
    .with_dark_current(DarkCurrent {
        map_e_per_s: Map::filled(16, 16, 40.0, Unit::Flags),
        reference_temperature_c: None,
        doubling_temperature_c: None,
    })
    .unwrap()
    .with_campaign(OperatingRange {
        exposures_s: vec![0.01, 0.1, 1.0],
        em_gains: vec![],
        temperatures_c: vec![],
    })
    .unwrap()
}

#[test]
fn report_states_the_camera_at_the_campaigns_default_rate() {
    let d = tempfile::tempdir().unwrap();
    let cam = d.path().join("cam");
    camera().write(&cam, false, &[]).unwrap();
    let out = d.path().join("report");
    let a = detnoise()
        .args(["report", "--gain-e-per-adu", "0.25", "--quick", "--darks"])
        .arg(data("scmos-darks-64x64.fits"))
        .arg("--camera")
        .arg(&cam)
        .arg("--out")
        .arg(&out)
        .assert()
        .success();
    let err = String::from_utf8_lossy(&a.get_output().stderr).into_owned();
    assert!(
        err.contains("no --exposure-s or --frame-rate-hz given: exposure 0.01 s (100 Hz)"),
        "{err}"
    );
    assert!(
        err.contains("camera model at 100.000000 Hz (0.010000 s exposure: the campaign's"),
        "{err}"
    );
    // The numbers are the library's camera at 0.01 s.
    let choice = CameraChoice::new(camera(), None, None, None).unwrap();
    let text = std::fs::read_to_string(out.join("summary.json")).unwrap();
    let summary: serde_json::Value = serde_json::from_str(&text).unwrap();
    let c = &summary["camera"];
    assert_eq!(c["exposure_choice"], "campaign_shortest");
    assert_eq!(c["frame_rate_hz"], 100.0);
    let eff = c["effective_read_noise_e"].as_f64().unwrap();
    assert_eq!(eff, choice.at.effective_read_noise_e());
    assert_eq!(c["dark_current_signal_e"], 0.4);
    assert_eq!(c["extrapolates"].as_array().unwrap().len(), 0);
    // The camera readout ran at the report's operating point (8 px, airy:2, 50 photons).
    let m = &c["monte_carlo"];
    assert_eq!(m["subap_px"], 8, "{c}");
    assert!(m["r_px"].as_f64().unwrap() > 0.0, "{c}");
    // The curve: units in the header, the campaign's exposures and the point marked.
    let csv = std::fs::read_to_string(out.join("camera_noise.csv")).unwrap();
    let header = csv.lines().next().unwrap();
    for column in [
        "frame_rate_hz",
        "exposure_s",
        "point",
        "effective_read_noise_e",
    ] {
        assert!(header.split(',').any(|h| h == column), "{header}");
    }
    assert_eq!(csv.matches(",campaign,").count(), 3, "{csv}");
    assert_eq!(csv.matches(",operating_point,").count(), 1, "{csv}");
    for f in ["camera_noise.png", "camera_noise.svg", "camera_noise.json"] {
        assert!(out.join(f).is_file(), "{f}");
    }
    let html = std::fs::read_to_string(out.join("index.html")).unwrap();
    assert!(
        html.contains("The camera model at its operating point"),
        "no camera section"
    );
    assert!(html.contains("camera_noise.png"));
}

#[test]
fn a_point_beyond_the_campaign_is_warned_of() {
    let d = tempfile::tempdir().unwrap();
    let cam = d.path().join("cam");
    camera().write(&cam, false, &[]).unwrap();
    let a = detnoise()
        .args(["simulate", "--model", "camera", "--camera"])
        .arg(&cam)
        .args(["--frame-rate-hz", "2000", "--subap", "8", "--signal", "100"])
        .args(["--iters", "500"])
        .assert()
        .success();
    let err = String::from_utf8_lossy(&a.get_output().stderr).into_owned();
    assert!(
        err.contains(
            "camera model: the operating point extrapolates beyond the campaign that measured \
             it: exposure 0.0005 s (2000 Hz) outside the campaign's darks (0.01 to 1 s)"
        ),
        "{err}"
    );
    assert!(err.contains("warning: "), "{err}");
    // Inside the campaign: no warning.
    let a = detnoise()
        .args(["simulate", "--model", "camera", "--camera"])
        .arg(&cam)
        .args(["--exposure-s", "0.05", "--subap", "8", "--signal", "100"])
        .args(["--iters", "500"])
        .assert()
        .success();
    let err = String::from_utf8_lossy(&a.get_output().stderr).into_owned();
    assert!(!err.contains("camera model"), "{err}");
}

/// The camera folder `detnoise campaign` writes (tests/fixtures/campaign/scmos: darks at 0.01,
/// 0.5, 2 and 5 s) records its exposures, and a report at 1 kHz, beyond them, says it
/// extrapolates: on the terminal, in summary.json and on the page.
#[test]
fn a_campaigns_camera_in_a_report_beyond_its_exposures() {
    let fixture =
        std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/fixtures/campaign/scmos");
    let d = tempfile::tempdir().unwrap();
    let campaign = d.path().join("campaign");
    detnoise()
        .arg("campaign")
        .arg("--manifest")
        .arg(fixture.join("manifest.csv"))
        .args(["--gain-e-per-adu", "0.5", "--out"])
        .arg(&campaign)
        .assert()
        .success();
    let cam = campaign.join("camera");
    let model = CameraModel::read(&cam).unwrap();
    assert_eq!(
        model.campaign,
        Some(OperatingRange {
            exposures_s: vec![0.01, 0.5, 2.0, 5.0],
            em_gains: vec![],
            temperatures_c: vec![],
        })
    );
    let out = d.path().join("report");
    let a = detnoise()
        .args(["report", "--gain-e-per-adu", "0.5", "--quick", "--darks"])
        .arg(fixture.join("scmos-t0.010s.fits"))
        .arg("--camera")
        .arg(&cam)
        .args(["--frame-rate-hz", "1000", "--out"])
        .arg(&out)
        .assert()
        .success();
    let err = String::from_utf8_lossy(&a.get_output().stderr).into_owned();
    let says = "exposure 0.001 s (1000 Hz) outside the campaign's darks (0.01 to 5 s)";
    assert!(
        err.contains(&format!(
            "extrapolates beyond the campaign that measured it: {says}"
        )),
        "{err}"
    );
    assert!(
        err.contains("0.001000 s exposure: 1 / the frame rate given, no EM gain"),
        "{err}"
    );
    let text = std::fs::read_to_string(out.join("summary.json")).unwrap();
    let summary: serde_json::Value = serde_json::from_str(&text).unwrap();
    let c = &summary["camera"];
    assert_eq!(c["exposure_choice"], "frame_rate");
    assert_eq!(c["extrapolates"][0], says);
    let at = CameraChoice::new(
        model,
        Some((0.001, detnoise::camera::ExposureChoice::FrameRate)),
        None,
        None,
    )
    .unwrap();
    assert_eq!(
        c["effective_read_noise_e"].as_f64().unwrap(),
        at.at.effective_read_noise_e()
    );
    let html = std::fs::read_to_string(out.join("index.html")).unwrap();
    assert!(
        html.contains("<b>extrapolates</b> beyond the campaign"),
        "no extrapolation on the page"
    );
}
