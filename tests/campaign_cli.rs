//! `detnoise campaign`'s measurement and decomposition options (issue 31) on the getframes
//! sCMOS campaign of tests/fixtures/campaign/scmos (4 dark stacks of 150 frames, 32x32 px,
//! K = 0.5 e-/adu, 0.75 adu of frame-common noise, 8 hot pixels at ~130x the median dark
//! current): each option changes what it should, and every value out of its range is refused
//! naming the option, before any output is written.

mod common;

use std::path::{Path, PathBuf};

use common::detnoise;

/// The sCMOS fixture's manifest.
fn manifest() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/fixtures/campaign/scmos/manifest.csv")
}

/// `detnoise campaign` on the fixture (K = 0.5 e-/adu, no checksums) into `out`, with `extra`.
fn campaign(out: &Path, extra: &[&str]) -> assert_cmd::assert::Assert {
    detnoise()
        .arg("campaign")
        .arg("--manifest")
        .arg(manifest())
        .args(["--gain-e-per-adu", "0.5", "--no-checksums", "--out"])
        .arg(out)
        .args(extra)
        .assert()
}

/// `campaign` on the fixture with `extra`: its conditions.csv rows (header, then one per
/// stack) and decomposition.json.
fn run(extra: &[&str]) -> (Vec<Vec<String>>, serde_json::Value) {
    let tmp = tempfile::tempdir().unwrap();
    let out = tmp.path().join("c");
    let a = campaign(&out, extra);
    let o = a.get_output();
    assert!(
        o.status.success(),
        "campaign {extra:?} failed:\n{}",
        String::from_utf8_lossy(&o.stderr)
    );
    let csv = std::fs::read_to_string(out.join("conditions.csv")).unwrap();
    let rows = csv
        .lines()
        .map(|l| l.split(',').map(str::to_string).collect())
        .collect();
    let text = std::fs::read_to_string(out.join("decomposition.json")).unwrap();
    (rows, serde_json::from_str(&text).unwrap())
}

/// Column `name` of conditions.csv, one number per stack.
fn column(rows: &[Vec<String>], name: &str) -> Vec<f64> {
    let at = rows[0].iter().position(|h| h == name).expect(name);
    rows[1..].iter().map(|r| r[at].parse().unwrap()).collect()
}

/// A number of decomposition.json at `path` (JSON pointer).
fn number(d: &serde_json::Value, path: &str) -> f64 {
    d.pointer(path)
        .and_then(|v| v.as_f64())
        .unwrap_or_else(|| panic!("decomposition.json: no number at {path}"))
}

#[test]
fn common_mode_takes_the_frame_noise_off_and_keeps_the_dark_signal() {
    let (plain, d0) = run(&[]);
    let (cm, d1) = run(&["--common-mode"]);
    let (f0, f1) = (
        column(&plain, "frame_rms_adu"),
        column(&cm, "frame_rms_adu"),
    );
    for (a, b) in f0.iter().zip(&f1) {
        // getframes' 0.75 adu common to each frame, then what its median's sampling error
        // leaves (~0.75 x the pixel noise / sqrt(1024): 0.07 to 0.2 adu).
        assert!(
            (a - 0.75).abs() < 0.1 && *b < 0.3,
            "frame rms {a} -> {b} adu"
        );
    }
    // The levels taken off are added back: means and dark current as without the option.
    for (a, b) in column(&plain, "mean_adu")
        .iter()
        .zip(column(&cm, "mean_adu"))
    {
        assert!((a - b).abs() < 1e-6, "mean {a} -> {b} adu");
    }
    let dark = "/dark_current_e_per_s/median";
    let (a, b) = (number(&d0, dark), number(&d1, dark));
    assert!(
        (a - b).abs() < 0.01 * a,
        "median dark current {a} -> {b} e-/s"
    );
}

#[test]
fn clipping_changes_the_per_pixel_moments_the_fit_uses() {
    let (plain, d0) = run(&[]);
    let chi2 = "/fit_quality/median_reduced_chi2";
    for extra in [["--clip", "3"], ["--sigma-clip", "3"]] {
        let (clipped, d) = run(&extra);
        let (m0, m1) = (column(&plain, "mean_adu"), column(&clipped, "mean_adu"));
        assert!(
            m0.iter()
                .zip(&m1)
                .all(|(a, b)| a != b && (a - b).abs() < 0.5),
            "{extra:?}: means {m0:?} -> {m1:?}"
        );
        assert_ne!(number(&d0, chi2), number(&d, chi2), "{extra:?}");
    }
}

#[test]
fn class_thresholds_and_the_bad_fit_p_value_reach_the_decomposition() {
    let (_, d0) = run(&[]);
    let count = |d: &serde_json::Value, c: &str| number(d, &format!("/hot_pixels/{c}"));
    assert_eq!((count(&d0, "warm"), count(&d0, "hot")), (0.0, 8.0));
    assert_eq!(number(&d0, "/fit_quality/pixels_flagged"), 0.0);
    // Lower robust thresholds: pixels of the dark current's tail become warm.
    let (_, d) = run(&["--warm-sigma", "2", "--hot-sigma", "10"]);
    assert!(count(&d, "warm") > 0.0, "{}", d["hot_pixels"]);
    let h = &d["hot_pixels"];
    let want = number(h, "/median_e_per_s") + 10.0 * number(h, "/robust_sigma_e_per_s");
    let got = number(h, "/hot_above_e_per_s");
    assert!(
        (got - want).abs() < 1e-9 * want,
        "hot above {got}, want {want} e-/s"
    );
    // Absolute thresholds: the 8 hot pixels (~260 e-/s) are warm under a 1000 e-/s hot line.
    let (_, d) = run(&["--warm-e-per-s", "50", "--hot-e-per-s", "1000"]);
    assert_eq!((count(&d, "warm"), count(&d, "hot")), (8.0, 0.0));
    assert_eq!(number(&d, "/hot_pixels/warm_above_e_per_s"), 50.0);
    // A p-value of 0.5 flags about half the pixels (the fit's chi2 is well calibrated).
    let (_, d) = run(&["--bad-fit-p-value", "0.5"]);
    assert_eq!(number(&d, "/fit_quality/flag_p_value"), 0.5);
    let flagged = number(&d, "/fit_quality/pixels_flagged");
    assert!(
        (300.0..700.0).contains(&flagged),
        "{flagged} of 1024 flagged"
    );
}

#[test]
fn values_out_of_range_are_refused_naming_the_option() {
    let cases: [(&[&str], &str); 10] = [
        (&["--warm-sigma", "0"], "--warm-sigma"),
        (&["--hot-sigma", "2000"], "--hot-sigma"),
        (&["--warm-sigma", "30"], "--hot-sigma"),
        (&["--warm-e-per-s", "5"], "--hot-e-per-s"),
        (
            &["--warm-e-per-s", "5", "--hot-e-per-s", "2e6"],
            "--hot-e-per-s",
        ),
        (&["--bad-fit-p-value", "1"], "--bad-fit-p-value"),
        (&["--sigma-clip", "1e4"], "--sigma-clip"),
        (&["--clip", "3", "--sigma-clip", "3"], "--sigma-clip"),
        (&["--clip", "100"], "--clip"),
        // Checked against every stack's frames before the first is read.
        (
            &["--clip", "75"],
            "leaves fewer than 2 of the 150 frames of",
        ),
    ];
    for (extra, option) in cases {
        let tmp = tempfile::tempdir().unwrap();
        let out = tmp.path().join("c");
        let a = campaign(&out, extra).failure();
        let err = String::from_utf8_lossy(&a.get_output().stderr).to_string();
        assert!(err.contains(option), "{extra:?}: {err}");
        assert!(!out.exists(), "{extra:?} wrote {}", out.display());
    }
}

#[test]
fn help_states_units_and_defaults_of_the_new_options() {
    let a = detnoise().args(["campaign", "--help"]).assert().success();
    let help = String::from_utf8_lossy(&a.get_output().stdout).to_string();
    for want in [
        "--common-mode",
        "--clip <CLIP>",
        "[default: 5]",
        "[default: 25]",
        "[default: 0.001]",
        "e- per s",
        "robust sigmas",
    ] {
        assert!(help.contains(want), "campaign --help lacks {want}:\n{help}");
    }
}

/// `darks` on `stack` with `extra`: whether it ran, and its stderr.
fn darks(stack: &Path, out: &Path, extra: &[&str]) -> (bool, String) {
    let a = detnoise()
        .arg("darks")
        .arg(stack)
        .args(["--gain-e-per-adu", "0.5", "--no-checksums", "--out"])
        .arg(out)
        .args(extra)
        .assert();
    let o = a.get_output();
    (
        o.status.success(),
        String::from_utf8_lossy(&o.stderr).to_string(),
    )
}

#[test]
fn darks_takes_a_camera_models_dark_signal_off_before_looking_for_light() {
    // The camera measured from the getframes campaign (median dark current 1.9 e-/s).
    let tmp = tempfile::tempdir().unwrap();
    let campaign = tmp.path().join("campaign");
    detnoise()
        .arg("campaign")
        .arg("--manifest")
        .arg(manifest())
        .args(["--gain-e-per-adu", "0.5", "--no-checksums", "--out"])
        .arg(&campaign)
        .assert()
        .success();
    let cam = campaign.join("camera");
    let cam = cam.to_str().unwrap();
    // 10 s darks of that camera (~20 e- of dark charge): refused as light without the model,
    // accepted with it; the getframes 5 s stack too. A signal the model does not expect (the
    // same darks checked as 0.1 s darks: 19.8 e- unexplained) is still refused.
    let dark = tmp.path().join("dark.fits");
    detnoise()
        .args([
            "synth",
            "--camera",
            cam,
            "--exposure-s",
            "10",
            "--frames",
            "200",
        ])
        .args(["--seed", "3", "--out"])
        .arg(&dark)
        .assert()
        .success();
    let out = |n: &str| tmp.path().join(n);
    let (ok, err) = darks(&dark, &out("a"), &[]);
    assert!(
        !ok && err.contains("illuminated") && err.contains("--camera"),
        "{err}"
    );
    let model = ["--camera", cam, "--exposure-s", "10"];
    let (ok, err) = darks(&dark, &out("b"), &model);
    assert!(ok, "{err}");
    let five = manifest().with_file_name("scmos-t5.000s.fits");
    let (ok, err) = darks(&five, &out("c"), &["--camera", cam, "--exposure-s", "5"]);
    assert!(ok, "{err}");
    let (ok, err) = darks(&dark, &out("d"), &["--camera", cam, "--exposure-s", "0.1"]);
    assert!(
        !ok && err.contains("illuminated") && err.contains("expected dark signal"),
        "{err}"
    );
    assert!(!out("d").exists());
    // The model's shape must be the stack's; the operating point is checked.
    let other = Path::new(env!("CARGO_MANIFEST_DIR")).join("data-synthetic/scmos-darks-64x64.fits");
    let (ok, err) = darks(&other, &out("e"), &model);
    assert!(
        !ok && err.contains("--camera") && err.contains("pixels"),
        "{err}"
    );
    let (ok, err) = darks(&dark, &out("f"), &["--camera", cam]);
    assert!(!ok && err.contains("--exposure-s"), "{err}");
    let (ok, err) = darks(&dark, &out("g"), &["--camera", cam, "--exposure-s", "1e6"]);
    assert!(!ok && err.contains("--exposure-s"), "{err}");
}
