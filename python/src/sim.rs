//! The Monte-Carlo runs: `detnoise.simulate` (R for readout models over a sweep) and
//! `detnoise.effective` (the effective Gaussian read noise of a detector), each returning the
//! library's records as a list of dicts (the rows of the CSV/JSON the command line writes),
//! which `pandas.DataFrame(records)` takes as they are.

use crate::convert::{one_or_many, subap_px_item, to_py, SIGNAL_ITEM, SPOT_ITEM};
use crate::errors::{invalid, IntoPy};
use crate::observer::observed;
use crate::params::read_params;
use detnoise::centroid::CentroiderSpec;
use detnoise::detector::ModelSpec;
use detnoise::effective::{effective_table_with, Precision};
use detnoise::montecarlo::{sweep_with, BgGrid, Grid, SimConfig};
use detnoise::settings::{self, Setting, Value};
use detnoise::spot::{Sampling, Spot};
use pyo3::prelude::*;
use pyo3::types::PyDict;

/// The readout models of a run (argument `keyword`): a comma-separated text or a list of names.
pub fn specs_of(models: &Bound<'_, PyAny>, keyword: &str) -> PyResult<Vec<ModelSpec>> {
    let names: Vec<String> = one_or_many(models, keyword, "a model name such as \"scmos-median\"")?;
    let specs: Vec<ModelSpec> = names
        .iter()
        .flat_map(|n| n.split(','))
        .filter(|s| !s.trim().is_empty())
        .map(|s| ModelSpec::parse(s.trim()).py())
        .collect::<PyResult<_>>()?;
    if specs.is_empty() {
        return Err(invalid(
            keyword,
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
    checked(&settings::SAMPLING, Value::Text(text.into()))?;
    Ok(Sampling::parse(text).expect("the registry's choices are the samplings"))
}

/// Spots: one `airy:D[,D...]` / `gauss:SX,SY` text or a list of them.
pub fn spots_of(spot: &Bound<'_, PyAny>) -> PyResult<Vec<Spot>> {
    Spot::parse_list(&one_or_many::<String>(spot, "spot", SPOT_ITEM)?).py()
}

/// The sweep's settings shared by `simulate` and `effective`.
pub struct Sweep<'a, 'py> {
    /// The command whose defaults apply to the lists left None (`simulate`, `effective`).
    pub command: &'static str,
    /// Sub-aperture sides, px.
    pub subap_px: Option<&'a Bound<'py, PyAny>>,
    /// Spots.
    pub spot: Option<&'a Bound<'py, PyAny>>,
    /// Signals, photons per sub-aperture.
    pub signal_photons: Option<&'a Bound<'py, PyAny>>,
    /// Everything else, in a configuration.
    pub shared: SimConfig,
}

impl Sweep<'_, '_> {
    /// Every configuration of the grid, validated; a list left None takes the command's
    /// default (`detnoise::settings`), as on the command line.
    pub fn configs(&self) -> PyResult<Vec<SimConfig>> {
        let default = |s: &Setting| settings::default_in(self.command, s).expect("has a default");
        let subaps_px = match self.subap_px {
            Some(v) => one_or_many(v, "subap_px", &subap_px_item())?,
            None => settings::parse_list(default(&settings::SUBAP_PX), "subap_px").py()?,
        };
        let spots = match self.spot {
            Some(v) => spots_of(v)?,
            None => Spot::parse_list(&[default(&settings::SPOT).to_string()]).py()?,
        };
        let signals_photons = match self.signal_photons {
            Some(v) => one_or_many(v, "signal_photons", SIGNAL_ITEM)?,
            None => {
                settings::parse_list(default(&settings::SIGNAL_PHOTONS), "signal_photons").py()?
            }
        };
        let grid = Grid {
            subaps_px,
            spots,
            signals_photons,
            shared: self.shared.clone(),
        };
        grid.configs().py()
    }
}

/// `value` for `setting` if the registry takes it, else a `ValueError` naming the keyword.
pub fn checked(setting: &Setting, value: Value) -> PyResult<Value> {
    setting.check(value).map_err(|e| invalid(setting.key, e))
}

/// A Python int for whole-number `setting`, checked by the registry (a negative one too, as a
/// `ValueError` rather than pyo3's `OverflowError`).
pub fn whole(setting: &Setting, v: i128) -> PyResult<u64> {
    let refused = || invalid(setting.key, format!("{v}: {}", setting.expected()));
    let v = u64::try_from(v).map_err(|_| refused())?;
    checked(setting, Value::Whole(v))?;
    Ok(v)
}

/// The configuration settings other than the grid's, each checked by the registry as the
/// command line checks it.
#[allow(clippy::too_many_arguments)]
pub fn shared_config(
    qe: f64,
    iters: i128,
    seed: i128,
    sampling: &str,
    bg_grid: &str,
    position_half_range_px: f64,
    max_empty_frac: f64,
) -> PyResult<SimConfig> {
    checked(&settings::QE, Value::Real(qe))?;
    let (iters, seed) = (
        whole(&settings::ITERS, iters)?,
        whole(&settings::SEED, seed)?,
    );
    checked(
        &settings::POSITION_HALF_RANGE_PX,
        Value::Real(position_half_range_px),
    )?;
    checked(&settings::MAX_EMPTY_FRAC, Value::Real(max_empty_frac))?;
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

/// The centroiders of `centroider` (a comma-separated text or a list of names), with
/// `mask_above` (times the median sigma) for those that take it; checked by the library.
pub fn centroiders_of(
    centroider: &Bound<'_, PyAny>,
    mask_above: Option<f64>,
) -> PyResult<Vec<CentroiderSpec>> {
    let names: Vec<String> = one_or_many(
        centroider,
        "centroider",
        "a centroider name such as \"cog\"",
    )?;
    if let Some(m) = mask_above {
        checked(&settings::MASK_ABOVE, Value::Real(m))?;
    }
    detnoise::centroid::parse_specs(&names.join(","), mask_above).py()
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
    max_empty_frac = 0.01, centroider = None, mask_above = None, progress = None, **params
))]
#[allow(clippy::too_many_arguments)]
pub fn simulate<'py>(
    py: Python<'py>,
    models: Option<&Bound<'py, PyAny>>,
    subap_px: Option<&Bound<'py, PyAny>>,
    spot: Option<&Bound<'py, PyAny>>,
    signal_photons: Option<&Bound<'py, PyAny>>,
    qe: f64,
    iters: i128,
    seed: i128,
    sampling: &str,
    bg_grid: &str,
    position_half_range_px: f64,
    max_empty_frac: f64,
    centroider: Option<&Bound<'py, PyAny>>,
    mask_above: Option<f64>,
    progress: Option<Py<PyAny>>,
    params: Option<&Bound<'py, PyDict>>,
) -> PyResult<Bound<'py, PyAny>> {
    let specs = match models {
        Some(m) => specs_of(m, "models")?,
        None => specs_of(DEFAULT_MODELS.into_pyobject(py)?.as_any(), "models")?,
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
    let configs = Sweep {
        command: "simulate",
        subap_px,
        spot,
        signal_photons,
        shared,
    }
    .configs()?;
    let centroiders = centroiders_or_cog(py, centroider, mask_above)?;
    let p = read_params(py, params)?;
    let records = observed(py, progress, |o| {
        sweep_with(&configs, &specs, &centroiders, &p.model, o)
    })?;
    to_py(py, &records)
}

/// The effective Gaussian read noise of detector `model` over the grid sub-aperture (px) x
/// spot x signal (photons), as `detnoise effective` solves it: one record per configuration
/// with `sigma_eff_e` and its SE `sigma_eff_se_e` (e-: the uniform camera with the same R under
/// the same centroider), the cog-equivalent `sigma_cog_equiv_e` and its SE
/// `sigma_cog_equiv_se_e` (e-: the same under plain `cog`), and a `status` word. Iterations start
/// at `iters` and are added, up to `max_iters`, until the SE is at most `target_se_e` (e-) or
/// `target_rel` times the value.
#[pyfunction]
#[pyo3(signature = (
    model = "scmos-random",
    *, subap_px = None, spot = None, signal_photons = None, qe = 1.0, iters = 10_000, seed = 1,
    sampling = "integrated", bg_grid = "auto", position_half_range_px = 0.5,
    max_empty_frac = 0.01, target_se_e = Precision::DEFAULT_TARGET_SE_E,
    target_rel = Precision::DEFAULT_TARGET_REL, max_iters = None, centroider = None,
    mask_above = None, progress = None, **params
))]
#[allow(clippy::too_many_arguments)]
pub fn effective<'py>(
    py: Python<'py>,
    model: &str,
    subap_px: Option<&Bound<'py, PyAny>>,
    spot: Option<&Bound<'py, PyAny>>,
    signal_photons: Option<&Bound<'py, PyAny>>,
    qe: f64,
    iters: i128,
    seed: i128,
    sampling: &str,
    bg_grid: &str,
    position_half_range_px: f64,
    max_empty_frac: f64,
    target_se_e: f64,
    target_rel: f64,
    max_iters: Option<u64>,
    centroider: Option<&Bound<'py, PyAny>>,
    mask_above: Option<f64>,
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
    let configs = Sweep {
        command: "effective",
        subap_px,
        spot,
        signal_photons,
        shared,
    }
    .configs()?;
    let centroiders = centroiders_or_cog(py, centroider, mask_above)?;
    let iters = configs[0].iters;
    let precision = Precision {
        target_se_e,
        target_rel,
        max_iters: max_iters.unwrap_or(Precision::DEFAULT_MAX_ITERS.max(iters)),
    };
    precision.validate(iters).py()?;
    let p = read_params(py, params)?;
    let records = observed(py, progress, |o| {
        effective_table_with(&configs, &[spec], &centroiders, &p.model, &precision, o)
    })?;
    to_py(py, &records)
}

/// The centroiders given, or the command's default (`cog`) when None.
fn centroiders_or_cog(
    py: Python<'_>,
    centroider: Option<&Bound<'_, PyAny>>,
    mask_above: Option<f64>,
) -> PyResult<Vec<CentroiderSpec>> {
    let default = settings::CENTROIDER
        .default
        .expect("has a default")
        .into_pyobject(py)?;
    centroiders_of(centroider.unwrap_or(default.as_any()), mask_above)
}
