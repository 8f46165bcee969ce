//! `detnoise effective --simple-qe`: the QE factor of the simple EMCCD model from the command
//! line (tables, charts, the terminal table) and its refusals.

mod common;

use common::detnoise;
use serde_json::Value;

#[test]
fn simple_qe_writes_the_factor_table_and_a_chart_per_spot() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("qe");
    let assert = detnoise()
        .args(["effective", "--model", "emccd-stochastic", "--simple-qe"])
        .args(["--subap", "6", "--spot", "airy:2", "--signal", "50,500"])
        .args(["--iters", "1000", "--max-iters", "8000", "--em-gain", "250"])
        .args(["--emccd-read-noise", "40", "--out"])
        .arg(&out)
        .assert()
        .success();
    let stdout = String::from_utf8_lossy(&assert.get_output().stdout).to_string();
    assert!(stdout.contains("QE factor of emccd-simple (read noise 0.1600 e-), gain 250"));
    assert!(!stdout.to_lowercase().contains("nan"), "{stdout}");
    for f in [
        "effective_qe.csv",
        "effective_qe.json",
        "effective_qe_airy-2.png",
    ] {
        assert!(out.join(f).is_file(), "missing {f}");
    }
    assert!(!out.join("effective_noise.csv").exists());
    let rows: Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("effective_qe.json")).unwrap())
            .unwrap();
    let rows = rows.as_array().unwrap();
    assert_eq!(rows.len(), 2);
    for r in rows {
        assert_eq!(r["simple_read_noise_e"], 0.16);
        assert_eq!(r["em_gain"], 250.0);
        if r["status"] == "ok" {
            let (q, se) = (
                r["qe_factor"].as_f64().unwrap(),
                r["qe_factor_se"].as_f64().unwrap(),
            );
            assert!(q > 0.0 && q <= 1.0 && se > 0.0, "{r}");
            let z = r["paper_z"].as_f64().unwrap();
            assert!((z - (q - 0.5) / se).abs() < 1e-9);
        }
    }
}

#[test]
fn simple_qe_refuses_scmos_models_and_bad_targets_naming_the_option() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("qe");
    for (args, flag, why) in [
        (
            vec!["--model", "scmos-random", "--simple-qe"],
            "--simple-qe",
            "scmos-random is an sCMOS model",
        ),
        (
            vec![
                "--model",
                "emccd-stochastic",
                "--simple-qe",
                "--qe-target-se",
                "-1",
            ],
            "--qe-target-se",
            "",
        ),
    ] {
        let assert = detnoise()
            .arg("effective")
            .args(&args)
            .arg("--out")
            .arg(&out)
            .assert()
            .code(2);
        let err = String::from_utf8_lossy(&assert.get_output().stderr).to_string();
        assert!(err.contains(flag) && err.contains(why), "{args:?}: {err}");
    }
    assert!(!out.exists());
}
