//! `darks` recovers the non-Gaussian noise `synth` injects: the RTS pixels (found, their
//! level steps, occupancies and dwell times within their standard errors), the row and
//! column noise amplitudes, Gaussian pixels' excess kurtosis consistent with 0 and the RTS
//! pixels' excess kurtosis, and the hot pixels.

use std::collections::HashMap;

use detnoise::calib::darks::{dark_maps, kurtosis_se, DarkOptions, FitStatus, FLAG_HOT};
use detnoise::io::FrameStack;
use detnoise::synth::SynthFormat;
use detnoise::synth::{
    draw_truth, write_synthetic, Camera, Defects, RtsParams, ScmosParams, SynthSpec,
};

const SHAPE: (usize, usize) = (64, 64);
const FRAMES: usize = 1000;
/// Pixel noise, row and column noise (e-); conversion gain 0.25 e-/adu (the default).
const PIXEL_E: f64 = 1.5;
const ROW_E: f64 = 0.5;
const COLUMN_E: f64 = 0.3;
const STEP_E: f64 = 8.0;
const DWELL: [f64; 2] = [30.0, 10.0];

fn spec() -> SynthSpec {
    SynthSpec {
        camera: Camera::Scmos(ScmosParams {
            defects: Defects {
                rts: Some(RtsParams {
                    fraction: 0.03,
                    steps_e: vec![STEP_E],
                    step_spread: 0.25,
                    dwell_frames: DWELL.to_vec(),
                    occupancy: None,
                }),
                row_noise_e: ROW_E,
                column_noise_e: COLUMN_E,
                hot_fraction: 0.002,
                hot_dark_e: 50.0,
            },
            ..ScmosParams::default()
        }),
        shape: SHAPE,
        frames: FRAMES,
        light_e: 0.0,
        seed: 13,
        u16_samples: true,
    }
}

/// Mean and sample standard deviation.
fn mean_sd(v: &[f64]) -> (f64, f64) {
    let n = v.len() as f64;
    let m = v.iter().sum::<f64>() / n;
    let sd = (v.iter().map(|x| (x - m) * (x - m)).sum::<f64>() / (n - 1.0)).sqrt();
    (m, sd)
}

#[test]
fn darks_recovers_the_injected_rts_row_column_and_hot_pixels() {
    let d = tempfile::tempdir().unwrap();
    let sp = spec();
    let pdf = detnoise::synth::rms_pdf(&PIXEL_E.to_string()).unwrap();
    let path = d.path().join("rts.fits");
    write_synthetic(&sp, pdf.as_ref(), SynthFormat::Fits, &path).unwrap();
    let truth = draw_truth(&sp, pdf.as_ref());
    let stack = FrameStack::open(std::slice::from_ref(&path)).unwrap();
    let maps = dark_maps(&stack, &DarkOptions::default()).unwrap();
    let gain = 0.25;

    // Row and column noise within 4 of their standard errors (in e- with the mean gain; the
    // per-pixel gain spread of 2 % averages out over a row's 64 pixels to 0.25 %, inside the
    // SE).
    let t = maps.stats.temporal.summary(Some(gain));
    let (row, row_se) = (t.row_rms_e.unwrap(), t.row_rms_se_e.unwrap());
    let (col, col_se) = (t.column_rms_e.unwrap(), t.column_rms_se_e.unwrap());
    assert!((row - ROW_E).abs() < 4.0 * row_se + 0.0025 * ROW_E, "{t:?}");
    assert!(
        (col - COLUMN_E).abs() < 4.0 * col_se + 0.0025 * COLUMN_E,
        "{t:?}"
    );
    assert!(row_se < 0.02 && col_se < 0.02, "{t:?}");

    // RTS pixels: at least 95 % of those injected are fitted `ok` with two levels, and no
    // more than 2 of the 4000 others are fitted (the von Neumann test at 5 SE lets through
    // 3e-7 of white-noise pixels).
    let injected: HashMap<usize, &detnoise::synth::RtsPixelTruth> =
        truth.defects.rts.iter().map(|p| (p.index, p)).collect();
    assert!(injected.len() > 90, "{} RTS pixels", injected.len());
    let fitted = &maps.rts.fitted;
    let found: Vec<_> = fitted
        .iter()
        .filter(|p| injected.contains_key(&p.index) && p.fit.status == FitStatus::Ok)
        .collect();
    let false_pos = fitted
        .iter()
        .filter(|p| !injected.contains_key(&p.index))
        .count();
    assert!(
        found.len() as f64 >= 0.95 * injected.len() as f64,
        "found {} of {}",
        found.len(),
        injected.len()
    );
    assert!(false_pos <= 2, "{false_pos} false RTS pixels");

    // Steps, occupancies and dwell times: z-scores against the truth have mean within
    // 4 / sqrt(n) of 0 and a standard deviation near 1 (0.6 to 1.5).
    let occ_truth = DWELL[0] / (DWELL[0] + DWELL[1]);
    let mut z: [Vec<f64>; 4] = Default::default();
    for p in &found {
        let l = &p.fit.levels;
        assert_eq!(l.len(), 2, "pixel {}: {:?}", p.index, p.fit);
        let g = truth.gain_e_per_adu.data[p.index];
        let step_adu = injected[&p.index].heights_e[1] / g;
        let step_se = l[0].mean_se.hypot(l[1].mean_se);
        z[0].push((l[1].mean - l[0].mean - step_adu) / step_se);
        z[1].push((l[0].occupancy - occ_truth) / l[0].occupancy_se);
        z[2].push((l[0].dwell_frames - DWELL[0]) / l[0].dwell_se_frames);
        z[3].push((l[1].dwell_frames - DWELL[1]) / l[1].dwell_se_frames);
    }
    for (k, v) in z.iter().enumerate() {
        let (m, sd) = mean_sd(v);
        let n = v.len() as f64;
        assert!(m.abs() < 4.0 / n.sqrt(), "figure {k}: mean z {m} (sd {sd})");
        assert!(sd > 0.6 && sd < 1.5, "figure {k}: sd of z {sd} (mean {m})");
    }

    // Excess kurtosis of the Gaussian pixels (neither RTS nor hot) is 0 within the SE of
    // their mean, sqrt(24 / n) / sqrt(pixels).
    let hot = &truth.defects.hot_dark_e;
    let gaussian: Vec<f64> = (0..SHAPE.0 * SHAPE.1)
        .filter(|i| !injected.contains_key(i) && hot[*i] == 0.0)
        .map(|i| maps.stats.excess_kurtosis[i])
        .collect();
    let (m, _) = mean_sd(&gaussian);
    let se = kurtosis_se(FRAMES) / (gaussian.len() as f64).sqrt();
    assert!(m.abs() < 4.0 * se, "Gaussian pixels' mean G2 {m} +- {se}");

    // RTS pixels: a two-level mixture has excess kurtosis A^4 p q (1 - 6 p q) / v^2 with v
    // = s^2 + p q A^2 (A the step, s the Gaussian noise including row, column and the 1/12
    // adu^2 of quantisation); measured minus expected has mean 0 within 4 SE of the mean
    // over the pixels (the chain's correlation widens each pixel's scatter, so the SE is
    // taken from the scatter itself).
    let (p, q) = (occ_truth, 1.0 - occ_truth);
    let diff: Vec<f64> = injected
        .values()
        .map(|t| {
            let g = truth.gain_e_per_adu.data[t.index];
            let a = t.heights_e[1] / g;
            let s2 = (PIXEL_E.powi(2) + ROW_E.powi(2) + COLUMN_E.powi(2)) / (g * g) + 1.0 / 12.0;
            let v = s2 + p * q * a * a;
            let want = a.powi(4) * p * q * (1.0 - 6.0 * p * q) / (v * v);
            maps.stats.excess_kurtosis[t.index] - want
        })
        .collect();
    let (m, sd) = mean_sd(&diff);
    let se = sd / (diff.len() as f64).sqrt();
    assert!(m.abs() < 4.0 * se, "RTS pixels' G2 off by {m} +- {se}");

    // Every hot pixel (50 e- a frame, 200 adu over an offset spread of 2 adu) is flagged hot.
    let hot_idx: Vec<usize> = (0..hot.len()).filter(|i| hot[*i] > 0.0).collect();
    assert!(!hot_idx.is_empty());
    assert!(hot_idx.iter().all(|i| maps.flags[*i] & FLAG_HOT != 0));
}

#[test]
fn rts_outputs_follow_the_shared_table_format() {
    // A small stack through `darks`' outputs: rts.csv has the shared header and one row per
    // fitted pixel, rts-series.csv a frame column and up to 4 pixels, summary.json the new
    // keys with units.
    let d = tempfile::tempdir().unwrap();
    let mut sp = spec();
    sp.frames = 300;
    sp.shape = (24, 20);
    let pdf = detnoise::synth::rms_pdf("1.5").unwrap();
    let path = d.path().join("s.fits");
    write_synthetic(&sp, pdf.as_ref(), SynthFormat::Fits, &path).unwrap();
    let stack = FrameStack::open(std::slice::from_ref(&path)).unwrap();
    let opts = DarkOptions::default();
    let maps = dark_maps(&stack, &opts).unwrap();
    let out = d.path().join("out");
    let inputs = detnoise::calib::summary::unhashed(&stack);
    let s = detnoise::calib::darks::write_outputs(
        &out,
        &stack,
        &maps,
        &opts,
        None,
        inputs,
        "summary.json",
    )
    .unwrap();
    let csv = std::fs::read_to_string(out.join("rts.csv")).unwrap();
    let mut lines = csv.lines();
    assert_eq!(
        lines.next().unwrap(),
        detnoise::calib::darks::rts_columns().join(",")
    );
    assert_eq!(lines.count(), maps.rts.fitted.len());
    assert!(!csv.contains("NaN"));
    let series = std::fs::read_to_string(out.join("rts-series.csv")).unwrap();
    let header: Vec<&str> = series.lines().next().unwrap().split(',').collect();
    assert_eq!(header[0], "frame");
    assert!(header.len() > 1 && header.len() <= 5, "{header:?}");
    assert!(header[1..]
        .iter()
        .all(|h| h.starts_with('x') && h.ends_with("_adu")));
    assert_eq!(series.lines().count(), 1 + 300);
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("summary.json")).unwrap()).unwrap();
    let t = &json["temporal_noise"];
    assert!(t["row_rms_adu"].as_f64().unwrap() > 0.0);
    assert!(t["row_rms_e"].is_null(), "no gain: e- figures are null");
    assert_eq!(json["rts"]["fitted"], maps.rts.fitted.len());
    assert!(json["excess_kurtosis"]["median"].is_number());
    assert!(s.outputs.iter().any(|o| o == "rts.fits"));
    for f in ["excess_kurtosis.fits", "rts.fits"] {
        assert!(out.join(f).metadata().unwrap().len() > 2880);
    }
}

#[test]
fn the_bundled_rts_stack_shows_its_row_and_column_noise_and_rts_pixels() {
    // data-synthetic/scmos-rts-64x64.fits: 200 frames, row 0.5 e-, column 0.3 e-, 126 RTS
    // pixels (its manifest), of which the von Neumann test at 200 frames finds most.
    let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("data-synthetic");
    let stack = FrameStack::open(&[dir.join("scmos-rts-64x64.fits")]).unwrap();
    let maps = dark_maps(&stack, &DarkOptions::default()).unwrap();
    let t = maps.stats.temporal.summary(Some(0.25));
    let z = |v: Option<f64>, se: Option<f64>, truth: f64| (v.unwrap() - truth) / se.unwrap();
    assert!(z(t.row_rms_e, t.row_rms_se_e, ROW_E).abs() < 4.0, "{t:?}");
    assert!(
        z(t.column_rms_e, t.column_rms_se_e, COLUMN_E).abs() < 4.0,
        "{t:?}"
    );
    let truth = std::fs::read_to_string(dir.join("scmos-rts-64x64.truth-rts.csv")).unwrap();
    let injected = truth.lines().count() - 1;
    let ok = maps
        .rts
        .fitted
        .iter()
        .filter(|p| p.fit.status == FitStatus::Ok)
        .count();
    assert_eq!(injected, 126);
    assert!(
        ok as f64 >= 0.8 * injected as f64 && ok <= injected + 2,
        "{ok} of {injected}"
    );
}
