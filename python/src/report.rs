//! `detnoise.report`: the end-to-end detector report (darks and flats in, effective read noise
//! out), written to its output directory as `detnoise report` writes it, and returned as a
//! `Report` with the key numbers, the tables and the files.

use crate::convert::{one_or_many, subap_px_item, to_py, SIGNAL_ITEM};
use crate::errors::{invalid, IntoPy};
use crate::fit::PdfFit;
use crate::observer::observed;
use crate::params::{given_values, params_of};
use crate::sim::{centroiders_of, checked, sampling_of, spots_of, whole};
use detnoise::effective::Precision;
use detnoise::report::{DetectorKind, OperatingPoint, ReportOptions, ReportResult, Summary};
use detnoise::settings::{self, Value};
use detnoise::subaps::{Geometry, GridSpec, ValidMask};
use pyo3::prelude::*;
use pyo3::types::PyDict;
use std::path::PathBuf;

/// The result of a report: what its summary.json, effective_noise.json and r_vs_signal.csv
/// hold, and the files written.
#[pyclass(module = "detnoise._detnoise", name = "Report", frozen)]
pub struct Report {
    result: ReportResult,
}

#[pymethods]
impl Report {
    /// The key numbers: the content of summary.json.
    #[getter]
    fn summary<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        match &self.result.summary {
            Summary::Scmos(s) => to_py(py, s),
            Summary::Emccd(s) => to_py(py, s),
        }
    }

    /// Effective read noise per configuration (records, e-): the fitted pdf's, then the
    /// measured map's (sCMOS; empty for an EMCCD).
    #[getter]
    fn effective<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        to_py(py, &self.result.effective)
    }

    /// R (px) against signal at the operating sub-aperture and spot, one record per compared
    /// model and signal.
    #[getter]
    fn comparison<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        let records: Vec<_> = self.result.comparison.iter().map(|c| &c.record).collect();
        to_py(py, &records)
    }

    /// The fit of the per-pixel read-noise pdf (sCMOS), or None.
    #[getter]
    fn pdf_fit(&self) -> Option<PdfFit> {
        self.result.pdf_fit.clone().map(|report| PdfFit { report })
    }

    /// The output directory.
    #[getter]
    fn out_dir(&self) -> PathBuf {
        self.result.out_dir.clone()
    }

    /// Every file written (index.html, the tables, charts and maps).
    #[getter]
    fn files(&self) -> Vec<PathBuf> {
        self.result.files.clone()
    }

    /// Summary, effective and comparison records, pdf fit and files as one dict.
    fn to_dict<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        let d = PyDict::new(py);
        d.set_item("summary", self.summary(py)?)?;
        d.set_item("effective", self.effective(py)?)?;
        d.set_item("comparison", self.comparison(py)?)?;
        d.set_item(
            "pdf_fit",
            self.result
                .pdf_fit
                .as_ref()
                .map(|f| to_py(py, f))
                .transpose()?,
        )?;
        d.set_item("out_dir", self.out_dir())?;
        d.set_item("files", self.files())?;
        Ok(d.into_any())
    }

    fn __repr__(&self) -> String {
        format!(
            "Report(out_dir={:?}, {} files)",
            self.result.out_dir.display().to_string(),
            self.result.files.len()
        )
    }
}

/// The end-to-end detector report, as `detnoise report` writes it into `out` (index.html,
/// maps, tables, charts; written only when the whole report succeeds). `darks`: dark frames
/// (files, a directory or a glob); `flats`: one stack per light level for photon transfer, or
/// give `gain_e_per_adu`. Lists left None take the full grid, or with `quick` the preview.
#[pyfunction]
#[pyo3(signature = (
    darks, *, out, flats = None, detector = "scmos", force = false, quick = false,
    subap_px = None, spot = None, signal_photons = None, operating_point = None, iters = 10_000,
    target_se_e = Precision::DEFAULT_TARGET_SE_E, target_rel = Precision::DEFAULT_TARGET_REL,
    max_iters = None, seed = 1, sampling = "integrated", qe = 1.0, qe_emccd = 1.0,
    accept_illuminated = false, centroider = None, mask_above = None,
    centroider_full_grid = false, subap_grid = None, subap_mask = None, progress = None,
    **params
))]
#[allow(clippy::too_many_arguments)]
pub fn report<'py>(
    py: Python<'py>,
    darks: &Bound<'py, PyAny>,
    out: PathBuf,
    flats: Option<Vec<PathBuf>>,
    detector: &str,
    force: bool,
    quick: bool,
    subap_px: Option<&Bound<'py, PyAny>>,
    spot: Option<&Bound<'py, PyAny>>,
    signal_photons: Option<&Bound<'py, PyAny>>,
    operating_point: Option<&str>,
    iters: i128,
    target_se_e: f64,
    target_rel: f64,
    max_iters: Option<u64>,
    seed: i128,
    sampling: &str,
    qe: f64,
    qe_emccd: f64,
    accept_illuminated: bool,
    centroider: Option<&Bound<'py, PyAny>>,
    mask_above: Option<f64>,
    centroider_full_grid: bool,
    subap_grid: Option<&str>,
    subap_mask: Option<PathBuf>,
    progress: Option<Py<PyAny>>,
    params: Option<&Bound<'py, PyDict>>,
) -> PyResult<Report> {
    checked(&settings::DETECTOR, Value::Text(detector.into()))?;
    checked(&settings::QE_EMCCD, Value::Real(qe_emccd))?;
    let detector = match detector {
        "emccd" => DetectorKind::Emccd,
        _ => DetectorKind::Scmos,
    };
    let (iters, seed) = (
        whole(&settings::ITERS, iters)?,
        whole(&settings::SEED, seed)?,
    );
    let mut options = ReportOptions {
        detector,
        darks_paths: crate::calib::paths_of(darks)?,
        flats_paths: flats.unwrap_or_default(),
        subaps_px: subap_px
            .map(|v| one_or_many(v, "subap_px", &subap_px_item()))
            .transpose()?,
        spots: spot.map(spots_of).transpose()?,
        signals_photons: signal_photons
            .map(|v| one_or_many(v, "signal_photons", SIGNAL_ITEM))
            .transpose()?,
        operating_point: operating_point
            .map(OperatingPoint::parse)
            .transpose()
            .py()?,
        iters,
        precision: Precision {
            target_se_e,
            target_rel,
            max_iters: max_iters.unwrap_or(Precision::DEFAULT_MAX_ITERS.max(iters)),
        },
        seed,
        sampling: sampling_of(sampling)?,
        qe,
        qe_emccd,
        accept_illuminated,
        quick,
        out_dir: out,
        force,
        ..ReportOptions::default()
    };
    // A report runs every registered centroider unless told otherwise (the command line's
    // default).
    if let Some(c) = centroider {
        options.centroiders = centroiders_of(c, mask_above)?;
    } else if mask_above.is_some() {
        let all = detnoise::centroid::centroider_names().into_pyobject(py)?;
        options.centroiders = centroiders_of(all.as_any(), mask_above)?;
    }
    options.centroider_full_grid = centroider_full_grid;
    if let Some(grid) = subap_grid {
        let grid = GridSpec::parse(grid).py()?;
        let mask = subap_mask
            .as_deref()
            .map(ValidMask::read)
            .transpose()
            .py()?;
        options.subaps = Some(Geometry { grid, mask });
    } else if subap_mask.is_some() {
        return Err(invalid("subap_mask", "applies only with `subap_grid`"));
    }
    // Every option is checked before any file is read, as on the command line: the register
    // and the conversion gain first, from the values given.
    let values = given_values(params)?;
    options.model_params.em_gain = values.real(&settings::EM_GAIN).expect("has a default");
    options.model_params.stages = values.whole(&settings::STAGES).expect("has a default") as u32;
    options.gain_e_per_adu = values.real(&settings::GAIN_E_PER_ADU);
    options.model_input_paths.extend(subap_mask);
    options.validate().py()?;
    let p = params_of(py, values)?;
    options.model_params = p.model;
    options.model_input_paths.extend(p.input_files);
    let result = observed(py, progress, |o| detnoise::report::run(&options, o))?;
    Ok(Report { result })
}
