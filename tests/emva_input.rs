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
