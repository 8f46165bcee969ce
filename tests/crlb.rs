//! The Cramer-Rao floor against analytic truth: the continuous Gaussian bound, a direct sum of
//! the exact per-pixel information, and a Monte-Carlo of the maximum-likelihood centroid.

use detnoise::crlb::{
    poisson_gauss, r_crlb_of_readout, radial, Information, PixelNoise, Position, SpotImages,
};
use detnoise::detector::{PhotonNoise, ScmosConstant};
use detnoise::montecarlo::SimConfig;
use detnoise::rng::stream;
use detnoise::spot::Spot;
use detnoise::stats::poisson;
use rand_distr::{Distribution, StandardNormal};
use std::f64::consts::PI;

fn gauss_config(n: usize, sigma_px: f64, photons: f64, h: f64) -> SimConfig {
    let mut cfg = SimConfig::paper(n);
    cfg.spot = Spot::Gauss {
        sigma_x_px: sigma_px,
        sigma_y_px: sigma_px,
    };
    cfg.signal_photons = photons;
    cfg.position_half_range_px = h;
    cfg
}

#[test]
fn a_finely_sampled_gaussian_spot_with_photon_noise_reaches_sigma_squared_over_n() {
    // 4 px spot in 40 px: fine pixels, nothing cut; the per-axis bound sigma^2 / N, so
    // E|e| = sqrt(pi/2) sigma / sqrt(N). Pixels of 1 px add 1/12 px^2 (0.26 % here).
    let (s, n_photons) = (4.0, 1000.0);
    let cfg = gauss_config(40, s, n_photons, 0.0);
    let noise = PixelNoise::new(
        PhotonNoise::Poisson { thinning: 1.0 },
        Information::Exact,
        &[0.0],
    );
    let r = SpotImages::new(&cfg)
        .r_crlb_px(&noise, &[0.0; 1600])
        .unwrap();
    let want = (PI / 2.0).sqrt() * s / n_photons.sqrt();
    let pixelated = (PI / 2.0).sqrt() * (s * s + 1.0 / 12.0).sqrt() / n_photons.sqrt();
    assert!(
        r > want && (r / pixelated - 1.0).abs() < 1e-3,
        "{r} vs {want}, {pixelated}"
    );
}

#[test]
fn a_flat_noise_floor_is_the_direct_sum_of_the_exact_information() {
    let cfg = gauss_config(6, 1.0, 300.0, 0.5);
    let sigma = 1.5;
    let images = SpotImages::new(&cfg);
    let noise = PixelNoise::new(
        PhotonNoise::Poisson { thinning: 1.0 },
        Information::Exact,
        &[],
    );
    let r = images.r_crlb_px(&noise, &[sigma; 36]).unwrap();
    // Direct: the exact integral at every pixel, the 2x2 algebra written out.
    let mut direct = 0.0;
    for p in &images.positions {
        let (mut a, mut b, mut c) = (0.0, 0.0, 0.0);
        for i in 0..36 {
            let j = poisson_gauss::exact_info(p.mu_e[i], sigma);
            a += j * p.dmu_dx[i] * p.dmu_dx[i];
            b += j * p.dmu_dx[i] * p.dmu_dy[i];
            c += j * p.dmu_dy[i] * p.dmu_dy[i];
        }
        let det = a * c - b * b;
        let t = p.truth_jacobian;
        let inv = [[c / det, -b / det], [-b / det, a / det]];
        let mut cov = [[0.0; 2]; 2];
        for r in 0..2 {
            for s in 0..2 {
                for k in 0..2 {
                    for l in 0..2 {
                        cov[r][s] += t[r][k] * inv[k][l] * t[s][l];
                    }
                }
            }
        }
        direct += p.weight * radial::mean_radius(cov);
    }
    assert!((r / direct - 1.0).abs() < 2e-4, "{r} vs {direct}");
    // Through the readout: a constant camera gives one window, the same floor.
    let camera = ScmosConstant::new(sigma, "scmos-constant".into());
    let via = r_crlb_of_readout(&cfg, &camera, Information::Exact).unwrap();
    assert!((via / r - 1.0).abs() < 1e-12, "{via} vs {r}");
    // The common approximation 1 / (mu + sigma^2) never exceeds the exact information
    // (Cramer-Rao for the pixel itself), so its floor is higher.
    let approx = r_crlb_of_readout(&cfg, &camera, Information::Approximate).unwrap();
    eprintln!("6x6 gauss:1 S=300 sigma 1.5: exact {r:.5} px, approximate {approx:.5} px");
    assert!(approx >= r, "{approx} vs {r}");
}

/// ln p(y | lambda) derivative: (p(y - 1) - p(y)) / p(y) for Poisson(lambda) + N(0, sigma^2).
fn score_factor(y: f64, lambda: f64, sigma: f64) -> f64 {
    let kmax = (lambda + 10.0 * lambda.sqrt() + 10.0 + y.max(0.0)) as usize;
    let (mut p, mut q, mut pk) = (0.0, 0.0, (-lambda).exp());
    let mut prev = 0.0;
    for k in 0..=kmax {
        if k > 0 {
            pk *= lambda / k as f64;
        }
        let phi = (-0.5 * ((y - k as f64) / sigma).powi(2)).exp();
        p += pk * phi;
        q += (prev - pk) * phi;
        prev = pk;
    }
    if p > 0.0 {
        q / p
    } else {
        0.0
    }
}

#[test]
fn the_maximum_likelihood_centroid_reaches_the_floor() {
    // 6x6 px, Gaussian spot sigma 1 px, 300 photons, sCMOS 1.5 e-: ML by Fisher scoring on
    // the exact Poisson-Gaussian likelihood, 600 frames of fixed seeds.
    let (sigma, frames) = (1.5, 600u64);
    let cfg = gauss_config(6, 1.0, 300.0, 0.5);
    let noise = PixelNoise::new(
        PhotonNoise::Poisson { thinning: 1.0 },
        Information::Exact,
        &[],
    );
    let camera = ScmosConstant::new(sigma, "scmos-constant".into());
    let floor = r_crlb_of_readout(&cfg, &camera, Information::Exact).unwrap();
    let (mut errors, mut ex, mut ey) = (Vec::new(), Vec::new(), Vec::new());
    for f in 0..frames {
        let mut rng = stream(77, f, 0);
        let h = cfg.position_half_range_px;
        let u = |r: &mut detnoise::rng::SimRng| {
            use rand::RngExt;
            r.random_range(-h..h)
        };
        let theta = (u(&mut rng), u(&mut rng));
        let truth = Position::new(&cfg, theta);
        let image: Vec<f64> = truth
            .mu_e
            .iter()
            .map(|&mu| {
                let z: f64 = StandardNormal.sample(&mut rng);
                poisson(mu, &mut rng) as f64 + sigma * z
            })
            .collect();
        let mut est = (0.0, 0.0);
        for _ in 0..30 {
            let p = Position::new(&cfg, est);
            let (mut sx, mut sy) = (0.0, 0.0);
            for (i, &y) in image.iter().enumerate() {
                let s = score_factor(y, p.mu_e[i], sigma);
                sx += s * p.dmu_dx[i];
                sy += s * p.dmu_dy[i];
            }
            let fm = p.fisher(|_, mu| noise.info(mu, sigma));
            let det = fm[0][0] * fm[1][1] - fm[0][1] * fm[1][0];
            let dx = (fm[1][1] * sx - fm[0][1] * sy) / det;
            let dy = (fm[0][0] * sy - fm[1][0] * sx) / det;
            est = (
                (est.0 + dx.clamp(-0.5, 0.5)).clamp(-1.5, 1.5),
                (est.1 + dy.clamp(-0.5, 0.5)).clamp(-1.5, 1.5),
            );
            if dx.hypot(dy) < 1e-9 {
                break;
            }
        }
        let t_hat = Position::new(&cfg, est).truth_px;
        let (dx, dy) = (t_hat[0] - truth.truth_px[0], t_hat[1] - truth.truth_px[1]);
        errors.push(dx.hypot(dy));
        ex.push(dx);
        ey.push(dy);
    }
    let stats = |v: &[f64]| {
        let m = v.iter().sum::<f64>() / v.len() as f64;
        let var = v.iter().map(|x| (x - m).powi(2)).sum::<f64>() / (v.len() - 1) as f64;
        (m, (var / v.len() as f64).sqrt())
    };
    let (r_ml, se) = stats(&errors);
    eprintln!("ML: R = {r_ml:.5} +- {se:.5} px; floor R_crlb = {floor:.5} px");
    assert!((r_ml - floor).abs() < 3.0 * se, "{r_ml} +- {se} vs {floor}");
    for (axis, e) in [("x", &ex), ("y", &ey)] {
        let (m, se) = stats(e);
        assert!(m.abs() < 3.0 * se, "bias in {axis}: {m} +- {se}");
    }
}

#[test]
fn the_floor_map_gives_every_window_its_floor() {
    // 256 windows of 16x16 px, S = 50, airy:2, on a map of per-pixel sigmas spread as an
    // sCMOS's (0.5 to 3 e-): every window has a finite floor, windows with the same pixels
    // the same floor, and a uniform window the constant camera's floor. (Its speed on a
    // 2048x2048 detector is measured by `cargo bench --bench subaps`.)
    use detnoise::calib::{Map, Unit};
    let (side, n) = (256usize, 16usize);
    let mut rng = stream(5, 0, 0);
    let mut data: Vec<f64> = (0..side * side)
        .map(|_| {
            let z: f64 = StandardNormal.sample(&mut rng);
            (0.0f64 + 0.35 * z).exp().clamp(0.5, 3.0)
        })
        .collect();
    // The window at (16, 0) is a copy of the window at (0, 0).
    for r in 0..n {
        for c in 0..n {
            data[r * side + n + c] = data[r * side + c];
        }
    }
    let map = Map {
        rows: side,
        cols: side,
        data,
        unit: Unit::Electrons,
        source: String::new(),
    };
    let origins: Vec<(usize, usize)> = (0..side / n)
        .flat_map(|r| (0..side / n).map(move |c| (c * n, r * n)))
        .collect();
    let cfg = SimConfig::paper(n);
    let floors = detnoise::subaps::crlb::floor_map(&map, &origins, &cfg);
    assert_eq!(floors.len(), 256);
    let finite: Vec<f64> = floors.iter().map(|f| f.unwrap()).collect();
    assert!(finite.iter().all(|f| f.is_finite() && *f > 0.0));
    assert_eq!(finite[0], finite[1]);
    assert!(finite.iter().any(|f| *f != finite[0]));
    let flat = Map {
        rows: n,
        cols: n,
        data: vec![1.2; n * n],
        unit: Unit::Electrons,
        source: String::new(),
    };
    let one = detnoise::subaps::crlb::floor_map(&flat, &[(0, 0)], &cfg)[0].unwrap();
    let camera = ScmosConstant::new(1.2, "scmos-constant".into());
    let want = r_crlb_of_readout(&cfg, &camera, Information::Exact).unwrap();
    assert!((one / want - 1.0).abs() < 1e-12, "{one} vs {want}");
}

#[test]
fn simulate_reports_the_floor_beside_r() {
    let out = assert_cmd::Command::cargo_bin("detnoise")
        .unwrap()
        .args([
            "simulate",
            "--model",
            "scmos-constant:1,emccd-stochastic",
            "--subap",
            "6",
        ])
        .args(["--signal", "100", "--iters", "800", "--format", "json"])
        .output()
        .unwrap();
    assert!(out.status.success());
    let rows: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    for row in rows.as_array().unwrap() {
        let (r, floor) = (
            row["r_px"].as_f64().unwrap(),
            row["r_crlb_px"].as_f64().unwrap(),
        );
        let eff = row["crlb_efficiency"].as_f64().unwrap();
        assert!(floor > 0.0 && floor < r, "{row}");
        assert!(
            (eff - floor / r).abs() < 1e-12 && row["below_crlb"] == false,
            "{row}"
        );
    }
}

#[test]
fn the_exact_information_lowers_the_floor_most_behind_an_em_register() {
    // Each pixel's output is an unbiased estimate of its mean with variance F^2 mu + sigma^2,
    // so the exact information is never below the common approximation's: the exact floor is
    // lower. Dim EMCCD pixels with a clean zero count photons (information 1 / mu, not
    // 1 / (2 mu)): the gap is largest there.
    use detnoise::detector::{EmRegister, EmccdStochastic};
    let cfg = SimConfig::paper(8);
    let em = EmccdStochastic::new(EmRegister::new(500.0, 520).unwrap(), 50.0, false);
    let scmos = ScmosConstant::new(1.0, "scmos-constant".into());
    for (name, model) in [
        ("emccd-stochastic", &em as &dyn detnoise::detector::Readout),
        ("scmos-constant:1", &scmos),
    ] {
        let exact = r_crlb_of_readout(&cfg, model, Information::Exact).unwrap();
        let approx = r_crlb_of_readout(&cfg, model, Information::Approximate).unwrap();
        eprintln!("8x8 airy:2 S=50 {name}: exact {exact:.5} px, approximate {approx:.5} px");
        assert!(exact < approx, "{name}: {exact} vs {approx}");
    }
}

#[test]
fn subaps_writes_the_floor_map_in_px() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("map");
    let map = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/data-synthetic/scmos-darks-64x64.truth-rms_e.fits"
    );
    let status = assert_cmd::Command::cargo_bin("detnoise")
        .unwrap()
        .args([
            "subaps",
            "--map",
            map,
            "--subap-grid",
            "16",
            "--spot",
            "airy:2",
        ])
        .args(["--signal", "50", "--iters", "200", "--out"])
        .arg(&out)
        .output()
        .unwrap();
    assert!(
        status.status.success(),
        "{}",
        String::from_utf8_lossy(&status.stderr)
    );
    let fits = std::fs::read(out.join("r_crlb_px.fits")).unwrap();
    let header = String::from_utf8_lossy(&fits[..2880]);
    assert!(header.contains("BUNIT   = 'pixel"), "{header}");
    // 4 x 4 sub-apertures, big-endian f64 after the header: every floor finite and positive.
    // One header block: the image's keywords are fewer than 36 cards.
    assert!(header.contains("END     "));
    let data = &fits[2880..];
    let values: Vec<f64> = data[..16 * 8]
        .chunks_exact(8)
        .map(|b| f64::from_be_bytes(b.try_into().unwrap()))
        .collect();
    assert!(
        values
            .iter()
            .all(|v| v.is_finite() && *v > 0.01 && *v < 1.0),
        "{values:?}"
    );
}
