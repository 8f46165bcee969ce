//! `detnoise.datasheet`: the EMVA 1288 (release 4.0) datasheet of a camera from its dataset,
//! as `detnoise datasheet` writes it into `out`, returned as a dict and numpy arrays.

use std::path::PathBuf;

use crate::convert::{images_dict, json_to_py};
use crate::errors::{invalid, IntoPy};
use detnoise::emva::beyond::BeyondOptions;
use detnoise::emva::run::{run, DatasheetInput, DatasheetRun, DATASHEET_NAMES};
use detnoise::emva::spatial::SpatialOptions;
use detnoise::io::{read_image, Image};
use detnoise::report::OperatingPoint;
use pyo3::prelude::*;
use pyo3::types::PyDict;

/// The datasheet written: its sheet (datasheet.json) and the per-pixel maps.
#[pyclass(module = "detnoise._detnoise", name = "Datasheet", frozen)]
pub struct PyDatasheet {
    out: PathBuf,
    sheet: serde_json::Value,
    maps: Vec<(String, Image)>,
}

#[pymethods]
impl PyDatasheet {
    /// The output directory written (datasheet.json/.csv/.html/.xml, figures, FITS maps).
    #[getter]
    fn out(&self) -> PathBuf {
        self.out.clone()
    }

    /// datasheet.json as a dict: sections of rows (label, unit, value, se, status) and the
    /// figures' curves.
    #[getter]
    fn sheet<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        json_to_py(py, &self.sheet)
    }

    /// The per-pixel maps as 2-D float64 arrays, keyed by file name without `.fits`:
    /// gain_dn_per_e, gain_se_dn_per_e, dark_current_e_per_s, dark_current_se_e_per_s, rms_e,
    /// rms_se_e.
    #[getter]
    fn maps<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        images_dict(py, &self.maps)
    }

    fn __repr__(&self) -> String {
        format!(
            "Datasheet({} maps, out={:?})",
            self.maps.len(),
            self.out.display().to_string()
        )
    }
}

/// The EMVA 1288 datasheet of the dataset named by exactly one of `emva` (descriptor) and
/// `manifest` (campaign CSV), as `detnoise datasheet`, written into `out`.
#[pyfunction]
#[pyo3(name = "datasheet")]
#[pyo3(signature = (*, emva = None, manifest = None, out, force = false, defect_sigma = 6.0, operating_point = OperatingPoint::DEFAULT_TEXT))]
pub fn datasheet_py(
    py: Python<'_>,
    emva: Option<PathBuf>,
    manifest: Option<PathBuf>,
    out: PathBuf,
    force: bool,
    defect_sigma: f64,
    operating_point: &str,
) -> PyResult<PyDatasheet> {
    let input = match (emva, manifest) {
        (Some(e), None) => DatasheetInput::Descriptor(e),
        (None, Some(m)) => DatasheetInput::Manifest(m),
        _ => {
            return Err(invalid(
                "emva",
                "give exactly one of `emva` (EMVA 1288 descriptor) and `manifest` (CSV)",
            ))
        }
    };
    if !(defect_sigma > 0.0 && defect_sigma <= 1000.0) {
        return Err(invalid(
            "defect_sigma",
            format!("{defect_sigma}: robust standard deviations in (0, 1000]"),
        ));
    }
    let job = DatasheetRun {
        input,
        out,
        force,
        spatial: SpatialOptions {
            defect_factor: defect_sigma,
            ..SpatialOptions::default()
        },
        beyond: BeyondOptions {
            point: OperatingPoint::parse(operating_point).py()?,
            ..BeyondOptions::default()
        },
    };
    let (_, _, out) = py.detach(|| run(&job)).py()?;
    let json = out.join("datasheet.json");
    let sheet = std::fs::read_to_string(&json)
        .map_err(|e| e.to_string())
        .and_then(|text| serde_json::from_str(&text).map_err(|e| e.to_string()))
        .map_err(|why| invalid("out", format!("{}: {why}", json.display())))?;
    let maps = DATASHEET_NAMES
        .iter()
        .filter_map(|name| name.strip_suffix(".fits"))
        .filter(|name| out.join(format!("{name}.fits")).exists())
        .map(|name| {
            Ok((
                name.to_string(),
                read_image(&out.join(format!("{name}.fits")))?,
            ))
        })
        .collect::<detnoise::Result<Vec<_>>>()
        .py()?;
    Ok(PyDatasheet { out, sheet, maps })
}
