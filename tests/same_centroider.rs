//! The effective read noise of a centroider is referred to the same centroider: a uniform
//! camera through any registered centroider comes back at its own sigma, and a camera with a
//! fixed long-tailed noise map through `wcog` comes back where a constant-sigma ladder run
//! through `wcog` (independent simulations) puts it.

use detnoise::centroid::{CentroiderSpec, CENTROIDERS};
use detnoise::detector::{PerPixelSigma, Readout, ScmosConstant};
use detnoise::effective::{effective_sigma_with, Effective, Precision, Status};
use detnoise::montecarlo::{Arm, Experiment, SimConfig, SimResult};
use detnoise::pdf::RmsPdf;
use detnoise::progress::Silent;

/// `target_se_e` only, from the configuration's iterations up to `max_iters`.
fn absolute(target_se_e: f64, max_iters: u64) -> Precision {
    Precision {
        target_se_e,
        target_rel: 0.0,
        max_iters,
    }
}

#[test]
fn a_uniform_camera_has_its_own_sigma_through_every_centroider() {
    // 6x6 px, airy:2, 50 photons: a uniform 1.2 e- camera read through each registered
    // centroider is matched against constant sigmas read through that centroider (its
    // parameter re-optimised per sigma), so it must come back at 1.2 e- within 3 SE. The
    // cog-equivalent is a value of its own for every method but `cog`, where it is sigma_eff.
    let mut cfg = SimConfig::paper(6);
    cfg.iters = 3000;
    let precision = absolute(0.05, 40_000);
    let sigma = 1.2;
    let uniform = ScmosConstant::new(sigma, "uniform".into());
    for entry in CENTROIDERS {
        let spec = CentroiderSpec::of(entry);
        let e = effective_sigma_with(&cfg, &uniform, spec, &precision, &Silent).unwrap();
        assert_eq!(e.status, Status::Ok, "{}: {e:?}", entry.name);
        assert!(
            (e.sigma_eff_e - sigma).abs() < 3.0 * e.sigma_eff_se_e,
            "{}: {} +- {}",
            entry.name,
            e.sigma_eff_e,
            e.sigma_eff_se_e
        );
        assert!(e.sigma_cog_equiv_e.is_finite(), "{}: {e:?}", entry.name);
        if entry.name == "cog" {
            assert_eq!(e.sigma_cog_equiv_e.to_bits(), e.sigma_eff_e.to_bits());
            assert_eq!(e.sigma_cog_equiv_se_e.to_bits(), e.sigma_eff_se_e.to_bits());
        } else {
            assert!(e.sigma_cog_equiv_se_e > 0.0, "{}: {e:?}", entry.name);
        }
    }
}

/// Side of the map camera's window (px).
const WINDOW: usize = 8;

/// A fixed 8x8 window of the paper's sCMOS rms pdf: its 64 quantiles at (i + 1/2) / 64
/// (median 0.79 e-, a long tail up to several e-), scattered over the window by a fixed
/// permutation, read as a per-pixel readout as `subaps` reads a window of a map.
fn paper_window() -> PerPixelSigma {
    let pdf = detnoise::pdf::paper();
    let n = WINDOW * WINDOW;
    let quantiles: Vec<f64> = (0..n)
        .map(|i| pdf.quantile((i as f64 + 0.5) / n as f64))
        .collect();
    let sigma: Vec<f64> = (0..n).map(|p| quantiles[(p * 37) % n]).collect();
    PerPixelSigma::new(sigma, "paper-window".into())
}

/// R of `models` read through `wcog` in one run of `cfg` with `seed` (px, with SEs).
fn wcog_run(cfg: &SimConfig, seed: u64, models: &[&dyn Readout]) -> Vec<SimResult> {
    let cfg = SimConfig {
        seed,
        ..cfg.clone()
    };
    let arms: Vec<Arm> = (0..models.len())
        .map(|model| Arm {
            model,
            centroider: CentroiderSpec::parse("wcog").unwrap(),
        })
        .collect();
    let mut exp = Experiment::with_arms(&cfg, models, &arms).unwrap();
    exp.extend_to(cfg.iters, &Silent, 1).unwrap();
    exp.results().unwrap()
}

/// The sigma where a ladder of independent constant-sigma `wcog` runs (seeds 100 + rung) has
/// the map camera's R (its own run, seed 99), linearly interpolated between the bracketing
/// rungs, with its SE: the runs are independent, so the R SEs add in quadrature.
fn ladder(cfg: &SimConfig, camera: &dyn Readout, sigmas: &[f64]) -> (f64, f64) {
    let det = wcog_run(cfg, 99, &[camera]).remove(0);
    let rungs: Vec<SimResult> = sigmas
        .iter()
        .enumerate()
        .map(|(k, &s)| {
            let c = ScmosConstant::new(s, format!("c{s}"));
            wcog_run(cfg, 100 + k as u64, &[&c]).remove(0)
        })
        .collect();
    for (s, r) in sigmas.iter().zip(&rungs) {
        eprintln!(
            "ladder: sigma {s} e-: R {:.5} +- {:.5} px",
            r.r_px, r.r_se_px
        );
    }
    eprintln!("ladder: camera R {:.5} +- {:.5} px", det.r_px, det.r_se_px);
    let k = (1..rungs.len())
        .find(|&k| rungs[k].r_px >= det.r_px)
        .expect("the ladder reaches the camera's R");
    assert!(
        rungs[0].r_px < det.r_px,
        "the ladder starts below the camera"
    );
    let (lo, hi) = (&rungs[k - 1], &rungs[k]);
    let slope = (hi.r_px - lo.r_px) / (sigmas[k] - sigmas[k - 1]);
    let t = (det.r_px - lo.r_px) / (hi.r_px - lo.r_px);
    let x = sigmas[k - 1] + t * (sigmas[k] - sigmas[k - 1]);
    let se_r = det
        .r_se_px
        .hypot((1.0 - t) * lo.r_se_px)
        .hypot(t * hi.r_se_px);
    (x, se_r / slope)
}

#[test]
fn a_long_tailed_map_through_wcog_matches_a_constant_sigma_ladder_through_wcog() {
    // 8x8 px, airy:2, 50 photons, the paper pdf's window: sigma_eff(wcog) is the constant
    // sigma a uniform camera needs to reach the map's R under wcog. A ladder of independent
    // constant-sigma runs through wcog must put it within 3 SE (the two SEs combined: the
    // ladder's runs and the solver's are independent), and the cog-equivalent (what the
    // solver gave before) is far lower: wcog helps a map with a tail more than a uniform one.
    let cfg = SimConfig {
        iters: 20_000,
        ..SimConfig::paper(WINDOW)
    };
    let camera = paper_window();
    let wcog = CentroiderSpec::parse("wcog").unwrap();
    let e: Effective =
        effective_sigma_with(&cfg, &camera, wcog, &Precision::fixed(cfg.iters), &Silent).unwrap();
    eprintln!(
        "map through wcog: sigma_eff {:.3} +- {:.3} e-, cog-equivalent {:.3} +- {:.3} e-, R {:.5} px",
        e.sigma_eff_e, e.sigma_eff_se_e, e.sigma_cog_equiv_e, e.sigma_cog_equiv_se_e, e.r_px
    );
    let ladder_cfg = SimConfig {
        iters: 40_000,
        ..cfg.clone()
    };
    let sigmas = [0.6, 0.9, 1.2, 1.5, 1.8, 2.2, 2.8, 3.6];
    let (x, se) = ladder(&ladder_cfg, &camera, &sigmas);
    eprintln!("ladder through wcog: {x:.3} +- {se:.3} e-");
    assert_eq!(e.status, Status::Ok, "{e:?}");
    let combined = e.sigma_eff_se_e.hypot(se);
    assert!(
        (e.sigma_eff_e - x).abs() < 3.0 * combined,
        "solver {} +- {}, ladder {x} +- {se}",
        e.sigma_eff_e,
        e.sigma_eff_se_e
    );
    assert!(
        e.sigma_cog_equiv_e + 3.0 * e.sigma_cog_equiv_se_e.hypot(e.sigma_eff_se_e) < e.sigma_eff_e,
        "{e:?}"
    );
}
