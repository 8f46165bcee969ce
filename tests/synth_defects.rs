//! `detnoise synth` with non-Gaussian noise: the truth files beside the stack, the manifest's
//! record of the defects, Gaussian stacks unchanged by the new options' defaults, and
//! impossible RTS chains refused naming the option.

mod common;

use common::detnoise;

fn synth(dir: &std::path::Path, name: &str, extra: &[&str]) -> assert_cmd::assert::Assert {
    let out = dir.join(name);
    let mut args = vec![
        "synth",
        "--detector",
        "scmos",
        "--shape",
        "16x12",
        "--frames",
        "40",
        "--seed",
        "5",
        "--out",
        out.to_str().unwrap(),
    ];
    args.extend_from_slice(extra);
    detnoise().args(&args).assert()
}

#[test]
fn defects_write_their_truth_and_manifest() {
    let d = tempfile::tempdir().unwrap();
    synth(
        d.path(),
        "s.fits",
        &[
            "--rts-fraction",
            "0.2",
            "--rts-steps-e",
            "5,12",
            "--rts-dwell-frames",
            "10,5,5",
            "--row-noise-e",
            "0.4",
            "--hot-fraction",
            "0.05",
        ],
    )
    .success();
    let csv = std::fs::read_to_string(d.path().join("s.truth-rts.csv")).unwrap();
    let rows: Vec<&str> = csv.lines().skip(1).collect();
    assert!(!rows.is_empty());
    for r in &rows {
        let c: Vec<&str> = r.split(',').collect();
        assert_eq!((c[2], c[3]), ("3", "ok"), "{r}");
        // Occupancies 0.5, 0.25, 0.25 (proportional to the dwell times).
        assert_eq!((c[7], c[16], c[25]), ("0.5", "0.25", "0.25"), "{r}");
    }
    let m: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(d.path().join("s.manifest.json")).unwrap())
            .unwrap();
    assert_eq!(m["defects"]["rts_pixels"], rows.len());
    assert_eq!(m["spec"]["camera"]["defects"]["row_noise_e"], 0.4);
    assert!(m["truth_maps"]["hot_dark_e"].is_string());
    assert!(d.path().join("s.truth-hot_dark_e.fits").exists());
}

#[test]
fn without_defects_the_stack_and_manifest_are_as_before() {
    // Defaults of the new options inject nothing: no new file, no `defects` key, and the
    // same samples as a run that names the zero values.
    let d = tempfile::tempdir().unwrap();
    synth(d.path(), "a.fits", &[]).success();
    synth(
        d.path(),
        "b.fits",
        &["--row-noise-e", "0", "--rts-fraction", "0"],
    )
    .success();
    assert!(!d.path().join("a.truth-rts.csv").exists());
    let m = std::fs::read_to_string(d.path().join("a.manifest.json")).unwrap();
    assert!(!m.contains("defects"));
    let data = |n: &str| std::fs::read(d.path().join(n)).unwrap();
    assert_eq!(data("a.fits")[2880..], data("b.fits")[2880..]);
}

#[test]
fn impossible_chains_are_refused_naming_the_option() {
    let d = tempfile::tempdir().unwrap();
    let a = synth(
        d.path(),
        "s.fits",
        &[
            "--rts-fraction",
            "0.1",
            "--rts-dwell-frames",
            "10,10",
            "--rts-occupancy",
            "0.9,0.1",
        ],
    )
    .failure();
    let err = String::from_utf8_lossy(&a.get_output().stderr).to_string();
    assert!(err.contains("--rts-occupancy"), "{err}");
    let a = synth(
        d.path(),
        "s.fits",
        &["--rts-fraction", "0.1", "--rts-steps-e", "4,9"],
    )
    .failure();
    let err = String::from_utf8_lossy(&a.get_output().stderr).to_string();
    assert!(err.contains("--rts-steps-e"), "{err}");
    assert!(!d.path().join("s.fits").exists());
}
