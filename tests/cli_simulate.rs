//! End-to-end tests of `detnoise simulate`.

mod common;

use common::detnoise;

use serde_json::Value;

const KEYS: [&str; 15] = [
    "model",
    "subap_px",
    "spot",
    "sampling",
    "signal_photons",
    "qe",
    "em_gain",
    "iters",
    "seed",
    "r_px",
    "r_se_px",
    "b_opt_e",
    "b_at_grid_edge",
    "r0_px",
    "zero_frames",
];

#[test]
fn json_sweep_has_every_record_and_key() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("r.json");
    detnoise()
        .args([
            "simulate",
            "--model",
            "emccd-stochastic,scmos-random",
            "--subap",
            "4,6",
            "--spot",
            "airy:2",
        ])
        .args([
            "--signal", "20,100", "--iters", "400", "--seed", "1", "--format", "json", "--out",
        ])
        .arg(&out)
        .assert()
        .success();
    let v: Value = serde_json::from_str(&std::fs::read_to_string(&out).unwrap()).unwrap();
    let recs = v.as_array().unwrap();
    assert_eq!(recs.len(), 2 * 2 * 2);
    for r in recs {
        for k in KEYS {
            assert!(r.get(k).is_some(), "missing key {k}");
        }
        assert!(r["r_px"].as_f64().unwrap() > 0.0 && r["r_se_px"].as_f64().unwrap() > 0.0);
        assert_eq!(
            r["bg_levels_e"].as_array().unwrap().len(),
            r["r_by_level_px"].as_array().unwrap().len()
        );
    }
}

#[test]
fn csv_has_the_same_columns_and_thread_count_does_not_change_results() {
    let run = |threads: &str| {
        let o = detnoise()
            .args([
                "--threads",
                threads,
                "simulate",
                "--model",
                "emccd-simple,scmos-fixed:2",
                "--subap",
                "5",
            ])
            .args([
                "--spot",
                "gauss:1,2",
                "--signal",
                "50",
                "--iters",
                "600",
                "--format",
                "csv",
            ])
            .output()
            .unwrap();
        assert!(o.status.success());
        String::from_utf8(o.stdout).unwrap()
    };
    let one = run("1");
    assert_eq!(one, run("2"));
    let header: Vec<&str> = one.lines().next().unwrap().split(',').collect();
    for k in KEYS {
        assert!(header.contains(&k), "CSV lacks {k}");
    }
    assert!(one.contains("\"gauss:1,2\""));
}

#[test]
fn bad_options_exit_with_code_2_and_a_clear_message() {
    for (args, needle) in [
        (vec!["--signal", "-5"], "--signal"),
        (vec!["--subap", "0"], "--subap"),
        (vec!["--model", "ccd-magic"], "unknown model"),
        (vec!["--spot", "airy:"], "--spot"),
        (vec!["--spot", "gauss:1"], "--spot"),
        // The error quotes the item as typed (it once echoed 'airy:airy:3').
        (
            vec!["--spot", "airy:2,airy:3"],
            "'airy:2,airy:3': 'airy:3' is not a diameter",
        ),
        (vec!["--bg-grid", "5:1:1"], "--bg-grid"),
        (vec!["--qe", "1.5"], "--qe"),
    ] {
        let o = detnoise()
            .arg("simulate")
            .args(&args)
            .args(["--iters", "10"])
            .output()
            .unwrap();
        assert_eq!(o.status.code(), Some(2), "{args:?}");
        let err = String::from_utf8(o.stderr).unwrap();
        assert!(err.contains(needle), "{args:?}: {err}");
    }
}

#[test]
fn failed_run_leaves_no_output_file() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("r.json");
    detnoise()
        .args(["simulate", "--model", "nope", "--format", "json", "--out"])
        .arg(&out)
        .assert()
        .code(2);
    assert!(!out.exists());
    assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 0);
}
