//! Conversions between the library's values and Python's: serialisable results as dicts and
//! lists (through their JSON form, so a dict has exactly the keys of the file the command line
//! writes), maps as 2-D numpy arrays, and the arguments that take one value or a list.

use detnoise::calib::{Map, Unit};
use numpy::{PyArray1, PyArrayMethods, PyUntypedArrayMethods};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyList};
use serde_json::Value;

/// A JSON value as a Python object (objects keep their key order).
pub fn json_to_py<'py>(py: Python<'py>, v: &Value) -> PyResult<Bound<'py, PyAny>> {
    Ok(match v {
        Value::Null => py.None().into_bound(py),
        Value::Bool(b) => b.into_pyobject(py)?.to_owned().into_any(),
        Value::Number(n) => match (n.as_u64(), n.as_i64()) {
            (Some(u), _) => u.into_pyobject(py)?.into_any(),
            (None, Some(i)) => i.into_pyobject(py)?.into_any(),
            _ => n.as_f64().unwrap_or(f64::NAN).into_pyobject(py)?.into_any(),
        },
        Value::String(s) => s.into_pyobject(py)?.into_any(),
        Value::Array(a) => {
            let items = a
                .iter()
                .map(|x| json_to_py(py, x))
                .collect::<PyResult<Vec<_>>>()?;
            PyList::new(py, items)?.into_any()
        }
        Value::Object(o) => {
            let d = PyDict::new(py);
            for (k, x) in o {
                d.set_item(k, json_to_py(py, x)?)?;
            }
            d.into_any()
        }
    })
}

/// Any serialisable value as a Python object, by its JSON form.
pub fn to_py<'py, T: serde::Serialize>(py: Python<'py>, value: &T) -> PyResult<Bound<'py, PyAny>> {
    let v = serde_json::to_value(value)
        .map_err(|e| pyo3::exceptions::PyRuntimeError::new_err(e.to_string()))?;
    json_to_py(py, &v)
}

/// Row-major values as a read-only-free 2-D numpy array of `rows` x `cols`.
pub fn array2<'py, T: numpy::Element>(
    py: Python<'py>,
    data: Vec<T>,
    rows: usize,
    cols: usize,
) -> PyResult<Bound<'py, PyAny>> {
    Ok(PyArray1::from_vec(py, data)
        .reshape([rows, cols])?
        .into_any())
}

/// A map as a 2-D numpy array.
pub fn map_array<'py>(py: Python<'py>, map: &Map) -> PyResult<Bound<'py, PyAny>> {
    array2(py, map.data.clone(), map.rows, map.cols)
}

/// A 2-D array-like (anything `numpy.asarray` takes) as a map in `unit`.
pub fn map_from(obj: &Bound<'_, PyAny>, unit: Unit, name: &str) -> PyResult<Map> {
    let array = float_array(obj)?;
    let shape = array.shape().to_vec();
    let [rows, cols] = shape[..] else {
        return Err(PyValueError::new_err(format!(
            "`{name}` must be a 2-D array (rows, columns), not {}-D",
            shape.len()
        )));
    };
    let data = array.readonly().as_slice()?.to_vec();
    Ok(Map::new(rows, cols, data, unit).with_source(format!("`{name}`")))
}

/// An array-like as a C-contiguous float64 numpy array (no copy when it already is one).
pub fn float_array<'py>(obj: &Bound<'py, PyAny>) -> PyResult<Bound<'py, numpy::PyArrayDyn<f64>>> {
    let np = obj.py().import("numpy")?;
    let a = np.call_method1("ascontiguousarray", (obj, "float64"))?;
    Ok(a.cast_into::<numpy::PyArrayDyn<f64>>()?)
}

/// One value or a sequence of values (e.g. `subap_px=8` or `subap_px=[4, 8]`).
pub fn one_or_many<'py, T: FromPyObjectOwned<'py>>(obj: &Bound<'py, PyAny>) -> PyResult<Vec<T>> {
    if let Ok(v) = obj.extract::<T>() {
        return Ok(vec![v]);
    }
    obj.try_iter()?
        .map(|item| item?.extract::<T>().map_err(Into::into))
        .collect()
}
