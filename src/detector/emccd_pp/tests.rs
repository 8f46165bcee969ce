use super::*;
use crate::detector::readout::sampling::pixel_samples;
use crate::rng::stream;
use crate::special::norm_cdf;
use crate::stats::poisson;

/// Gain 2^9 with 9 stages doubles every electron at every stage: k electrons give exactly
/// 512 k, so x / g = k + (sigma / g) z and the count distribution is known in closed form.
const G: f64 = 512.0;
const SIGMA: f64 = 50.0;

fn model_with(rule: PpRule, lambda_ref: Option<f64>, corrected: bool) -> EmccdPp {
    let config = PpConfig::new(rule, G, SIGMA).unwrap();
    let register = EmRegister::new(G, 9).unwrap();
    EmccdPp::new(register, SIGMA, config, lambda_ref, corrected).unwrap()
}

fn model(lambda_ref: Option<f64>, corrected: bool) -> EmccdPp {
    model_with(PpRule::PoissonPrior, lambda_ref, corrected)
}

/// P(K = j) for j = 0, 1, ... of a pixel of Poisson(`lambda`) photo-electrons binned by
/// `counter`, for the exact-doubling register: P(K > j) = P(x > t_j) = sum_k Pois(k; lambda)
/// Phi((k - t_j) g / sigma), and P(K = j) = P(K > j - 1) - P(K > j), with P(K > -1) = 1.
fn count_probabilities(counter: &PpCounter, lambda: f64) -> Vec<f64> {
    let pois: Vec<f64> = (0..60)
        .scan((-lambda).exp(), |p, k| {
            let now = *p;
            *p *= lambda / (k + 1) as f64;
            Some(now)
        })
        .collect();
    let above: Vec<f64> = counter
        .thresholds
        .t_over_g
        .iter()
        .map(|&t| {
            pois.iter()
                .enumerate()
                .map(|(k, p)| p * norm_cdf((k as f64 - t) * G / SIGMA))
                .sum()
        })
        .collect();
    (0..=above.len())
        .map(|j| {
            let hi = if j == 0 { 1.0 } else { above[j - 1] };
            hi - above.get(j).copied().unwrap_or(0.0)
        })
        .collect()
}

#[test]
fn counts_and_corrections_follow_the_exact_output() {
    // From the count distribution, the mean and variance of the count and of the corrected
    // level (a lookup by count). The sample means agree within 4 SE, SE = sd / sqrt(N) from
    // the analytic sd.
    let lambda = 1.0;
    let counter = PpConfig::new(PpRule::PoissonPrior, G, SIGMA)
        .unwrap()
        .counter(lambda)
        .unwrap();
    let p_count = count_probabilities(&counter, lambda);
    let moments = |value: &dyn Fn(usize) -> f64| {
        let m: f64 = p_count.iter().enumerate().map(|(j, p)| p * value(j)).sum();
        let m2: f64 = p_count.iter().enumerate().map(|(j, p)| p * value(j).powi(2)).sum();
        (m, m2 - m * m)
    };
    let n = 200_000;
    for corrected in [false, true] {
        let (mean, var) = if corrected {
            moments(&|j| counter.correction.lambda_for_count(j))
        } else {
            moments(&|j| j as f64)
        };
        let xs = pixel_samples(&model(Some(lambda), corrected), lambda, n);
        let m = xs.iter().sum::<f64>() / n as f64;
        assert!(
            (m - mean).abs() < 4.0 * (var / n as f64).sqrt(),
            "corrected {corrected}: mean {m} vs {mean}"
        );
        if !corrected {
            assert!(xs.iter().all(|x| x.fract() == 0.0 && *x >= 0.0));
        }
    }
}

#[test]
fn default_reference_is_the_sub_aperture_mean() {
    // Without a fixed reference the thresholds follow the frame's mean expected light, so
    // a frame whose mean is 1 photo-electron reads exactly as with a fixed reference of 1.
    for corrected in [false, true] {
        let fixed = pixel_samples(&model(Some(1.0), corrected), 1.0, 2000);
        let mean = pixel_samples(&model(None, corrected), 1.0, 2000);
        assert_eq!(fixed, mean);
    }
    assert_eq!(model(None, true).name(), "emccd-pp");
    assert_eq!(model(None, false).name(), "emccd-pp-uncorrected");
}

#[test]
fn the_pixel_prior_gives_each_pixel_rule_as_thresholds_at_its_own_level() {
    // Each pixel's thresholds are Rule A's at that pixel's mean level (a dark pixel's floored
    // as the sub-aperture mean's is); pixels of one level share one counter, and an image's
    // counters are built once.
    let config = PpConfig::new(PpRule::PixelPrior, 500.0, 50.0).unwrap();
    let rule_a = PpConfig::new(PpRule::PoissonPrior, 500.0, 50.0).unwrap();
    let prior = PixelPrior::new(config).unwrap();
    let mean_e = [0.0, 0.3, 3.0, 0.3, 12.5];
    let counters = prior.counters(&mean_e, config.lambda_max).unwrap();
    assert_eq!(counters.len(), mean_e.len());
    for (c, &l) in counters.iter().zip(&mean_e) {
        let want = rule_a.thresholds(l.max(PixelPrior::FLOOR_E)).unwrap();
        assert_eq!(c.thresholds, want, "level {l}");
        assert_eq!(c.lambda_ref, l.max(PixelPrior::FLOOR_E));
    }
    // Rule A's boundaries n (n + 1) / lambda: 2 / 3 g for the 1|2 boundary at 3 e-.
    assert_eq!(counters[2].thresholds.t_over_g[1], 2.0 / 3.0);
    assert!(std::sync::Arc::ptr_eq(&counters[1], &counters[3]));
    assert!(std::sync::Arc::ptr_eq(
        &counters,
        &prior.counters(&mean_e, config.lambda_max).unwrap()
    ));
    // A fixed reference level contradicts the per-pixel levels.
    let register = EmRegister::new(500.0, 520).unwrap();
    let e = EmccdPp::new(register, 50.0, config, Some(1.0), true).unwrap_err();
    assert!(e.to_string().contains("`pp_lambda`"), "{e}");
}

#[test]
fn with_the_pixel_prior_each_pixels_counts_follow_its_own_level() {
    // Two-pixel frames whose mean levels are 0.3 and 3 photo-electrons, each pixel's photons
    // Poisson of its level: the frequency of each count against P(K = j) for the thresholds
    // at that pixel's own level, within 4 SE sqrt(p (1 - p) / N) plus the distribution's
    // truncation (1e-12); the sub-aperture mean's thresholds (1.65) predict other counts.
    let mean_e = [0.3, 3.0];
    let model = model_with(PpRule::PixelPrior, None, false);
    let rule_a = PpConfig::new(PpRule::PoissonPrior, G, SIGMA).unwrap();
    let n = 100_000;
    let mut freq = [vec![0u32; 40], vec![0u32; 40]];
    let (mut rng, mut noise, mut aux) = (stream(4, 0, 0), stream(4, 0, 1), stream(4, 0, 2));
    let (mut z, mut out) = ([0.0; 2], [0.0; 2]);
    for _ in 0..n {
        let k = [poisson(mean_e[0], &mut rng), poisson(mean_e[1], &mut rng)];
        crate::detector::draw_normals(&mut noise, &mut z);
        let input = FrameInput {
            subap_px: 1,
            expected_e: &mean_e,
            mean_e: &mean_e,
            photo_e: &k,
            normals: &z,
        };
        model.read(&input, &mut aux, &mut out);
        for (f, &o) in freq.iter_mut().zip(&out) {
            f[o as usize] += 1;
        }
    }
    for (px, &l) in mean_e.iter().enumerate() {
        let p = count_probabilities(&rule_a.counter(l).unwrap(), l);
        for (j, &f) in freq[px].iter().enumerate() {
            let pj = p.get(j).copied().unwrap_or(0.0);
            let se = (pj * (1.0 - pj) / n as f64).sqrt();
            assert!(
                (f as f64 / n as f64 - pj).abs() < 4.0 * se + 1e-12,
                "pixel {px}, count {j}: {f} vs {pj}"
            );
        }
    }
    // The bright pixel under the mean's prior: P(K = 1) differs by far more than 4 SE.
    let shared = count_probabilities(&rule_a.counter(1.65).unwrap(), 3.0);
    let own = count_probabilities(&rule_a.counter(3.0).unwrap(), 3.0);
    assert!((shared[1] - own[1]).abs() > 0.02, "{} {}", shared[1], own[1]);
}

#[test]
fn bright_pixels_are_corrected_to_their_level_not_clipped() {
    // 16x16 frames with one pixel of 900 photo-electrons (a point-sampled 2 px Airy spot of
    // about 3000 photons) and the rest 1, read without read noise through the exact-doubling
    // register: the bright pixel's count lies far above the outputs the default span of 256
    // photo-electrons covers, so its corrected level was clipped at 256; spanning the frame's
    // brightest pixel it is 900 to within the bin's width (about 28 e- here) and the
    // correction's interpolation: 5 %. Both priors.
    let n = 16;
    let mut expected = vec![1.0; n * n];
    expected[0] = 900.0;
    let photo: Vec<u32> = expected.iter().map(|&v| v as u32).collect();
    let normals = vec![0.0; n * n];
    let input = FrameInput {
        subap_px: n,
        expected_e: &expected,
        mean_e: &expected,
        photo_e: &photo,
        normals: &normals,
    };
    for rule in [PpRule::PoissonPrior, PpRule::PixelPrior] {
        let config = PpConfig::new(rule, G, 0.0).unwrap();
        let model = EmccdPp::new(EmRegister::new(G, 9).unwrap(), 0.0, config, None, true).unwrap();
        let mut out = vec![0.0; n * n];
        model.read(&input, &mut stream(5, 0, 0), &mut out);
        assert!(
            (out[0] / 900.0 - 1.0).abs() < 0.05,
            "{rule:?}: bright pixel read as {}",
            out[0]
        );
    }
    // The span: powers of two at or above twice the peak, never below the configured one
    // nor above the bound.
    let c = PpConfig::new(PpRule::PoissonPrior, G, SIGMA).unwrap();
    assert_eq!(c.spanning(10.0).lambda_max, c.lambda_max);
    assert_eq!(c.spanning(900.0).lambda_max, 2048.0);
    assert_eq!(c.spanning(1e9).lambda_max, PpConfig::LAMBDA_MAX_BOUND);
}

#[test]
fn posterior_is_the_mean_count_given_the_bin_under_the_prior() {
    // E[n | K = k] straight from its definition, with Poisson weights e^-lambda lambda^n / n!
    // and the survival functions P(X > t | n) of the Gamma register, n up to 80: equal to the
    // counter's table (log-space weights) to 1e-9, at a faint and a bright prior.
    for lambda in [0.05, 3.0] {
        let counter = PpConfig::new(PpRule::PoissonPrior, 500.0, 50.0)
            .unwrap()
            .counter(lambda)
            .unwrap();
        let t = &counter.thresholds.t_over_g;
        let surv: Vec<Vec<f64>> = t
            .iter()
            .map(|&t| crate::detector::pp::survival_by_n(t * 500.0, 500.0, 50.0, 80))
            .collect();
        let mut w = (-lambda).exp();
        let weights: Vec<f64> = (0..=80)
            .map(|n| {
                if n > 0 {
                    w *= lambda / n as f64;
                }
                w
            })
            .collect();
        for k in 0..=t.len().min(6) {
            let (mut num, mut den) = (0.0, 0.0);
            for (n, &wn) in weights.iter().enumerate() {
                let hi = if k == 0 { 1.0 } else { surv[k - 1][n] };
                let lo = surv.get(k).map_or(0.0, |s| s[n]);
                num += n as f64 * wn * (hi - lo).max(0.0);
                den += wn * (hi - lo).max(0.0);
            }
            let want = num / den;
            assert!(
                (counter.posterior[k] - want).abs() <= 1e-9 * want.max(1.0),
                "lambda {lambda}, k {k}: {} vs {want}",
                counter.posterior[k]
            );
        }
    }
}

#[test]
fn with_the_pixel_prior_a_lone_photon_in_a_dark_pixel_reads_as_one() {
    // A dark pixel (mean level 1e-6) receiving one photo-electron, exact-doubling register
    // without read noise: its counter has the 0|1 boundary and none other within the span, so
    // the inverse transfer curve read the count 1 as the level whose mean count is 1 (tens of
    // photo-electrons and more); the posterior under the pixel's prior reads 1.
    let n = 2;
    let expected = vec![1e-6; n * n];
    let photo = [1, 0, 0, 0];
    let normals = vec![0.0; n * n];
    let input = FrameInput {
        subap_px: n,
        expected_e: &expected,
        mean_e: &expected,
        photo_e: &photo,
        normals: &normals,
    };
    let model = model_with(PpRule::PixelPrior, None, true);
    let mut out = vec![0.0; n * n];
    model.read(&input, &mut stream(6, 0, 0), &mut out);
    // Below 1 by the chance (under the prior) that the count is read noise; the unlit pixels
    // read their prior's posterior, about 4e-7.
    assert!((out[0] - 1.0).abs() < 0.05, "{out:?}");
    assert!(out[1..].iter().all(|&v| (0.0..1e-5).contains(&v)), "{out:?}");
    let counter = PpConfig::new(PpRule::PixelPrior, G, SIGMA)
        .unwrap()
        .counter(1e-6)
        .unwrap();
    assert!(counter.corrected(1.0) > 10.0, "{}", counter.corrected(1.0));
}

#[test]
fn its_cramer_rao_floor_is_the_em_register_s_not_a_photon_counter_s() {
    // Thresholding processes an EMCCD's output; its photon variance factor (1, a counter's)
    // would floor it below the camera it reads.
    assert_eq!(model(None, true).photon_noise(), PhotonNoise::EmRegister);
}
