//! The readout-model parameters as Python keywords (`em_gain=1000, map_e=rms_e, ...`): parsed
//! into the library's [`ModelParams`] by the library itself, each value checked by the
//! settings registry, as the command line checks it.

use crate::calib::paths_of;
use crate::convert::map_from;
use crate::errors::{invalid, IntoPy};
use crate::fit::PdfFit;
use crate::observer::PyObserver;
use detnoise::calib::Unit;
use detnoise::detector::ModelParams;
use detnoise::settings::{self, Kind, Setting, Value, Values};
use pyo3::exceptions::PyTypeError;
use pyo3::prelude::*;
use pyo3::types::{PyBool, PyDict, PyList};
use std::path::PathBuf;
use std::sync::Arc;

/// The keywords of the readout-model parameters, in the order of the documentation: the
/// registry's (`detnoise::settings::READOUT`).
pub fn keywords() -> Vec<&'static str> {
    settings::READOUT.iter().map(|s| s.key).collect()
}

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
    params_of(py, given_values(params)?)
}

/// The parameters `values` give (from [`given_values`]), their files read; the warnings of
/// those files are issued as Python warnings.
pub fn params_of(py: Python<'_>, values: Values) -> PyResult<Params> {
    let observer = PyObserver::new(None);
    let model = ModelParams::from_settings(&values, &observer).py();
    observer.finish(py, Ok(()))?;
    Ok(Params {
        gain_e_per_adu: values.real(&settings::GAIN_E_PER_ADU),
        input_files: ModelParams::input_files(&values),
        model: model?,
    })
}

/// The readout settings given as `**params`, each checked by the registry, no file read yet.
pub fn given_values(params: Option<&Bound<'_, PyDict>>) -> PyResult<Values> {
    match params {
        Some(dict) => Given::new(dict)?.values(),
        None => Ok(Values::default()),
    }
}

/// The keyword arguments, checked for unknown names.
struct Given<'a, 'py> {
    dict: &'a Bound<'py, PyDict>,
}

impl<'a, 'py> Given<'a, 'py> {
    fn new(dict: &'a Bound<'py, PyDict>) -> PyResult<Self> {
        for key in dict.keys() {
            let key: String = key.extract()?;
            if !settings::READOUT.iter().any(|s| s.key == key) {
                return Err(PyTypeError::new_err(format!(
                    "unexpected keyword argument '{key}'; readout-model parameters are: {}",
                    keywords().join(", ")
                )));
            }
        }
        Ok(Given { dict })
    }

    /// The settings given (None values are not given), each checked by the registry as the
    /// command line checks it.
    fn values(&self) -> PyResult<Values> {
        let mut values = Values::default();
        let pdf_model: Option<String> = self
            .dict
            .get_item(settings::PDF_MODEL.key)?
            .and_then(|m| m.extract().ok());
        for &setting in settings::READOUT {
            let Some(v) = self.dict.get_item(setting.key)?.filter(|v| !v.is_none()) else {
                continue;
            };
            let value = value_of(setting, &v, pdf_model.as_deref())?;
            let value = setting.check(value).map_err(|e| invalid(setting.key, e))?;
            values.set(setting, value);
        }
        Ok(values)
    }
}

/// The Python value `v` of `setting` as a registry value (not yet range-checked): numbers of
/// the right kind, text, paths, and the objects only Python passes (a `PdfFit` as `pdf`, an
/// array as `map_e`); `pdf_model` picks the model of a `PdfFit`.
fn value_of(setting: &Setting, v: &Bound<'_, PyAny>, pdf_model: Option<&str>) -> PyResult<Value> {
    let wrong = || invalid(setting.key, format!("{}: {}", repr(v), setting.expected()));
    match setting.kind {
        Kind::Real(..) => {
            // bool is an int in Python: refuse it as a number.
            if v.is_instance_of::<PyBool>() {
                return Err(wrong());
            }
            v.extract::<f64>().map(Value::Real).map_err(|_| wrong())
        }
        Kind::Whole(..) => {
            if v.is_instance_of::<PyBool>() {
                return Err(wrong());
            }
            v.extract::<u64>().map(Value::Whole).map_err(|_| wrong())
        }
        Kind::Choice(_) | Kind::Text | Kind::TextList => {
            if let Ok(fit) = v.cast::<PdfFit>() {
                return fit.get().report.pdf(pdf_model).py().map(Value::Pdf);
            }
            if let Ok(text) = v.extract::<String>() {
                return Ok(Value::Text(text));
            }
            if setting.kind == Kind::Text {
                if let Ok(path) = v.extract::<PathBuf>() {
                    return Ok(Value::Path(path));
                }
            }
            Err(wrong())
        }
        Kind::Path => match v.extract::<PathBuf>() {
            Ok(path) => Ok(Value::Path(path)),
            Err(_) => map_from(v, Unit::Electrons, setting.key).map(|m| Value::Map(Arc::new(m))),
        },
        Kind::Paths => paths_of(v).map(Value::Paths),
    }
}

/// `repr(v)` for messages.
fn repr(v: &Bound<'_, PyAny>) -> String {
    v.repr()
        .map(|r| r.to_string())
        .unwrap_or_else(|_| "?".into())
}

/// The settings registry as Python sees it (`detnoise.SETTINGS`): one dict per setting with
/// its group, keyword, field, flag, unit, kind, range or choices, default (as a Python value)
/// and help, so that tests and users read the ranges and defaults the checks apply.
pub fn settings_table(py: Python<'_>) -> PyResult<Bound<'_, PyList>> {
    let rows = PyList::empty(py);
    for (group, entries) in settings::GROUPS {
        for setting in entries.iter() {
            let d = PyDict::new(py);
            d.set_item("group", group)?;
            d.set_item("key", setting.key)?;
            d.set_item("field", setting.field)?;
            d.set_item("flag", setting.flag)?;
            d.set_item("unit", setting.unit)?;
            d.set_item("help", setting.help)?;
            kind_items(&d, setting)?;
            let default = setting.default_value().map(|v| match v {
                Value::Real(x) => x.into_pyobject(py).map(|o| o.into_any()),
                Value::Whole(n) => n.into_pyobject(py).map(|o| o.into_any()),
                other => settings_text(&other)
                    .into_pyobject(py)
                    .map(|o| o.into_any()),
            });
            d.set_item("default", default.transpose()?)?;
            rows.append(d)?;
        }
    }
    Ok(rows)
}

/// `kind` ("real", "whole", "choice", "text", "texts", "path", "paths") and its range: `lo`,
/// `hi` (None: unbounded), `lo_open`, `hi_open` for numbers, `choices` for words.
fn kind_items(d: &Bound<'_, PyDict>, setting: &Setting) -> PyResult<()> {
    use std::ops::Bound::{Excluded, Included, Unbounded};
    let bound = |b: std::ops::Bound<f64>| match b {
        Included(x) => (Some(x), false),
        Excluded(x) => (Some(x), true),
        Unbounded => (None, false),
    };
    let kind = match setting.kind {
        Kind::Real(lo, hi) => {
            let ((lo, lo_open), (hi, hi_open)) = (bound(lo), bound(hi));
            d.set_item("lo", lo)?;
            d.set_item("hi", hi)?;
            d.set_item("lo_open", lo_open)?;
            d.set_item("hi_open", hi_open)?;
            "real"
        }
        Kind::Whole(lo, hi) => {
            d.set_item("lo", lo)?;
            d.set_item("hi", hi)?;
            "whole"
        }
        Kind::Choice(words) => {
            d.set_item("choices", words.to_vec())?;
            "choice"
        }
        Kind::Text => "text",
        Kind::TextList => "texts",
        Kind::Path => "path",
        Kind::Paths => "paths",
    };
    d.set_item("kind", kind)
}

/// The text of a text or path value.
fn settings_text(v: &Value) -> String {
    match v {
        Value::Text(t) => t.clone(),
        Value::Path(p) => p.to_string_lossy().into_owned(),
        other => format!("{other:?}"),
    }
}
