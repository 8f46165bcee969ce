//! `detnoise subaps` and `subaps-merge` from the command line: bad inputs refused before any
//! work (naming the option or file), and shards merged into the files of one run.
#![cfg(feature = "cli")]

mod common;

use common::{detnoise, FAST};
use detnoise::calib::{Map, Unit};
use detnoise::io::fits::{key, KeyValue};
use std::path::{Path, PathBuf};

/// A 12x16 px noise map with varied pixels, written as FITS in `unit` (BUNIT) to `dir`.
fn map_file(dir: &Path, name: &str, unit: Unit) -> PathBuf {
    let data = (0..12 * 16)
        .map(|i| 0.6 + ((i * 37) % 23) as f64 * 0.15)
        .collect();
    let p = dir.join(name);
    let note = key("COMMENT", KeyValue::Str("test map".into()), "");
    Map::new(12, 16, data, unit)
        .write_fits(&p, &[note])
        .unwrap();
    p
}

fn subaps(map: &Path, out: &Path, extra: &[&str]) -> std::process::Output {
    detnoise()
        .args(["subaps", "--map"])
        .arg(map)
        .arg("--out")
        .arg(out)
        .args(FAST)
        .args(extra)
        .output()
        .unwrap()
}

#[test]
fn bad_inputs_are_refused_before_any_work_naming_what_is_wrong() {
    let d = tempfile::tempdir().unwrap();
    let e_map = map_file(d.path(), "rms_e.fits", Unit::Electrons);
    let adu_map = map_file(d.path(), "rms_adu.fits", Unit::Adu);
    let out = d.path().join("out");
    let cases: [(&Path, &[&str], i32, &[&str]); 11] = [
        (
            &adu_map,
            &["--subap-grid", "4"],
            1,
            &["rms_adu.fits", "BUNIT", "electrons"],
        ),
        (
            &e_map,
            &["--subap-grid", "32"],
            2,
            &["--subap-grid", "12x16 px map"],
        ),
        (
            &e_map,
            &["--subap-grid", "4", "--shard", "3"],
            2,
            &["--shard", "K/N"],
        ),
        (
            &e_map,
            &["--subap-grid", "4", "--shard", "4/3"],
            2,
            &["--shard"],
        ),
        (
            &e_map,
            &["--subap-grid", "4", "--signal", "50,100"],
            2,
            &["--signal", "one spot and one signal"],
        ),
        (
            &e_map,
            &["--subap-grid", "4", "--subap", "8"],
            2,
            &["--subap", "--subap-grid"],
        ),
        (&e_map, &[], 2, &["--subap-grid"]),
        // An origin whose first window would end past the largest integer (it wrapped around
        // to a window far outside the map, or panicked), and one merely beyond the map.
        (
            &e_map,
            &["--subap-grid", "16,16,18446744073709551600,0"],
            2,
            &["--subap-grid", "X0 = 18446744073709551600"],
        ),
        (
            &e_map,
            &["--subap-grid", "4,4,0,18446744073709551614"],
            2,
            &["--subap-grid", "Y0 = 18446744073709551614"],
        ),
        (
            &e_map,
            &["--subap-grid", "4,4,18446744073709551599,1"],
            2,
            &["--subap-grid", "12x16 px map"],
        ),
        // A centroider that cannot read a 4x4 window: refused before --out exists.
        (
            &e_map,
            &["--subap-grid", "4", "--centroider", "brightest-n:1000"],
            2,
            &["--centroider", "brightest-n:1000", "16 pixels"],
        ),
    ];
    for (map, extra, code, needles) in cases {
        let o = subaps(map, &out, extra);
        let err = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(code), "{extra:?}: {err}");
        for n in needles {
            assert!(err.contains(n), "{extra:?}: {err} lacks {n}");
        }
        assert!(!out.exists(), "{extra:?} left an output");
    }
    // A mask needs the grid it masks.
    let o = detnoise()
        .args(["subaps", "--map"])
        .arg(&e_map)
        .args(["--subap-mask", "m.fits", "--out"])
        .arg(&out)
        .output()
        .unwrap();
    assert_eq!(o.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&o.stderr).contains("--subap-grid"));
    // Merging nothing, or a file that is not a part.
    let o = detnoise()
        .args(["subaps-merge", "--out"])
        .arg(&out)
        .arg(&e_map)
        .output()
        .unwrap();
    assert_eq!(o.status.code(), Some(1));
    assert!(String::from_utf8_lossy(&o.stderr).contains("not a detnoise part file"));
    assert!(!out.exists());
    // A part of an older format is named as such, to be rerun.
    let old = d.path().join("subaps-part-0-of-1.jsonl");
    std::fs::write(
        &old,
        "{\"format\":\"detnoise-subaps-part-1\",\"shard\":\"0/1\"}\n",
    )
    .unwrap();
    let o = detnoise()
        .args(["subaps-merge", "--out"])
        .arg(&out)
        .arg(&old)
        .output()
        .unwrap();
    assert_eq!(o.status.code(), Some(1));
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(
        err.contains("written by an older detnoise") && err.contains("rerun"),
        "{err}"
    );
    assert!(err.contains("subaps-part-0-of-1.jsonl"), "{err}");
    assert!(!out.exists());
}

#[test]
fn shards_merged_from_the_command_line_equal_one_run() {
    let d = tempfile::tempdir().unwrap();
    let map = map_file(d.path(), "rms_e.fits", Unit::Electrons);
    let (one, parts, merged) = (
        d.path().join("one"),
        d.path().join("parts"),
        d.path().join("merged"),
    );
    let grid = ["--subap-grid", "4,5,1,1", "--seed", "3"];
    let o = subaps(&map, &one, &grid);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let stdout = String::from_utf8_lossy(&o.stdout);
    assert!(stdout.contains("sub-apertures:"), "{stdout}");
    for k in ["1/2", "2/2"] {
        let o = subaps(&map, &parts, &[&grid[..], &["--shard", k]].concat());
        let err = String::from_utf8_lossy(&o.stderr);
        assert!(o.status.success(), "{err}");
        assert!(err.contains("subaps-merge"), "{err}");
    }
    let o = detnoise()
        .args(["subaps-merge", "--out"])
        .arg(&merged)
        .arg(&parts)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    for name in detnoise::subaps::OUTPUT_NAMES {
        let (a, b) = (one.join(name), merged.join(name));
        assert_eq!(
            std::fs::read(&a).unwrap(),
            std::fs::read(&b).unwrap(),
            "{name}"
        );
    }
    // 16 px wide from column 1 at pitch 5: 3 columns; 12 rows from row 1: 2 rows.
    let csv = std::fs::read_to_string(one.join("subaps.csv")).unwrap();
    assert_eq!(csv.lines().count(), 1 + 6, "{csv}");
    // Merging into the directory that holds the parts is refused (they are its inputs).
    let o = detnoise()
        .args(["subaps-merge", "--out"])
        .arg(&parts)
        .arg(&parts)
        .output()
        .unwrap();
    assert_eq!(o.status.code(), Some(2));
}

/// The bundled sCMOS darks' report on a one-configuration grid, optionally with a lenslet
/// geometry; returns the directory written.
fn report(dir: &Path, name: &str, geometry: Option<&str>) -> PathBuf {
    use detnoise::effective::Precision;
    use detnoise::report::{run, ReportOptions};
    use detnoise::subaps::{Geometry, GridSpec};
    let out = dir.join(name);
    let options = ReportOptions {
        darks_paths: vec![common::data("scmos-darks-64x64.fits")],
        gain_e_per_adu: Some(0.25),
        subaps_px: Some(vec![8]),
        spots: Some(vec![detnoise::spot::Spot::Airy { diameter_px: 2.0 }]),
        signals_photons: Some(vec![50.0]),
        iters: 2000,
        precision: Precision::fixed(2000),
        out_dir: out.clone(),
        subaps: geometry.map(|g| Geometry {
            grid: GridSpec::parse(g).unwrap(),
            mask: None,
        }),
        ..ReportOptions::default()
    };
    run(&options, &detnoise::progress::Silent).unwrap();
    out
}

#[test]
fn a_report_with_a_lenslet_grid_adds_the_map_and_is_otherwise_unchanged() {
    let d = tempfile::tempdir().unwrap();
    let plain = report(d.path(), "plain", None);
    let with = report(d.path(), "with", Some("16,16,0,0"));
    let names = |dir: &Path| {
        let mut v: Vec<String> = std::fs::read_dir(dir)
            .unwrap()
            .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
            .collect();
        v.sort();
        v
    };
    let (a, b) = (names(&plain), names(&with));
    let added: Vec<&String> = b.iter().filter(|n| !a.contains(n)).collect();
    let mut expect: Vec<&str> = detnoise::subaps::OUTPUT_NAMES.to_vec();
    expect.sort();
    assert_eq!(added, expect);
    assert!(!a.iter().any(|n| n.starts_with("subaps")));
    // Every file of the plain report is the same in the other, but for the summary and the
    // page (and the manifest, which lists the files): the summary gains one key.
    for n in &a {
        if ["summary.json", "index.html", ".detnoise-manifest.json"].contains(&n.as_str()) {
            continue;
        }
        assert_eq!(
            std::fs::read(plain.join(n)).unwrap(),
            std::fs::read(with.join(n)).unwrap(),
            "{n}"
        );
    }
    let json = |dir: &Path| -> serde_json::Value {
        serde_json::from_str(&std::fs::read_to_string(dir.join("summary.json")).unwrap()).unwrap()
    };
    let (mut s_plain, mut s_with) = (json(&plain), json(&with));
    assert!(s_plain.get("subaps").is_none());
    let subaps = s_with.as_object_mut().unwrap().remove("subaps").unwrap();
    s_plain.as_object_mut().unwrap().remove("tool");
    s_with.as_object_mut().unwrap().remove("tool");
    assert_eq!(s_plain, s_with);
    // 4x4 sub-apertures of 16 px, every one counted once, at the operating point's signal.
    let counts = subaps["counts"].as_object().unwrap();
    let total: u64 = counts.values().map(|v| v.as_u64().unwrap()).sum();
    assert_eq!(total, 16);
    assert_eq!(subaps["options"]["signal_photons"], 50.0);
    let page = std::fs::read_to_string(with.join("index.html")).unwrap();
    assert!(
        page.contains("Effective read noise per sub-aperture")
            && page.contains("subaps_sigma_eff.png")
    );
    assert!(!std::fs::read_to_string(plain.join("index.html"))
        .unwrap()
        .contains("per sub-aperture</h2>"));
}

#[test]
fn a_report_refuses_a_grid_that_wraps_before_any_work() {
    let d = tempfile::tempdir().unwrap();
    let out = d.path().join("report");
    let darks = common::data("scmos-darks-64x64.fits");
    for (grid, extra, needle) in [
        (
            "16,16,18446744073709551600,0",
            None,
            "X0 = 18446744073709551600",
        ),
        ("16,16,18446744073709551599,1", None, "64x64 px map"),
        ("16", Some("brightest-n:1000"), "brightest-n:1000"),
    ] {
        let start = std::time::Instant::now();
        let mut cmd = detnoise();
        cmd.args(["report", "--darks"])
            .arg(&darks)
            .args(["--gain-e-per-adu", "0.25", "--quick", "--subap-grid", grid])
            .arg("--out")
            .arg(&out);
        if let Some(c) = extra {
            cmd.args(["--centroider", c]);
        }
        let o = cmd.output().unwrap();
        let err = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(2), "{grid}: {err}");
        assert!(err.contains(needle), "{grid}: {err}");
        assert!(!out.exists(), "{grid}");
        // Refused at once: the report's Monte-Carlo takes tens of seconds.
        assert!(
            start.elapsed().as_secs_f64() < 3.0,
            "{grid}: {:?}",
            start.elapsed()
        );
    }
}

#[test]
fn a_usage_error_leaves_nothing_so_the_corrected_rerun_runs() {
    let d = tempfile::tempdir().unwrap();
    let map = map_file(d.path(), "rms_e.fits", Unit::Electrons);
    let out = d.path().join("out");
    let o = subaps(
        &map,
        &out,
        &["--subap-grid", "4", "--centroider", "brightest-n:1000"],
    );
    assert_eq!(o.status.code(), Some(2));
    assert!(!out.exists());
    let o = subaps(
        &map,
        &out,
        &["--subap-grid", "4", "--centroider", "brightest-n:4"],
    );
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
}

#[test]
fn a_mask_of_another_shape_than_the_grid_is_refused_naming_both() {
    let d = tempfile::tempdir().unwrap();
    let map = map_file(d.path(), "rms_e.fits", Unit::Electrons);
    let mask = d.path().join("mask.fits");
    // The 12x16 px map holds 3x4 sub-apertures of 4 px; the mask is 2x4.
    Map::new(2, 4, vec![1.0; 8], Unit::Flags)
        .write_fits(&mask, &[])
        .unwrap();
    let out = d.path().join("out");
    let o = subaps(
        &map,
        &out,
        &["--subap-grid", "4", "--subap-mask", mask.to_str().unwrap()],
    );
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(2), "{err}");
    for n in ["--subap-mask", "2x4 cells", "3x4 sub-apertures"] {
        assert!(err.contains(n), "{err} lacks {n}");
    }
    assert!(!out.exists());
}

/// Options of a run that takes a few seconds (the lock tests need it running).
const SLOW: [&str; 6] = [
    "--subap-grid",
    "4",
    "--iters",
    "100000",
    "--max-iters",
    "100000",
];

fn slow_run(map: &Path, out: &Path) -> std::process::Child {
    std::process::Command::new(env!("CARGO_BIN_EXE_detnoise"))
        .args(["subaps", "--map"])
        .arg(map)
        .arg("--out")
        .arg(out)
        .args(["--target-se-e", "0", "--target-rel", "0"])
        .args(SLOW)
        .stdout(std::process::Stdio::null())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap()
}

/// Wait until `path` exists and holds at least `lines` lines (30 s at most: a run's first
/// record follows its constant-sigma ladder, 100,000 frames of some 40 references here).
fn wait_for(path: &Path, lines: usize) {
    let start = std::time::Instant::now();
    while std::fs::read_to_string(path).map_or(true, |t| t.lines().count() < lines) {
        assert!(
            start.elapsed().as_secs() < 30,
            "{} never came",
            path.display()
        );
        std::thread::sleep(std::time::Duration::from_millis(20));
    }
}

#[test]
fn a_second_run_on_the_same_part_is_refused_naming_the_first_ones_pid() {
    let d = tempfile::tempdir().unwrap();
    let map = map_file(d.path(), "rms_e.fits", Unit::Electrons);
    let out = d.path().join("out");
    let first = slow_run(&map, &out);
    let lock = out.join("subaps-1-of-1.part.lock");
    wait_for(&lock, 1);
    let second = detnoise()
        .args(["subaps", "--map"])
        .arg(&map)
        .arg("--out")
        .arg(&out)
        .args(["--target-se-e", "0", "--target-rel", "0"])
        .args(SLOW)
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&second.stderr);
    assert_eq!(second.status.code(), Some(2), "{err}");
    assert!(
        err.contains(&format!("pid {}", first.id())) && err.contains("subaps-1-of-1.part"),
        "{err}"
    );
    let o = first.wait_with_output().unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    // The first wrote every sub-aperture once, and its lock is gone.
    let part = detnoise::subaps::read_part(&out.join("subaps-1-of-1.part")).unwrap();
    assert_eq!((part.records.len(), part.torn), (12, false));
    assert!(!lock.exists());
    let csv = std::fs::read_to_string(out.join("subaps.csv")).unwrap();
    assert_eq!(csv.lines().count(), 13);
}

#[test]
fn a_run_killed_with_its_lock_held_resumes() {
    let d = tempfile::tempdir().unwrap();
    let map = map_file(d.path(), "rms_e.fits", Unit::Electrons);
    let out = d.path().join("out");
    let mut first = slow_run(&map, &out);
    // Killed (SIGKILL) once a sub-aperture is in the part: the lock file stays behind.
    wait_for(&out.join("subaps-1-of-1.part"), 2);
    first.kill().unwrap();
    first.wait().unwrap();
    let lock = out.join("subaps-1-of-1.part.lock");
    assert!(lock.exists());
    let o = slow_run(&map, &out).wait_with_output().unwrap();
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(o.status.success(), "{err}");
    assert!(!err.contains(" 0 resumed"), "{err}");
    assert!(!lock.exists());
}

#[test]
fn damaged_and_edited_parts_are_refused_for_what_they_are() {
    let d = tempfile::tempdir().unwrap();
    let map = map_file(d.path(), "rms_e.fits", Unit::Electrons);
    let (parts, merged) = (d.path().join("parts"), d.path().join("merged"));
    for k in ["1/2", "2/2"] {
        let o = subaps(&map, &parts, &["--subap-grid", "4", "--shard", k]);
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    }
    let part = parts.join("subaps-1-of-2.part");
    let text = std::fs::read_to_string(&part).unwrap();
    // An edited signal (50 -> 500): the header no longer matches its checksum.
    std::fs::write(
        &part,
        text.replacen("\"signal_photons\":50.0", "\"signal_photons\":500.0", 1),
    )
    .unwrap();
    let o = detnoise()
        .args(["subaps-merge", "--out"])
        .arg(&merged)
        .arg(&parts)
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(1), "{err}");
    assert!(
        err.contains("subaps-1-of-2.part") && err.contains("binding_blake3"),
        "{err}"
    );
    assert!(!merged.exists());
    // One flipped byte in a record: the reason, without --force, naming the file.
    let mut bytes = text.into_bytes();
    let at = bytes.iter().position(|&b| b == b'\n').unwrap() + 5;
    bytes[at] ^= 0x04;
    std::fs::write(&part, &bytes).unwrap();
    let o = subaps(&map, &parts, &["--subap-grid", "4", "--shard", "2/2"]);
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(1), "{err}");
    assert!(
        err.contains("subaps-1-of-2.part: line 2 is damaged"),
        "{err}"
    );
    assert_eq!(std::fs::read(&part).unwrap(), bytes);
}

#[test]
fn the_summary_names_the_map_as_read_after_a_rename() {
    let d = tempfile::tempdir().unwrap();
    let map = map_file(d.path(), "rms_e.fits", Unit::Electrons);
    let out = d.path().join("out");
    assert!(subaps(&map, &out, &["--subap-grid", "4"]).status.success());
    let renamed = d.path().join("renamed_e.fits");
    std::fs::rename(&map, &renamed).unwrap();
    let o = subaps(&renamed, &out, &["--subap-grid", "4"]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let s: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("subaps_summary.json")).unwrap())
            .unwrap();
    let source = s["map_source"].as_str().unwrap();
    assert!(source.ends_with("renamed_e.fits"), "{source}");
}
