//! `camera`: frames read through a measured camera model at an operating point.

use std::sync::Arc;

use super::readout::{draw_normals, FrameInput, Readout};
use super::spec::{ModelEntry, ModelSpec, Sensor};
use crate::camera::{CameraAt, CameraSampler};
use crate::rng::SimRng;
use crate::{Error, Result};

/// The registry entry of `camera`.
///
/// Its `sensor` tag is `Scmos` even for a camera with an EM register, and that is harmless:
/// the tag belongs to the model's name, known before the camera folder is read, and the
/// simulation never consults it (the register, its excess noise in
/// [`Readout::photon_variance_factor`], the noise scales all come from the camera at its
/// operating point). The tag drives only (a) `effective --simple-qe`, which solves the QE
/// factor of `emccd-simple` built from the run's own `em_gain` and `emccd_read_noise_e`, not
/// from a camera model, so refusing `camera` there is right, and (b) Python's
/// `Readout.sensor` string, which for a camera should come from [`CameraAt::sensor`].
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
    sampler: CameraSampler,
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
        let sampler = CameraSampler::new(&at)?;
        let total = at.total_noise_e();
        let rms_e = (total.iter().map(|s| s * s).sum::<f64>() / total.len() as f64).sqrt();
        let median_e = crate::stats::median(&total);
        Ok(CameraReadout {
            at,
            sampler,
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
                *o = self.sampler.pixel_e(at, p, k, z, aux) - at.dark_signal_e(p);
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
        // The camera's converter: every pixel to whole adu within its range, and back.
        for (i, orow) in out.chunks_exact_mut(n).enumerate() {
            let base = (r0 + i) * cols + c0;
            for (j, o) in orow.iter_mut().enumerate() {
                *o = at.quantised_e(base + j, *o);
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
    use crate::detector::rts_table::fixture::{row, table};
    use crate::stats::mean_var;

    /// A 2x2 camera with per-pixel read noise and dark current, CIC and common noise, behind a
    /// 604-stage register of serial CIC `serial` (events per pixel) when `register`.
    fn camera_with(register: bool, serial: Option<f64>) -> CameraModel {
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
                .with_register(EmRegisterModel { stages: 604, gain_curve: vec![], serial_cic_e: serial })
                .unwrap(),
            false => cam,
        }
    }

    fn camera(register: bool) -> CameraModel {
        camera_with(register, None)
    }

    /// Pixel (row 0, column 1) a two-level telegraph: -2 e- 40 % and +4 e- 60 % of the frames
    /// (mean 1.6 e-, variance 0.4 x 0.6 x 6^2 = 8.64 e-^2), each level 2 e- wide (the pixel's
    /// read noise in the map).
    fn with_telegraph(cam: CameraModel) -> CameraModel {
        let rts = table(&[row(1, 0, "ok", &[(-2.0, 0.4, 2.0), (4.0, 0.6, 2.0)], true)]);
        cam.with_rts_csv(rts).unwrap()
    }

    /// Each pixel's mean (0: the dark signal taken off) and variance over `n` frames agree
    /// with the camera at `op` within 4 SE (the variance's SE from the sample's fourth moment);
    /// the frame term shows as the covariance of two pixels of neither the same row nor column.
    fn check_pixels(cam: &CameraModel, op: OperatingPoint, n: usize) -> Arc<CameraAt> {
        let at = Arc::new(cam.at(op).unwrap());
        let model = CameraReadout::new(at.clone(), 2).unwrap();
        let px = dark_samples(&model, 2, n, 5);
        for (i, p) in px.iter().enumerate() {
            let (m, v) = mean_var(p);
            let var = at.total_variance_e2(i);
            assert!(m.abs() < 4.0 * (var / n as f64).sqrt(), "pixel {i}: mean {m}");
            let m4 = p.iter().map(|x| (x - m).powi(4)).sum::<f64>() / n as f64;
            let se = ((m4 - v * v) / n as f64).sqrt();
            assert!((v - var).abs() < 4.0 * se, "pixel {i}: var {v} vs {var} (se {se})");
        }
        let (ma, _) = mean_var(&px[0]);
        let (mb, _) = mean_var(&px[3]);
        let cov = px[0].iter().zip(&px[3]).map(|(a, b)| (a - ma) * (b - mb)).sum::<f64>()
            / (n - 1) as f64;
        let f2 = at.frame_noise_e.powi(2);
        let se = ((at.total_variance_e2(0) * at.total_variance_e2(3) + f2 * f2) / n as f64).sqrt();
        assert!((cov - f2).abs() < 4.0 * se, "frame covariance {cov} vs {f2}");
        at
    }

    #[test]
    fn pixel_statistics_agree_with_the_camera_at_its_operating_point() {
        let op = OperatingPoint { exposure_s: 2.0, em_gain: None, temperature_c: None };
        check_pixels(&camera(false), op, 100_000);
    }

    #[test]
    fn behind_the_register_the_dark_shot_noise_has_its_excess_noise() {
        let op = OperatingPoint { exposure_s: 2.0, em_gain: Some(200.0), temperature_c: None };
        check_pixels(&camera(true), op, 100_000);
    }

    #[test]
    fn a_telegraph_pixel_adds_its_levels_variance_to_the_read_noise() {
        // Before issue 31 the model's rts.csv was not simulated: the pixel read 2 e- rms.
        let op = OperatingPoint { exposure_s: 2.0, em_gain: None, temperature_c: None };
        let at = check_pixels(&with_telegraph(camera(false)), op, 100_000);
        // Widths equal to the map's read noise: read^2 + the two-level variance.
        assert!((at.read_variance_e2(1) - (4.0 + 8.64)).abs() < 1e-12, "{}", at.read_variance_e2(1));
        assert_eq!(at.read_variance_e2(0), 1.0);
        // Known-noise centroiders see it: read_known's sigma is the total noise.
        let model = CameraReadout::new(at.clone(), 2).unwrap();
        let (zeros, z) = (vec![0u32; 4], vec![0.0; 4]);
        let input = FrameInput { subap_px: 2, expected_e: &z, mean_e: &z, photo_e: &zeros, normals: &z };
        let (mut out, mut sigma) = (vec![0.0; 4], vec![0.0; 4]);
        model.read_known(&input, &mut crate::rng::stream(1, 0, 1), &mut out, &mut sigma);
        let total = 4.0 + 8.64 + 0.0 + 0.2 + 1.0 / 12.0 + at.common_variance_e2();
        assert!((sigma[1] - total.sqrt()).abs() < 1e-12, "{} vs {}", sigma[1], total.sqrt());
        // Behind a register the telegraph is output-referred, as the read noise.
        let op = OperatingPoint { exposure_s: 2.0, em_gain: Some(50.0), temperature_c: None };
        let at = with_telegraph(camera(true)).at(op).unwrap();
        assert!((at.read_variance_e2(1) - 12.64 / 2500.0).abs() < 1e-15);
    }

    #[test]
    fn serial_cic_adds_its_mean_and_variance() {
        // 0.2 events per pixel at G 200, 604 stages: per event mean (G-1)/(N p) and second
        // moment averaged over the stages left, divided by G (input-referred).
        let op = OperatingPoint { exposure_s: 2.0, em_gain: Some(200.0), temperature_c: None };
        let at = check_pixels(&camera_with(true, Some(0.2)), op, 200_000);
        let p = crate::detector::register::stage_probability(200.0, 604);
        let mean = 0.2 * 199.0 / (604.0 * p) / 200.0;
        assert!((at.serial_cic_mean_e - mean).abs() < 1e-9, "{}", at.serial_cic_mean_e);
        assert!((at.dark_signal_e(0) - (2.0 + 0.2 + mean)).abs() < 1e-12);
        // Its variance rate m2 / G^2: about rate / (N p), events of second moment
        // 2 (1+p)^(2j) averaged over the stages left (a little less: F^2 < 2 in short runs).
        let (_, m2) = crate::detector::register::serial_cic_moments(200.0, 604);
        assert!((at.serial_cic_variance_e2 - 0.2 * m2 / 4e4).abs() < 1e-12);
        let ratio = at.serial_cic_variance_e2 / (0.2 / (604.0 * p));
        assert!((0.9..1.0).contains(&ratio), "{ratio}");
        // Without multiplication there is no serial CIC.
        let op = OperatingPoint { em_gain: None, ..op };
        assert_eq!(camera_with(true, Some(0.2)).at(op).unwrap().serial_cic_mean_e, 0.0);
    }

    /// One pixel of offset `offset` adu, gain `gain` e-/adu and read noise `read` e-,
    /// saturating at `saturation` adu, read `n` times.
    fn one_pixel(offset: f64, gain: f64, read: f64, saturation: f64, n: usize) -> Vec<f64> {
        let cam = CameraModel::new(
            Map::filled(1, 1, offset, Unit::Adu),
            gain,
            Map::filled(1, 1, read, Unit::Electrons),
            16,
        )
        .unwrap()
        .with_saturation(saturation)
        .unwrap();
        let op = OperatingPoint { exposure_s: 1.0, em_gain: None, temperature_c: None };
        let model = CameraReadout::new(Arc::new(cam.at(op).unwrap()), 1).unwrap();
        dark_samples(&model, 1, n, 9).remove(0)
    }

    #[test]
    fn quantisation_adds_a_twelfth_of_an_adu_squared() {
        // 4 e-/adu, 6 e- (1.5 adu) read noise, offset 100.3 adu: whole adu out, variance
        // 36 + 16/12 e-^2 (1.33 e-^2 is 11 SE here).
        let n = 200_000;
        let xs = one_pixel(100.3, 4.0, 6.0, 65535.0, n);
        assert!(xs.iter().all(|x| ((x / 4.0 + 100.3) - (x / 4.0 + 100.3).round()).abs() < 1e-9));
        let (m, v) = mean_var(&xs);
        let var = 36.0 + 16.0 / 12.0;
        assert!(m.abs() < 4.0 * (var / n as f64).sqrt(), "mean {m}");
        let se = var * (2.0 / n as f64).sqrt();
        assert!((v - var).abs() < 4.0 * se, "variance {v} vs {var} (se {se})");
    }

    #[test]
    fn values_above_saturation_are_clipped_as_the_gaussian_tail_says() {
        // Offset 100 adu, 1 e-/adu, 10 e- rms, saturation 110 adu: a read is 110 adu (10 e-)
        // whenever the value before rounding is >= 109.5, P = 1 - Phi(0.95) = 0.171.
        let n = 100_000;
        let xs = one_pixel(100.0, 1.0, 10.0, 110.0, n);
        assert!(xs.iter().all(|&x| x <= 10.0));
        let at_max = xs.iter().filter(|&&x| x == 10.0).count() as f64 / n as f64;
        let p = 1.0 - crate::special::norm_cdf(0.95);
        let se = (p * (1.0 - p) / n as f64).sqrt();
        assert!((at_max - p).abs() < 4.0 * se, "clipped {at_max} vs {p} (se {se})");
    }

    #[test]
    fn a_camera_smaller_than_the_sub_aperture_is_refused() {
        let op = OperatingPoint { exposure_s: 1.0, em_gain: None, temperature_c: None };
        let at = Arc::new(camera(false).at(op).unwrap());
        let e = CameraReadout::new(at, 3).unwrap_err();
        assert!(e.to_string().contains("smaller than the 3x3 px sub-aperture"), "{e}");
    }
}
