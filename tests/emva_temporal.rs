//! The temporal datasheet numbers of the bundled camera (data-synthetic/emva-cmos-64x96)
//! against its truth.json: each within 3 SE of the truth, or within the relative figure its
//! model allows where the truth is not the quantity measured exactly (stated per number).

use std::path::Path;

use detnoise::emva::pairs::measure;
use detnoise::emva::temporal::{temporal, TemporalResult};
use detnoise::emva::{EmvaDataset, Quantity, QuantityStatus};

fn bundled() -> (TemporalResult, serde_json::Value) {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("data-synthetic/emva-cmos-64x96");
    let dataset = EmvaDataset::from_descriptor(&dir.join("EMVA1288descriptor.txt")).unwrap();
    let truth: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(dir.join("truth.json")).unwrap()).unwrap();
    (temporal(&measure(&dataset).unwrap()), truth)
}

fn near(q: &Quantity, truth: f64, relative: f64, what: &str) {
    eprintln!("{what}: {} +- {} (truth {truth})", q.value, q.se);
    assert_eq!(q.status, QuantityStatus::Ok, "{what}: {q:?}");
    let tolerance = (3.0 * q.se).max(relative * truth.abs());
    assert!(
        (q.value - truth).abs() <= tolerance,
        "{what}: {} +- {} vs truth {truth} (tolerance {tolerance})",
        q.value,
        q.se
    );
}

#[test]
fn the_bundled_camera_s_temporal_numbers_match_its_truth() {
    let (r, truth) = bundled();
    let t = |k: &str| truth[k].as_f64().unwrap();
    assert!(r.rules_broken.is_empty(), "{:?}", r.rules_broken);
    // The pixels' gains spread by the PRNU: the photon transfer measures their average.
    near(
        &r.system_gain_dn_per_e,
        t("K_pixel_average_dn_per_e"),
        0.0,
        "K",
    );
    near(&r.quantum_efficiency_percent, 100.0 * t("qe"), 0.0, "QE");
    near(&r.dark_noise_e, t("read_noise_e"), 0.0, "sigma_d");
    // The realised pixels' dark current, read through their own gains (1 % effect).
    let dc = t("dark_current_realised_mean_e_per_s");
    near(
        &r.dark_current_mean_e_per_s,
        dc,
        0.01,
        "dark current (mean)",
    );
    near(
        &r.dark_current_variance_e_per_s,
        dc,
        0.01,
        "dark current (variance)",
    );
    // Saturation: the variance peaks where the brightest pixels reach the full well, a few
    // photon-noise sigma below it (within 10 %).
    near(&r.saturation_capacity_e, t("full_well_e"), 0.1, "mu_e.sat");
    assert!(r.saturation_capacity_e.value <= t("full_well_e"));
    // A linear camera.
    for le in [
        &r.linearity_error_min_percent,
        &r.linearity_error_max_percent,
    ] {
        near(le, 0.0, 0.0, "linearity error");
    }
}
