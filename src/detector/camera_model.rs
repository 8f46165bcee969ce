//! `camera`: frames read through a measured camera model at an operating point.

use std::sync::Arc;

use super::readout::{draw_normals, FrameInput, Readout};
use super::register::EmRegister;
use super::spec::{ModelEntry, ModelSpec, Sensor};
use crate::camera::CameraAt;
use crate::rng::SimRng;
use crate::{Error, Result};

/// The registry entry of `camera`.
pub const ENTRY: ModelEntry = ModelEntry {
    name: "camera",
    arg: None,
    help: "the measured camera model of `camera` at the operating point (`exposure_s`, \
           `em_gain`, `temperature_c`): a random window of its maps every frame, read noise, \
           dark current and CIC with their shot noise (through the EM register when it \
           multiplies), row, column and frame-common noise; the expected dark signal taken off",
    sensor: Sensor::Scmos,
    params: &["camera"],
    parse: ModelSpec::registered,
    build: |_, p, subap_px| match &p.camera {
        Some(at) => Ok(Box::new(CameraReadout::new(at.clone(), subap_px)?)),
        None => Err(Error::invalid(
            "camera",
            "the camera model needs a camera model folder: give `camera` FILE",
        )),
    },
};

/// `camera`: each frame reads through an n x n window of the camera at a random place. Per
/// pixel: photo-electrons plus a Poisson draw of the expected dark signal (dark current x
/// exposure + CIC), through the EM register when the gain is > 1 and divided by its mean gain,
/// less the expected dark signal (a master dark taken off), plus read noise; then one normal
/// draw per row, per column and per frame scaled by their amplitudes. Output e-, input-referred.
#[derive(Debug, Clone)]
pub struct CameraReadout {
    at: Arc<CameraAt>,
    register: Option<EmRegister>,
    n: usize,
    rms_e: f64,
    median_e: f64,
}

impl CameraReadout {
    /// Windows of `n` x `n` pixels of the camera `at` an operating point; the camera must be
    /// at least that large.
    pub fn new(at: Arc<CameraAt>, n: usize) -> Result<Self> {
        let (rows, cols) = at.shape;
        if rows < n || cols < n {
            return Err(Error::invalid(
                "camera",
                format!("the camera is {rows}x{cols} px, smaller than the {n}x{n} px sub-aperture"),
            ));
        }
        let register = at
            .stages
            .map(|s| EmRegister::new(at.em_gain, s))
            .transpose()?;
        let total = at.total_noise_e();
        let rms_e = (total.iter().map(|s| s * s).sum::<f64>() / total.len() as f64).sqrt();
        let median_e = crate::stats::median(&total);
        Ok(CameraReadout {
            at,
            register,
            n,
            rms_e,
            median_e,
        })
    }

    /// Read one frame (see [`Readout::read`]); the window's top-left (row, column).
    fn read_at(&self, input: &FrameInput, aux: &mut SimRng, out: &mut [f64]) -> (usize, usize) {
        use rand::RngExt;
        let (n, at) = (self.n, &*self.at);
        let (rows, cols) = at.shape;
        let r0 = aux.random_range(0..=rows - n);
        let c0 = aux.random_range(0..=cols - n);
        for (i, ((orow, krow), zrow)) in out
            .chunks_exact_mut(n)
            .zip(input.photo_e.chunks_exact(n))
            .zip(input.normals.chunks_exact(n))
            .enumerate()
        {
            let base = (r0 + i) * cols + c0;
            for (j, ((o, &k), &z)) in orow.iter_mut().zip(krow).zip(zrow).enumerate() {
                let p = base + j;
                let dark = at.dark_e[p];
                let d = if dark > 0.0 { crate::stats::poisson(dark, aux) } else { 0 };
                let e = u64::from(k) + u64::from(d);
                let multiplied = match &self.register {
                    Some(reg) if e > 0 => reg.sample(e, aux) / at.em_gain,
                    _ => e as f64,
                };
                *o = multiplied - dark + at.read_noise_e[p] * z;
            }
        }
        // Then n row deviates, n column deviates and one frame deviate, from the same stream.
        let mut deviates = vec![0.0; 2 * n + 1];
        draw_normals(aux, &mut deviates);
        let (lines, frame) = deviates.split_at(2 * n);
        let (row_z, col_z) = lines.split_at(n);
        let frame = at.frame_noise_e * frame[0];
        for (orow, &r) in out.chunks_exact_mut(n).zip(row_z) {
            let shared = frame + at.row_noise_e * r;
            for (o, &c) in orow.iter_mut().zip(col_z) {
                *o += shared + at.column_noise_e * c;
            }
        }
        (r0, c0)
    }
}

impl Readout for CameraReadout {
    fn name(&self) -> String {
        "camera".into()
    }

    fn read(&self, input: &FrameInput, aux: &mut SimRng, out: &mut [f64]) {
        self.read_at(input, aux, out);
    }

    fn noise_scale_e(&self) -> f64 {
        self.rms_e
    }

    fn read_known(
        &self,
        input: &FrameInput,
        aux: &mut SimRng,
        out: &mut [f64],
        sigma_e: &mut [f64],
    ) {
        let (r0, c0) = self.read_at(input, aux, out);
        let (n, cols) = (self.n, self.at.shape.1);
        for (i, srow) in sigma_e.chunks_exact_mut(n).enumerate() {
            for (j, s) in srow.iter_mut().enumerate() {
                *s = self.at.total_variance_e2((r0 + i) * cols + c0 + j).sqrt();
            }
        }
    }

    fn median_sigma_e(&self) -> f64 {
        self.median_e
    }

    fn photon_variance_factor(&self) -> f64 {
        self.at.excess_noise_f2
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::calib::{Map, Unit};
    use crate::camera::{CameraModel, DarkCurrent, EmRegisterModel, OperatingPoint};
    use crate::detector::readout::sampling::dark_samples;
    use crate::stats::mean_var;

    /// A 2x2 camera with per-pixel read noise and dark current, CIC and common noise.
    fn camera(register: bool) -> CameraModel {
        let cam = CameraModel::new(
            Map::filled(2, 2, 100.0, Unit::Adu),
            1.0,
            Map::new(2, 2, vec![1.0, 2.0, 0.5, 1.5], Unit::Electrons),
            16,
        )
        .unwrap()
        .with_common_noise(0.3, 0.4, 0.6)
        .unwrap()
        .with_dark_current(DarkCurrent {
            map_e_per_s: Map::new(2, 2, vec![1.0, 0.0, 3.0, 0.5], Unit::Flags),
            reference_temperature_c: None,
            doubling_temperature_c: None,
        })
        .unwrap()
        .with_cic(Map::filled(2, 2, 0.2, Unit::Electrons))
        .unwrap();
        match register {
            true => cam
                .with_register(EmRegisterModel { stages: 604, gain_curve: vec![] })
                .unwrap(),
            false => cam,
        }
    }

    /// Each pixel's mean (0: the dark signal taken off) and variance over `n` frames agree
    /// with the camera at `op` within 4 SE; the frame term shows as the covariance of two
    /// pixels of neither the same row nor column.
    fn check_pixels(cam: &CameraModel, op: OperatingPoint, n: usize, kurtosis: f64) {
        let at = Arc::new(cam.at(op).unwrap());
        let model = CameraReadout::new(at.clone(), 2).unwrap();
        let px = dark_samples(&model, 2, n, 5);
        for (i, p) in px.iter().enumerate() {
            let (m, v) = mean_var(p);
            let var = at.total_variance_e2(i);
            assert!(m.abs() < 4.0 * (var / n as f64).sqrt(), "pixel {i}: mean {m}");
            let se = var * ((kurtosis - 1.0) / n as f64).sqrt();
            assert!((v - var).abs() < 4.0 * se, "pixel {i}: var {v} vs {var} (se {se})");
        }
        let (ma, _) = mean_var(&px[0]);
        let (mb, _) = mean_var(&px[3]);
        let cov = px[0].iter().zip(&px[3]).map(|(a, b)| (a - ma) * (b - mb)).sum::<f64>()
            / (n - 1) as f64;
        let f2 = at.frame_noise_e.powi(2);
        let se = ((at.total_variance_e2(0) * at.total_variance_e2(3) + f2 * f2) / n as f64).sqrt();
        assert!((cov - f2).abs() < 4.0 * se, "frame covariance {cov} vs {f2}");
    }

    #[test]
    fn pixel_statistics_agree_with_the_camera_at_its_operating_point() {
        let op = OperatingPoint { exposure_s: 2.0, em_gain: None, temperature_c: None };
        check_pixels(&camera(false), op, 100_000, 3.5);
    }

    #[test]
    fn behind_the_register_the_dark_shot_noise_has_its_excess_noise() {
        let op = OperatingPoint { exposure_s: 2.0, em_gain: Some(200.0), temperature_c: None };
        // A compound Poisson-exponential: heavier tails, a larger SE of the variance.
        check_pixels(&camera(true), op, 100_000, 8.0);
    }

    #[test]
    fn a_camera_smaller_than_the_sub_aperture_is_refused() {
        let op = OperatingPoint { exposure_s: 1.0, em_gain: None, temperature_c: None };
        let at = Arc::new(camera(false).at(op).unwrap());
        let e = CameraReadout::new(at, 3).unwrap_err();
        assert!(e.to_string().contains("smaller than the 3x3 px sub-aperture"), "{e}");
    }
}
