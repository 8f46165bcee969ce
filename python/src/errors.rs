//! detnoise errors as Python exceptions: `ValueError` for a bad setting, `OSError` for a file,
//! `RuntimeError` for a numerical failure, `KeyboardInterrupt` for an interrupted run.
//!
//! Messages name settings by their Python keyword: the library's field names, except the few
//! that the Python API spells otherwise ([`PY_NAMES`]), so that a message names the argument
//! the caller typed, as the command line names its flag.

use detnoise::Error;
use pyo3::exceptions::{PyKeyboardInterrupt, PyOSError, PyRuntimeError, PyValueError};
use pyo3::PyErr;

/// Library fields outside the settings registry that the Python API spells differently:
/// (field, keyword). The registry's settings carry their own keyword.
pub const PY_NAMES: &[(&str, &str)] = &[
    ("stacks", "paths"),
    ("darks_paths", "darks"),
    ("flats_paths", "flats"),
    ("subaps_px", "subap_px"),
    ("spots", "spot"),
    ("signals_photons", "signal_photons"),
    ("out", "out"),
];

/// Every (field, keyword) pair that differs: the registry's, then [`PY_NAMES`].
fn renamed() -> impl Iterator<Item = (&'static str, &'static str)> {
    let registry = detnoise::settings::all().map(|s| (s.field, s.key));
    registry
        .chain(PY_NAMES.iter().copied())
        .filter(|(f, k)| f != k)
}

/// The Python keyword of library field `field`.
pub fn keyword(field: &str) -> &str {
    renamed()
        .find(|(f, _)| *f == field)
        .map_or(field, |(_, k)| k)
}

/// `message` with every `` `field` `` mention replaced by `` `keyword` ``.
pub fn keywords_in(message: &str) -> String {
    renamed().fold(message.to_string(), |m, (field, kw)| {
        m.replace(&format!("`{field}`"), &format!("`{kw}`"))
    })
}

/// The Python exception of a library error.
pub fn to_py(e: Error) -> PyErr {
    match e {
        Error::Usage { field, message } => {
            let e = Error::invalid(keyword(&field), keywords_in(&message));
            PyValueError::new_err(e.to_string())
        }
        // An input that is not a file but an argument (`map_e` given as an array) is a bad
        // value, not a bad file.
        Error::Input { path, message } if path.to_string_lossy().starts_with('`') => {
            PyValueError::new_err(format!(
                "invalid {}: {}",
                path.display(),
                keywords_in(&message)
            ))
        }
        e @ Error::Input { .. } => PyOSError::new_err(e.to_string()),
        Error::Io { path, source } => {
            // errno, reason and file name, as Python's own OSError has them: Python then
            // raises the subclass of the errno (FileNotFoundError, PermissionError, ...).
            let file = path.display().to_string();
            match source.raw_os_error() {
                Some(code) => PyOSError::new_err((code, source.to_string(), file)),
                None => PyOSError::new_err(format!("{file}: {source}")),
            }
        }
        Error::Numeric(message) => PyRuntimeError::new_err(keywords_in(&message)),
        Error::Interrupted => PyKeyboardInterrupt::new_err("interrupted"),
    }
}

/// A `ValueError` naming the Python keyword `keyword`, worded like the library's errors.
pub fn invalid(keyword: &str, message: impl Into<String>) -> PyErr {
    PyValueError::new_err(Error::invalid(keyword, message).to_string())
}

/// Library results as Python results.
pub trait IntoPy<T> {
    /// The result with its error as a Python exception.
    fn py(self) -> pyo3::PyResult<T>;
}

impl<T> IntoPy<T> for detnoise::Result<T> {
    fn py(self) -> pyo3::PyResult<T> {
        self.map_err(to_py)
    }
}
