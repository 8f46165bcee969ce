//! `detnoise datasheet` from the command line: the bundled EMVA dataset's datasheet and its
//! files, a dataset out of the standard's rules computed with statuses, and bad input refused
//! before any work, naming the file and what is wrong, leaving nothing behind.

mod common;

use std::path::{Path, PathBuf};

use common::{datasheet, detnoise};

/// The bundled dataset's folder.
fn bundled() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("data-synthetic/emva-cmos-64x96")
}

/// A descriptor in `dir` listing the bundled images (by absolute path) of the first `points`
/// photon-transfer points (with their dark pairs) and, if `spatial`, the spatial stacks.
fn subset(dir: &Path, points: usize, spatial: bool) -> PathBuf {
    let text = std::fs::read_to_string(bundled().join("EMVA1288descriptor.txt")).unwrap();
    let images = bundled().join("images");
    let mut out = String::new();
    let mut bright_seen = 0;
    let mut keep = true;
    let mut lines = text.lines().peekable();
    while let Some(line) = lines.next() {
        let words: Vec<&str> = line.split_whitespace().collect();
        match words.first() {
            Some(&"b") | Some(&"d") => {
                // A set of more than two images is a spatial stack.
                let mut set = Vec::new();
                while let Some(l) = lines.peek().filter(|l| l.starts_with("i ")) {
                    set.push(l.to_string());
                    lines.next();
                }
                let is_spatial = set.len() > 2;
                if words[0] == "b" && !is_spatial {
                    bright_seen += 1;
                }
                keep = if is_spatial {
                    spatial
                } else {
                    bright_seen <= points
                };
                if keep {
                    out.push_str(line);
                    out.push('\n');
                    for i in set {
                        let name = i.trim_start_matches("i images\\");
                        out.push_str(&format!("i {}\n", images.join(name).display()));
                    }
                }
            }
            _ if keep => {
                out.push_str(line);
                out.push('\n');
            }
            _ => {}
        }
    }
    let path = dir.join("descriptor.txt");
    std::fs::write(&path, out).unwrap();
    path
}

#[test]
fn the_bundled_dataset_gives_its_datasheet_and_every_file() {
    let d = tempfile::tempdir().unwrap();
    let out = d.path().join("ds");
    let o = datasheet(&bundled().join("EMVA1288descriptor.txt"), &out);
    let stdout = String::from_utf8_lossy(&o.stdout);
    assert!(stdout.contains("System gain K (DN/e-)"), "{stdout}");
    for name in [
        "datasheet.json",
        "datasheet.csv",
        "datasheet.html",
        "photon_transfer.png",
        "photon_transfer.svg",
        "snr.svg",
        "spectrogram_horizontal_dsnu.svg",
        "histogram_prnu_accumulated.png",
    ] {
        assert!(out.join(name).is_file(), "{name}");
    }
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("datasheet.json")).unwrap())
            .unwrap();
    let rows: Vec<&serde_json::Value> = json["sections"]
        .as_array()
        .unwrap()
        .iter()
        .flat_map(|s| s["rows"].as_array().unwrap())
        .collect();
    // Every key names its unit (or is a ratio / count, said so by its label).
    for r in &rows {
        let key = r["key"].as_str().unwrap();
        let unit = r["unit"].as_str().unwrap();
        let unitless = [
            "snr_max",
            "dynamic_range",
            "bright_stack_saturation_fraction",
        ];
        assert!(
            unitless.contains(&key)
                || ["_dn", "_e", "_percent", "_db", "_px", "_per_e", "_per_s", "_photon"]
                    .iter()
                    .any(|u| key.ends_with(u)),
            "{key} ({unit})"
        );
    }
    // The bundled camera's truth (truth.json): K 0.4 DN/e- (pixel average 0.39965), QE 60 %,
    // read noise 6 e-, dark current 199.6 e-/s realised.
    let get = |key: &str| {
        let r = rows.iter().find(|r| r["key"] == key).unwrap();
        (r["value"].as_f64().unwrap(), r["se"].as_f64().unwrap())
    };
    for (key, truth) in [
        ("system_gain_dn_per_e", 0.39965),
        ("quantum_efficiency_percent", 60.0),
        ("dark_noise_e", 6.0),
        ("dark_current_mean_e_per_s", 199.61),
        ("dark_current_variance_e_per_s", 199.61),
    ] {
        let (v, se) = get(key);
        assert!(
            (v - truth).abs() < 3.0 * se,
            "{key}: {v} +- {se} vs {truth}"
        );
    }
    let csv = std::fs::read_to_string(out.join("datasheet.csv")).unwrap();
    assert!(csv.starts_with("section,key,label,unit,value,se,status,rule\n"));
    let html = std::fs::read_to_string(out.join("datasheet.html")).unwrap();
    assert!(html.contains("<img src=\"photon_transfer.svg\"") && !html.contains("NaN"));
}

#[test]
fn a_dataset_out_of_the_rules_is_computed_with_statuses_naming_the_rule() {
    // 12 points (the standard asks for 50), none past saturation, no spatial stacks.
    let d = tempfile::tempdir().unwrap();
    let descriptor = subset(d.path(), 12, false);
    let out = d.path().join("ds");
    let o = datasheet(&descriptor, &out);
    let csv = std::fs::read_to_string(out.join("datasheet.csv")).unwrap();
    let k = csv
        .lines()
        .find(|l| l.contains(",system_gain_dn_per_e,"))
        .unwrap();
    assert!(k.contains("out_of_rules") && k.contains("50"), "{k}");
    assert!(
        !csv.contains("dsnu_e"),
        "no spatial stacks, no DSNU rows: {csv}"
    );
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert!(stderr.contains("no spatial stacks"), "{stderr}");
}

#[test]
fn bad_input_is_refused_before_any_work_and_leaves_nothing() {
    let d = tempfile::tempdir().unwrap();
    let out = d.path().join("ds");
    let run = |descriptor: &Path| {
        detnoise()
            .args(["datasheet", "--emva-descriptor"])
            .arg(descriptor)
            .arg("--out")
            .arg(&out)
            .output()
            .unwrap()
    };
    // A descriptor that does not exist.
    let o = run(&d.path().join("nowhere.txt"));
    assert_eq!(o.status.code(), Some(1));
    assert!(String::from_utf8_lossy(&o.stderr).contains("nowhere.txt"));
    assert!(!out.exists());
    // A descriptor naming images that do not exist.
    let missing = d.path().join("missing.txt");
    std::fs::write(
        &missing,
        "n 12 96 64\nb 1000 10\ni a.fits\ni b.fits\nd 1000\ni c.fits\ni d.fits\n",
    )
    .unwrap();
    let o = run(&missing);
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(1), "{err}");
    assert!(
        err.contains("missing.txt") && err.contains("a.fits"),
        "{err}"
    );
    assert!(!out.exists());
    // Fewer than the 5 points anything can be fitted to.
    let three = subset(d.path(), 3, false);
    let o = run(&three);
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(1), "{err}");
    assert!(err.contains("descriptor.txt"), "{err}");
    assert!(!out.exists());
    // An --out holding someone else's file is refused before any frame is read.
    std::fs::create_dir(&out).unwrap();
    std::fs::write(out.join("notes.txt"), "mine").unwrap();
    let o = run(&bundled().join("EMVA1288descriptor.txt"));
    assert_eq!(
        o.status.code(),
        Some(2),
        "{}",
        String::from_utf8_lossy(&o.stderr)
    );
    assert_eq!(
        std::fs::read_to_string(out.join("notes.txt")).unwrap(),
        "mine"
    );
    assert_eq!(std::fs::read_dir(&out).unwrap().count(), 1);
}

#[test]
fn a_second_run_replaces_its_own_folder() {
    let d = tempfile::tempdir().unwrap();
    let out = d.path().join("ds");
    for _ in 0..2 {
        datasheet(&bundled().join("EMVA1288descriptor.txt"), &out);
    }
    assert!(out.join("datasheet.json").is_file());
}
