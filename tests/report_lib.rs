//! A whole report run from Rust, without the command line: options in, numbers and files out.

mod common;

use common::data;
use detnoise::progress::Silent;
use detnoise::report::QUICK_AIRY_DIAMETERS_PX;
use detnoise::report::{self, DetectorKind, OperatingPoint, ReportOptions};
use detnoise::report::{QUICK_SIGNALS_PHOTONS, QUICK_SUBAPS_PX};
use detnoise::spot::Spot;
use detnoise::Error;
use serde_json::Value;
use std::path::Path;

/// The manifest of bundled stack `name` (its truth).
fn manifest(name: &str) -> Value {
    let path = data(name).with_extension("manifest.json");
    serde_json::from_str(&std::fs::read_to_string(&path).unwrap()).unwrap()
}

fn quick(stack: &str, gain_e_per_adu: f64, out: &Path) -> ReportOptions {
    ReportOptions {
        darks_paths: vec![data(stack)],
        gain_e_per_adu: Some(gain_e_per_adu),
        quick: true,
        out_dir: out.to_path_buf(),
        ..ReportOptions::default()
    }
}

fn assert_files_exist(result: &report::ReportResult, names: &[&str]) {
    for f in &result.files {
        assert!(f.starts_with(&result.out_dir), "{}", f.display());
        assert!(f.is_file(), "missing {}", f.display());
    }
    for name in names {
        assert!(
            result.files.contains(&result.out_dir.join(name)),
            "{name} not listed"
        );
    }
}

#[test]
fn scmos_report_recovers_the_bundled_cameras_median_read_noise() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("rep");
    let options = quick("scmos-darks-64x64.fits", 0.25, &out);
    let result = report::run(&options, &Silent).unwrap();
    let s = result.scmos().expect("an sCMOS summary");
    assert_eq!((s.frames, s.shape), (100, [64, 64]));
    assert_eq!((s.gain_e_per_adu, s.gain_source.as_str()), (0.25, "given"));

    // Truth: the median of the synthesis' rms map, plus the quantisation of integer samples
    // (variance + 1/12 adu^2, i.e. + g^2/12 e^2; monotone, so it moves the median alike).
    let m = manifest("scmos-darks-64x64.fits");
    let g = 0.25;
    let truth_e = (m["rms_e_median"].as_f64().unwrap().powi(2) + g * g / 12.0).sqrt();
    // Each pixel's rms scatters by 1/sqrt(2 (n - 1)) from its n frames and by the per-pixel
    // gain spread (converted with one gain); the median of N pixels then has a standard error
    // of sqrt(pi / 2) x scatter / sqrt(N).
    let frames = m["spec"]["frames"].as_f64().unwrap();
    let spread = m["spec"]["camera"]["gain_spread"].as_f64().unwrap();
    let scatter_e = truth_e * (1.0 / (2.0 * (frames - 1.0)) + spread * spread).sqrt();
    let se_e = (std::f64::consts::PI / 2.0).sqrt() * scatter_e / (s.pixels_used as f64).sqrt();
    assert!(
        (s.median_rms_e - truth_e).abs() < 4.0 * se_e,
        "median {} against {truth_e} +- {se_e}",
        s.median_rms_e
    );

    let grid = QUICK_SUBAPS_PX.len() * QUICK_AIRY_DIAMETERS_PX.len() * QUICK_SIGNALS_PHOTONS.len();
    // Two models over the grid: the fitted pdf, then the measured map.
    assert_eq!(result.effective.len(), 2 * grid);
    assert!(result.effective[..grid]
        .iter()
        .all(|r| r.model == "scmos-random (fitted pdf)"));
    assert!(result.effective[grid..]
        .iter()
        .all(|r| r.model == "scmos-map (measured map)"));
    // Five models (fitted pdf, map, median, mean, EMCCD) at each signal.
    assert_eq!(result.comparison.len(), 5 * QUICK_SIGNALS_PHOTONS.len());
    let op = &s.operating_point;
    assert_eq!((op.at.subap_px, op.at.spot.as_str()), (8, "airy:2"));
    assert_eq!(op.at.signal_photons, 50.0);
    assert_eq!((op.at.chosen.as_str(), op.at.in_grid), ("default", true));
    assert!(op.sigma_eff_map_e > s.median_rms_e, "{op:?}");
    assert!(result.pdf_fit.is_some() && result.ptc.is_none());
    assert_files_exist(
        &result,
        &[
            "index.html",
            "summary.json",
            "effective_noise.csv",
            "rms_e.fits",
            "effective_noise_S50.png",
        ],
    );
    let page = std::fs::read_to_string(out.join("index.html")).unwrap();
    assert!(!page.contains("NaN"));
    assert!(page.contains("8x8 px, airy:2, 50 photons (default)"));
    // summary.json holds the returned numbers.
    let written: Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("summary.json")).unwrap()).unwrap();
    assert_eq!(written["median_rms_e"].as_f64(), Some(s.median_rms_e));

    // The centroider section: every centroider for the map and the pdf at the operating point,
    // then the map at the grid's other sizes; cog is the reference of the R comparison and its
    // cog-equivalent is its sigma_eff; on this camera (noisy tail) tcog's R is lower than
    // cog's by more than 2 paired SE on shared frames, and the comparison with the EMCCD has
    // one row per signal, told with plain cog and with each side's best centroider.
    let c = &s.centroiders;
    let kinds = detnoise::centroid::CENTROIDERS.len();
    assert_eq!(c.rows.len(), kinds * (2 + QUICK_SUBAPS_PX.len() - 1));
    assert_eq!(c.median_rms_e, s.median_rms_e);
    let at_op = |model: &str, name: &str| {
        c.rows
            .iter()
            .find(|r| r.model == model && r.centroider == name && r.subap_px == 8)
            .unwrap()
    };
    let cog = at_op("scmos-map", "cog");
    assert_eq!((cog.vs_cog.as_str(), cog.r_vs_cog), ("reference", None));
    assert_eq!(cog.sigma_cog_equiv_e, cog.sigma_eff_e);
    let tcog = at_op("scmos-map", "tcog");
    assert_eq!(tcog.vs_cog, "lower", "{tcog:?}");
    let (g, g_se) = (tcog.r_vs_cog.unwrap(), tcog.r_vs_cog_se.unwrap());
    assert!(-g > 2.0 * g_se && g_se > 0.0, "{tcog:?}");
    assert!(page.contains("With plain cog:") && page.contains("With each side's best centroider:"));
    assert!(c.best_for_map.is_some());
    assert_eq!(c.versus_emccd.len(), QUICK_SIGNALS_PHOTONS.len());
    assert_files_exist(
        &result,
        &[
            "centroiders.csv",
            "centroiders.png",
            "centroiders_vs_emccd.png",
        ],
    );
    assert!(page.contains("What the wavefront sensor can do about it"));
}

#[test]
fn emccd_report_recovers_the_bundled_cameras_em_gain() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("rep");
    let options = ReportOptions {
        detector: DetectorKind::Emccd,
        ..quick("emccd-lowlight-32x48.fits", 10.0, &out)
    };
    let result = report::run(&options, &Silent).unwrap();
    let s = result.emccd().expect("an EMCCD summary");
    let truth = manifest("emccd-lowlight-32x48.fits")["spec"]["camera"]["em_gain"]
        .as_f64()
        .unwrap();
    let (gain, se) = (s.emgain.em_gain, s.emgain.em_gain_se);
    assert!(
        (gain - truth).abs() < 4.0 * se,
        "gain {gain} +- {se}, truth {truth}"
    );
    assert!(result.effective.is_empty() && result.pdf_fit.is_none());
    // Four models (this EMCCD, the paper's pdf, median, mean) at each signal.
    assert_eq!(result.comparison.len(), 4 * QUICK_SIGNALS_PHOTONS.len());
    assert_files_exist(&result, &["emgain.png", "r_vs_signal.csv", "index.html"]);
    // The simple model's effective QE factor: one record per configuration of the quick grid,
    // with the simple model's read noise the fitted one over the fitted gain; the operating
    // point's (8x8 px, airy:2, 50 photons) in the summary; table and chart written.
    let qe = &s.effective_qe;
    let grid = QUICK_SUBAPS_PX.len() * QUICK_AIRY_DIAMETERS_PX.len() * QUICK_SIGNALS_PHOTONS.len();
    assert_eq!(
        (qe.configurations, s.effective_qe_records.len()),
        (grid, grid)
    );
    assert_eq!(qe.paper_holds + qe.paper_fails, qe.ok);
    assert_eq!(qe.simple_read_noise_e, s.read_noise_output_e / gain);
    let at = qe
        .at_operating_point
        .as_ref()
        .expect("the default point is in the quick grid");
    assert_eq!(
        (at.subap_px, at.spot.as_str(), at.signal_photons),
        (8, "airy:2", 50.0)
    );
    for r in &s.effective_qe_records {
        if r.qe.status == detnoise::effective::QeStatus::Ok {
            assert!(r.qe.qe_factor > 0.0 && r.qe.qe_factor <= 1.0 && r.qe.qe_factor_se > 0.0);
        }
    }
    assert_files_exist(
        &result,
        &[
            "effective_qe.csv",
            "effective_qe.json",
            "effective_qe_airy-2.png",
        ],
    );
    let page = std::fs::read_to_string(out.join("index.html")).unwrap();
    assert!(page.contains("The simple model's effective QE factor") && !page.contains("NaN"));
    let written: Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("summary.json")).unwrap()).unwrap();
    assert_eq!(written["effective_qe"]["configurations"], grid);
}

#[test]
fn a_bad_option_is_refused_naming_its_field_before_anything_is_written() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("rep");
    let options = ReportOptions {
        gain_e_per_adu: None,
        ..quick("scmos-darks-64x64.fits", 0.25, &out)
    };
    match options.validate() {
        Err(Error::Usage { field, .. }) => assert_eq!(field, "gain_e_per_adu"),
        other => panic!("{other:?}"),
    }
    let e = report::run(&options, &Silent).unwrap_err();
    assert!(matches!(e, Error::Usage { ref field, .. } if field == "gain_e_per_adu"));
    assert!(!out.exists());
}

/// BLAKE3 of a file's bytes as lower-case hex, computed here in one call, independently of
/// the library's streaming.
fn blake3_hex(path: &Path) -> String {
    blake3::hash(&std::fs::read(path).unwrap())
        .to_hex()
        .to_string()
}

#[test]
fn summary_lists_every_input_and_a_given_operating_point_beside_the_grid() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("rep");
    let flats: Vec<_> = [100, 400, 1600, 6400]
        .iter()
        .map(|e| data(&format!("scmos-flat-64x64-{e}e.fits")))
        .collect();
    let point = OperatingPoint {
        subap_px: 6,
        spot: Spot::Airy { diameter_px: 2.0 },
        signal_photons: 50.0,
    };
    let options = ReportOptions {
        gain_e_per_adu: None,
        flats_paths: flats.clone(),
        subaps_px: Some(vec![4]),
        spots: Some(vec![Spot::Airy { diameter_px: 2.0 }]),
        signals_photons: Some(vec![50.0]),
        iters: 600,
        operating_point: Some(point),
        ..quick("scmos-darks-64x64.fits", 0.25, &out)
    };
    let result = report::run(&options, &Silent).unwrap();
    let written: Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("summary.json")).unwrap()).unwrap();

    // Every input: the darks, then each flat, with its own BLAKE3, frame count and format.
    let inputs = written["inputs"].as_array().unwrap();
    let expected: Vec<(&str, std::path::PathBuf)> =
        std::iter::once(("darks", data("scmos-darks-64x64.fits")))
            .chain(flats.iter().map(|f| ("flats", f.clone())))
            .collect();
    assert_eq!(inputs.len(), expected.len());
    for (input, (role, path)) in inputs.iter().zip(&expected) {
        assert_eq!(input["role"], *role);
        assert_eq!(input["path"], path.display().to_string());
        assert_eq!(input["blake3"], blake3_hex(path), "{}", path.display());
        assert!(input["sha256"].is_null());
        assert_eq!(input["format"], "fits");
        let manifest = manifest(path.file_name().unwrap().to_str().unwrap());
        assert_eq!(input["frames"], manifest["spec"]["frames"]);
    }

    // The given point is not in the one-configuration grid: solved beside it, not tabled.
    let op = &written["operating_point"];
    assert_eq!(op["subap_px"], 6);
    assert_eq!(op["spot"], "airy:2");
    assert_eq!(
        (op["chosen"].as_str(), op["in_grid"].as_bool()),
        (Some("given"), Some(false))
    );
    assert!(op["sigma_eff_map_status"].is_string());
    assert_eq!(result.effective.len(), 2);
    assert!(result.effective.iter().all(|r| r.config.subap_px == 4));
    // The comparison runs at the point's sub-aperture.
    assert!(result
        .comparison
        .iter()
        .all(|c| c.record.config.subap_px == 6));
    let page = std::fs::read_to_string(out.join("index.html")).unwrap();
    assert!(
        page.contains("6x6 px, airy:2, 50 photons (given; not in the grid, simulated beside it)")
    );
    assert!(page.contains("a 6×6 px sub-aperture"));

    // Photon transfer's points are written as tables beside its chart.
    let csv = std::fs::read_to_string(out.join("ptc_points.csv")).unwrap();
    assert_eq!(csv.lines().count(), 1 + flats.len());
    let points: Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("ptc_points.json")).unwrap())
            .unwrap();
    let ptc = result.ptc.as_ref().unwrap();
    for (p, level) in points.as_array().unwrap().iter().zip(&ptc.levels) {
        assert_eq!(p["mean_adu"].as_f64(), Some(level.mean_adu));
        assert_eq!(p["frames"].as_u64(), Some(level.frames as u64));
    }
    assert!(result.files.contains(&out.join("ptc_points.csv")));
}

#[test]
fn an_operating_point_outside_the_valid_range_is_refused_before_any_frame_is_read() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("rep");
    for point in [
        OperatingPoint {
            subap_px: 1,
            ..OperatingPoint::default()
        },
        OperatingPoint {
            signal_photons: -5.0,
            ..OperatingPoint::default()
        },
        OperatingPoint {
            spot: Spot::Airy { diameter_px: 0.01 },
            ..OperatingPoint::default()
        },
    ] {
        let options = ReportOptions {
            // A stack that does not exist: the point is refused before it is looked for.
            darks_paths: vec![dir.path().join("missing.fits")],
            operating_point: Some(point),
            ..quick("scmos-darks-64x64.fits", 0.25, &out)
        };
        let e = report::run(&options, &Silent).unwrap_err();
        assert!(
            matches!(e, Error::Usage { ref field, .. } if field == "operating_point"),
            "{e}"
        );
        assert!(!out.exists());
    }
}

#[test]
fn the_real_noise_section_measures_and_simulates_the_cameras_rts_and_line_noise() {
    // The bundled camera with 3 % two-level RTS pixels (8 e- steps), row noise 0.5 e- and
    // column noise 0.3 e- (data-synthetic/scmos-rts-64x64.manifest.json): the report recovers
    // the line noise within 4 SE, fits most RTS pixels, and solves every richer model at the
    // operating point beside the map, each difference carrying its SE.
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("rep");
    let result = report::run(&quick("scmos-rts-64x64.fits", 0.25, &out), &Silent).unwrap();
    assert_files_exist(
        &result,
        &[
            "real_noise.csv",
            "real_noise.json",
            "rts.csv",
            "rts.fits",
            "rts_series.png",
        ],
    );
    let r = &result.scmos().expect("an sCMOS summary").real_noise;
    let t = &r.temporal_noise;
    for (got, se, truth) in [
        (t.row_rms_e, t.row_rms_se_e, 0.5),
        (t.column_rms_e, t.column_rms_se_e, 0.3),
    ] {
        let (got, se) = (got.unwrap(), se.unwrap());
        assert!((got - truth).abs() < 4.0 * se, "{got} ± {se} vs {truth}");
    }
    let injected = manifest("scmos-rts-64x64.fits")["defects"]["rts_pixels"]
        .as_u64()
        .unwrap() as usize;
    assert!(r.rts.ok >= injected * 9 / 10, "{} of {injected}", r.rts.ok);
    let models: Vec<&str> = r.rows.iter().map(|row| row.model.as_str()).collect();
    for name in [
        "scmos-random",
        "scmos-map",
        "scmos-rts",
        "scmos-correlated",
        "scmos-frames",
    ] {
        assert!(
            models.iter().any(|m| m.starts_with(name)),
            "{name} in {models:?}"
        );
    }
    for row in &r.rows {
        let reference = row.model.starts_with("scmos-map");
        assert_eq!(row.adds_status == "reference", reference, "{row:?}");
        if !reference && row.sigma_eff_e.is_some() {
            let (a, se) = (row.adds_e.unwrap(), row.adds_se_e.unwrap());
            assert!(a.is_finite() && se > 0.0, "{row:?}");
        }
    }
    let written: Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("summary.json")).unwrap()).unwrap();
    assert_eq!(written["real_noise"]["rows"].as_array().unwrap().len(), 5);
    let page = std::fs::read_to_string(out.join("index.html")).unwrap();
    assert!(page.contains("noise beyond Gaussian pixels") && !page.contains("NaN"));
}

/// Whether `name` matches the glob `pattern` (only `*` is used in output names).
fn matches(pattern: &str, name: &str) -> bool {
    match pattern.split_once('*') {
        None => pattern == name,
        Some((head, tail)) => {
            name.len() >= head.len() + tail.len() && name.starts_with(head) && name.ends_with(tail)
        }
    }
}

/// The readout parameters with a 16x16 camera model whose campaign took darks at 0.01 and
/// 0.1 s (its operating point: the default exposure, 0.01 s).
fn with_camera() -> detnoise::detector::ModelParams {
    use detnoise::calib::{Map, Unit};
    use detnoise::camera::{CameraChoice, CameraModel, OperatingRange};
    let model = CameraModel::new(
        Map::filled(16, 16, 100.0, Unit::Adu),
        1.0,
        Map::filled(16, 16, 1.5, Unit::Electrons),
        16,
    )
    .unwrap()
    .with_campaign(OperatingRange {
        exposures_s: vec![0.01, 0.1],
        em_gains: vec![],
        temperatures_c: vec![],
    })
    .unwrap();
    let choice = CameraChoice::new(model, None, None, None).unwrap();
    detnoise::detector::ModelParams {
        camera: Some(choice.at.clone()),
        camera_choice: Some(std::sync::Arc::new(choice)),
        ..Default::default()
    }
}

#[test]
fn the_declared_output_names_are_the_files_full_reports_write() {
    // Every part of a report: the darks with telegraph pixels (their example series), photon
    // transfer on the flats, a lenslet geometry, every centroider (the default), and an EMCCD
    // report; on one configuration with few iterations (the files do not depend on them).
    let dir = tempfile::tempdir().unwrap();
    let one_config = |stack: &str, out: &str| ReportOptions {
        subaps_px: Some(vec![8]),
        spots: Some(vec![Spot::Airy { diameter_px: 2.0 }]),
        signals_photons: Some(vec![50.0]),
        ..quick(stack, 0.25, &dir.path().join(out))
    };
    let small = |stack: &str, out: &str| ReportOptions {
        iters: 600,
        precision: detnoise::effective::Precision::fixed(600),
        ..one_config(stack, out)
    };
    let geometry = detnoise::subaps::Geometry {
        grid: detnoise::subaps::GridSpec::parse("8").unwrap(),
        mask: None,
    };
    let runs = [
        ReportOptions {
            subaps: Some(geometry),
            ..small("scmos-rts-64x64.fits", "rts")
        },
        ReportOptions {
            gain_e_per_adu: None,
            flats_paths: [100, 400, 1600, 6400]
                .iter()
                .map(|e| data(&format!("scmos-flat-64x64-{e}e.fits")))
                .collect(),
            ..small("scmos-darks-64x64.fits", "flats")
        },
        // The QE factor's chart needs an `ok` factor: the quick precision target. With a
        // camera model: its section's files.
        ReportOptions {
            detector: DetectorKind::Emccd,
            gain_e_per_adu: Some(10.0),
            model_params: with_camera(),
            ..one_config("emccd-lowlight-32x48.fits", "emccd")
        },
    ];
    let declared = report::output_names(true);
    let mut written: Vec<String> = Vec::new();
    for options in &runs {
        report::run(options, &Silent).unwrap();
        for entry in std::fs::read_dir(&options.out_dir).unwrap() {
            let name = entry.unwrap().file_name().to_string_lossy().into_owned();
            // The directory's manifest is the output directory's, not a part's.
            if name != ".detnoise-manifest.json" {
                written.push(name);
            }
        }
    }
    let undeclared: Vec<&String> = written
        .iter()
        .filter(|n| !declared.iter().any(|p| matches(p, n)))
        .collect();
    assert!(
        undeclared.is_empty(),
        "written, not declared: {undeclared:?}"
    );
    let unwritten: Vec<&&str> = declared
        .iter()
        .filter(|p| !written.iter().any(|n| matches(p, n)))
        .collect();
    assert!(unwritten.is_empty(), "declared, not written: {unwritten:?}");
    // Without a lenslet geometry the per-sub-aperture files are not among the names.
    let plain = report::output_names(false);
    assert_eq!(
        plain.len() + detnoise::subaps::OUTPUT_NAMES.len(),
        declared.len()
    );
    assert!(!plain.contains(&"subaps.csv") && declared.contains(&"subaps.csv"));
}
