//! `detnoise.campaign`: a characterisation campaign (dark and flat stacks at several
//! exposures, EM gains and temperatures) measured and decomposed as `detnoise campaign` does,
//! its outputs written to `out` and returned as dicts and numpy arrays.

use std::path::PathBuf;

use crate::calib::paths_of;
use crate::convert::{images_dict, json_to_py, to_py};
use crate::errors::invalid;
use detnoise::calib::darks::Clip;
use detnoise::campaign::fit::{FitThresholds, HotRule, TemperatureTerm, OUTPUT_NAMES};
use detnoise::campaign::{
    run, CampaignInput, CampaignRun, ConditionRow, KeywordOptions, MeasureOptions, StackKind,
};
use detnoise::io::{read_image, Checksum, Image};
use pyo3::prelude::*;
use pyo3::types::PyDict;

/// What a campaign produced: its conditions table, its summaries and the decomposition's maps.
#[pyclass(module = "detnoise._detnoise", name = "Campaign", frozen)]
pub struct PyCampaign {
    out: PathBuf,
    conditions: Vec<ConditionRow>,
    summary: serde_json::Value,
    decomposition: serde_json::Value,
    maps: Vec<(String, Image)>,
    camera: Option<PathBuf>,
}

#[pymethods]
impl PyCampaign {
    /// The output directory written (conditions.csv, campaign.json, the maps, camera/).
    #[getter]
    fn out(&self) -> PathBuf {
        self.out.clone()
    }

    /// One dict per stack, in input order, with the columns of conditions.csv (noise in adu).
    #[getter]
    fn conditions<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        to_py(py, &self.conditions)
    }

    /// campaign.json as a dict.
    #[getter]
    fn summary<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        json_to_py(py, &self.summary)
    }

    /// decomposition.json as a dict (the fit's figures, hot pixels, fit quality, notes).
    #[getter]
    fn decomposition<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        json_to_py(py, &self.decomposition)
    }

    /// The decomposition's maps as 2-D float64 arrays, keyed by file name without `.fits`:
    /// offset_adu, offset_se_adu, dark_current_e_per_s, dark_current_se_e_per_s,
    /// fit_reduced_chi2, hot_class (0 normal, 1 warm, 2 hot, 3 not fitted) and, with CIC
    /// fitted, cic_e_per_frame and cic_se_e_per_frame.
    #[getter]
    fn maps<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        images_dict(py, &self.maps)
    }

    /// The camera model folder written (for `Readout.from_camera`, `--camera`); None when the
    /// campaign could not describe a camera.
    #[getter]
    fn camera(&self) -> Option<PathBuf> {
        self.camera.clone()
    }

    fn __repr__(&self) -> String {
        format!(
            "Campaign({} stacks, {} maps, out={:?})",
            self.conditions.len(),
            self.maps.len(),
            self.out.display().to_string()
        )
    }
}

/// The stacks' source: exactly one of `manifest`, `emva` and `files`.
fn input_of(
    manifest: Option<PathBuf>,
    emva: Option<PathBuf>,
    files: Option<&Bound<'_, PyAny>>,
    keywords: KeywordOptions,
) -> PyResult<CampaignInput> {
    match (manifest, emva, files) {
        (Some(m), None, None) => Ok(CampaignInput::Manifest(m)),
        (None, Some(e), None) => Ok(CampaignInput::Emva(e)),
        (None, None, Some(f)) => Ok(CampaignInput::Keywords {
            files: paths_of(f)?,
            options: keywords,
        }),
        _ => Err(invalid(
            "manifest",
            "give exactly one of `manifest` (CSV), `emva` (EMVA 1288 descriptor) and `files` \
             (FITS stacks with header keywords)",
        )),
    }
}

/// `clip` / `sigma_clip` as the library's rejection (checked by the run).
fn clip_of(clip: usize, sigma_clip: Option<f64>) -> PyResult<Clip> {
    match (clip, sigma_clip) {
        (n, Some(_)) if n > 0 => Err(invalid(
            "sigma_clip",
            "give one rejection: `clip` or `sigma_clip`, not both",
        )),
        (_, Some(k)) => Ok(Clip::Sigma(k)),
        (0, None) => Ok(Clip::None),
        (n, None) => Ok(Clip::Extremes(n)),
    }
}

/// The warm/hot rule: robust sigmas, or absolute e-/s when both are given.
fn hot_rule(
    warm_sigma: f64,
    hot_sigma: f64,
    warm_e_per_s: Option<f64>,
    hot_e_per_s: Option<f64>,
) -> PyResult<HotRule> {
    match (warm_e_per_s, hot_e_per_s) {
        (Some(warm_e_per_s), Some(hot_e_per_s)) => Ok(HotRule::Absolute {
            warm_e_per_s,
            hot_e_per_s,
        }),
        (None, None) => Ok(HotRule::Robust {
            warm_sigmas: warm_sigma,
            hot_sigmas: hot_sigma,
        }),
        _ => Err(invalid(
            "hot_e_per_s",
            "give both `warm_e_per_s` and `hot_e_per_s` (absolute thresholds), or neither",
        )),
    }
}

/// `temperature_term`: "off", "fit" or a doubling temperature in deg C (> 0).
fn temperature_of(term: &Bound<'_, PyAny>) -> PyResult<TemperatureTerm> {
    let text = match term.extract::<String>() {
        Ok(t) => t,
        Err(_) => term.extract::<f64>()?.to_string(),
    };
    detnoise::cli::campaign::parse_temperature_term(&text)
        .map_err(|why| invalid("temperature_term", why))
}

/// Measure and decompose a campaign as `detnoise campaign`, writing its outputs to `out`.
#[pyfunction]
#[pyo3(name = "campaign")]
#[pyo3(signature = (*, manifest = None, emva = None, files = None, out, gain_e_per_adu, exposure_key = "EXPTIME".to_string(), em_gain_key = None, temperature_key = None, kind_key = None, kind = None, light_key = None, force = false, checksum = Some("blake3"), em_fit = true, temperature_term = None, clip = 0, sigma_clip = None, common_mode = false, warm_sigma = 5.0, hot_sigma = 25.0, warm_e_per_s = None, hot_e_per_s = None, bad_fit_p_value = 1e-3, progress = None))]
#[allow(clippy::too_many_arguments)]
pub fn campaign_py(
    py: Python<'_>,
    manifest: Option<PathBuf>,
    emva: Option<PathBuf>,
    files: Option<&Bound<'_, PyAny>>,
    out: PathBuf,
    gain_e_per_adu: f64,
    exposure_key: String,
    em_gain_key: Option<String>,
    temperature_key: Option<String>,
    kind_key: Option<String>,
    kind: Option<&str>,
    light_key: Option<String>,
    force: bool,
    checksum: Option<&str>,
    em_fit: bool,
    temperature_term: Option<&Bound<'_, PyAny>>,
    clip: usize,
    sigma_clip: Option<f64>,
    common_mode: bool,
    warm_sigma: f64,
    hot_sigma: f64,
    warm_e_per_s: Option<f64>,
    hot_e_per_s: Option<f64>,
    bad_fit_p_value: f64,
    progress: Option<Py<PyAny>>,
) -> PyResult<PyCampaign> {
    let kind = match kind {
        None => None,
        Some("dark") => Some(StackKind::Dark),
        Some("flat") => Some(StackKind::Flat),
        Some(other) => {
            return Err(invalid(
                "kind",
                format!("{other:?}: must be \"dark\", \"flat\" or None"),
            ))
        }
    };
    let keywords = KeywordOptions {
        exposure_key,
        em_gain_key,
        temperature_key,
        kind_key,
        kind,
        light_key,
    };
    let checksum = match checksum {
        None => None,
        Some("blake3") => Some(Checksum::Blake3),
        Some("sha256") => Some(Checksum::Sha256),
        Some(other) => {
            return Err(invalid(
                "checksum",
                format!("{other:?}: must be \"blake3\", \"sha256\" or None"),
            ))
        }
    };
    let job = CampaignRun {
        input: input_of(manifest, emva, files, keywords)?,
        out,
        force,
        measure: MeasureOptions {
            gain_e_per_adu,
            checksum,
            em_fit,
            clip: clip_of(clip, sigma_clip)?,
            common_mode,
        },
        temperature: match temperature_term {
            Some(t) => temperature_of(t)?,
            None => TemperatureTerm::Off,
        },
        thresholds: FitThresholds {
            hot: hot_rule(warm_sigma, hot_sigma, warm_e_per_s, hot_e_per_s)?,
            bad_fit_p_value,
        },
    };
    crate::observer::observed(py, progress, |observer| {
        let r = run(&job, observer)?;
        let json = |name: &str| -> detnoise::Result<serde_json::Value> {
            let path = r.out.join(name);
            let text = std::fs::read_to_string(&path).map_err(|e| detnoise::Error::io(&path, e))?;
            serde_json::from_str(&text)
                .map_err(|e| detnoise::Error::input(&path, format!("not JSON: {e}")))
        };
        let mut maps = Vec::new();
        for name in OUTPUT_NAMES {
            let path = r.out.join(name);
            if let (Some(stem), true) = (name.strip_suffix(".fits"), path.exists()) {
                maps.push((stem.to_string(), read_image(&path)?));
            }
        }
        let camera = r.out.join(detnoise::campaign::CAMERA_DIR);
        Ok(PyCampaign {
            conditions: r.stacks.iter().map(ConditionRow::of).collect(),
            summary: json("campaign.json")?,
            decomposition: json("decomposition.json")?,
            maps,
            camera: camera.is_dir().then_some(camera),
            out: r.out,
        })
    })
}
