//! The camera's noise beyond Gaussian pixels at the operating point: the effective read noise
//! of the measured map beside the models that add what `darks` measured (its telegraph pixels,
//! its row and column noise) or read through the camera's own dark frames, and what each adds.

use std::path::{Path, PathBuf};
use std::sync::Arc;

use serde::Serialize;

use crate::calib::darks::{RtsFits, RtsSummary, TemporalNoiseSummary};
use crate::detector::dark_frames::DEFAULT_MAX_MIB;
use crate::detector::{DarkFrames, ModelParams, ModelSpec, RtsTable};
use crate::effective::{effective_table, Effective, Precision, Status};
use crate::montecarlo::SimConfig;
use crate::plot::{LineChart, Series};
use crate::progress::Observer;
use crate::Result;

/// Files of the section: its table, and the example telegraph series (only with telegraph
/// pixels).
pub(crate) const REAL_NOISE_FILES: [&str; 3] =
    ["real_noise.csv", "real_noise.json", "rts_series.png"];

/// The camera's noise beyond Gaussian pixels, as summary.json's `real_noise` records it.
#[derive(Debug, Clone, Serialize)]
pub struct RealNoise {
    /// The dark temporal noise split into pixel, row and column parts (as `darks` gives it).
    pub temporal_noise: TemporalNoiseSummary,
    /// The telegraph (RTS) pixels found and fitted (as `darks` gives it).
    pub rts: RtsSummary,
    /// Dark frames kept for `scmos-frames`, and their size in memory (one sentence).
    pub dark_frames: Option<String>,
    /// Effective read noise at the operating point per model, and what each adds to the map's.
    pub rows: Vec<RealNoiseRow>,
}

/// Set in `params` the inputs of the richer models that the caller did not give, from what
/// `darks` measured: the telegraph table it wrote (`rts_csv`, when `rts_ok` pixels were fitted
/// `ok`), the row and column noise of `temporal` (e-), and the dark stack `darks` itself as
/// frames (e- with `gain_e_per_adu`). Inputs given by the caller (`--rts-table`,
/// `--row-noise-e` / `--column-noise-e`, `--dark-frames`) are kept. Returns the dark frames'
/// description.
pub(crate) fn measured_inputs(
    params: &mut ModelParams,
    darks: &[PathBuf],
    gain_e_per_adu: f64,
    temporal: &TemporalNoiseSummary,
    (rts_csv, rts_ok): (&Path, usize),
    observer: &dyn Observer,
) -> Result<String> {
    if params.rts_table.is_none() && rts_ok > 0 {
        params.rts_table = Some(Arc::new(RtsTable::read(rts_csv, observer)?));
    }
    // A component that the split could not resolve (no estimate) adds nothing.
    let lines = [
        temporal.row_rms_e,
        temporal.column_rms_e,
        temporal.frame_rms_e,
    ];
    let given = params.row_noise_e.is_some()
        || params.column_noise_e.is_some()
        || params.frame_noise_e.is_some();
    if !given && lines.iter().any(Option::is_some) {
        params.row_noise_e = Some(temporal.row_rms_e.unwrap_or(0.0));
        params.column_noise_e = Some(temporal.column_rms_e.unwrap_or(0.0));
        // The frame term, counted once: `darks` solves it apart from the line terms.
        params.frame_noise_e = Some(temporal.frame_rms_e.unwrap_or(0.0));
    }
    let frames = match params.dark_frames.take() {
        Some(given) => given,
        None => {
            let frames = DarkFrames::read(darks, gain_e_per_adu, DEFAULT_MAX_MIB)?;
            if let Some(warning) = frames.few_frames() {
                observer.warn(&warning);
            }
            Arc::new(frames)
        }
    };
    let described = frames.summary();
    params.dark_frames = Some(frames);
    Ok(described)
}

/// An error unless the dark frames given for `scmos-frames` (`dark_frames`, if any) have the
/// darks' frame shape (rows, cols): the report labels them the camera's own dark frames, and
/// windows read through frames of another camera would say nothing about this one.
pub(crate) fn check_given_frames(params: &ModelParams, darks_shape: (usize, usize)) -> Result<()> {
    let Some(frames) = &params.dark_frames else {
        return Ok(());
    };
    let (rows, cols) = darks_shape;
    if (frames.rows, frames.cols) == darks_shape {
        return Ok(());
    }
    Err(crate::Error::invalid(
        "dark_frames",
        format!(
            "{} holds frames of {}x{} px, the darks {rows}x{cols} px: give the camera's own dark \
             frames, of the darks' shape (or leave `dark_frames` out to use the darks)",
            frames.source.display(),
            frames.rows,
            frames.cols
        ),
    ))
}

/// The models compared with the measured map, with their labels on the page.
const MODELS: [(&str, &str); 3] = [
    ("scmos-rts", "scmos-rts (map + telegraph pixels)"),
    (
        "scmos-correlated",
        "scmos-correlated (map + row, column and frame noise)",
    ),
    (
        "scmos-frames",
        "scmos-frames (the camera's own dark frames)",
    ),
];

/// One model's effective read noise at the operating point, and what it adds to the map's.
#[derive(Debug, Clone, Serialize)]
pub struct RealNoiseRow {
    /// The model, as the page labels it.
    pub model: String,
    /// Effective read noise (e-); null when `status` gives no value.
    pub sigma_eff_e: Option<f64>,
    /// Its standard error (e-); null when `status` gives no value.
    pub sigma_eff_se_e: Option<f64>,
    /// How the value was settled (the effective-noise status words).
    pub status: Status,
    /// sigma_eff minus the measured map's (e-): what the model's extra noise adds; null when
    /// either value is missing.
    pub adds_e: Option<f64>,
    /// Standard error of `adds_e` (e-): both standard errors in quadrature. The runs share
    /// their random numbers (spots, photons, deviates, windows), which correlates them
    /// positively, so this overstates the uncertainty of the difference.
    pub adds_se_e: Option<f64>,
    /// `ok` when both values are `ok` and the difference is resolved (|adds| >= 2 SE),
    /// `not_resolved` when both are `ok` but the difference is below 2 SE, `reference` on the
    /// map's own row, else the worse status of the two.
    pub adds_status: String,
}

/// The value and standard error (e-) of an effective-noise solution when it has both (an
/// `imprecise` one is shown for information, its status beside it).
fn value(e: &Effective) -> Option<(f64, f64)> {
    let shown = matches!(
        e.status,
        Status::Ok | Status::Imprecise | Status::LowerBound
    );
    (shown && e.sigma_eff_e.is_finite() && e.sigma_eff_se_e.is_finite())
        .then_some((e.sigma_eff_e, e.sigma_eff_se_e))
}

/// The row of `model` (a page label) solved as `e`, against the map's solution `map`.
fn row(model: &str, e: &Effective, map: &Effective) -> RealNoiseRow {
    let (own, base) = (value(e), value(map));
    // Each model's value is its own solve (a separate experiment on the same seed): with no
    // joint block sums the SEs add in quadrature, which overstates the SE (the page says so).
    let adds = own
        .zip(base)
        .map(|((a, sa), (b, sb))| (a - b, sa.hypot(sb)));
    let adds_status = match (e.status, map.status, adds) {
        (Status::Ok, Status::Ok, Some((d, se))) if d.abs() >= 2.0 * se => "ok".to_string(),
        (Status::Ok, Status::Ok, _) => "not_resolved".to_string(),
        (Status::Ok, worse, _) | (worse, _, _) => worse.label().to_string(),
    };
    RealNoiseRow {
        model: model.into(),
        sigma_eff_e: own.map(|v| v.0),
        sigma_eff_se_e: own.map(|v| v.1),
        status: e.status,
        adds_e: adds.map(|v| v.0),
        adds_se_e: adds.map(|v| v.1),
        adds_status,
    }
}

/// Solve the richer models at the operating point `cfg` (the configuration the map's headline
/// value `map` was solved on, same seed: common random numbers) with `params` (map, RTS table,
/// row and column noise, dark frames set): the fitted pdf's row (`fitted`), the map's, then one
/// row per model whose inputs `params` holds.
pub(crate) fn real_noise_rows(
    cfg: &SimConfig,
    params: &ModelParams,
    (fitted, map): (&Effective, &Effective),
    precision: &Precision,
    observer: &dyn Observer,
) -> Result<Vec<RealNoiseRow>> {
    let available = |name: &str| match name {
        "scmos-rts" => params.rts_table.is_some(),
        "scmos-correlated" => params.row_noise_e.is_some() && params.column_noise_e.is_some(),
        "scmos-frames" => params.dark_frames.is_some(),
        _ => false,
    };
    let chosen: Vec<(&str, &str)> = MODELS.into_iter().filter(|(n, _)| available(n)).collect();
    let specs = chosen
        .iter()
        .map(|(name, _)| ModelSpec::parse(name))
        .collect::<Result<Vec<_>>>()?;
    let records = effective_table(
        std::slice::from_ref(cfg),
        &specs,
        params,
        precision,
        observer,
    )?;
    let reference = RealNoiseRow {
        adds_e: None,
        adds_se_e: None,
        adds_status: "reference".into(),
        ..row("scmos-map (measured map)", map, map)
    };
    let base = [row("scmos-random (fitted pdf)", fitted, map), reference];
    Ok(base
        .into_iter()
        .chain(
            chosen
                .iter()
                .zip(&records)
                .map(|((_, label), r)| row(label, &r.effective, map)),
        )
        .collect())
}

/// `rts_series.png`: the example telegraph pixels' outputs (e-, each less its mean over the
/// stack) against frame, one line per pixel, stacked apart so that each one's levels show.
pub(crate) fn rts_series_chart(
    fits: &RtsFits,
    cols: usize,
    gain_e_per_adu: f64,
    path: &Path,
) -> Result<()> {
    let span = fits
        .examples
        .iter()
        .flat_map(|(_, v)| v.iter())
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), &v| {
            (lo.min(v), hi.max(v))
        });
    let step = ((span.1 - span.0) * gain_e_per_adu * 1.1).max(1e-9);
    let mut chart = LineChart::new(
        "Example random-telegraph pixels (dark frames)",
        "frame",
        format!("output - pixel mean (e-); pixel k drawn {step:.2} e- x k higher"),
    );
    chart.series = fits
        .examples
        .iter()
        .enumerate()
        .map(|(k, (index, values))| {
            let shift = step * k as f64;
            Series::new(
                format!("pixel x {} y {}", index % cols, index / cols),
                values
                    .iter()
                    .enumerate()
                    .map(|(f, v)| (f as f64, v * gain_e_per_adu + shift)),
            )
        })
        .collect();
    chart.save(path)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn solved(sigma: f64, se: f64, status: Status) -> Effective {
        Effective {
            sigma_eff_e: sigma,
            sigma_eff_se_e: se,
            sigma_cog_equiv_e: sigma,
            sigma_cog_equiv_se_e: se,
            target_se_e: None,
            iters: 1000,
            r_px: 0.1,
            r_se_px: 0.001,
            b_opt_e: 1.0,
            param_name: None,
            param_opt: None,
            sigma_grid_e: vec![],
            r_const_px: vec![],
            status,
            parts: Default::default(),
        }
    }

    #[test]
    fn the_measured_frame_noise_goes_to_the_correlated_model_once() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("darks.fits");
        let mut next = || vec![100.0; 16];
        crate::io::fits::write_cube(&path, (4, 4), 2, false, &mut next, &[]).unwrap();
        let temporal = TemporalNoiseSummary {
            row_rms_e: Some(0.2),
            column_rms_e: Some(0.1),
            frame_rms_e: Some(0.75),
            ..Default::default()
        };
        let mut params = ModelParams::default();
        let silent = &crate::progress::Silent;
        let none = dir.path().join("rts.csv");
        measured_inputs(
            &mut params,
            std::slice::from_ref(&path),
            1.0,
            &temporal,
            (&none, 0),
            silent,
        )
        .unwrap();
        let lines = (
            params.row_noise_e,
            params.column_noise_e,
            params.frame_noise_e,
        );
        assert_eq!(lines, (Some(0.2), Some(0.1), Some(0.75)));
        // The model built from them reads the frame term: sqrt(1.5^2 + 0.2^2 + 0.1^2 + 0.75^2).
        params.map = Some(Arc::new(crate::calib::Map::filled(
            4,
            4,
            1.5,
            crate::calib::Unit::Electrons,
        )));
        let model = ModelSpec::parse("scmos-correlated")
            .unwrap()
            .build(&params, 2)
            .unwrap();
        let expect = (1.5f64.powi(2) + 0.04 + 0.01 + 0.5625).sqrt();
        assert!(
            (model.noise_scale_e() - expect).abs() < 1e-12,
            "{}",
            model.noise_scale_e()
        );
        // Amplitudes the caller gave are kept: none taken from the darks.
        let mut given = ModelParams {
            frame_noise_e: Some(0.0),
            ..ModelParams::default()
        };
        measured_inputs(&mut given, &[path], 1.0, &temporal, (&none, 0), silent).unwrap();
        assert_eq!((given.row_noise_e, given.frame_noise_e), (None, Some(0.0)));
    }

    #[test]
    fn differences_carry_both_errors_and_the_worse_status() {
        let map = solved(1.0, 0.03, Status::Ok);
        let r = row("m", &solved(1.5, 0.04, Status::Ok), &map);
        assert!((r.adds_e.unwrap() - 0.5).abs() < 1e-12);
        assert!((r.adds_se_e.unwrap() - 0.05).abs() < 1e-12);
        assert_eq!(r.adds_status, "ok");
        let r = row("m", &solved(1.05, 0.04, Status::Ok), &map);
        assert_eq!(r.adds_status, "not_resolved");
        let r = row("m", &solved(1.5, 0.3, Status::Imprecise), &map);
        assert_eq!(r.adds_status, "imprecise");
        let r = row("m", &solved(f64::NAN, f64::NAN, Status::Unreachable), &map);
        assert_eq!((r.sigma_eff_e, r.adds_e), (None, None));
        assert_eq!(r.adds_status, "unreachable");
    }
}
