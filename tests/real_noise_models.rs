//! The readout models of the camera's real noise (`scmos-rts`, `scmos-correlated`,
//! `scmos-frames`) end to end: `scmos-frames` on a synthetic Gaussian camera against
//! `scmos-map` on the same stack's noise map, and the three models through the command line.

mod common;

use std::path::Path;
use std::sync::Arc;

use common::{data, detnoise, open};
use detnoise::calib::{Map, Unit};
use detnoise::detector::{DarkFrames, Readout, ScmosFrames, ScmosMap};
use detnoise::effective::{effective_sigma, Precision};
use detnoise::montecarlo::SimConfig;
use detnoise::progress::Silent;

/// The bundled synthetic sCMOS darks (100 frames of 64x64 px, Gaussian pixels, u16) and the
/// conversion gain it was made with (e- per adu; its manifest).
const DARKS: &str = "scmos-darks-64x64.fits";
const GAIN_E_PER_ADU: f64 = 0.25;

/// The stack's per-pixel rms in e-: sample standard deviation over its frames (N - 1 in the
/// denominator) x gain, the spread `scmos-frames` draws from (it undoes the (N - 1) / N that
/// subtracting the stack's own mean takes).
fn rms_e_map(path: &Path) -> Map {
    let stack = open(path);
    let npx = stack.pixels();
    let (mut sum, mut sq) = (vec![0.0; npx], vec![0.0; npx]);
    let mut frame = vec![0.0; npx];
    let mut reader = stack.reader();
    while reader.next_frame(&mut frame).unwrap().is_some() {
        for ((s, q), &v) in sum.iter_mut().zip(&mut sq).zip(&frame) {
            *s += v;
            *q += v * v;
        }
    }
    let n = stack.frames as f64;
    let rms: Vec<f64> = sum
        .iter()
        .zip(&sq)
        .map(|(s, q)| {
            ((q / n - (s / n) * (s / n)).max(0.0) * n / (n - 1.0)).sqrt() * GAIN_E_PER_ADU
        })
        .collect();
    Map::new(stack.shape.0, stack.shape.1, rms, Unit::Electrons).with_source("computed")
}

#[test]
fn frames_of_a_gaussian_camera_give_the_effective_noise_of_its_map() {
    // A synthetic camera whose pixels are Gaussian: reading through its own bias-subtracted
    // frames must give the effective read noise of reading through its rms map, within the
    // two values' combined standard error (4 SE; both at 8x8 px, airy:2, 50 photons,
    // 80,000 frames, seed 1).
    let path = data(DARKS);
    let map = Arc::new(rms_e_map(&path));
    let frames = Arc::new(DarkFrames::read(&[path], GAIN_E_PER_ADU, 512.0).unwrap());
    assert_eq!((frames.kept(), frames.total), (100, 100));
    let by_map = ScmosMap::new(map, 8).unwrap();
    let by_frames = ScmosFrames::new(frames, 8).unwrap();
    // The frames' power is the map's: per-pixel sample variance of the stack (to f32
    // rounding).
    let (a, b) = (by_map.noise_scale_e(), by_frames.noise_scale_e());
    assert!((a / b - 1.0).abs() < 1e-6, "rms {a} vs {b}");
    let cfg = SimConfig {
        iters: 80_000,
        ..SimConfig::paper(8)
    };
    let precision = Precision::fixed(cfg.iters);
    let solve = |m: &dyn Readout| effective_sigma(&cfg, m, &precision, &Silent).unwrap();
    let (m, f) = (solve(&by_map), solve(&by_frames));
    // Two separate solves (separate experiments): their SEs add in quadrature.
    let se = m.sigma_eff_se_e.hypot(f.sigma_eff_se_e);
    assert!(
        (m.sigma_eff_e - f.sigma_eff_e).abs() < 4.0 * se,
        "scmos-map {} +- {}, scmos-frames {} +- {}",
        m.sigma_eff_e,
        m.sigma_eff_se_e,
        f.sigma_eff_e,
        f.sigma_eff_se_e
    );
    assert!(m.sigma_eff_e > 0.3 && se < 0.05, "{m:?}");
}

/// A telegraph level: (level e-, occupancy, width e-).
type Level = (f64, f64, f64);

/// One row of an `rts.csv`: x_px, y_px, status and the levels.
type RtsRow<'a> = (usize, usize, &'a str, &'a [Level]);

/// An `rts.csv` in the shared format; e- cells empty unless `electrons`.
fn rts_csv(rows: &[RtsRow], electrons: bool) -> String {
    let mut header = vec!["x_px,y_px,n_levels,status".to_string()];
    for k in 1..=3 {
        header.push(format!(
            "level_{k}_adu,level_{k}_se_adu,level_{k}_e,occupancy_{k},occupancy_{k}_se,\
             width_{k}_adu,width_{k}_e,dwell_{k}_frames,dwell_{k}_se_frames"
        ));
    }
    let mut lines = vec![header.join(",")];
    for (x, y, status, levels) in rows {
        let mut cells = vec![format!("{x},{y},{},{status}", levels.len())];
        for k in 0..3 {
            cells.push(match levels.get(k) {
                Some((l, o, w)) => {
                    let e = |v: f64| {
                        if electrons {
                            v.to_string()
                        } else {
                            String::new()
                        }
                    };
                    format!(
                        "{},0.02,{},{o},0.01,{},{},8,0.5",
                        l * 4.0,
                        e(*l),
                        w * 4.0,
                        e(*w)
                    )
                }
                None => ",,,,,,,,".into(),
            });
        }
        lines.push(cells.join(","));
    }
    lines.join("\n") + "\n"
}

const TWO: &[Level] = &[(-6.0, 0.25, 0.3), (2.0, 0.75, 0.3)];

#[test]
fn the_three_models_run_in_simulate_and_effective() {
    let dir = tempfile::tempdir().unwrap();
    let rts = dir.path().join("rts.csv");
    let rows: &[RtsRow] = &[
        (3, 5, "ok", TWO),
        (40, 63, "ok", TWO),
        (1, 1, "imprecise", TWO),
    ];
    std::fs::write(&rts, rts_csv(rows, true)).unwrap();
    let out = dir.path().join("r.csv");
    let run = detnoise()
        .args([
            "simulate",
            "--model",
            "scmos-map,scmos-rts,scmos-correlated,scmos-frames",
        ])
        .args([
            "--subap", "4", "--signal", "50", "--iters", "2000", "--format", "csv",
        ])
        .arg("--map")
        .arg(data("scmos-darks-64x64.truth-rms_e.fits"))
        .arg("--rts-table")
        .arg(&rts)
        .args(["--row-noise-e", "0.4", "--column-noise-e", "0.2"])
        .arg("--dark-frames")
        .arg(data(DARKS))
        .args(["--gain-e-per-adu", "0.25", "--out"])
        .arg(&out)
        .assert()
        .success();
    let stderr = String::from_utf8_lossy(&run.get_output().stderr).to_string();
    assert!(
        stderr.contains("1 of 3 RTS pixels skipped") && stderr.contains("--rts-table"),
        "{stderr}"
    );
    assert!(
        stderr.contains("scmos-frames: 100 of 100 dark frames of 64x64 px kept"),
        "{stderr}"
    );
    let table = std::fs::read_to_string(&out).unwrap();
    for model in ["scmos-rts", "scmos-correlated", "scmos-frames"] {
        assert_eq!(
            table
                .lines()
                .filter(|l| l.starts_with(&format!("{model},")))
                .count(),
            1,
            "{table}"
        );
    }
    assert!(!table.to_lowercase().contains("nan"));
    let eff = dir.path().join("eff");
    let run = detnoise()
        .args([
            "effective",
            "--model",
            "scmos-frames",
            "--subap",
            "4",
            "--spot",
            "airy:2",
        ])
        .args(["--signal", "50", "--iters", "2000", "--max-iters", "2000"])
        .arg("--dark-frames")
        .arg(data(DARKS))
        .args(["--gain-e-per-adu", "0.25", "--out"])
        .arg(&eff)
        .assert()
        .success();
    let stdout = String::from_utf8_lossy(&run.get_output().stdout).to_string();
    assert!(
        stdout.starts_with("scmos-frames: effective read noise"),
        "{stdout}"
    );
    assert!(eff.join("effective_noise.csv").exists());
}

#[test]
fn missing_and_bad_inputs_are_refused_naming_the_option_or_file() {
    let dir = tempfile::tempdir().unwrap();
    let map = data("scmos-darks-64x64.truth-rms_e.fits");
    let adu = dir.path().join("adu.csv");
    std::fs::write(&adu, rts_csv(&[(3, 5, "ok", TWO)], false)).unwrap();
    let far = dir.path().join("far.csv");
    std::fs::write(
        &far,
        rts_csv(&[(3, 5, "ok", TWO), (64, 0, "ok", TWO)], true),
    )
    .unwrap();
    let simulate = |model: &str| {
        let mut c = detnoise();
        c.args([
            "simulate", "--model", model, "--subap", "4", "--iters", "200",
        ]);
        c
    };
    let refused = |mut c: assert_cmd::Command, code: i32, needles: &[&str]| {
        let out = c.assert().code(code);
        let stderr = String::from_utf8_lossy(&out.get_output().stderr).to_string();
        for n in needles {
            assert!(stderr.contains(n), "{n} not in: {stderr}");
        }
    };
    let mut c = simulate("scmos-rts");
    c.arg("--map").arg(&map);
    refused(c, 2, &["--rts-table"]);
    let mut c = simulate("scmos-correlated");
    c.arg("--map").arg(&map).args(["--row-noise-e", "0.3"]);
    refused(c, 2, &["--column-noise-e"]);
    let mut c = simulate("scmos-frames");
    c.arg("--dark-frames").arg(data(DARKS));
    refused(c, 2, &["--gain-e-per-adu"]);
    let mut c = simulate("scmos-rts");
    c.arg("--map").arg(&map).arg("--rts-table").arg(&adu);
    refused(c, 1, &["adu.csv: line 2", "--gain-e-per-adu"]);
    let mut c = simulate("scmos-rts");
    c.arg("--map").arg(&map).arg("--rts-table").arg(&far);
    refused(
        c,
        1,
        &[
            "far.csv: line 3",
            "x_px 64",
            "outside the 64x64 px noise map",
        ],
    );
    let mut c = simulate("scmos-frames");
    c.arg("--dark-frames").arg(dir.path().join("none.fits"));
    c.args(["--gain-e-per-adu", "0.25"]);
    refused(c, 1, &["none.fits"]);
    let mut c = simulate("scmos-frames");
    c.arg("--dark-frames").arg(data(DARKS));
    c.args(["--gain-e-per-adu", "0.25", "--dark-frames-max-mib", "0.001"]);
    refused(
        c,
        2,
        &["--dark-frames-max-mib", "holds no frame of --dark-frames"],
    );
    // report reads the models' options too (through the same detector options), before any
    // dark frame is read.
    let mut c = detnoise();
    c.arg("report").arg("--darks").arg(data(DARKS));
    c.args(["--gain-e-per-adu", "0.25", "--quick", "--out"])
        .arg(dir.path().join("rep"));
    c.arg("--rts-table").arg(&adu);
    refused(c, 1, &["adu.csv: line 2", "--gain-e-per-adu"]);
}
