//! Closure tests of the decomposition on moments synthesised from known per-pixel maps (no
//! files): the mean of each condition drawn around the model with the variance of a mean of
//! `FRAMES` frames, the sample variance around the model's with its chi2 spread.

use rand::SeedableRng;
use rand_distr::{Distribution, StandardNormal};

use super::*;
use crate::campaign::{Condition, ConditionStats, StackKind};
use crate::detector::register::excess_noise_factor_sq;
use crate::rng::SimRng;

const FRAMES: usize = 200;
const SIDE: usize = 64;
const STAGES: u32 = 520;

/// The true maps of a camera.
struct Truth {
    f: Vec<f64>,
    c: Vec<f64>,
    d: Vec<f64>,
}

/// A camera's operating setup for synthesis.
struct Camera {
    k: f64,
    read_adu: f64,
    /// (T_d, T_ref) of the dark current, deg C.
    doubling: Option<(f64, f64)>,
}

fn normal(rng: &mut SimRng) -> f64 {
    StandardNormal.sample(rng)
}

fn truth(npix: usize, d_typ: f64, c_typ: f64, seed: u64) -> Truth {
    let mut rng = SimRng::seed_from_u64(seed);
    let mut t = Truth {
        f: Vec::new(),
        c: Vec::new(),
        d: Vec::new(),
    };
    for _ in 0..npix {
        t.f.push(500.0 + 10.0 * normal(&mut rng));
        t.c.push(c_typ * (1.0 + 0.3 * normal(&mut rng)).abs());
        t.d.push(d_typ * (1.0 + 0.3 * normal(&mut rng)).abs());
    }
    t
}

/// (exposure s, commanded gain, true gain, temperature).
type Cond = (f64, Option<f64>, f64, Option<f64>);

fn synth(truth: &Truth, cam: &Camera, conds: &[Cond], seed: u64) -> Vec<ConditionStats> {
    let n = FRAMES as f64;
    conds
        .iter()
        .enumerate()
        .map(|(ci, &(t, commanded, g, temp))| {
            let mut rng = SimRng::seed_from_u64(seed * 1000 + ci as u64);
            let register = commanded.is_some();
            let f2 = if register {
                excess_noise_factor_sq(g, STAGES)
            } else {
                1.0
            };
            let factor = match (cam.doubling, temp) {
                (Some((td, tref)), Some(tc)) => ((tc - tref) / td).exp2(),
                _ => 1.0,
            };
            let mut mean = Vec::new();
            let mut var = Vec::new();
            for p in 0..truth.f.len() {
                let cic = if register { truth.c[p] } else { 0.0 };
                let e = cic + t * truth.d[p] * factor;
                let m = truth.f[p] + g / cam.k * e;
                let v = cam.read_adu.powi(2) + g * g * f2 * e / (cam.k * cam.k);
                mean.push(m + (v / n).sqrt() * normal(&mut rng));
                var.push(v * (1.0 + (2.0 / (n - 1.0)).sqrt() * normal(&mut rng)));
            }
            ConditionStats {
                file: format!("dark-{ci}.fits").into(),
                condition: Condition {
                    exposure_s: t,
                    em_gain: commanded,
                    temperature_c: temp,
                    kind: StackKind::Dark,
                    light_level: None,
                },
                frames: FRAMES,
                rows: SIDE,
                cols: truth.f.len() / SIDE,
                mean_adu: mean,
                var_adu2: var,
                temporal: Default::default(),
            }
        })
        .collect()
}

/// Mean and SD of (fit - truth) / SE over the pixels.
fn pulls(fit: &[f64], se: &[f64], truth: &[f64]) -> (f64, f64) {
    let z: Vec<f64> = (0..fit.len())
        .map(|i| (fit[i] - truth[i]) / se[i])
        .collect();
    crate::stats::mean_var(&z)
}

fn assert_pulls(what: &str, fit: &[f64], se: &[f64], truth: &[f64]) {
    let (m, v) = pulls(fit, se, truth);
    let sd = v.sqrt();
    println!(
        "{what}: pull mean {m:.4}, SD {sd:.4} over {} pixels",
        fit.len()
    );
    // Over 4096 pixels the mean's SE is 0.016, the SD's 0.011.
    assert!(m.abs() < 0.1, "{what}: pull mean {m}");
    assert!((sd - 1.0).abs() < 0.1, "{what}: pull SD {sd}");
}

const EM_K: f64 = 5.0;
const EM_GAINS: [f64; 3] = [100.0, 300.0, 1000.0];
const EM_TIMES: [f64; 3] = [0.1, 1.0, 5.0];

/// 3 gains x 3 exposures; true gains 4 % off the commanded ones.
fn emccd_conds() -> Vec<Cond> {
    let mut c = Vec::new();
    for g in EM_GAINS {
        for t in EM_TIMES {
            c.push((t, Some(g), 1.04 * g, None));
        }
    }
    c
}

fn emccd_fits() -> Vec<EmGainFit> {
    EM_GAINS
        .iter()
        .map(|&g| EmGainFit {
            commanded: g,
            gain: 1.04 * g,
            se: 0.01 * g,
        })
        .collect()
}

fn emccd() -> (Truth, Vec<ConditionStats>, DecomposeOptions) {
    let truth = truth(SIDE * SIDE, 0.5, 0.02, 1);
    let cam = Camera {
        k: EM_K,
        read_adu: 10.0,
        doubling: None,
    };
    let stats = synth(&truth, &cam, &emccd_conds(), 2);
    let mut opts = DecomposeOptions::new(EM_K);
    opts.em_gains = emccd_fits();
    opts.register_stages = STAGES;
    (truth, stats, opts)
}

const S_K: f64 = 0.5;

fn scmos_conds(temps: &[f64]) -> Vec<Cond> {
    let mut c = Vec::new();
    for &temp in temps {
        for t in [0.01, 0.1, 0.5, 1.0] {
            c.push((t, None, 1.0, temps.len().gt(&1).then_some(temp)));
        }
    }
    c
}

fn scmos(temps: &[f64], doubling: Option<(f64, f64)>) -> (Truth, Vec<ConditionStats>) {
    let truth = truth(SIDE * SIDE, 20.0, 0.0, 3);
    let cam = Camera {
        k: S_K,
        read_adu: 3.0,
        doubling,
    };
    let stats = synth(&truth, &cam, &scmos_conds(temps), 4);
    (truth, stats)
}

#[test]
fn emccd_maps_have_unit_pulls_with_fitted_gains() {
    let (truth, stats, opts) = emccd();
    let d = decompose(&stats, &opts).unwrap();
    assert_pulls("F", &d.offset_adu, &d.offset_se_adu, &truth.f);
    assert_pulls(
        "C",
        d.cic_e_per_frame.as_ref().unwrap(),
        d.cic_se_e_per_frame.as_ref().unwrap(),
        &truth.c,
    );
    assert_pulls(
        "D",
        &d.dark_current_e_per_s,
        &d.dark_current_se_e_per_s,
        &truth.d,
    );
    let s = &d.summary;
    assert_eq!(s.fit_quality.dof, 6);
    assert!(
        (s.fit_quality.median_reduced_chi2 - 0.9).abs() < 0.15,
        "{s:?}"
    );
    assert_eq!(s.pixels_fitted, SIDE * SIDE);
    // The gains' 1 % SEs put a ~1 % systematic error on C and D, none worth the name on F.
    let dc = s.dark_current_e_per_s;
    assert!(dc.systematic_se > 0.003 * dc.median && dc.systematic_se < 0.03 * dc.median);
    let curve = s.em_gain_curve.as_ref().unwrap();
    assert!((curve.b - 1.0).abs() < 1e-9 && (curve.a - 1.04f64.ln()).abs() < 1e-9);
    assert_eq!(curve.rows.len(), 3);
}

#[test]
fn emccd_dark_current_shot_noise_matches_the_mean() {
    let (_, stats, opts) = emccd();
    let s = decompose(&stats, &opts).unwrap().summary;
    let shot = s.shot_noise.unwrap();
    assert!((shot.ratio - 1.0).abs() < 3.0 * shot.ratio_se, "{shot:?}");
    assert_eq!(shot.status, "consistent");
    assert!(shot.ratio_se < 0.1, "{shot:?}");
    // A wrong register (F^2 of 2 stages, far below 2) shows as excess noise.
    let mut wrong = opts.clone();
    wrong.register_stages = 11;
    let bad = decompose(&stats, &wrong)
        .unwrap()
        .summary
        .shot_noise
        .unwrap();
    assert_eq!(bad.status, "excess", "{bad:?}");
}

#[test]
fn scmos_maps_have_unit_pulls_and_no_cic() {
    let (truth, stats) = scmos(&[-10.0], None);
    let d = decompose(&stats, &DecomposeOptions::new(S_K)).unwrap();
    assert_pulls("F", &d.offset_adu, &d.offset_se_adu, &truth.f);
    assert_pulls(
        "D",
        &d.dark_current_e_per_s,
        &d.dark_current_se_e_per_s,
        &truth.d,
    );
    assert!(d.cic_e_per_frame.is_none());
    assert!(d
        .summary
        .notes
        .iter()
        .any(|n| n.contains("CIC cannot be told")));
    let shot = d.summary.shot_noise.unwrap();
    assert!((shot.ratio - 1.0).abs() < 3.0 * shot.ratio_se, "{shot:?}");
    assert!(d.summary.em_gain_curve.is_none());
}

#[test]
fn the_doubling_temperature_is_recovered_within_three_se() {
    let (truth, stats) = scmos(&[-20.0, -10.0, 0.0], Some((6.0, -10.0)));
    let mut opts = DecomposeOptions::new(S_K);
    opts.temperature = TemperatureTerm::Fit { reference_c: None };
    let d = decompose(&stats, &opts).unwrap();
    let t = d.summary.temperature.clone().unwrap();
    assert_eq!(t.reference_c, -10.0);
    assert!(t.doubling_se_c > 0.0 && t.doubling_se_c < 0.5, "{t:?}");
    assert!((t.doubling_c - 6.0).abs() < 3.0 * t.doubling_se_c, "{t:?}");
    assert_pulls(
        "D(T_ref)",
        &d.dark_current_e_per_s,
        &d.dark_current_se_e_per_s,
        &truth.d,
    );
    // The term off on the same darks: D is an average, the fits are bad, and a note says why.
    let off = decompose(&stats, &DecomposeOptions::new(S_K)).unwrap();
    assert!(off.summary.fit_quality.median_reduced_chi2 > 10.0);
    assert!(off
        .summary
        .notes
        .iter()
        .any(|n| n.contains("temperature term is off")));
}

#[test]
fn commanded_gains_are_used_when_no_fitted_gains_are_given() {
    let (truth, _, _) = emccd();
    let cam = Camera {
        k: EM_K,
        read_adu: 10.0,
        doubling: None,
    };
    let exact: Vec<Cond> = emccd_conds()
        .into_iter()
        .map(|(t, g, _, temp)| (t, g, g.unwrap(), temp))
        .collect();
    let stats = synth(&truth, &cam, &exact, 8);
    let d = decompose(&stats, &DecomposeOptions::new(EM_K)).unwrap();
    assert_pulls(
        "D",
        &d.dark_current_e_per_s,
        &d.dark_current_se_e_per_s,
        &truth.d,
    );
    assert!(d
        .summary
        .notes
        .iter()
        .any(|n| n.contains("commanded values")));
    assert_eq!(d.summary.dark_current_e_per_s.systematic_se, 0.0);
    assert!(d.summary.em_gain_curve.is_none());
}

#[test]
fn a_given_doubling_temperature_scales_every_condition_to_the_reference() {
    let (truth, stats) = scmos(&[-20.0, -10.0, 0.0], Some((6.0, -10.0)));
    let mut opts = DecomposeOptions::new(S_K);
    opts.temperature = TemperatureTerm::Given {
        doubling_c: 6.0,
        reference_c: Some(-10.0),
    };
    let d = decompose(&stats, &opts).unwrap();
    let t = d.summary.temperature.clone().unwrap();
    assert!(!t.fitted && t.doubling_se_c == 0.0);
    assert_pulls(
        "D(-10 C)",
        &d.dark_current_e_per_s,
        &d.dark_current_se_e_per_s,
        &truth.d,
    );
    // At T_ref = 0 C the same darks give D larger by 2^(10/6).
    opts.temperature = TemperatureTerm::Given {
        doubling_c: 6.0,
        reference_c: Some(0.0),
    };
    let d0 = decompose(&stats, &opts).unwrap();
    let ratio = d0.summary.dark_current_e_per_s.median / d.summary.dark_current_e_per_s.median;
    assert!((ratio - (10.0f64 / 6.0).exp2()).abs() < 1e-3, "{ratio}");
}

#[test]
fn a_pixel_off_the_model_is_flagged_by_its_chi2_and_hot_pixels_are_classed() {
    let (mut truth, _, opts) = emccd();
    for p in [10, 20] {
        truth.d[p] *= 200.0;
    }
    let cam = Camera {
        k: EM_K,
        read_adu: 10.0,
        doubling: None,
    };
    let mut stats = synth(&truth, &cam, &emccd_conds(), 2);
    // Pixel 7 jumps by 30 SEs of its mean at one condition (e.g. an RTS step).
    let se = (stats[4].var_adu2[7] / FRAMES as f64).sqrt();
    stats[4].mean_adu[7] += 30.0 * se;
    let d = decompose(&stats, &opts).unwrap();
    assert!(d.bad_fit(7), "reduced chi2 {}", d.reduced_chi2[7]);
    let flagged = d.summary.fit_quality.pixels_flagged;
    // p < 1e-3: a handful of the 4096 good pixels at most.
    assert!((1..=15).contains(&flagged), "{flagged}");
    assert_eq!(d.hot_class[10], HotClass::Hot);
    assert_eq!(d.hot_class[20], HotClass::Hot);
    assert_eq!(d.summary.hot_pixels.hot, 2);
    // 0.3 relative spread: no pixel 5 robust sigmas above the median.
    assert_eq!(d.summary.hot_pixels.warm, 0);
    // A dead pixel (zero variance) is not fitted, not fatal.
    stats[0].var_adu2[3] = 0.0;
    let d = decompose(&stats, &opts).unwrap();
    assert!(d.offset_adu[3].is_nan());
    assert_eq!(d.hot_class[3], HotClass::NotFitted);
    assert_eq!(d.summary.pixels_not_fitted, 1);
}

fn refused(stats: &[ConditionStats], opts: &DecomposeOptions) -> String {
    decompose(stats, opts).unwrap_err().to_string()
}

#[test]
fn designs_that_cannot_be_solved_are_refused_naming_what_is_missing() {
    let truth = truth(SIDE * SIDE, 0.5, 0.02, 1);
    let cam = Camera {
        k: EM_K,
        read_adu: 10.0,
        doubling: None,
    };
    let opts = DecomposeOptions::new(EM_K);
    let one_time: Vec<Cond> = EM_GAINS.iter().map(|&g| (1.0, Some(g), g, None)).collect();
    let e = refused(&synth(&truth, &cam, &one_time, 5), &opts);
    assert!(
        e.contains("two or more exposure times") && e.contains("1 s"),
        "{e}"
    );
    let one_gain: Vec<Cond> = EM_TIMES
        .iter()
        .map(|&t| (t, Some(300.0), 300.0, None))
        .collect();
    let stats = synth(&truth, &cam, &one_gain, 5);
    let e = refused(&stats, &opts);
    assert!(
        e.contains("two or more EM gains") && e.contains("fit_cic"),
        "{e}"
    );
    // Without CIC the same darks fit (CIC then part of F).
    let mut no_cic = opts.clone();
    no_cic.fit_cic = false;
    let d = decompose(&stats, &no_cic).unwrap();
    assert!(d.cic_e_per_frame.is_none());
    // Two gains, two times, but G t the same at both: offset, CIC and D not separable.
    let tangled: Vec<Cond> = vec![
        (1.0, Some(100.0), 100.0, None),
        (0.5, Some(200.0), 200.0, None),
        (1.0, Some(100.0), 100.0, None),
    ];
    let e = refused(&synth(&truth, &cam, &tangled, 5), &opts);
    assert!(e.contains("do not separate"), "{e}");
    // Fitted gains for some commanded gains only.
    let mut partial = opts.clone();
    partial.em_gains = emccd_fits()[..2].to_vec();
    let e = refused(&synth(&truth, &cam, &emccd_conds(), 5), &partial);
    assert!(
        e.contains("no fitted EM gain for commanded gain 1000"),
        "{e}"
    );
    // No darks at all.
    let mut flats = synth(&truth, &cam, &emccd_conds(), 5);
    for s in &mut flats {
        s.condition.kind = StackKind::Flat;
    }
    assert!(refused(&flats, &opts).contains("no dark stacks"));
}

#[test]
fn inconsistent_stacks_and_temperature_terms_are_refused_naming_the_file() {
    let (_, mut stats) = scmos(&[-10.0], None);
    let opts = DecomposeOptions::new(S_K);
    let mut fit_t = opts.clone();
    fit_t.temperature = TemperatureTerm::Fit { reference_c: None };
    let e = refused(&stats, &fit_t);
    assert!(
        e.contains("dark-0.fits") && e.contains("no temperature"),
        "{e}"
    );
    for s in &mut stats {
        s.condition.temperature_c = Some(-10.0);
    }
    let e = refused(&stats, &fit_t);
    assert!(e.contains("two or more temperatures"), "{e}");
    stats[2].condition.em_gain = Some(100.0);
    let e = refused(&stats, &opts);
    assert!(
        e.contains("dark-2.fits") && e.contains("all EMCCD or all without"),
        "{e}"
    );
    stats[2].condition.em_gain = None;
    stats[3].rows = 32;
    let e = refused(&stats, &opts);
    assert!(e.contains("dark-3.fits") && e.contains("one shape"), "{e}");
    stats[3].rows = SIDE;
    let mut wrong_map = opts.clone();
    wrong_map.conversion_gain = ConversionGain::Map(vec![1.0; 10]);
    assert!(refused(&stats, &wrong_map).contains("gain map has 10 pixels"));
}

#[test]
fn a_per_pixel_conversion_gain_is_used_pixel_by_pixel() {
    let (truth, _) = scmos(&[-10.0], None);
    // Two halves at K = 0.5 and 1.0: synthesised apart, fitted together with the map.
    let half = SIDE * SIDE / 2;
    let mut stats = Vec::new();
    for (k, seed) in [(0.5, 6), (1.0, 7)] {
        let cam = Camera {
            k,
            read_adu: 3.0,
            doubling: None,
        };
        stats.push(synth(&truth, &cam, &scmos_conds(&[-10.0]), seed));
    }
    let mut merged = stats[0].clone();
    for (m, o) in merged.iter_mut().zip(&stats[1]) {
        m.mean_adu[half..].copy_from_slice(&o.mean_adu[half..]);
        m.var_adu2[half..].copy_from_slice(&o.var_adu2[half..]);
    }
    let mut opts = DecomposeOptions::new(1.0);
    let map: Vec<f64> = (0..SIDE * SIDE)
        .map(|p| if p < half { 0.5 } else { 1.0 })
        .collect();
    opts.conversion_gain = ConversionGain::Map(map);
    let d = decompose(&merged, &opts).unwrap();
    assert_pulls(
        "D",
        &d.dark_current_e_per_s,
        &d.dark_current_se_e_per_s,
        &truth.d,
    );
    assert!(d.summary.conversion_gain_e_per_adu.is_none());
}

#[test]
fn outputs_carry_their_exact_names_units_and_the_summary() {
    let (_, stats, opts) = emccd();
    let d = decompose(&stats, &opts).unwrap();
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("fit");
    let names = write_outputs(&d, &out, &[]).unwrap();
    assert_eq!(names.len(), OUTPUT_NAMES.len());
    for n in OUTPUT_NAMES {
        assert!(out.join(n).is_file(), "{n}");
    }
    let header = |n: &str| {
        let b = std::fs::read(out.join(n)).unwrap();
        String::from_utf8_lossy(&b[..2880]).into_owned()
    };
    assert!(header("dark_current_e_per_s.fits").contains("BUNIT   = 'electron/s'"));
    assert!(header("offset_se_adu.fits").contains("BUNIT   = 'adu "));
    assert!(header("cic_e_per_frame.fits").contains("BUNIT   = 'electron'"));
    assert!(header("hot_class.fits").contains("CLASS2  = 'hot "));
    assert!(header("fit_reduced_chi2.fits").contains("CHI2FLAG"));
    let json: serde_json::Value =
        serde_json::from_slice(&std::fs::read(out.join("decomposition.json")).unwrap()).unwrap();
    assert!(json["dark_current_e_per_s"]["median"].as_f64().unwrap() > 0.4);
    assert_eq!(json["outputs"].as_array().unwrap().len(), 10);
    let csv = std::fs::read_to_string(out.join("em_gain_curve.csv")).unwrap();
    assert!(
        csv.starts_with("commanded_gain,fitted_gain,fitted_gain_se,"),
        "{csv}"
    );
    assert_eq!(csv.lines().count(), 4);
    // No temporary file is left beside them.
    let left: Vec<_> = std::fs::read_dir(&out)
        .unwrap()
        .filter_map(|e| e.ok())
        .filter(|e| e.file_name().to_string_lossy().ends_with(".tmp"))
        .collect();
    assert!(left.is_empty());
    // Without a register: no CIC maps, no curve.
    let (_, stats) = scmos(&[-10.0], None);
    let d = decompose(&stats, &DecomposeOptions::new(S_K)).unwrap();
    let names = write_outputs(&d, &dir.path().join("s"), &[]).unwrap();
    assert_eq!(names.len(), 7);
    assert!(!names
        .iter()
        .any(|n| n.starts_with("cic") || n.ends_with(".csv")));
}

/// CPU seconds of this process (user + system): the wall time of a loaded machine says little.
fn cpu_s() -> f64 {
    let mut u: libc::rusage = unsafe { std::mem::zeroed() };
    // SAFETY: getrusage fills the struct it is given.
    unsafe { libc::getrusage(libc::RUSAGE_SELF, &mut u) };
    let tv = |t: libc::timeval| t.tv_sec as f64 + t.tv_usec as f64 * 1e-6;
    tv(u.ru_utime) + tv(u.ru_stime)
}

/// The speed figure of the issue: 2048 x 2048 pixels, 9 EMCCD conditions (`cargo test --lib
/// campaign::fit::tests::speed -- --ignored --nocapture`).
#[test]
#[ignore]
fn speed_2048_squared_9_conditions() {
    let side = 2048;
    let npix = side * side;
    let truth = truth(npix, 0.5, 0.02, 1);
    let cam = Camera {
        k: EM_K,
        read_adu: 10.0,
        doubling: None,
    };
    let mut stats = synth(&truth, &cam, &emccd_conds(), 2);
    for s in &mut stats {
        s.rows = side;
        s.cols = side;
    }
    let mut opts = DecomposeOptions::new(EM_K);
    opts.em_gains = emccd_fits();
    let (t0, c0) = (std::time::Instant::now(), cpu_s());
    let d = decompose(&stats, &opts).unwrap();
    let dt = t0.elapsed().as_secs_f64();
    println!(
        "decompose 2048x2048 x 9 conditions: {dt:.2} s wall, {:.2} s CPU, {} threads; {} pixels fitted",
        cpu_s() - c0,
        rayon::current_num_threads(),
        d.summary.pixels_fitted
    );
    // With a fitted doubling temperature (3 temperatures x 3 exposures, sCMOS).
    let truth = self::truth(npix, 20.0, 0.0, 3);
    let cam = Camera {
        k: S_K,
        read_adu: 3.0,
        doubling: Some((6.0, -10.0)),
    };
    let mut conds = Vec::new();
    for temp in [-20.0, -10.0, 0.0] {
        for t in [0.1, 0.5, 1.0] {
            conds.push((t, None, 1.0, Some(temp)));
        }
    }
    let mut stats = synth(&truth, &cam, &conds, 4);
    for s in &mut stats {
        s.rows = side;
        s.cols = side;
    }
    let mut opts = DecomposeOptions::new(S_K);
    opts.temperature = TemperatureTerm::Fit { reference_c: None };
    let (t0, c0) = (std::time::Instant::now(), cpu_s());
    let d = decompose(&stats, &opts).unwrap();
    println!(
        "decompose 2048x2048 x 9 conditions with T_d fitted: {:.2} s wall, {:.2} s CPU; T_d {:?}",
        t0.elapsed().as_secs_f64(),
        cpu_s() - c0,
        d.summary.temperature
    );
}
