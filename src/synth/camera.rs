//! Dark frames of a measured camera model at an operating point, with the master dark a
//! pipeline would make of them and its standard error.

use std::path::{Path, PathBuf};

use crate::calib::Unit;
use crate::camera::{CameraAt, CameraSampler};
use crate::detector::draw_normals;
use crate::io::fits::{key, write_cube, KeyValue};
use crate::rng::{stream, SimRng};
use crate::Result;

/// Purpose of the per-frame streams of camera darks (apart from `synth`'s other streams).
const PURPOSE_CAMERA: u64 = 40;

/// Dark frames of the camera `at` an operating point, frame by frame and reproducible: frame
/// k draws from `stream(seed, k, 40)` only.
#[derive(Debug, Clone)]
pub struct CameraDarks<'a> {
    at: &'a CameraAt,
    sampler: CameraSampler,
    seed: u64,
}

impl<'a> CameraDarks<'a> {
    /// The darks of `at` with seed `seed`.
    pub fn new(at: &'a CameraAt, seed: u64) -> Result<Self> {
        let sampler = CameraSampler::new(at)?;
        Ok(CameraDarks { at, sampler, seed })
    }

    /// Frame `k` in adu, row-major, whole adu clipped to [0, saturation]: per pixel a Poisson
    /// draw of the dark charge (through the register), serial CIC, read noise (or the
    /// telegraph), and one draw per row, per column and per frame scaled by their amplitudes,
    /// converted with the pixel's gain plus its offset (see [`CameraSampler::pixel_e`] and
    /// [`CameraAt::digitise`]).
    pub fn frame(&self, k: usize) -> Vec<f64> {
        let at = self.at;
        let (rows, cols) = at.shape;
        let mut rng: SimRng = stream(self.seed, k as u64, PURPOSE_CAMERA);
        let mut common = vec![0.0; rows + cols + 1];
        draw_normals(&mut rng, &mut common);
        let (row_z, rest) = common.split_at(rows);
        let (col_z, frame_z) = rest.split_at(cols);
        let frame = at.frame_noise_e * frame_z[0];
        let mut z = vec![0.0; rows * cols];
        draw_normals(&mut rng, &mut z);
        (0..rows * cols)
            .map(|p| {
                let (i, j) = (p / cols, p % cols);
                let e = self.sampler.pixel_e(at, p, 0, z[p], &mut rng)
                    + at.row_noise_e * row_z[i]
                    + at.column_noise_e * col_z[j]
                    + frame;
                at.digitise(p, e)
            })
            .collect()
    }
}

/// The files `synth --camera` writes for stack `out`: the stack, the master dark (adu) and
/// its standard error (e-).
pub fn camera_dark_files(out: &Path) -> [PathBuf; 3] {
    let stem = super::stack_stem(out);
    let beside = |suffix: &str| {
        let mut s = stem.clone().into_os_string();
        s.push(suffix);
        PathBuf::from(s)
    };
    [
        out.to_path_buf(),
        beside(".master_dark_adu.fits"),
        beside(".master_dark_se_e.fits"),
    ]
}

/// What [`write_camera_darks`] wrote.
#[derive(Debug, Clone, PartialEq)]
pub struct CameraDarksSummary {
    /// Median over the pixels of the expected dark signal, e- per frame.
    pub dark_e_median: f64,
    /// The camera's effective read noise at the operating point (median total noise), e- rms.
    pub noise_e_median: f64,
}

/// Write `frames` dark frames of `at` (seed `seed`) as a FITS stack in `dir` under the name of
/// `out` (unsigned 16-bit integers, or 32-bit floats when `float`), with the master dark (the
/// mean of the frames as stored, adu) and its standard error (e- per pixel: the total noise at
/// the operating point over sqrt(frames)) beside it.
pub fn write_camera_darks(
    at: &CameraAt,
    frames: usize,
    seed: u64,
    float: bool,
    out: &Path,
    dir: &Path,
) -> Result<CameraDarksSummary> {
    let darks = CameraDarks::new(at, seed)?;
    let [stack, master, se] =
        camera_dark_files(out).map(|p| dir.join(p.file_name().expect("a file")));
    let npx = at.pixels();
    let mut sum = vec![0.0; npx];
    let mut k = 0;
    let mut next = || {
        let frame = darks.frame(k);
        k += 1;
        for (s, &v) in sum.iter_mut().zip(&frame) {
            *s += if float {
                f64::from(v as f32)
            } else {
                v.round().clamp(0.0, 65535.0)
            };
        }
        frame
    };
    let op = at.point;
    let keys = [
        key(
            "EXPTIME",
            KeyValue::F64(op.exposure_s),
            "exposure time of each frame, s",
        ),
        key(
            "EMGAIN",
            KeyValue::F64(at.em_gain),
            "actual mean EM gain, e-/e-",
        ),
    ];
    write_cube(&stack, at.shape, frames, !float, &mut next, &keys)?;
    let mean: Vec<f64> = sum.iter().map(|s| s / frames as f64).collect();
    at.map(mean, Unit::Adu).write_fits(&master, &keys)?;
    let n = frames as f64;
    let se_e = (0..npx)
        .map(|i| (at.total_variance_e2(i) / n).sqrt())
        .collect();
    at.map(se_e, Unit::Electrons).write_fits(&se, &keys)?;
    Ok(CameraDarksSummary {
        dark_e_median: crate::stats::median(
            &(0..npx).map(|i| at.dark_signal_e(i)).collect::<Vec<_>>(),
        ),
        noise_e_median: at.effective_read_noise_e(),
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::calib::Map;
    use crate::camera::{CameraModel, DarkCurrent, EmRegisterModel, OperatingPoint};

    /// Each pixel's mean and variance over many frames agree with the camera at the
    /// operating point (4 SE), in adu.
    fn check(cam: &CameraModel, op: OperatingPoint, n: usize) {
        let at = cam.at(op).unwrap();
        let darks = CameraDarks::new(&at, 3).unwrap();
        let frames: Vec<Vec<f64>> = (0..n).map(|k| darks.frame(k)).collect();
        for p in 0..at.pixels() {
            let xs: Vec<f64> = frames.iter().map(|f| f[p]).collect();
            let (m, v) = crate::stats::mean_var(&xs);
            let var = at.noise_adu(p).powi(2);
            assert!(
                (m - at.mean_adu(p)).abs() < 4.0 * (var / n as f64).sqrt(),
                "{p}: mean {m}"
            );
            // The variance's SE from the sample's fourth moment.
            let m4 = xs.iter().map(|x| (x - m).powi(4)).sum::<f64>() / n as f64;
            let se = ((m4 - v * v) / n as f64).sqrt();
            assert!((v - var).abs() < 4.0 * se, "{p}: var {v} vs {var}");
            assert!(xs.iter().all(|x| x.fract() == 0.0), "{p}: whole adu");
        }
    }

    fn camera() -> CameraModel {
        CameraModel::new(
            Map::new(2, 2, vec![100.0, 120.0, 90.0, 110.0], Unit::Adu),
            0.5,
            Map::new(2, 2, vec![1.0, 2.0, 1.5, 0.8], Unit::Electrons),
            16,
        )
        .unwrap()
        .with_common_noise(0.3, 0.2, 0.5)
        .unwrap()
        .with_dark_current(DarkCurrent {
            map_e_per_s: Map::new(2, 2, vec![0.5, 2.0, 0.0, 1.0], Unit::Flags),
            reference_temperature_c: None,
            doubling_temperature_c: None,
        })
        .unwrap()
        .with_cic(Map::filled(2, 2, 0.05, Unit::Electrons))
        .unwrap()
    }

    #[test]
    fn dark_frames_have_the_mean_and_noise_of_the_operating_point() {
        let op = OperatingPoint {
            exposure_s: 3.0,
            em_gain: None,
            temperature_c: None,
        };
        check(&camera(), op, 40_000);
        let reg = EmRegisterModel {
            stages: 604,
            gain_curve: vec![],
            serial_cic_e: None,
        };
        let em = camera().with_register(reg).unwrap();
        let op = OperatingPoint {
            exposure_s: 0.2,
            em_gain: Some(50.0),
            temperature_c: None,
        };
        check(&em, op, 40_000);
    }

    #[test]
    fn dark_frames_hold_the_serial_cic_and_the_telegraph_pixels() {
        // Pixel (row 1, column 0) a two-level telegraph of 30 e- steps (output-referred), and
        // 0.1 serial CIC events per pixel, at G 50: both in the frames' mean and variance.
        let rts = crate::detector::rts_table::fixture::table(&[
            crate::detector::rts_table::fixture::row(
                0,
                1,
                "ok",
                &[(-10.0, 0.5, 1.5), (20.0, 0.5, 1.5)],
                true,
            ),
        ]);
        let reg = EmRegisterModel {
            stages: 604,
            gain_curve: vec![],
            serial_cic_e: Some(0.1),
        };
        let em = camera()
            .with_register(reg)
            .unwrap()
            .with_rts_csv(rts)
            .unwrap();
        let op = OperatingPoint {
            exposure_s: 0.2,
            em_gain: Some(50.0),
            temperature_c: None,
        };
        let at = em.at(op).unwrap();
        assert!(at.serial_cic_mean_e > 0.0);
        assert!((at.read_variance_e2(2) - (225.0 + 2.25) / 2500.0).abs() < 1e-12);
        check(&em, op, 40_000);
    }
}
