//! [`CameraSampler`]: one frame's draws of each pixel of the camera at an operating point,
//! shared by the readout model `camera` and `synth --camera` so that both simulate the same
//! camera.

use super::operating::CameraAt;
use crate::detector::register::{EmRegister, SerialCic};
use crate::rng::SimRng;
use crate::Result;

/// The samplers of a camera at an operating point: its register's exact output law and its
/// serial CIC's (tables built once).
#[derive(Debug, Clone)]
pub struct CameraSampler {
    register: Option<EmRegister>,
    serial: Option<SerialCic>,
}

impl CameraSampler {
    /// The samplers of the camera `at` an operating point (a register only when it multiplies,
    /// serial CIC only when it has a rate).
    pub fn new(at: &CameraAt) -> Result<Self> {
        let register = at
            .stages
            .map(|s| EmRegister::new(at.em_gain, s))
            .transpose()?;
        let serial = match at.stages {
            Some(s) if at.serial_cic_e > 0.0 => {
                Some(SerialCic::new(at.serial_cic_e, at.em_gain, s)?)
            }
            _ => None,
        };
        Ok(CameraSampler { register, serial })
    }

    /// Pixel `p`'s own value in one frame, e- input-referred, the expected dark signal not
    /// taken off: `photo_e` photo-electrons plus a Poisson draw of the dark charge, through the
    /// register when it multiplies (divided by its mean gain), plus the serial CIC's output,
    /// plus the read noise times the normal deviate `z` (at a telegraph pixel, its level by
    /// occupancy and that level's width times `z`, about the telegraph's mean). Draws from
    /// `rng`, in order: the dark count, the register, the serial CIC (when the camera has it),
    /// the telegraph's level (at a telegraph pixel).
    pub fn pixel_e(&self, at: &CameraAt, p: usize, photo_e: u32, z: f64, rng: &mut SimRng) -> f64 {
        use rand::RngExt;
        let dark = at.dark_e[p];
        let d = if dark > 0.0 {
            crate::stats::poisson(dark, rng)
        } else {
            0
        };
        let e = u64::from(photo_e) + u64::from(d);
        let mut x = match &self.register {
            Some(reg) if e > 0 => reg.sample(e, rng) / at.em_gain,
            _ => e as f64,
        };
        if let Some(serial) = &self.serial {
            x += serial.sample(rng) / at.em_gain;
        }
        x + match at.telegraph_at(p) {
            Some(t) => (t.value(rng.random::<f64>(), z) - t.mean_e()) / at.em_gain,
            None => at.read_noise_e[p] * z,
        }
    }
}
