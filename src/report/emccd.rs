//! The EMCCD report: the EM-gain fit on the frames' histogram (exact register), R against
//! signal for an EMCCD with the fitted gain and read noise beside sCMOS models, and the simple
//! model's effective QE factor over the grid (`qe_factor`).

use super::camera::{section as camera_section, CAMERA_FILES};
use super::compare::{
    compare_models, emccd_groups, emccd_labels, write_comparison, COMPARISON_FILES,
};
use super::grid::Grid;
use super::options::{GainSource, ReportOptions};
use super::page::{emccd_html, PAGE_FILES};
use super::point::ChosenPoint;
use super::qe_factor::{html_section, QeSummary};
use super::result::{EmccdSummary, ReportInput, ReportResult, Summary};
use crate::calib::summary::{inputs, Checksum};
use crate::charts::qe_factor::{chart_stem, save_chart};
use crate::detector::{EmRegister, ModelSpec};
use crate::effective::{effective_qe_table, write_qe_tables, QePrecision, QE_TABLE_NAMES};
use crate::fit::emgain::require_em_signature;
use crate::fit::emgain::{accumulate as emgain_histogram, chart as emgain_chart};
use crate::fit::emgain::{fit_emgain, EmGainOptions, EmShape};
use crate::io::FrameStack;
use crate::output::{write_atomic, write_json, OutputDir};
use crate::progress::Observer;
use crate::{Error, Result};
use std::path::PathBuf;

/// The EM-gain fit's chart.
const EMGAIN_FILES: [&str; 1] = ["emgain.png"];

/// The effective QE factor's charts, one per spot (see [`chart_stem`]).
const QE_CHART_FILES: [&str; 2] = ["effective_qe_*.png", "effective_qe_*.svg"];

/// The files an EMCCD report may write (glob patterns), part by part.
pub(super) fn outputs() -> impl Iterator<Item = &'static str> {
    EMGAIN_FILES
        .into_iter()
        .chain(COMPARISON_FILES)
        .chain(QE_TABLE_NAMES)
        .chain(QE_CHART_FILES)
        .chain(CAMERA_FILES)
        .chain(PAGE_FILES)
}

/// Run the EMCCD report on `stack` into `dir`; `files` of the result are names inside `dir`.
pub(crate) fn run(
    o: &ReportOptions,
    grid: &Grid,
    stack: &FrameStack,
    dir: &OutputDir,
    observer: &dyn Observer,
) -> Result<ReportResult> {
    let GainSource::Given(conv) = o.gain_source()? else {
        return Err(Error::invalid(
            "flats_paths",
            "an EMCCD report takes no flats",
        ));
    };
    require_em_signature(stack)?;
    let (hist, _) = emgain_histogram(stack, None, None)?;
    let opts = EmGainOptions {
        shape: Some(EmShape::Register {
            stages: o.model_params.stages,
        }),
        gain_e_per_adu: Some(conv),
        ..EmGainOptions::default()
    };
    // A fit that fails on these frames is bad data in the stack, not a programming error.
    let fit = fit_emgain(&hist, &opts).map_err(|e| match e {
        Error::Numeric(m) => Error::input(&stack.sources[0].path, m),
        other => other,
    })?;
    emgain_chart(&hist, &fit, &dir.path(EMGAIN_FILES[0]))?;
    let mut params = o.model_params.clone();
    params.em_gain = fit.em_gain.max(1.0);
    params.emccd_read_noise_e = fit.read_noise_adu * conv;
    EmRegister::check(params.em_gain, params.stages, "em_gain").map_err(|e| {
        Error::input(
            &stack.sources[0].path,
            format!("the fitted EM gain cannot be simulated: {e}"),
        )
    })?;
    let op = o.operating_point();
    let comparison = compare_models(grid, &op, &params, &emccd_groups(o.qe, o.qe_emccd))?;
    let error_bars = write_comparison(&comparison, dir, &emccd_labels(&params))?;
    // The comparison runs at the point's sub-aperture and spot over the grid's signals and the
    // point's, whether or not the point is one of the grid's configurations.
    let operating_point = ChosenPoint::new(&op, o.operating_point.is_some(), grid.contains(&op));
    // The simple model's effective QE factor over the grid, at the EMCCD's QE, with the
    // effective noise's relative target and cap.
    let precision = QePrecision::with(&o.precision_in_use(), QePrecision::DEFAULT_TARGET_SE);
    let qe_records = effective_qe_table(
        &grid.configs(o.qe_emccd),
        &[ModelSpec::EmccdStochastic],
        &params,
        &precision,
        observer,
    )?;
    write_qe_tables(&qe_records, &dir.path(""))?;
    let qe_charts = save_chart(&qe_records, &op.spot, dir)?;
    let qe_summary = QeSummary::new(&qe_records, (op.subap_px, op.spot, op.signal_photons));
    let qe_chart_png = (!qe_charts.is_empty()).then(|| format!("{}.png", chart_stem(&op.spot)));
    let qe_html = html_section(&qe_records, &qe_summary, qe_chart_png.as_deref());
    let (camera, camera_files) = match camera_section(o, grid, &op, dir, observer)? {
        Some((s, names)) => (Some(s), names),
        None => (None, Vec::new()),
    };
    let summary = EmccdSummary {
        tool: format!("detnoise {}", env!("CARGO_PKG_VERSION")),
        inputs: ReportInput::all("darks", inputs(stack, Checksum::Blake3)?).collect(),
        frames: stack.frames,
        shape: [stack.shape.0, stack.shape.1],
        gain_e_per_adu: conv,
        read_noise_output_e: params.emccd_read_noise_e,
        emgain: fit,
        operating_point,
        iters: grid.iters,
        seed: grid.seed,
        quick: o.quick,
        effective_qe: qe_summary,
        effective_qe_records: qe_records,
        camera,
    };
    let [json, html] = PAGE_FILES;
    write_json(&dir.path(json), &summary)?;
    write_atomic(
        &dir.path(html),
        emccd_html(&summary, &comparison, &error_bars, &qe_html).as_bytes(),
    )?;
    let qe_files = qe_charts
        .iter()
        .filter_map(|p| p.file_name().map(PathBuf::from));
    let files = EMGAIN_FILES
        .into_iter()
        .chain(COMPARISON_FILES)
        .chain(QE_TABLE_NAMES)
        .chain(PAGE_FILES)
        .chain(camera_files)
        .map(PathBuf::from)
        .chain(qe_files)
        .collect();
    Ok(ReportResult {
        summary: Summary::Emccd(Box::new(summary)),
        effective: Vec::new(),
        comparison,
        pdf_fit: None,
        ptc: None,
        out_dir: PathBuf::new(),
        files,
    })
}
