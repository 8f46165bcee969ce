//! The telegraph fit against simulated Markov chains with known levels, occupancies and
//! dwell times, and the chain formulas against closed forms.

use rand_distr::{Distribution, StandardNormal};

use super::*;
use crate::rng::stream;
use crate::synth::RtsChain;

/// `t` frames of a pixel switching between `levels` (adu) by `chain`, with Gaussian noise
/// of `width` (adu).
fn series(chain: &RtsChain, levels: &[f64], width: f64, t: usize, seed: u64) -> Vec<f64> {
    let mut rng = stream(seed, 0, 0x7e1e);
    let mut s = chain.start(&mut rng);
    (0..t)
        .map(|_| {
            let g: f64 = StandardNormal.sample(&mut rng);
            let y = levels[s as usize] + width * g;
            s = chain.step(s, &mut rng);
            y
        })
        .collect()
}

/// z-score of a fitted figure against the truth.
fn z(est: f64, se: f64, truth: f64) -> f64 {
    (est - truth) / se
}

#[test]
fn a_two_level_chain_is_recovered_within_its_standard_errors() {
    // Levels 0 and 6 adu, width 1.5 adu, dwell 40 and 20 frames (occupancy 2/3, 1/3), 4000
    // frames: ~130 runs in each level.
    let chain = RtsChain::new(&[40.0, 20.0], None).unwrap();
    let y = series(&chain, &[0.0, 6.0], 1.5, 4000, 1);
    let fit = fit_telegraph(&y).unwrap();
    assert_eq!(fit.levels.len(), 2, "{fit:?}");
    assert_eq!(fit.status, FitStatus::Ok);
    let mean = y.iter().sum::<f64>() / y.len() as f64;
    let (lo, hi) = (&fit.levels[0], &fit.levels[1]);
    assert!(z(lo.mean, lo.mean_se, -mean).abs() < 4.0, "{fit:?}");
    assert!(z(hi.mean, hi.mean_se, 6.0 - mean).abs() < 4.0, "{fit:?}");
    assert!(
        z(lo.occupancy, lo.occupancy_se, 2.0 / 3.0).abs() < 4.0,
        "{fit:?}"
    );
    assert!(
        z(lo.dwell_frames, lo.dwell_se_frames, 40.0).abs() < 4.0,
        "{fit:?}"
    );
    assert!(
        z(hi.dwell_frames, hi.dwell_se_frames, 20.0).abs() < 4.0,
        "{fit:?}"
    );
    // Widths: SE sigma / sqrt(2 n).
    assert!(
        (lo.width - 1.5).abs() < 4.0 * 1.5 / (2.0 * 2600.0f64).sqrt(),
        "{fit:?}"
    );
    // Levels are relative to the series' mean: occupancy-weighted they sum to 0.
    let s: f64 = fit.levels.iter().map(|l| l.occupancy * l.mean).sum();
    assert!(s.abs() < 1e-9, "{s}");
}

#[test]
fn a_three_level_chain_gets_three_levels() {
    let chain = RtsChain::new(&[30.0, 15.0, 15.0], None).unwrap();
    let y = series(&chain, &[0.0, 8.0, 20.0], 1.5, 4000, 2);
    let fit = fit_telegraph(&y).unwrap();
    assert_eq!(fit.levels.len(), 3, "{fit:?}");
    assert_eq!(fit.status, FitStatus::Ok);
    let mean = y.iter().sum::<f64>() / y.len() as f64;
    for (l, (truth, dwell)) in fit
        .levels
        .iter()
        .zip([(0.0, 30.0), (8.0, 15.0), (20.0, 15.0)])
    {
        assert!(z(l.mean, l.mean_se, truth - mean).abs() < 4.0, "{fit:?}");
        assert!(
            z(l.dwell_frames, l.dwell_se_frames, dwell).abs() < 4.0,
            "{fit:?}"
        );
    }
}

#[test]
fn white_noise_is_not_a_telegraph() {
    let mut rng = stream(3, 0, 0x7e1e);
    let y: Vec<f64> = (0..2000).map(|_| StandardNormal.sample(&mut rng)).collect();
    let fit = fit_telegraph(&y).unwrap();
    assert_eq!(fit.status, FitStatus::Imprecise, "{fit:?}");
    assert!(fit.bic[0] < fit.bic[1] && fit.bic[0] < fit.bic[2]);
    assert!(fit_telegraph(&[1.0; 100]).is_none());
    assert!(fit_telegraph(&[1.0, 2.0]).is_none());
}

#[test]
fn standard_errors_match_the_scatter_of_replicas() {
    // 60 replicas of a 2000-frame chain (dwell 25 and 50 frames, levels 0 and 5 adu, width
    // 1 adu): the z-scores of occupancy and dwell time have a standard deviation near 1;
    // with 60 replicas that is 1 +- 0.09 (1 SE), bound at 0.6 to 1.4.
    let chain = RtsChain::new(&[25.0, 50.0], None).unwrap();
    let mut zs: [Vec<f64>; 3] = Default::default();
    for seed in 0..60 {
        let y = series(&chain, &[0.0, 5.0], 1.0, 2000, 100 + seed);
        let f = fit_telegraph(&y).unwrap();
        let l = &f.levels;
        zs[0].push(z(l[0].occupancy, l[0].occupancy_se, 1.0 / 3.0));
        zs[1].push(z(l[0].dwell_frames, l[0].dwell_se_frames, 25.0));
        zs[2].push(z(l[1].dwell_frames, l[1].dwell_se_frames, 50.0));
    }
    for (k, v) in zs.iter().enumerate() {
        let n = v.len() as f64;
        let m = v.iter().sum::<f64>() / n;
        let sd = (v.iter().map(|x| (x - m) * (x - m)).sum::<f64>() / (n - 1.0)).sqrt();
        assert!(m.abs() < 4.0 / n.sqrt(), "figure {k}: mean z {m}");
        assert!(sd > 0.6 && sd < 1.4, "figure {k}: sd of z {sd}");
    }
}

#[test]
fn chain_formulas_match_closed_forms() {
    // Two states, leaving probabilities a = 0.1, b = 0.3: pi_1 = b / (a + b) = 0.75, and the
    // time average of being in state 1 has asymptotic variance pi_1 pi_2 (1 + l) / (1 - l)
    // with l = 1 - a - b.
    let a = [0.9, 0.1, 0.3, 0.7];
    let pi = stationary(&a, 2);
    assert!((pi[0] - 0.75).abs() < 1e-14 && (pi[1] - 0.25).abs() < 1e-14);
    let z = fundamental(&a, &pi, 2);
    let var = pi[0] * (1.0 - pi[0]) + 2.0 * pi[0] * (z[0] - 1.0);
    let l = 0.6;
    assert!(
        (var - 0.75 * 0.25 * (1.0 + l) / (1.0 - l)).abs() < 1e-12,
        "{var}"
    );
    // A 3 x 3 system solved exactly.
    let mut m = vec![2.0, 1.0, 0.0, 1.0, 3.0, 1.0, 0.0, 1.0, 4.0];
    let mut b = vec![3.0, 5.0, 5.0];
    solve(&mut m, &mut b, 3);
    for (x, want) in b.iter().zip([1.0, 1.0, 1.0]) {
        assert!((x - want).abs() < 1e-14);
    }
}
