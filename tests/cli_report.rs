//! End-to-end tests of `detnoise report` on tiny synthetic cameras.

mod common;

use common::detnoise;

use serde_json::Value;
use std::path::Path;

/// A synthetic sCMOS dark stack with read noise `rms` (`paper` or a constant in e-), gain 0.25 e-/adu.
fn synth(dir: &Path, rms: &str, frames: &str, seed: &str) -> std::path::PathBuf {
    let stack = dir.join("darks.fits");
    detnoise()
        .args([
            "synth",
            "--detector",
            "scmos",
            "--shape",
            "48x48",
            "--frames",
            frames,
            "--rms-pdf",
            rms,
        ])
        .args(["--gain-spread", "0", "--seed", seed, "--out"])
        .arg(&stack)
        .assert()
        .success();
    stack
}

fn report(stack: &Path, out: &Path, grid: &[&str]) {
    detnoise()
        .args(["report", "--gain-e-per-adu", "0.25", "--quick", "--darks"])
        .arg(stack)
        .args(grid)
        .arg("--out")
        .arg(out)
        .assert()
        .success();
}

fn json(path: &Path) -> Value {
    serde_json::from_str(
        &std::fs::read_to_string(path).unwrap_or_else(|e| panic!("{}: {e}", path.display())),
    )
    .unwrap()
}

#[test]
fn constant_noise_camera_has_that_effective_noise_and_every_output() {
    let dir = tempfile::tempdir().unwrap();
    // 400 frames: each pixel's measured rms scatters by 1/sqrt(2 x 399) = 3.5 %, which raises the
    // noise-power equivalent of the map by only 0.06 %.
    let stack = synth(dir.path(), "1.5", "400", "3");
    let out = dir.path().join("rep");
    report(
        &stack,
        &out,
        &["--subap", "6", "--spot", "airy:2", "--signal", "50"],
    );
    for f in [
        "index.html",
        "summary.json",
        "darks_summary.json",
        "effective_noise.csv",
        "effective_noise.json",
        "pdf_fit.json",
        "pdf_fit.png",
        "r_vs_signal.png",
        "r_vs_signal.svg",
        "r_vs_signal.csv",
        "rms_hist.png",
        "offset_adu.fits",
        "rms_adu.fits",
        "rms_e.fits",
        "flags.fits",
        "effective_noise_S50.png",
        "effective_noise_S50.svg",
    ] {
        assert!(
            std::fs::metadata(out.join(f))
                .map(|m| m.len() > 0)
                .unwrap_or(false),
            "missing or empty {f}"
        );
    }
    for png in ["pdf_fit.png", "r_vs_signal.png", "effective_noise_S50.png"] {
        image::open(out.join(png)).unwrap();
    }
    let summary = json(&out.join("summary.json"));
    // Each pixel's rms from 400 frames scatters by 3.5 %; the median of 2304 such values has
    // SE ~ 1.2533 x 0.035 x 1.5 / 48 = 0.0014 e-, and uint16 rounding adds +0.1 %: 4 SE + bias.
    assert!((summary["median_rms_e"].as_f64().unwrap() - 1.5).abs() < 4.0 * 0.0014 + 0.0015);
    let eff = json(&out.join("effective_noise.json"));
    for r in eff.as_array().unwrap() {
        let (s, se) = (
            r["sigma_eff_e"].as_f64().unwrap(),
            r["sigma_eff_se_e"].as_f64().unwrap(),
        );
        assert!(se > 0.0 && se < 0.3, "{r}");
        assert!(
            (s - 1.5).abs() < 3.0 * se,
            "{}: sigma_eff {s} +- {se}, truth 1.5",
            r["model"]
        );
    }
    assert!(std::fs::read_to_string(out.join("effective_noise.csv"))
        .unwrap()
        .starts_with("model,centroider,subap_px,"));
}

#[test]
fn paper_pdf_camera_matches_effective_with_the_paper_pdf() {
    let dir = tempfile::tempdir().unwrap();
    let stack = synth(dir.path(), "paper", "200", "5");
    let out = dir.path().join("rep");
    let grid = ["--subap", "8", "--spot", "airy:2", "--signal", "50"];
    report(&stack, &out, &grid);
    let eff_dir = dir.path().join("eff");
    detnoise()
        .args(["effective", "--iters", "2000", "--pdf", "paper", "--out"])
        .arg(&eff_dir)
        .args(grid)
        .assert()
        .success();
    let reference = &json(&eff_dir.join("effective_noise.json"))[0];
    let (rs, rse) = (
        reference["sigma_eff_e"].as_f64().unwrap(),
        reference["sigma_eff_se_e"].as_f64().unwrap(),
    );
    for r in json(&out.join("effective_noise.json")).as_array().unwrap() {
        let (s, se) = (
            r["sigma_eff_e"].as_f64().unwrap(),
            r["sigma_eff_se_e"].as_f64().unwrap(),
        );
        // Independent estimates: the difference has SE sqrt(se^2 + rse^2); 3 SE.
        assert!(
            (s - rs).abs() < 3.0 * (se * se + rse * rse).sqrt(),
            "{}: {s} +- {se} vs paper {rs} +- {rse}",
            r["model"]
        );
    }
}

#[test]
fn bad_input_stops_the_report_and_leaves_no_directory() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("rep");
    // A truncated FITS file.
    let bad = dir.path().join("bad.fits");
    std::fs::write(&bad, b"SIMPLE  =                    T").unwrap();
    let o = detnoise()
        .args(["report", "--gain-e-per-adu", "1", "--quick", "--darks"])
        .arg(&bad)
        .arg("--out")
        .arg(&out)
        .output()
        .unwrap();
    assert_ne!(o.status.code(), Some(0));
    assert!(String::from_utf8_lossy(&o.stderr).contains("bad.fits"));
    // No gain and no flats: refused, with how to give one.
    let stack = synth(dir.path(), "1.0", "20", "1");
    let o = detnoise()
        .args(["report", "--quick", "--darks"])
        .arg(&stack)
        .arg("--out")
        .arg(&out)
        .output()
        .unwrap();
    assert_eq!(o.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&o.stderr).contains("--gain-e-per-adu"));
    assert!(!out.exists());
    let leftovers: Vec<_> = std::fs::read_dir(dir.path())
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().to_string())
        .filter(|n| n.contains("partial"))
        .collect();
    assert!(leftovers.is_empty(), "{leftovers:?}");
}

#[test]
fn emccd_report_recovers_the_bundled_cameras_gain_and_read_noise() {
    // data-synthetic/emccd-lowlight-32x48: exact 520-stage register, gain 300, read noise 50 e-,
    // 10 e-/adu, 0.2 e- light + 0.005 e- CIC per pixel and frame (its manifest).
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("rep");
    let stack =
        Path::new(env!("CARGO_MANIFEST_DIR")).join("data-synthetic/emccd-lowlight-32x48.fits");
    detnoise()
        .args([
            "report",
            "--detector",
            "emccd",
            "--gain-e-per-adu",
            "10",
            "--quick",
            "--darks",
        ])
        .arg(&stack)
        .args([
            "--subap", "8", "--spot", "airy:2", "--signal", "50", "--out",
        ])
        .arg(&out)
        .assert()
        .success();
    let s = json(&out.join("summary.json"));
    let (g, g_se) = (
        s["emgain"]["em_gain"].as_f64().unwrap(),
        s["emgain"]["em_gain_se"].as_f64().unwrap(),
    );
    assert!((g - 300.0).abs() < 4.0 * g_se, "gain {g} +- {g_se}");
    // The fit is the exact register model of the synthesis, so every parameter is within 4 of
    // its own standard errors (Hessian) of the truth; read noise is fitted in adu (10 e-/adu).
    let f = &s["emgain"];
    let rn_se_e = 10.0 * f["read_noise_adu_se"].as_f64().unwrap();
    assert!((s["read_noise_output_e"].as_f64().unwrap() - 50.0).abs() < 4.0 * rn_se_e);
    let lambda_se = f["lambda_e_se"].as_f64().unwrap();
    assert!((f["lambda_e"].as_f64().unwrap() - 0.205).abs() < 4.0 * lambda_se);
    for f in [
        "index.html",
        "emgain.png",
        "r_vs_signal.png",
        "r_vs_signal.csv",
    ] {
        assert!(out.join(f).exists(), "missing {f}");
    }
}

#[test]
fn a_malformed_operating_point_is_a_usage_error_naming_the_option() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("rep");
    for (point, why) in [
        ("8,airy:2", "SUBAP,SPOT,SIGNAL"),
        ("200,airy:2,50", "sub-aperture sizes must be 2 to 128 px"),
        ("8,airy:2,0", "signals must be > 0 photons"),
    ] {
        let assert = detnoise()
            .args([
                "report",
                "--gain-e-per-adu",
                "0.25",
                "--operating-point",
                point,
            ])
            // The darks do not exist: the point is refused before any frame is looked for.
            .args(["--darks", "missing.fits", "--out"])
            .arg(&out)
            .assert()
            .code(2);
        let err = String::from_utf8_lossy(&assert.get_output().stderr).to_string();
        assert!(
            err.contains("--operating-point") && err.contains(why) && !err.contains("missing"),
            "{point}: {err}"
        );
    }
    assert!(!out.exists());
}
