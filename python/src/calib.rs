//! Frames and dark maps: `detnoise.read_stack` (an iterator of 2-D arrays) and
//! `detnoise.dark_maps` (offset, read noise and flag maps with the summary of `darks`).

use crate::convert::{array2, map_array, to_py};
use crate::errors::IntoPy;
use crate::observer::observed;
use detnoise::calib::darks::{
    dark_maps, dark_maps_hashed, require_dark_expecting, summarise, Clip, DarkMaps as Maps,
    DarkOptions, DarkSummary, ExpectedDark,
};
use detnoise::calib::summary::unhashed;
use detnoise::io::{Checksum, FrameStack, StackReader};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use std::path::PathBuf;

/// Stack arguments: one path (file, directory or glob) or a list of them.
pub fn paths_of(obj: &Bound<'_, PyAny>) -> PyResult<Vec<PathBuf>> {
    match obj.extract::<PathBuf>() {
        Ok(p) => Ok(vec![p]),
        Err(_) => obj.extract(),
    }
}

/// The frames of a stack, one 2-D float64 array (rows, columns) per frame, in stack order.
/// It holds one open file, which only the thread that opened it may read (`unsendable`).
#[pyclass(module = "detnoise._detnoise", name = "StackIterator", unsendable)]
pub struct StackIterator {
    reader: StackReader<'static>,
    shape: (usize, usize),
    frames: usize,
}

#[pymethods]
impl StackIterator {
    fn __iter__(slf: PyRef<'_, Self>) -> PyRef<'_, Self> {
        slf
    }

    fn __next__<'py>(&mut self, py: Python<'py>) -> PyResult<Option<Bound<'py, PyAny>>> {
        let (rows, cols) = self.shape;
        let mut values = vec![0.0; rows * cols];
        match self.reader.next_frame(&mut values).py()? {
            Some(_) => array2(py, values, rows, cols).map(Some),
            None => Ok(None),
        }
    }

    fn __len__(&self) -> usize {
        self.frames
    }

    /// Frame shape (rows, columns).
    #[getter]
    fn shape(&self) -> (usize, usize) {
        self.shape
    }
}

/// The frames of `paths` (FITS, TIFF or OpenEXR files, directories or glob patterns, in
/// stack order) as an iterator of 2-D float64 arrays (rows, columns) of the stored values.
#[pyfunction]
pub fn read_stack(paths: &Bound<'_, PyAny>) -> PyResult<StackIterator> {
    let stack = FrameStack::open(&paths_of(paths)?).py()?;
    Ok(StackIterator {
        shape: stack.shape,
        frames: stack.frames,
        reader: stack.into_reader(),
    })
}

/// The maps of a dark stack, as `detnoise darks` writes them.
#[pyclass(module = "detnoise._detnoise", name = "DarkMaps", frozen)]
pub struct PyDarkMaps {
    maps: Maps,
    rms_e: Option<detnoise::calib::Map>,
    summary: DarkSummary,
}

#[pymethods]
impl PyDarkMaps {
    /// Per-pixel offset (mean level), adu, 2-D.
    #[getter]
    fn offset_adu<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        map_array(py, &self.maps.offset_adu)
    }

    /// Per-pixel read noise (sample standard deviation), adu, 2-D.
    #[getter]
    fn rms_adu<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        map_array(py, &self.maps.rms_adu)
    }

    /// Per-pixel read noise, e- (rms_adu x gain_e_per_adu), 2-D; None without a gain.
    #[getter]
    fn rms_e<'py>(&self, py: Python<'py>) -> PyResult<Option<Bound<'py, PyAny>>> {
        self.rms_e.as_ref().map(|m| map_array(py, m)).transpose()
    }

    /// Flag bits per pixel (int32, 2-D): 1 hot, 2 dead, 4 RTS, ... (see `summary["flags"]`).
    #[getter]
    fn flags<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        let (rows, cols) = self.maps.offset_adu.shape();
        array2(py, self.maps.flags.clone(), rows, cols)
    }

    /// Per-pixel excess kurtosis G2 (0 for Gaussian noise), 2-D.
    #[getter]
    fn excess_kurtosis<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        let (rows, cols) = self.maps.offset_adu.shape();
        array2(py, self.maps.stats.excess_kurtosis.clone(), rows, cols)
    }

    /// The summary, with the keys of the summary.json that `detnoise darks` writes (its
    /// `outputs` empty: nothing was written).
    #[getter]
    fn summary<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        to_py(py, &self.summary)
    }

    /// The summary as a dict (the same as `summary`).
    fn to_dict<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        self.summary(py)
    }

    fn __repr__(&self) -> String {
        let s = &self.summary;
        format!(
            "DarkMaps({} frames of {}x{}, median read noise {:.4} adu)",
            s.frames, s.shape[0], s.shape[1], s.rms_adu.median
        )
    }
}

/// Offset, read-noise and flag maps of a dark stack, as `detnoise darks` computes them.
#[pyfunction]
#[pyo3(name = "dark_maps")]
#[pyo3(signature = (paths, *, gain_e_per_adu = None, clip = 0, sigma_clip = None, common_mode = false, hot_sigma = 5.0, dead_fraction = 0.1, rts_sigma = 5.0, checksum = Some("blake3"), accept_illuminated = false, camera = None, exposure_s = None, em_gain = None, temperature_c = None, progress = None))]
#[allow(clippy::too_many_arguments)]
pub fn dark_maps_py(
    py: Python<'_>,
    paths: &Bound<'_, PyAny>,
    gain_e_per_adu: Option<f64>,
    clip: usize,
    sigma_clip: Option<f64>,
    common_mode: bool,
    hot_sigma: f64,
    dead_fraction: f64,
    rts_sigma: f64,
    checksum: Option<&str>,
    accept_illuminated: bool,
    camera: Option<PathBuf>,
    exposure_s: Option<f64>,
    em_gain: Option<f64>,
    temperature_c: Option<f64>,
    progress: Option<Py<PyAny>>,
) -> PyResult<PyDarkMaps> {
    let expected = expected_dark(camera, exposure_s, em_gain, temperature_c)?;
    if let Some(g) = gain_e_per_adu {
        if !(g > 0.0 && g.is_finite()) {
            return Err(crate::errors::invalid(
                "gain_e_per_adu",
                format!("{g}: must be a number > 0 e- per adu"),
            ));
        }
    }
    let clip = match (clip, sigma_clip) {
        (n, Some(_)) if n > 0 => {
            return Err(crate::errors::invalid(
                "sigma_clip",
                "give one rejection: `clip` or `sigma_clip`, not both",
            ))
        }
        (_, Some(k)) => Clip::Sigma(k),
        (0, None) => Clip::None,
        (n, None) => Clip::Extremes(n),
    };
    let checksum = match checksum {
        None => None,
        Some("blake3") => Some(Checksum::Blake3),
        Some("sha256") => Some(Checksum::Sha256),
        Some(other) => {
            return Err(PyValueError::new_err(format!(
                "invalid `checksum`: {other:?}: must be \"blake3\", \"sha256\" or None"
            )))
        }
    };
    let options = DarkOptions {
        clip,
        common_mode,
        hot_sigma,
        dead_fraction,
        rts_sigma,
    };
    let paths = paths_of(paths)?;
    observed(py, progress, |observer| {
        options.check()?;
        let stack = FrameStack::open(&paths)?;
        if let Some(e) = &expected {
            e.check_shape(&stack)?;
        }
        let (maps, inputs) = match checksum {
            Some(algorithm) => dark_maps_hashed(&stack, &options, algorithm)?,
            None => (dark_maps(&stack, &options)?, unhashed(&stack)),
        };
        if let Some(warning) =
            require_dark_expecting(&stack, &maps, accept_illuminated, expected.as_ref())?
        {
            detnoise::progress::Observer::warn(observer, &warning);
        }
        let mut summary = summarise(&stack, &maps, &options, gain_e_per_adu, inputs, "");
        summary.outputs.clear();
        let rms_e = gain_e_per_adu.map(|g| maps.rms_adu.to_electrons(g));
        Ok(PyDarkMaps {
            maps,
            rms_e,
            summary,
        })
    })
}

/// The dark signal the frames hold by the camera model `camera` at its operating point
/// (`exposure_s` required with it); None without a camera.
fn expected_dark(
    camera: Option<PathBuf>,
    exposure_s: Option<f64>,
    em_gain: Option<f64>,
    temperature_c: Option<f64>,
) -> PyResult<Option<ExpectedDark>> {
    let Some(dir) = camera else {
        for (name, given) in [
            ("exposure_s", exposure_s.is_some()),
            ("em_gain", em_gain.is_some()),
            ("temperature_c", temperature_c.is_some()),
        ] {
            if given {
                return Err(crate::errors::invalid(
                    name,
                    "applies to the dark frames of a camera model: give `camera` too",
                ));
            }
        }
        return Ok(None);
    };
    let Some(exposure_s) = exposure_s else {
        return Err(crate::errors::invalid(
            "exposure_s",
            "the dark frames' exposure time (s) is needed with `camera`",
        ));
    };
    let at = detnoise::camera::CameraModel::read(&dir)
        .and_then(|m| {
            m.at(detnoise::camera::OperatingPoint {
                exposure_s,
                em_gain,
                temperature_c,
            })
        })
        .py()?;
    Ok(Some(ExpectedDark::of_camera(
        &at,
        dir.display().to_string(),
    )))
}
