//! Argument groups shared by the Monte-Carlo commands, and list parsing.

use crate::detector::{ModelParams, ModelSpec, MODEL_NAMES};
use crate::montecarlo::{BgGrid, SimConfig};
use crate::spot::{Sampling, Spot};
use crate::{Error, Result};
use std::sync::Arc;

/// The sub-aperture, spot, signal and sampling options of a Monte-Carlo sweep.
#[derive(clap::Args, Debug, Clone)]
pub struct SweepArgs {
    /// Sub-aperture sizes, pixels per side, comma-separated (e.g. 4,8,16).
    #[arg(long, default_value = "16", allow_hyphen_values = true)]
    pub subap: String,
    /// Spot shapes: airy:D (first-dark-ring diameter D px; airy:1,2,4 gives three spots) or
    /// gauss:SX,SY (standard deviations in px). Repeat the option for several Gaussians.
    #[arg(long, default_values = ["airy:2"])]
    pub spot: Vec<String>,
    /// Pixel sampling of the spot: integrated over each pixel's area, or point values at pixel centres.
    #[arg(long, value_enum, default_value_t = Sampling::Integrated)]
    pub sampling: Sampling,
    /// Signal levels, photons per sub-aperture before QE, comma-separated.
    #[arg(long, default_value = "50", allow_hyphen_values = true)]
    pub signal: String,
    /// Quantum efficiency (photo-electrons per photon, 0-1], applied to every model.
    #[arg(long, default_value_t = 1.0, allow_hyphen_values = true)]
    pub qe: f64,
    /// Monte-Carlo iterations (frames) per configuration.
    #[arg(long, default_value_t = 10_000)]
    pub iters: u64,
    /// Seed of every random stream; the same seed gives the same results on any thread count.
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Background levels subtracted before centroiding, e-: `auto` (0-1 e- in 0.05 steps,
    /// coarser above, 5 % steps up to the brightest expected pixel) or start:stop:step.
    #[arg(long, default_value = "auto")]
    pub bg_grid: String,
    /// Half-width of the random spot offset, px: offsets are uniform in [-h, h] in x and y.
    #[arg(long, default_value_t = 0.5, allow_hyphen_values = true)]
    pub position_range: f64,
    /// Largest fraction of empty frames (nothing above the level) for a level to be eligible.
    #[arg(long, default_value_t = 0.01)]
    pub max_empty_frac: f64,
}

impl SweepArgs {
    /// Every configuration of the cartesian product sub-aperture x spot x signal.
    pub fn configs(&self) -> Result<Vec<SimConfig>> {
        let subaps = parse_list::<usize>(&self.subap, "--subap")?;
        let signals = parse_list::<f64>(&self.signal, "--signal")?;
        let spots = parse_spots(&self.spot)?;
        let bg_grid = BgGrid::parse(&self.bg_grid)?;
        let mut out = Vec::new();
        for &subap_px in &subaps {
            for spot in &spots {
                for &signal_photons in &signals {
                    let cfg = SimConfig {
                        subap_px,
                        spot: *spot,
                        sampling: self.sampling,
                        signal_photons,
                        qe: self.qe,
                        iters: self.iters,
                        seed: self.seed,
                        bg_grid: bg_grid.clone(),
                        position_half_range_px: self.position_range,
                        max_empty_frac: self.max_empty_frac,
                    };
                    cfg.validate()?;
                    out.push(cfg);
                }
            }
        }
        Ok(out)
    }
}

/// Detector parameters of the readout models.
#[derive(clap::Args, Debug, Clone)]
pub struct DetectorArgs {
    /// EMCCD mean EM gain, output e- per input e-.
    #[arg(long, default_value_t = 500.0)]
    pub gain: f64,
    /// Stages of the EM register.
    #[arg(long, default_value_t = 520)]
    pub stages: u32,
    /// EMCCD read noise before division by the gain, e- rms.
    #[arg(long, default_value_t = 50.0)]
    pub emccd_read_noise: f64,
    /// Read noise of `scmos-constant` without its own `:SIGMA`, e- rms.
    #[arg(long, default_value_t = 1.0)]
    pub sigma: f64,
    /// `emccd-distribution` draws N(n g, n g^2) instead of Gamma(n, g) above this many input
    /// electrons (the paper's switch, corrected); default: always the exact Gamma.
    #[arg(long)]
    pub gaussian_switch: Option<u32>,
    /// EM register sampler: `exact` (tabulated single-electron output, fast) or `cascade`
    /// (per-stage binomials, the slow reference).
    #[arg(long, value_parser = ["exact", "cascade"], default_value = "exact")]
    pub register: String,
    /// Seed of the fixed sCMOS noise patterns (`scmos-fixed:K` uses pattern K of it).
    #[arg(long, default_value_t = 2015)]
    pub pattern_seed: u64,
    /// `emccd-pp` threshold rule (a reconstruction of Basden et al. 2003): poisson-prior
    /// (boundaries n(n+1)/lambda in units of g) or equal-density (fixed, ~0.203, 0.719, 1.896 g ...).
    #[arg(long, value_parser = ["poisson-prior", "equal-density"], default_value = "poisson-prior")]
    pub pp_rule: String,
    /// `emccd-pp` reference light level, photo-electrons per pixel; default: the sub-aperture mean.
    #[arg(long)]
    pub pp_lambda: Option<f64>,
    /// Per-pixel rms distribution of the sCMOS models: `paper` (Eq. 3 on [0, 10] e-) or a
    /// `pdf_fit.json` written by `detnoise fit-pdf` (its best model unless --pdf-model).
    #[arg(long, default_value = "paper")]
    pub pdf: String,
    /// Model to take from a `pdf_fit.json`: paper-scaled, paper-family, lognormal+tail or empirical.
    #[arg(long)]
    pub pdf_model: Option<String>,
    /// Measured read-noise map in e- (FITS/TIFF/EXR; e.g. `rms_e.fits` from `darks`) for the
    /// `scmos-map` model; non-finite pixels are excluded.
    #[arg(long)]
    pub map: Option<std::path::PathBuf>,
}

impl DetectorArgs {
    /// Model parameters, with the paper's rms pdf unless another is given.
    pub fn params(&self) -> Result<ModelParams> {
        if !(self.gain >= 1.0 && self.gain.is_finite()) {
            return Err(Error::usage("--gain", "EM gain must be >= 1"));
        }
        if self.stages == 0 {
            return Err(Error::usage(
                "--stages",
                "the register needs at least one stage",
            ));
        }
        if !(self.emccd_read_noise >= 0.0 && self.sigma >= 0.0) {
            return Err(Error::usage("--sigma", "read noise must be >= 0 e-"));
        }
        Ok(ModelParams {
            gain: self.gain,
            stages: self.stages,
            emccd_read_noise_e: self.emccd_read_noise,
            gaussian_switch_e: self.gaussian_switch,
            cascade_register: self.register == "cascade",
            sigma_e: self.sigma,
            pdf: self.rms_pdf()?,
            pattern_seed: self.pattern_seed,
            map: self.noise_map()?,
            pp_rule: if self.pp_rule == "equal-density" {
                crate::pp::PpRule::EqualDensity
            } else {
                crate::pp::PpRule::PoissonPrior
            },
            pp_lambda: match self.pp_lambda {
                Some(l) if !(l.is_finite() && l > 0.0) => {
                    return Err(Error::usage(
                        "--pp-lambda",
                        "must be > 0 photo-electrons per pixel",
                    ))
                }
                other => other,
            },
        })
    }
}

impl DetectorArgs {
    /// The per-pixel rms distribution named by `--pdf`.
    fn rms_pdf(&self) -> Result<Arc<dyn crate::pdf::RmsPdf>> {
        match (self.pdf.as_str(), &self.pdf_model) {
            ("paper", None) => Ok(Arc::new(crate::pdf::paper())),
            ("paper", Some(_)) => Err(Error::usage("--pdf-model", "applies only with --pdf FILE")),
            (file, model) => {
                crate::fit::pdf_fit::load_pdf_fit(std::path::Path::new(file), model.as_deref())
            }
        }
    }

    /// The files these options read (`--map`, a `--pdf` file), for the output-path checks.
    pub fn input_files(&self) -> Vec<std::path::PathBuf> {
        let pdf = (self.pdf != "paper").then(|| std::path::PathBuf::from(&self.pdf));
        self.map.iter().cloned().chain(pdf).collect()
    }

    /// The measured noise map named by `--map`, if any.
    fn noise_map(&self) -> Result<Option<Arc<crate::detector::NoiseMap>>> {
        let Some(path) = &self.map else {
            return Ok(None);
        };
        let m = crate::maps::read_map(path)?;
        Ok(Some(Arc::new(crate::detector::NoiseMap {
            rows: m.rows,
            cols: m.cols,
            rms_e: m.data,
            source: path.display().to_string(),
        })))
    }
}

/// Parse the comma-separated model list.
pub fn parse_models(text: &str) -> Result<Vec<ModelSpec>> {
    let specs: Vec<ModelSpec> = text
        .split(',')
        .filter(|s| !s.trim().is_empty())
        .map(|s| ModelSpec::parse(s.trim()))
        .collect::<Result<_>>()?;
    if specs.is_empty() {
        return Err(Error::usage(
            "--model",
            format!("no model given (known: {MODEL_NAMES})"),
        ));
    }
    Ok(specs)
}

/// Parse a comma-separated list of numbers for `option`.
pub fn parse_list<T: std::str::FromStr>(text: &str, option: &str) -> Result<Vec<T>> {
    let items: Vec<T> = text
        .split(',')
        .map(|s| {
            s.trim().parse::<T>().map_err(|_| {
                Error::usage(option, format!("'{s}' in '{text}' is not a valid number"))
            })
        })
        .collect::<Result<_>>()?;
    if items.is_empty() {
        return Err(Error::usage(option, "empty list"));
    }
    Ok(items)
}

/// Parse spot options: `airy:D1,D2,...` gives one Airy spot per diameter; `gauss:SX,SY` one Gaussian.
pub fn parse_spots(items: &[String]) -> Result<Vec<Spot>> {
    let mut spots = Vec::new();
    for item in items {
        match item.strip_prefix("airy:") {
            Some(ds) => {
                for d in ds.split(',') {
                    spots.push(Spot::parse(&format!("airy:{}", d.trim()))?);
                }
            }
            None => spots.push(Spot::parse(item)?),
        }
    }
    Ok(spots)
}
