//! `detnoise campaign`: the three inputs (CSV manifest, FITS header keywords, EMVA 1288
//! descriptor), the refusals before any work (exit code and the file named), and the stacks'
//! figures agreeing with `darks` on the same stack.

mod common;

use std::path::{Path, PathBuf};

use common::detnoise;
use detnoise::io::fits::{key, write_cube, KeyValue, Keyword};
use serde_json::Value;

const HEADER: &str = "file,kind,exposure_s,em_gain,temperature_c,light_level\n";

/// Gaussian-ish deterministic noise: the sum of 12 uniforms from a 64-bit LCG, minus 6.
struct Noise(u64);

impl Noise {
    fn uniform(&mut self) -> f64 {
        self.0 = self
            .0
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        (self.0 >> 11) as f64 / (1u64 << 53) as f64
    }
    fn gauss(&mut self) -> f64 {
        (0..12).map(|_| self.uniform()).sum::<f64>() - 6.0
    }
}

/// Write a uint16 stack of `frames` frames `shape` at `path`: offset 500 adu + `signal` adu,
/// 3 adu of Gaussian noise, with header `keys`.
fn stack(path: &Path, shape: (usize, usize), frames: usize, signal: f64, keys: &[Keyword]) {
    let mut n = Noise(path.to_string_lossy().len() as u64 * 7919 + frames as u64);
    let mut next = || -> Vec<f64> {
        (0..shape.0 * shape.1)
            .map(|i| 500.0 + (i % 7) as f64 + signal + 3.0 * n.gauss())
            .collect()
    };
    write_cube(path, shape, frames, true, &mut next, keys).unwrap();
}

/// A folder with darks `d1.fits` (0.1 s), `d2.fits` (1 s) and a flat `f1.fits`, 8 x 12 x 10
/// frames, and a manifest of them `m.csv` with `rows` (defaults when None).
fn campaign(rows: Option<&str>) -> (tempfile::TempDir, PathBuf) {
    let dir = tempfile::tempdir().unwrap();
    for (name, signal) in [("d1.fits", 0.0), ("d2.fits", 5.0), ("f1.fits", 200.0)] {
        stack(&dir.path().join(name), (8, 12), 10, signal, &[]);
    }
    let rows = rows.unwrap_or("d1.fits,dark,0.1,,,\nd2.fits,dark,1,,,\nf1.fits,flat,1,,,250\n");
    let manifest = dir.path().join("m.csv");
    std::fs::write(&manifest, format!("{HEADER}{rows}")).unwrap();
    (dir, manifest)
}

/// Run `campaign` with `args` and `--gain-e-per-adu 2 --out OUT`; the output and the json.
fn run_ok(args: &[&str], out: &Path) -> Value {
    let a = detnoise()
        .arg("campaign")
        .args(args)
        .args(["--gain-e-per-adu", "2", "--out"])
        .arg(out)
        .assert()
        .success();
    let _ = a;
    serde_json::from_str(&std::fs::read_to_string(out.join("campaign.json")).unwrap()).unwrap()
}

#[test]
fn a_manifest_gives_one_row_per_stack_with_units_in_the_header() {
    let (dir, manifest) = campaign(None);
    let out = dir.path().join("out");
    let json = run_ok(&["--manifest", manifest.to_str().unwrap()], &out);
    let csv = std::fs::read_to_string(out.join("conditions.csv")).unwrap();
    let mut lines = csv.lines();
    let head = lines.next().unwrap();
    for col in [
        "file",
        "kind",
        "exposure_s",
        "em_gain",
        "temperature_c",
        "frames",
        "mean_adu",
        "total_rms_adu",
        "total_rms_se_adu",
        "pixel_rms_adu",
        "row_rms_se_adu",
        "column_rms_adu",
        "frame_rms_se_adu",
        "em_fit_gain_e_per_e",
        "em_fit_lambda_e_per_pixel",
        "em_fit_serial_cic_e_per_pixel",
    ] {
        assert!(head.split(',').any(|h| h == col), "{col} in {head}");
    }
    assert_eq!(lines.count(), 3);
    let stacks = json["stacks"].as_array().unwrap();
    assert_eq!(stacks.len(), 3);
    assert_eq!(stacks[1]["condition"]["exposure_s"], 1.0);
    assert_eq!(stacks[2]["condition"]["kind"], "flat");
    assert_eq!(stacks[2]["condition"]["light_level"], 250.0);
    assert_eq!(
        json["design"]["dark_exposures_s"],
        serde_json::json!([0.1, 1.0])
    );
    // One pass per stack, with checksums as `darks` records them.
    assert_eq!(stacks[0]["inputs"][0]["blake3"].as_str().unwrap().len(), 64);
    // The dark signal: 5 adu more at 1 s than at 0.1 s (3 adu noise, 960 samples per pixel).
    let d = stacks[1]["mean_adu"].as_f64().unwrap() - stacks[0]["mean_adu"].as_f64().unwrap();
    assert!((d - 5.0).abs() < 0.1, "{d}");
}

#[test]
fn fits_keywords_give_the_conditions() {
    let dir = tempfile::tempdir().unwrap();
    let mut files = Vec::new();
    for (i, (t, kind)) in [
        (0.5, "Dark Frame"),
        (2.0, "Dark Frame"),
        (2.0, "Flat Field"),
    ]
    .into_iter()
    .enumerate()
    {
        let p = dir.path().join(format!("s{i}.fits"));
        let keys = [
            key("EXPOSURE", KeyValue::F64(t), "s"),
            key("IMAGETYP", KeyValue::Str(kind.into()), ""),
            key("CCD-TEMP", KeyValue::F64(-20.0), "C"),
        ];
        stack(&p, (8, 8), 6, 0.0, &keys);
        files.push(p.to_str().unwrap().to_string());
    }
    let out = dir.path().join("out");
    let mut args: Vec<&str> = files.iter().map(String::as_str).collect();
    args.extend([
        "--exposure-key",
        "EXPOSURE",
        "--kind-key",
        "IMAGETYP",
        "--temperature-key",
        "CCD-TEMP",
    ]);
    let json = run_ok(&args, &out);
    let s = json["stacks"].as_array().unwrap();
    assert_eq!(s[0]["condition"]["exposure_s"], 0.5);
    assert_eq!(s[1]["condition"]["kind"], "dark");
    assert_eq!(s[2]["condition"]["kind"], "flat");
    assert_eq!(s[2]["condition"]["temperature_c"], -20.0);
    assert_eq!(json["input"], "keywords");
}

#[test]
fn an_emva_descriptor_runs_unchanged_with_windows_paths() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::create_dir(dir.path().join("img")).unwrap();
    let mut text = String::from("# made for the EMVA reference\nv 3.0\nn 16 12 8\n");
    for (k, (line, signal)) in [
        ("d 1000000", 0.0),
        ("d 20000000", 3.0),
        ("b 20000000 12,5", 90.0),
    ]
    .into_iter()
    .enumerate()
    {
        text += &format!("{line}\n");
        for j in 0..2 {
            let name = format!("p{k}_{j}.fits");
            stack(&dir.path().join("img").join(&name), (8, 12), 1, signal, &[]);
            text += &format!("i img\\{name}\n");
        }
    }
    let descriptor = dir.path().join("desc.txt");
    std::fs::write(&descriptor, text).unwrap();
    let out = dir.path().join("out");
    let json = run_ok(&["--emva-descriptor", descriptor.to_str().unwrap()], &out);
    let s = json["stacks"].as_array().unwrap();
    assert_eq!(s.len(), 3);
    assert_eq!(s[0]["frames"], 2);
    assert_eq!(s[1]["condition"]["exposure_s"], 0.02);
    assert_eq!(s[2]["condition"]["kind"], "flat");
    assert_eq!(s[2]["condition"]["light_level"], 12.5);
    assert_eq!(s[2]["files"].as_array().unwrap().len(), 2);
}

/// Run `campaign --gain-e-per-adu 2 --out OUT` with `args` in `dir`; its exit code and
/// standard error, and whether OUT was written.
fn run_err(dir: &Path, args: &[&str]) -> (i32, String, bool) {
    let out = dir.join("out");
    let o = detnoise()
        .current_dir(dir)
        .arg("campaign")
        .args(args)
        .args(["--gain-e-per-adu", "2", "--out"])
        .arg(&out)
        .output()
        .unwrap();
    (
        o.status.code().unwrap(),
        String::from_utf8_lossy(&o.stderr).into_owned(),
        out.exists(),
    )
}

#[test]
fn inconsistent_campaigns_refused_before_any_work_naming_the_file() {
    let cases: [(&str, &str, &[&str]); 6] = [
        (
            "d1.fits,dark,0.1,,,\nd9.fits,dark,1,,,\n",
            "d9.fits",
            &["not found", "m.csv line 3"],
        ),
        (
            "d1.fits,dark,0.1,,,\n./d1.fits,dark,1,,,\n",
            "d1.fits",
            &["given twice"],
        ),
        (
            "d1.fits,dark,0.1,,,\nd2.fits,dark,1,,,\nshape.fits,dark,2,,,\n",
            "shape.fits",
            &["frames of 4x4", "8x12", "one frame shape"],
        ),
        (
            "d1.fits,dark,0.1,100,,\nd2.fits,dark,1,,,\n",
            "d2.fits",
            &["em_gain is missing", "m.csv line 3", "d1.fits"],
        ),
        (
            "d1.fits,dark,1,,,\nd2.fits,dark,1,,,\nf1.fits,flat,2,,,\n",
            "m.csv",
            &["every dark is at exposure 1 s", "2 exposure times"],
        ),
        ("f1.fits,flat,1,,,\n", "m.csv", &["no dark stack"]),
    ];
    for (rows, file, says) in cases {
        let (dir, manifest) = campaign(Some(rows));
        stack(&dir.path().join("shape.fits"), (4, 4), 10, 0.0, &[]);
        let (code, err, wrote) = run_err(dir.path(), &["--manifest", manifest.to_str().unwrap()]);
        assert_eq!(code, 1, "{rows}: {err}");
        assert!(err.contains(file), "{rows}: {err}");
        for s in says {
            assert!(err.contains(s), "{rows}: {s} in {err}");
        }
        assert!(!wrote, "{rows}: no output");
    }
}

#[test]
fn keyword_problems_refused_naming_the_file() {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("a.fits");
    stack(
        &p,
        (4, 4),
        3,
        0.0,
        &[key("IMAGETYP", KeyValue::Str("Flat Field".into()), "")],
    );
    let a = p.to_str().unwrap();
    let cases: [(&[&str], i32, &[&str]); 3] = [
        (&[a, "--kind", "dark"], 1, &["a.fits", "no keyword EXPTIME"]),
        (
            &[
                a,
                "--kind",
                "dark",
                "--kind-key",
                "IMAGETYP",
                "--exposure-key",
                "NAXIS",
            ],
            1,
            &["a.fits", "conflicting kind"],
        ),
        (&[a], 2, &["kind"]),
    ];
    for (args, want, says) in cases {
        let (code, err, wrote) = run_err(dir.path(), args);
        assert_eq!(code, want, "{args:?}: {err}");
        for s in says {
            assert!(err.contains(s), "{args:?}: {s} in {err}");
        }
        assert!(!wrote);
    }
}

#[test]
fn usage_errors_exit_2() {
    let (dir, manifest) = campaign(None);
    let m = manifest.to_str().unwrap();
    let cases: [&[&str]; 3] = [
        &[],
        &["--manifest", m, "--emva-descriptor", m],
        &["--manifest", m, "d1.fits"],
    ];
    for args in cases {
        let (code, err, wrote) = run_err(dir.path(), args);
        assert_eq!(code, 2, "{args:?}: {err}");
        assert!(!wrote);
    }
}

#[test]
fn emccd_darks_at_one_gain_run_with_cic_not_separable() {
    let (dir, manifest) = campaign(Some("d1.fits,dark,0.1,300,,\nd2.fits,dark,1,300,,\n"));
    let out = dir.path().join("out");
    let o = detnoise()
        .args([
            "campaign",
            "--no-em-fit",
            "--manifest",
            manifest.to_str().unwrap(),
        ])
        .args(["--gain-e-per-adu", "2", "--out"])
        .arg(&out)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert!(String::from_utf8_lossy(&o.stderr).contains("not separable"));
    let json: Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("campaign.json")).unwrap()).unwrap();
    assert_eq!(json["design"]["cic_separable"], false);
    assert_eq!(json["design"]["dark_em_gains"], serde_json::json!([300.0]));
}

#[test]
fn stack_figures_agree_with_darks_on_the_same_stack() {
    let (dir, manifest) = campaign(None);
    let out = dir.path().join("out");
    let json = run_ok(&["--manifest", manifest.to_str().unwrap()], &out);
    let darks = dir.path().join("darks");
    detnoise()
        .args(["darks", "--gain-e-per-adu", "2", "--out"])
        .arg(&darks)
        .arg(dir.path().join("d2.fits"))
        .assert()
        .success();
    let summary: Value =
        serde_json::from_str(&std::fs::read_to_string(darks.join("summary.json")).unwrap())
            .unwrap();
    let c = &json["stacks"][1];
    assert_eq!(c["temporal_noise"], summary["temporal_noise"]);
    assert_eq!(c["inputs"][0]["blake3"], summary["inputs"][0]["blake3"]);
    let mean = c["mean_adu"].as_f64().unwrap();
    let offset = summary["offset_adu"]["mean"].as_f64().unwrap();
    assert!((mean - offset).abs() < 1e-9, "{mean} vs {offset}");
}

/// An EMCCD dark stack at `path`: `frames` frames of 32 x 32, 0.1 input electrons per pixel
/// per frame through an exponential register of mean `gain` (e-/e-), 10 e- read noise, 2 e-
/// per adu, bias 500 adu.
fn emccd_stack(path: &Path, frames: usize, gain: f64, seed: u64) {
    let mut n = Noise(seed);
    let p0 = (-0.1f64).exp();
    let mut next = || -> Vec<f64> {
        (0..32 * 32)
            .map(|_| {
                // Poisson(0.1) by inversion; each electron an exponential of mean `gain`.
                let (u, mut k, mut p, mut cdf) = (n.uniform(), 0, p0, p0);
                while u > cdf && k < 10 {
                    k += 1;
                    p *= 0.1 / k as f64;
                    cdf += p;
                }
                let mut out = 0.0;
                for _ in 0..k {
                    out -= gain * (1.0 - n.uniform()).ln();
                }
                500.0 + (out + 10.0 * n.gauss()) / 2.0
            })
            .collect()
    };
    write_cube(path, (32, 32), frames, true, &mut next, &[]).unwrap();
}

#[test]
fn emccd_darks_get_the_em_histogram_fit() {
    let dir = tempfile::tempdir().unwrap();
    let mut rows = String::new();
    for (k, (t, g)) in [(0.1, 100.0), (1.0, 100.0), (0.1, 300.0)]
        .into_iter()
        .enumerate()
    {
        emccd_stack(
            &dir.path().join(format!("e{k}.fits")),
            100,
            g,
            11 + k as u64,
        );
        rows += &format!("e{k}.fits,dark,{t},{g},,\n");
    }
    let manifest = dir.path().join("m.csv");
    std::fs::write(&manifest, format!("{HEADER}{rows}")).unwrap();
    let out = dir.path().join("out");
    let json = run_ok(&["--manifest", manifest.to_str().unwrap()], &out);
    assert_eq!(json["design"]["cic_separable"], true);
    for s in json["stacks"].as_array().unwrap() {
        let want = s["condition"]["em_gain"].as_f64().unwrap();
        let fit = &s["em_fit"];
        let (g, se) = (
            fit["em_gain"].as_f64().unwrap(),
            fit["em_gain_se"].as_f64().unwrap(),
        );
        assert!(
            (g / want - 1.0).abs() < 0.2 && se > 0.0,
            "G {g} +/- {se} for {want}"
        );
        let lambda = fit["lambda_e"].as_f64().unwrap();
        assert!((lambda - 0.1).abs() < 0.03, "lambda {lambda}");
    }
    let csv = std::fs::read_to_string(out.join("conditions.csv")).unwrap();
    let head: Vec<&str> = csv.lines().next().unwrap().split(',').collect();
    let col = head
        .iter()
        .position(|h| *h == "em_fit_gain_e_per_e")
        .unwrap();
    for line in csv.lines().skip(1) {
        assert!(!line.split(',').nth(col).unwrap().is_empty(), "{line}");
    }
}

#[test]
fn an_out_with_foreign_files_is_refused_before_any_work_and_left_alone() {
    let (dir, manifest) = campaign(None);
    let out = dir.path().join("out");
    std::fs::create_dir(&out).unwrap();
    std::fs::write(out.join("notes.txt"), "mine").unwrap();
    let (code, err, _) = run_err(dir.path(), &["--manifest", manifest.to_str().unwrap()]);
    assert_eq!(code, 2, "{err}");
    assert!(err.contains("--out"), "{err}");
    assert_eq!(std::fs::read_dir(&out).unwrap().count(), 1);
    assert_eq!(
        std::fs::read_to_string(out.join("notes.txt")).unwrap(),
        "mine"
    );
}
