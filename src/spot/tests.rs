//! Tests of spot shapes and rendering.

use super::*;
use crate::centroid::cog;
use rand::RngExt;

#[test]
fn spot_lists_expand_airy_diameters_and_keep_the_order() {
    let items = [
        "airy:1, 2.5".to_string(),
        "gauss:1,3".into(),
        "airy:4".into(),
    ];
    let labels: Vec<String> = Spot::parse_list(&items)
        .unwrap()
        .iter()
        .map(Spot::label)
        .collect();
    assert_eq!(labels, ["airy:1", "airy:2.5", "gauss:1,3", "airy:4"]);
    // Errors quote the item as typed, then the part refused.
    let e = Spot::parse_list(&["airy:2,0.01".into()]).unwrap_err();
    assert!(
        e.to_string()
            .starts_with("invalid `spot`: 'airy:2,0.01': diameter '0.01': sizes must be"),
        "{e}"
    );
    let e = Spot::parse_list(&["airy:2, airy:3".into()]).unwrap_err();
    assert!(
        e.to_string()
            .starts_with("invalid `spot`: 'airy:2, airy:3': 'airy:3' is not a diameter"),
        "{e}"
    );
    assert!(!e.to_string().contains("airy:airy"), "{e}");
    let e = Spot::parse_list(&["airy:0".into()]).unwrap_err();
    assert!(
        e.to_string().starts_with("invalid `spot`: 'airy:0': sizes"),
        "{e}"
    );
    assert!(Spot::parse_list(&["disc:2".into()]).is_err());
}

fn normalised(spot: Spot, sampling: Sampling, n: usize, x0: f64, y0: f64) -> Vec<f64> {
    let r = SpotRenderer::new(spot, sampling, n, 0.6);
    let mut img = vec![0.0; n * n];
    r.render(x0, y0, &mut img);
    let s: f64 = img.iter().sum();
    img.iter().map(|v| v / s).collect()
}

#[test]
fn airy_first_zero_is_at_half_diameter() {
    let d = 2.0;
    let v = J1_FIRST_ZERO / (d / 2.0) * (d / 2.0);
    assert!(airy_intensity(v) < 1e-20);
    assert!(airy_intensity(0.99 * v) > 0.0 && airy_intensity(1.01 * v) > 0.0);
    let r = radial::RadialTable::new(d, 5.0);
    assert!(r.at(1.0) < 1e-8, "{}", r.at(1.0));
    assert!((r.at(0.0) - 1.0).abs() < 1e-12);
}

#[test]
fn matches_reference_values_of_the_research_notes() {
    // 8x8 px, D = 2, offset (0.25, -0.10) px: notes 1.3 table (max pixel, CoG).
    let airy = Spot::Airy { diameter_px: 2.0 };
    for (sampling, max, cx, cy) in [
        (Sampling::Point, 0.592, 0.476, -0.235),
        (Sampling::Integrated, 0.416, 0.275, -0.116),
    ] {
        let img = normalised(airy, sampling, 8, 0.25, -0.10);
        let m = img.iter().cloned().fold(0.0, f64::max);
        let (x, y) = cog(&img, 8).unwrap();
        assert!((m - max).abs() < 1.5e-3, "{sampling:?} max {m}");
        assert!(
            (x - cx).abs() < 1.5e-3 && (y - cy).abs() < 1.5e-3,
            "{sampling:?} cog {x} {y}"
        );
    }
}

#[test]
fn centred_symmetric_spots_have_centred_cog() {
    for spot in [
        Spot::Airy { diameter_px: 3.0 },
        Spot::Gauss {
            sigma_x_px: 1.0,
            sigma_y_px: 2.0,
        },
    ] {
        for sampling in [Sampling::Point, Sampling::Integrated] {
            for n in [4, 7, 16] {
                let (x, y) = cog(&normalised(spot, sampling, n, 0.0, 0.0), n).unwrap();
                assert!(
                    x.abs() < 1e-9 && y.abs() < 1e-9,
                    "{spot:?} {sampling:?} {n}: {x} {y}"
                );
            }
        }
    }
}

#[test]
fn integrated_gaussian_is_exact_and_point_differs_from_integrated_at_d2() {
    // A wide Gaussian fully inside the frame integrates to 1 over the whole plane.
    let r = SpotRenderer::new(
        Spot::Gauss {
            sigma_x_px: 1.0,
            sigma_y_px: 1.5,
        },
        Sampling::Integrated,
        16,
        0.5,
    );
    let mut img = vec![0.0; 256];
    r.render(0.3, -0.2, &mut img);
    assert!((img.iter().sum::<f64>() - 1.0).abs() < 1e-6);
    let p = normalised(
        Spot::Airy { diameter_px: 2.0 },
        Sampling::Point,
        8,
        0.0,
        0.0,
    );
    let q = normalised(
        Spot::Airy { diameter_px: 2.0 },
        Sampling::Integrated,
        8,
        0.0,
        0.0,
    );
    let diff: f64 = p.iter().zip(&q).map(|(a, b)| (a - b).abs()).sum();
    assert!(
        diff > 0.05,
        "point and integrated should differ at D = 2: {diff}"
    );
}

#[test]
fn integrated_airy_conserves_energy_inside_large_frame() {
    // Encircled energy of an Airy disc within radius 8 first-zero radii is ~0.99;
    // a 32x32 frame around a D = 2 spot holds at least that.
    let r = SpotRenderer::new(
        Spot::Airy { diameter_px: 2.0 },
        Sampling::Integrated,
        32,
        0.5,
    );
    let mut img = vec![0.0; 32 * 32];
    r.render(0.0, 0.0, &mut img);
    // Total intensity of (2J1(v)/v)^2 over the plane is 4 pi / k^2, k = 3.8317 / (D/2).
    let k = J1_FIRST_ZERO;
    let total = 4.0 * std::f64::consts::PI / (k * k);
    let got: f64 = img.iter().sum();
    assert!(
        got / total > 0.985 && got / total < 1.0 + 1e-4,
        "{}",
        got / total
    );
}

#[test]
fn parses_spots_and_rejects_malformed() {
    assert_eq!(
        Spot::parse("airy:2").unwrap(),
        Spot::Airy { diameter_px: 2.0 }
    );
    assert_eq!(
        Spot::parse("gauss:1,3.5").unwrap(),
        Spot::Gauss {
            sigma_x_px: 1.0,
            sigma_y_px: 3.5
        }
    );
    for bad in [
        "airy",
        "airy:-1",
        "airy:x",
        "gauss:1",
        "disc:2",
        "gauss:1,0",
        "airy:0.05",
        "airy:1e-9",
        "gauss:1,0.01",
    ] {
        assert_eq!(Spot::parse(bad).unwrap_err().exit_code(), 2, "{bad}");
    }
    assert!(Spot::parse("airy:0.1").is_ok());
}

#[test]
fn spots_made_in_code_meet_the_same_size_rule() {
    // A library caller can build a spot without parsing it: `validate` (and with it
    // `SimConfig::validate`) applies the parser's rule, naming `spot`.
    let small = [
        Spot::Airy { diameter_px: 0.05 },
        Spot::Gauss {
            sigma_x_px: 1.0,
            sigma_y_px: 0.0,
        },
        Spot::Airy {
            diameter_px: f64::NAN,
        },
    ];
    for spot in small {
        let msg = spot.validate().unwrap_err().to_string();
        assert!(msg.contains("`spot`") && msg.contains(">= 0.1 px"), "{msg}");
        let cfg = crate::montecarlo::SimConfig {
            spot,
            ..crate::montecarlo::SimConfig::paper(8)
        };
        assert!(cfg.validate().unwrap_err().to_string().contains("`spot`"));
    }
    assert!(Spot::Airy { diameter_px: 0.1 }.validate().is_ok());
    assert!(SIZE_RULE.contains(&format!(">= {MIN_SIZE_PX} px")));
}

/// Gauss-Legendre nodes and weights on [-1, 1], 8 points.
const GL8: [(f64, f64); 8] = [
    (-0.960_289_856_497_536_3, 0.101_228_536_290_376_3),
    (-0.796_666_477_413_626_7, 0.222_381_034_453_374_5),
    (-0.525_532_409_916_329, 0.313_706_645_877_887_3),
    (-0.183_434_642_495_649_8, 0.362_683_783_378_362),
    (0.183_434_642_495_649_8, 0.362_683_783_378_362),
    (0.525_532_409_916_329, 0.313_706_645_877_887_3),
    (0.796_666_477_413_626_7, 0.222_381_034_453_374_5),
    (0.960_289_856_497_536_3, 0.101_228_536_290_376_3),
];

/// The integral of the Airy intensity (peak 1, first dark ring of diameter `d` px) over the unit
/// pixel centred (x, y) px from the spot, independently of the renderer's tables: J1 at the
/// nodes of composite 8-point Gauss-Legendre rules on m x m sub-squares of side at most D/8
/// (m >= 2). Halving the sub-squares changes it by under 1e-15 of the peak for D = 0.5 to 4.
fn exact_pixel_integral(d: f64, x: f64, y: f64) -> f64 {
    let m = ((8.0 / d).ceil() as usize).max(2);
    let half = 0.5 / m as f64;
    let nodes: Vec<(f64, f64)> = (0..m)
        .flat_map(|c| {
            let mid = -0.5 + (2 * c + 1) as f64 * half;
            GL8.iter().map(move |&(t, w)| (mid + half * t, half * w))
        })
        .collect();
    let k = J1_FIRST_ZERO / (d / 2.0);
    let mut total = 0.0;
    for &(v, wv) in &nodes {
        let row: f64 = nodes
            .iter()
            .map(|&(u, wu)| wu * airy_intensity(k * (x + u).hypot(y + v)))
            .sum();
        total += wv * row;
    }
    total
}

#[test]
fn integrated_airy_matches_an_independent_pixel_integral() {
    // Tolerance 1e-5 of the brightest pixel integral T(0, 0). An error e (of the peak) in the
    // expected image moves R by about e relatively, and R's standard error is ~1e-3 relative at
    // the paper's 10,000 frames: 1e-5 is 1 % of it. The table meets it with margin: its nodes
    // are exact to 2e-7 of the peak (cubic radial look-ups, 2 x 2-point Gauss-Legendre cells of
    // 1/P px, f32), and bicubic interpolation at P phases per px with P D >= 64 errs by at most
    // h^4 (9/16)/24 (|d4T/dx4| + |d4T/dy4|), h = 1/P: measured at most 4e-6 of the peak
    // (D = 4, P = 16), and ~1e-6 for D = 0.1 to 2.
    let mut rng = crate::rng::stream(12, 0, 0);
    for (d, n, frames) in [
        (0.1, 4, 2),
        (0.25, 4, 4),
        (0.5, 4, 8),
        (1.0, 4, 16),
        (1.5, 6, 8),
        (2.0, 4, 24),
        (2.0, 16, 2),
        (4.0, 6, 16),
        (10.0, 4, 8),
    ] {
        let renderer =
            SpotRenderer::new(Spot::Airy { diameter_px: d }, Sampling::Integrated, n, 0.5);
        let peak = exact_pixel_integral(d, 0.0, 0.0);
        let c = (n as f64 - 1.0) / 2.0;
        let mut img = vec![0.0; n * n];
        let mut worst = 0.0f64;
        for _ in 0..frames {
            let (x0, y0) = (rng.random_range(-0.5..=0.5), rng.random_range(-0.5..=0.5));
            renderer.render(x0, y0, &mut img);
            for (p, v) in img.iter().enumerate() {
                let (x, y) = ((p % n) as f64 - c - x0, (p / n) as f64 - c - y0);
                worst = worst.max((v - exact_pixel_integral(d, x, y)).abs() / peak);
            }
        }
        assert!(
            worst < 1e-5,
            "D = {d} px, {n}x{n}: error {worst:e} of the peak"
        );
    }
}

#[test]
fn point_airy_is_the_intensity_at_pixel_centres() {
    // Linear interpolation on 400 steps per first-zero radius: at most 5.7e-6 of the peak.
    let mut rng = crate::rng::stream(13, 0, 0);
    for d in [0.5, 2.0, 7.0] {
        let n = 8;
        let renderer = SpotRenderer::new(Spot::Airy { diameter_px: d }, Sampling::Point, n, 0.5);
        let k = J1_FIRST_ZERO / (d / 2.0);
        let mut img = vec![0.0; n * n];
        for _ in 0..20 {
            let (x0, y0) = (rng.random_range(-0.5..=0.5), rng.random_range(-0.5..=0.5));
            renderer.render(x0, y0, &mut img);
            for (p, v) in img.iter().enumerate() {
                let (x, y) = ((p % n) as f64 - 3.5 - x0, (p / n) as f64 - 3.5 - y0);
                let exact = airy_intensity(k * x.hypot(y));
                assert!((v - exact).abs() < 5.8e-6, "D = {d}: {v} against {exact}");
            }
        }
    }
}

#[test]
fn airy_derivatives_stay_within_the_bounds_behind_the_interpolation_errors() {
    // Finite differences (step 0.01 in v) of (2 J1(v)/v)^2: |I''| <= 1/2 and |I''''| <= 5/8,
    // both reached at v = 0, bound the radial tables' linear and cubic errors.
    let h = 0.01;
    for i in 0..60_000 {
        let v = i as f64 * 1e-3;
        let f = |s: f64| airy_intensity((v + s * h).abs());
        let d2 = (f(1.0) - 2.0 * f(0.0) + f(-1.0)) / (h * h);
        let d4 = (f(2.0) - 4.0 * f(1.0) + 6.0 * f(0.0) - 4.0 * f(-1.0) + f(-2.0)) / h.powi(4);
        assert!(
            d2.abs() <= 0.5 + 1e-6 && d4.abs() <= 0.625 + 1e-4,
            "v = {v}: {d2} {d4}"
        );
    }
}

#[test]
fn gaussian_images_are_their_separable_formulas() {
    let (sx, sy) = (0.7, 1.9);
    let spot = Spot::Gauss {
        sigma_x_px: sx,
        sigma_y_px: sy,
    };
    let erf_box = |d: f64, s: f64| {
        let k = 1.0 / (s * std::f64::consts::SQRT_2);
        0.5 * (libm::erf((d + 0.5) * k) - libm::erf((d - 0.5) * k))
    };
    let gauss = |d: f64, s: f64| (-0.5 * (d / s).powi(2)).exp();
    for n in [1, 4, 9] {
        for (x0, y0) in [(0.0, 0.0), (0.31, -0.47), (-0.5, 0.5)] {
            let c = (n as f64 - 1.0) / 2.0;
            let mut img = vec![0.0; n * n];
            for (sampling, profile) in [
                (Sampling::Point, &gauss as &dyn Fn(f64, f64) -> f64),
                (Sampling::Integrated, &erf_box),
            ] {
                SpotRenderer::new(spot, sampling, n, 0.5).render(x0, y0, &mut img);
                for (p, v) in img.iter().enumerate() {
                    let (x, y) = ((p % n) as f64 - c - x0, (p / n) as f64 - c - y0);
                    let want = profile(x, sx) * profile(y, sy);
                    assert!(
                        (v - want).abs() < 1e-15,
                        "{sampling:?} {n}: {v} against {want}"
                    );
                }
            }
        }
    }
}

#[test]
fn pixels_beyond_the_tabulated_extent_are_dark() {
    // 4x4 px with no offset range: the table covers pixel centres up to 1.5 px (2 whole px);
    // a spot moved 1 px puts column 0 at 2.5 px.
    let r = SpotRenderer::new(
        Spot::Airy { diameter_px: 2.0 },
        Sampling::Integrated,
        4,
        0.0,
    );
    let mut img = vec![1.0; 16];
    r.render(1.0, 0.0, &mut img);
    assert!(img.chunks(4).all(|row| row[0] == 0.0 && row[1] > 0.0));
    r.render(1e12, f64::NAN, &mut img);
    assert!(img.iter().all(|v| *v == 0.0));
}

#[test]
fn pixel_tables_are_shared_and_depend_on_their_key_only() {
    let airy = Spot::Airy { diameter_px: 3.0 };
    // 4x4 px at 0.5 px and 5x5 px at 0 px both need 3 whole px.
    let a = SpotRenderer::new(airy, Sampling::Integrated, 4, 0.5);
    let b = SpotRenderer::new(airy, Sampling::Integrated, 5, 0.0);
    let (Kind::AiryIntegrated { table: ta }, Kind::AiryIntegrated { table: tb }) =
        (&a.kind, &b.kind)
    else {
        panic!("integrated Airy renderers hold a pixel table");
    };
    assert!(Arc::ptr_eq(ta, tb));
    assert_eq!(ta.phases(), 32);
    // The same values built afresh, on one thread or three.
    for threads in [1, 3] {
        assert_eq!(PixelTable::build(3.0, 3, threads).values(), ta.values());
    }
}

#[test]
fn phases_follow_the_spot_size_within_the_build_budget() {
    use pixel_table::{extent, phases};
    assert_eq!(extent(4, 0.5), 3);
    assert_eq!(extent(16, 0.5), 9);
    assert_eq!(extent(16, 4.0), 12);
    assert_eq!(extent(7, 0.0), 4);
    for (d, k, p) in [
        (10.0, 9, 16),
        (4.0, 9, 16),
        (2.0, 9, 32),
        (1.0, 9, 64),
        (0.5, 9, 128),
    ] {
        assert_eq!(phases(d, k), p, "D = {d}");
    }
    assert_eq!(phases(0.1, 3), 512);
    // Small spots over large extents: P shrinks to fit the budget, never below 16.
    assert_eq!(phases(0.1, 9), 256);
    assert_eq!(phases(1.0, 97), 32);
    for d in [0.1, 0.3, 1.0, 5.0] {
        for k in [2, 9, 33, 97] {
            let p = phases(d, k);
            assert!(p == 16 || pixel_table::build_bytes(p, k) <= pixel_table::BUILD_BUDGET_BYTES);
        }
    }
}

#[test]
fn the_cache_builds_each_key_once_and_keeps_its_budget() {
    use cache::{Cache, Footprint};
    use std::sync::atomic::{AtomicUsize, Ordering};
    struct Blob(usize);
    impl Footprint for Blob {
        fn bytes(&self) -> usize {
            self.0
        }
    }
    let cache: Cache<u32, Blob> = Cache::new(250);
    let builds = AtomicUsize::new(0);
    let build = |bytes| {
        builds.fetch_add(1, Ordering::SeqCst);
        std::thread::sleep(std::time::Duration::from_millis(20));
        Blob(bytes)
    };
    // Threads asking for one key at once share one build.
    std::thread::scope(|s| {
        for _ in 0..4 {
            s.spawn(|| cache.get(&1, || build(100)));
        }
    });
    assert_eq!(builds.load(Ordering::SeqCst), 1);
    let two = cache.get(&2, || build(100));
    assert_eq!(cache.get(&1, || build(100)).0, 100);
    assert_eq!(builds.load(Ordering::SeqCst), 2);
    // 300 bytes > 250: the least recently used table (2) goes; its holders keep it.
    cache.get(&3, || build(100));
    assert!(cache.holds(&1) && !cache.holds(&2) && cache.holds(&3));
    assert_eq!(cache.kept_bytes(), 200);
    assert_eq!(two.0, 100);
    // Asked again, it is built again.
    cache.get(&2, || build(100));
    assert_eq!(builds.load(Ordering::SeqCst), 4);
    assert_eq!(cache.kept_bytes(), 200);
}

#[test]
fn tables_over_the_largest_sub_apertures_stay_within_their_stated_error() {
    // At 128x128 px the build budget allows 32 phases per px: P D = 32 for D = 1 px, where the
    // stated error is 1.4e-5 of the peak (it falls as (P D)^-4). The central 8x8 pixels hold the
    // largest errors; the tolerance is 2e-5.
    let (d, n) = (1.0, 128);
    let renderer = SpotRenderer::new(Spot::Airy { diameter_px: d }, Sampling::Integrated, n, 0.5);
    let Kind::AiryIntegrated { table } = &renderer.kind else {
        panic!("integrated Airy renderers hold a pixel table");
    };
    assert_eq!(table.phases(), 32);
    let peak = exact_pixel_integral(d, 0.0, 0.0);
    let mut rng = crate::rng::stream(14, 0, 0);
    let mut img = vec![0.0; n * n];
    let mut worst = 0.0f64;
    for _ in 0..6 {
        let (x0, y0) = (rng.random_range(-0.5..=0.5), rng.random_range(-0.5..=0.5));
        renderer.render(x0, y0, &mut img);
        for i in 60..68 {
            for j in 60..68 {
                let (x, y) = (j as f64 - 63.5 - x0, i as f64 - 63.5 - y0);
                let err = (img[i * n + j] - exact_pixel_integral(d, x, y)).abs() / peak;
                worst = worst.max(err);
            }
        }
    }
    assert!(worst < 2e-5, "error {worst:e} of the peak");
}
