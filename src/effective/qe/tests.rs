use super::*;
use crate::detector::{EmRegister, EmccdStochastic, ScmosConstant};
use crate::progress::Silent;

/// Absolute target `target_se` only, up to `max_iters`.
fn absolute(target_se: f64, max_iters: u64) -> QePrecision {
    QePrecision {
        target_se,
        target_rel: 0.0,
        max_iters,
    }
}

#[test]
fn a_simple_model_detector_has_its_own_factor_within_the_target() {
    // A detector that is itself `emccd-simple:q0` (the same read noise) must come back at q0:
    // on common random numbers the only error is the interpolation across the bracket, within
    // 3 SE, and the SE meets the target (iterations added where the start did not suffice).
    let mut cfg = SimConfig::paper(8);
    cfg.signal_photons = 50.0;
    cfg.iters = 2000;
    let precision = absolute(0.02, 40_000);
    for q0 in [0.5, 0.35, 0.8] {
        let det = EmccdSimple::new(q0, 0.1).unwrap();
        let e = effective_qe(&cfg, &det, 0.1, &precision, &Silent).unwrap();
        assert_eq!(e.status, QeStatus::Ok, "{q0}: {e:?}");
        assert_eq!(e.target_se, Some(0.02));
        assert!(e.qe_factor_se > 0.0 && e.qe_factor_se <= 0.02, "{e:?}");
        assert!(
            (e.qe_factor - q0).abs() < 3.0 * e.qe_factor_se,
            "{q0}: {e:?}"
        );
        // The final grid brackets the answer and R falls as q grows.
        assert!(e.qe_grid.windows(2).all(|w| w[0] > w[1]), "{e:?}");
        assert!(e.qe_grid[0] >= e.qe_factor && e.qe_factor >= e.qe_grid[3]);
        assert!(e.r_simple_px[0] < e.r_simple_px[3]);
    }
}

#[test]
fn a_high_gain_register_at_high_signal_is_the_simple_model_at_one_over_f_squared() {
    // Shot noise dominates at 1,000 photons: the centroid's variance is F^2 sum lambda_i d_i^2
    // / S^2 for the register's output and sum lambda_i d_i^2 / (q S^2) for the simple model,
    // equal at q = 1 / F^2 (0.5004 for g = 500, 520 stages); the same read noise (50 e- / 500)
    // on both sides. Within 3 SE.
    let mut cfg = SimConfig::paper(8);
    cfg.signal_photons = 1000.0;
    cfg.iters = 4000;
    let register = EmRegister::new(500.0, 520).unwrap();
    let truth = 1.0 / register.excess_noise_factor_sq();
    let det = EmccdStochastic::new(register, 50.0, false);
    let e = effective_qe(&cfg, &det, 0.1, &absolute(0.01, 80_000), &Silent).unwrap();
    assert_eq!(e.status, QeStatus::Ok, "{e:?}");
    assert!(
        (e.qe_factor - truth).abs() < 3.0 * e.qe_factor_se,
        "{truth}: {e:?}"
    );
    let z = e.paper_z().unwrap();
    assert!((z - (e.qe_factor - 0.5) / e.qe_factor_se).abs() < 1e-12);
}

#[test]
fn a_detector_better_than_every_factor_is_above_range() {
    // A noiseless full-QE readout beats the simple model at q = 1 with 0.5 e- of read noise:
    // the factor is 1 (a bound), with the status saying so.
    let mut cfg = SimConfig::paper(6);
    cfg.signal_photons = 50.0;
    cfg.iters = 1000;
    let det = ScmosConstant::new(0.0, "noiseless".into());
    let e = effective_qe(&cfg, &det, 0.5, &QePrecision::default(), &Silent).unwrap();
    assert_eq!(e.status, QeStatus::AboveRange, "{e:?}");
    assert_eq!(e.qe_factor, 1.0);
    assert!(e.status.has_value() && e.paper_z().is_none());
}

#[test]
fn bad_precision_and_read_noise_are_refused_naming_the_field() {
    let cfg = SimConfig::paper(4);
    let det = EmccdSimple::paper();
    let bad = QePrecision {
        target_se: -0.1,
        ..QePrecision::default()
    };
    let e = effective_qe(&cfg, &det, 0.1, &bad, &Silent).unwrap_err();
    assert!(e.to_string().contains("`qe_target_se`"), "{e}");
    let cap = QePrecision {
        max_iters: 10,
        ..QePrecision::default()
    };
    let e = effective_qe(&cfg, &det, 0.1, &cap, &Silent).unwrap_err();
    assert!(e.to_string().contains("`max_iters`"), "{e}");
    let e = effective_qe(&cfg, &det, f64::NAN, &QePrecision::default(), &Silent).unwrap_err();
    assert!(e.to_string().contains("`emccd_read_noise_e`"), "{e}");
    for s in QeStatus::ALL {
        assert_eq!(serde_json::to_value(s).unwrap(), s.label());
    }
}

#[test]
fn the_standard_error_is_calibrated_across_independent_seeds() {
    // K = 30 solves of an EMCCD (g = 500) at 8x8 px, S = 100, on independent seeds with a fixed
    // 2,000 frames: the sum of squared deviations of q from their mean over the mean reported
    // SE^2 lies within the 0.1 % bounds of chi-square with 29 degrees of freedom.
    let mut cfg = SimConfig::paper(8);
    cfg.signal_photons = 100.0;
    cfg.iters = 2000;
    let det = EmccdStochastic::new(EmRegister::new(500.0, 520).unwrap(), 50.0, false);
    let k = 30;
    let solves: Vec<QeFactor> = (0..k)
        .map(|seed| {
            let cfg = SimConfig {
                seed: 500 + seed,
                ..cfg.clone()
            };
            effective_qe(&cfg, &det, 0.1, &absolute(0.0, 2000), &Silent).unwrap()
        })
        .collect();
    assert!(
        solves.iter().all(|e| e.status == QeStatus::Ok),
        "{solves:?}"
    );
    let n = k as f64;
    let mean = solves.iter().map(|e| e.qe_factor).sum::<f64>() / n;
    let ss: f64 = solves.iter().map(|e| (e.qe_factor - mean).powi(2)).sum();
    let var = solves.iter().map(|e| e.qe_factor_se.powi(2)).sum::<f64>() / n;
    let (lo, hi) = crate::effective::solve::tests::chi_square_bounds(n - 1.0);
    let x = ss / var;
    assert!(
        x > lo && x < hi,
        "chi-square {x} outside ({lo}, {hi}); mean {mean}"
    );
    println!(
        "chi-square {x} in ({lo}, {hi}); mean q {mean}, SE {}",
        var.sqrt()
    );
}
