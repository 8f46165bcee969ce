//! The calibration fits: `detnoise.fit_pdf` (the per-pixel read-noise distribution of a map)
//! and `detnoise.fit_emgain` (EM gain, bias, read noise and light level of EMCCD frames), each
//! a result object with its parameters, standard errors and `.to_dict()` (the JSON file the
//! command line writes).

use crate::calib::paths_of;
use crate::convert::{float_array, to_py};
use crate::errors::{invalid, IntoPy};
use crate::observer::observed;
use detnoise::fit::emgain::{fit_report, EmgainReport, EmgainRun};
use detnoise::fit::{fit_pdf, PdfFitOptions, PdfFitReport, PdfModel};
use numpy::PyArrayMethods;
use pyo3::prelude::*;
use std::path::PathBuf;

/// A fit of the per-pixel read-noise pdf: every model fitted, and the one chosen (lowest AIC).
/// Pass it as `pdf=` to `Readout`, `simulate` or `effective` to simulate with it.
#[pyclass(module = "detnoise._detnoise", name = "PdfFit", frozen)]
pub struct PdfFit {
    /// The content of pdf_fit.json.
    pub report: PdfFitReport,
}

impl PdfFit {
    fn model(&self, name: Option<&str>) -> PyResult<&detnoise::fit::ModelFit> {
        let name = name.unwrap_or(&self.report.best_model);
        self.report.models.get(name).ok_or_else(|| {
            let known: Vec<&str> = self.report.models.keys().map(String::as_str).collect();
            invalid(
                "model",
                format!("{name:?} was not fitted (fitted: {})", known.join(", ")),
            )
        })
    }
}

#[pymethods]
impl PdfFit {
    /// The parametric model with the lowest AIC.
    #[getter]
    fn best_model(&self) -> String {
        self.report.best_model.clone()
    }

    /// Names of the models fitted.
    #[getter]
    fn models(&self) -> Vec<String> {
        self.report.models.keys().cloned().collect()
    }

    /// Parameters of `model` (default the best), natural units (names carry them: `_e`).
    #[pyo3(signature = (model = None))]
    fn params<'py>(&self, py: Python<'py>, model: Option<&str>) -> PyResult<Bound<'py, PyAny>> {
        to_py(py, &self.model(model)?.params)
    }

    /// Standard errors of the parameters of `model` (None where the Hessian is not positive
    /// definite).
    #[pyo3(signature = (model = None))]
    fn param_se<'py>(&self, py: Python<'py>, model: Option<&str>) -> PyResult<Bound<'py, PyAny>> {
        to_py(py, &self.model(model)?.param_se)
    }

    /// Values used in the fit.
    #[getter]
    fn n_values(&self) -> usize {
        self.report.n_values
    }

    /// Upper cut of the support, e-.
    #[getter]
    fn upper_cut_e(&self) -> f64 {
        self.report.upper_cut_e
    }

    /// The fit as a dict: the content of the pdf_fit.json `detnoise fit-pdf` writes.
    fn to_dict<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        to_py(py, &self.report)
    }

    /// The plain-text summary `detnoise fit-pdf` prints.
    fn summary_text(&self) -> String {
        self.report.summary_text()
    }

    fn __repr__(&self) -> String {
        format!(
            "PdfFit(best_model={:?}, n_values={}, upper_cut_e={:.4})",
            self.report.best_model, self.report.n_values, self.report.upper_cut_e
        )
    }
}

/// Fit models of the per-pixel read-noise pdf to `rms_e` (an array of read noise, e- rms, any
/// shape; non-finite and non-positive values are left out), as `detnoise fit-pdf` does.
/// `flags`: an array of the same shape whose non-zero pixels are left out. `models`: names
/// among paper-scaled, paper-family, lognormal+tail, empirical (default all). `upper_cut_e`:
/// values above it are left out (default the largest value).
#[pyfunction]
#[pyo3(name = "fit_pdf")]
#[pyo3(signature = (rms_e, *, flags = None, models = None, upper_cut_e = None))]
pub fn fit_pdf_py(
    py: Python<'_>,
    rms_e: &Bound<'_, PyAny>,
    flags: Option<&Bound<'_, PyAny>>,
    models: Option<Vec<String>>,
    upper_cut_e: Option<f64>,
) -> PyResult<PdfFit> {
    let values = float_array(rms_e, "rms_e")?;
    let values = values.readonly();
    let values = values.as_slice()?;
    let kept: Vec<f64> = match flags {
        None => values.to_vec(),
        Some(f) => {
            let f = float_array(f, "flags")?;
            let f = f.readonly();
            let f = f.as_slice()?;
            if f.len() != values.len() {
                return Err(invalid(
                    "flags",
                    format!("{} values for {} read-noise values", f.len(), values.len()),
                ));
            }
            values
                .iter()
                .zip(f)
                .filter(|(_, &flag)| flag == 0.0)
                .map(|(&v, _)| v)
                .collect()
        }
    };
    let options = PdfFitOptions {
        models: match models {
            Some(m) if !m.is_empty() => PdfModel::parse_list(&m).py()?,
            _ => PdfModel::ALL.to_vec(),
        },
        upper_cut_e,
    };
    let report = observed(py, None, |_| fit_pdf(&kept, &options))?;
    Ok(PdfFit { report })
}

/// An EM-gain fit of EMCCD frames: EM gain, bias, read noise and light level with standard
/// errors, and its cross-checks.
#[pyclass(module = "detnoise._detnoise", name = "EmGainFit", frozen)]
pub struct PyEmGainFit {
    report: EmgainReport,
}

#[pymethods]
impl PyEmGainFit {
    /// EM gain, in `em_gain_units` (e-/e- with a conversion gain, else adu/e-).
    #[getter]
    fn em_gain(&self) -> f64 {
        self.report.fit.em_gain
    }

    /// Standard error of `em_gain`.
    #[getter]
    fn em_gain_se(&self) -> f64 {
        self.report.fit.em_gain_se
    }

    /// "e-/e-" or "adu/e-".
    #[getter]
    fn em_gain_units(&self) -> String {
        self.report.fit.em_gain_units.clone()
    }

    /// Bias, adu.
    #[getter]
    fn bias_adu(&self) -> f64 {
        self.report.fit.bias_adu
    }

    /// Standard error of `bias_adu`, adu.
    #[getter]
    fn bias_adu_se(&self) -> f64 {
        self.report.fit.bias_adu_se
    }

    /// Read noise, adu rms.
    #[getter]
    fn read_noise_adu(&self) -> f64 {
        self.report.fit.read_noise_adu
    }

    /// Standard error of `read_noise_adu`, adu.
    #[getter]
    fn read_noise_adu_se(&self) -> f64 {
        self.report.fit.read_noise_adu_se
    }

    /// Mean input electrons per pixel-sample (photo + dark + parallel CIC), e-.
    #[getter]
    fn lambda_e(&self) -> f64 {
        self.report.fit.lambda_e
    }

    /// Standard error of `lambda_e`, e-.
    #[getter]
    fn lambda_e_se(&self) -> f64 {
        self.report.fit.lambda_e_se
    }

    /// The fit as a dict: the content of the emgain.json `detnoise emgain` writes.
    fn to_dict<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        to_py(py, &self.report)
    }

    /// The plain-text summary `detnoise emgain` prints.
    fn summary_text(&self) -> String {
        self.report.summary_text()
    }

    fn __repr__(&self) -> String {
        let f = &self.report.fit;
        format!(
            "EmGainFit(em_gain={:.4} +- {:.4} {}, bias_adu={:.3}, read_noise_adu={:.3}, lambda_e={:.5})",
            f.em_gain, f.em_gain_se, f.em_gain_units, f.bias_adu, f.read_noise_adu, f.lambda_e
        )
    }
}

/// Fit bias, read noise, EM gain and light level to EMCCD frames (`paths`: files,
/// directories or globs), as `detnoise emgain` does. `gain_e_per_adu` (or `gain_map`, a file)
/// reports the gain in e-/e-; `offset` (a bias map file, adu) is subtracted per pixel;
/// `read_noise` (a map file, adu, with `offset`) holds bias and read noise fixed; `stages`
/// sets the register's stages (default 604: the exact register with a conversion gain, else a
/// Gamma law with its F^2); `serial_cic` None fits with and without serial CIC and keeps the
/// one the BIC prefers, True or False forces it; `reference_stack` with `reference_offset` adds the
/// ratio-of-means cross-check.
#[pyfunction]
#[pyo3(name = "fit_emgain")]
#[pyo3(signature = (paths, *, gain_e_per_adu = None, gain_map = None, offset = None, read_noise = None, stages = None, serial_cic = None, max_value_adu = None, bin_width_adu = None, reference_stack = None, reference_offset = None))]
#[allow(clippy::too_many_arguments)]
pub fn fit_emgain_py(
    py: Python<'_>,
    paths: &Bound<'_, PyAny>,
    gain_e_per_adu: Option<f64>,
    gain_map: Option<PathBuf>,
    offset: Option<PathBuf>,
    read_noise: Option<PathBuf>,
    stages: Option<u32>,
    serial_cic: Option<bool>,
    max_value_adu: Option<f64>,
    bin_width_adu: Option<f64>,
    reference_stack: Option<&Bound<'_, PyAny>>,
    reference_offset: Option<PathBuf>,
) -> PyResult<PyEmGainFit> {
    let positive = |name: &str, v: Option<f64>, unit: &str| match v {
        Some(x) if !(x > 0.0 && x.is_finite()) => {
            Err(invalid(name, format!("{x}: must be a number > 0 {unit}")))
        }
        _ => Ok(()),
    };
    positive("gain_e_per_adu", gain_e_per_adu, "e- per adu")?;
    positive("bin_width_adu", bin_width_adu, "adu")?;
    if max_value_adu.is_some_and(|v| !v.is_finite()) {
        return Err(invalid("max_value_adu", "must be a finite number (adu)"));
    }
    let job = EmgainRun {
        stack: paths_of(paths)?,
        gain_e_per_adu,
        gain_map,
        offset,
        read_noise,
        stages,
        serial_cic: serial_cic == Some(true),
        no_serial_cic: serial_cic == Some(false),
        max_value_adu,
        bin_width_adu,
        reference_stack: reference_stack
            .map(paths_of)
            .transpose()?
            .unwrap_or_default(),
        reference_offset,
        ..EmgainRun::default()
    };
    if let Some(s) = stages {
        detnoise::detector::EmRegister::check(1.0, s, "em_gain").py()?;
    }
    let (report, _) = observed(py, None, |_| fit_report(&job))?;
    Ok(PyEmGainFit { report })
}
