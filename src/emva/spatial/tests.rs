//! Synthetic spatial stacks with known row, column and pixel non-uniformity and temporal
//! noise (fixed seeds): each part recovered within 3 SE, the temporal correction, the
//! spectrograms, histograms and defect counts.

use rand_distr::{Distribution, StandardNormal};

use super::*;
use crate::rng::{stream, SimRng};

/// A fixed pattern: offset + row + column + pixel parts (standard deviations, DN), plus a
/// column cosine of `wave` (amplitude DN, period pixels).
#[derive(Clone, Copy, Default)]
struct Pattern {
    offset: f64,
    row: f64,
    col: f64,
    pixel: f64,
    wave: (f64, f64),
}

fn gauss(rng: &mut SimRng) -> f64 {
    StandardNormal.sample(rng)
}

fn pattern(shape: (usize, usize), p: Pattern, seed: u64) -> Vec<f64> {
    let (m, n) = shape;
    let mut rng = stream(seed, 0, 1);
    let rows: Vec<f64> = (0..m).map(|_| p.row * gauss(&mut rng)).collect();
    let cols: Vec<f64> = (0..n)
        .map(|c| {
            let w = p.wave.0 * (2.0 * std::f64::consts::PI * c as f64 / p.wave.1.max(1.0)).cos();
            p.col * gauss(&mut rng) + w
        })
        .collect();
    (0..m * n)
        .map(|i| p.offset + rows[i / n] + cols[i % n] + p.pixel * gauss(&mut rng))
        .collect()
}

/// `frames` frames of `mean` plus white temporal noise of `sd` (DN), rounded to integers
/// when `integer`.
fn stack(mean: &[f64], shape: (usize, usize), frames: usize, sd: f64, seed: u64) -> StackImage {
    let all: Vec<Vec<f64>> = (0..frames)
        .map(|k| {
            let mut rng = stream(seed, k as u64 + 1, 2);
            mean.iter()
                .map(|m| (m + sd * gauss(&mut rng)).round())
                .collect()
        })
        .collect();
    StackImage::from_frames(shape, all.iter().map(|f| f.as_slice())).unwrap()
}

fn within(q: &Quantity, truth: f64, what: &str) {
    assert!(
        matches!(q.status, QuantityStatus::Ok),
        "{what}: status {:?}",
        q.status
    );
    let z = (q.value - truth) / q.se;
    eprintln!(
        "{what}: {:.4} +- {:.4} (truth {truth:.4}, {z:+.2} SE)",
        q.value, q.se
    );
    assert!(
        z.abs() < 3.0,
        "{what}: {} +- {} vs truth {truth} ({z:.2} SE)",
        q.value,
        q.se
    );
}

fn gain() -> Quantity {
    Quantity::ok(0.5, 0.0)
}

/// Dark: rows 1.5, columns 2, pixels 3 DN; bright adds a photo response of 2000 DN with
/// rows 0.3 %, columns 0.5 %, pixels 1 %; temporal noise 4 DN dark, 30 DN bright.
fn camera(shape: (usize, usize), frames: usize, seed: u64) -> (StackImage, StackImage) {
    let dark = Pattern {
        offset: 100.0,
        row: 1.5,
        col: 2.0,
        pixel: 3.0,
        ..Pattern::default()
    };
    let gain_pattern = Pattern {
        offset: 1.0,
        row: 0.003,
        col: 0.005,
        pixel: 0.01,
        ..Pattern::default()
    };
    let d = pattern(shape, dark, seed);
    let g = pattern(shape, gain_pattern, seed + 1);
    let b: Vec<f64> = d.iter().zip(&g).map(|(d, g)| d + 2000.0 * g).collect();
    (
        stack(&b, shape, frames, 30.0, seed + 2),
        stack(&d, shape, frames, 4.0, seed + 3),
    )
}

#[test]
fn dsnu_and_prnu_parts_are_recovered_within_3_se() {
    let (b, d) = camera((128, 160), 16, 7);
    let r = spatial_from_images(&b, &d, &gain(), &SpatialOptions::default()).unwrap();
    let dsnu_total = (1.5f64.powi(2) + 4.0 + 9.0).sqrt();
    within(&r.dsnu_dn.total, dsnu_total, "DSNU total");
    within(&r.dsnu_dn.row, 1.5, "DSNU row");
    within(&r.dsnu_dn.col, 2.0, "DSNU col");
    within(&r.dsnu_dn.pixel, 3.0, "DSNU pixel");
    within(&r.dsnu_e.pixel, 6.0, "DSNU pixel (e-)");
    // The photo response: 2000 DN x the gain pattern, relative to the mean signal (2000 DN).
    let prnu_total = (0.3f64.powi(2) + 0.5f64.powi(2) + 1.0).sqrt();
    within(&r.prnu_percent.total, prnu_total, "PRNU total");
    within(&r.prnu_percent.row, 0.3, "PRNU row");
    within(&r.prnu_percent.col, 0.5, "PRNU col");
    within(&r.prnu_percent.pixel, 1.0, "PRNU pixel");
    // The SEs are neither wildly large nor tiny: the pixel part is known to about 1 %.
    let rel = r.dsnu_dn.pixel.se / r.dsnu_dn.pixel.value;
    assert!((0.003..0.03).contains(&rel), "pixel DSNU relative SE {rel}");
    assert_eq!(
        (r.frames_bright, r.frames_dark, r.rows, r.cols),
        (16, 16, 128, 160)
    );
}

#[test]
fn the_parts_ses_match_their_scatter_over_seeds() {
    // 40 cameras of one design: the spread of each estimate matches its stated SE (within
    // the 22 % a standard deviation from 40 draws allows at 2 sigma, and a bit).
    let runs: Vec<SpatialResult> = (0..40)
        .map(|s| {
            let (b, d) = camera((48, 64), 6, 100 + 10 * s);
            spatial_from_images(&b, &d, &gain(), &SpatialOptions::default()).unwrap()
        })
        .collect();
    for (what, get) in [
        (
            "dsnu row",
            (|r: &SpatialResult| r.dsnu_dn.row.clone()) as fn(&SpatialResult) -> Quantity,
        ),
        ("dsnu col", |r| r.dsnu_dn.col.clone()),
        ("dsnu pixel", |r| r.dsnu_dn.pixel.clone()),
        ("prnu col", |r| r.prnu_percent.col.clone()),
        ("prnu pixel", |r| r.prnu_percent.pixel.clone()),
    ] {
        let q: Vec<Quantity> = runs.iter().map(get).collect();
        let n = q.len() as f64;
        let mean = q.iter().map(|q| q.value).sum::<f64>() / n;
        let sd = (q.iter().map(|q| (q.value - mean).powi(2)).sum::<f64>() / (n - 1.0)).sqrt();
        let se = q.iter().map(|q| q.se).sum::<f64>() / n;
        assert!(
            (0.7..1.35).contains(&(sd / se)),
            "{what}: scatter {sd:.4} vs mean SE {se:.4}"
        );
    }
}

#[test]
fn the_temporal_correction_removes_the_bias_of_few_frames() {
    // Pixel DSNU 1 DN under 4 DN of temporal noise, averaged over 2 or 4 frames: the
    // averaged image's variance is 1 + 16 / L, the corrected one 1.
    let shape = (256, 256);
    let p = pattern(
        shape,
        Pattern {
            offset: 50.0,
            pixel: 1.0,
            ..Pattern::default()
        },
        11,
    );
    for frames in [2, 4] {
        let d = stack(&p, shape, frames, 4.0, 12);
        let r = spatial_from_images(&d, &d, &gain(), &SpatialOptions::default()).unwrap();
        let measured = r.dark.measured_dn2;
        // Rounding to integers adds 1/12 DN^2 of temporal noise, which the correction also
        // removes (it is in each pixel's temporal variance).
        assert!(
            (measured - (1.0 + (16.0 + 1.0 / 12.0) / frames as f64)).abs() < 0.2,
            "L = {frames}: measured {measured}"
        );
        within(&r.dsnu_dn.total, 1.0, "corrected DSNU");
        within(&r.dsnu_dn.pixel, 1.0, "corrected pixel DSNU");
    }
}

#[test]
fn white_noise_gives_a_flat_spectrogram_at_its_level() {
    let shape = (256, 128);
    let p = pattern(
        shape,
        Pattern {
            offset: 1000.0,
            pixel: 3.0,
            ..Pattern::default()
        },
        21,
    );
    let d = stack(&p, shape, 8, 2.0, 22);
    let r = spatial_from_images(&d, &d, &gain(), &SpatialOptions::default()).unwrap();
    // Pixel pattern plus the temporal noise left in the average of 8 frames.
    let level = (9.0 + (4.0 + 1.0 / 12.0) / 8.0f64).sqrt();
    for (s, lines) in [
        (&r.spectrogram_horizontal, 256.0f64),
        (&r.spectrogram_vertical, 128.0),
    ] {
        let power: Vec<f64> = s.dsnu_dn.iter().skip(1).map(|a| a * a).collect();
        let mean = power.iter().sum::<f64>() / power.len() as f64;
        assert!(
            (mean.sqrt() / level - 1.0).abs() < 0.02,
            "level {} vs {level}",
            mean.sqrt()
        );
        // Each bin averages `lines` periodograms: relative SD 1/sqrt(lines) (the Nyquist bin
        // twice that, being real); nothing beyond 5 of those.
        let tol = 5.0 * 2.0 / lines.sqrt();
        assert!(
            power.iter().all(|p| (p / mean - 1.0).abs() < tol),
            "not flat"
        );
        assert!((s.floor_dark_dn - ((4.0f64 + 1.0 / 12.0) / 8.0).sqrt()).abs() < 0.05);
        assert_eq!(s.frequency_cycles_per_px.len(), s.dsnu_dn.len());
        assert_eq!(*s.frequency_cycles_per_px.last().unwrap(), 0.5);
    }
}

#[test]
fn a_periodic_column_pattern_peaks_at_its_frequency() {
    let shape = (64, 128);
    let p = pattern(
        shape,
        Pattern {
            offset: 200.0,
            pixel: 1.0,
            wave: (2.0, 8.0),
            ..Pattern::default()
        },
        31,
    );
    let d = stack(&p, shape, 4, 1.0, 32);
    let r = spatial_from_images(&d, &d, &gain(), &SpatialOptions::default()).unwrap();
    let h = &r.spectrogram_horizontal;
    let peak = (1..h.dsnu_dn.len())
        .max_by(|&a, &b| h.dsnu_dn[a].total_cmp(&h.dsnu_dn[b]))
        .unwrap();
    assert_eq!(h.frequency_cycles_per_px[peak], 1.0 / 8.0);
    // A cosine of amplitude A puts A^2 N / 4 in its bin: sqrt = A sqrt(N) / 2.
    assert!((h.dsnu_dn[peak] / (2.0 * 128f64.sqrt() / 2.0) - 1.0).abs() < 0.1);
    // Down the columns the pattern is constant: no peak in the vertical spectrogram.
    let v = &r.spectrogram_vertical;
    let vmax = v.dsnu_dn.iter().skip(1).cloned().fold(0.0, f64::max);
    assert!(vmax < 3.0 * v.dsnu_dn[1..].iter().sum::<f64>() / (v.dsnu_dn.len() - 1) as f64);
}

#[test]
fn histograms_count_every_pixel_and_profiles_span_the_image() {
    let shape = (40, 70);
    let (b, d) = camera(shape, 5, 41);
    let r = spatial_from_images(&b, &d, &gain(), &SpatialOptions::default()).unwrap();
    let total = |c: &[u64]| c.iter().sum::<u64>();
    assert_eq!(total(&r.histogram_dsnu.counts), 40 * 70);
    assert_eq!(total(&r.histogram_prnu.counts), 36 * 66);
    for h in [&r.histogram_dsnu, &r.histogram_prnu] {
        assert!(h.counts.len() <= 256 && h.counts.len() == h.bins_dn.len());
        assert_eq!(h.model_counts.len(), h.counts.len());
        // Bins step by a whole number of DN summed over the frames.
        let w = h.bins_dn[1] - h.bins_dn[0];
        assert!(w > 0.0);
    }
    for a in [&r.histogram_dsnu_accumulated, &r.histogram_prnu_accumulated] {
        assert_eq!(a.pixels_percent[0], 100.0);
        assert!(a.pixels_percent.windows(2).all(|w| w[0] >= w[1]));
        assert!(*a.pixels_percent.last().unwrap() > 0.0);
    }
    // The DSNU histogram is centred on the dark mean: bins are deviations.
    let lo = r.histogram_dsnu.bins_dn[0];
    assert!(lo < 0.0 && lo > -20.0, "lowest dark deviation {lo}");
    assert_eq!(r.profile_horizontal_dark.mean_dn.len(), 70);
    assert_eq!(r.profile_vertical_bright.middle_dn.len(), 40);
    let p = &r.profile_horizontal_bright;
    assert!((0..70).all(|i| p.min_dn[i] <= p.mean_dn[i] && p.mean_dn[i] <= p.max_dn[i]));
    let mean_signal = p.mean_dn.iter().sum::<f64>() / 70.0;
    assert!((mean_signal - 2000.0).abs() < 5.0, "{mean_signal}");
}

#[test]
fn injected_defects_are_counted() {
    let shape = (100, 120);
    let dark_pattern = Pattern {
        offset: 100.0,
        col: 1.0,
        pixel: 2.0,
        ..Pattern::default()
    };
    let mut d = pattern(shape, dark_pattern, 51);
    let mut b: Vec<f64> = d.iter().map(|d| d + 1500.0).collect();
    for &(i, hot) in &[
        (5, true),
        (777, true),
        (4000, true),
        (9999, false),
        (11_000, true),
    ] {
        d[i] += if hot { 300.0 } else { -80.0 };
        b[i] = if hot { b[i] + 300.0 } else { b[i] - 80.0 };
    }
    // Four dim pixels (half the response), away from the edges the highpass filter drops.
    for &i in &[3 * 120 + 50, 40 * 120 + 60, 70 * 120 + 7, 95 * 120 + 100] {
        b[i] = d[i] + 750.0;
    }
    let r = spatial_from_images(
        &stack(&b, shape, 8, 20.0, 52),
        &stack(&d, shape, 8, 3.0, 53),
        &gain(),
        &SpatialOptions::default(),
    )
    .unwrap();
    assert_eq!((r.defects_dark.above, r.defects_dark.below), (4, 1));
    assert_eq!((r.defects_bright.above, r.defects_bright.below), (0, 4));
    assert!(
        (r.defects_dark.robust_std - 2.48).abs() < 0.2,
        "{:?}",
        r.defects_dark
    );
}

#[test]
fn a_part_below_resolution_is_unavailable_with_its_bound() {
    let q = std_from_variance("row", -0.01, 1e-4, "DN", true);
    match q.status {
        QuantityStatus::Unavailable(why) => assert!(why.contains("row part"), "{why}"),
        s => panic!("{s:?}"),
    }
    assert!(q.value.is_nan());
    assert!(matches!(
        std_from_variance("row", 0.01, 1e-4, "DN", true).status,
        QuantityStatus::Imprecise
    ));
    assert!(matches!(
        std_from_variance("row", 0.1, 1e-4, "DN", true).status,
        QuantityStatus::Ok
    ));
    // Two rows: no split, the total stays.
    let p = pattern(
        (2, 50),
        Pattern {
            offset: 9.0,
            pixel: 2.0,
            ..Pattern::default()
        },
        61,
    );
    let d = stack(&p, (2, 50), 4, 1.0, 62);
    let r = spatial_from_images(&d, &d, &gain(), &SpatialOptions::default()).unwrap();
    assert!(matches!(r.dsnu_dn.total.status, QuantityStatus::Ok));
    assert!(matches!(
        r.dsnu_dn.row.status,
        QuantityStatus::Unavailable(_)
    ));
    assert!(matches!(
        r.dark.parts_dn2.pixel.status,
        QuantityStatus::Unavailable(_)
    ));
}

#[test]
fn the_gain_and_the_saturation_rule_pass_to_the_statuses() {
    let (b, d) = camera((32, 32), 4, 71);
    // Signal 2000 DN above 100 DN of dark: saturation at 2500 DN puts it at 83 %.
    let options = SpatialOptions {
        saturation_dn: Some(2500.0),
        ..SpatialOptions::default()
    };
    let r = spatial_from_images(&b, &d, &Quantity::ok(2.0, 0.2), &options).unwrap();
    assert!(matches!(
        r.saturation_fraction.status,
        QuantityStatus::OutOfRules(_)
    ));
    assert!((r.saturation_fraction.value - 2000.0 / 2400.0).abs() < 0.01);
    assert!(matches!(
        r.prnu_percent.total.status,
        QuantityStatus::OutOfRules(_)
    ));
    assert!(matches!(r.dsnu_dn.total.status, QuantityStatus::Ok));
    // DSNU in e-: DN / K, the gain's 10 % in the SE.
    let (dn, e) = (&r.dsnu_dn.total, &r.dsnu_e.total);
    assert!((e.value - dn.value / 2.0).abs() < 1e-12);
    assert!(e.se / e.value > 0.1);
    let at_half = SpatialOptions {
        saturation_dn: Some(4100.0),
        ..SpatialOptions::default()
    };
    let r = spatial_from_images(&b, &d, &Quantity::unavailable("no pairs"), &at_half).unwrap();
    assert!(matches!(r.prnu_percent.total.status, QuantityStatus::Ok));
    assert!(matches!(
        r.dsnu_e.total.status,
        QuantityStatus::Unavailable(_)
    ));
    let json = serde_json::to_value(&r).unwrap();
    assert!(json["dsnu_dn"]["pixel"]["value"].is_number());
    assert!(json["spectrogram_horizontal"]["frequency_cycles_per_px"].is_array());
}

#[test]
fn files_read_once_give_the_in_memory_sums() {
    let dir = tempfile::tempdir().unwrap();
    let shape = (12, 17);
    let p = pattern(
        shape,
        Pattern {
            offset: 300.0,
            pixel: 5.0,
            ..Pattern::default()
        },
        81,
    );
    let mut rng = stream(82, 0, 0);
    let frames: Vec<Vec<f64>> = (0..5)
        .map(|_| {
            p.iter()
                .map(|m| (m + 3.0 * gauss(&mut rng)).round())
                .collect()
        })
        .collect();
    let path = dir.path().join("stack.fits");
    let mut k = 0;
    crate::io::fits::write_cube(
        &path,
        shape,
        5,
        true,
        &mut || {
            k += 1;
            frames[k - 1].clone()
        },
        &[],
    )
    .unwrap();
    let read = read_stack_image(&[path]).unwrap();
    let memory = StackImage::from_frames(shape, frames.iter().map(|f| f.as_slice())).unwrap();
    assert_eq!(read.frames, 5);
    assert_eq!(read.sum_dn, memory.sum_dn);
    for (a, b) in read.temporal_var_dn2.iter().zip(&memory.temporal_var_dn2) {
        assert!((a - b).abs() < 1e-9);
    }
    let one = dir.path().join("one.fits");
    crate::io::fits::write_cube(&one, shape, 1, true, &mut || p.clone(), &[]).unwrap();
    let err = read_stack_image(&[one]).unwrap_err().to_string();
    assert!(
        err.contains("one.fits") && err.contains("at least 2"),
        "{err}"
    );
}

/// SplitMix64's finaliser (as `crate::rng`), for integer frames Python reproduces exactly.
fn mix64(mut z: u64) -> u64 {
    z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
    z ^ (z >> 31)
}

fn hashed(tag: u64, i: u64, range: u64) -> f64 {
    (mix64((tag << 40) | i) % range) as f64
}

/// The reference implementation (`emva1288` 1.x, `Data1288._get_spatial` and `Results1288`)
/// on integer frames both sides generate from `mix64`: 64 x 96, 8 frames each; dark = 100 +
/// row (0..8) + column (0..12) + pixel (0..20) + temporal (0..16); bright adds 1500 + 3 x
/// row (0..6) + 4 x column (0..4) + 2 x pixel (0..30) and temporal (0..60). The Python side,
/// with `u(tag, i, r) = mix64((tag << 40) | i) % r` and the same keys as `hashed` below:
///
/// ```text
/// sp = lambda fr: {'sum': S, 'pvar': L * (L * sum(f*f) - S*S), 'L': L}   # S = sum(fr)
/// d = Data1288.__new__(Data1288); d.rows, d.cols = 64, 96
/// spatial = d._get_spatial({0.01: {0.0: sp(dark_frames), 1000.0: sp(bright_frames)}})
/// r = Results1288({'temporal': {}, 'spatial': spatial})
/// ```
#[test]
fn agrees_with_the_reference_implementation_on_integer_frames() {
    let (m, n, l) = (64u64, 96u64, 8u64);
    let shape = (m as usize, n as usize);
    let pixel = |tag: u64, r: u64| -> Vec<f64> {
        (0..m * n)
            .map(|i| hashed(tag, (i / n) * 1000 + i % n, r))
            .collect()
    };
    let dark: Vec<f64> = pixel(3, 21)
        .iter()
        .enumerate()
        .map(|(i, p)| {
            let (r, c) = (i as u64 / n, i as u64 % n);
            100.0 + hashed(1, r, 9) + hashed(2, c, 13) + p
        })
        .collect();
    let signal: Vec<f64> = pixel(8, 31)
        .iter()
        .enumerate()
        .map(|(i, p)| {
            let (r, c) = (i as u64 / n, i as u64 % n);
            1500.0 + 3.0 * hashed(6, r, 7) + 4.0 * hashed(7, c, 5) + 2.0 * p
        })
        .collect();
    let frames = |base: &[f64], tag: u64, range: u64| -> Vec<Vec<f64>> {
        (0..l)
            .map(|k| {
                base.iter()
                    .enumerate()
                    .map(|(i, b)| {
                        let (r, c) = (i as u64 / n, i as u64 % n);
                        b + hashed(tag, (k * 1000 + r) * 1000 + c, range)
                    })
                    .collect()
            })
            .collect()
    };
    let bright_base: Vec<f64> = dark.iter().zip(&signal).map(|(d, s)| d + s).collect();
    let fd = frames(&dark, 4, 17);
    let fb = frames(&bright_base, 9, 61);
    let d = StackImage::from_frames(shape, fd.iter().map(|f| f.as_slice())).unwrap();
    let b = StackImage::from_frames(shape, fb.iter().map(|f| f.as_slice())).unwrap();
    let r = spatial_from_images(&b, &d, &gain(), &SpatialOptions::default()).unwrap();
    let close = |ours: f64, reference: f64, what: &str| {
        assert!(
            (ours - reference).abs() <= 1e-9 * reference.abs().max(1.0),
            "{what}: {ours} vs reference {reference}"
        );
    };
    close(
        r.bright.temporal_var_dn2.value,
        308.4219970703125,
        "sigma_2_y_stack",
    );
    close(
        r.dark.temporal_var_dn2.value,
        24.13048444475446,
        "sigma_2_y_stack_dark",
    );
    close(r.bright.measured_dn2, 485.0689375132873, "s_2_y_measured");
    close(
        r.dark.measured_dn2,
        59.477312792517665,
        "s_2_y_measured_dark",
    );
    close(r.bright.cav_dn2, 53.75180208517445, "s_2_y_cav");
    close(r.dark.cav_dn2, 13.114662332726377, "s_2_y_cav_dark");
    close(r.bright.rav_dn2, 45.49048170612913, "s_2_y_rav");
    close(r.dark.rav_dn2, 7.027704859122867, "s_2_y_rav_dark");
    let parts = &r.bright.parts_dn2;
    close(parts.total.value, 446.51618787949826, "s_2_y");
    close(parts.col.value, 48.18056298215529, "s_2_y_col");
    close(parts.row.value, 41.776322304116356, "s_2_y_row");
    close(parts.pixel.value, 356.5593025932267, "s_2_y_pixel");
    let parts = &r.dark.parts_dn2;
    close(parts.total.value, 56.461002236923356, "s_2_y_dark");
    close(parts.col.value, 12.532010433607542, "s_2_y_col_dark");
    close(parts.row.value, 6.63927025971031, "s_2_y_row_dark");
    close(parts.pixel.value, 37.289721543605516, "s_2_y_pixel_dark");
    close(r.dsnu_dn.total.value, 7.514053648791933, "DSNU1288_DN");
    close(r.prnu_percent.total.value, 1.2587510397389015, "PRNU1288");
    close(r.prnu_percent.row.value, 0.3777978440321484, "PRNU1288_row");
    close(r.prnu_percent.col.value, 0.3805377663147336, "PRNU1288_col");
    close(
        r.prnu_percent.pixel.value,
        1.1388213106087448,
        "PRNU1288_pixel",
    );
    close(r.bright.mean_dn.value, 1697.0099690755208, "avg_mean");
    close(r.dark.mean_dn.value, 128.00909423828125, "avg_mean_dark");
    // Histograms: the same bins and counts (`histogram_DSNU`, `histogram_PRNU`,
    // `histogram_DSNU_accumulated`).
    let h = &r.histogram_dsnu;
    assert_eq!(h.bins_dn.len(), 171);
    let firsts = [-22.00909423828125, -21.75909423828125, -21.50909423828125];
    for (o, e) in h.bins_dn.iter().zip(firsts) {
        close(*o, e, "DSNU histogram bin");
    }
    assert_eq!(h.counts[..5], [1, 0, 1, 1, 0]);
    let h = &r.histogram_prnu;
    assert_eq!(h.bins_dn.len(), 254);
    for (o, e) in h.bins_dn.iter().zip([-55.61, -55.105, -54.6]) {
        close(*o, e, "PRNU histogram bin");
    }
    assert_eq!(h.counts[..5], [1, 0, 0, 0, 1]);
    let a = &r.histogram_dsnu_accumulated;
    assert_eq!(a.bins_dn.len(), 177);
    let firsts = [
        100.0,
        99.52799479166667,
        98.56770833333333,
        97.44466145833333,
    ];
    for (o, e) in a.pixels_percent.iter().zip(firsts) {
        close(*o, e, "accumulated DSNU histogram");
    }
    // Spectrograms (`FFT1288` of the dark sum image, n = L, square-rooted).
    let h = [
        26.032210375444294,
        7.064077552095394,
        8.332615080277854,
        7.038773969654172,
    ];
    for (o, e) in r.spectrogram_horizontal.dsnu_dn.iter().zip(h) {
        close(*o, e, "horizontal DSNU spectrogram");
    }
    let v = [
        29.023347495595377,
        6.300333059134671,
        6.366610821744977,
        6.7158363236798095,
    ];
    for (o, e) in r.spectrogram_vertical.dsnu_dn.iter().zip(v) {
        close(*o, e, "vertical DSNU spectrogram");
    }
}

/// The bundled camera (`data-synthetic/emva-cmos-64x96`, 24-frame spatial stacks at 50 % of
/// saturation): DSNU (e-, at the stacks' exposure) and PRNU parts within 3 SE of the realised
/// patterns its `truth.json` states.
#[test]
fn the_bundled_camera_gives_its_truth() {
    let dir =
        std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("data-synthetic/emva-cmos-64x96");
    let truth: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(dir.join("truth.json")).unwrap()).unwrap();
    let data =
        crate::emva::EmvaDataset::from_descriptor(&dir.join("EMVA1288descriptor.txt")).unwrap();
    let k = truth["K_dn_per_e"].as_f64().unwrap();
    let options = SpatialOptions {
        saturation_dn: Some(3700.0),
        ..SpatialOptions::default()
    };
    let r = spatial_from_stacks(
        data.spatial_bright.as_ref().unwrap(),
        data.spatial_dark.as_ref().unwrap(),
        &Quantity::ok(k, 0.0),
        &options,
    )
    .unwrap();
    assert_eq!(
        (r.rows, r.cols, r.frames_bright, r.frames_dark),
        (64, 96, 24, 24)
    );
    // 4500 e- of 9000 (the pixels' gains average 0.1 % below K: within 0.01 of a half).
    let f = &r.saturation_fraction;
    assert!(
        matches!(f.status, QuantityStatus::Ok) && (f.value - 0.5).abs() < 0.01,
        "{f:?}"
    );
    let dsnu = &truth["dsnu_at_spatial_exposure_e"];
    for (part, ours) in [
        ("total", &r.dsnu_e.total),
        ("row", &r.dsnu_e.row),
        ("col", &r.dsnu_e.col),
        ("pixel", &r.dsnu_e.pixel),
    ] {
        within(
            ours,
            dsnu[part].as_f64().unwrap(),
            &format!("bundled DSNU {part} (e-)"),
        );
    }
    let prnu = &truth["prnu_realised_percent"];
    for (part, ours) in [
        ("total", &r.prnu_percent.total),
        ("row", &r.prnu_percent.row),
        ("col", &r.prnu_percent.col),
        ("pixel", &r.prnu_percent.pixel),
    ] {
        within(
            ours,
            prnu[part].as_f64().unwrap(),
            &format!("bundled PRNU {part} (%)"),
        );
    }
    for (part, q) in [
        ("row", &r.dsnu_e.row),
        ("col", &r.dsnu_e.col),
        ("pixel", &r.dsnu_e.pixel),
    ] {
        eprintln!(
            "bundled DSNU {part} (e-): {:.4} +- {:.4} {:?}",
            q.value, q.se, q.status
        );
    }
}
