//! Recovery of known read-noise pdfs from synthetic maps, refusals, and the JSON round trip.

use super::*;
use crate::fit::pdf_models::PdfModel;
use crate::pdf::{paper, RmsPdf};
use crate::rng::stream;
use rand_distr::{Distribution, LogNormal};

fn paper_map(side: usize, seed: u64) -> Vec<f64> {
    let p = paper();
    let mut rng = stream(seed, 0, 0);
    (0..side * side).map(|_| p.sample(&mut rng)).collect()
}

/// Recovery on a map drawn from the paper's pdf. The paper-scaled scale must contain 1
/// within 3 of its standard errors (a 99.7 % interval if the Hessian SE is right).
/// Medians and means: the fitted pdf is compared with the map it was fitted to, so the
/// sampling error of the map cancels; 2 % is the tolerance (the SE of the map's
/// mean itself is sd/sqrt(n) = 1.05/64 = 1.6 % at 64x64, so a model that matched the
/// true pdf instead of the map would still pass at 2 % only narrowly, which is why
/// the comparison is with the map).
fn check_paper_recovery(side: usize, seed: u64) -> PdfFitReport {
    let values = paper_map(side, seed);
    let t = std::time::Instant::now();
    let r = fit_pdf(&values, &PdfFitOptions::default()).unwrap();
    eprintln!("{side}x{side}: fit in {:.2} s", t.elapsed().as_secs_f64());
    assert!(r.failures.is_empty(), "{:?}", r.failures);
    let ps = &r.models["paper-scaled"];
    let s = ps.params["scale"];
    let se = ps.param_se["scale"].unwrap();
    eprintln!(
        "{side}x{side}: scale {s:.5} +- {se:.5} ({:.2} SE from 1)",
        (s - 1.0) / se
    );
    assert!((s - 1.0).abs() < 3.0 * se, "scale {s} +- {se}");
    // The fitted models' mean and median against the map's, within 2 % or 3 standard errors
    // of the map's own mean and median (sd / sqrt(N); sqrt(1 / 4N) / f(median), f the
    // fitted scaled paper pdf), whichever is wider: a heavy-tailed 64x64 map's mean alone has a
    // 1.5 % standard error.
    let n = values.len() as f64;
    let (mean, var) = crate::stats::mean_var(&values);
    let mean_tol = 0.02f64.max(3.0 * var.sqrt() / n.sqrt() / mean);
    let f_median = crate::pdf::paper().density(r.data.median_e / s) / s;
    let median_tol = 0.02f64.max(3.0 * (0.25 / n).sqrt() / f_median / r.data.median_e);
    for (name, m) in &r.models {
        let dm = m.median_e / r.data.median_e - 1.0;
        let da = m.mean_e / r.data.mean_e - 1.0;
        eprintln!(
            "{side}x{side} {name}: lnL {:?} aic {:?} ks {:.4} median {:+.4}% mean {:+.4}% it {}",
            m.log_likelihood,
            m.aic,
            m.max_cdf_distance,
            100.0 * dm,
            100.0 * da,
            m.iterations
        );
        assert!(
            dm.abs() < median_tol && da.abs() < mean_tol,
            "{name}: {dm} {da} (tolerances {median_tol} {mean_tol})"
        );
    }
    r
}

#[test]
fn paper_map_64x64_is_recovered() {
    check_paper_recovery(64, 1);
}

#[test]
fn paper_map_512x512_is_recovered() {
    check_paper_recovery(512, 2);
}

#[test]
fn lognormal_map_prefers_lognormal_tail() {
    let ln = LogNormal::new(0.2, 0.25).unwrap();
    let mut rng = stream(3, 0, 0);
    let values: Vec<f64> = (0..64 * 64).map(|_| ln.sample(&mut rng)).collect();
    let r = fit_pdf(&values, &PdfFitOptions::default()).unwrap();
    let a_ln = r.models["lognormal+tail"].aic.unwrap();
    let a_ps = r.models["paper-scaled"].aic.unwrap();
    eprintln!(
        "lognormal map: AIC lognormal+tail {a_ln:.1}, paper-scaled {a_ps:.1}, best {}",
        r.best_model
    );
    assert!(a_ln < a_ps);
}

#[test]
fn bad_maps_get_a_reason() {
    let e = fit_pdf(&[1.0; 10], &PdfFitOptions::default()).unwrap_err();
    assert!(e.to_string().contains("at least 50"), "{e}");
    let e = fit_pdf(&[1.0; 100], &PdfFitOptions::default()).unwrap_err();
    assert!(e.to_string().contains("same"), "{e}");
    let mut v = paper_map(16, 5);
    v.extend([f64::NAN, -1.0, 0.0]);
    let r = fit_pdf(
        &v,
        &PdfFitOptions {
            models: vec![PdfModel::Empirical],
            upper_cut_e: None,
        },
    )
    .unwrap();
    assert_eq!((r.n_values, r.n_excluded), (256, 3));
    assert_eq!(r.best_model, "empirical");
}

#[test]
fn json_round_trip_rebuilds_the_fitted_pdf() {
    let r = fit_pdf(&paper_map(32, 6), &PdfFitOptions::default()).unwrap();
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("pdf_fit.json");
    r.write_json(&path).unwrap();
    for (name, m) in &r.models {
        let pdf = load_pdf_fit(&path, Some(name)).unwrap();
        assert!((pdf.median() - m.median_e).abs() < 1e-12, "{name}");
        assert!((pdf.mean() - m.mean_e).abs() < 1e-12, "{name}");
    }
    let best = load_pdf_fit(&path, None).unwrap();
    assert!((best.median() - r.models[&r.best_model].median_e).abs() < 1e-12);
}
