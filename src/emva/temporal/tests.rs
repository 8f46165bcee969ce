//! The temporal numbers against the truth of frames simulated here (fixed seeds): a linear
//! camera with Poisson photo-electrons and dark current, Gaussian read noise, a full well and
//! rounding to DN. Tolerances are 3 SE of the estimate from the sample used.

use rand_distr::{Distribution, StandardNormal};

use super::*;
use crate::emva::pairs::{measure, pair_stats, PairStats, PointStats};
use crate::emva::{EmvaDataset, PairPoint};
use crate::rng::{stream, SimRng};
use crate::stats::poisson;

const PIXELS: usize = 100 * 100;

/// The simulated camera's truth.
#[derive(Clone, Copy)]
struct Camera {
    k_dn_per_e: f64,
    qe: f64,
    sigma_d_e: f64,
    dark_current_e_per_s: f64,
    offset_dn: f64,
    full_well_e: f64,
}

const CAMERA: Camera = Camera {
    k_dn_per_e: 0.5,
    qe: 0.6,
    sigma_d_e: 5.0,
    dark_current_e_per_s: 50.0,
    offset_dn: 100.0,
    full_well_e: 10_000.0,
};

/// One frame: `photons` mean photons per pixel at `exposure_s`.
fn frame(cam: &Camera, photons: f64, exposure_s: f64, rng: &mut SimRng) -> Vec<f64> {
    let lambda = cam.qe * photons + cam.dark_current_e_per_s * exposure_s;
    (0..PIXELS)
        .map(|_| {
            let e = (poisson(lambda, rng) as f64).min(cam.full_well_e);
            let read: f64 = StandardNormal.sample(rng);
            (cam.offset_dn + cam.k_dn_per_e * (e + cam.sigma_d_e * read))
                .round()
                .max(0.0)
        })
        .collect()
}

/// A series of `n` points at exposures up to 1 s; photons per pixel rise with exposure (fixed
/// irradiance) up to `top` times the full well's photons when `vary_exposure`, else the
/// exposure stays 0.5 s and the irradiance varies. The second bright frame of each pair sees
/// `drift` more light.
fn series(
    cam: &Camera,
    n: usize,
    top: f64,
    vary_exposure: bool,
    drift: f64,
    seed: u64,
) -> Vec<PointStats> {
    (0..n)
        .map(|i| {
            let f = (i + 1) as f64 / n as f64;
            let t = if vary_exposure { f } else { 0.5 };
            let photons = f * top * cam.full_well_e / cam.qe;
            let mut rng = stream(seed, i as u64, 0);
            let a = frame(cam, photons, t, &mut rng);
            let b = frame(cam, photons * (1.0 + drift), t, &mut rng);
            let da = frame(cam, 0.0, t, &mut rng);
            let db = frame(cam, 0.0, t, &mut rng);
            PointStats {
                exposure_s: t,
                photons_per_px: Some(photons * (1.0 + drift / 2.0)),
                bright: pair_stats(&a, &b),
                dark: pair_stats(&da, &db),
            }
        })
        .collect()
}

fn assert_within_3se(q: &Quantity, truth: f64, max_relative_se: f64, what: &str) {
    assert!(
        (q.value - truth).abs() <= 3.0 * q.se,
        "{what}: {} +- {} vs truth {truth}",
        q.value,
        q.se
    );
    assert!(
        q.se > 0.0 && q.se <= max_relative_se * truth.abs(),
        "{what}: SE {} not within (0, {max_relative_se} x truth]",
        q.se
    );
}

#[test]
fn recovers_gain_qe_dark_noise_and_dark_current_within_3_se() {
    let cam = CAMERA;
    let r = temporal(&series(&cam, 60, 1.3, true, 0.0, 11));
    assert!(r.rules_broken.is_empty(), "{:?}", r.rules_broken);
    for (name, q) in [
        ("K", &r.system_gain_dn_per_e),
        ("QE %", &r.quantum_efficiency_percent),
        ("sigma_d e-", &r.dark_noise_e),
        ("dark current (mean) e-/s", &r.dark_current_mean_e_per_s),
        ("dark current (var) e-/s", &r.dark_current_variance_e_per_s),
        ("mu_e.sat e-", &r.saturation_capacity_e),
        ("mu_e.min e-", &r.sensitivity_threshold_e),
        ("DR dB", &r.dynamic_range_db),
        ("LE_min %", &r.linearity_error_min_percent),
        ("LE_max %", &r.linearity_error_max_percent),
    ] {
        eprintln!("{name}: {} +- {} ({})", q.value, q.se, q.status.label());
    }
    let k = &r.system_gain_dn_per_e;
    assert_eq!(k.status, QuantityStatus::Ok);
    assert_within_3se(k, cam.k_dn_per_e, 0.02, "K");
    assert_within_3se(&r.quantum_efficiency_percent, 100.0 * cam.qe, 0.02, "QE");
    assert_within_3se(&r.dark_noise_e, cam.sigma_d_e, 0.02, "sigma_d");
    assert!(!r.dark_noise_floored);
    assert_within_3se(
        &r.dark_current_mean_e_per_s,
        cam.dark_current_e_per_s,
        0.02,
        "dark current (mean)",
    );
    assert_within_3se(
        &r.dark_current_variance_e_per_s,
        cam.dark_current_e_per_s,
        0.05,
        "dark current (variance)",
    );
    // Saturation: the variance peaks within a few sigma of the full well.
    let e_sat = r.saturation_capacity_e.value;
    assert!(
        (0.9 * cam.full_well_e..=cam.full_well_e).contains(&e_sat),
        "{e_sat}"
    );
    assert_eq!(r.saturation_capacity_e.status, QuantityStatus::Ok);
    assert!((r.snr_max.value - e_sat.sqrt()).abs() < 1e-9 * e_sat);
    // Threshold and dynamic range from the truth's sigma_d (quantisation adds 1/12 DN^2).
    let s2 = (cam.k_dn_per_e * cam.sigma_d_e).powi(2) + 1.0 / 12.0;
    let e_min = 0.5 + (0.25 + s2 / cam.k_dn_per_e.powi(2)).sqrt();
    assert_within_3se(&r.sensitivity_threshold_e, e_min, 0.02, "mu_e.min");
    assert!((r.dynamic_range.value - e_sat / r.sensitivity_threshold_e.value).abs() < 1e-6);
    assert!((r.dynamic_range_db.value - 20.0 * r.dynamic_range.value.log10()).abs() < 1e-9);
    // A linear camera: the linearity error is within a few of its SEs of zero.
    for le in [
        &r.linearity_error_min_percent,
        &r.linearity_error_max_percent,
    ] {
        assert!(le.value.abs() < 0.5, "{le:?}");
        assert_eq!(le.status, QuantityStatus::Ok);
    }
    let [lo, hi] = r.linearity_fit.unwrap();
    assert!(lo < r.sensitivity_fit[1] && r.sensitivity_fit[1] < hi && hi < r.saturation_index);
}

#[test]
fn the_drift_correction_removes_a_mean_drift_between_the_frames() {
    let mut rng = stream(3, 0, 0);
    let a = frame(&CAMERA, 4000.0, 0.1, &mut rng);
    let b = frame(&CAMERA, 4000.0, 0.1, &mut rng);
    let shifted: Vec<f64> = b.iter().map(|v| v + 7.0).collect();
    let (plain, drifted) = (pair_stats(&a, &b), pair_stats(&a, &shifted));
    assert!((plain.variance_dn2 - drifted.variance_dn2).abs() < 1e-9 * plain.variance_dn2);
    assert!((drifted.drift_dn - plain.drift_dn + 7.0).abs() < 1e-9);
    // Without the correction the variance would carry drift^2 / 2.
    let raw = |a: &[f64], b: &[f64]| {
        a.iter().zip(b).map(|(x, y)| (x - y).powi(2)).sum::<f64>() / (2.0 * a.len() as f64)
    };
    let excess = raw(&a, &shifted) - raw(&a, &b);
    assert!(excess > 20.0, "{excess}");

    // A light source 2 % brighter in each pair's second frame: K still within 3 SE, while the
    // uncorrected variances would put it far off.
    let cam = CAMERA;
    let points = series(&cam, 60, 1.3, true, 0.02, 5);
    let r = temporal(&points);
    assert_within_3se(
        &r.system_gain_dn_per_e,
        cam.k_dn_per_e,
        0.02,
        "K with drift",
    );
    let uncorrected: Vec<PointStats> = points
        .iter()
        .map(|p| {
            let add = |s: &PairStats| PairStats {
                variance_dn2: s.variance_dn2 + s.drift_dn.powi(2) / 2.0,
                ..*s
            };
            PointStats {
                bright: add(&p.bright),
                dark: add(&p.dark),
                ..p.clone()
            }
        })
        .collect();
    let bad = temporal(&uncorrected).system_gain_dn_per_e;
    assert!(
        (bad.value - cam.k_dn_per_e).abs() > 5.0 * r.system_gain_dn_per_e.se,
        "{bad:?}"
    );
}

#[test]
fn without_photons_qe_is_unavailable_and_the_rest_computed() {
    let mut points = series(&CAMERA, 55, 1.3, true, 0.0, 7);
    for p in &mut points {
        p.photons_per_px = None;
    }
    let r = temporal(&points);
    for q in [
        &r.quantum_efficiency_percent,
        &r.responsivity_dn_per_photon,
        &r.sensitivity_threshold_photons_per_px,
        &r.saturation_photons_per_px,
    ] {
        assert!(matches!(q.status, QuantityStatus::Unavailable(_)), "{q:?}");
        assert!(q.value.is_nan());
    }
    assert_within_3se(&r.system_gain_dn_per_e, CAMERA.k_dn_per_e, 0.02, "K");
    assert_eq!(r.dynamic_range.status, QuantityStatus::Ok);
    // Linearity against exposure time (fixed irradiance).
    assert_eq!(r.linearity_error_max_percent.status, QuantityStatus::Ok);
}

#[test]
fn fewer_points_than_the_standard_asks_are_computed_but_out_of_rules() {
    let r = temporal(&series(&CAMERA, 20, 1.3, true, 0.0, 8));
    let QuantityStatus::OutOfRules(rule) = &r.system_gain_dn_per_e.status else {
        panic!("{:?}", r.system_gain_dn_per_e);
    };
    assert!(
        rule.contains("20 photon-transfer points") && rule.contains("50"),
        "{rule}"
    );
    assert!(r.system_gain_dn_per_e.value.is_finite());
    assert!(matches!(r.dark_noise_dn.status, QuantityStatus::Ok));
}

#[test]
fn a_series_that_never_saturates_breaks_the_saturation_rule() {
    let r = temporal(&series(&CAMERA, 50, 0.6, true, 0.0, 9));
    assert_eq!(r.saturation_index, 49);
    for q in [
        &r.saturation_capacity_e,
        &r.snr_max,
        &r.system_gain_dn_per_e,
    ] {
        let QuantityStatus::OutOfRules(rule) = &q.status else {
            panic!("{q:?}");
        };
        assert!(rule.contains("no point beyond saturation"), "{rule}");
    }
}

#[test]
fn a_single_exposure_time_gives_dark_noise_but_no_dark_current() {
    let r = temporal(&series(&CAMERA, 50, 1.3, false, 0.0, 10));
    assert!(matches!(
        r.dark_current_mean_e_per_s.status,
        QuantityStatus::Unavailable(_)
    ));
    // At 0.5 s the dark variance carries 25 e- of dark-current shot noise.
    let truth = (CAMERA.sigma_d_e.powi(2) + 0.5 * CAMERA.dark_current_e_per_s).sqrt();
    assert_within_3se(&r.dark_noise_e, truth, 0.02, "sigma_d at 0.5 s");
    assert_within_3se(&r.quantum_efficiency_percent, 100.0 * CAMERA.qe, 0.02, "QE");
}

#[test]
fn a_dark_noise_below_the_quantisation_floor_is_floored() {
    let cam = Camera {
        sigma_d_e: 0.2,
        k_dn_per_e: 0.5,
        dark_current_e_per_s: 0.0,
        ..CAMERA
    };
    let r = temporal(&series(&cam, 50, 1.3, true, 0.0, 12));
    assert!(r.dark_noise_floored);
    assert!((r.dark_noise_dn.value - DARK_VARIANCE_FLOOR_DN2.sqrt()).abs() < 1e-12);
}

#[test]
fn measure_reads_each_pair_from_files() {
    let dir = tempfile::tempdir().unwrap();
    let mut rng = stream(4, 0, 0);
    let shape = (100, 100);
    let mut frames = Vec::new();
    let mut path_of = |name: &str, photons: f64| {
        let v = frame(&CAMERA, photons, 0.2, &mut rng);
        let path = dir.path().join(name);
        crate::io::fits::write_image(&path, shape, crate::io::fits::ImageData::F64(&v), "", &[])
            .unwrap();
        frames.push(v);
        path
    };
    let bright = [path_of("b0.fits", 3000.0), path_of("b1.fits", 3000.0)];
    let dark = [path_of("d0.fits", 0.0), path_of("d1.fits", 0.0)];
    let dataset = EmvaDataset {
        source: dir.path().join("descriptor.txt"),
        format: None,
        points: vec![PairPoint {
            exposure_s: 0.2,
            photons_per_px: Some(3000.0),
            bright,
            dark,
        }],
        spatial_bright: None,
        spatial_dark: None,
    };
    let got = measure(&dataset).unwrap();
    assert_eq!(got.len(), 1);
    assert_eq!(got[0].bright, pair_stats(&frames[0], &frames[1]));
    assert_eq!(got[0].dark, pair_stats(&frames[2], &frames[3]));
}

#[test]
fn the_standard_errors_are_honest_over_seeds() {
    // 12 independent series: the RMS of (estimate - truth) / SE is ~1 (chi^2 with 12 dof puts
    // it in [0.5, 1.6] with 99.5 % probability).
    let cam = CAMERA;
    let mut sums = [0.0; 3];
    let seeds = 12;
    for seed in 0..seeds {
        let r = temporal(&series(&cam, 50, 1.3, true, 0.0, 100 + seed));
        let pull = |q: &Quantity, truth: f64| ((q.value - truth) / q.se).powi(2);
        sums[0] += pull(&r.system_gain_dn_per_e, cam.k_dn_per_e);
        sums[1] += pull(&r.dark_noise_e, cam.sigma_d_e);
        sums[2] += pull(&r.dark_current_variance_e_per_s, cam.dark_current_e_per_s);
    }
    for (name, s) in ["K", "sigma_d", "dark current (variance)"].iter().zip(sums) {
        let rms = (s / seeds as f64).sqrt();
        eprintln!("{name}: RMS pull {rms}");
        assert!((0.5..1.6).contains(&rms), "{name}: RMS pull {rms}");
    }
}
