//! Every file a run writes is an ordinary shared result, mode 0644, and its directory 0755
//! (issue 11: `pdf_fit.json` was once 0600, as temporary files are created, where every other
//! file was 0644): report (sCMOS with flats, EMCCD), darks, fit-pdf and emgain, run from Rust.

#![cfg(unix)]

mod common;

use common::data;
use detnoise::calib::darks::{self, DarkOptions, DarksRun};
use detnoise::calib::Unit;
use detnoise::fit::emgain::{self, EmgainRun};
use detnoise::fit::pdf_fit::{self, FitPdfRun};
use detnoise::progress::Silent;
use detnoise::report::{self, DetectorKind, ReportOptions};
use detnoise::spot::Spot;
use std::os::unix::fs::PermissionsExt;
use std::path::{Path, PathBuf};

/// Every entry under `dir` (hidden ones too) with its permission bits.
fn modes(dir: &Path) -> Vec<(PathBuf, u32)> {
    let mut out = Vec::new();
    for e in std::fs::read_dir(dir).unwrap() {
        let p = e.unwrap().path();
        let mode = std::fs::symlink_metadata(&p).unwrap().permissions().mode() & 0o7777;
        if p.is_dir() {
            out.extend(modes(&p));
        }
        out.push((p, mode));
    }
    out
}

/// `dir` is 0755 and every file in it 0644; returns how many files it holds.
fn assert_shared(dir: &Path) -> usize {
    let own = std::fs::metadata(dir).unwrap().permissions().mode() & 0o7777;
    assert_eq!(own, 0o755, "{}: mode {own:o}", dir.display());
    let entries = modes(dir);
    for (p, mode) in &entries {
        let want = if p.is_dir() { 0o755 } else { 0o644 };
        assert_eq!(*mode, want, "{}: mode {mode:o}", p.display());
    }
    entries.len()
}

/// A report of the smallest grid (one configuration, 200 iterations): every output kind.
fn tiny_report(detector: DetectorKind, out: &Path) -> ReportOptions {
    ReportOptions {
        detector,
        subaps_px: Some(vec![4]),
        spots: Some(vec![Spot::Airy { diameter_px: 2.0 }]),
        signals_photons: Some(vec![50.0]),
        iters: 200,
        out_dir: out.to_path_buf(),
        ..ReportOptions::default()
    }
}

#[test]
fn every_file_of_a_report_is_0644() {
    let tmp = tempfile::tempdir().unwrap();
    let scmos = ReportOptions {
        darks_paths: vec![data("scmos-darks-64x64.fits")],
        flats_paths: ["100", "400", "1600", "6400"]
            .iter()
            .map(|e| data(&format!("scmos-flat-64x64-{e}e.fits")))
            .collect(),
        ..tiny_report(DetectorKind::Scmos, &tmp.path().join("scmos"))
    };
    let result = report::run(&scmos, &Silent).unwrap();
    let n = assert_shared(&result.out_dir);
    // Maps, pdf fit, tables, charts (ptc.png among them), summary and page.
    assert!(n >= result.files.len() && n > 15, "{n} files");
    assert!(result.files.iter().any(|f| f.ends_with("pdf_fit.json")));
    assert!(result.files.iter().any(|f| f.ends_with("ptc.png")));

    let emccd = ReportOptions {
        darks_paths: vec![data("emccd-lowlight-32x48.fits")],
        gain_e_per_adu: Some(10.0),
        ..tiny_report(DetectorKind::Emccd, &tmp.path().join("emccd"))
    };
    let result = report::run(&emccd, &Silent).unwrap();
    assert!(assert_shared(&result.out_dir) >= result.files.len());
    assert!(result.files.iter().any(|f| f.ends_with("emgain.png")));
}

#[test]
fn every_file_of_darks_fit_pdf_and_emgain_is_0644() {
    let tmp = tempfile::tempdir().unwrap();
    let darks_out = tmp.path().join("darks");
    let job = DarksRun {
        stack: vec![data("scmos-darks-64x64.fits")],
        out: darks_out.clone(),
        force: false,
        options: DarkOptions::default(),
        gain_e_per_adu: Some(0.25),
        checksum: Some(detnoise::io::Checksum::Blake3),
        accept_illuminated: false,
        expected_dark: None,
    };
    let r = darks::run(&job, &Silent).unwrap();
    assert!(assert_shared(&r.out) >= 6);

    let job = FitPdfRun {
        map: darks_out.join("rms_e.fits"),
        out: tmp.path().join("fit"),
        force: false,
        unit: Unit::Electrons,
        gain_e_per_adu: None,
        flags: None,
        keep_flagged: false,
        models: Vec::new(),
        upper_cut_e: None,
    };
    let r = pdf_fit::run(&job).unwrap();
    assert!(r.out.join("pdf_fit.json").is_file());
    assert!(assert_shared(&r.out) >= 2);

    let job = EmgainRun {
        stack: vec![data("emccd-lowlight-32x48.fits")],
        out: tmp.path().join("emgain"),
        force: false,
        gain_e_per_adu: Some(10.0),
        gain_map: None,
        offset: None,
        read_noise: None,
        stages: Some(520),
        law: None,
        serial_cic: false,
        no_serial_cic: false,
        max_value_adu: None,
        bin_width_adu: None,
        reference_stack: Vec::new(),
        reference_offset: None,
    };
    let r = emgain::run(&job).unwrap();
    assert!(assert_shared(&r.out) >= 2);
}
