//! `detnoise emgain` with its defaults on EMCCD dark stacks made by generators that are not
//! detnoise's own `synth` (issue 31): the JPL simulator emccd-detect (exact 604-stage register,
//! serial CIC 0 to 0.2 events per pixel) and a numpy exact register, written once by
//! tests/fixtures/emccd_detect/make_fixtures.py with their truth in truth.json.
//!
//! Each stack must give G within 3 standard errors of the truth, and the serial-CIC
//! comparison must say present exactly where the generator put serial CIC.

mod common;

use common::detnoise;

use std::path::{Path, PathBuf};

fn fixtures() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/fixtures/emccd_detect")
}

fn json(path: &Path) -> serde_json::Value {
    serde_json::from_str(&std::fs::read_to_string(path).unwrap()).unwrap()
}

/// Every fixture stack with its truth.
fn stacks() -> Vec<(String, serde_json::Value)> {
    let truth = json(&fixtures().join("truth.json"));
    let stacks: Vec<_> = truth
        .as_object()
        .unwrap()
        .iter()
        .map(|(k, v)| (k.clone(), v.clone()))
        .collect();
    assert_eq!(stacks.len(), 7, "fixture stacks");
    stacks
}

/// `detnoise emgain STACK [args]` with the defaults otherwise: emgain.json.
fn emgain(name: &str, args: &[String], out: &Path) -> serde_json::Value {
    detnoise()
        .arg("emgain")
        .arg(fixtures().join(format!("{name}.fits.gz")))
        .args(args)
        .arg("--out")
        .arg(out)
        .assert()
        .success();
    json(&out.join("emgain.json"))
}

fn f(v: &serde_json::Value, key: &str) -> f64 {
    v[key].as_f64().unwrap_or_else(|| panic!("{key} in {v}"))
}

#[test]
fn default_fit_recovers_gain_and_finds_serial_cic_on_peer_stacks() {
    let dir = tempfile::tempdir().unwrap();
    let mut bad = vec![];
    for (name, t) in stacks() {
        let conv = f(&t, "gain_e_per_adu");
        let j = emgain(
            &name,
            &["--gain-e-per-adu".into(), conv.to_string()],
            &dir.path().join(&name),
        );
        assert_eq!(j["shape"]["kind"], "register", "{name}: default law");
        assert_eq!(j["shape"]["stages"], 604, "{name}: default stages");
        let pull = |key: &str, truth: f64| (f(&j, key) - truth) / f(&j, &format!("{key}_se"));
        let g = pull("em_gain", f(&t, "em_gain"));
        let serial = f(&t, "serial_cic_e");
        let test = &j["serial_cic_test"];
        eprintln!(
            "{name}: G {:.1} +- {:.1} (pull {g:+.2}), serial CIC {} (truth {serial}), delta BIC {:.1}",
            f(&j, "em_gain"),
            f(&j, "em_gain_se"),
            j["serial_cic_e"],
            f(test, "delta_bic")
        );
        if g.abs() > 3.0 {
            bad.push(format!("{name}: G pull {g:+.2}"));
        }
        if test["present"].as_bool() != Some(serial > 0.0) {
            bad.push(format!("{name}: serial CIC verdict {test}"));
        }
        if serial > 0.0 {
            let c = pull("serial_cic_e", serial);
            if c.abs() > 3.0 {
                bad.push(format!("{name}: serial CIC pull {c:+.2}"));
            }
        }
    }
    assert!(bad.is_empty(), "{bad:?}");
}

#[test]
fn gamma_law_without_the_conversion_gain_recovers_gain_in_adu() {
    // Without the conversion gain the default law is the Gamma law with the register's
    // F^2: G in adu/e- within 3 SE on a stack with serial CIC and one without.
    let dir = tempfile::tempdir().unwrap();
    for (name, t) in stacks()
        .into_iter()
        .filter(|(n, _)| n == "jpl-serial0.1" || n == "np-g2000-serial0")
    {
        let j = emgain(&name, &[], &dir.path().join(&name));
        assert_eq!(j["shape"]["kind"], "register_gamma", "{name}");
        assert_eq!(j["em_gain_units"], "adu/e-");
        let truth = f(&t, "em_gain") / f(&t, "gain_e_per_adu");
        let pull = (f(&j, "em_gain") - truth) / f(&j, "em_gain_se");
        eprintln!(
            "{name}: G {} adu/e- (truth {truth}, pull {pull:+.2})",
            j["em_gain"]
        );
        assert!(pull.abs() < 3.0, "{name}: pull {pull}");
        assert_eq!(
            j["serial_cic_test"]["present"].as_bool(),
            Some(f(&t, "serial_cic_e") > 0.0),
            "{name}"
        );
    }
}
