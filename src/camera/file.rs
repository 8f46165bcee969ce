//! The camera model's folder: `camera.json` (the scalars, and which optional maps there are)
//! and one FITS image per map, each with the BUNIT of its values, plus `rts.csv` when the camera
//! has telegraph pixels. Written as an output directory (built beside, moved into place,
//! never over foreign files); read with every check of [`CameraModel::check`].

use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};

use super::model::{CameraModel, DarkCurrent, EmRegisterModel};
use super::range::OperatingRange;
use crate::calib::{Map, Unit};
use crate::io::fits::{write_image, ImageData};
use crate::output::{write_atomic, write_json, DirPlan, OutputDir};
use crate::{Error, Result};

/// Name of the model's header file inside its folder.
pub const CAMERA_JSON: &str = "camera.json";
/// `format` of a camera.json.
const FORMAT: &str = "detnoise-camera";
/// The one version of the format.
const VERSION: u32 = 1;

/// The map files of a camera folder: (file name, BUNIT written, BUNITs accepted on reading).
pub const MAP_FILES: [(&str, &str, &[&str]); 5] = [
    (
        "offset_adu.fits",
        "adu",
        &["adu", "adus", "dn", "count", "counts"],
    ),
    (
        "gain_e_per_adu.fits",
        "electron/adu",
        &["electron/adu", "electrons/adu", "e-/adu", "e/adu"],
    ),
    (
        "read_noise_e.fits",
        "electron",
        &["electron", "electrons", "e-", "e"],
    ),
    (
        "dark_current_e_per_s.fits",
        "electron/s",
        &["electron/s", "electrons/s", "e-/s", "e/s"],
    ),
    (
        "cic_e.fits",
        "electron",
        &[
            "electron",
            "electrons",
            "e-",
            "e",
            "electron/frame",
            "e-/frame",
        ],
    ),
];
const OFFSET: usize = 0;
const GAIN: usize = 1;
const READ_NOISE: usize = 2;
const DARK: usize = 3;
const CIC: usize = 4;
/// The telegraph pixels' table inside the folder.
const RTS_CSV: &str = "rts.csv";

/// camera.json: every scalar of the model, and which optional maps the folder holds.
#[derive(Debug, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct Header {
    format: String,
    version: u32,
    rows: usize,
    cols: usize,
    gain_e_per_adu: f64,
    gain_map: bool,
    row_noise_e: f64,
    column_noise_e: f64,
    frame_noise_e: f64,
    dark_current: Option<DarkHeader>,
    cic: bool,
    rts: bool,
    em_register: Option<RegisterHeader>,
    saturation_adu: f64,
    bit_depth: u32,
    /// Absent in files written before the campaign recorded its conditions (and in models
    /// without one): they read as before, and write the same bytes.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    campaign: Option<OperatingRange>,
}

#[derive(Debug, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct DarkHeader {
    reference_temperature_c: Option<f64>,
    doubling_temperature_c: Option<f64>,
}

#[derive(Debug, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct RegisterHeader {
    stages: u32,
    gain_curve: Vec<[f64; 2]>,
    /// Absent in models written before serial CIC was measured (and when it was not).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    serial_cic_e: Option<f64>,
}

impl CameraModel {
    /// Write the model as the folder `dir` under the output rule: built beside it and moved
    /// into place whole; an earlier model folder is replaced, a folder with files detnoise
    /// did not write is refused (`force`: written beside them); `inputs` are never overwritten.
    pub fn write(&self, dir: &Path, force: bool, inputs: &[PathBuf]) -> Result<PathBuf> {
        self.check()?;
        let names: Vec<&str> = MAP_FILES
            .iter()
            .map(|m| m.0)
            .chain([CAMERA_JSON, RTS_CSV])
            .collect();
        let plan = DirPlan {
            command: "camera",
            force,
            inputs,
            names: &names,
        };
        let out = OutputDir::prepare(dir, plan)?;
        self.write_files(&out.path(""))?;
        out.commit()
    }

    /// Write the model's files into the folder `dir` (created if missing), inside an output
    /// that is being staged (e.g. the `camera/` folder of a campaign's output).
    pub fn write_files(&self, dir: &Path) -> Result<()> {
        self.check()?;
        std::fs::create_dir_all(dir).map_err(|e| Error::io(dir, e))?;
        let out = StagedDir(dir);
        let map = |i: usize, m: &Map| {
            let (name, bunit, _) = MAP_FILES[i];
            write_image(
                &out.path(name),
                m.shape(),
                ImageData::F64(&m.data),
                bunit,
                &[],
            )
        };
        map(OFFSET, &self.offset_adu)?;
        map(READ_NOISE, &self.read_noise_e)?;
        if let Some(g) = &self.gain_map {
            map(GAIN, g)?;
        }
        if let Some(d) = &self.dark {
            map(DARK, &d.map_e_per_s)?;
        }
        if let Some(c) = &self.cic_e {
            map(CIC, c)?;
        }
        if let Some(text) = &self.rts_csv {
            write_atomic(&out.path(RTS_CSV), text.as_bytes())?;
        }
        write_json(&out.path(CAMERA_JSON), &self.header())
    }

    fn header(&self) -> Header {
        let (rows, cols) = self.shape();
        Header {
            format: FORMAT.into(),
            version: VERSION,
            rows,
            cols,
            gain_e_per_adu: self.gain_e_per_adu,
            gain_map: self.gain_map.is_some(),
            row_noise_e: self.row_noise_e,
            column_noise_e: self.column_noise_e,
            frame_noise_e: self.frame_noise_e,
            dark_current: self.dark.as_ref().map(|d| DarkHeader {
                reference_temperature_c: d.reference_temperature_c,
                doubling_temperature_c: d.doubling_temperature_c,
            }),
            cic: self.cic_e.is_some(),
            rts: self.rts_csv.is_some(),
            em_register: self.register.as_ref().map(|r| RegisterHeader {
                stages: r.stages,
                gain_curve: r.gain_curve.iter().map(|&(c, a)| [c, a]).collect(),
                serial_cic_e: r.serial_cic_e,
            }),
            saturation_adu: self.saturation_adu,
            bit_depth: self.bit_depth,
            campaign: self.campaign.clone(),
        }
    }

    /// Read the model folder `dir` (or its `camera.json`), with every check: a missing or
    /// unknown file, a map of another shape than camera.json states or a BUNIT other than its
    /// own, and the checks of [`CameraModel::check`]; errors name the file.
    pub fn read(dir: &Path) -> Result<CameraModel> {
        let dir = if dir.file_name().is_some_and(|n| n == CAMERA_JSON) {
            dir.parent().unwrap_or(Path::new("."))
        } else {
            dir
        };
        let json = dir.join(CAMERA_JSON);
        if !dir.is_dir() {
            return Err(Error::input(
                dir,
                "not a camera model folder (it holds camera.json and the maps): no such directory",
            ));
        }
        let text = std::fs::read_to_string(&json).map_err(|e| {
            Error::input(&json, format!("cannot read the camera model's header: {e}"))
        })?;
        let h: Header = serde_json::from_str(&text)
            .map_err(|e| Error::input(&json, format!("not a camera model header: {e}")))?;
        if h.format != FORMAT || h.version != VERSION {
            return Err(Error::input(
                &json,
                format!(
                    "format {:?} version {}: this detnoise reads {FORMAT:?} version {VERSION}",
                    h.format, h.version
                ),
            ));
        }
        let shape = (h.rows, h.cols);
        let map = |i: usize, unit: Unit| read_map(dir, i, unit, shape);
        let rts_csv = if h.rts {
            let p = dir.join(RTS_CSV);
            Some(std::fs::read_to_string(&p).map_err(|e| Error::input(&p, e.to_string()))?)
        } else {
            None
        };
        let model = CameraModel {
            offset_adu: map(OFFSET, Unit::Adu)?,
            gain_e_per_adu: h.gain_e_per_adu,
            gain_map: h.gain_map.then(|| map(GAIN, Unit::EPerAdu)).transpose()?,
            read_noise_e: map(READ_NOISE, Unit::Electrons)?,
            rts_csv,
            row_noise_e: h.row_noise_e,
            column_noise_e: h.column_noise_e,
            frame_noise_e: h.frame_noise_e,
            dark: h
                .dark_current
                .map(|d| -> Result<DarkCurrent> {
                    Ok(DarkCurrent {
                        map_e_per_s: map(DARK, Unit::Flags)?,
                        reference_temperature_c: d.reference_temperature_c,
                        doubling_temperature_c: d.doubling_temperature_c,
                    })
                })
                .transpose()?,
            cic_e: h.cic.then(|| map(CIC, Unit::Electrons)).transpose()?,
            register: h.em_register.map(|r| EmRegisterModel {
                stages: r.stages,
                gain_curve: r.gain_curve.iter().map(|p| (p[0], p[1])).collect(),
                serial_cic_e: r.serial_cic_e,
            }),
            saturation_adu: h.saturation_adu,
            bit_depth: h.bit_depth,
            campaign: h.campaign,
        };
        model.check().map_err(|e| match e {
            Error::Usage { field, message } => Error::input(&json, format!("`{field}`: {message}")),
            other => other,
        })?;
        Ok(model)
    }
}

/// Map `i` of [`MAP_FILES`] in `dir`: present, of `shape`, with its BUNIT.
fn read_map(dir: &Path, i: usize, unit: Unit, shape: (usize, usize)) -> Result<Map> {
    let (name, _, accepted) = MAP_FILES[i];
    let path = dir.join(name);
    if !path.is_file() {
        return Err(Error::input(
            &path,
            "missing: camera.json says the camera has this map",
        ));
    }
    let image = crate::io::read_image(&path)?;
    let bunit = image.bunit.as_deref().map(str::trim).unwrap_or("");
    if !accepted.contains(&bunit.to_lowercase().as_str()) {
        return Err(Error::input(
            &path,
            format!(
                "BUNIT {bunit:?}: this map's values are in {} (BUNIT one of {})",
                accepted[0],
                accepted.join(", ")
            ),
        ));
    }
    if image.shape != shape {
        return Err(Error::input(
            &path,
            format!(
                "{}x{} px, where camera.json states {}x{} px",
                image.shape.0, image.shape.1, shape.0, shape.1
            ),
        ));
    }
    Ok(Map::new(shape.0, shape.1, image.data, unit).with_source(path.display().to_string()))
}

/// A folder being written under a staged output.
struct StagedDir<'a>(&'a Path);

impl StagedDir<'_> {
    fn path(&self, name: &str) -> std::path::PathBuf {
        self.0.join(name)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn camera() -> CameraModel {
        let offset = Map::new(
            2,
            3,
            vec![100.0, 101.5, 99.0, 100.25, 98.0, 102.0],
            Unit::Adu,
        );
        let rn = Map::new(2, 3, vec![1.0, 1.5, 2.0, 1.2, 0.9, 3.0], Unit::Electrons);
        CameraModel::new(offset, 0.5, rn, 16)
            .unwrap()
            .with_common_noise(0.2, 0.3, 0.4)
            .unwrap()
            .with_dark_current(DarkCurrent {
                map_e_per_s: Map::filled(2, 3, 0.01, Unit::Flags),
                reference_temperature_c: Some(-20.0),
                doubling_temperature_c: Some(6.5),
            })
            .unwrap()
            .with_cic(Map::filled(2, 3, 0.02, Unit::Electrons))
            .unwrap()
            .with_register(EmRegisterModel {
                stages: 604,
                gain_curve: vec![(10.0, 11.0), (1000.0, 950.0)],
                serial_cic_e: Some(0.05),
            })
            .unwrap()
            .with_gain_map(Map::filled(2, 3, 0.5, Unit::EPerAdu))
            .unwrap()
    }

    #[test]
    fn a_model_reads_back_equal_and_writes_the_same_bytes_again() {
        let d = tempfile::tempdir().unwrap();
        let (a, b) = (d.path().join("a"), d.path().join("b"));
        let cam = camera();
        cam.write(&a, false, &[]).unwrap();
        let back = CameraModel::read(&a).unwrap();
        assert_eq!(back, cam);
        back.write(&b, false, &[]).unwrap();
        let mut names: Vec<_> = MAP_FILES.iter().map(|m| m.0).collect();
        names.push(CAMERA_JSON);
        for name in names {
            let (x, y) = (
                std::fs::read(a.join(name)).unwrap(),
                std::fs::read(b.join(name)).unwrap(),
            );
            assert!(x == y, "{name} differs");
        }
        assert_eq!(CameraModel::read(&a.join(CAMERA_JSON)).unwrap(), cam);
    }

    #[test]
    fn the_campaign_range_is_optional_and_reads_back() {
        // A folder written before camera.json had `campaign` (python/tests' committed one).
        let old = Path::new(env!("CARGO_MANIFEST_DIR")).join("python/tests/data/camera");
        let cam = CameraModel::read(&old).unwrap();
        assert_eq!(cam.campaign, None);
        // Without a range camera.json holds no `campaign` key: its bytes are as before.
        let d = tempfile::tempdir().unwrap();
        cam.write(&d.path().join("old"), false, &[]).unwrap();
        let text = std::fs::read_to_string(d.path().join("old").join(CAMERA_JSON)).unwrap();
        assert_eq!(
            text,
            std::fs::read_to_string(old.join(CAMERA_JSON)).unwrap()
        );
        let range = OperatingRange {
            exposures_s: vec![0.01, 0.5],
            em_gains: vec![50.0, 800.0],
            temperatures_c: vec![-60.0],
        };
        let cam = camera().with_campaign(range.clone()).unwrap();
        let dir = d.path().join("new");
        cam.write(&dir, false, &[]).unwrap();
        assert_eq!(CameraModel::read(&dir).unwrap().campaign, Some(range));
        // A bad range is refused naming the file and the list.
        let json = dir.join(CAMERA_JSON);
        let text = std::fs::read_to_string(&json).unwrap();
        std::fs::write(&json, text.replace("0.01", "-0.01")).unwrap();
        let e = CameraModel::read(&dir).unwrap_err().to_string();
        assert!(
            e.contains("camera.json: `campaign.exposures_s`: value 0"),
            "{e}"
        );
    }

    #[test]
    fn a_camera_json_without_serial_cic_reads_as_none() {
        // Models written before the register had a serial-CIC rate hold no such key.
        let d = tempfile::tempdir().unwrap();
        let dir = d.path().join("cam");
        camera().write(&dir, false, &[]).unwrap();
        let json = dir.join(CAMERA_JSON);
        let mut h: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(&json).unwrap()).unwrap();
        let reg = h["em_register"].as_object_mut().unwrap();
        assert_eq!(reg.remove("serial_cic_e"), Some(serde_json::json!(0.05)));
        std::fs::write(&json, serde_json::to_string_pretty(&h).unwrap()).unwrap();
        let back = CameraModel::read(&dir).unwrap();
        assert_eq!(back.register.as_ref().unwrap().serial_cic_e, None);
        let mut expect = camera();
        expect.register.as_mut().unwrap().serial_cic_e = None;
        assert_eq!(back, expect);
        // And a model without it writes no key (older readers' files stay as they were).
        let again = d.path().join("again");
        back.write(&again, false, &[]).unwrap();
        let text = std::fs::read_to_string(again.join(CAMERA_JSON)).unwrap();
        assert!(!text.contains("serial_cic_e"), "{text}");
    }

    #[test]
    fn a_folder_with_foreign_files_is_not_replaced() {
        let d = tempfile::tempdir().unwrap();
        let dir = d.path().join("cam");
        std::fs::create_dir(&dir).unwrap();
        std::fs::write(dir.join("notes.txt"), "mine").unwrap();
        assert!(camera().write(&dir, false, &[]).is_err());
        assert_eq!(
            std::fs::read_to_string(dir.join("notes.txt")).unwrap(),
            "mine"
        );
        assert!(!dir.join(CAMERA_JSON).exists());
    }

    #[test]
    fn bad_folders_are_refused_naming_the_file_and_the_fault() {
        let d = tempfile::tempdir().unwrap();
        let dir = d.path().join("cam");
        camera().write(&dir, false, &[]).unwrap();
        let err = |dir: &Path| CameraModel::read(dir).unwrap_err().to_string();
        // A map of another shape.
        Map::filled(3, 3, 0.02, Unit::Electrons)
            .write_fits(&dir.join("cic_e.fits"), &[])
            .unwrap();
        let e = err(&dir);
        assert!(
            e.contains("cic_e.fits: 3x3 px, where camera.json states 2x3"),
            "{e}"
        );
        // A map in another unit.
        Map::filled(2, 3, 0.02, Unit::Adu)
            .write_fits(&dir.join("cic_e.fits"), &[])
            .unwrap();
        let e = err(&dir);
        assert!(e.contains("cic_e.fits: BUNIT \"adu\""), "{e}");
        // A missing map.
        std::fs::remove_file(dir.join("cic_e.fits")).unwrap();
        let e = err(&dir);
        assert!(e.contains("cic_e.fits: missing"), "{e}");
        // Negative noise, named with its file.
        let mut rn = camera().read_noise_e;
        rn.data[2] = -1.0;
        rn.write_fits(&dir.join("read_noise_e.fits"), &[]).unwrap();
        Map::filled(2, 3, 0.02, Unit::Electrons)
            .write_fits(&dir.join("cic_e.fits"), &[])
            .unwrap();
        let e = err(&dir);
        assert!(
            e.contains("read_noise_e.fits: read_noise_e: 1 pixel(s) outside >= 0"),
            "{e}"
        );
        // A bad scalar in camera.json, and an unknown key.
        camera().write(&dir, false, &[]).unwrap();
        let json = dir.join(CAMERA_JSON);
        let text = std::fs::read_to_string(&json).unwrap();
        std::fs::write(
            &json,
            text.replace("\"frame_noise_e\": 0.4", "\"frame_noise_e\": -0.4"),
        )
        .unwrap();
        let e = err(&dir);
        assert!(
            e.contains("camera.json: `frame_noise_e`: -0.4 e- rms"),
            "{e}"
        );
        std::fs::write(
            &json,
            text.replace("\"cic\": true", "\"cic\": true, \"cics\": 1"),
        )
        .unwrap();
        let e = err(&dir);
        assert!(
            e.contains("camera.json: not a camera model header: unknown field `cics`"),
            "{e}"
        );
        let e = err(&d.path().join("none"));
        assert!(e.contains("not a camera model folder"), "{e}");
    }
}
