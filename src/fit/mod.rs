//! Calibration fits with argmin: the per-pixel read-noise pdf of a map (`pdf_fit`) and the
//! gain of an EMCCD from the histogram of its frames (`emgain`).

pub mod em_signature;
pub mod emgain;
mod optim;
pub mod pdf_fit;
pub mod pdf_models;

pub use pdf_fit::{fit_pdf, load_pdf_fit, ModelFit, PdfFitOptions, PdfFitReport, RmsSummary};
pub use pdf_models::PdfModel;

use crate::error::{Error, Result};
use std::io::Write;
use std::path::Path;

/// Write `bytes` to `path` through a temporary file in the same directory, so a failure
/// never leaves a partial file.
pub(crate) fn write_atomic(path: &Path, bytes: &[u8]) -> Result<()> {
    let dir = path
        .parent()
        .filter(|d| !d.as_os_str().is_empty())
        .unwrap_or(Path::new("."));
    let mut tmp = tempfile::NamedTempFile::new_in(dir).map_err(|e| Error::io(path, e))?;
    tmp.write_all(bytes).map_err(|e| Error::io(path, e))?;
    tmp.persist(path).map_err(|e| Error::io(path, e.error))?;
    Ok(())
}
