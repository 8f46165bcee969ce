//! The sCMOS report: dark maps, conversion gain, the fitted per-pixel noise distribution, the
//! effective read noise over the grid (fitted pdf and measured map), the camera's noise beyond
//! Gaussian pixels, the per-sub-aperture map, the centroiders, the comparison, and the page.

mod darks;
mod effective;

use super::camera::{CameraSection, CAMERA_FILES};
use super::centroiders::CENTROIDER_FILES;
use super::centroiders::{centroider_section, Centroiders, Inputs as CentroiderInputs};
use super::compare::COMPARISON_FILES;
use super::compare::{compare_models, scmos_groups, scmos_labels, write_comparison};
use super::grid::Grid;
use super::options::ReportOptions;
use super::page::{index_html, ScmosPage, PAGE_FILES};
use super::point::OperatingPoint;
use super::real_noise::REAL_NOISE_FILES;
use super::real_noise::{measured_inputs, real_noise_rows, rts_series_chart, RealNoise};
use super::result::{Compared, Headline, ReportInput, ReportResult, ReportSummary, Summary};
use crate::detector::ModelParams;
use crate::effective::Effective;
use crate::fit::pdf_fit::PdfFitReport;
use crate::io::FrameStack;
use crate::output::{write_atomic, write_csv_json, write_json, OutputDir};
use crate::progress::Observer;
use crate::subaps::SubapsSummary;
use crate::Result;
use darks::Darks;
use effective::Table;
use std::path::PathBuf;

/// The files an sCMOS report may write (glob patterns), part by part; the per-sub-aperture
/// map's are the caller's to add (only with a lenslet geometry).
pub(super) fn outputs() -> impl Iterator<Item = &'static str> {
    darks::outputs()
        .chain(effective::outputs())
        .chain(REAL_NOISE_FILES)
        .chain(CENTROIDER_FILES)
        .chain(COMPARISON_FILES)
        .chain(CAMERA_FILES)
        .chain(PAGE_FILES)
}

/// One sCMOS report under way: its settings, where it writes, and the names written so far.
struct Job<'a> {
    o: &'a ReportOptions,
    grid: &'a Grid,
    op: OperatingPoint,
    dir: &'a OutputDir,
    observer: &'a dyn Observer,
    files: Vec<String>,
}

/// The parts of summary.json computed after the darks and the fit.
struct Parts {
    operating_point: Headline,
    real_noise: RealNoise,
    subaps: Option<SubapsSummary>,
    centroiders: Centroiders,
    camera: Option<CameraSection>,
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
    let mut job = Job {
        o,
        grid,
        op: o.operating_point(),
        dir,
        observer,
        files: Vec::new(),
    };
    let d = darks::calibrate(o, stack, dir, observer)?;
    job.files.extend(d.summary.outputs.iter().cloned());
    let (fit, names) = darks::fit_noise(&d.values, dir)?;
    job.wrote(names);
    let mut params = o.model_params.clone();
    params.pdf = fit.pdf(None)?;
    params.map = Some(d.rms_e.clone());
    let dark_frames = measured_inputs(
        &mut params,
        &o.darks_paths,
        d.gain.e_per_adu,
        &d.summary.temporal_noise,
        (&dir.path("rts.csv"), d.summary.rts.ok),
        observer,
    )?;
    let precision = o.precision_in_use();
    let op = (&job.op, o.operating_point.is_some());
    let solved = effective::solve(grid, op, o.qe, &params, &precision, observer)?;
    let real_noise = job.real_noise(&params, &solved.at_point, &d, stack.shape.1, dark_frames)?;
    let operating_point = solved.headline.clone();
    let (table, names) = solved.write(dir)?;
    job.files.extend(names);
    let parts = Parts {
        operating_point,
        real_noise,
        subaps: job.subaps(&params)?,
        centroiders: job.centroiders(&params, fit.data.median_e, &table.effective)?,
        camera: job.camera()?,
    };
    let comparison = compare_models(grid, &job.op, &params, &scmos_groups(o.qe, o.qe_emccd))?;
    let error_bars = write_comparison(&comparison, dir, &scmos_labels(&params))?;
    job.wrote(COMPARISON_FILES);
    job.wrote(darks::write_ptc(&d.gain, dir)?);
    let summary = job.summary(stack, &d, &fit, parts);
    let has_ptc = d.gain.ptc.is_some();
    job.page(&summary, &fit, &table, (&comparison, &error_bars), has_ptc)?;
    Ok(ReportResult {
        summary: Summary::Scmos(Box::new(summary)),
        effective: table.effective,
        comparison,
        pdf_fit: Some(fit),
        ptc: d.gain.ptc,
        out_dir: PathBuf::new(),
        files: job.files.into_iter().map(PathBuf::from).collect(),
    })
}

impl Job<'_> {
    /// Record `names` as written.
    fn wrote<'n>(&mut self, names: impl IntoIterator<Item = &'n str>) {
        self.files.extend(names.into_iter().map(String::from));
    }

    /// The camera's noise beyond Gaussian pixels at the operating point: the richer models
    /// beside the measured map (`at_point`: fitted pdf, map), its table and the example
    /// telegraph series (frames `cols` px wide) when there are any; `dark_frames` describes
    /// the frames scmos-frames read.
    fn real_noise(
        &mut self,
        params: &ModelParams,
        at_point: &(Effective, Effective),
        d: &Darks,
        cols: usize,
        dark_frames: String,
    ) -> Result<RealNoise> {
        let (o, op) = (self.o, &self.op);
        let op_cfg = self
            .grid
            .config(op.subap_px, op.spot, op.signal_photons, o.qe);
        let (fitted, map) = at_point;
        let rows = real_noise_rows(
            &op_cfg,
            params,
            (fitted, map),
            &o.precision_in_use(),
            self.observer,
        )?;
        let [csv, json, series] = REAL_NOISE_FILES;
        write_csv_json(&rows, &self.dir.path(""), [csv, json])?;
        self.wrote([csv, json]);
        if !d.summary.rts.example_pixels.is_empty() {
            let path = self.dir.path(series);
            rts_series_chart(&d.maps.rts, cols, d.gain.e_per_adu, &path)?;
            self.wrote([series]);
        }
        Ok(RealNoise {
            temporal_noise: d.summary.temporal_noise.clone(),
            rts: d.summary.rts.clone(),
            dark_frames: Some(dark_frames),
            rows,
        })
    }

    /// The per-sub-aperture map of the measured map, with a lenslet geometry.
    fn subaps(&mut self, params: &ModelParams) -> Result<Option<SubapsSummary>> {
        let (Some(geometry), Some(map)) = (&self.o.subaps, params.map.as_deref()) else {
            return Ok(None);
        };
        let (summary, names) = super::subaps::subaps_section(
            self.o,
            self.grid,
            geometry,
            map,
            self.dir,
            self.observer,
        )?;
        self.files.extend(names);
        Ok(Some(summary))
    }

    /// The camera read through each centroider; `solved` is the effective table (its `cog`
    /// values are reused), `median_rms_e` the camera's median read noise (e⁻).
    fn centroiders(
        &mut self,
        params: &ModelParams,
        median_rms_e: f64,
        solved: &[crate::effective::EffectiveRecord],
    ) -> Result<Centroiders> {
        let o = self.o;
        let inputs = CentroiderInputs {
            grid: self.grid,
            op: &self.op,
            params,
            centroiders: &o.centroiders,
            qe: (o.qe, o.qe_emccd),
            median_rms_e,
            precision: &o.precision_in_use(),
            full_grid: o.centroider_full_grid,
            solved,
        };
        let c = centroider_section(&inputs, &self.dir.path(""), self.observer)?;
        self.wrote(CENTROIDER_FILES);
        Ok(c)
    }

    /// The camera model of `--camera` at its operating point, when given.
    fn camera(&mut self) -> Result<Option<CameraSection>> {
        let section = super::camera::section(self.o, self.grid, &self.op, self.dir, self.observer)?;
        Ok(section.map(|(s, names)| {
            self.wrote(names);
            s
        }))
    }

    /// summary.json's content.
    fn summary(
        &self,
        stack: &FrameStack,
        d: &Darks,
        fit: &PdfFitReport,
        parts: Parts,
    ) -> ReportSummary {
        let mut inputs: Vec<ReportInput> =
            ReportInput::all("darks", d.summary.inputs.clone()).collect();
        inputs.extend(ReportInput::all("flats", d.gain.flat_inputs.clone()));
        ReportSummary {
            tool: format!("detnoise {}", env!("CARGO_PKG_VERSION")),
            inputs,
            frames: stack.frames,
            shape: [stack.shape.0, stack.shape.1],
            gain_e_per_adu: d.gain.e_per_adu,
            gain_source: d.gain.source.into(),
            gain_se_e_per_adu: d.gain.se_e_per_adu,
            pixels_used: d.values.len(),
            pixels_flagged: d.maps.flags.iter().filter(|f| **f != 0).count(),
            median_rms_e: fit.data.median_e,
            mean_rms_e: fit.data.mean_e,
            rms_rms_e: fit.data.rms_e,
            frac_above_3x_median: fit.data.frac_above_3x_median,
            pdf_best_model: fit.best_model.clone(),
            split_half_correlation: d.maps.split_half_correlation,
            operating_point: parts.operating_point,
            iters: self.grid.iters,
            seed: self.grid.seed,
            sampling: self.grid.sampling.label().into(),
            quick: self.o.quick,
            real_noise: parts.real_noise,
            subaps: parts.subaps,
            centroiders: parts.centroiders,
            camera: parts.camera,
        }
    }

    /// Write summary.json and the page; `comparison` is R against signal per model and what
    /// its chart's caption says of the error bars; `has_ptc`: photon transfer gave the gain.
    fn page(
        &mut self,
        summary: &ReportSummary,
        fit: &PdfFitReport,
        table: &Table,
        (comparison, error_bars): (&[Compared], &str),
        has_ptc: bool,
    ) -> Result<()> {
        let [json, html] = PAGE_FILES;
        write_json(&self.dir.path(json), summary)?;
        let page = index_html(&ScmosPage {
            summary,
            fit,
            effective: &table.effective,
            comparison,
            heatmaps: &table.heatmaps,
            scale: &table.scale,
            error_bars,
            has_ptc,
            out_dir: &self.o.out_dir,
        });
        write_atomic(&self.dir.path(html), page.as_bytes())?;
        self.wrote(PAGE_FILES);
        Ok(())
    }
}
