//! The EMVA 1288 dataset loader on the bundled dataset, the reference implementation's
//! fixtures and bad input (library calls, no CLI).

use std::path::{Path, PathBuf};

use detnoise::emva::dataset::{DatasheetPart, EmvaDataset, MIN_POINTS, STANDARD_POINTS};
use detnoise::io::fits::write_cube;
use serde_json::Value;

fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

fn bundled() -> PathBuf {
    root().join("data-synthetic/emva-cmos-64x96/EMVA1288descriptor.txt")
}

fn json(path: &Path) -> Value {
    serde_json::from_str(&std::fs::read_to_string(path).unwrap()).unwrap()
}

#[test]
fn the_bundled_dataset_reads_as_its_truth_describes() {
    let d = EmvaDataset::from_descriptor(&bundled()).unwrap();
    let truth = json(&bundled().with_file_name("truth.json"));
    let f = d.format.unwrap();
    assert_eq!((f.bits, f.height, f.width), (12, 64, 96));
    assert_eq!(
        d.points.len() as u64,
        truth["photon_transfer_points"].as_u64().unwrap()
    );
    assert!(d.points.len() >= STANDARD_POINTS);
    assert!(d
        .points
        .windows(2)
        .all(|w| w[0].photons_per_px < w[1].photons_per_px));
    let rate = truth["photons_per_px_per_s"].as_f64().unwrap();
    for p in &d.points {
        let photons = p.photons_per_px.unwrap();
        assert!((photons - rate * p.exposure_s).abs() < 1e-3, "{p:?}");
        assert!(p.bright.iter().chain(&p.dark).all(|f| f.is_file()));
    }
    let sb = d.spatial_bright.as_ref().unwrap();
    let sd = d.spatial_dark.as_ref().unwrap();
    let frames = truth["spatial_frames"].as_u64().unwrap() as usize;
    assert_eq!((sb.files.len(), sd.files.len()), (frames, frames));
    let t = truth["spatial_exposure_s"].as_f64().unwrap();
    assert!((sb.exposure_s - t).abs() < 1e-12 && (sd.exposure_s - t).abs() < 1e-12);
    assert_eq!(d.rule_breaks(), vec![]);
    assert_eq!(d.exposures_s().len(), d.points.len());

    let check = d.check_frames().unwrap();
    assert_eq!(check.shape, (64, 96));
    assert_eq!(check.saturation_dn, Some(4095.0));
    assert_eq!(check.rule_breaks, vec![]);
    // Past saturation: the brightest pair's variance is the quantisation and read noise only.
    assert!(check.brightest_variance_ratio.unwrap() < 0.1, "{check:?}");
    // Spatial stack at 50 % of the full well, the brightest point at the full well.
    let r = check.spatial_signal_ratio.unwrap();
    assert!((r - 0.5).abs() < 0.05, "{check:?}");
}

/// A folder holding `files` (name -> frame of `shape` filled by `value(pixel index)`) as
/// single-frame uint16 FITS files, and `descriptor` written beside them.
struct Dataset {
    dir: tempfile::TempDir,
}

impl Dataset {
    fn new() -> Dataset {
        Dataset {
            dir: tempfile::tempdir().unwrap(),
        }
    }

    fn frame(&self, name: &str, shape: (usize, usize), value: impl Fn(usize) -> f64) {
        let path = self.dir.path().join(name.replace('\\', "/"));
        std::fs::create_dir_all(path.parent().unwrap()).unwrap();
        let mut next = || (0..shape.0 * shape.1).map(&value).collect::<Vec<f64>>();
        write_cube(&path, shape, 1, true, &mut next, &[]).unwrap();
    }

    fn descriptor(&self, text: &str) -> PathBuf {
        let path = self.dir.path().join("desc.txt");
        std::fs::write(&path, text).unwrap();
        path
    }
}

/// Deterministic noise in [-0.5, 0.5) from a pixel index and a seed.
fn noise(i: usize, seed: usize) -> f64 {
    let x = (i as u64 + 1).wrapping_mul(6364136223846793005)
        ^ (seed as u64 + 7).wrapping_mul(1442695040888963407);
    let x = x.wrapping_mul(0x9E3779B97F4A7C15);
    (x >> 11) as f64 / (1u64 << 53) as f64 - 0.5
}

/// A linear camera on `shape` px, 12 bits, 0.5 DN/e-, offset 100 DN, full well 4000 e-: the
/// descriptor lines and frames of `n` exposure points at `e_per_point` e- steps, dark pairs
/// at each, and 4-frame spatial stacks at `spatial_e` e-.
fn camera(
    ds: &Dataset,
    shape: (usize, usize),
    n: usize,
    e_per_point: f64,
    spatial_e: f64,
) -> String {
    let mut text = format!("v 4.0\nn 12 {} {}\n", shape.1, shape.0);
    let mut k = 0;
    let mut images = |signal_e: f64, count: usize, text: &mut String| {
        for _ in 0..count {
            let name = format!("images\\f{k}.fits");
            let e = signal_e.min(4000.0);
            // Photon and read noise (9 e-^2) as uniform noise of that variance; none at the
            // full well.
            let sigma_e = if e >= 4000.0 {
                0.0
            } else {
                (e + 9.0).sqrt() * 12f64.sqrt()
            };
            let seed = k;
            ds.frame(&name, shape, |i| {
                (100.0 + 0.5 * (e + sigma_e * noise(i, seed))).round()
            });
            text.push_str(&format!("i {name}\n"));
            k += 1;
        }
    };
    for p in 1..=n {
        let e = p as f64 * e_per_point;
        text.push_str(&format!("b {}000 {}\n", p, e * 2.0));
        images(e, 2, &mut text);
        text.push_str(&format!("d {}000\n", p));
        images(0.0, 2, &mut text);
    }
    let t = (spatial_e / e_per_point).round() as usize;
    text.push_str(&format!("b {t}000 {}\n", spatial_e * 2.0));
    images(spatial_e, 4, &mut text);
    text.push_str(&format!("d {t}000\n"));
    images(0.0, 4, &mut text);
    text
}

#[test]
fn a_series_past_saturation_with_its_spatial_stack_at_half_passes() {
    let ds = Dataset::new();
    let text = camera(&ds, (6, 8), 10, 500.0, 2000.0);
    let d = EmvaDataset::from_descriptor(&ds.descriptor(&text)).unwrap();
    let breaks = d.rule_breaks();
    assert_eq!(breaks.len(), 1);
    assert_eq!(breaks[0].part, DatasheetPart::Temporal);
    let check = d.check_frames().unwrap();
    assert_eq!(check.shape, (6, 8));
    assert_eq!(check.rule_breaks, vec![], "{check:?}");
}

#[test]
fn a_series_that_stops_below_saturation_is_out_of_the_rules() {
    let ds = Dataset::new();
    let text = camera(&ds, (6, 8), 6, 500.0, 1500.0);
    let d = EmvaDataset::from_descriptor(&ds.descriptor(&text)).unwrap();
    let check = d.check_frames().unwrap();
    assert_eq!(check.rule_breaks.len(), 1, "{check:?}");
    assert_eq!(check.rule_breaks[0].part, DatasheetPart::Temporal);
    assert!(check.rule_breaks[0]
        .rule
        .starts_with("no photon-transfer point past saturation"));
}

#[test]
fn a_saturated_spatial_stack_is_refused() {
    let ds = Dataset::new();
    let text = camera(&ds, (6, 8), 10, 500.0, 4500.0);
    let d = EmvaDataset::from_descriptor(&ds.descriptor(&text)).unwrap();
    let e = d.check_frames().unwrap_err().to_string();
    assert!(e.contains("f40.fits"), "{e}");
    assert!(e.contains("the bright spatial stack is saturated"), "{e}");
}

#[test]
fn a_spatial_stack_far_from_half_saturation_is_out_of_the_rules() {
    let ds = Dataset::new();
    let text = camera(&ds, (6, 8), 10, 500.0, 500.0);
    let d = EmvaDataset::from_descriptor(&ds.descriptor(&text)).unwrap();
    let check = d.check_frames().unwrap();
    assert_eq!(check.rule_breaks.len(), 1, "{check:?}");
    assert_eq!(check.rule_breaks[0].part, DatasheetPart::Spatial);
}

#[test]
fn frames_of_another_shape_than_the_n_line_are_refused() {
    let ds = Dataset::new();
    let text = camera(&ds, (6, 8), 5, 500.0, 1000.0).replace("n 12 8 6", "n 12 6 8");
    let d = EmvaDataset::from_descriptor(&ds.descriptor(&text)).unwrap();
    let e = d.check_frames().unwrap_err().to_string();
    assert!(
        e.contains("frame 0: 6 rows x 8 columns, but the descriptor's `n` line declares width 6 and height 8"),
        "{e}"
    );
    // Values beyond the declared bits.
    let text = camera(&ds, (6, 8), 5, 500.0, 1000.0).replace("n 12 8 6", "n 8 8 6");
    let d = EmvaDataset::from_descriptor(&ds.descriptor(&text)).unwrap();
    let e = d.check_frames().unwrap_err().to_string();
    assert!(e.contains("above 255, the largest of the 8 bits"), "{e}");
}

#[test]
fn windows_paths_missing_files_and_too_few_points_are_refused_before_frames() {
    let ds = Dataset::new();
    let text = camera(&ds, (6, 8), MIN_POINTS, 500.0, 1000.0);
    assert!(text.contains("i images\\f0.fits"));
    let d = EmvaDataset::from_descriptor(&ds.descriptor(&text)).unwrap();
    assert_eq!(d.points[0].bright[0], ds.dir.path().join("images/f0.fits"));
    // One point fewer than the minimum: refused, naming the count.
    let cut = text.find(&format!("b {MIN_POINTS}000")).unwrap();
    let e = EmvaDataset::from_descriptor(&ds.descriptor(&text[..cut]))
        .unwrap_err()
        .to_string();
    assert!(e.contains("4 photon-transfer point(s)"), "{e}");
    std::fs::remove_file(ds.dir.path().join("images/f3.fits")).unwrap();
    let e = EmvaDataset::from_descriptor(&ds.descriptor(&text))
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("desc.txt: 1 image file(s) it names do not exist"),
        "{e}"
    );
    assert!(e.contains("f3.fits (") && e.contains("line 6)"), "{e}");
}

fn fixture(name: &str) -> PathBuf {
    root().join("tests/fixtures/emva1288").join(name)
}

#[test]
fn the_reference_fixtures_read_with_their_windows_paths() {
    for (name, shape, bits, exposures) in [
        ("emva-ref-96x128", (96, 128), 12, 50),
        ("emva-ref-64x64", (64, 64), 10, 1),
    ] {
        let descriptor = fixture(name).join("EMVA1288descriptor.txt");
        let text = std::fs::read_to_string(&descriptor).unwrap();
        assert!(text.contains("i images\\image0.tif"), "{name}");
        let d = EmvaDataset::from_descriptor(&descriptor).unwrap();
        let results = json(&fixture(name).join("results.json"));
        let temporal = &results["temporal"];
        assert_eq!(d.points.len(), 50, "{name}");
        assert_eq!(d.exposures_s().len(), exposures, "{name}");
        // The points in the reference's order (by exposure, then photons) with its photons.
        let photons: Vec<f64> = temporal["u_p_photons"]
            .as_array()
            .unwrap()
            .iter()
            .map(|v| v.as_f64().unwrap())
            .collect();
        for (p, want) in d.points.iter().zip(&photons) {
            assert!((p.photons_per_px.unwrap() - want).abs() < 1e-9, "{name}");
        }
        let spatial = &results["spatial"];
        let sb = d.spatial_bright.as_ref().unwrap();
        assert_eq!(sb.files.len() as u64, spatial["L"].as_u64().unwrap());
        assert!((sb.exposure_s * 1e9 - spatial["texp_ns"].as_f64().unwrap()).abs() < 1e-3);
        assert_eq!(d.rule_breaks(), vec![], "{name}");
        let check = d.check_frames().unwrap();
        assert_eq!(check.shape, shape, "{name}");
        assert_eq!(check.saturation_dn, Some(2f64.powi(bits) - 1.0), "{name}");
        assert_eq!(check.rule_breaks, vec![], "{name}: {check:?}");
    }
}

/// The reference's results agree with the simulator's truth where the simulator and the
/// reference are right (K, QE, dark current, DSNU and PRNU), and are null where it gives NaN.
#[test]
fn the_reference_results_agree_with_the_truth_they_were_made_from() {
    let close = |got: &Value, want: &Value, rel: f64, what: &str| {
        let (g, w) = (got.as_f64().unwrap(), want.as_f64().unwrap());
        assert!((g - w).abs() <= rel * w.abs(), "{what}: {g} vs {w}");
    };
    for name in ["emva-ref-96x128", "emva-ref-64x64"] {
        let r = json(&fixture(name).join("results.json"));
        let t = json(&fixture(name).join("truth.json"));
        let r = &r["results"];
        close(&r["K_dn_per_e"], &t["K_dn_per_e"], 0.01, name);
        close(&r["QE_percent"], &t["qe_percent"], 0.01, name);
        close(
            &r["sigma_d_e"],
            &t["temporal_dark_noise_as_measured_e"],
            0.02,
            name,
        );
        close(
            &r["DSNU1288_pixel_e"],
            &t["dsnu_realised_e"]["pixel"],
            0.05,
            name,
        );
        close(
            &r["PRNU1288_pixel_percent"],
            &t["prnu_realised_percent"]["pixel"],
            0.05,
            name,
        );
    }
    let r = json(&fixture("emva-ref-96x128/results.json"));
    let t = json(&fixture("emva-ref-96x128/truth.json"));
    close(
        &r["results"]["u_I_mean_e_per_s"],
        &t["dark_current_e_per_s"],
        0.05,
        "dark current",
    );
    close(
        &r["results"]["DSNU1288_col_e"],
        &t["dsnu_realised_e"]["col"],
        0.05,
        "col",
    );
    close(
        &r["results"]["PRNU1288_percent"],
        &t["prnu_realised_percent"]["total"],
        0.05,
        "prnu",
    );
    // No row pattern on the 64-row camera: the reference's row estimates fall below 0 and it
    // gives NaN (null here); one exposure time: no dark current.
    let r = json(&fixture("emva-ref-64x64/results.json"));
    for key in ["DSNU1288_row_e", "PRNU1288_row_percent", "u_I_mean_e_per_s"] {
        assert!(r["results"][key].is_null(), "{key}");
    }
    // On the bundled dataset the reference takes the last point of the noisy plateau past
    // saturation as the saturation point.
    let b = json(&fixture("bundled-results.json"));
    assert_eq!(b["results"]["index_u_ysat"].as_f64(), Some(59.0));
}

/// The bundled dataset as a campaign manifest (one row per image, light_level the photons per
/// pixel of the flats) is the same dataset as its descriptor, `n` line aside.
#[test]
fn the_bundled_dataset_as_a_manifest_is_the_same_dataset() {
    let dir = tempfile::tempdir().unwrap();
    let text = std::fs::read_to_string(bundled()).unwrap();
    let folder = bundled().parent().unwrap().to_path_buf();
    let mut rows = String::from("file,kind,exposure_s,em_gain,temperature_c,light_level\n");
    let mut condition = String::new();
    for line in text.lines() {
        let words: Vec<&str> = line.split_whitespace().collect();
        let ns = |w: &str| w.parse::<f64>().unwrap() * 1e-9;
        match words.as_slice() {
            ["b", t, photons] => condition = format!("flat,{},,,{photons}", ns(t)),
            ["d", t] => condition = format!("dark,{},,,", ns(t)),
            ["i", path] => {
                let file = folder.join(path.replace('\\', "/"));
                rows.push_str(&format!("{},{condition}\n", file.display()));
            }
            _ => {}
        }
    }
    let manifest = dir.path().join("emva.csv");
    std::fs::write(&manifest, rows).unwrap();
    let from_manifest = EmvaDataset::from_manifest(&manifest).unwrap();
    let from_descriptor = EmvaDataset::from_descriptor(&bundled()).unwrap();
    assert_eq!(from_manifest.format, None);
    assert_eq!(from_manifest.points.len(), from_descriptor.points.len());
    for (m, d) in from_manifest.points.iter().zip(&from_descriptor.points) {
        assert_eq!((&m.bright, &m.dark), (&d.bright, &d.dark));
        assert!((m.exposure_s - d.exposure_s).abs() < 1e-15);
        assert!((m.photons_per_px.unwrap() - d.photons_per_px.unwrap()).abs() < 1e-9);
    }
    assert_eq!(
        from_manifest.spatial_bright.as_ref().unwrap().files,
        from_descriptor.spatial_bright.as_ref().unwrap().files
    );
    assert_eq!(
        from_manifest.spatial_dark.as_ref().unwrap().files,
        from_descriptor.spatial_dark.as_ref().unwrap().files
    );
    let check = from_manifest.check_frames().unwrap();
    // No `n` line: the largest value is the stored type's (uint16).
    assert_eq!(check.saturation_dn, Some(65535.0));
    assert_eq!(check.rule_breaks, vec![]);
}

#[test]
fn a_multi_frame_file_in_a_manifest_is_refused_by_the_frame_check() {
    let ds = Dataset::new();
    let text = camera(&ds, (6, 8), 5, 500.0, 1000.0);
    let d = EmvaDataset::from_descriptor(&ds.descriptor(&text)).unwrap();
    // The brightest point's first image replaced by a 3-frame stack.
    let path = &d.points[4].bright[0];
    let mut next = || vec![100.0; 48];
    write_cube(path, (6, 8), 3, true, &mut next, &[]).unwrap();
    let e = d.check_frames().unwrap_err().to_string();
    assert!(
        e.contains(
            "f16.fits: holds 3 frames: each image of an EMVA dataset is one single-frame file"
        ),
        "{e}"
    );
}

#[test]
fn a_descriptor_saved_on_windows_reads_as_it_is() {
    let ds = Dataset::new();
    let text = camera(&ds, (6, 8), 5, 500.0, 1000.0);
    // CRLF line ends, a byte-order mark, decimal commas, comments.
    let windows = format!(
        "\u{feff}# written on Windows\r\n{}",
        text.replace("b 1000 1000\n", "b 1000,0 1000,0\n")
            .replace('\n', "\r\n")
    );
    assert!(windows.contains("b 1000,0 1000,0\r\ni images\\f0.fits\r\n"));
    let d = EmvaDataset::from_descriptor(&ds.descriptor(&windows)).unwrap();
    let plain = EmvaDataset::from_descriptor(&ds.descriptor(&text)).unwrap();
    assert_eq!(d.points, plain.points);
    assert_eq!(d.spatial_bright, plain.spatial_bright);
    assert_eq!(d.points[0].bright[0], ds.dir.path().join("images/f0.fits"));
}
