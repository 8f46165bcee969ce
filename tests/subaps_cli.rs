//! `detnoise subaps` and `subaps-merge` from the command line: bad inputs refused before any
//! work (naming the option or file), and shards merged into the files of one run.
#![cfg(feature = "cli")]

mod common;

use common::detnoise;
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

/// The fast options of every run: 4 px sub-apertures, 1,000 iterations, no precision target.
const FAST: [&str; 8] = [
    "--iters",
    "1000",
    "--max-iters",
    "1000",
    "--target-se-e",
    "0",
    "--target-rel",
    "0",
];

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
    let cases: [(&Path, &[&str], i32, &[&str]); 7] = [
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
