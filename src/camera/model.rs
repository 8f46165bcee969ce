//! [`CameraModel`]: the measured camera as maps and amplitudes, each checked once, here,
//! whether it was built from a campaign's maps or read from a folder.

use super::range::OperatingRange;
use crate::calib::{Map, Unit};
use crate::detector::register::{MAX_EM_GAIN, MAX_STAGES};
use crate::detector::telegraph::TelegraphPixels;
use crate::detector::EmRegister;
use crate::settings::{MAX_GAIN_E_PER_ADU, MAX_NOISE_E};
use crate::{Error, Result};

/// Largest dark current of any pixel, e-/s: a pixel's full well (~1e6 e-) each second.
pub const MAX_DARK_E_PER_S: f64 = 1e6;
/// Largest clock-induced charge of any pixel, e- per frame (the bound of `synth`'s light).
pub const MAX_CIC_E: f64 = crate::synth::MAX_LIGHT_E;

/// Dark current per pixel and how it changes with temperature (EMVA 1288's doubling law:
/// D(T) = D(T_ref) 2^((T - T_ref) / T_d)).
#[derive(Debug, Clone, PartialEq)]
pub struct DarkCurrent {
    /// Dark current of each pixel at the reference temperature, e-/s (>= 0).
    pub map_e_per_s: Map,
    /// Sensor temperature the map was measured at, degrees C; None: unknown (then no other
    /// temperature can be asked for).
    pub reference_temperature_c: Option<f64>,
    /// Temperature step that doubles the dark current, degrees C (> 0); None: not measured.
    pub doubling_temperature_c: Option<f64>,
}

/// The EM register of an EMCCD: its stages and how the commanded gain maps to the actual one.
#[derive(Debug, Clone, PartialEq)]
pub struct EmRegisterModel {
    /// Multiplication stages.
    pub stages: u32,
    /// Commanded gain -> actual mean gain, (commanded, actual) pairs with the commanded gain
    /// strictly ascending, interpolated linearly; empty: the actual gain is the commanded one.
    pub gain_curve: Vec<(f64, f64)>,
    /// Serial (in-register) clock-induced charge, events per pixel over the whole register
    /// (each born at a uniformly random stage, as `emgain` fits it); None: not measured.
    pub serial_cic_e: Option<f64>,
}

/// The measured camera. Maps share one shape (rows x cols, the offset's); amplitudes of noise
/// common to a row, a column or a whole frame are output-referred e- rms (before an EM
/// register's gain is divided out), as the read noise is.
#[derive(Debug, Clone, PartialEq)]
pub struct CameraModel {
    /// Offset (bias) of each pixel, adu.
    pub offset_adu: Map,
    /// Conversion gain, e- per adu (the camera's, or the mean of `gain_map`).
    pub gain_e_per_adu: f64,
    /// Conversion gain of each pixel, e- per adu; None: `gain_e_per_adu` everywhere.
    pub gain_map: Option<Map>,
    /// Read noise of each pixel, e- rms (at the output, before any EM gain is divided out).
    pub read_noise_e: Map,
    /// Telegraph pixels, as the `rts.csv` text `darks` writes (checked by the RTS table's
    /// reader); None: none measured.
    pub rts_csv: Option<String>,
    /// Noise shared by the pixels of a row, one draw per row and frame, e- rms.
    pub row_noise_e: f64,
    /// Noise shared by the pixels of a column, one draw per column and frame, e- rms.
    pub column_noise_e: f64,
    /// Noise shared by every pixel of a frame, one draw per frame, e- rms.
    pub frame_noise_e: f64,
    /// Dark current; None: not measured (no dark signal at any exposure).
    pub dark: Option<DarkCurrent>,
    /// Clock-induced charge of each pixel, e- per frame (before the EM register); None: none.
    pub cic_e: Option<Map>,
    /// The EM register; None: a camera without one (sCMOS, CCD).
    pub register: Option<EmRegisterModel>,
    /// Largest value the camera outputs, adu.
    pub saturation_adu: f64,
    /// Bits of the converter (1 to 32); the saturation is at most 2^bits - 1.
    pub bit_depth: u32,
    /// The conditions the campaign measured the camera at; None: not recorded (a model built
    /// by hand, or written before the campaign recorded them).
    pub campaign: Option<OperatingRange>,
}

impl CameraModel {
    /// A camera of `offset_adu` (adu), conversion gain `gain_e_per_adu` (e-/adu) and read
    /// noise `read_noise_e` (e- rms), nothing else measured (no line or frame noise, dark
    /// current, CIC or register), saturating at 2^bit_depth - 1 adu; refused when the maps
    /// disagree in shape or hold values no camera has. Add the rest with the `with_` methods.
    pub fn new(
        offset_adu: Map,
        gain_e_per_adu: f64,
        read_noise_e: Map,
        bit_depth: u32,
    ) -> Result<CameraModel> {
        let saturation_adu = if (1..=32).contains(&bit_depth) {
            2f64.powi(bit_depth as i32) - 1.0
        } else {
            f64::NAN
        };
        let model = CameraModel {
            offset_adu,
            gain_e_per_adu,
            gain_map: None,
            read_noise_e,
            rts_csv: None,
            row_noise_e: 0.0,
            column_noise_e: 0.0,
            frame_noise_e: 0.0,
            dark: None,
            cic_e: None,
            register: None,
            saturation_adu,
            bit_depth,
            campaign: None,
        };
        model.check()?;
        Ok(model)
    }

    /// This camera with per-pixel conversion gains (e-/adu), checked.
    pub fn with_gain_map(self, gain_map: Map) -> Result<CameraModel> {
        CameraModel {
            gain_map: Some(gain_map),
            ..self
        }
        .checked()
    }

    /// This camera with row, column and frame-common noise (e- rms each), checked.
    pub fn with_common_noise(self, row_e: f64, column_e: f64, frame_e: f64) -> Result<Self> {
        CameraModel {
            row_noise_e: row_e,
            column_noise_e: column_e,
            frame_noise_e: frame_e,
            ..self
        }
        .checked()
    }

    /// This camera with its dark current, checked.
    pub fn with_dark_current(self, dark: DarkCurrent) -> Result<CameraModel> {
        CameraModel {
            dark: Some(dark),
            ..self
        }
        .checked()
    }

    /// This camera with its clock-induced charge map (e- per frame), checked.
    pub fn with_cic(self, cic_e: Map) -> Result<CameraModel> {
        CameraModel {
            cic_e: Some(cic_e),
            ..self
        }
        .checked()
    }

    /// This camera with an EM register, checked.
    pub fn with_register(self, register: EmRegisterModel) -> Result<CameraModel> {
        CameraModel {
            register: Some(register),
            ..self
        }
        .checked()
    }

    /// This camera saturating at `saturation_adu` (adu, at most 2^bit_depth - 1), checked.
    pub fn with_saturation(self, saturation_adu: f64) -> Result<CameraModel> {
        CameraModel {
            saturation_adu,
            ..self
        }
        .checked()
    }

    /// This camera with the telegraph pixels of an `rts.csv` (its text), checked.
    pub fn with_rts_csv(self, rts_csv: String) -> Result<CameraModel> {
        CameraModel {
            rts_csv: Some(rts_csv),
            ..self
        }
        .checked()
    }

    /// This camera with the conditions its campaign measured it at, checked.
    pub fn with_campaign(self, campaign: OperatingRange) -> Result<CameraModel> {
        CameraModel {
            campaign: Some(campaign),
            ..self
        }
        .checked()
    }

    /// Frame shape (rows, cols).
    pub fn shape(&self) -> (usize, usize) {
        self.offset_adu.shape()
    }

    fn checked(self) -> Result<CameraModel> {
        self.check()?;
        Ok(self)
    }

    /// Every check of a camera: shapes, units, ranges. The error names the map's source (its
    /// file when read) or the field, and what is wrong.
    pub fn check(&self) -> Result<()> {
        let shape = self.shape();
        if shape.0 == 0 || shape.1 == 0 {
            return Err(bad("offset_adu", "the offset map has no pixel"));
        }
        check_map(&self.offset_adu, "offset_adu", Unit::Adu, shape, None)?;
        check_scalar(
            "gain_e_per_adu",
            self.gain_e_per_adu,
            false,
            MAX_GAIN_E_PER_ADU,
            "e-/adu",
        )?;
        if let Some(g) = &self.gain_map {
            check_map(
                g,
                "gain_map",
                Unit::EPerAdu,
                shape,
                Some((false, MAX_GAIN_E_PER_ADU)),
            )?;
        }
        check_map(
            &self.read_noise_e,
            "read_noise_e",
            Unit::Electrons,
            shape,
            Some((true, MAX_NOISE_E)),
        )?;
        for (field, v) in [
            ("row_noise_e", self.row_noise_e),
            ("column_noise_e", self.column_noise_e),
            ("frame_noise_e", self.frame_noise_e),
        ] {
            check_scalar(field, v, true, MAX_NOISE_E, "e- rms")?;
        }
        if let Some(d) = &self.dark {
            check_map(
                &d.map_e_per_s,
                "dark_current_e_per_s",
                Unit::Flags,
                shape,
                Some((true, MAX_DARK_E_PER_S)),
            )?;
            if let Some(t) = d.reference_temperature_c {
                check_temperature("reference_temperature_c", t)?;
            }
            if let Some(td) = d.doubling_temperature_c {
                check_scalar("doubling_temperature_c", td, false, 100.0, "degrees C")?;
            }
        }
        if let Some(c) = &self.cic_e {
            check_map(c, "cic_e", Unit::Electrons, shape, Some((true, MAX_CIC_E)))?;
        }
        if let Some(r) = &self.register {
            check_register(r)?;
        }
        if !(1..=32).contains(&self.bit_depth) {
            return Err(bad(
                "bit_depth",
                format!("{} bits: must be 1 to 32", self.bit_depth),
            ));
        }
        let full = 2f64.powi(self.bit_depth as i32) - 1.0;
        if !(self.saturation_adu > 0.0 && self.saturation_adu <= full) {
            return Err(bad(
                "saturation_adu",
                format!(
                    "{} adu: must be > 0 and at most 2^{} - 1 = {full} adu (the converter's range)",
                    self.saturation_adu, self.bit_depth
                ),
            ));
        }
        self.telegraph()?;
        if let Some(range) = &self.campaign {
            range.check()?;
        }
        Ok(())
    }

    /// The telegraph pixels of `rts_csv` on the camera's frame (None: none), checked: the
    /// table's reader and every pixel inside the frame.
    pub(crate) fn telegraph(&self) -> Result<Option<TelegraphPixels>> {
        let Some(text) = &self.rts_csv else {
            return Ok(None);
        };
        let table = crate::detector::RtsTable::parse(text, std::path::Path::new("rts.csv"))?;
        let (rows, cols) = self.shape();
        TelegraphPixels::new(&table, rows, cols, "camera").map(Some)
    }

    /// The actual mean EM gain at the commanded gain `commanded` (e-/e-), through the gain
    /// curve; refused without a register or outside the curve.
    pub fn actual_em_gain(&self, commanded: f64) -> Result<f64> {
        let Some(reg) = &self.register else {
            return Err(bad(
                "em_gain",
                format!(
                    "{commanded}: this camera has no EM register (its model has no \
                     `em_register`): give no EM gain"
                ),
            ));
        };
        let g = match reg.gain_curve.as_slice() {
            [] => commanded,
            curve => interpolate(curve, commanded).ok_or_else(|| {
                bad(
                    "em_gain",
                    format!(
                        "{commanded}: outside the camera's measured gain curve (commanded {} to \
                         {}): the actual gain there is not known",
                        curve[0].0,
                        curve[curve.len() - 1].0
                    ),
                )
            })?,
        };
        EmRegister::check(g, reg.stages, "em_gain")?;
        Ok(g)
    }
}

/// Linear interpolation of `curve` ((x, y) pairs, x ascending) at `x`; None outside it.
fn interpolate(curve: &[(f64, f64)], x: f64) -> Option<f64> {
    if curve.len() == 1 {
        return (x == curve[0].0).then_some(curve[0].1);
    }
    curve.windows(2).find_map(|w| {
        let ((x0, y0), (x1, y1)) = (w[0], w[1]);
        (x0..=x1)
            .contains(&x)
            .then(|| y0 + (y1 - y0) * (x - x0) / (x1 - x0))
    })
}

/// A usage error about field `field` of a camera model.
fn bad(field: &str, message: impl Into<String>) -> Error {
    Error::invalid(field, message)
}

/// `v` finite, >= 0 (`zero_ok`) or > 0, and at most `max` (`unit` for the message).
fn check_scalar(field: &str, v: f64, zero_ok: bool, max: f64, unit: &str) -> Result<()> {
    let low_ok = if zero_ok { v >= 0.0 } else { v > 0.0 };
    if v.is_finite() && low_ok && v <= max {
        return Ok(());
    }
    let low = if zero_ok { ">= 0" } else { "> 0" };
    Err(bad(
        field,
        format!("{v} {unit}: must be finite, {low} and at most {max:e}"),
    ))
}

fn check_temperature(field: &str, t: f64) -> Result<()> {
    if t.is_finite() && (-273.15..=200.0).contains(&t) {
        return Ok(());
    }
    Err(bad(
        field,
        format!("{t} degrees C: must be from -273.15 to 200"),
    ))
}

/// A map of `shape` in `unit` (Flags: any) whose finite values lie in `range` ((zero allowed,
/// max); None: any finite value). Non-finite pixels mark pixels without a value. The error
/// names the map's source when it has one (its file), else `field`.
fn check_map(
    map: &Map,
    field: &str,
    unit: Unit,
    shape: (usize, usize),
    range: Option<(bool, f64)>,
) -> Result<()> {
    let fail = |what: String| {
        if map.source.is_empty() {
            bad(field, what)
        } else {
            Error::input(&map.source, format!("{field}: {what}"))
        }
    };
    if map.shape() != shape {
        return Err(fail(format!(
            "{}x{} px, where the offset map is {}x{} px: every map of a camera has its shape",
            map.rows, map.cols, shape.0, shape.1
        )));
    }
    if unit != Unit::Flags && map.unit != unit {
        return Err(fail(format!(
            "in {}, expected {}",
            map.unit.bunit(),
            unit.bunit()
        )));
    }
    if map.data.iter().all(|v| !v.is_finite()) {
        return Err(fail("no pixel has a value (all non-finite)".into()));
    }
    let Some((zero_ok, max)) = range else {
        return Ok(());
    };
    let outside = |v: f64| v.is_finite() && !(if zero_ok { v >= 0.0 } else { v > 0.0 } && v <= max);
    if let Some(i) = map.data.iter().position(|v| outside(*v)) {
        let count = map.data.iter().filter(|v| outside(**v)).count();
        let low = if zero_ok { ">= 0" } else { "> 0" };
        return Err(fail(format!(
            "{count} pixel(s) outside {low} and <= {max:e}, the first at row {}, column {} ({})",
            i / map.cols,
            i % map.cols,
            map.data[i]
        )));
    }
    Ok(())
}

fn check_register(r: &EmRegisterModel) -> Result<()> {
    if !(1..=MAX_STAGES).contains(&r.stages) {
        return Err(bad(
            "em_register.stages",
            format!("{}: must be 1 to {MAX_STAGES}", r.stages),
        ));
    }
    if let Some(c) = r.serial_cic_e {
        check_scalar(
            "em_register.serial_cic_e",
            c,
            true,
            MAX_CIC_E,
            "events per pixel",
        )?;
    }
    for (i, &(c, a)) in r.gain_curve.iter().enumerate() {
        let ok = |g: f64| g.is_finite() && (1.0..=MAX_EM_GAIN).contains(&g);
        if !ok(c) || !ok(a) {
            return Err(bad(
                "em_register.gain_curve",
                format!("point {i} ({c}, {a}): gains must be 1 to {MAX_EM_GAIN}"),
            ));
        }
        if i > 0 && c <= r.gain_curve[i - 1].0 {
            return Err(bad(
                "em_register.gain_curve",
                format!(
                    "point {i}: commanded gains must ascend strictly ({c} after {})",
                    r.gain_curve[i - 1].0
                ),
            ));
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn small() -> CameraModel {
        CameraModel::new(
            Map::filled(2, 3, 100.0, Unit::Adu),
            0.5,
            Map::filled(2, 3, 1.5, Unit::Electrons),
            16,
        )
        .unwrap()
    }

    #[test]
    fn maps_of_another_shape_or_unit_or_range_are_refused_naming_them() {
        let cam = small();
        let e = cam
            .clone()
            .with_cic(Map::filled(3, 2, 0.1, Unit::Electrons))
            .unwrap_err();
        assert!(
            e.to_string()
                .contains("`cic_e`: 3x2 px, where the offset map is 2x3"),
            "{e}"
        );
        let mut rn = Map::filled(2, 3, 1.0, Unit::Electrons).with_source("rn.fits");
        rn.data[4] = -0.5;
        let e = CameraModel::new(Map::filled(2, 3, 1.0, Unit::Adu), 1.0, rn, 16).unwrap_err();
        assert!(
            e.to_string()
                .starts_with("rn.fits: read_noise_e: 1 pixel(s) outside >= 0"),
            "{e}"
        );
        assert!(e.to_string().contains("row 1, column 1 (-0.5)"), "{e}");
        let e = cam
            .clone()
            .with_cic(Map::filled(2, 3, 0.1, Unit::Adu))
            .unwrap_err();
        assert!(e.to_string().contains("in adu, expected electron"), "{e}");
        let e = cam.clone().with_common_noise(0.1, -1.0, 0.0).unwrap_err();
        assert!(e.to_string().starts_with("invalid `column_noise_e`"), "{e}");
        let e = cam.clone().with_saturation(70000.0).unwrap_err();
        assert!(e.to_string().contains("2^16 - 1 = 65535"), "{e}");
        let reg = EmRegisterModel {
            stages: 604,
            gain_curve: vec![(10.0, 9.0), (5.0, 6.0)],
            serial_cic_e: None,
        };
        let e = cam.with_register(reg).unwrap_err();
        assert!(e.to_string().contains("ascend strictly"), "{e}");
    }

    #[test]
    fn telegraph_pixels_and_serial_cic_are_checked() {
        use crate::detector::rts_table::fixture::{row, table};
        // A telegraph pixel outside the 2x3 frame (column 3) is refused naming its line.
        let rts = table(&[row(3, 0, "ok", &[(-1.0, 0.5, 1.0), (1.0, 0.5, 1.0)], true)]);
        let e = small().with_rts_csv(rts).unwrap_err().to_string();
        assert!(
            e.contains("rts.csv: line 2: pixel (x_px 3, y_px 0) is outside the 2x3 px camera"),
            "{e}"
        );
        let reg = EmRegisterModel {
            stages: 604,
            gain_curve: vec![],
            serial_cic_e: Some(-0.1),
        };
        let e = small().with_register(reg).unwrap_err().to_string();
        assert!(e.contains("`em_register.serial_cic_e`"), "{e}");
    }

    #[test]
    fn the_gain_curve_is_interpolated_and_bounded() {
        let reg = EmRegisterModel {
            stages: 604,
            gain_curve: vec![(100.0, 80.0), (300.0, 280.0)],
            serial_cic_e: None,
        };
        let cam = small().with_register(reg).unwrap();
        assert_eq!(cam.actual_em_gain(200.0).unwrap(), 180.0);
        let e = cam.actual_em_gain(400.0).unwrap_err();
        assert!(
            e.to_string()
                .contains("outside the camera's measured gain curve"),
            "{e}"
        );
        let e = small().actual_em_gain(10.0).unwrap_err();
        assert!(e.to_string().contains("no EM register"), "{e}");
    }
}
