//! `detnoise.Readout`: any readout model of the registry as a noise generator that an AO
//! simulation calls every frame, on a full frame (n, n) or a stack of sub-apertures (k, n, n).
//!
//! Each sub-aperture of a call is one work item with its own seeded streams (shot noise,
//! read-noise deviates, the model's own draws: the roles of the Monte-Carlo engine), read in
//! parallel without the GIL: the result does not depend on the thread count. Sub-aperture `i`
//! of the camera's frame `f` uses item `f * 2^32 + i` of the camera's seed; an explicit
//! `seed=s` reads as frame 0 of a camera of seed `s` and leaves the frame counter alone.

use crate::convert::{checked_array, float_array, to_f64};
use crate::errors::{invalid, IntoPy};
use crate::params::read_params;
use detnoise::detector::{draw_normals, FrameInput, ModelSpec, Readout, Sensor};
use detnoise::rng::stream;
use detnoise::stats::poisson;
use numpy::{PyArrayDyn, PyArrayMethods, PyUntypedArrayMethods};
use pyo3::prelude::*;
use pyo3::types::PyDict;
use rayon::prelude::*;
use std::sync::atomic::{AtomicU64, Ordering::Relaxed};
use std::sync::{Arc, Mutex};

/// Stream roles of one sub-aperture, as in the Monte-Carlo engine.
const PHOTONS: u64 = 1;
const NOISE: u64 = 2;
const AUX: u64 = 3;

/// Largest expected photo-electrons per pixel with `photon_noise` (the engine's bound per
/// sub-aperture: counts are 32-bit).
const MAX_EXPECTED_E: f64 = 1e9;

/// A readout model, built for each sub-aperture size it is asked to read.
#[pyclass(module = "detnoise._detnoise", name = "Readout", frozen)]
pub struct PyReadout {
    text: String,
    spec: ModelSpec,
    params: detnoise::detector::ModelParams,
    gain_e_per_adu: Option<f64>,
    seed: u64,
    frame: AtomicU64,
    built: Mutex<Vec<(usize, Arc<dyn Readout>)>>,
}

impl PyReadout {
    /// The model for `n` x `n` images (built on first use, then kept).
    fn model(&self, n: usize) -> PyResult<Arc<dyn Readout>> {
        let mut built = self.built.lock().expect("model cache lock");
        if let Some((_, m)) = built.iter().find(|(size, _)| *size == n) {
            return Ok(m.clone());
        }
        let m: Arc<dyn Readout> = self.spec.build(&self.params, n).py()?.into();
        built.push((n, m.clone()));
        Ok(m)
    }
}

/// What one call reads: the input's meaning and the output's unit.
struct Job<'a> {
    model: &'a dyn Readout,
    n: usize,
    seed: u64,
    first_item: u64,
    photon_noise: bool,
    /// Per-sub-aperture mean image (n x n, or the whole input's size), if given.
    mean_e: Option<&'a [f64]>,
    /// Output scale (1, or 1 / gain for adu) and offset (adu).
    scale: f64,
    offset: f64,
}

impl Job<'_> {
    /// Read sub-aperture `i` of `input` into `out`; Err names the first bad pixel value.
    fn read(
        &self,
        i: usize,
        input: &[f64],
        out: &mut [f64],
        scratch: &mut (Vec<u32>, Vec<f64>),
    ) -> Result<(), (usize, f64)> {
        let (photo_e, normals) = scratch;
        let item = self.first_item + i as u64;
        if self.photon_noise {
            let mut rng = stream(self.seed, item, PHOTONS);
            for (p, (k, &lambda)) in photo_e.iter_mut().zip(input).enumerate() {
                if !(0.0..=MAX_EXPECTED_E).contains(&lambda) {
                    return Err((p, lambda));
                }
                *k = poisson(lambda, &mut rng);
            }
        } else {
            for (p, (k, &count)) in photo_e.iter_mut().zip(input).enumerate() {
                if !(count >= 0.0 && count <= u32::MAX as f64 && count.fract() == 0.0) {
                    return Err((p, count));
                }
                *k = count as u32;
            }
        }
        draw_normals(&mut stream(self.seed, item, NOISE), normals);
        let npix = self.n * self.n;
        let mean_e = match self.mean_e {
            Some(m) if m.len() == npix => m,
            Some(m) => &m[i * npix..(i + 1) * npix],
            None => input,
        };
        let frame = FrameInput {
            subap_px: self.n,
            expected_e: input,
            mean_e,
            photo_e,
            normals,
        };
        self.model
            .read(&frame, &mut stream(self.seed, item, AUX), out);
        if self.scale != 1.0 || self.offset != 0.0 {
            out.iter_mut()
                .for_each(|v| *v = *v * self.scale + self.offset);
        }
        Ok(())
    }
}

#[pymethods]
impl PyReadout {
    /// A readout model of the registry (`detnoise.MODELS`), e.g. `Readout("scmos-map",
    /// map_e=rms_e)` or `Readout("emccd-stochastic", em_gain=1000)`; `seed` seeds the frames
    /// read without an explicit seed; `**params` are the model's parameters (see `ModelParams`).
    #[new]
    #[pyo3(signature = (model, *, seed = 0, **params))]
    fn new(
        py: Python<'_>,
        model: &str,
        seed: u64,
        params: Option<&Bound<'_, PyDict>>,
    ) -> PyResult<Self> {
        let spec = ModelSpec::parse(model).py()?;
        let p = read_params(py, params)?;
        let this = PyReadout {
            text: model.to_string(),
            spec,
            params: p.model,
            gain_e_per_adu: p.gain_e_per_adu,
            seed,
            frame: AtomicU64::new(0),
            built: Mutex::new(Vec::new()),
        };
        // A missing or unfit parameter is an error now, not at the first frame.
        this.model(detnoise::montecarlo::SimConfig::MIN_SUBAP_PX)?;
        Ok(this)
    }

    /// The `camera` readout of the camera model folder `path` (docs/camera.md) at an
    /// operating point: `exposure_s` (s; None: the campaign's shortest dark exposure, which
    /// camera.json records), `em_gain` (commanded, e-/e-; None: no multiplication),
    /// `temperature_c` (degrees C; None: the dark current's reference).
    #[staticmethod]
    #[pyo3(signature = (path, *, exposure_s = None, em_gain = None, temperature_c = None, seed = 0))]
    fn from_camera(
        py: Python<'_>,
        path: std::path::PathBuf,
        exposure_s: Option<f64>,
        em_gain: Option<f64>,
        temperature_c: Option<f64>,
        seed: u64,
    ) -> PyResult<Self> {
        let params = PyDict::new(py);
        params.set_item("camera", path)?;
        if let Some(t) = exposure_s {
            params.set_item("exposure_s", t)?;
        }
        if let Some(g) = em_gain {
            params.set_item("em_gain", g)?;
        }
        if let Some(t) = temperature_c {
            params.set_item("temperature_c", t)?;
        }
        Self::new(py, "camera", seed, Some(&params))
    }

    /// Read `image_e` through the camera: a frame (n, n) or a stack of sub-apertures
    /// (k, n, n). With `photon_noise` the values are expected photo-electrons per pixel and
    /// shot noise is drawn; without, they are photo-electron counts (whole numbers >= 0).
    /// Returns a new float64 array of the same shape: e- referred to the input (an EMCCD's
    /// output divided by its mean gain), or with `unit="adu"` value / `gain_e_per_adu` +
    /// `offset_adu` (not quantised). `mean_e` is the controller's mean image per pixel (e-, the
    /// centred spot) for models with a per-pixel prior: (n, n) or the input's shape; default
    /// the input.
    #[pyo3(signature = (image_e, *, seed = None, photon_noise = true, unit = "e", offset_adu = None, mean_e = None))]
    #[allow(clippy::too_many_arguments)]
    fn read<'py>(
        &self,
        py: Python<'py>,
        image_e: &Bound<'py, PyAny>,
        seed: Option<u64>,
        photon_noise: bool,
        unit: &str,
        offset_adu: Option<&Bound<'py, PyAny>>,
        mean_e: Option<&Bound<'py, PyAny>>,
    ) -> PyResult<Bound<'py, PyArrayDyn<f64>>> {
        // Shapes are checked before anything of their size is allocated.
        let input = checked_array(image_e, "image_e")?;
        let shape = input.shape().to_vec();
        let (k, n) = match shape[..] {
            [r, c] if r == c => (1, r),
            [k, r, c] if r == c => (k, r),
            _ => {
                return Err(invalid(
                    "image_e",
                    format!(
                        "shape {shape:?}: a square frame (n, n) or a stack of square \
                         sub-apertures (k, n, n)"
                    ),
                ))
            }
        };
        if n == 0 || k as u64 > u32::MAX as u64 {
            return Err(invalid(
                "image_e",
                format!("shape {shape:?}: nothing to read"),
            ));
        }
        let (scale, offset_scalar, offset_array) = self.output_unit(unit, offset_adu)?;
        let mean = mean_e.map(|m| checked_array(m, "mean_e")).transpose()?;
        if let Some(m) = &mean {
            let ok = m.shape() == [n, n] || m.shape() == shape.as_slice();
            if !ok {
                return Err(invalid(
                    "mean_e",
                    format!("shape {:?}: must be ({n}, {n}) or {shape:?}", m.shape()),
                ));
            }
        }
        let input = to_f64(&input)?;
        let mean = mean.as_ref().map(to_f64).transpose()?;
        let model = self.model(n)?;
        let (seed, first_item) = match seed {
            Some(s) => (s, 0),
            None => (self.seed, self.frame.fetch_add(1, Relaxed) << 32),
        };
        let out = PyArrayDyn::<f64>::zeros(py, shape.clone(), false);
        {
            let input_ro = input.readonly();
            let mean_ro = mean.as_ref().map(|m| m.readonly());
            let mut out_rw = out.readwrite();
            let job = Job {
                model: model.as_ref(),
                n,
                seed,
                first_item,
                photon_noise,
                mean_e: mean_ro.as_ref().map(|m| m.as_slice()).transpose()?,
                scale,
                offset: offset_scalar,
            };
            let src = input_ro.as_slice()?;
            let dst = out_rw.as_slice_mut()?;
            let npix = n * n;
            let result = py.detach(|| {
                dst.par_chunks_mut(npix)
                    .zip(src.par_chunks(npix))
                    .enumerate()
                    .try_for_each_init(
                        || (vec![0u32; npix], vec![0.0; npix]),
                        |scratch, (i, (o, x))| {
                            job.read(i, x, o, scratch)
                                .map_err(|(p, v)| (i * npix + p, v))
                        },
                    )
            });
            if let Err((at, v)) = result {
                let what = if photon_noise {
                    format!("expected photo-electrons must be finite, 0 to {MAX_EXPECTED_E:e}")
                } else {
                    "photo-electron counts (photon_noise=False) must be whole numbers >= 0"
                        .to_string()
                };
                let index: Vec<usize> = unravel(at, &shape);
                return Err(invalid(
                    "image_e",
                    format!("value {v} at index {index:?}: {what}"),
                ));
            }
        }
        if let Some(offset) = offset_array {
            out.call_method1("__iadd__", (offset,))?;
        }
        Ok(out)
    }

    /// The model as given, e.g. `scmos-fixed:3`.
    #[getter]
    fn model_name(&self) -> String {
        self.text.clone()
    }

    /// The camera type: "scmos" or "emccd" (a camera model's: "emccd" when its register
    /// multiplies at the operating point).
    #[getter]
    fn sensor(&self) -> &'static str {
        let sensor = match &self.params.camera {
            Some(at) if self.spec.name() == "camera" => at.sensor(),
            _ => self.spec.sensor(),
        };
        match sensor {
            Sensor::Emccd => "emccd",
            Sensor::Scmos => "scmos",
        }
    }

    /// The seed of the frames read without an explicit seed.
    #[getter]
    fn seed(&self) -> u64 {
        self.seed
    }

    /// The frame counter: the next read without a seed reads frame `frame` (settable).
    #[getter]
    fn get_frame(&self) -> u64 {
        self.frame.load(Relaxed)
    }

    #[setter]
    fn set_frame(&self, frame: u64) {
        self.frame.store(frame, Relaxed);
    }

    /// Typical per-pixel read noise (e-) of the model for `subap_px` x `subap_px` images.
    fn noise_scale_e(&self, subap_px: usize) -> PyResult<f64> {
        Ok(self.model(subap_px)?.noise_scale_e())
    }

    fn __repr__(&self) -> String {
        format!("Readout({:?}, seed={})", self.text, self.seed)
    }
}

impl PyReadout {
    /// Scale and offsets of the output unit: (scale, scalar offset, array offset).
    fn output_unit<'py>(
        &self,
        unit: &str,
        offset_adu: Option<&Bound<'py, PyAny>>,
    ) -> PyResult<(f64, f64, Option<Bound<'py, PyAny>>)> {
        match unit {
            "e" => {
                if offset_adu.is_some() {
                    return Err(invalid("offset_adu", "applies only with `unit` \"adu\""));
                }
                Ok((1.0, 0.0, None))
            }
            "adu" => {
                let Some(g) = self.gain_e_per_adu else {
                    return Err(invalid(
                        "unit",
                        "\"adu\" needs the camera's conversion gain: give `gain_e_per_adu` to \
                         Readout",
                    ));
                };
                match offset_adu {
                    None => Ok((1.0 / g, 0.0, None)),
                    Some(o) => match o.extract::<f64>() {
                        Ok(v) if v.is_finite() => Ok((1.0 / g, v, None)),
                        Ok(v) => Err(invalid("offset_adu", format!("{v}: must be finite"))),
                        Err(_) => {
                            Ok((1.0 / g, 0.0, Some(float_array(o, "offset_adu")?.into_any())))
                        }
                    },
                }
            }
            other => Err(invalid(
                "unit",
                format!("{other:?}: must be \"e\" (electrons) or \"adu\""),
            )),
        }
    }
}

/// The multi-index of flat index `at` in an array of `shape` (C order).
fn unravel(mut at: usize, shape: &[usize]) -> Vec<usize> {
    let mut index = vec![0; shape.len()];
    for (i, &d) in shape.iter().enumerate().rev() {
        index[i] = at % d;
        at /= d;
    }
    index
}
