//! `scmos-correlated`: the measured noise map plus row and column noise.

use std::sync::Arc;

use super::readout::{draw_normals, FrameInput, Readout};
use super::scmos_map::ScmosMap;
use super::spec::{ModelEntry, ModelSpec, Sensor};
use crate::calib::Map;
use crate::rng::SimRng;
use crate::{Error, Result};

/// The registry entry of `scmos-correlated`.
pub const ENTRY: ModelEntry = ModelEntry {
    name: "scmos-correlated",
    arg: None,
    help: "scmos-map plus row and column noise: every frame one normal draw per row and one per \
           column of the window, scaled by the measured amplitudes",
    sensor: Sensor::Scmos,
    params: &["map", "row_noise_e", "column_noise_e", "frame_noise_e"],
    parse: ModelSpec::registered,
    build: |_, p, subap_px| {
        let map = p.map.clone().ok_or_else(|| {
            Error::invalid(
                "map",
                "scmos-correlated needs a measured noise map: give `map` FILE",
            )
        })?;
        let need = |v: Option<f64>, field: &str| {
            v.ok_or_else(|| {
                Error::invalid(
                    field,
                    "scmos-correlated needs the row and the column noise amplitudes (e- rms; \
                     darks measures them: temporal_noise in its summary.json): give \
                     `row_noise_e` and `column_noise_e` (0 for none)",
                )
            })
        };
        let row = need(p.row_noise_e, "row_noise_e")?;
        let column = need(p.column_noise_e, "column_noise_e")?;
        let model = ScmosCorrelated::new(map, row, column, subap_px)?;
        Ok(Box::new(model.with_frame_noise(p.frame_noise_e.unwrap_or(0.0))?))
    },
};

/// Row and column deviates kept on the stack: two per row of a 128 px sub-aperture.
const STACK_DEVIATES: usize = 256;

/// `scmos-correlated`: each frame reads through a random window of the measured map (as
/// `scmos-map`) and adds row and column noise, as rolling readout and column-parallel ADCs
/// do: one N(0, row_noise_e^2) draw per row of the window, shared by its pixels, and one
/// N(0, column_noise_e^2) per column. Two pixels of a row thus covary by row_noise_e^2, two of
/// a column by column_noise_e^2, and a pixel's variance is sigma^2 + row^2 + column^2.
#[derive(Debug, Clone)]
pub struct ScmosCorrelated {
    map: ScmosMap,
    n: usize,
    row_noise_e: f64,
    column_noise_e: f64,
    frame_noise_e: f64,
}

impl ScmosCorrelated {
    /// Windows of `n` x `n` pixels of `map` (e-) plus row and column noise of the given rms (e-).
    pub fn new(map: Arc<Map>, row_noise_e: f64, column_noise_e: f64, n: usize) -> Result<Self> {
        for (v, field) in [(row_noise_e, "row_noise_e"), (column_noise_e, "column_noise_e")] {
            if !(v.is_finite() && v >= 0.0) {
                return Err(Error::invalid(
                    field,
                    format!("{v} e-: must be a finite number >= 0 e- rms"),
                ));
            }
        }
        Ok(ScmosCorrelated {
            map: ScmosMap::new(map, n)?,
            n,
            row_noise_e,
            column_noise_e,
            frame_noise_e: 0.0,
        })
    }

    /// The same model with noise common to the whole frame: one N(0, frame_e^2) draw per
    /// frame (e- rms), shared by every pixel, counted once (not in the row or column terms).
    pub fn with_frame_noise(self, frame_e: f64) -> Result<Self> {
        if !(frame_e.is_finite() && frame_e >= 0.0) {
            return Err(Error::invalid(
                "frame_noise_e",
                format!("{frame_e} e-: must be a finite number >= 0 e- rms"),
            ));
        }
        Ok(ScmosCorrelated {
            frame_noise_e: frame_e,
            ..self
        })
    }

    /// Variance shared with other pixels (row, column, frame), e-^2.
    fn shared_variance(&self) -> f64 {
        self.row_noise_e.powi(2) + self.column_noise_e.powi(2) + self.frame_noise_e.powi(2)
    }
}

impl Readout for ScmosCorrelated {
    fn name(&self) -> String {
        "scmos-correlated".into()
    }

    fn read(&self, input: &FrameInput, aux: &mut SimRng, out: &mut [f64]) {
        self.read_at(input, aux, out);
    }

    fn read_known(&self, input: &FrameInput, aux: &mut SimRng, out: &mut [f64], sigma_e: &mut [f64]) {
        // Each pixel's total: its own sigma with the row and column noise added in quadrature.
        let at = self.read_at(input, aux, out);
        self.map.window_sigma(at, sigma_e);
        let shared = self.shared_variance();
        sigma_e.iter_mut().for_each(|s| *s = (*s * *s + shared).sqrt());
    }

    fn median_sigma_e(&self) -> f64 {
        let m = self.map.median_sigma_e();
        (m * m + self.shared_variance()).sqrt()
    }

    fn noise_scale_e(&self) -> f64 {
        let s = self.map.noise_scale_e();
        (s * s + self.shared_variance()).sqrt()
    }
}

impl ScmosCorrelated {
    /// Read one frame (see [`Readout::read`]); the window's top-left (row, column) in the map.
    fn read_at(&self, input: &FrameInput, aux: &mut SimRng, out: &mut [f64]) -> (usize, usize) {
        let n = self.n;
        let at = self.map.read_window(input, aux, out);
        // Then n row deviates and n column deviates, in that order, from the same stream (on
        // the stack up to 128 px sub-apertures, the largest a run can have).
        let mut stack = [0.0; STACK_DEVIATES];
        let mut heap = Vec::new();
        let deviates = if 2 * n <= stack.len() {
            &mut stack[..2 * n]
        } else {
            heap.resize(2 * n, 0.0);
            &mut heap[..]
        };
        draw_normals(aux, deviates);
        let (rows, cols) = deviates.split_at(n);
        // The frame deviate after them, drawn only when there is frame noise, so that frames
        // without it read bit for bit as before it was modelled.
        let frame = if self.frame_noise_e > 0.0 {
            let mut z = [0.0];
            draw_normals(aux, &mut z);
            self.frame_noise_e * z[0]
        } else {
            0.0
        };
        for (orow, &r) in out.chunks_exact_mut(n).zip(rows) {
            let shared = frame + self.row_noise_e * r;
            for (o, &c) in orow.iter_mut().zip(cols) {
                *o += shared + self.column_noise_e * c;
            }
        }
        at
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::calib::Unit;
    use crate::detector::readout::sampling::{dark_samples, frames_own_streams};
    use crate::stats::mean_var;

    /// Sample covariance of two equally long series.
    fn covariance(a: &[f64], b: &[f64]) -> f64 {
        let (ma, _) = mean_var(a);
        let (mb, _) = mean_var(b);
        let s: f64 = a.iter().zip(b).map(|(x, y)| (x - ma) * (y - mb)).sum();
        s / (a.len() - 1) as f64
    }

    #[test]
    fn rows_and_columns_covary_by_their_amplitudes() {
        // A uniform 3x3 map of sigma 1 e- read whole (one window): a pixel's variance is
        // 1 + row^2 + col^2; two pixels of a row covary by row^2, of a column by col^2, others 0.
        // SE of a sample covariance of normals: sqrt((var_a var_b + cov^2) / N).
        let (row, col) = (0.8, 0.5);
        let map = Map::new(3, 3, vec![1.0; 9], Unit::Electrons).with_source("t");
        let m = ScmosCorrelated::new(Arc::new(map), row, col, 3).unwrap();
        let n = 100_000;
        let px = dark_samples(&m, 3, n, 17);
        let var = 1.0 + row * row + col * col;
        assert_eq!(m.noise_scale_e(), var.sqrt());
        let se = |cov: f64| ((var * var + cov * cov) / n as f64).sqrt();
        for (a, b, truth) in [
            (0, 2, row * row), // same row
            (4, 5, row * row),
            (1, 7, col * col), // same column
            (3, 6, col * col),
            (0, 4, 0.0), // neither
            (2, 6, 0.0),
        ] {
            let cov = covariance(&px[a], &px[b]);
            assert!((cov - truth).abs() < 4.0 * se(truth), "{a},{b}: {cov} vs {truth}");
        }
        for p in &px {
            let (mean, v) = mean_var(p);
            assert!(mean.abs() < 4.0 * (var / n as f64).sqrt(), "mean {mean}");
            assert!((v - var).abs() < 4.0 * var * (2.0 / n as f64).sqrt(), "var {v}");
        }
    }

    #[test]
    fn frame_noise_is_shared_by_every_pixel_once() {
        // Frame noise 0.7 e- on a 3x3 window without row or column noise: every pair of pixels
        // covaries by 0.49, each pixel's variance is 1 + 0.49.
        let frame = 0.7;
        let map = Map::new(3, 3, vec![1.0; 9], Unit::Electrons).with_source("t");
        let m = ScmosCorrelated::new(Arc::new(map), 0.0, 0.0, 3)
            .unwrap()
            .with_frame_noise(frame)
            .unwrap();
        let n = 100_000;
        let px = dark_samples(&m, 3, n, 23);
        let var = 1.0 + frame * frame;
        assert!((m.noise_scale_e() - var.sqrt()).abs() < 1e-12);
        let f2 = frame * frame;
        let se = ((var * var + f2 * f2) / n as f64).sqrt();
        for (a, b) in [(0, 8), (2, 6), (1, 5)] {
            let cov = covariance(&px[a], &px[b]);
            assert!((cov - f2).abs() < 4.0 * se, "{a},{b}: {cov} vs {f2}");
        }
        let (_, v) = mean_var(&px[4]);
        assert!((v - var).abs() < 4.0 * var * (2.0 / n as f64).sqrt(), "var {v}");
        assert!(ScmosCorrelated::new(Arc::new(Map::filled(2, 2, 1.0, Unit::Electrons)), 0.0, 0.0, 2)
            .unwrap()
            .with_frame_noise(-1.0)
            .is_err());
    }

    #[test]
    fn without_row_and_column_noise_it_reads_as_the_map() {
        // Zero amplitudes: the same window draws and normals as scmos-map, bit for bit.
        let data: Vec<f64> = (0..20).map(|i| 0.5 + 0.1 * i as f64).collect();
        let map = Arc::new(Map::new(4, 5, data, Unit::Electrons).with_source("t"));
        let plain = ScmosMap::new(map.clone(), 3).unwrap();
        let none = ScmosCorrelated::new(map, 0.0, 0.0, 3).unwrap();
        let (a, b) = (frames_own_streams(&none, 3, 500, 4), frames_own_streams(&plain, 3, 500, 4));
    assert!(a == b, "differs from scmos-map");
    }

    #[test]
    fn missing_or_bad_amplitudes_name_their_field() {
        let map = Arc::new(Map::new(2, 2, vec![1.0; 4], Unit::Electrons).with_source("t"));
        let spec = ModelSpec::parse("scmos-correlated").unwrap();
        let params = super::super::ModelParams {
            map: Some(map.clone()),
            row_noise_e: Some(0.3),
            ..Default::default()
        };
        let Err(e) = spec.build(&params, 2) else {
            panic!("built without column_noise_e")
        };
        let msg = e.to_string();
        assert!(msg.starts_with("invalid `column_noise_e`: "), "{msg}");
        assert!(msg.contains("`row_noise_e`") && msg.contains("summary.json"), "{msg}");
        let no_map = super::super::ModelParams {
            map: None,
            ..params.clone()
        };
        let Err(e) = spec.build(&no_map, 2) else {
            panic!("built without a map")
        };
        assert!(e.to_string().starts_with("invalid `map`: "), "{e}");
        for bad in [-0.1, f64::NAN] {
            let e = ScmosCorrelated::new(map.clone(), 0.2, bad, 2).unwrap_err();
            assert!(e.to_string().starts_with("invalid `column_noise_e`: "), "{e}");
        }
        let both = super::super::ModelParams {
            column_noise_e: Some(0.0),
            ..params
        };
        assert_eq!(spec.build(&both, 2).unwrap().name(), "scmos-correlated");
    }
}
