use super::*;
use crate::detector::readout::sampling::pixel_samples;
use crate::detector::{ModelParams, ModelSpec};
use crate::rng::stream;
use crate::stats::mean_var;
use rand::RngExt;

#[test]
fn simple_model_variance_is_q_lambda_plus_read_noise() {
    // Poisson(q lambda) + Normal(0, 0.1): mean q lambda, variance q lambda + 0.01;
    // SE(mean) = sqrt(var / N), SE(var) ~ var sqrt(3 / N) (a Poisson's kurtosis is small
    // here), 4 SE. q = 1/2 and 1 end after one digit or none; 0.3 and 0.7 have endless binary
    // expansions (cut at the double's last digit). The last level lies above
    // BINOMIAL_ABOVE_E, where one Binomial(k, q) draw replaces the digit-by-digit thinning.
    let n = 200_000;
    for q in [0.5, 0.3, 0.7, 1.0] {
        let model = EmccdSimple::new(q, 0.1).unwrap();
        for lambda in [0.2, 3.0, 40.0, 4.0 * BINOMIAL_ABOVE_E as f64] {
            let xs = pixel_samples(&model, lambda, n);
            let (m, v) = mean_var(&xs);
            let var = q * lambda + 0.01;
            assert!(
                (m - q * lambda).abs() < 4.0 * (var / n as f64).sqrt(),
                "q {q}, lambda {lambda}: mean {m}"
            );
            assert!(
                (v - var).abs() < 4.0 * var * (3.0 / n as f64).sqrt(),
                "q {q}, lambda {lambda}: var {v}"
            );
        }
    }
}

#[test]
fn thinning_is_binomial_for_a_fixed_count() {
    // k = 9 electrons kept with q = 0.3 (an endless binary expansion): the frequency of each
    // count j against Binomial(9, 0.3), within 4 SE sqrt(p (1 - p) / N).
    let (k, q, n) = (9u32, 0.3, 100_000);
    let model = EmccdSimple::new(q, 0.0).unwrap();
    let mut aux = stream(3, 0, 0);
    let mut freq = [0u32; 10];
    for _ in 0..n {
        freq[model.thin(k, &mut aux) as usize] += 1;
    }
    let choose = |j: u32| (0..j).fold(1.0, |c, i| c * (k - i) as f64 / (i + 1) as f64);
    for (j, &f) in freq.iter().enumerate() {
        let p = choose(j as u32) * q.powi(j as i32) * (1.0 - q).powi((k - j as u32) as i32);
        let se = (p * (1.0 - p) / n as f64).sqrt();
        assert!((f as f64 / n as f64 - p).abs() < 4.0 * se + 1e-12, "{j}: {f}");
    }
}

#[test]
fn the_papers_factor_draws_exactly_what_the_halving_did() {
    // q = 1/2 keeps `binomial_half(k)` of the same stream (as emccd-simple did before it took
    // a factor), bit for bit, and its read noise is 50 / 500 = 0.1 e- exactly.
    let model = EmccdSimple::new(0.5, EmccdSimple::read_noise_of(500.0, 50.0).unwrap()).unwrap();
    assert_eq!(EmccdSimple::read_noise_of(500.0, 50.0).unwrap(), 0.1);
    let (mut a, mut b) = (stream(8, 1, 2), stream(8, 1, 2));
    for k in (0..300).chain([BINOMIAL_ABOVE_E, 70_000]) {
        let want = match k {
            0 => 0,
            k if k > BINOMIAL_ABOVE_E => Binomial::new(k as u64, 0.5).unwrap().sample(&mut b) as u32,
            k => binomial_half(k, &mut b),
        };
        assert_eq!(model.thin(k, &mut a), want, "k {k}");
    }
    let built = ModelSpec::parse("emccd-simple")
        .unwrap()
        .build(&ModelParams::default(), 4)
        .unwrap();
    assert_eq!(built.name(), "emccd-simple");
    assert_eq!(built.noise_scale_e(), 0.1);
}

#[test]
fn the_factor_and_the_read_noise_come_from_the_spec_and_the_params() {
    let params = ModelParams {
        em_gain: 300.0,
        emccd_read_noise_e: 60.0,
        ..ModelParams::default()
    };
    let spec = ModelSpec::parse("emccd-simple:0.42").unwrap();
    assert_eq!(spec, ModelSpec::EmccdSimple(Some(0.42)));
    let built = spec.build(&params, 4).unwrap();
    assert_eq!(built.name(), "emccd-simple:0.42");
    assert_eq!(built.noise_scale_e(), 0.2);
    assert!(spec.uses("em_gain") && spec.uses("emccd_read_noise_e"));
    for bad in ["emccd-simple:0", "emccd-simple:1.5", "emccd-simple:x", "emccd-simple:NaN"] {
        let e = ModelSpec::parse(bad).unwrap_err().to_string();
        assert!(e.contains("QE factor must be a number in (0, 1]"), "{bad}: {e}");
    }
    assert!(EmccdSimple::new(0.5, -1.0).is_err());
    assert!(EmccdSimple::read_noise_of(0.0, 50.0).is_err());
}

#[test]
fn the_popcnt_build_reads_what_the_portable_one_reads() {
    // Counts from 0 to past BINOMIAL_ABOVE_E, q with a short and an endless binary expansion:
    // `read` (the POPCNT build where the CPU has it) and the portable loop give the same
    // pixels bit for bit and leave the stream in the same state.
    let photo_e: Vec<u32> = (0..400u32)
        .map(|i| i * i * 7 % 1000)
        .chain([70_000])
        .collect();
    let normals: Vec<f64> = (0..photo_e.len()).map(|i| (i as f64 * 0.37).sin()).collect();
    let zeros = vec![0.0; photo_e.len()];
    let input = FrameInput {
        subap_px: 1,
        expected_e: &zeros,
        mean_e: &zeros,
        photo_e: &photo_e,
        normals: &normals,
    };
    for q in [0.5, 0.37, 1.0] {
        let model = EmccdSimple::new(q, 0.1).unwrap();
        let (mut a, mut b) = (stream(9, 2, 3), stream(9, 2, 3));
        let (mut x, mut y) = (vec![0.0; photo_e.len()], vec![0.0; photo_e.len()]);
        model.read(&input, &mut a, &mut x);
        model.read_inline(&input, &mut b, &mut y);
        let bits = |v: &[f64]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
        assert_eq!(bits(&x), bits(&y), "q {q}");
        assert_eq!(a.random::<u64>(), b.random::<u64>(), "q {q}: streams in step");
    }
}
