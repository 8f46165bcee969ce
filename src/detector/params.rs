//! The settings shared by the readout models of a run; each registry entry lists the fields
//! its builder reads.

use super::dark_frames::DarkFrames;
use super::pp::PpRule;
use super::rts_table::RtsTable;
use super::{EmRegister, ModelSpec};
use crate::calib::{Map, Unit};
use crate::camera::{CameraAt, CameraChoice, CameraModel, ExposureChoice, OperatingPoint};
use crate::pdf::RmsPdf;
use crate::progress::Observer;
use crate::settings::{self as s, Value, Values};
use crate::{Error, Result};
use std::path::PathBuf;
use std::sync::Arc;

/// Parameters shared by the models of a run.
#[derive(Debug, Clone)]
pub struct ModelParams {
    /// EMCCD mean gain (output e- per input e-); paper default 500.
    pub em_gain: f64,
    /// EM register stages; paper default 520.
    pub stages: u32,
    /// EMCCD read noise before division by the gain (e-); paper default 50.
    pub emccd_read_noise_e: f64,
    /// Above this many input electrons `emccd-distribution` uses N(n g, n g^2); None = exact Gamma.
    pub gaussian_switch_e: Option<u32>,
    /// Use the per-stage binomial cascade instead of the tabulated register (reference, slow).
    pub cascade_register: bool,
    /// sigma (e-) for a bare `scmos-constant`.
    pub sigma_e: f64,
    /// Distribution of per-pixel rms for the sCMOS models.
    pub pdf: Arc<dyn RmsPdf>,
    /// Seed of the fixed sCMOS noise patterns (pattern K uses stream K of it).
    pub pattern_seed: u64,
    /// Measured noise map for `scmos-map`.
    pub map: Option<Arc<Map>>,
    /// Threshold rule of `emccd-pp`.
    pub pp_rule: PpRule,
    /// Fixed reference light level of `emccd-pp` (photo-electrons per pixel); None = sub-aperture mean.
    pub pp_lambda: Option<f64>,
    /// Telegraph (RTS) pixels of `scmos-rts`, from the `rts.csv` of `darks` (levels in e-).
    pub rts_table: Option<Arc<RtsTable>>,
    /// Row-noise amplitude of `scmos-correlated` (e- rms, shared by a row of the window).
    pub row_noise_e: Option<f64>,
    /// Column-noise amplitude of `scmos-correlated` (e- rms, shared by a column of the window).
    pub column_noise_e: Option<f64>,
    /// Frame-common noise amplitude of `scmos-correlated` (e- rms, shared by the whole frame).
    pub frame_noise_e: Option<f64>,
    /// The bias-subtracted dark frames (e-) of `scmos-frames`.
    pub dark_frames: Option<Arc<DarkFrames>>,
    /// The camera model of `camera` at the run's operating point.
    pub camera: Option<Arc<CameraAt>>,
    /// The camera model of `camera` itself and how its operating point was chosen (the same
    /// point as `camera`'s).
    pub camera_choice: Option<Arc<CameraChoice>>,
}

impl Default for ModelParams {
    /// Every setting at its registry default (`crate::settings::READOUT`).
    fn default() -> Self {
        ModelParams::from_settings(&Values::default(), &crate::progress::Silent)
            .expect("the registry's defaults are valid and read no file")
    }
}

impl ModelParams {
    /// Check the readout settings together, before any file is read (single values were
    /// checked when given); `specs` are the models the run will build.
    pub fn check_settings(values: &Values, specs: &[ModelSpec]) -> Result<()> {
        let em_gain = values.real(&s::EM_GAIN).unwrap_or(f64::NAN);
        let stages = values.whole(&s::STAGES).unwrap_or(0) as u32;
        EmRegister::check(em_gain, stages, "em_gain")?;
        let pdf_is_file = !matches!(values.get(&s::PDF), Some(Value::Text(t)) if t == "paper");
        if values.is_given(&s::PDF_MODEL) && !pdf_is_file {
            return Err(Error::invalid(
                "pdf_model",
                "applies only with `pdf` FILE, a pdf_fit.json (or a fitted pdf)",
            ));
        }
        for spec in specs {
            for field in spec.entry().params {
                let Some(setting) = s::by_field(field) else {
                    continue;
                };
                if let (None, Some(what)) = (values.get(setting), setting.needs) {
                    return Err(Error::invalid(
                        setting.field,
                        format!(
                            "the {} model needs {what}: give `{}`",
                            spec.name(),
                            setting.field
                        ),
                    ));
                }
            }
        }
        if values.is_given(&s::DARK_FRAMES) && !values.is_given(&s::GAIN_E_PER_ADU) {
            return Err(Error::invalid(
                "gain_e_per_adu",
                "`dark_frames` needs their conversion gain to convert them to e-: give \
                 `gain_e_per_adu`",
            ));
        }
        check_operating_point(values)
    }

    /// The parameters `values` give, the files among them read (a pdf fit, the noise map, the
    /// RTS table, the dark frames); the RTS table's skipped rows are told to `observer`.
    pub fn from_settings(values: &Values, observer: &dyn Observer) -> Result<ModelParams> {
        Self::check_settings(values, &[])?;
        let real = |setting| values.real(setting);
        let camera_choice = camera(values, observer)?;
        Ok(ModelParams {
            em_gain: real(&s::EM_GAIN).expect("has a default"),
            stages: values.whole(&s::STAGES).expect("has a default") as u32,
            emccd_read_noise_e: real(&s::EMCCD_READ_NOISE_E).expect("has a default"),
            gaussian_switch_e: values.whole(&s::GAUSSIAN_SWITCH_E).map(|n| n as u32),
            cascade_register: values.text(&s::REGISTER).as_deref() == Some("cascade"),
            sigma_e: real(&s::SIGMA_E).expect("has a default"),
            pdf: rms_pdf(values)?,
            pattern_seed: values.whole(&s::PATTERN_SEED).expect("has a default"),
            map: noise_map(values)?,
            pp_rule: values
                .text(&s::PP_RULE)
                .and_then(|t| PpRule::parse(&t))
                .expect("a checked choice"),
            pp_lambda: real(&s::PP_LAMBDA),
            rts_table: values
                .path(&s::RTS_TABLE)
                .map(|p| RtsTable::read(&p, observer).map(Arc::new))
                .transpose()?,
            row_noise_e: real(&s::ROW_NOISE_E),
            column_noise_e: real(&s::COLUMN_NOISE_E),
            frame_noise_e: real(&s::FRAME_NOISE_E),
            dark_frames: dark_frames(values, observer)?,
            camera: camera_choice.as_ref().map(|c| c.at.clone()),
            camera_choice,
        })
    }

    /// The files `values` name (a pdf fit, the map, the RTS table, the dark frames), for the
    /// output-path checks: none of them may be overwritten.
    pub fn input_files(values: &Values) -> Vec<PathBuf> {
        let pdf = match values.get(&s::PDF) {
            Some(Value::Text(t)) if t != "paper" => Some(PathBuf::from(t)),
            Some(Value::Path(p)) => Some(p),
            _ => None,
        };
        let files = values.path(&s::MAP).into_iter().chain(pdf);
        let files = files.chain(values.path(&s::RTS_TABLE));
        let files = files.chain(values.paths(&s::DARK_FRAMES));
        files.chain(camera_files(values)).collect()
    }
}

/// The operating-point settings go with `camera` (whose exposure defaults from its campaign,
/// see [`CameraChoice::new`]).
fn check_operating_point(values: &Values) -> Result<()> {
    if !values.is_given(&s::CAMERA) {
        for setting in [&s::EXPOSURE_S, &s::TEMPERATURE_C, &s::FRAME_RATE_HZ] {
            if values.is_given(setting) {
                return Err(Error::invalid(
                    setting.field,
                    "is an operating point of a camera model: applies only with `camera` FILE",
                ));
            }
        }
    }
    Ok(())
}

/// The operating point the settings give: `exposure_s` (else 1 / `frame_rate_hz`), `em_gain`
/// when given (else none: no multiplication), `temperature_c` when given; None without an
/// exposure or a frame rate.
pub fn operating_point(values: &Values) -> Option<OperatingPoint> {
    let (exposure_s, _) = given_exposure(values)?;
    Some(OperatingPoint {
        exposure_s,
        em_gain: given_em_gain(values),
        temperature_c: values.real(&s::TEMPERATURE_C),
    })
}

/// The exposure the settings give (s) and how: `exposure_s`, else 1 / `frame_rate_hz`.
fn given_exposure(values: &Values) -> Option<(f64, ExposureChoice)> {
    values
        .real(&s::EXPOSURE_S)
        .map(|t| (t, ExposureChoice::Given))
        .or_else(|| {
            let rate = values.real(&s::FRAME_RATE_HZ)?;
            Some((1.0 / rate, ExposureChoice::FrameRate))
        })
}

/// The commanded EM gain when `em_gain` is given (its registry default is the EMCCD models').
fn given_em_gain(values: &Values) -> Option<f64> {
    values
        .is_given(&s::EM_GAIN)
        .then(|| values.real(&s::EM_GAIN))
        .flatten()
}

/// The camera model of `camera` at the operating point of the settings (the exposure from its
/// campaign when none is given); the default exposure and a point beyond the campaign are told
/// to `observer`.
fn camera(values: &Values, observer: &dyn Observer) -> Result<Option<Arc<CameraChoice>>> {
    let Some(path) = values.path(&s::CAMERA) else {
        return Ok(None);
    };
    let choice = CameraChoice::new(
        CameraModel::read(&path)?,
        given_exposure(values),
        given_em_gain(values),
        values.real(&s::TEMPERATURE_C),
    )?;
    for notice in choice.notices() {
        observer.warn(&format!("{}: {notice}", path.display()));
    }
    Ok(Some(Arc::new(choice)))
}

/// The files of the camera model folder of `camera` (for the output checks).
fn camera_files(values: &Values) -> Vec<PathBuf> {
    let Some(dir) = values.path(&s::CAMERA) else {
        return Vec::new();
    };
    let names = crate::camera::MAP_FILES.iter().map(|m| m.0);
    let mut files: Vec<PathBuf> = names
        .chain([crate::camera::CAMERA_JSON, "rts.csv"])
        .map(|n| dir.join(n))
        .collect();
    files.push(dir);
    files
}

/// The per-pixel rms distribution `pdf` names: the paper's, a fitted one, or a pdf_fit.json.
fn rms_pdf(values: &Values) -> Result<Arc<dyn RmsPdf>> {
    let model = values.text(&s::PDF_MODEL);
    match values.get(&s::PDF) {
        Some(Value::Pdf(pdf)) => Ok(pdf),
        Some(Value::Text(t)) if t == "paper" => Ok(Arc::new(crate::pdf::paper())),
        _ => {
            let path = values.path(&s::PDF).expect("pdf has a default");
            crate::fit::pdf_fit::load_pdf_fit(&path, model.as_deref())
        }
    }
}

/// The measured noise map of `map`: an array given, or a file in e-; either refused when it
/// cannot be a read-noise map (negative or only zero values).
fn noise_map(values: &Values) -> Result<Option<Arc<Map>>> {
    match values.get(&s::MAP) {
        None => Ok(None),
        Some(Value::Map(map)) => match map.noise_problem() {
            Some(problem) => Err(Error::invalid(s::MAP.field, problem)),
            None => Ok(Some(map)),
        },
        Some(_) => {
            let path = values.path(&s::MAP).expect("given");
            Ok(Some(Arc::new(Map::read_noise(path, Unit::Electrons)?)))
        }
    }
}

/// The dark frames of `dark_frames`, converted with `gain_e_per_adu` (a stack too short to
/// stand for its camera warned of).
fn dark_frames(values: &Values, observer: &dyn Observer) -> Result<Option<Arc<DarkFrames>>> {
    let paths = values.paths(&s::DARK_FRAMES);
    if paths.is_empty() {
        return Ok(None);
    }
    // `check_settings` has refused dark frames without a gain.
    let gain = values.real(&s::GAIN_E_PER_ADU).unwrap_or(f64::NAN);
    let max_mib = values.real(&s::DARK_FRAMES_MAX_MIB).expect("has a default");
    let frames = DarkFrames::read(&paths, gain, max_mib)?;
    if let Some(warning) = frames.few_frames() {
        observer.warn(&warning);
    }
    Ok(Some(Arc::new(frames)))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn dark_frames_of_a_short_stack_are_warned_of() {
        let dir = tempfile::tempdir().unwrap();
        let read = |count: usize| {
            let path = dir.path().join(format!("darks-{count}.fits"));
            let mut next = || vec![100.0; 16];
            crate::io::fits::write_cube(&path, (4, 4), count, false, &mut next, &[]).unwrap();
            let mut v = Values::default();
            v.set(&s::DARK_FRAMES, Value::Paths(vec![path]));
            v.set(&s::GAIN_E_PER_ADU, Value::Real(1.0));
            let seen = crate::progress::Recorder::default();
            ModelParams::from_settings(&v, &seen).unwrap();
            seen.warnings.into_inner().unwrap()
        };
        let warned = read(5);
        assert_eq!(warned.len(), 1, "{warned:?}");
        assert!(
            warned[0].contains("darks-5.fits: only 5 dark frames"),
            "{warned:?}"
        );
        assert!(read(100).is_empty());
    }

    #[test]
    fn a_map_given_as_values_is_checked_as_a_noise_map() {
        let with = |data: Vec<f64>| {
            let mut v = Values::default();
            let map = Map::new(1, 3, data, Unit::Electrons).with_source("`map_e`");
            v.set(&s::MAP, Value::Map(Arc::new(map)));
            ModelParams::from_settings(&v, &crate::progress::Silent)
        };
        assert!(with(vec![0.5, f64::NAN, 2.0]).unwrap().map.is_some());
        for (data, says) in [
            (
                vec![0.5, -1.0, 2.0],
                "1 negative pixel(s), the first at row 0, column 1",
            ),
            (vec![0.0, 0.0, f64::NAN], "every pixel is 0"),
        ] {
            match with(data) {
                Err(Error::Usage { field, message }) => {
                    assert_eq!(field, "map");
                    assert!(message.contains(says), "{message}");
                }
                other => panic!("{:?}", other.map(|p| p.map)),
            }
        }
    }
}
