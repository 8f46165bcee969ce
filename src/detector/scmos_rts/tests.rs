//! Exact tests of `scmos-rts`: level occupancies, moments, where the telegraph pixels fall in
//! the window, and the errors of table and map.

use super::*;
use crate::calib::Unit;
use crate::detector::readout::sampling::{dark_samples, frames_own_streams};
use crate::detector::rts_table::fixture::{row, table};
use crate::detector::ModelParams;
use crate::stats::mean_var;
use std::path::Path;

/// The table of `rows` as `scmos-rts` reads it.
fn rts(rows: &[String]) -> RtsTable {
    RtsTable::parse(&table(rows), Path::new("rts.csv")).unwrap()
}

/// A `rows` x `cols` map of sigma 1 e-.
fn ones(rows: usize, cols: usize) -> Arc<Map> {
    Arc::new(Map::new(rows, cols, vec![1.0; rows * cols], Unit::Electrons).with_source("map.fits"))
}

/// Three levels with zero mean: 0.2 (-3) + 0.5 (0) + 0.3 (2) = 0.
const LEVELS: [f64; 3] = [-3.0, 0.0, 2.0];
const OCCUPANCY: [f64; 3] = [0.2, 0.5, 0.3];

#[test]
fn levels_are_taken_by_their_occupancy() {
    // Zero widths: the output is the level itself, so every frame names its level. Pearson's
    // chi-square over the 3 levels (2 degrees of freedom) stays below 13.8 (p = 0.001), and
    // each count within 4 binomial SE.
    let levels: Vec<(f64, f64, f64)> = (0..3).map(|k| (LEVELS[k], OCCUPANCY[k], 0.0)).collect();
    let m = ScmosRts::new(ones(1, 1), &rts(&[row(0, 0, "ok", &levels, true)]), 1).unwrap();
    assert_eq!(m.rts_pixels(), 1);
    let n = 100_000;
    let xs = dark_samples(&m, 1, n, 5).remove(0);
    let mut counts = [0usize; 3];
    for x in &xs {
        let k = LEVELS.iter().position(|l| l == x).expect("output is a level");
        counts[k] += 1;
    }
    let mut chi2 = 0.0;
    for k in 0..3 {
        let expect = n as f64 * OCCUPANCY[k];
        let se = (expect * (1.0 - OCCUPANCY[k])).sqrt();
        assert!((counts[k] as f64 - expect).abs() < 4.0 * se, "level {k}: {}", counts[k]);
        chi2 += (counts[k] as f64 - expect).powi(2) / expect;
    }
    assert!(chi2 < 13.8, "chi-square {chi2} on 2 dof");
}

#[test]
fn a_telegraph_pixel_has_the_mixture_moments() {
    // With widths, the output is the mixture sum_k p_k N(level_k, width_k^2): mean 0 and
    // variance sum_k p_k (level_k^2 + width_k^2) = 0.2 (9.25) + 0.5 (0.09) + 0.3 (4.64)
    // = 3.287, within 4 SE (SE of the variance from the mixture's 4th moment).
    let widths = [0.5, 0.3, 0.8];
    let levels: Vec<(f64, f64, f64)> =
        (0..3).map(|k| (LEVELS[k], OCCUPANCY[k], widths[k])).collect();
    let m = ScmosRts::new(ones(1, 1), &rts(&[row(0, 0, "ok", &levels, true)]), 1).unwrap();
    let n = 200_000;
    let xs = dark_samples(&m, 1, n, 6).remove(0);
    let moment = |f: &dyn Fn(f64, f64) -> f64| (0..3).map(|k| OCCUPANCY[k] * f(LEVELS[k], widths[k])).sum::<f64>();
    let var = moment(&|l, w| l * l + w * w);
    // E[x^4] of N(l, w^2): l^4 + 6 l^2 w^2 + 3 w^4.
    let m4 = moment(&|l, w| l.powi(4) + 6.0 * l * l * w * w + 3.0 * w.powi(4));
    assert!((var - 3.287).abs() < 1e-12);
    let (mean, v) = mean_var(&xs);
    assert!(mean.abs() < 4.0 * (var / n as f64).sqrt(), "mean {mean}");
    assert!((v - var).abs() < 4.0 * ((m4 - var * var) / n as f64).sqrt(), "var {v} vs {var}");
    // Light adds its photo-electrons on top (Poisson, mean 7): variance var + 7, central 4th
    // moment m4 + 6 var 7 + (7 + 3 7^2) (independent sum).
    let lit = crate::detector::readout::sampling::pixel_samples(&m, 7.0, n);
    let (mean, v) = mean_var(&lit);
    let (var_lit, m4_lit) = (var + 7.0, m4 + 6.0 * var * 7.0 + 7.0 + 3.0 * 49.0);
    assert!((mean - 7.0).abs() < 4.0 * (var_lit / n as f64).sqrt(), "lit mean {mean}");
    let se = ((m4_lit - var_lit * var_lit) / n as f64).sqrt();
    assert!((v - var_lit).abs() < 4.0 * se, "lit var {v}");
}

#[test]
fn telegraph_pixels_follow_the_window() {
    // A 3x4 map (sigma 1) with one RTS pixel at x_px 2 (column), y_px 1 (row), read through
    // 2x2 windows: r0 in {0, 1}, c0 in {0, 1, 2}, each of the 6 places with probability 1/6.
    // The pixel is inside for c0 in {1, 2}: at window place (1 - r0, 2 - c0), each of the 4
    // with probability 1/6; in 1/3 of the frames it is outside. Zero-width levels make it
    // recognisable (a Gaussian output never equals a level exactly).
    let levels = [(-2.5, 0.5, 0.0), (2.5, 0.5, 0.0)];
    let m = ScmosRts::new(ones(3, 4), &rts(&[row(2, 1, "ok", &levels, true)]), 2).unwrap();
    let n = 60_000;
    let px = dark_samples(&m, 2, n, 9);
    let mut at = [0usize; 4];
    let hits = |f: usize| -> Vec<usize> { (0..4).filter(|&j| px[j][f].abs() == 2.5).collect() };
    for (f, hit) in (0..n).map(hits).enumerate() {
        assert!(hit.len() <= 1, "frame {f}: {hit:?}");
        if let Some(&j) = hit.first() {
            at[j] += 1;
        }
    }
    let se = (n as f64 * (1.0 / 6.0) * (5.0 / 6.0)).sqrt();
    for (j, &count) in at.iter().enumerate() {
        assert!((count as f64 - n as f64 / 6.0).abs() < 4.0 * se, "place {j}: {count}");
    }
    let outside = n - at.iter().sum::<usize>();
    let se = (n as f64 * (1.0 / 3.0) * (2.0 / 3.0)).sqrt();
    assert!((outside as f64 - n as f64 / 3.0).abs() < 4.0 * se, "{outside}");
}

#[test]
fn without_telegraph_pixels_it_reads_as_the_map() {
    // An empty table (built in code: the reader refuses one): the same draws as scmos-map,
    // bit for bit.
    let data: Vec<f64> = (0..20).map(|i| 0.5 + 0.1 * i as f64).collect();
    let map = Arc::new(Map::new(4, 5, data, Unit::Electrons).with_source("t"));
    let empty = RtsTable {
        source: "rts.csv".into(),
        pixels: Vec::new(),
        skipped: 0,
    };
    let none = ScmosRts::new(map.clone(), &empty, 3).unwrap();
    let plain = ScmosMap::new(map, 3).unwrap();
    let (a, b) = (frames_own_streams(&none, 3, 500, 4), frames_own_streams(&plain, 3, 500, 4));
    assert!(a == b, "differs from scmos-map");
    assert_eq!(none.noise_scale_e(), plain.noise_scale_e());
}

#[test]
fn table_pixels_outside_the_map_and_missing_inputs_are_errors() {
    let two = [(-1.0, 0.5, 0.2), (1.0, 0.5, 0.2)];
    let t = rts(&[row(1, 1, "ok", &two, true), row(4, 1, "ok", &two, true)]);
    let err = ScmosRts::new(ones(3, 4), &t, 2).unwrap_err().to_string();
    assert!(
        err.starts_with("rts.csv: line 3: pixel (x_px 4, y_px 1) is outside the 3x4 px noise map map.fits"),
        "{err}"
    );
    let t = rts(&[row(0, 3, "ok", &two, true)]);
    assert!(ScmosRts::new(ones(3, 4), &t, 2).is_err());
    // The builder names the missing parameter.
    let spec = ModelSpec::parse("scmos-rts").unwrap();
    let table = Arc::new(rts(&[row(1, 1, "ok", &two, true)]));
    let no_table = ModelParams {
        map: Some(ones(3, 4)),
        ..ModelParams::default()
    };
    let no_map = ModelParams {
        rts_table: Some(table.clone()),
        ..ModelParams::default()
    };
    for (params, field) in [(&no_table, "rts_table"), (&no_map, "map")] {
        let Err(e) = spec.build(params, 2) else {
            panic!("built without {field}")
        };
        assert!(e.to_string().starts_with(&format!("invalid `{field}`: ")), "{e}");
        assert_eq!(e.exit_code(), 2);
    }
    let both = ModelParams {
        map: Some(ones(3, 4)),
        ..no_map
    };
    assert_eq!(spec.build(&both, 2).unwrap().name(), "scmos-rts");
}
