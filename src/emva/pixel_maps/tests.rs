//! The maps against the per-pixel truth of a simulated camera whose gain and dark current vary
//! from pixel to pixel: the pulls (estimate - truth) / SE over the pixels have mean ~0 and RMS ~1.

use rand_distr::{Distribution, StandardNormal};

use super::*;
use crate::emva::pairs::pair_stats;
use crate::emva::temporal::temporal;
use crate::rng::{stream, SimRng};
use crate::stats::poisson;

const PIXELS: usize = 50 * 50;
const POINTS: usize = 60;

struct Truth {
    gain: Vec<f64>,
    dark_current: Vec<f64>,
}

fn truth() -> Truth {
    let u = |j: usize, p: usize| ((j * p) % 97) as f64 / 48.0 - 1.0;
    Truth {
        gain: (0..PIXELS).map(|j| 0.5 * (1.0 + 0.2 * u(j, 31))).collect(),
        dark_current: (0..PIXELS)
            .map(|j| 200.0 * (1.0 + 0.5 * u(j, 57)))
            .collect(),
    }
}

/// A frame of `electrons` mean photo-electrons per pixel at `t` s (read noise 5 e-, full well
/// 10,000 e-, offset 100 DN, rounded).
fn frame(truth: &Truth, electrons: f64, t: f64, rng: &mut SimRng) -> Vec<f64> {
    (0..PIXELS)
        .map(|j| {
            let e = (poisson(electrons + truth.dark_current[j] * t, rng) as f64).min(10_000.0);
            let read: f64 = StandardNormal.sample(rng);
            (100.0 + truth.gain[j] * (e + 5.0 * read)).round()
        })
        .collect()
}

fn pulls(estimate: &[f64], se: &[f64], truth: &[f64]) -> (f64, f64) {
    let p: Vec<f64> = (0..estimate.len())
        .map(|j| (estimate[j] - truth[j]) / se[j])
        .collect();
    let n = p.len() as f64;
    let mean = p.iter().sum::<f64>() / n;
    let rms = (p.iter().map(|x| x * x).sum::<f64>() / n).sqrt();
    (mean, rms)
}

#[test]
fn gain_and_dark_current_maps_match_the_pixels_truth_within_their_ses() {
    let truth = truth();
    let frames: Vec<[Vec<f64>; 4]> = (0..POINTS)
        .map(|i| {
            let f = (i + 1) as f64 / POINTS as f64;
            let mut rng = stream(21, i as u64, 0);
            let e = 13_000.0 * f;
            [
                frame(&truth, e, f, &mut rng),
                frame(&truth, e, f, &mut rng),
                frame(&truth, 0.0, f, &mut rng),
                frame(&truth, 0.0, f, &mut rng),
            ]
        })
        .collect();
    let stats: Vec<PointStats> = frames
        .iter()
        .enumerate()
        .map(|(i, [a, b, da, db])| PointStats {
            exposure_s: (i + 1) as f64 / POINTS as f64,
            photons_per_px: None,
            bright: pair_stats(a, b),
            dark: pair_stats(da, db),
        })
        .collect();
    let result = temporal(&stats);
    let k = result.system_gain_dn_per_e.value;
    let maps = accumulate(frames.iter().flatten(), &stats, &result);
    let (mean, rms) = pulls(&maps.gain_dn_per_e, &maps.gain_se_dn_per_e, &truth.gain);
    eprintln!("gain map pulls: mean {mean}, rms {rms}");
    assert!(
        mean.abs() < 0.1 && (0.85..1.15).contains(&rms),
        "{mean} {rms}"
    );
    // The dark current map is the DN/s slope over the datasheet's K: compare slopes.
    let slope: Vec<f64> = maps.dark_current_e_per_s.iter().map(|v| v * k).collect();
    let slope_se: Vec<f64> = maps.dark_current_se_e_per_s.iter().map(|v| v * k).collect();
    let slope_truth: Vec<f64> = (0..PIXELS)
        .map(|j| truth.gain[j] * truth.dark_current[j])
        .collect();
    let (mean, rms) = pulls(&slope, &slope_se, &slope_truth);
    eprintln!("dark current map pulls: mean {mean}, rms {rms}");
    assert!(
        mean.abs() < 0.1 && (0.8..1.2).contains(&rms),
        "{mean} {rms}"
    );
}

/// The maps of in-memory frames (four per point: bright pair, dark pair), point by point.
fn accumulate<'a>(
    frames: impl Iterator<Item = &'a Vec<f64>>,
    stats: &[PointStats],
    result: &TemporalResult,
) -> PixelMaps {
    let k = result.system_gain_dn_per_e.value;
    let frames: Vec<FrameData> = frames.map(|f| FrameData::Values(f.clone())).collect();
    let mut acc = MapAccumulator::new(PIXELS);
    for (i, f) in frames.chunks(4).enumerate() {
        let bright = (i <= result.sensitivity_fit[1]).then(|| [&f[0], &f[1]]);
        acc.add_point([&f[2], &f[3]], bright, &stats[i], k);
    }
    acc.finish((50, 50), k)
}

#[test]
fn pixel_maps_read_from_files_equal_the_accumulated_frames() {
    use crate::emva::pairs::measure;
    use crate::emva::{EmvaDataset, PairPoint};
    use crate::io::fits::write_cube;
    let truth = truth();
    let dir = tempfile::tempdir().unwrap();
    let mut frames = Vec::new();
    let mut points = Vec::new();
    for i in 0..4 {
        let t = 0.1 * (i + 1) as f64;
        let mut rng = stream(22, i, 0);
        let mut paths = Vec::new();
        for (k, e) in [2000.0 * t, 2000.0 * t, 0.0, 0.0].into_iter().enumerate() {
            let v = frame(&truth, e, t, &mut rng);
            let path = dir.path().join(format!("p{i}f{k}.fits"));
            // Stored as uint16 (read as stored bytes, decoded block by block).
            let mut once = Some(v.clone());
            write_cube(&path, (50, 50), 1, true, &mut || once.take().unwrap(), &[]).unwrap();
            frames.push(v);
            paths.push(path);
        }
        points.push(PairPoint {
            exposure_s: t,
            photons_per_px: None,
            bright: [paths[0].clone(), paths[1].clone()],
            dark: [paths[2].clone(), paths[3].clone()],
        });
    }
    let dataset = EmvaDataset {
        source: dir.path().join("descriptor.txt"),
        format: None,
        points,
        spatial_bright: None,
        spatial_dark: None,
    };
    let stats = measure(&dataset).unwrap();
    let result = temporal(&stats);
    let maps = pixel_maps(&dataset, &stats, &result).unwrap();
    assert_eq!(maps, accumulate(frames.iter(), &stats, &result));
    assert!(maps.gain_dn_per_e.iter().all(|g| g.is_finite()));
}
