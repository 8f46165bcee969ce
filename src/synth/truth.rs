//! The per-pixel truth of a synthetic camera and its frames, each drawn from its own random
//! stream so that results do not depend on the thread count.

use rand_distr::{Distribution, StandardNormal};

use super::defects::{add_defects, DefectTruth};
use super::spec::{Camera, SynthSpec};
use crate::calib::{Map, Unit};
use crate::detector::register::EmRegister;
use crate::pdf::RmsPdf;
use crate::rng::{stream, SimRng};
use crate::stats::poisson;

const PURPOSE_PIXELS: u64 = 0x5059_5845_4c53; // "PIXELS"
const PURPOSE_FRAMES: u64 = 0x4652_414d_4553; // "FRAMES"

/// Per-pixel truth of a synthetic camera.
#[derive(Clone, Debug)]
pub struct Truth {
    /// Offset (adu).
    pub offset_adu: Map,
    /// Read noise (e-).
    pub rms_e: Map,
    /// Conversion gain (e per adu).
    pub gain_e_per_adu: Map,
    /// RTS and hot pixels (sCMOS with defects; empty otherwise).
    pub defects: DefectTruth,
}

impl Truth {
    /// Read noise in adu (rms_e / gain).
    pub fn rms_adu(&self) -> Map {
        let d = self
            .rms_e
            .data
            .iter()
            .zip(&self.gain_e_per_adu.data)
            .map(|(r, g)| r / g)
            .collect();
        Map::new(self.rms_e.rows, self.rms_e.cols, d, Unit::Adu)
    }
}

fn normal(rng: &mut SimRng) -> f64 {
    StandardNormal.sample(rng)
}

/// Draw the per-pixel truth. sCMOS read noise comes from `pdf`; EMCCD pixels share one
/// read noise, bias and conversion factor. Defects must have been checked
/// ([`Defects::check`](super::Defects::check)); unchecked ones are left out.
pub fn draw_truth(spec: &SynthSpec, pdf: &dyn RmsPdf) -> Truth {
    let (rows, cols) = spec.shape;
    let n = rows * cols;
    let mut offset = vec![0.0; n];
    let mut rms = vec![0.0; n];
    let mut gain = vec![0.0; n];
    for i in 0..n {
        let mut rng = stream(spec.seed, i as u64, PURPOSE_PIXELS);
        match &spec.camera {
            Camera::Scmos(p) => {
                offset[i] = p.offset_adu + p.offset_spread_adu * normal(&mut rng);
                gain[i] = p.gain_e_per_adu * (1.0 + p.gain_spread * normal(&mut rng)).max(0.1);
                rms[i] = pdf.sample(&mut rng);
            }
            Camera::Emccd(p) => {
                offset[i] = p.bias_adu;
                gain[i] = p.conversion_e_per_adu;
                rms[i] = p.read_noise_e;
            }
        }
    }
    let defects = match &spec.camera {
        Camera::Scmos(p) if !p.defects.is_none() => {
            let chain = p.defects.check().ok().flatten();
            DefectTruth::draw(&p.defects, chain, n, spec.seed)
        }
        _ => DefectTruth::default(),
    };
    Truth {
        offset_adu: Map::new(rows, cols, offset, Unit::Adu),
        rms_e: Map::new(rows, cols, rms, Unit::Electrons),
        gain_e_per_adu: Map::new(rows, cols, gain, Unit::EPerAdu),
        defects,
    }
}

/// Frame `k` of the stack in adu (before rounding to the stored type). With RTS pixels their
/// chains are replayed from frame 0 (writers step them with [`frame_with`] instead).
pub fn frame(spec: &SynthSpec, truth: &Truth, register: Option<&EmRegister>, k: usize) -> Vec<f64> {
    let levels = if truth.defects.rts.is_empty() {
        Vec::new()
    } else {
        truth.defects.levels_at(spec.seed, k)
    };
    frame_with(spec, truth, register, k, &levels)
}

/// Frame `k` of the stack in adu with the RTS pixels in `levels` (one per RTS pixel).
pub fn frame_with(
    spec: &SynthSpec,
    truth: &Truth,
    register: Option<&EmRegister>,
    k: usize,
    levels: &[u8],
) -> Vec<f64> {
    let purpose = PURPOSE_FRAMES ^ spec.light_e.to_bits().rotate_left(17);
    let mut rng = stream(spec.seed, k as u64, purpose);
    let n = spec.shape.0 * spec.shape.1;
    let mut out = vec![0.0; n];
    for (i, o) in out.iter_mut().enumerate() {
        *o = match &spec.camera {
            Camera::Scmos(_) => {
                poisson(spec.light_e, &mut rng) as f64 + truth.rms_e.data[i] * normal(&mut rng)
            }
            Camera::Emccd(p) => {
                let k_in = poisson(spec.light_e + p.cic_e, &mut rng) as u64;
                let reg = register.expect("EMCCD needs a register");
                reg.sample(k_in, &mut rng) + p.read_noise_e * normal(&mut rng)
            }
        };
    }
    if let Camera::Scmos(p) = &spec.camera {
        if !p.defects.is_none() {
            let id = (spec.seed, k, purpose);
            add_defects(&p.defects, &truth.defects, levels, spec.shape, id, &mut out);
        }
    }
    for (i, o) in out.iter_mut().enumerate() {
        *o = truth.offset_adu.data[i] + *o / truth.gain_e_per_adu.data[i];
    }
    out
}
