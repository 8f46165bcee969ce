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
