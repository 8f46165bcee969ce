//! The readout-model parameters as Python keywords (`em_gain=1000, map_e=rms_e, ...`): parsed
//! into the library's [`ModelParams`], each value checked against the range the command line
//! accepts for the same setting.

use crate::convert::map_from;
use crate::errors::{invalid, IntoPy};
use crate::fit::PdfFit;
use crate::observer::PyObserver;
use detnoise::calib::{Map, Unit};
use detnoise::detector::dark_frames::DEFAULT_MAX_MIB;
use detnoise::detector::pp::PpRule;
use detnoise::detector::{DarkFrames, EmRegister, ModelParams, RtsTable};
use detnoise::progress::Observer;
use pyo3::exceptions::PyTypeError;
use pyo3::prelude::*;
use pyo3::types::PyDict;
use std::path::PathBuf;
use std::sync::Arc;

/// The keywords of the readout-model parameters, in the order of the documentation.
pub const KEYWORDS: &[&str] = &[
    "em_gain",
    "stages",
    "emccd_read_noise_e",
    "gaussian_switch_e",
    "register",
    "sigma_e",
    "pdf",
    "pdf_model",
    "pattern_seed",
    "map_e",
    "pp_rule",
    "pp_lambda",
    "rts_table",
    "row_noise_e",
    "column_noise_e",
    "dark_frames",
    "dark_frames_max_mib",
    "gain_e_per_adu",
];

/// The parameters of a run: the models' and the conversion gain (which converts dark frames,
/// and a `Readout`'s output to adu).
pub struct Params {
    /// The readout models' parameters.
    pub model: ModelParams,
    /// Conversion gain, e- per adu, if given.
    pub gain_e_per_adu: Option<f64>,
    /// The files the parameters were read from (never to be overwritten by an output).
    pub input_files: Vec<PathBuf>,
}

/// The parameters given as `**params`, the others at the library's defaults. Unknown keywords
/// are a `TypeError`, as for any Python function; values out of range a `ValueError`. The
/// warnings of the files read (skipped rows of an RTS table) are issued as Python warnings.
pub fn read_params(py: Python<'_>, params: Option<&Bound<'_, PyDict>>) -> PyResult<Params> {
    let observer = PyObserver::new(None);
    let empty = PyDict::new(py);
    let p = Given::new(params.unwrap_or(&empty)).and_then(|g| g.params(&observer));
    observer.finish(py, Ok(()))?;
    p
}

/// The keyword arguments, checked for unknown names.
struct Given<'a, 'py> {
    dict: &'a Bound<'py, PyDict>,
}

impl<'a, 'py> Given<'a, 'py> {
    fn new(dict: &'a Bound<'py, PyDict>) -> PyResult<Self> {
        for key in dict.keys() {
            let key: String = key.extract()?;
            if !KEYWORDS.contains(&key.as_str()) {
                return Err(PyTypeError::new_err(format!(
                    "unexpected keyword argument '{key}'; readout-model parameters are: {}",
                    KEYWORDS.join(", ")
                )));
            }
        }
        Ok(Given { dict })
    }

    /// The value of `key`, None when absent or None.
    fn get(&self, key: &str) -> PyResult<Option<Bound<'py, PyAny>>> {
        Ok(self.dict.get_item(key)?.filter(|v| !v.is_none()))
    }

    /// A number, with a `ValueError` naming `key` when it is not one.
    fn number<T>(&self, key: &str) -> PyResult<Option<T>>
    where
        T: for<'b> FromPyObject<'b, 'py>,
    {
        match self.get(key)? {
            None => Ok(None),
            Some(v) => v
                .extract::<T>()
                .map(Some)
                .map_err(|_| invalid(key, format!("{}: not a number of the right kind", repr(&v)))),
        }
    }

    /// A real number within `ok` (described as `range` in the message).
    fn real(&self, key: &str, ok: impl Fn(f64) -> bool, range: &str) -> PyResult<Option<f64>> {
        match self.number::<f64>(key)? {
            Some(v) if !(v.is_finite() && ok(v)) => {
                Err(invalid(key, format!("{v}: must be a number {range}")))
            }
            v => Ok(v),
        }
    }

    /// A text value among `allowed`.
    fn choice(&self, key: &str, allowed: &[&str]) -> PyResult<Option<String>> {
        match self.get(key)? {
            None => Ok(None),
            Some(v) => match v.extract::<String>() {
                Ok(s) if allowed.contains(&s.as_str()) => Ok(Some(s)),
                _ => Err(invalid(
                    key,
                    format!("{}: must be one of {}", repr(&v), allowed.join(", ")),
                )),
            },
        }
    }

    /// A path (str or os.PathLike).
    fn path(&self, key: &str) -> PyResult<Option<PathBuf>> {
        self.get(key)?.map(|v| v.extract::<PathBuf>()).transpose()
    }

    fn params(&self, observer: &dyn Observer) -> PyResult<Params> {
        let d = ModelParams::default();
        let em_gain = self.real("em_gain", |_| true, "")?.unwrap_or(d.em_gain);
        let stages = self.number::<u32>("stages")?.unwrap_or(d.stages);
        EmRegister::check(em_gain, stages, "em_gain").py()?;
        let non_negative = |k| self.real(k, |v| v >= 0.0, ">= 0 e-");
        let positive = |k, unit| self.real(k, |v| v > 0.0, unit);
        let gain_e_per_adu = positive("gain_e_per_adu", "> 0 e- per adu")?;
        let pp_rule = match self.choice("pp_rule", &["poisson-prior", "equal-density"])? {
            Some(s) if s == "equal-density" => PpRule::EqualDensity,
            _ => d.pp_rule,
        };
        let model = ModelParams {
            em_gain,
            stages,
            emccd_read_noise_e: non_negative("emccd_read_noise_e")?.unwrap_or(d.emccd_read_noise_e),
            gaussian_switch_e: self.number::<u32>("gaussian_switch_e")?,
            cascade_register: self.choice("register", &["exact", "cascade"])?.as_deref()
                == Some("cascade"),
            sigma_e: non_negative("sigma_e")?.unwrap_or(d.sigma_e),
            pdf: self.pdf()?.unwrap_or(d.pdf),
            pattern_seed: self
                .number::<u64>("pattern_seed")?
                .unwrap_or(d.pattern_seed),
            map: self.map()?.map(Arc::new),
            pp_rule,
            pp_lambda: positive("pp_lambda", "> 0 photo-electrons per pixel")?,
            rts_table: self
                .path("rts_table")?
                .map(|p| RtsTable::read(&p, observer).map(Arc::new))
                .transpose()
                .py()?,
            row_noise_e: non_negative("row_noise_e")?,
            column_noise_e: non_negative("column_noise_e")?,
            dark_frames: self.dark_frames(gain_e_per_adu)?,
        };
        let mut input_files: Vec<PathBuf> = ["pdf", "map_e", "rts_table"]
            .iter()
            .filter_map(|k| self.path(k).ok().flatten())
            .filter(|p| p.as_os_str() != "paper")
            .collect();
        input_files.extend(self.dark_frame_paths()?);
        Ok(Params {
            model,
            gain_e_per_adu,
            input_files,
        })
    }

    /// `pdf`: `"paper"`, a `PdfFit` (with `pdf_model`), or the path of a pdf_fit.json.
    fn pdf(&self) -> PyResult<Option<Arc<dyn detnoise::pdf::RmsPdf>>> {
        let model = self
            .get("pdf_model")?
            .map(|m| m.extract::<String>())
            .transpose()?;
        let Some(pdf) = self.get("pdf")? else {
            return match model {
                Some(_) => Err(invalid(
                    "pdf_model",
                    "applies only with `pdf` a PdfFit or a pdf_fit.json",
                )),
                None => Ok(None),
            };
        };
        if let Ok(fit) = pdf.cast::<PdfFit>() {
            return fit.get().report.pdf(model.as_deref()).py().map(Some);
        }
        if pdf.extract::<String>().is_ok_and(|s| s == "paper") {
            if model.is_some() {
                return Err(invalid(
                    "pdf_model",
                    "applies only with `pdf` a PdfFit or a pdf_fit.json",
                ));
            }
            return Ok(Some(Arc::new(detnoise::pdf::paper())));
        }
        let path: PathBuf = pdf.extract().map_err(|_| {
            invalid(
                "pdf",
                format!(
                    "{}: must be \"paper\", a PdfFit or a pdf_fit.json path",
                    repr(&pdf)
                ),
            )
        })?;
        detnoise::fit::load_pdf_fit(&path, model.as_deref())
            .py()
            .map(Some)
    }

    /// `map_e`: a 2-D array (e-) or the path of a map file in e-.
    fn map(&self) -> PyResult<Option<Map>> {
        let Some(v) = self.get("map_e")? else {
            return Ok(None);
        };
        if let Ok(path) = v.extract::<PathBuf>() {
            return Map::read(&path, Unit::Electrons).py().map(Some);
        }
        map_from(&v, Unit::Electrons, "map_e").map(Some)
    }

    /// The paths of `dark_frames` (a path or a list of paths; none when absent).
    fn dark_frame_paths(&self) -> PyResult<Vec<PathBuf>> {
        match self.get("dark_frames")? {
            None => Ok(Vec::new()),
            Some(v) => crate::calib::paths_of(&v),
        }
    }

    /// `dark_frames` with their conversion gain.
    fn dark_frames(&self, gain: Option<f64>) -> PyResult<Option<Arc<DarkFrames>>> {
        let paths = self.dark_frame_paths()?;
        if paths.is_empty() {
            return Ok(None);
        }
        let Some(gain) = gain else {
            return Err(invalid(
                "gain_e_per_adu",
                "`dark_frames` needs their conversion gain to convert them to e-: give \
                 `gain_e_per_adu`",
            ));
        };
        let max_mib = self
            .real("dark_frames_max_mib", |v| v > 0.0, "> 0 MiB")?
            .unwrap_or(DEFAULT_MAX_MIB);
        DarkFrames::read(&paths, gain, max_mib)
            .map(|f| Some(Arc::new(f)))
            .py()
    }
}

/// `repr(v)` for messages.
fn repr(v: &Bound<'_, PyAny>) -> String {
    v.repr()
        .map(|r| r.to_string())
        .unwrap_or_else(|_| "?".into())
}
