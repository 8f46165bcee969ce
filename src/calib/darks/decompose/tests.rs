//! The decomposition against simulated Gaussian frames with known components: estimates
//! within their standard errors, and standard errors that match the scatter of replicas.

use rand_distr::{Distribution, StandardNormal};

use super::*;
use crate::rng::stream;

/// Line variances and per-pixel variances of `frames` frames of `shape` with pixel noise of
/// variance `p_i` = p (0.5 + i / npix), row noise r, column noise c and noise common to the
/// whole frame f (adu^2).
fn simulate(
    shape: (usize, usize),
    frames: usize,
    (p, r, c, f): (f64, f64, f64, f64),
    seed: u64,
) -> (LineVariances, Vec<f64>) {
    let (rows, cols) = shape;
    let npix = rows * cols;
    let mut rng = stream(seed, 0, 0xdec0);
    let mut g = || -> f64 { StandardNormal.sample(&mut rng) };
    let sd: Vec<f64> = (0..npix)
        .map(|i| (p * (0.5 + i as f64 / npix as f64)).sqrt())
        .collect();
    let mut x = vec![vec![0.0; npix]; frames];
    for frame in x.iter_mut() {
        // (No draw without it, so that the other components' draws are those of before.)
        let common = if f > 0.0 { f.sqrt() * g() } else { 0.0 };
        let rn: Vec<f64> = (0..rows).map(|_| r.sqrt() * g()).collect();
        let cn: Vec<f64> = (0..cols).map(|_| c.sqrt() * g()).collect();
        for (i, v) in frame.iter_mut().enumerate() {
            *v = sd[i] * g() + rn[i / cols] + cn[i % cols] + common;
        }
    }
    let var = |s: &[f64]| {
        let n = s.len() as f64;
        let m = s.iter().sum::<f64>() / n;
        s.iter().map(|v| (v - m) * (v - m)).sum::<f64>() / (n - 1.0)
    };
    let line = |pix: &dyn Fn(usize) -> Vec<usize>, count: usize| -> Vec<f64> {
        (0..count)
            .map(|l| {
                let idx = pix(l);
                let means: Vec<f64> = x
                    .iter()
                    .map(|f| idx.iter().map(|i| f[*i]).sum::<f64>() / idx.len() as f64)
                    .collect();
                var(&means)
            })
            .collect()
    };
    let row_var = line(&|r| (r * cols..(r + 1) * cols).collect(), rows);
    let col_var = line(&|c| (0..rows).map(|r| r * cols + c).collect(), cols);
    let frame_var = line(&|_| (0..npix).collect(), 1)[0];
    let pixel_var = (0..npix)
        .map(|i| var(&x.iter().map(|f| f[i]).collect::<Vec<f64>>()))
        .collect();
    let lines = LineVariances {
        frames,
        row_var_adu2: row_var,
        col_var_adu2: col_var,
        frame_var_adu2: frame_var,
    };
    (lines, pixel_var)
}

#[test]
fn components_are_recovered_within_their_standard_errors() {
    // Pixel 4 adu^2 on average, row 0.25, column 0.09: a 40 x 48 camera, 200 frames.
    let shape = (40, 48);
    let truth = (4.0, 0.25, 0.09, 0.0);
    let (lines, pv) = simulate(shape, 200, truth, 1);
    let t = TemporalNoise::decompose(&lines, &pv, shape);
    let (row, col) = (t.row.unwrap(), t.column.unwrap());
    let z = |est: (f64, f64), want: f64| (est.0 - want) / est.1;
    assert!(z(t.total, 4.0 + 0.25 + 0.09).abs() < 4.0, "{t:?}");
    assert!(z(t.pixel, 4.0).abs() < 4.0, "{t:?}");
    assert!(z(row, 0.25).abs() < 4.0, "{t:?}");
    assert!(z(col, 0.09).abs() < 4.0, "{t:?}");
    // The line components are clear detections (their SEs are a fraction of them).
    assert!(row.1 < 0.2 * 0.25 && col.1 < 0.3 * 0.09, "{t:?}");
    // The rms figures, in e- with 0.5 e-/adu.
    let s = t.summary(Some(0.5));
    let (r, se) = rms_of(row);
    assert_eq!((s.row_rms_adu, s.row_rms_se_adu), (Some(r), Some(se)));
    assert_eq!(s.row_rms_e, Some(0.5 * r));
    assert!(t.summary(None).row_rms_e.is_none());
}

/// The z-scores (estimate - truth) / SE of the pixel, row, column and frame components over
/// `replicas` simulated stacks of `shape` and `frames`.
fn z_scores(
    shape: (usize, usize),
    frames: usize,
    truth: (f64, f64, f64, f64),
    replicas: u64,
) -> [Vec<f64>; 4] {
    let mut z: [Vec<f64>; 4] = Default::default();
    for seed in 0..replicas {
        let (lines, pv) = simulate(shape, frames, truth, 100 + seed);
        let t = TemporalNoise::decompose(&lines, &pv, shape);
        let want = [truth.0, truth.1, truth.2, truth.3];
        let got = [t.pixel, t.row.unwrap(), t.column.unwrap(), t.frame.unwrap()];
        for k in 0..4 {
            z[k].push((got[k].0 - want[k]) / got[k].1);
        }
    }
    z
}

#[test]
fn standard_errors_match_the_scatter_of_replicas() {
    // 120 replicas of a 12 x 16 camera, 30 frames: the z-scores of each component have a
    // standard deviation near 1, which 120 replicas pin to about +-0.065 (1 SE of a standard
    // deviation: 1 / sqrt(2 x 119)); with and without noise common to whole frames (one draw
    // per frame for every row and column, not one per row or column).
    for truth in [(2.0, 0.3, 0.2, 0.0), (2.0, 0.3, 0.2, 0.4)] {
        for (k, zs) in z_scores((12, 16), 30, truth, 120).iter().enumerate() {
            let n = zs.len() as f64;
            let m = zs.iter().sum::<f64>() / n;
            let sd = (zs.iter().map(|v| (v - m) * (v - m)).sum::<f64>() / (n - 1.0)).sqrt();
            // Mean z within 4 / sqrt(120) of 0; spread within 4 x 0.065 of 1.
            assert!(
                m.abs() < 4.0 / n.sqrt(),
                "{truth:?} component {k}: mean z {m}"
            );
            assert!(
                (sd - 1.0).abs() < 0.26,
                "{truth:?} component {k}: sd of z {sd}"
            );
        }
    }
}

#[test]
fn noise_common_to_whole_frames_is_counted_once() {
    // Issue 31's camera: 4.027 adu of pixel noise, 0.75 adu common to whole frames, and row
    // and column terms of 0.5 and 0.3 adu; 40 x 48 pixels, 200 frames. The frame term was
    // counted in both line terms and taken twice off the pixel term (3.960 adu, -32 SE).
    let shape = (40, 48);
    let truth = (4.027f64.powi(2), 0.25, 0.09, 0.75f64.powi(2));
    let (lines, pv) = simulate(shape, 200, truth, 3);
    let t = TemporalNoise::decompose(&lines, &pv, shape);
    let z = |est: (f64, f64), want: f64| (est.0 - want) / est.1;
    let (row, col, frame) = (t.row.unwrap(), t.column.unwrap(), t.frame.unwrap());
    assert!(
        z(t.total, truth.0 + 0.25 + 0.09 + truth.3).abs() < 4.0,
        "{t:?}"
    );
    assert!(z(t.pixel, truth.0).abs() < 4.0, "{t:?}");
    assert!(z(row, 0.25).abs() < 4.0, "{t:?}");
    assert!(z(col, 0.09).abs() < 4.0, "{t:?}");
    assert!(z(frame, truth.3).abs() < 4.0, "{t:?}");
    // One draw per frame: the frame term is known to about sqrt(2 / 199) of itself.
    assert!(frame.1 > 0.08 * truth.3, "{t:?}");
    let s = t.summary(Some(2.0));
    let (f, se) = rms_of(frame);
    assert_eq!((s.frame_rms_adu, s.frame_rms_se_adu), (Some(f), Some(se)));
    assert_eq!(s.frame_rms_e, Some(2.0 * f));
}

#[test]
fn a_single_row_or_column_has_no_line_component_and_small_ones_clamp_at_zero() {
    let (lines, pv) = simulate((1, 30), 50, (1.0, 0.0, 0.0, 0.0), 7);
    let t = TemporalNoise::decompose(&lines, &pv, (1, 30));
    assert!(t.column.is_none() && t.frame.is_none() && t.row.is_some());
    let s = t.summary(Some(2.0));
    assert!(s.column_rms_adu.is_none() && s.column_rms_e.is_none());
    assert!(s.frame_rms_adu.is_none() && s.frame_rms_e.is_none());
    // rms of a negative variance estimate is 0, its SE the square root of the variance's.
    assert_eq!(rms_of((-0.04, 0.01)), (0.0, 0.01 / 0.01f64.sqrt()));
    let (r, se) = rms_of((4.0, 0.4));
    assert_eq!(r, 2.0);
    assert!((se - 0.4 / (4.0 + 0.4f64.sqrt())).abs() < 1e-15);
}
