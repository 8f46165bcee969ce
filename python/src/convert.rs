//! Conversions between the library's values and Python's: serialisable results as dicts and
//! lists (through their JSON form, so a dict has exactly the keys of the file the command line
//! writes), maps as 2-D numpy arrays, and the arguments that take one value or a list.

use crate::errors::invalid;
use detnoise::calib::{Map, Unit};
use numpy::{
    PyArray1, PyArrayDescrMethods, PyArrayDyn, PyArrayMethods, PyUntypedArray,
    PyUntypedArrayMethods,
};
use pyo3::exceptions::{PyOverflowError, PyTypeError, PyValueError};
use pyo3::prelude::*;
use pyo3::types::{PyBytes, PyDict, PyList, PyString};
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

/// Images read from FITS, by name, as a dict of 2-D numpy arrays.
pub fn images_dict<'py>(
    py: Python<'py>,
    images: &[(String, detnoise::io::Image)],
) -> PyResult<Bound<'py, PyDict>> {
    let d = PyDict::new(py);
    for (name, image) in images {
        let (rows, cols) = image.shape;
        d.set_item(name, array2(py, image.data.clone(), rows, cols)?)?;
    }
    Ok(d)
}

/// A map as a 2-D numpy array.
pub fn map_array<'py>(py: Python<'py>, map: &Map) -> PyResult<Bound<'py, PyAny>> {
    array2(py, map.data.clone(), map.rows, map.cols)
}

/// A 2-D array-like (anything `numpy.asarray` takes) as a map in `unit`.
pub fn map_from(obj: &Bound<'_, PyAny>, unit: Unit, name: &str) -> PyResult<Map> {
    let array = float_array(obj, name)?;
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

/// Most elements an array argument is expanded to beyond those it holds (2^27: 1 GiB as
/// float64). A broadcast view (`numpy.broadcast_to`) holds few elements for a large shape;
/// copying it, and the output of its shape, may not cost more than this.
pub const MAX_EXPANDED_ELEMENTS: u128 = 1 << 27;

/// Argument `name` (anything `numpy.asarray` takes) as a numpy array, not copied when it is
/// one; refused, naming `name`, when not of numbers (text, objects, dates), when complex
/// (float64 would drop the imaginary part) or when
/// its shape has more elements than both the memory it spans holds and
/// [`MAX_EXPANDED_ELEMENTS`] (checked before anything of its shape is allocated).
pub fn checked_array<'py>(
    obj: &Bound<'py, PyAny>,
    name: &str,
) -> PyResult<Bound<'py, PyUntypedArray>> {
    let np = obj.py().import("numpy")?;
    let a = np
        .call_method1("asarray", (obj,))?
        .cast_into::<PyUntypedArray>()?;
    let dtype = a.dtype();
    if dtype.kind() == b'c' {
        return Err(invalid(
            name,
            format!(
                "complex values (dtype {dtype}): detnoise takes real numbers and would drop the \
                 imaginary part; pass `.real` or `abs()` of the array"
            ),
        ));
    }
    if !matches!(dtype.kind(), b'b' | b'i' | b'u' | b'f') {
        return Err(invalid(
            name,
            format!(
                "values of dtype {dtype}, not numbers: detnoise takes arrays of real numbers \
                 (integer or float), and would not guess at text or objects; convert them \
                 first, e.g. with `numpy.asarray(x, dtype=float)`"
            ),
        ));
    }
    let shape = a.shape();
    let size: u128 = shape.iter().map(|&d| d as u128).product();
    if size > MAX_EXPANDED_ELEMENTS {
        let held = held_elements(shape, a.strides(), dtype.itemsize()).min(size);
        if size > held {
            return Err(invalid(
                name,
                format!(
                    "shape {shape:?} has {size} elements ({:.1} GiB as float64) but the array \
                     holds {held} (a broadcast or strided view): a view is expanded to at most \
                     {MAX_EXPANDED_ELEMENTS} elements (1 GiB), so that one call cannot \
                     exhaust memory; pass a real array of this shape, or a smaller one",
                    size as f64 * 8.0 / f64::from(1u32 << 30)
                ),
            ));
        }
    }
    Ok(a)
}

/// Elements in the memory spanned by an array of `shape`, `strides` (bytes) and `itemsize`
/// (a broadcast dimension, of stride 0, spans one element). Only meaningful for a non-empty
/// shape.
fn held_elements(shape: &[usize], strides: &[isize], itemsize: usize) -> u128 {
    let itemsize = itemsize.max(1) as u128;
    let span: u128 = shape
        .iter()
        .zip(strides)
        .map(|(&d, &s)| (d.saturating_sub(1) as u128) * s.unsigned_abs() as u128)
        .sum();
    span / itemsize + 1
}

/// A checked array (see [`checked_array`]) as a C-contiguous float64 numpy array (no copy
/// when it already is one).
pub fn to_f64<'py>(a: &Bound<'py, PyUntypedArray>) -> PyResult<Bound<'py, PyArrayDyn<f64>>> {
    let np = a.py().import("numpy")?;
    let f = np.call_method1("ascontiguousarray", (a, "float64"))?;
    Ok(f.cast_into::<PyArrayDyn<f64>>()?)
}

/// Argument `name` as a C-contiguous float64 numpy array, checked by [`checked_array`].
pub fn float_array<'py>(
    obj: &Bound<'py, PyAny>,
    name: &str,
) -> PyResult<Bound<'py, PyArrayDyn<f64>>> {
    to_f64(&checked_array(obj, name)?)
}

/// Argument `keyword`: one value or a sequence of values (e.g. `subap_px=8` or
/// `subap_px=[4, 8]`), each `what` (e.g. "a whole number of pixels"). A value of another type
/// is a `TypeError`, one out of the type's range (`subap_px=-8`) or an empty sequence a
/// `ValueError`, each naming `keyword`.
pub fn one_or_many<'py, T: FromPyObjectOwned<'py>>(
    obj: &Bound<'py, PyAny>,
    keyword: &str,
    what: &str,
) -> PyResult<Vec<T>> {
    let first: PyErr = match obj.extract::<T>() {
        Ok(v) => return Ok(vec![v]),
        Err(e) => e.into(),
    };
    // Text is iterable, but by character: one refused value, not a list.
    let text = obj.is_instance_of::<PyString>() || obj.is_instance_of::<PyBytes>();
    let Some(items) = obj.try_iter().ok().filter(|_| !text) else {
        return Err(refused(obj, first, keyword, what));
    };
    let values = items
        .map(|item| {
            let item = item?;
            item.extract::<T>()
                .map_err(|e| refused(&item, e.into(), keyword, what))
        })
        .collect::<PyResult<Vec<T>>>()?;
    if values.is_empty() {
        return Err(invalid(
            keyword,
            format!("an empty list: give {what}, or a list of at least one"),
        ));
    }
    Ok(values)
}

/// What one sub-aperture size is, for [`one_or_many`].
pub fn subap_px_item() -> String {
    use detnoise::montecarlo::SimConfig;
    format!(
        "a whole number of pixels, {} to {} (the sub-aperture side)",
        SimConfig::MIN_SUBAP_PX,
        SimConfig::MAX_SUBAP_PX
    )
}
/// What one signal is, for [`one_or_many`].
pub const SIGNAL_ITEM: &str = "a number of photons";
/// What one spot is, for [`one_or_many`].
pub const SPOT_ITEM: &str = "a spot text such as \"airy:2\" or \"gauss:1,2\"";

/// The error of `item` refused for `keyword` with `error`: a value of the right type but out
/// of its range (pyo3's `OverflowError`, e.g. a negative size) is a `ValueError`, any other a
/// `TypeError`; both say what is expected.
fn refused(item: &Bound<'_, PyAny>, error: PyErr, keyword: &str, what: &str) -> PyErr {
    let shown = item
        .repr()
        .map_or_else(|_| "?".to_string(), |r| r.to_string());
    if error.is_instance_of::<PyOverflowError>(item.py()) {
        return invalid(keyword, format!("{shown}: must be {what}"));
    }
    let type_name = item
        .get_type()
        .name()
        .map_or_else(|_| "?".to_string(), |n| n.to_string());
    PyTypeError::new_err(format!(
        "`{keyword}` takes {what} or a list of them, not {type_name} {shown}"
    ))
}
