//! The centroiders against their definitions, written out directly per setting and frame.

use super::*;
use crate::rng::stream;
use crate::spot::{Sampling, Spot, SpotRenderer};
use rand::RngExt;

/// A context for n x n sub-apertures with the automatic levels of a 30 e- peak.
fn build(spec: CentroiderSpec, n: usize, mean: &[f64], median: f64) -> Box<dyn Centroider> {
    let levels = crate::montecarlo::BgGrid::Auto.levels(30.0);
    let ctx = CentroidContext {
        subap_px: n,
        levels_e: &levels,
        mean_e: mean,
        spot: Spot::Airy { diameter_px: 2.0 },
        sampling: Sampling::Point,
        median_sigma_e: median,
    };
    spec.build(&ctx).unwrap()
}

/// Gaussian weights of FWHM `f` px on an n x n sub-aperture, as `wcog` makes them.
fn gauss_weight(f: f64, n: usize) -> Vec<f64> {
    let s = f / (8.0 * std::f64::consts::LN_2).sqrt();
    let c = (n as f64 - 1.0) / 2.0;
    (0..n * n)
        .map(|p| {
            let (x, y) = ((p % n) as f64 - c, (p / n) as f64 - c);
            thresholded::cut((-(x * x + y * y) / (2.0 * s * s)).exp())
        })
        .collect()
}

/// The centroiders [`direct`] defines (a new centroider brings its own definition and test).
const DEFINED: [&str; 6] = [
    "cog",
    "tcog",
    "masked-cog",
    "ivw-cog",
    "wcog",
    "brightest-n",
];

/// The estimate (px from the centre) of centroider `name` at `setting`, straight from its
/// definition; None when nothing is left above the threshold. `gain` is wcog's bias correction.
fn direct(
    name: &str,
    s: &Setting,
    f: &CentroidFrame,
    median: f64,
    gain: (f64, f64),
) -> Option<(f64, f64)> {
    let n = (f.image_e.len() as f64).sqrt() as usize;
    let clip = |x: f64, t: f64| (x - t).max(0.0);
    let v: Vec<f64> = match name {
        "cog" => f.image_e.iter().map(|&x| clip(x, s.b_e)).collect(),
        "tcog" => {
            let k = s.param.unwrap();
            f.image_e
                .iter()
                .zip(f.sigma_e)
                .map(|(&x, &sg)| clip(x, k * sg))
                .collect()
        }
        "masked-cog" => {
            let above = s.param.unwrap() * median;
            f.image_e
                .iter()
                .zip(f.sigma_e)
                .map(|(&x, &sg)| if sg <= above { clip(x, s.b_e) } else { 0.0 })
                .collect()
        }
        "ivw-cog" => {
            let var: Vec<f64> = f
                .sigma_e
                .iter()
                .zip(f.mean_e)
                .map(|(&sg, &m)| sg * sg + f.photon_variance_factor * m)
                .collect();
            let least = var.iter().copied().fold(f64::INFINITY, f64::min);
            f.image_e
                .iter()
                .zip(&var)
                .map(|(&x, &v)| clip(x, s.b_e) * thresholded::cut(least / v))
                .collect()
        }
        "wcog" => f
            .image_e
            .iter()
            .zip(gauss_weight(s.param.unwrap(), n))
            .map(|(&x, w)| w * clip(x, s.b_e))
            .collect(),
        "brightest-n" => {
            let k = s.param.unwrap() as usize;
            let mut order: Vec<usize> = (0..n * n).collect();
            order.sort_by(|&a, &b| f.image_e[b].total_cmp(&f.image_e[a]).then(a.cmp(&b)));
            let t = f.image_e[order[k]];
            let mut v = vec![0.0; n * n];
            for &p in &order[..k] {
                v[p] = f.image_e[p] - t;
            }
            v
        }
        other => unreachable!("no direct definition of {other}"),
    };
    cog(&v, n).map(|(x, y)| (x * gain.0, y * gain.1))
}

/// Add to `w` (sum of distances, of their squares, empty frames) the error of `estimate`
/// against `truth`: an empty frame's estimate is the centre.
pub(super) fn add_error(w: &mut (f64, f64, u64), estimate: Option<(f64, f64)>, truth: (f64, f64)) {
    let d = match estimate {
        Some((x, y)) => (x - truth.0).hypot(y - truth.1),
        None => {
            w.2 += 1;
            truth.0.hypot(truth.1)
        }
    };
    w.0 += d;
    w.1 += d * d;
}

/// wcog's gains, per width, from a built centroider's internals.
fn gains_of(c: &dyn Centroider, n: usize) -> Vec<(f64, f64)> {
    // The gains are not exposed: recover them from one frame whose centroid is known. A single
    // pixel lit next to the centre, at offset (x, y), has that uncorrected centroid, so the
    // corrected error at truth 0 is sqrt((gx x)^2 + (gy y)^2); with gx = gy (round spot) that
    // gives the gain.
    let widths = c.settings().iter().map(|s| s.part).max().unwrap() + 1;
    let c0 = (n as f64 - 1.0) / 2.0;
    let (row, col) = (c0.floor() as usize, c0.floor() as usize + 1);
    let offset = (col as f64 - c0).hypot(row as f64 - c0);
    let mut img = vec![0.0; n * n];
    img[row * n + col] = 1.0;
    let zeros = vec![0.0; n * n];
    let f = CentroidFrame {
        image_e: &img,
        truth_px: (0.0, 0.0),
        sigma_e: &zeros,
        mean_e: &zeros,
        photon_variance_factor: 1.0,
    };
    let mut acc = c.sums();
    c.worker().accumulate(&f, &mut acc);
    let t = acc.finish();
    let per = t.len() / widths;
    (0..widths)
        .map(|w| {
            let g = t[w * per].0 / offset;
            (g, g)
        })
        .collect()
}

#[test]
fn every_centroider_matches_its_definition_at_every_setting() {
    // Random frames (values -3 to 40 e-, some on a level) with a random noise map and mean
    // image, at sizes 3-7 px; the sweep's per-setting sums against the direct estimate:
    // relative error below 2e-6 (distances in single precision), same empty-frame counts.
    let mut rng = stream(14, 0, 0);
    let median = 1.0;
    for n in 3..8 {
        let npix = n * n;
        let mean: Vec<f64> = (0..npix).map(|_| rng.random_range(0.0..5.0)).collect();
        for name in DEFINED {
            let c = build(CentroiderSpec::parse(name).unwrap(), n, &mean, median);
            let settings = c.settings();
            let parts = settings.iter().map(|s| s.part).max().unwrap() + 1;
            let gains = match name {
                "wcog" => gains_of(c.as_ref(), n),
                _ => vec![(1.0, 1.0); parts],
            };
            let mut worker = c.worker();
            let mut acc = c.sums();
            let mut want = vec![(0.0, 0.0, 0u64); settings.len()];
            for _ in 0..25 {
                let img: Vec<f64> = (0..npix).map(|_| rng.random_range(-3.0..40.0)).collect();
                let sigma: Vec<f64> = (0..npix).map(|_| rng.random_range(0.3..4.0)).collect();
                let truth = (rng.random_range(-0.5..0.5), rng.random_range(-0.5..0.5));
                let f = CentroidFrame {
                    image_e: &img,
                    truth_px: truth,
                    sigma_e: &sigma,
                    mean_e: &mean,
                    photon_variance_factor: 2.0,
                };
                worker.accumulate(&f, &mut acc);
                for (w, s) in want.iter_mut().zip(&settings) {
                    add_error(w, direct(name, s, &f, median, gains[s.part]), truth);
                }
            }
            for (k, (got, w)) in acc.finish().iter().zip(&want).enumerate() {
                assert!(
                    (got.0 - w.0).abs() <= 2e-6 * w.0
                        && (got.1 - w.1).abs() <= 4e-6 * w.1
                        && got.2 == w.2,
                    "{name} {n}x{n} setting {k} {:?}: {got:?} vs {w:?}",
                    settings[k]
                );
            }
        }
    }
}

#[test]
fn masked_pixels_never_contribute() {
    // Two pixels noisier than 3 x the median: whatever they read (here 0 or 1e6 e-), the
    // masked centroid at m = 3 is the same, bit for bit.
    let n = 4;
    let mean = vec![1.0; 16];
    let c = build(
        CentroiderSpec::parse("masked-cog:3").unwrap(),
        n,
        &mean,
        1.0,
    );
    let mut sigma = vec![1.0; 16];
    sigma[2] = 3.5;
    sigma[13] = 10.0;
    let mut rng = stream(15, 0, 0);
    let run = |hot: f64, rng: &mut crate::rng::SimRng| {
        let mut acc = c.sums();
        let mut w = c.worker();
        for _ in 0..50 {
            let mut img: Vec<f64> = (0..16).map(|_| rng.random_range(-2.0..20.0)).collect();
            img[2] = hot;
            img[13] = hot;
            let f = CentroidFrame {
                image_e: &img,
                truth_px: (0.1, -0.2),
                sigma_e: &sigma,
                mean_e: &mean,
                photon_variance_factor: 1.0,
            };
            w.accumulate(&f, &mut acc);
        }
        acc.finish()
    };
    let a = run(0.0, &mut stream(15, 0, 0));
    let b = run(1e6, &mut rng);
    assert_eq!(a, b);
}

#[test]
fn wcog_gain_is_the_gaussian_response_slope() {
    // A point-sampled Gaussian spot of sigma 3 px on 32 px: its weighted centroid responds to
    // a shift with slope w^2 / (s^2 + w^2) (weight sigma w), so the gain is the inverse; the
    // sampling changes it by far less than 1e-6, the truncation of the spot at 5 sigma (which
    // the gain's reference, the unweighted centroid, feels) by about 3e-6.
    let (n, s) = (32, 3.0);
    let spot = Spot::Gauss {
        sigma_x_px: s,
        sigma_y_px: s,
    };
    let renderer = SpotRenderer::new(spot, Sampling::Point, n, thresholded::SLOPE_OFFSET_PX);
    let fwhm = [3.0, 5.0, 9.0];
    let thresholded::Weighting::Gaussian { gains, .. } =
        thresholded::Weighting::gaussian(&fwhm, &renderer).unwrap()
    else {
        unreachable!()
    };
    for (f, (gx, gy)) in fwhm.iter().zip(gains) {
        let w = f / (8.0 * std::f64::consts::LN_2).sqrt();
        let want = (s * s + w * w) / (w * w);
        assert!(
            (gx / want - 1.0).abs() < 1e-5 && (gy / want - 1.0).abs() < 1e-5,
            "{f}: {gx} vs {want}"
        );
    }
}

#[test]
fn noiseless_spots_are_found_exactly_or_in_the_linear_limit() {
    // Noiseless images of an Airy spot at small offsets: cog at b = 0, tcog at k = 0 and
    // masked-cog with nothing masked find the truth (the centroid of the image) to rounding;
    // wcog, corrected by its slope, to 1 % of offsets up to 0.05 px (its response is linear
    // to third order).
    let n = 8;
    let renderer = SpotRenderer::new(Spot::Airy { diameter_px: 2.0 }, Sampling::Point, n, 0.1);
    let mean = vec![1.0; n * n];
    let sigma = vec![1.0; n * n];
    for (dx, dy) in [(0.05, 0.0), (0.0, -0.03), (0.02, 0.04)] {
        let mut img = vec![0.0; n * n];
        renderer.render(dx, dy, &mut img);
        let truth = cog(&img, n).unwrap();
        for (spec, tol) in [
            ("cog", 1e-6),
            ("tcog:0", 1e-6),
            ("masked-cog:2", 1e-6),
            ("wcog", 0.01),
        ] {
            let c = build(CentroiderSpec::parse(spec).unwrap(), n, &mean, 1.0);
            let f = CentroidFrame {
                image_e: &img,
                truth_px: truth,
                sigma_e: &sigma,
                mean_e: &mean,
                photon_variance_factor: 1.0,
            };
            let mut acc = c.sums();
            c.worker().accumulate(&f, &mut acc);
            // The first setting of each part is b = 0 (k = 0 for tcog).
            let finish = acc.finish();
            for (k, s) in c
                .settings()
                .iter()
                .enumerate()
                .filter(|(_, s)| s.b_e == 0.0)
            {
                let d = finish[k].0;
                let offset = truth.0.hypot(truth.1);
                assert!(
                    d <= tol * offset,
                    "{spec} {s:?} at ({dx}, {dy}): error {d} px"
                );
            }
        }
    }
}

#[test]
fn centroiders_are_unbiased_on_a_centred_spot_with_a_symmetric_map() {
    // A centred spot with Poisson light and a noise map symmetric about the centre: by
    // symmetry every estimator's mean is 0; the mean of 4000 estimates lies within 4 SE.
    let n = 6;
    let renderer = SpotRenderer::new(Spot::Airy { diameter_px: 2.0 }, Sampling::Point, n, 0.0);
    let mut mean = vec![0.0; n * n];
    renderer.render(0.0, 0.0, &mut mean);
    let total: f64 = mean.iter().sum();
    mean.iter_mut().for_each(|m| *m *= 100.0 / total);
    let mut rng = stream(16, 0, 0);
    let half: Vec<f64> = (0..n * n / 2).map(|_| rng.random_range(0.5..3.0)).collect();
    // Pixel p and pixel n^2 - 1 - p are point reflections of each other.
    let sigma: Vec<f64> = (0..n * n).map(|p| half[p.min(n * n - 1 - p)]).collect();
    let frames = 4000;
    for name in DEFINED {
        let c = build(CentroiderSpec::parse(name).unwrap(), n, &mean, 1.0);
        let settings = c.settings();
        let s = settings[settings.len() / 3];
        let gain = match name {
            "wcog" => gains_of(c.as_ref(), n)[s.part],
            _ => (1.0, 1.0),
        };
        let (mut sx, mut sxx, mut sy, mut syy) = (0.0, 0.0, 0.0, 0.0);
        for _ in 0..frames {
            let img: Vec<f64> = mean
                .iter()
                .zip(&sigma)
                .map(|(&m, &sg)| {
                    let z: f64 =
                        rand_distr::Distribution::sample(&rand_distr::StandardNormal, &mut rng);
                    crate::stats::poisson(m, &mut rng) as f64 + sg * z
                })
                .collect();
            let f = CentroidFrame {
                image_e: &img,
                truth_px: (0.0, 0.0),
                sigma_e: &sigma,
                mean_e: &mean,
                photon_variance_factor: 1.0,
            };
            let (x, y) = direct(name, &s, &f, 1.0, gain).unwrap_or((0.0, 0.0));
            sx += x;
            sxx += x * x;
            sy += y;
            syy += y * y;
        }
        let m = frames as f64;
        for (s1, s2) in [(sx, sxx), (sy, syy)] {
            let mu = s1 / m;
            let se = ((s2 / m - mu * mu) / m).sqrt();
            assert!(mu.abs() <= 4.0 * se, "{name}: mean {mu} px, SE {se}");
        }
    }
}

/// A random frame with its noise map and truth.
struct Drawn {
    image_e: Vec<f64>,
    sigma_e: Vec<f64>,
    truth_px: (f64, f64),
}

#[test]
fn every_registered_centroider_builds_sweeps_and_fixes_its_parameter() {
    // The registry's contract, for every entry (one added later included): its swept grid lies
    // in its parameter's range, the built centroider names itself and its parameter as the
    // entry does, its sums have one slot per setting, and fixing the parameter at a swept value
    // keeps only the settings at that value, each with the same error on the same frames.
    let mut rng = stream(17, 0, 0);
    let levels = crate::montecarlo::BgGrid::Auto.levels(30.0);
    for n in [2, 5, 8] {
        let npix = n * n;
        let mean: Vec<f64> = (0..npix).map(|_| rng.random_range(0.0..5.0)).collect();
        let ctx = CentroidContext {
            subap_px: n,
            levels_e: &levels,
            mean_e: &mean,
            spot: Spot::Airy { diameter_px: 2.0 },
            sampling: Sampling::Integrated,
            median_sigma_e: 1.0,
        };
        let frames: Vec<Drawn> = (0..20)
            .map(|_| Drawn {
                image_e: (0..npix).map(|_| rng.random_range(-3.0..40.0)).collect(),
                sigma_e: (0..npix).map(|_| rng.random_range(0.3..4.0)).collect(),
                truth_px: (rng.random_range(-0.5..0.5), rng.random_range(-0.5..0.5)),
            })
            .collect();
        let run = |c: &dyn Centroider| {
            let (mut acc, mut worker) = (c.sums(), c.worker());
            for d in &frames {
                let f = CentroidFrame {
                    image_e: &d.image_e,
                    truth_px: d.truth_px,
                    sigma_e: &d.sigma_e,
                    mean_e: &mean,
                    photon_variance_factor: 1.0,
                };
                worker.accumulate(&f, &mut acc);
            }
            acc.finish()
        };
        for entry in CENTROIDERS {
            let swept = CentroiderSpec::of(entry);
            let c = match swept.build(&ctx) {
                Ok(c) => c,
                // A small sub-aperture may be refused (wcog needs a weight that follows the
                // spot), naming the option; at 8x8 px every centroider runs.
                Err(e) if n < 8 => {
                    assert!(e.to_string().contains("centroider"), "{}: {e}", entry.name);
                    continue;
                }
                Err(e) => panic!("{} {n}x{n}: {e}", entry.name),
            };
            assert_eq!(c.name(), entry.name);
            assert_eq!(
                c.param_name(),
                entry.param.map(|p| p.name),
                "{}",
                entry.name
            );
            let settings = c.settings();
            let totals = run(c.as_ref());
            assert_eq!(totals.len(), settings.len(), "{} {n}x{n}", entry.name);
            let Some(param) = entry.param else {
                assert!(settings.iter().all(|s| s.param.is_none()), "{}", entry.name);
                continue;
            };
            let grid = (param.grid)(&ctx);
            assert!(
                grid.iter().all(|&v| param.range.contains(v)),
                "{} {n}x{n}: {grid:?}",
                entry.name
            );
            let at = settings[settings.len() / 2]
                .param
                .expect("a swept parameter");
            let fixed = CentroiderSpec {
                entry,
                param: Some(at),
            };
            let fixed_totals = run(fixed.build(&ctx).unwrap().as_ref());
            let want: Vec<_> = settings
                .iter()
                .zip(&totals)
                .filter(|(s, _)| s.param == Some(at))
                .map(|(_, t)| *t)
                .collect();
            assert_eq!(fixed_totals, want, "{}:{at} {n}x{n}", entry.name);
        }
    }
}

#[test]
fn names_parse_with_and_without_parameters() {
    for e in CENTROIDERS {
        assert_eq!(
            CentroiderSpec::parse(e.name).unwrap(),
            CentroiderSpec::of(e)
        );
    }
    let m = CentroiderSpec::parse("masked-cog:3").unwrap();
    assert_eq!((m.entry.name, m.param), ("masked-cog", Some(3.0)));
    assert_eq!(m.label(), "masked-cog:3");
    assert_eq!(CentroiderSpec::default().label(), "cog");
    for (bad, why) in [
        (
            "cg",
            "'cg': unknown; known: cog, tcog, masked-cog, ivw-cog, wcog, brightest-n, \
             matched-filter, correlation",
        ),
        ("cog:2", "'cog:2': cog takes no parameter"),
        ("ivw-cog:1", "'ivw-cog:1': ivw-cog takes no parameter"),
        ("tcog:-1", "tcog:-1: K must be >= 0 (sigmas)"),
        (
            "masked-cog:0",
            "masked-cog:0: M must be > 0 (times the median sigma)",
        ),
        (
            "brightest-n:2.5",
            "brightest-n:2.5: N must be a whole number >= 1",
        ),
        ("wcog:0", "wcog:0: W must be > 0 (px)"),
        ("tcog:x", "'tcog:x': parameter must be a number"),
        ("tcog:inf", "'tcog:inf': parameter must be a number"),
    ] {
        let e = CentroiderSpec::parse(bad).unwrap_err().to_string();
        assert_eq!(e, format!("invalid `centroider`: {why}"));
    }
}

/// Random frames, noise maps and truths for the new centroiders' definition tests: the noise
/// map is redrawn every fourth frame (a worker must notice the change) and the mean image is
/// the given one.
fn random_frames(n: usize, count: usize, rng: &mut crate::rng::SimRng) -> Vec<Drawn> {
    let npix = n * n;
    let mut sigma: Vec<f64> = Vec::new();
    (0..count)
        .map(|k| {
            if k % 4 == 0 {
                sigma = (0..npix).map(|_| rng.random_range(0.3..4.0)).collect();
            }
            Drawn {
                image_e: (0..npix).map(|_| rng.random_range(-3.0..40.0)).collect(),
                sigma_e: sigma.clone(),
                truth_px: (rng.random_range(-0.5..0.5), rng.random_range(-0.5..0.5)),
            }
        })
        .collect()
}

/// The error (px) of the single-setting centroider `c` on one frame, from its sums.
fn one_error(c: &dyn Centroider, worker: &mut dyn CentroidWorker, f: &CentroidFrame) -> f64 {
    let mut acc = c.sums();
    worker.accumulate(f, &mut acc);
    let t = acc.finish();
    assert_eq!(t.len(), 1);
    t[0].0
}

/// Solve the 3 x 3 system `m` x = `b` by Gaussian elimination with partial pivoting.
#[allow(clippy::needless_range_loop)] // elimination's index arithmetic reads best as indices
fn solve3(mut m: [[f64; 3]; 3], mut b: [f64; 3]) -> [f64; 3] {
    for col in 0..3 {
        let p = (col..3)
            .max_by(|&i, &j| m[i][col].abs().total_cmp(&m[j][col].abs()))
            .unwrap();
        m.swap(col, p);
        b.swap(col, p);
        for r in col + 1..3 {
            let f = m[r][col] / m[col][col];
            for c in col..3 {
                m[r][c] -= f * m[col][c];
            }
            b[r] -= f * b[col];
        }
    }
    let mut x = [0.0; 3];
    for r in (0..3).rev() {
        let s: f64 = (r + 1..3).map(|c| m[r][c] * x[c]).sum();
        x[r] = (b[r] - s) / m[r][r];
    }
    x
}

/// The matched filter's estimate straight from its definition: the generalised least-squares
/// fit of I - I0 by [F gx, F gy, I0] with weights 1 / (factor mean + sigma^2), solved as normal
/// equations for this frame, its shift added to the mean image's centroid.
fn direct_matched_filter(f: &CentroidFrame, gx: &[f64], gy: &[f64]) -> (f64, f64) {
    let n = (f.image_e.len() as f64).sqrt() as usize;
    let flux: f64 = f.mean_e.iter().sum();
    let (mut m, mut b) = ([[0.0; 3]; 3], [0.0; 3]);
    for i in 0..n * n {
        let var = f.photon_variance_factor * f.mean_e[i] + f.sigma_e[i] * f.sigma_e[i];
        let w = 1.0 / var.max(matched_filter::VARIANCE_FLOOR_E2);
        let g = [flux * gx[i], flux * gy[i], f.mean_e[i]];
        for r in 0..3 {
            for c in 0..3 {
                m[r][c] += g[r] * w * g[c];
            }
            b[r] += g[r] * w * (f.image_e[i] - f.mean_e[i]);
        }
    }
    let theta = solve3(m, b);
    let origin = cog(f.mean_e, n).unwrap();
    (origin.0 + theta[0], origin.1 + theta[1])
}

/// The correlation centroider's estimate straight from its definition: every searched shift's
/// sum over every frame pixel whose template pixel lies inside, the first largest, a parabola
/// per axis.
fn direct_correlation(f: &CentroidFrame) -> (f64, f64) {
    let n = (f.image_e.len() as f64).sqrt() as isize;
    let c = |dx: isize, dy: isize| -> f64 {
        let mut s = 0.0;
        for y in 0..n {
            for x in 0..n {
                let (tx, ty) = (x - dx, y - dy);
                if (0..n).contains(&tx) && (0..n).contains(&ty) {
                    s += f.image_e[(y * n + x) as usize] * f.mean_e[(ty * n + tx) as usize];
                }
            }
        }
        s
    };
    let r = correlation::reach(n as usize) as isize;
    let mut best = (-r, -r);
    for dy in -r..=r {
        for dx in -r..=r {
            if c(dx, dy) > c(best.0, best.1) {
                best = (dx, dy);
            }
        }
    }
    let parabola = |a: f64, b: f64, cc: f64| {
        let curve = a - 2.0 * b + cc;
        if curve < 0.0 {
            (a - cc) / (2.0 * curve)
        } else {
            0.0
        }
    };
    let (dx, dy) = best;
    let fx = if dx.abs() == r {
        0.0
    } else {
        parabola(c(dx - 1, dy), c(dx, dy), c(dx + 1, dy))
    };
    let fy = if dy.abs() == r {
        0.0
    } else {
        parabola(c(dx, dy - 1), c(dx, dy), c(dx, dy + 1))
    };
    let origin = cog(f.mean_e, n as usize).unwrap();
    (origin.0 + dx as f64 + fx, origin.1 + dy as f64 + fy)
}

#[test]
fn matched_filter_and_correlation_match_their_definitions() {
    // Random frames, noise maps (changing every fourth frame) and mean images at sizes 2-8 px:
    // each frame's error from the worker (which keeps its filter between frames) against the
    // estimate solved directly for that frame: equal to 1e-12 px (different routes through
    // the same algebra, so rounding only).
    let mut rng = stream(18, 0, 0);
    for n in 2..9 {
        let mean: Vec<f64> = (0..n * n).map(|_| rng.random_range(0.0..5.0)).collect();
        let frames = random_frames(n, 24, &mut rng);
        for name in ["matched-filter", "correlation"] {
            let ctx_levels = [0.0];
            let ctx = CentroidContext {
                subap_px: n,
                levels_e: &ctx_levels,
                mean_e: &mean,
                spot: Spot::Airy { diameter_px: 2.0 },
                sampling: Sampling::Integrated,
                median_sigma_e: 1.0,
            };
            let c = CentroiderSpec::parse(name).unwrap().build(&ctx).unwrap();
            let filter = matched_filter::MatchedFilter::new(&ctx).unwrap();
            let (gx, gy) = filter.gradients();
            let mut worker = c.worker();
            for (k, d) in frames.iter().enumerate() {
                let f = CentroidFrame {
                    image_e: &d.image_e,
                    truth_px: d.truth_px,
                    sigma_e: &d.sigma_e,
                    mean_e: &mean,
                    photon_variance_factor: [1.0, 2.0][k / 12],
                };
                let (x, y) = match name {
                    "matched-filter" => direct_matched_filter(&f, gx, gy),
                    _ => direct_correlation(&f),
                };
                let want = (x - d.truth_px.0).hypot(y - d.truth_px.1);
                let got = one_error(c.as_ref(), worker.as_mut(), &f);
                assert!(
                    (got - want).abs() <= 1e-12 * want.max(1.0),
                    "{name} {n}x{n} frame {k}: {got} vs {want}"
                );
            }
        }
    }
}

#[test]
fn matched_filter_gradients_are_the_spots_derivative() {
    // A point-sampled Gaussian of sigma 2 px on 16 px (well sampled, 0.2 % of it outside):
    // the truth moves with the spot, so the unit-total image's derivative is the analytic
    // -d/dx0 of the normalised Gaussian, (x - x0) / s^2 times it; the central difference over
    // +-0.01 px and the truncation leave it within 1e-3 of the largest gradient.
    let (n, s) = (16, 2.0);
    let spot = Spot::Gauss {
        sigma_x_px: s,
        sigma_y_px: s,
    };
    let ctx = CentroidContext {
        subap_px: n,
        levels_e: &[0.0],
        mean_e: &[],
        spot,
        sampling: Sampling::Point,
        median_sigma_e: 1.0,
    };
    let filter = matched_filter::MatchedFilter::new(&ctx).unwrap();
    let (gx, gy) = filter.gradients();
    let c = (n as f64 - 1.0) / 2.0;
    let g: Vec<f64> = (0..n * n)
        .map(|p| {
            let (x, y) = ((p % n) as f64 - c, (p / n) as f64 - c);
            (-(x * x + y * y) / (2.0 * s * s)).exp()
        })
        .collect();
    let total: f64 = g.iter().sum();
    let largest = gx.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    for p in 0..n * n {
        let (x, y) = ((p % n) as f64 - c, (p / n) as f64 - c);
        let (wx, wy) = (x / (s * s) * g[p] / total, y / (s * s) * g[p] / total);
        assert!(
            (gx[p] - wx).abs() <= 1e-3 * largest && (gy[p] - wy).abs() <= 1e-3 * largest,
            "pixel {p}: ({}, {}) vs ({wx}, {wy})",
            gx[p],
            gy[p]
        );
    }
}

#[test]
fn matched_filter_and_correlation_find_noiseless_shifted_spots() {
    // Noiseless images of the spot at small offsets, scaled to 200 e-, the mean spot the same
    // centred: the matched filter finds the truth to 2 % of the offset (its response is linear
    // to second order), the correlation's parabola to 10 % (a 3-point parabola through the
    // Gaussian-like correlation peak of a spot of sigma 1.5 px reads about 0.89 of the shift:
    // the method's own pixel-locking bias, which it keeps as DASP does).
    let n = 10;
    for (spot, sampling) in [
        (Spot::Airy { diameter_px: 2.0 }, Sampling::Integrated),
        (
            Spot::Gauss {
                sigma_x_px: 1.5,
                sigma_y_px: 1.5,
            },
            Sampling::Point,
        ),
    ] {
        let renderer = SpotRenderer::new(spot, sampling, n, 0.1);
        let scaled = |x0: f64, y0: f64| {
            let mut img = vec![0.0; n * n];
            renderer.render(x0, y0, &mut img);
            let t: f64 = img.iter().sum();
            img.iter_mut().for_each(|v| *v *= 200.0 / t);
            img
        };
        let mean = scaled(0.0, 0.0);
        let sigma = vec![1.0; n * n];
        let levels = [0.0];
        let ctx = CentroidContext {
            subap_px: n,
            levels_e: &levels,
            mean_e: &mean,
            spot,
            sampling,
            median_sigma_e: 1.0,
        };
        for (dx, dy) in [(0.05, 0.0), (0.0, -0.03), (0.02, 0.04)] {
            let img = scaled(dx, dy);
            let truth = cog(&img, n).unwrap();
            for (name, tol) in [("matched-filter", 0.02), ("correlation", 0.1)] {
                if name == "correlation" && matches!(spot, Spot::Airy { .. }) {
                    continue;
                }
                let c = CentroiderSpec::parse(name).unwrap().build(&ctx).unwrap();
                let f = CentroidFrame {
                    image_e: &img,
                    truth_px: truth,
                    sigma_e: &sigma,
                    mean_e: &mean,
                    photon_variance_factor: 1.0,
                };
                let d = one_error(c.as_ref(), c.worker().as_mut(), &f);
                let offset = truth.0.hypot(truth.1);
                assert!(
                    d <= tol * offset,
                    "{name} {spot:?} at ({dx}, {dy}): error {d} px of {offset}"
                );
            }
        }
    }
}

#[test]
fn matched_filter_beats_cog_when_read_noise_dominates() {
    // 8x8 px, the paper's Airy spot, 50 photons, 3 e- read noise in every pixel, 3000 frames
    // on one seed: the matched filter's R (0.13 px at 10,000 frames) is far below the swept
    // cog's (0.23 px): more than 10 SE of either; correlation, which weights by the spot too,
    // is below cog as well.
    use crate::detector::{ModelParams, ModelSpec};
    use crate::montecarlo::{sweep_with, SimConfig};
    let cfg = crate::montecarlo::SimConfig {
        iters: 3000,
        ..SimConfig::paper(8)
    };
    let specs = ["cog", "matched-filter", "correlation"].map(|s| CentroiderSpec::parse(s).unwrap());
    let records = sweep_with(
        &[cfg],
        &[ModelSpec::ScmosConstant(Some(3.0))],
        &specs,
        &ModelParams::default(),
        &crate::progress::Silent,
    )
    .unwrap();
    let [cog, mf, corr] = &records[..] else {
        panic!("one record per centroider: {}", records.len())
    };
    let (cog, mf, corr) = (&cog.result, &mf.result, &corr.result);
    assert_eq!(
        (mf.centroider.as_str(), mf.param_name),
        ("matched-filter", None)
    );
    let se = cog.r_se_px.max(mf.r_se_px);
    assert!(
        mf.r_px + 10.0 * se < cog.r_px,
        "{} vs {}",
        mf.r_px,
        cog.r_px
    );
    assert!(
        corr.r_px + 5.0 * se < cog.r_px,
        "{} vs {}",
        corr.r_px,
        cog.r_px
    );
}
