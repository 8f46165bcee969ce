//! What to simulate: the camera and its parameters, the frame shape and count, the light, and
//! the read-noise pdf of an sCMOS; with the limits every simulation keeps.

use serde::Serialize;

use super::defects::Defects;
use crate::calib::{Map, Unit};
use crate::error::{Error, Result};
use crate::pdf::RmsPdf;

/// Most frames a synthetic stack holds.
pub const MAX_FRAMES: u64 = 1_000_000;
/// Most pixels per frame: frames are generated 32 at a time in memory, 8 bytes a pixel.
pub const MAX_PIXELS: usize = 1 << 24;
/// Most light (and CIC) per pixel per frame, e-: above the full well of any pixel.
pub const MAX_LIGHT_E: f64 = 1e6;

/// sCMOS camera parameters.
#[derive(Clone, Debug, Serialize)]
pub struct ScmosParams {
    /// Mean offset (adu).
    pub offset_adu: f64,
    /// Pixel-to-pixel spread (standard deviation) of the offset (adu).
    pub offset_spread_adu: f64,
    /// Mean conversion gain (e per adu).
    pub gain_e_per_adu: f64,
    /// Relative pixel-to-pixel spread of the gain (standard deviation / mean).
    pub gain_spread: f64,
    /// RTS pixels, row and column noise, hot pixels (none by default; left out of the
    /// manifest when none).
    #[serde(skip_serializing_if = "Defects::is_none")]
    pub defects: Defects,
}

impl Default for ScmosParams {
    fn default() -> Self {
        ScmosParams {
            offset_adu: 100.0,
            offset_spread_adu: 2.0,
            gain_e_per_adu: 0.25,
            gain_spread: 0.02,
            defects: Defects::default(),
        }
    }
}

/// EMCCD camera parameters.
#[derive(Clone, Debug, Serialize)]
pub struct EmccdParams {
    /// Mean EM gain (output e- per input e-).
    pub em_gain: f64,
    /// Number of multiplication stages.
    pub stages: u32,
    /// Bias level (adu).
    pub bias_adu: f64,
    /// Output-amplifier read noise (e-, after the register).
    pub read_noise_e: f64,
    /// Clock-induced charge (mean input e- per pixel per frame).
    pub cic_e: f64,
    /// Conversion factor of the output amplifier (e per adu).
    pub conversion_e_per_adu: f64,
}

impl Default for EmccdParams {
    fn default() -> Self {
        EmccdParams {
            em_gain: 300.0,
            stages: 520,
            bias_adu: 500.0,
            read_noise_e: 50.0,
            cic_e: 0.005,
            conversion_e_per_adu: 10.0,
        }
    }
}

/// The camera being simulated.
#[derive(Clone, Debug, Serialize)]
#[serde(tag = "detector", rename_all = "lowercase")]
pub enum Camera {
    /// sCMOS with per-pixel offset, gain and read noise.
    Scmos(ScmosParams),
    /// EMCCD with an exact EM register.
    Emccd(EmccdParams),
}

/// What to simulate.
#[derive(Clone, Debug, Serialize)]
pub struct SynthSpec {
    /// Camera model and parameters.
    pub camera: Camera,
    /// Frame shape (rows, cols).
    pub shape: (usize, usize),
    /// Number of frames.
    pub frames: usize,
    /// Mean light per pixel per frame (photo-electrons; 0 for darks).
    pub light_e: f64,
    /// Seed of all random draws.
    pub seed: u64,
    /// Store unsigned 16-bit integers (true) or 32-bit floats.
    pub u16_samples: bool,
}

/// Parse a frame shape `ROWSxCOLS` (at most [`MAX_PIXELS`] pixels); the error says why not.
pub fn parse_shape(s: &str) -> std::result::Result<(usize, usize), String> {
    let (r, c) = s
        .split_once(['x', 'X'])
        .ok_or_else(|| format!("expected ROWSxCOLS, got {s}"))?;
    let r: usize = r
        .trim()
        .parse()
        .map_err(|_| format!("bad row count in {s}"))?;
    let c: usize = c
        .trim()
        .parse()
        .map_err(|_| format!("bad column count in {s}"))?;
    if r == 0 || c == 0 {
        return Err(format!("empty shape {s}"));
    }
    if r.checked_mul(c).is_none_or(|n| n > MAX_PIXELS) {
        return Err(format!(
            "{s} is more than {MAX_PIXELS} pixels (4096x4096): frames are generated 32 at a time in memory"
        ));
    }
    Ok((r, c))
}

/// The sCMOS read-noise pdf named by `spec`: `paper` (Basden 2015 Eq. 3 on [0, 10] e-), a
/// constant in e- (e.g. `1.5`), or a noise map file (FITS/TIFF/EXR, e-) sampled empirically.
pub fn rms_pdf(spec: &str) -> Result<Box<dyn RmsPdf>> {
    if spec == "paper" {
        return Ok(Box::new(crate::pdf::paper()));
    }
    if let Ok(v) = spec.parse::<f64>() {
        if !(v >= 0.0 && v.is_finite()) {
            return Err(Error::invalid(
                "rms_pdf",
                format!("constant read noise {v} must be finite and >= 0 e-"),
            ));
        }
        return Ok(Box::new(
            crate::pdf::EmpiricalPdf::new(&[v], &format!("constant {v} e-"))
                .ok_or_else(|| Error::invalid("rms_pdf", "bad constant"))?,
        ));
    }
    let map = Map::read_noise(spec, Unit::Electrons)?;
    let values: Vec<f64> = map.data.into_iter().filter(|v| v.is_finite()).collect();
    let pdf = crate::pdf::EmpiricalPdf::new(&values, &format!("map {spec}"))
        .ok_or_else(|| Error::input(spec, "frame 0: noise map has no finite value"))?;
    Ok(Box::new(pdf))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn shapes_parse_within_the_pixel_limit() {
        assert_eq!(parse_shape("64x48"), Ok((64, 48)));
        assert_eq!(parse_shape(" 2 X 3"), Ok((2, 3)));
        assert_eq!(parse_shape("4096x4096"), Ok((4096, 4096)));
        assert!(parse_shape("0x8").unwrap_err().contains("empty"));
        assert!(parse_shape("8").unwrap_err().contains("ROWSxCOLS"));
        assert!(parse_shape("4097x4096")
            .unwrap_err()
            .contains("16777216 pixels"));
    }

    #[test]
    fn rms_pdfs_by_name_constant_or_map() {
        assert_eq!(rms_pdf("paper").unwrap().label(), "paper [0, 10] e-");
        let c = rms_pdf("1.5").unwrap();
        assert_eq!((c.median(), c.mean()), (1.5, 1.5));
        match rms_pdf("-1") {
            Err(Error::Usage { field, .. }) => assert_eq!(field, "rms_pdf"),
            other => panic!("{other:?}"),
        }
        let d = tempfile::tempdir().unwrap();
        let p = d.path().join("rms_e.fits");
        Map::new(1, 4, vec![1.0, 2.0, f64::NAN, 3.0], Unit::Electrons)
            .write_fits(&p, &[])
            .unwrap();
        let m = rms_pdf(p.to_str().unwrap()).unwrap();
        assert_eq!(m.median(), 2.0);
        assert!(rms_pdf(d.path().join("none.fits").to_str().unwrap()).is_err());
    }
}
