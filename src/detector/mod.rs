//! Detector readout models: photo-electrons in, an image in electrons out.
//!
//! Every model implements [`Readout`]; a new detector is one new type. Users name models
//! with [`ModelSpec`], which builds a readout for one sub-aperture size.

mod emccd;
mod pp;
pub mod register;
mod scmos;

pub use emccd::{EmccdDistribution, EmccdSimple, EmccdStochastic};
pub use pp::EmccdPp;
pub use register::EmRegister;
pub use scmos::{NoiseMap, PerPixelSigma, ScmosConstant, ScmosMap, ScmosRandom};

use crate::pdf::RmsPdf;
use crate::rng::SimRng;
use crate::{Error, Result};
use std::sync::Arc;

/// What a readout sees of one frame.
#[derive(Debug, Clone, Copy)]
pub struct FrameInput<'a> {
    /// Sub-aperture side (pixels); images are row-major n x n.
    pub subap_px: usize,
    /// Expected photo-electrons per pixel (noiseless spot x signal x QE).
    pub expected_e: &'a [f64],
    /// Photo-electrons per pixel after shot noise (shared by all models of a sweep).
    pub photo_e: &'a [u32],
}

/// A detector readout model. Output is in electrons referred to the input (EMCCD output is
/// divided by the mean gain), so all models share one background scale.
pub trait Readout: Send + Sync {
    /// Model name as reported in tables, e.g. `emccd-stochastic` or `scmos-fixed:3`.
    fn name(&self) -> String;
    /// Read one frame into `out` (e-). `noise` drives the per-frame read noise and is the same
    /// stream for every model of a sweep; `aux` drives model-specific draws (per-pixel sigmas).
    fn read(&self, input: &FrameInput, noise: &mut SimRng, aux: &mut SimRng, out: &mut [f64]);
    /// Typical per-pixel read noise (e-), used to size the default background grid.
    fn noise_scale_e(&self) -> f64;
}

/// Parameters shared by the models of a run.
#[derive(Debug, Clone)]
pub struct ModelParams {
    /// EMCCD mean gain (output e- per input e-); paper default 500.
    pub gain: f64,
    /// EM register stages; paper default 520.
    pub stages: u32,
    /// EMCCD read noise before division by the gain (e-); paper default 50.
    pub emccd_read_noise_e: f64,
    /// Above this many input electrons `emccd-distribution` uses N(n g, n g^2); None = exact Gamma.
    pub gaussian_switch_e: Option<u32>,
    /// Use the per-stage binomial cascade instead of the tabulated register (reference, slow).
    pub cascade_register: bool,
    /// sigma (e-) for a bare `scmos-constant`.
    pub sigma_e: f64,
    /// Distribution of per-pixel rms for the sCMOS models.
    pub pdf: Arc<dyn RmsPdf>,
    /// Seed of the fixed sCMOS noise patterns (pattern K uses stream K of it).
    pub pattern_seed: u64,
    /// Measured noise map for `scmos-map`.
    pub map: Option<Arc<NoiseMap>>,
    /// Threshold rule of `emccd-pp`.
    pub pp_rule: crate::pp::PpRule,
    /// Fixed reference light level of `emccd-pp` (photo-electrons per pixel); None = sub-aperture mean.
    pub pp_lambda: Option<f64>,
}

impl Default for ModelParams {
    fn default() -> Self {
        ModelParams {
            gain: 500.0,
            stages: 520,
            emccd_read_noise_e: 50.0,
            gaussian_switch_e: None,
            cascade_register: false,
            sigma_e: 1.0,
            pdf: Arc::new(crate::pdf::paper()),
            pattern_seed: 2015,
            map: None,
            pp_rule: crate::pp::PpRule::PoissonPrior,
            pp_lambda: None,
        }
    }
}

/// A readout model named on the command line.
#[derive(Debug, Clone, PartialEq)]
pub enum ModelSpec {
    /// Half the flux, Poisson, + Normal(0, 0.1 e-).
    EmccdSimple,
    /// Exact 520-stage register + Normal(0, 50 e-), divided by the gain.
    EmccdStochastic,
    /// `emccd-stochastic` then Poisson-probability thresholding; `true` = photometrically corrected.
    EmccdPp(bool),
    /// Gamma(k, g) register + Normal(0, 50 e-), divided by the gain.
    EmccdDistribution,
    /// One sigma for all pixels (e-); None takes the run's `--sigma`.
    ScmosConstant(Option<f64>),
    /// Constant sigma equal to the pdf's median.
    ScmosMedian,
    /// Constant sigma equal to the pdf's mean.
    ScmosMean,
    /// Per-pixel sigma drawn once from the pdf; the number selects the seeded pattern.
    ScmosFixed(u32),
    /// Per-pixel sigma drawn anew from the pdf every frame.
    ScmosRandom,
    /// Per-pixel sigma from a random window of a measured noise map (`--map FILE`).
    ScmosMap,
}

/// Every model name accepted by [`ModelSpec::parse`], for help texts.
pub const MODEL_NAMES: &str =
    "emccd-simple, emccd-stochastic, emccd-distribution, emccd-pp, emccd-pp-uncorrected, \
scmos-constant[:SIGMA_E], scmos-median, scmos-mean, scmos-fixed[:PATTERN], scmos-random, scmos-map";

impl ModelSpec {
    /// Parse a model name such as `scmos-fixed:3` or `scmos-constant:1.2`.
    pub fn parse(text: &str) -> Result<Self> {
        let (head, arg) = match text.split_once(':') {
            Some((h, a)) => (h, Some(a)),
            None => (text, None),
        };
        let bad = || {
            Error::invalid(
                "--model",
                format!("unknown model '{text}' (known: {MODEL_NAMES})"),
            )
        };
        let no_arg = |spec: ModelSpec| if arg.is_some() { Err(bad()) } else { Ok(spec) };
        match head.trim() {
            "emccd-simple" => no_arg(ModelSpec::EmccdSimple),
            "emccd-stochastic" => no_arg(ModelSpec::EmccdStochastic),
            "emccd-distribution" => no_arg(ModelSpec::EmccdDistribution),
            "emccd-pp" => no_arg(ModelSpec::EmccdPp(true)),
            "emccd-pp-uncorrected" => no_arg(ModelSpec::EmccdPp(false)),
            "scmos-median" => no_arg(ModelSpec::ScmosMedian),
            "scmos-mean" => no_arg(ModelSpec::ScmosMean),
            "scmos-random" => no_arg(ModelSpec::ScmosRandom),
            "scmos-map" => no_arg(ModelSpec::ScmosMap),
            "scmos-constant" => match arg {
                None => Ok(ModelSpec::ScmosConstant(None)),
                Some(a) => match a.parse::<f64>() {
                    Ok(s) if s.is_finite() && s >= 0.0 => Ok(ModelSpec::ScmosConstant(Some(s))),
                    _ => Err(Error::invalid(
                        "--model",
                        format!("'{text}': sigma must be a number >= 0 (e-)"),
                    )),
                },
            },
            "scmos-fixed" => match arg {
                None => Ok(ModelSpec::ScmosFixed(0)),
                Some(a) => a.parse::<u32>().map(ModelSpec::ScmosFixed).map_err(|_| {
                    Error::invalid(
                        "--model",
                        format!("'{text}': pattern must be a whole number"),
                    )
                }),
            },
            _ => Err(bad()),
        }
    }

    /// Build the readout for `subap_px` x `subap_px` sub-apertures.
    pub fn build(&self, params: &ModelParams, subap_px: usize) -> Result<Box<dyn Readout>> {
        let constant = |sigma: f64, name: String| -> Box<dyn Readout> {
            Box::new(ScmosConstant::new(sigma, name))
        };
        Ok(match self {
            ModelSpec::EmccdSimple => Box::new(EmccdSimple::paper()),
            ModelSpec::EmccdStochastic => Box::new(EmccdStochastic::new(
                EmRegister::new(params.gain, params.stages)?,
                params.emccd_read_noise_e,
                params.cascade_register,
            )),
            ModelSpec::EmccdPp(corrected) => Box::new(EmccdPp::new(
                EmRegister::new(params.gain, params.stages)?,
                params.emccd_read_noise_e,
                crate::pp::PpConfig::new(params.pp_rule, params.gain, params.emccd_read_noise_e)?,
                params.pp_lambda,
                *corrected,
            )?),
            ModelSpec::EmccdDistribution => Box::new(EmccdDistribution::new(
                params.gain,
                params.emccd_read_noise_e,
                params.gaussian_switch_e,
            )),
            ModelSpec::ScmosConstant(s) => {
                let sigma = s.unwrap_or(params.sigma_e);
                constant(sigma, format!("scmos-constant:{sigma}"))
            }
            ModelSpec::ScmosMedian => constant(params.pdf.median(), "scmos-median".into()),
            ModelSpec::ScmosMean => constant(params.pdf.mean(), "scmos-mean".into()),
            ModelSpec::ScmosFixed(k) => Box::new(PerPixelSigma::fixed_pattern(
                params.pdf.as_ref(),
                subap_px,
                params.pattern_seed,
                *k,
            )),
            ModelSpec::ScmosRandom => Box::new(ScmosRandom::new(params.pdf.clone())),
            ModelSpec::ScmosMap => match &params.map {
                Some(map) => Box::new(ScmosMap::new(map.clone(), subap_px)?),
                None => {
                    return Err(Error::invalid(
                        "--model",
                        "scmos-map needs a measured noise map: give --map FILE",
                    ))
                }
            },
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parses_every_model_and_rejects_unknown() {
        for name in [
            "emccd-simple",
            "emccd-stochastic",
            "emccd-distribution",
            "emccd-pp",
            "emccd-pp-uncorrected",
            "scmos-constant",
            "scmos-constant:1.5",
            "scmos-median",
            "scmos-mean",
            "scmos-fixed",
            "scmos-fixed:4",
            "scmos-random",
        ] {
            let spec = ModelSpec::parse(name).unwrap();
            let built = spec.build(&ModelParams::default(), 4).unwrap();
            assert!(built.name().starts_with(name.split(':').next().unwrap()));
        }
        for bad in [
            "emccd",
            "scmos-constant:-1",
            "scmos-fixed:x",
            "emccd-simple:2",
            "",
        ] {
            let err = ModelSpec::parse(bad).unwrap_err();
            assert_eq!(err.exit_code(), 2, "{bad}");
        }
    }
}
