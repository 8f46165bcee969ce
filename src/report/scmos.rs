//! The sCMOS report: dark maps, conversion gain, the fitted per-pixel noise distribution, the
//! effective read noise over the grid (fitted pdf and measured map), and the comparison.

use super::centroiders::{centroider_section, Inputs as CentroiderInputs, CENTROIDER_FILES};
use super::compare::{
    compare_models, scmos_groups, scmos_labels, write_comparison, COMPARISON_FILES,
};
use super::grid::Grid;
use super::options::{GainSource, ReportOptions};
use super::page::{index_html, ScmosPage};
use super::point::{ChosenPoint, OperatingPoint};
use super::real_noise::{measured_inputs, real_noise_rows, rts_series_chart, RealNoise};
use super::result::{Headline, ReportInput, ReportResult, ReportSummary, Summary};
use crate::calib::darks::write_outputs as write_dark_outputs;
use crate::calib::darks::{dark_maps_hashed, require_dark, DarkMaps, DarkOptions};
use crate::calib::ptc::chart as ptc_chart;
use crate::calib::ptc::POINTS_NAMES;
use crate::calib::ptc::{photon_transfer, write_points, DarkReference, PtcOptions, PtcResult};
use crate::calib::summary::{inputs, Checksum, InputFile};
use crate::charts::heatmaps::{effective_heatmaps, NoiseScale};
use crate::detector::{ModelParams, ModelSpec};
use crate::effective::{effective_table, Effective, EffectiveRecord, Precision, TABLE_NAMES};
use crate::fit::pdf_fit::chart as pdf_fit_chart;
use crate::fit::pdf_fit::{fit_pdf, PdfFitOptions};
use crate::io::FrameStack;
use crate::montecarlo::SimConfig;
use crate::output::{write_atomic, write_csv_json, write_json, OutputDir};
use crate::progress::Observer;
use crate::{Error, Result};
use std::path::PathBuf;
use std::sync::Arc;

/// The models of the effective-noise table, with their labels in it.
const EFFECTIVE_MODELS: [(ModelSpec, &str); 2] = [
    (ModelSpec::ScmosRandom, "scmos-random (fitted pdf)"),
    (ModelSpec::ScmosMap, "scmos-map (measured map)"),
];

/// The conversion gain and where it came from.
struct Gain {
    e_per_adu: f64,
    source: &'static str,
    se_e_per_adu: Option<f64>,
    ptc: Option<PtcResult>,
    /// The flats' input records (with BLAKE3), empty when the gain was given.
    flat_inputs: Vec<InputFile>,
}

/// Run the sCMOS report on the dark `stack` into `dir`; `files` of the result are names
/// inside `dir`.
pub(crate) fn run(
    o: &ReportOptions,
    grid: &Grid,
    stack: &FrameStack,
    dir: &OutputDir,
    observer: &dyn Observer,
) -> Result<ReportResult> {
    let dark_opts = DarkOptions::default();
    // The darks are hashed from the frames read for the statistics, not read a second time.
    let (maps, darks_inputs) = dark_maps_hashed(stack, &dark_opts, Checksum::Blake3)?;
    if let Some(warning) = require_dark(stack, &maps, o.accept_illuminated)? {
        observer.warn(&warning);
    }
    let gain = conversion_gain(o, &maps)?;
    let dark_summary = write_dark_outputs(
        &dir.path(""),
        stack,
        &maps,
        &dark_opts,
        Some(gain.e_per_adu),
        darks_inputs,
        "darks_summary.json",
    )?;
    let mut files = dark_summary.outputs.clone();
    // Noise map in e-, flagged pixels excluded (NaN) from the statistics and the windows.
    let rms_e = maps
        .rms_adu
        .masked(&maps.flags)
        .to_electrons(gain.e_per_adu)
        .with_source(o.darks_paths[0].display().to_string());
    let values: Vec<f64> = rms_e
        .data
        .iter()
        .copied()
        .filter(|v| v.is_finite() && *v > 0.0)
        .collect();
    if values.len() < 16 {
        return Err(Error::input(
            &o.darks_paths[0],
            format!(
                "only {} unflagged pixels with a positive noise: too few to fit a distribution",
                values.len()
            ),
        ));
    }
    let fit = fit_pdf(&values, &PdfFitOptions::default())?;
    fit.write_json(&dir.path("pdf_fit.json"))?;
    pdf_fit_chart(&fit, &values, &dir.path("pdf_fit.png"))?;
    files.extend(["pdf_fit.json".into(), "pdf_fit.png".into()]);
    let mut params = o.model_params.clone();
    params.pdf = fit.pdf(None)?;
    params.map = Some(Arc::new(rms_e));
    let dark_frames = measured_inputs(
        &mut params,
        &o.darks_paths,
        gain.e_per_adu,
        &dark_summary.temporal_noise,
        (&dir.path("rts.csv"), dark_summary.rts.ok),
        observer,
    )?;
    let op = o.operating_point();
    let in_grid = grid.contains(&op);
    let grid_len = grid.configs(o.qe).len();
    // The headline is solved with the table (one stage of progress): beside the grid, last,
    // when it is not one of the grid's configurations.
    let configs = with_point(grid, &op, o.qe, in_grid);
    let [mut fitted, mut measured] =
        effective_tables(&configs, &params, &o.precision_in_use(), observer)?;
    let at = ChosenPoint::new(&op, o.operating_point.is_some(), in_grid);
    let operating_point = headline(at, &op, &fitted, &measured);
    let op_cfg = grid.config(op.subap_px, op.spot, op.signal_photons, o.qe);
    let real_noise = RealNoise {
        temporal_noise: dark_summary.temporal_noise.clone(),
        rts: dark_summary.rts.clone(),
        dark_frames: Some(dark_frames),
        rows: real_noise_rows(
            &op_cfg,
            &params,
            (&at_point(&fitted, &op), &at_point(&measured, &op)),
            &o.precision_in_use(),
            observer,
        )?,
    };
    let names = ["real_noise.csv", "real_noise.json"];
    write_csv_json(&real_noise.rows, &dir.path(""), names)?;
    files.extend(names.map(String::from));
    if !dark_summary.rts.example_pixels.is_empty() {
        rts_series_chart(
            &maps.rts,
            stack.shape.1,
            gain.e_per_adu,
            &dir.path("rts_series.png"),
        )?;
        files.push("rts_series.png".into());
    }
    fitted.truncate(grid_len);
    measured.truncate(grid_len);
    let heatmaps = effective_heatmaps(&fitted, dir)?;
    files.extend(heatmaps.iter().map(|p| file_name(p)));
    let scale = NoiseScale::from_ok(&fitted);
    let effective: Vec<EffectiveRecord> = fitted.into_iter().chain(measured).collect();
    write_csv_json(&effective, &dir.path(""), TABLE_NAMES)?;
    files.extend(TABLE_NAMES.map(String::from));
    let subaps = match (&o.subaps, params.map.as_deref()) {
        (Some(geometry), Some(map)) => {
            let (summary, names) =
                super::subaps::subaps_section(o, grid, geometry, map, dir, observer)?;
            files.extend(names);
            Some(summary)
        }
        _ => None,
    };
    let centroiders = centroider_section(
        &CentroiderInputs {
            grid,
            op: &op,
            params: &params,
            centroiders: &o.centroiders,
            qe: (o.qe, o.qe_emccd),
            median_rms_e: fit.data.median_e,
            precision: &o.precision_in_use(),
            full_grid: o.centroider_full_grid,
            solved: &effective,
        },
        &dir.path(""),
        observer,
    )?;
    files.extend(CENTROIDER_FILES.map(String::from));
    let comparison = compare_models(grid, &op, &params, &scmos_groups(o.qe, o.qe_emccd))?;
    let error_bars = write_comparison(&comparison, dir, &scmos_labels(&params))?;
    files.extend(COMPARISON_FILES.map(String::from));
    if let Some(p) = &gain.ptc {
        ptc_chart(p, &dir.path("ptc.png"))?;
        write_points(p, &dir.path(""))?;
        files.push("ptc.png".into());
        files.extend(POINTS_NAMES.map(String::from));
    }
    let mut report_inputs: Vec<ReportInput> =
        ReportInput::all("darks", dark_summary.inputs.clone()).collect();
    report_inputs.extend(ReportInput::all("flats", gain.flat_inputs));
    let summary = ReportSummary {
        tool: format!("detnoise {}", env!("CARGO_PKG_VERSION")),
        inputs: report_inputs,
        frames: stack.frames,
        shape: [stack.shape.0, stack.shape.1],
        gain_e_per_adu: gain.e_per_adu,
        gain_source: gain.source.into(),
        gain_se_e_per_adu: gain.se_e_per_adu,
        pixels_used: values.len(),
        pixels_flagged: maps.flags.iter().filter(|f| **f != 0).count(),
        median_rms_e: fit.data.median_e,
        mean_rms_e: fit.data.mean_e,
        rms_rms_e: fit.data.rms_e,
        frac_above_3x_median: fit.data.frac_above_3x_median,
        pdf_best_model: fit.best_model.clone(),
        split_half_correlation: maps.split_half_correlation,
        operating_point,
        iters: grid.iters,
        seed: grid.seed,
        sampling: grid.sampling.label().into(),
        quick: o.quick,
        real_noise,
        subaps,
        centroiders,
    };
    write_json(&dir.path("summary.json"), &summary)?;
    let page = index_html(&ScmosPage {
        summary: &summary,
        fit: &fit,
        effective: &effective,
        comparison: &comparison,
        heatmaps: &heatmaps,
        scale: &scale,
        error_bars: &error_bars,
        has_ptc: gain.ptc.is_some(),
        out_dir: &o.out_dir,
    });
    write_atomic(&dir.path("index.html"), page.as_bytes())?;
    files.extend(["summary.json".into(), "index.html".into()]);
    Ok(ReportResult {
        summary: Summary::Scmos(Box::new(summary)),
        effective,
        comparison,
        pdf_fit: Some(fit),
        ptc: gain.ptc,
        out_dir: PathBuf::new(),
        files: files.into_iter().map(PathBuf::from).collect(),
    })
}

fn file_name(path: &std::path::Path) -> String {
    path.file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_default()
}

/// The gain: from photon transfer when flats are given, else the caller's; never guessed.
fn conversion_gain(o: &ReportOptions, maps: &DarkMaps) -> Result<Gain> {
    match o.gain_source()? {
        GainSource::Given(g) => Ok(Gain {
            e_per_adu: g,
            source: "given",
            se_e_per_adu: None,
            ptc: None,
            flat_inputs: Vec::new(),
        }),
        GainSource::PhotonTransfer => {
            let flats: Vec<FrameStack> = o
                .flats_paths
                .iter()
                .map(|f| FrameStack::open(std::slice::from_ref(f)))
                .collect::<Result<_>>()?;
            let dark = DarkReference::from_stats(&maps.stats);
            let p = photon_transfer(&flats, &dark, &PtcOptions::default())?;
            let flat_inputs = flats
                .iter()
                .map(|f| inputs(f, Checksum::Blake3))
                .collect::<Result<Vec<_>>>()?;
            Ok(Gain {
                e_per_adu: p.gain_e_per_adu,
                source: "ptc",
                se_e_per_adu: Some(p.gain_err_e_per_adu),
                ptc: Some(p),
                flat_inputs: flat_inputs.into_iter().flatten().collect(),
            })
        }
    }
}

/// The effective read noise of each model of [`EFFECTIVE_MODELS`] on every configuration, as
/// one stage of progress (both models' iterations), labelled as the page names them.
fn effective_tables(
    configs: &[SimConfig],
    params: &ModelParams,
    precision: &Precision,
    observer: &dyn Observer,
) -> Result<[Vec<EffectiveRecord>; 2]> {
    let specs = EFFECTIVE_MODELS.map(|(spec, _)| spec);
    // Records come model by model, each over every configuration.
    let mut records = effective_table(configs, &specs, params, precision, observer)?.into_iter();
    Ok(EFFECTIVE_MODELS.map(|(_, label)| {
        records
            .by_ref()
            .take(configs.len())
            .map(|r| EffectiveRecord {
                model: label.into(),
                ..r
            })
            .collect()
    }))
}

/// The grid's configurations at quantum efficiency `qe`, and the operating point's after them
/// when it is not `in_grid`.
fn with_point(grid: &Grid, op: &OperatingPoint, qe: f64, in_grid: bool) -> Vec<SimConfig> {
    let mut configs = grid.configs(qe);
    if !in_grid {
        configs.push(grid.config(op.subap_px, op.spot, op.signal_photons, qe));
    }
    configs
}

/// The headline numbers: both tables' records at the operating point (solved with them).
fn headline(
    at: ChosenPoint,
    op: &OperatingPoint,
    fitted: &[EffectiveRecord],
    measured: &[EffectiveRecord],
) -> Headline {
    let (f, m) = (at_point(fitted, op), at_point(measured, op));
    Headline {
        at,
        sigma_eff_fitted_pdf_e: f.sigma_eff_e,
        sigma_eff_fitted_pdf_se_e: f.sigma_eff_se_e,
        sigma_eff_fitted_pdf_status: f.status,
        sigma_eff_map_e: m.sigma_eff_e,
        sigma_eff_map_se_e: m.sigma_eff_se_e,
        sigma_eff_map_status: m.status,
    }
}

/// The solution at the operating point `op` among `records` (solved with the table).
fn at_point(records: &[EffectiveRecord], op: &OperatingPoint) -> Effective {
    records
        .iter()
        .find(|r| {
            let c = &r.config;
            c.subap_px == op.subap_px && c.spot == op.spot && c.signal_photons == op.signal_photons
        })
        .expect("the operating point is solved with the table")
        .effective
        .clone()
}
