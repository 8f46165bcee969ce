//! An operating point (exposure, EM gain, temperature) and the camera at it: per pixel the
//! expected dark signal, the offset and the noise of every term, input-referred.

use std::sync::Arc;

use super::model::CameraModel;
use super::point::OperatingPoint;
use crate::calib::Map;
use crate::detector::register::{excess_noise_factor_sq, serial_cic_moments};
use crate::detector::telegraph::TelegraphPixels;
use crate::{Error, Result};

pub use crate::settings::MAX_EXPOSURE_S;

/// The camera at an operating point. Electrons are input-referred (an EM register's mean gain
/// divided out), as the readout models output them; per-pixel vectors are row-major.
#[derive(Debug, Clone, PartialEq)]
pub struct CameraAt {
    /// The operating point.
    pub point: OperatingPoint,
    /// Frame shape (rows, cols).
    pub shape: (usize, usize),
    /// Actual mean EM gain, e-/e- (1 without multiplication).
    pub em_gain: f64,
    /// Register stages when the camera multiplies (EM gain > 1), for its exact sampler.
    pub stages: Option<u32>,
    /// Excess noise factor squared of the register at this gain (1 without multiplication).
    pub excess_noise_f2: f64,
    /// Offset of each pixel, adu (a pixel without a value: the map's median).
    pub offset_adu: Vec<f64>,
    /// Conversion gain of each pixel, e- (output) per adu.
    pub gain_e_per_adu: Vec<f64>,
    /// Expected dark charge of each pixel per frame, e-: dark current x exposure + CIC (the
    /// charge that enters the register; serial CIC apart, see [`CameraAt::dark_signal_e`]).
    pub dark_e: Vec<f64>,
    /// Serial (in-register) CIC, events per pixel per frame (0 without multiplication or
    /// without a measured rate).
    pub serial_cic_e: f64,
    /// Mean of the serial CIC's output per pixel, e- input-referred.
    pub serial_cic_mean_e: f64,
    /// Variance of the serial CIC's output per pixel, e-^2 input-referred.
    pub serial_cic_variance_e2: f64,
    /// The telegraph pixels of the model's `rts.csv`, levels and widths output-referred e-
    /// (divided by the EM gain where used); None: none.
    pub(crate) telegraph: Option<Arc<TelegraphPixels>>,
    /// Read noise of each pixel, e- rms, input-referred (a pixel without a value: the map's rms).
    pub read_noise_e: Vec<f64>,
    /// Row noise, e- rms, input-referred.
    pub row_noise_e: f64,
    /// Column noise, e- rms, input-referred.
    pub column_noise_e: f64,
    /// Frame-common noise, e- rms, input-referred.
    pub frame_noise_e: f64,
    /// Largest value the camera outputs, adu.
    pub saturation_adu: f64,
}

impl CameraModel {
    /// The camera at `op`; refused (naming the setting) for an exposure <= 0, an EM gain on a
    /// camera without a register or outside its gain curve, a temperature without a dark
    /// current temperature law.
    pub fn at(&self, op: OperatingPoint) -> Result<CameraAt> {
        if !(op.exposure_s > 0.0 && op.exposure_s <= MAX_EXPOSURE_S) {
            return Err(Error::invalid(
                "exposure_s",
                format!(
                    "{} s: must be > 0 and at most {MAX_EXPOSURE_S} s",
                    op.exposure_s
                ),
            ));
        }
        let (em_gain, stages) = match op.em_gain {
            Some(g) => (
                self.actual_em_gain(g)?,
                self.register.as_ref().map(|r| r.stages),
            ),
            None => (1.0, None),
        };
        let stages = stages.filter(|_| em_gain > 1.0);
        let f2 = stages.map_or(1.0, |s| excess_noise_factor_sq(em_gain, s));
        let dark_scale = self.dark_scale(op.temperature_c)?;
        let n = self.offset_adu.data.len();
        let dark_e_per_s = self.dark.as_ref().map(|d| filled(&d.map_e_per_s, median));
        let cic = self.cic_e.as_ref().map(|c| filled(c, median));
        let dark_e = (0..n)
            .map(|i| {
                let d = dark_e_per_s
                    .as_ref()
                    .map_or(0.0, |d| d[i] * dark_scale * op.exposure_s);
                d + cic.as_ref().map_or(0.0, |c| c[i])
            })
            .collect();
        let gain_e_per_adu = match &self.gain_map {
            Some(g) => g
                .data
                .iter()
                .map(|v| {
                    if v.is_finite() {
                        *v
                    } else {
                        self.gain_e_per_adu
                    }
                })
                .collect(),
            None => vec![self.gain_e_per_adu; n],
        };
        let serial_cic_e = match (stages, &self.register) {
            (Some(_), Some(r)) => r.serial_cic_e.unwrap_or(0.0),
            _ => 0.0,
        };
        let (m1, m2) = stages.map_or((0.0, 0.0), |s| serial_cic_moments(em_gain, s));
        Ok(CameraAt {
            point: op,
            shape: self.shape(),
            em_gain,
            stages,
            excess_noise_f2: f2,
            offset_adu: filled(&self.offset_adu, median),
            gain_e_per_adu,
            dark_e,
            serial_cic_e,
            serial_cic_mean_e: serial_cic_e * m1 / em_gain,
            serial_cic_variance_e2: serial_cic_e * m2 / (em_gain * em_gain),
            telegraph: self.telegraph()?.map(Arc::new),
            read_noise_e: filled(&self.read_noise_e, rms)
                .iter()
                .map(|s| s / em_gain)
                .collect(),
            row_noise_e: self.row_noise_e / em_gain,
            column_noise_e: self.column_noise_e / em_gain,
            frame_noise_e: self.frame_noise_e / em_gain,
            saturation_adu: self.saturation_adu,
        })
    }

    /// The dark current at `temperature_c` relative to its reference (1 at the reference).
    fn dark_scale(&self, temperature_c: Option<f64>) -> Result<f64> {
        let Some(t) = temperature_c else {
            return Ok(1.0);
        };
        let law = self
            .dark
            .as_ref()
            .and_then(|d| Some((d.reference_temperature_c?, d.doubling_temperature_c?)));
        let Some((t_ref, t_d)) = law else {
            return Err(Error::invalid(
                "temperature_c",
                format!(
                    "{t} degrees C: the camera model has no dark current temperature law (its \
                     dark current needs a reference and a doubling temperature): give no \
                     temperature"
                ),
            ));
        };
        if !(t.is_finite() && (-273.15..=200.0).contains(&t)) {
            return Err(Error::invalid(
                "temperature_c",
                format!("{t} degrees C: must be from -273.15 to 200"),
            ));
        }
        Ok(2f64.powf((t - t_ref) / t_d))
    }
}

impl CameraAt {
    /// Number of pixels.
    pub fn pixels(&self) -> usize {
        self.offset_adu.len()
    }

    /// The kind of camera at this point: an EMCCD when its register multiplies, else a camera
    /// read directly (sCMOS, or a CCD without EM gain).
    pub fn sensor(&self) -> crate::detector::sensor::Sensor {
        match self.stages {
            Some(_) => crate::detector::sensor::Sensor::Emccd,
            None => crate::detector::sensor::Sensor::Scmos,
        }
    }

    /// Expected dark signal of pixel `i` per frame, e- input-referred: its dark charge and
    /// the serial CIC's mean output.
    pub fn dark_signal_e(&self, i: usize) -> f64 {
        self.dark_e[i] + self.serial_cic_mean_e
    }

    /// Variance of pixel `i`'s own noise, e-^2: read noise (at a telegraph pixel its
    /// telegraph's variance instead), the dark charge's shot noise (times the register's excess
    /// noise factor squared), the serial CIC's and the quantisation's.
    pub fn pixel_variance_e2(&self, i: usize) -> f64 {
        self.read_variance_e2(i)
            + self.excess_noise_f2 * self.dark_e[i]
            + self.serial_cic_variance_e2
            + self.quantisation_variance_e2(i)
    }

    /// Variance of pixel `i`'s read noise, e-^2 input-referred: the read noise map's, or at a
    /// telegraph pixel sum_k occupancy_k ((level_k - mean)^2 + width_k^2) (the table's widths
    /// are the pixel's Gaussian noise around each level, so they replace the map's sigma there,
    /// as in `scmos-rts`).
    pub fn read_variance_e2(&self, i: usize) -> f64 {
        match self.telegraph_at(i) {
            Some(t) => t.variance_e2() / (self.em_gain * self.em_gain),
            None => self.read_noise_e[i].powi(2),
        }
    }

    /// The telegraph of pixel `i`, if it is a telegraph pixel.
    pub(crate) fn telegraph_at(&self, i: usize) -> Option<&crate::detector::telegraph::Telegraph> {
        let cols = self.shape.1;
        self.telegraph.as_ref()?.at(i / cols, i % cols)
    }

    /// Variance the rounding to whole adu adds to pixel `i`, e-^2 input-referred: 1/12 adu^2
    /// (exact for noise above about 0.5 adu rms; Sheppard's correction).
    pub fn quantisation_variance_e2(&self, i: usize) -> f64 {
        (self.gain_e_per_adu[i] / self.em_gain).powi(2) / 12.0
    }

    /// Pixel `i` holding `e` e- (input-referred, the dark signal included) as the camera
    /// outputs it, adu: offset plus `e` converted, rounded to a whole adu and clipped to
    /// [0, saturation].
    pub fn digitise(&self, i: usize, e: f64) -> f64 {
        (self.offset_adu[i] + e * self.adu_per_e(i))
            .round()
            .clamp(0.0, self.saturation_adu)
    }

    /// Pixel `i`'s value `x` (e- input-referred, the expected dark signal taken off) after the
    /// camera's converter: digitised ([`CameraAt::digitise`]) and converted back.
    pub fn quantised_e(&self, i: usize, x: f64) -> f64 {
        let dark = self.dark_signal_e(i);
        (self.digitise(i, x + dark) - self.offset_adu[i]) / self.adu_per_e(i) - dark
    }

    /// Variance of noise common to a row, a column and the frame, e-^2 (each counted once).
    pub fn common_variance_e2(&self) -> f64 {
        self.row_noise_e.powi(2) + self.column_noise_e.powi(2) + self.frame_noise_e.powi(2)
    }

    /// Total temporal variance of pixel `i`, e-^2: its own noise and the common terms.
    pub fn total_variance_e2(&self, i: usize) -> f64 {
        self.pixel_variance_e2(i) + self.common_variance_e2()
    }

    /// Total temporal noise of every pixel, e- rms.
    pub fn total_noise_e(&self) -> Vec<f64> {
        (0..self.pixels())
            .map(|i| self.total_variance_e2(i).sqrt())
            .collect()
    }

    /// Output adu per input e- of pixel `i` (the EM gain over the conversion gain).
    pub fn adu_per_e(&self, i: usize) -> f64 {
        self.em_gain / self.gain_e_per_adu[i]
    }

    /// Expected value of pixel `i` in a dark frame, adu: offset plus the dark signal.
    pub fn mean_adu(&self, i: usize) -> f64 {
        self.offset_adu[i] + self.dark_signal_e(i) * self.adu_per_e(i)
    }

    /// Total temporal noise of pixel `i`, adu rms.
    pub fn noise_adu(&self, i: usize) -> f64 {
        self.total_variance_e2(i).sqrt() * self.adu_per_e(i)
    }

    /// The effective read noise of the camera at this point, e- rms input-referred: the median
    /// over the pixels of the total temporal noise (read or telegraph, dark shot, CIC, serial
    /// CIC, quantisation, row, column, frame).
    pub fn effective_read_noise_e(&self) -> f64 {
        crate::stats::median(&self.total_noise_e())
    }

    /// `values` (one per pixel) as a map of this camera's shape in `unit`.
    pub fn map(&self, values: Vec<f64>, unit: crate::calib::Unit) -> Map {
        Map::new(self.shape.0, self.shape.1, values, unit)
    }
}

/// The map's values with non-finite pixels replaced by `fill` of the finite ones.
fn filled(map: &Map, fill: fn(&[f64]) -> f64) -> Vec<f64> {
    let finite: Vec<f64> = map.data.iter().copied().filter(|v| v.is_finite()).collect();
    let value = fill(&finite);
    map.data
        .iter()
        .map(|v| if v.is_finite() { *v } else { value })
        .collect()
}

fn median(values: &[f64]) -> f64 {
    crate::stats::median(values)
}

fn rms(values: &[f64]) -> f64 {
    (values.iter().map(|v| v * v).sum::<f64>() / values.len() as f64).sqrt()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::calib::Unit;
    use crate::camera::{DarkCurrent, EmRegisterModel};

    fn camera(register: bool, law: bool) -> CameraModel {
        let cam = CameraModel::new(
            Map::filled(1, 2, 100.0, Unit::Adu),
            2.0,
            Map::new(1, 2, vec![3.0, f64::NAN], Unit::Electrons),
            16,
        )
        .unwrap()
        .with_common_noise(0.3, 0.4, 1.2)
        .unwrap()
        .with_dark_current(DarkCurrent {
            map_e_per_s: Map::new(1, 2, vec![0.5, 1.5], Unit::Flags),
            reference_temperature_c: law.then_some(-10.0),
            doubling_temperature_c: law.then_some(5.0),
        })
        .unwrap()
        .with_cic(Map::filled(1, 2, 0.1, Unit::Electrons))
        .unwrap();
        if register {
            cam.with_register(EmRegisterModel {
                stages: 604,
                gain_curve: vec![],
                serial_cic_e: None,
            })
            .unwrap()
        } else {
            cam
        }
    }

    #[test]
    fn dark_signal_noise_and_offset_at_an_operating_point() {
        let op = OperatingPoint {
            exposure_s: 2.0,
            em_gain: None,
            temperature_c: Some(-5.0),
        };
        let at = camera(false, true).at(op).unwrap();
        // Dark current doubles from -10 to -5 C: 2 x 0.5 e-/s x 2 s + 0.1 e- CIC.
        assert_eq!(at.dark_e, vec![2.1, 6.1]);
        assert_eq!(at.read_noise_e, vec![3.0, 3.0]);
        let common = 0.09 + 0.16 + 1.44;
        // The rounding to whole adu adds 1/12 adu^2: (2 e-/adu)^2 / 12.
        let q = 4.0 / 12.0;
        assert!((at.total_variance_e2(0) - (9.0 + 2.1 + q + common)).abs() < 1e-12);
        assert_eq!(at.mean_adu(1), 100.0 + 6.1 / 2.0);
        assert_eq!(at.sensor(), crate::detector::sensor::Sensor::Scmos);
        // Behind a register of gain 100: read and common noise divided by it, shot noise
        // times F^2 (1.976 for 604 stages at this gain, not 2).
        let op = OperatingPoint {
            exposure_s: 2.0,
            em_gain: Some(100.0),
            temperature_c: None,
        };
        let at = camera(true, false).at(op).unwrap();
        assert!((at.excess_noise_f2 - excess_noise_factor_sq(100.0, 604)).abs() < 1e-12);
        assert!(
            (at.excess_noise_f2 - 1.98).abs() < 0.01,
            "{}",
            at.excess_noise_f2
        );
        let v = 0.03f64.powi(2) + at.excess_noise_f2 * 1.1 + common / 1e4 + q / 1e4;
        assert!((at.total_variance_e2(0) - v).abs() < 1e-12);
        assert_eq!(at.mean_adu(0), 100.0 + 1.1 * 50.0);
        assert_eq!(at.sensor(), crate::detector::sensor::Sensor::Emccd);
        // With serial CIC (0.1 events per pixel): its mean output and variance, divided by
        // the gain, join the dark signal and the variance.
        let mut cam = camera(true, false);
        cam.register.as_mut().unwrap().serial_cic_e = Some(0.1);
        let with = cam.at(op).unwrap();
        let (m1, m2) = serial_cic_moments(100.0, 604);
        assert!((with.dark_signal_e(0) - (1.1 + 0.1 * m1 / 100.0)).abs() < 1e-12);
        assert!((with.mean_adu(0) - (100.0 + with.dark_signal_e(0) * 50.0)).abs() < 1e-9);
        let dv = with.total_variance_e2(0) - at.total_variance_e2(0);
        assert!((dv - 0.1 * m2 / 1e4).abs() < 1e-12, "{dv}");
    }

    #[test]
    fn operating_points_the_camera_cannot_run_at_are_refused() {
        let op = OperatingPoint {
            exposure_s: 1.0,
            em_gain: None,
            temperature_c: None,
        };
        for (cam, op, field, says) in [
            (
                camera(false, true),
                OperatingPoint {
                    exposure_s: 0.0,
                    ..op
                },
                "exposure_s",
                "must be > 0",
            ),
            (
                camera(false, true),
                OperatingPoint {
                    exposure_s: f64::NAN,
                    ..op
                },
                "exposure_s",
                "must be > 0",
            ),
            (
                camera(false, true),
                OperatingPoint {
                    em_gain: Some(10.0),
                    ..op
                },
                "em_gain",
                "no EM register",
            ),
            (
                camera(true, false),
                OperatingPoint {
                    temperature_c: Some(0.0),
                    ..op
                },
                "temperature_c",
                "no dark current temperature law",
            ),
            (
                camera(true, false),
                OperatingPoint {
                    em_gain: Some(0.5),
                    ..op
                },
                "em_gain",
                "",
            ),
        ] {
            match cam.at(op) {
                Err(Error::Usage { field: f, message }) => {
                    assert_eq!(f, field);
                    assert!(message.contains(says), "{message}");
                }
                other => panic!("{op:?}: {other:?}"),
            }
        }
    }
}
