//! Tests of the terminal table on real (short) sweeps: width, columns, and cells.

use super::*;
use crate::detector::{ModelParams, ModelSpec};
use crate::montecarlo::{sweep, BgGrid, Grid, SimConfig};
use crate::progress::Silent;
use crate::spot::Spot;

/// Records of `models` over the grid (subaps x spots x signals), 200 iterations each.
fn run(models: &str, subaps_px: &[usize], spots: &[Spot], signals: &[f64]) -> Vec<SimRecord> {
    let grid = Grid {
        subaps_px: subaps_px.to_vec(),
        spots: spots.to_vec(),
        signals_photons: signals.to_vec(),
        shared: SimConfig {
            iters: 200,
            bg_grid: BgGrid::Auto,
            ..SimConfig::paper(subaps_px[0])
        },
    };
    let specs: Vec<ModelSpec> = models
        .split(',')
        .map(|m| ModelSpec::parse(m).unwrap())
        .collect();
    sweep(
        &grid.configs().unwrap(),
        &specs,
        &ModelParams::default(),
        &Silent,
    )
    .unwrap()
}

const AIRY2: Spot = Spot::Airy { diameter_px: 2.0 };

/// The default models of `simulate` (its `--model` default).
const DEFAULT_MODELS: &str =
    "emccd-simple,emccd-stochastic,emccd-distribution,scmos-median,scmos-mean,scmos-random";

/// The cell of column `name` in `row`, by the header's column spans: numbers align right (a
/// cell ends where its header name ends), the model and the note left (a cell starts where
/// its header name starts); columns are two spaces apart.
fn cell<'a>(header: &str, row: &'a str, name: &str) -> &'a str {
    let mut heads: Vec<(usize, &str)> = Vec::new();
    let mut at = 0;
    for h in header.split_whitespace() {
        at += header[at..].find(h).unwrap();
        heads.push((at, h));
        at += h.len();
    }
    let left = |k: usize| k == 0 || heads[k].1 == "note";
    let end = |k: usize| match heads.get(k + 1) {
        _ if !left(k) => heads[k].0 + heads[k].1.len(),
        Some((next, _)) => next - 2,
        None => usize::MAX,
    };
    let k = heads
        .iter()
        .position(|(_, h)| *h == name)
        .unwrap_or_else(|| panic!("no column {name} in {header}"));
    let lo = if left(k) { heads[k].0 } else { end(k - 1) + 2 };
    let (lo, hi) = (lo.min(row.len()), end(k).min(row.len()));
    row[lo..hi].trim()
}

/// The header lines (starting with `model`) and the rows under each, in order.
fn rows(text: &str) -> Vec<(&str, &str)> {
    let mut header = "";
    let mut out = Vec::new();
    for line in text.lines() {
        if line.starts_with("model ") {
            header = line;
        } else if !header.is_empty() && (line.starts_with("emccd-") || line.starts_with("scmos-")) {
            out.push((header, line));
        }
    }
    out
}

fn assert_fits(text: &str) {
    for line in text.lines() {
        assert!(
            line.chars().count() <= MAX_WIDTH,
            "{} chars: {line}",
            line.len()
        );
    }
    assert!(!text.to_lowercase().contains("nan"), "{text}");
}

#[test]
fn the_default_run_shows_only_what_applies_in_100_columns() {
    let records = run(DEFAULT_MODELS, &[16], &[AIRY2], &[50.0]);
    let text = terminal_table(&records);
    assert_fits(&text);
    // One configuration: it is stated once, not repeated in six rows.
    let first = text.lines().next().unwrap();
    for shared in [
        "sub-aperture 16x16 px",
        "spot airy:2",
        "50 photons",
        "200 iterations",
    ] {
        assert!(first.contains(shared), "{first}");
    }
    let header = text.lines().find(|l| l.starts_with("model ")).unwrap();
    for absent in [
        "subap_px",
        "spot",
        "signal_photons",
        "qe",
        "iters",
        "seed",
        "sampling",
    ] {
        assert!(!header.split_whitespace().any(|h| h == absent), "{header}");
    }
    for absent in ["b_at_grid_edge", "no_eligible_level", "r0_se_px"] {
        assert!(!header.contains(absent), "{header}");
    }
    let rows = rows(&text);
    assert_eq!(rows.len(), records.len());
    for ((h, row), r) in rows.iter().zip(&records) {
        assert_eq!(cell(h, row, "model"), r.result.model);
        assert_eq!(cell(h, row, "r_px"), sig(r.result.r_px, 4), "{row}");
        assert_eq!(cell(h, row, "r_se_px"), sig(r.result.r_se_px, 2), "{row}");
        // The EM gain only on the rows of models with a register.
        let gain = cell(h, row, "em_gain");
        match r.em_gain {
            Some(g) => assert_eq!(gain, plain(g), "{row}"),
            None => assert_eq!(gain, "", "{row}"),
        }
    }
    assert!(rows.iter().any(|(h, r)| cell(h, r, "em_gain") == "500"));
}

#[test]
fn a_many_model_sweep_fits_100_columns_with_every_result() {
    let models = "emccd-simple,emccd-stochastic,emccd-distribution,emccd-pp,\
                  emccd-pp-uncorrected,scmos-constant:1.5,scmos-median,scmos-mean,\
                  scmos-fixed:3,scmos-random";
    let gauss = Spot::Gauss {
        sigma_x_px: 1.0,
        sigma_y_px: 2.5,
    };
    let records = run(models, &[4, 16], &[AIRY2, gauss], &[20.0, 1000.0]);
    let text = terminal_table(&records);
    assert_fits(&text);
    let rows = rows(&text);
    assert_eq!(rows.len(), records.len());
    for ((h, row), r) in rows.iter().zip(&records) {
        assert_eq!(cell(h, row, "model"), r.result.model, "{row}");
        assert_eq!(cell(h, row, "r0_px"), sig(r.result.r0_px, 4), "{row}");
    }
    // Too wide for one table: one per configuration, each headed by its swept settings.
    assert!(
        text.contains("sub-aperture 4x4 px, spot gauss:1,2.5, 1000 photons"),
        "{text}"
    );
    // A signal sweep of the sCMOS models alone fits one table, without an EM-gain column.
    let records = run(
        "scmos-median,scmos-mean,scmos-random",
        &[8],
        &[AIRY2],
        &[20.0, 50.0],
    );
    let text = terminal_table(&records);
    assert_fits(&text);
    let header = text.lines().find(|l| l.starts_with("model ")).unwrap();
    assert!(
        header.contains("signal_photons") && !header.contains("em_gain"),
        "{header}"
    );
    assert_eq!(text.matches("model ").count(), 1, "{text}");
}

#[test]
fn numbers_are_written_with_their_significant_digits() {
    assert_eq!(sig(0.153614, 4), "0.1536");
    assert_eq!(sig(0.004129, 2), "0.0041");
    assert_eq!(sig(1.2345e-5, 4), "1.234e-5");
    assert_eq!(sig(7.04e-4, 2), "0.00070");
    assert_eq!(sig(0.99996, 4), "1.000");
    assert_eq!(sig(2.0, 4), "2.000");
    assert_eq!(sig(f64::NAN, 4), "");
    assert_eq!(plain(500.0), "500");
    assert_eq!(plain(0.95), "0.95");
    assert_eq!(plain(trimmed(12.61234, 3)), "12.6");
    assert_eq!(plain(f64::INFINITY), "");
}
