//! The committed data-synthetic/ stacks run through `darks` and `ptc` from a clean checkout,
//! give identical maps in all three formats and match their truth maps.

mod common;

use common::data;

use detnoise::calib::darks::{dark_maps, pixel_stats, Clip, DarkOptions};
use detnoise::calib::ptc::{photon_transfer, DarkReference, PtcOptions};
use detnoise::calib::{Map, Unit};
use detnoise::io::FrameStack;

fn open(name: &str) -> FrameStack {
    FrameStack::open(&[data(name)]).unwrap()
}

#[test]
fn scmos_darks_agree_across_formats_and_with_truth() {
    let maps: Vec<_> = ["fits", "tif", "exr"]
        .iter()
        .map(|e| {
            dark_maps(
                &open(&format!("scmos-darks-64x64.{e}")),
                &DarkOptions::default(),
            )
            .unwrap()
        })
        .collect();
    assert_eq!(maps[0].rms_adu, maps[1].rms_adu);
    assert_eq!(maps[0].rms_adu, maps[2].rms_adu);
    assert_eq!(maps[0].offset_adu, maps[2].offset_adu);
    let truth = Map::read(data("scmos-darks-64x64.truth-rms_adu.fits"), Unit::Adu).unwrap();
    // Quantisation adds 1/12 adu^2. Sample std from n = 100 frames: standard error
    // sigma / sqrt(2 (n - 1)) = 7 %; the mean z-score over 4096 pixels has standard error
    // 1/64 = 0.016, bound at 5 of them plus 0.02 for the small-n bias of the std.
    let n = 100.0f64;
    let z: Vec<f64> = truth
        .data
        .iter()
        .zip(&maps[0].rms_adu.data)
        .map(|(t, m)| {
            let s = (t * t + 1.0 / 12.0).sqrt();
            (m - s) / (s / (2.0 * (n - 1.0)).sqrt())
        })
        .collect();
    let mean = z.iter().sum::<f64>() / z.len() as f64;
    assert!(mean.abs() < 0.08 + 0.02, "mean z {mean}");
}

#[test]
fn scmos_flat_series_gives_the_true_gain() {
    let dark = DarkReference::from_stats(
        &pixel_stats(&open("scmos-darks-64x64.fits"), Clip::None, None).unwrap(),
    );
    let flats: Vec<FrameStack> = [100, 400, 1600, 6400]
        .iter()
        .map(|l| open(&format!("scmos-flat-64x64-{l}e.fits")))
        .collect();
    let r = photon_transfer(&flats, &dark, &PtcOptions::default()).unwrap();
    let g = Map::read(
        data("scmos-darks-64x64.truth-gain_e_per_adu.fits"),
        Unit::EPerAdu,
    )
    .unwrap();
    let truth = g.data.iter().map(|g| 1.0 / g).sum::<f64>()
        / g.data.iter().map(|g| 1.0 / (g * g)).sum::<f64>();
    // Within 3 stated standard errors.
    assert!(
        (r.gain_e_per_adu - truth).abs() < 3.0 * r.gain_err_e_per_adu,
        "{} +/- {} vs {truth}",
        r.gain_e_per_adu,
        r.gain_err_e_per_adu
    );
}

#[test]
fn emccd_stacks_read() {
    for name in ["emccd-darks-32x48.fits", "emccd-lowlight-32x48.fits"] {
        let s = open(name);
        assert_eq!((s.shape, s.frames), ((32, 48), 200));
        let m = dark_maps(&s, &DarkOptions::default()).unwrap();
        // Bias 500 adu plus CIC/light electrons amplified x300 at 10 e/adu.
        let med = detnoise::stats::median(&m.offset_adu.data);
        assert!(med > 500.0 && med < 520.0, "{name}: median offset {med}");
    }
}
