//! The Monte-Carlo runs: `detnoise.simulate` (R for readout models over a sweep) and
//! `detnoise.effective` (the effective Gaussian read noise of a detector), each returning the
//! library's records as a list of dicts (the rows of the CSV/JSON the command line writes),
//! which `pandas.DataFrame(records)` takes as they are.

use crate::convert::{one_or_many, to_py};
use crate::errors::{invalid, IntoPy};
use crate::observer::observed;
use crate::params::read_params;
use detnoise::detector::ModelSpec;
use detnoise::effective::{effective_table, Precision};
use detnoise::montecarlo::{sweep, BgGrid, Grid, SimConfig};
use detnoise::spot::{Sampling, Spot};
use pyo3::prelude::*;
use pyo3::types::PyDict;

/// The readout models of a run: a comma-separated text or a list of names.
pub fn specs_of(models: &Bound<'_, PyAny>) -> PyResult<Vec<ModelSpec>> {
    let names: Vec<String> = one_or_many(models)?;
    let specs: Vec<ModelSpec> = names
        .iter()
        .flat_map(|n| n.split(','))
        .filter(|s| !s.trim().is_empty())
        .map(|s| ModelSpec::parse(s.trim()).py())
        .collect::<PyResult<_>>()?;
    if specs.is_empty() {
        return Err(invalid(
            "model",
            format!(
                "no model given (known: {})",
                detnoise::detector::MODEL_NAMES
            ),
        ));
    }
    Ok(specs)
}

/// `"integrated"` or `"point"`.
pub fn sampling_of(text: &str) -> PyResult<Sampling> {
    match text {
        "integrated" => Ok(Sampling::Integrated),
        "point" => Ok(Sampling::Point),
        other => Err(invalid(
            "sampling",
            format!("{other:?}: must be \"integrated\" or \"point\""),
        )),
    }
}

/// Spots: one `airy:D[,D...]` / `gauss:SX,SY` text or a list of them.
pub fn spots_of(spot: &Bound<'_, PyAny>) -> PyResult<Vec<Spot>> {
    Spot::parse_list(&one_or_many::<String>(spot)?).py()
}

/// The sweep's settings shared by `simulate` and `effective`.
pub struct Sweep<'a, 'py> {
    /// Sub-aperture sides, px.
    pub subap_px: &'a Bound<'py, PyAny>,
    /// Spots.
    pub spot: &'a Bound<'py, PyAny>,
    /// Signals, photons per sub-aperture.
    pub signal_photons: &'a Bound<'py, PyAny>,
    /// Everything else, in a configuration.
    pub shared: SimConfig,
}

impl Sweep<'_, '_> {
    /// Every configuration of the grid, validated.
    pub fn configs(&self) -> PyResult<Vec<SimConfig>> {
        let grid = Grid {
            subaps_px: one_or_many(self.subap_px)?,
            spots: spots_of(self.spot)?,
            signals_photons: one_or_many(self.signal_photons)?,
            shared: self.shared.clone(),
        };
        grid.configs().py()
    }
}

/// The configuration settings other than the grid's, checked by the library.
#[allow(clippy::too_many_arguments)]
pub fn shared_config(
    qe: f64,
    iters: u64,
    seed: u64,
    sampling: &str,
    bg_grid: &str,
    position_half_range_px: f64,
    max_empty_frac: f64,
) -> PyResult<SimConfig> {
    Ok(SimConfig {
        sampling: sampling_of(sampling)?,
        qe,
        iters,
        seed,
        bg_grid: BgGrid::parse(bg_grid).py()?,
        position_half_range_px,
        max_empty_frac,
        ..SimConfig::paper(SimConfig::MIN_SUBAP_PX)
    })
}

/// The models `simulate` compares by default (those of the command line).
pub const DEFAULT_MODELS: &str =
    "emccd-simple,emccd-stochastic,emccd-distribution,scmos-median,scmos-mean,scmos-random";

/// The sub-aperture Monte-Carlo of Basden (2015) for readout `models` over the grid
/// sub-aperture (px) x spot x signal (photons), as `detnoise simulate` runs it: one record per
/// configuration and model, with the mean radial centroid error R (px) and its SE.
#[pyfunction]
#[pyo3(signature = (
    models = None,
    *, subap_px = None, spot = None, signal_photons = None, qe = 1.0, iters = 10_000, seed = 1,
    sampling = "integrated", bg_grid = "auto", position_half_range_px = 0.5,
    max_empty_frac = 0.01, progress = None, **params
))]
#[allow(clippy::too_many_arguments)]
pub fn simulate<'py>(
    py: Python<'py>,
    models: Option<&Bound<'py, PyAny>>,
    subap_px: Option<&Bound<'py, PyAny>>,
    spot: Option<&Bound<'py, PyAny>>,
    signal_photons: Option<&Bound<'py, PyAny>>,
    qe: f64,
    iters: u64,
    seed: u64,
    sampling: &str,
    bg_grid: &str,
    position_half_range_px: f64,
    max_empty_frac: f64,
    progress: Option<Py<PyAny>>,
    params: Option<&Bound<'py, PyDict>>,
) -> PyResult<Bound<'py, PyAny>> {
    let specs = match models {
        Some(m) => specs_of(m)?,
        None => specs_of(DEFAULT_MODELS.into_pyobject(py)?.as_any())?,
    };
    let shared = shared_config(
        qe,
        iters,
        seed,
        sampling,
        bg_grid,
        position_half_range_px,
        max_empty_frac,
    )?;
    let defaults = (
        16usize.into_pyobject(py)?,
        "airy:2".into_pyobject(py)?,
        50.0f64.into_pyobject(py)?,
    );
    let configs = Sweep {
        subap_px: subap_px.unwrap_or(defaults.0.as_any()),
        spot: spot.unwrap_or(defaults.1.as_any()),
        signal_photons: signal_photons.unwrap_or(defaults.2.as_any()),
        shared,
    }
    .configs()?;
    let p = read_params(py, params)?;
    let records = observed(py, progress, |o| sweep(&configs, &specs, &p.model, o))?;
    to_py(py, &records)
}

/// The effective Gaussian read noise of detector `model` over the grid sub-aperture (px) x
/// spot x signal (photons), as `detnoise effective` solves it: one record per configuration
/// with `sigma_eff_e` and its SE `sigma_eff_se_e` (e-), and a `status` word. Iterations start
/// at `iters` and are added, up to `max_iters`, until the SE is at most `target_se_e` (e-) or
/// `target_rel` times the value.
#[pyfunction]
#[pyo3(signature = (
    model = "scmos-random",
    *, subap_px = None, spot = None, signal_photons = None, qe = 1.0, iters = 10_000, seed = 1,
    sampling = "integrated", bg_grid = "auto", position_half_range_px = 0.5,
    max_empty_frac = 0.01, target_se_e = Precision::DEFAULT_TARGET_SE_E,
    target_rel = Precision::DEFAULT_TARGET_REL, max_iters = None, progress = None, **params
))]
#[allow(clippy::too_many_arguments)]
pub fn effective<'py>(
    py: Python<'py>,
    model: &str,
    subap_px: Option<&Bound<'py, PyAny>>,
    spot: Option<&Bound<'py, PyAny>>,
    signal_photons: Option<&Bound<'py, PyAny>>,
    qe: f64,
    iters: u64,
    seed: u64,
    sampling: &str,
    bg_grid: &str,
    position_half_range_px: f64,
    max_empty_frac: f64,
    target_se_e: f64,
    target_rel: f64,
    max_iters: Option<u64>,
    progress: Option<Py<PyAny>>,
    params: Option<&Bound<'py, PyDict>>,
) -> PyResult<Bound<'py, PyAny>> {
    let spec = ModelSpec::parse(model).py()?;
    let shared = shared_config(
        qe,
        iters,
        seed,
        sampling,
        bg_grid,
        position_half_range_px,
        max_empty_frac,
    )?;
    let defaults = (
        vec![4usize, 6, 8, 10, 12, 14, 16].into_pyobject(py)?,
        "airy:1,2,4,6,8,10".into_pyobject(py)?,
        vec![20.0f64, 50.0, 100.0, 200.0, 500.0, 1000.0].into_pyobject(py)?,
    );
    let configs = Sweep {
        subap_px: subap_px.unwrap_or(defaults.0.as_any()),
        spot: spot.unwrap_or(defaults.1.as_any()),
        signal_photons: signal_photons.unwrap_or(defaults.2.as_any()),
        shared,
    }
    .configs()?;
    let precision = Precision {
        target_se_e,
        target_rel,
        max_iters: max_iters.unwrap_or(Precision::DEFAULT_MAX_ITERS.max(iters)),
    };
    precision.validate(iters).py()?;
    let p = read_params(py, params)?;
    let records = observed(py, progress, |o| {
        effective_table(&configs, &[spec], &p.model, &precision, o)
    })?;
    to_py(py, &records)
}
