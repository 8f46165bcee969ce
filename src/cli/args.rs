//! Argument groups shared by the Monte-Carlo commands, list parsing, and the value parsers
//! that check every numeric option's range while the command line is parsed.

use super::progress::Terminal;
use crate::calib::{Map, Unit};
use crate::detector::dark_frames::DEFAULT_MAX_MIB;
use crate::detector::register::{MAX_EM_GAIN, MAX_STAGES};
use crate::detector::{DarkFrames, EmRegister, ModelParams, ModelSpec, RtsTable, MODEL_NAMES};
use crate::montecarlo::{BgGrid, Grid, SimConfig};
use crate::spot::{Sampling, Spot};
use crate::{Error, Result};
use std::ops::Bound::{self, Excluded, Included, Unbounded};
use std::ops::RangeBounds;
use std::sync::Arc;

/// A clap value parser for a finite real number between `lo` and `hi`; `unit` follows the
/// range in the message (clap names the option, e.g. `invalid value '-1' for '--qe <QE>':
/// must be a number in (0, 1]`).
pub fn real(
    lo: Bound<f64>,
    hi: Bound<f64>,
    unit: &'static str,
) -> impl Fn(&str) -> std::result::Result<f64, String> + Clone + Send + Sync + 'static {
    move |text: &str| match text.trim().parse::<f64>() {
        Ok(v) if v.is_finite() && (lo, hi).contains(&v) => Ok(v),
        _ => Err(format!("must be a number {}", describe(lo, hi, unit))),
    }
}

/// A clap value parser for a whole number from `lo` to `hi` (also written like `1e6`).
pub fn whole<T>(
    lo: u64,
    hi: u64,
    unit: &'static str,
) -> impl Fn(&str) -> std::result::Result<T, String> + Clone + Send + Sync + 'static
where
    T: TryFrom<u64>,
{
    move |text: &str| {
        let text = text.trim();
        let value = text.parse::<i128>().ok().or_else(|| {
            let v = text.parse::<f64>().ok()?;
            (v.is_finite() && v.fract() == 0.0 && v.abs() < 1e30).then_some(v as i128)
        });
        value
            .filter(|v| (lo as i128..=hi as i128).contains(v))
            .and_then(|v| T::try_from(v as u64).ok())
            .ok_or_else(|| {
                let sep = if unit.is_empty() { "" } else { " " };
                format!("must be a whole number from {lo} to {hi}{sep}{unit}")
            })
    }
}

/// A clap value parser for a retired option: it refuses any value, naming the option's new
/// spelling (`now`).
pub fn renamed(
    now: &'static str,
) -> impl Fn(&str) -> std::result::Result<String, String> + Clone + Send + Sync + 'static {
    move |_: &str| Err(format!("this option was renamed: use {now}"))
}

/// `in (0, 1] unit`, `>= 0 unit`, ...: a range as the messages state it.
fn describe(lo: Bound<f64>, hi: Bound<f64>, unit: &str) -> String {
    let unit = if unit.is_empty() {
        String::new()
    } else {
        format!(" {unit}")
    };
    let num = |v: f64| {
        if v.abs() >= 1e6 {
            format!("{v:e}")
        } else {
            format!("{v}")
        }
    };
    match (lo, hi) {
        (Included(a), Unbounded) => format!(">= {}{unit}", num(a)),
        (Excluded(a), Unbounded) => format!("> {}{unit}", num(a)),
        (Unbounded, Unbounded) => format!("(finite){unit}"),
        (lo, hi) => {
            let (open, a) = match lo {
                Included(a) => ('[', num(a)),
                Excluded(a) => ('(', num(a)),
                Unbounded => ('(', "-inf".into()),
            };
            let (close, b) = match hi {
                Included(b) => (']', num(b)),
                Excluded(b) => (')', num(b)),
                Unbounded => (')', "inf".into()),
            };
            format!("in {open}{a}, {b}{close}{unit}")
        }
    }
}

/// The sub-aperture, spot, signal and sampling options of a Monte-Carlo sweep.
#[derive(clap::Args, Debug, Clone)]
pub struct SweepArgs {
    /// Sub-aperture sizes, pixels per side (2 to 128), comma-separated (e.g. 4,8,16).
    #[arg(long, default_value = "16", allow_hyphen_values = true)]
    pub subap: String,
    /// Spot shapes: airy:D (first-dark-ring diameter D px; airy:1,2,4 gives three spots) or
    /// gauss:SX,SY (standard deviations in px); sizes >= 0.1 px. Repeat the option for
    /// several Gaussians.
    #[arg(long, default_values = ["airy:2"], allow_hyphen_values = true)]
    pub spot: Vec<String>,
    /// Pixel sampling of the spot: integrated over each pixel's area, or point values at pixel centres.
    #[arg(long, value_enum, default_value_t = Sampling::Integrated)]
    pub sampling: Sampling,
    /// Signal levels, photons per sub-aperture before QE, comma-separated; signal x QE at most
    /// 1e9 photo-electrons (counts are 32-bit per pixel).
    #[arg(long, default_value = "50", allow_hyphen_values = true)]
    pub signal: String,
    /// Quantum efficiency (photo-electrons per photon, 0-1], applied to every model.
    #[arg(long, default_value_t = 1.0, value_parser = real(Excluded(0.0), Included(1.0), ""))]
    pub qe: f64,
    /// Monte-Carlo iterations (frames) per configuration, 2 to 1e9.
    #[arg(long, default_value_t = 10_000, value_parser = whole::<u64>(2, SimConfig::MAX_ITERS, "frames"))]
    pub iters: u64,
    /// Seed of every random stream (a whole number, unitless); the same seed gives the same
    /// results on any thread count.
    #[arg(long, default_value_t = 1, value_parser = whole::<u64>(0, u64::MAX, ""))]
    pub seed: u64,
    /// Background levels subtracted before centroiding, e-: `auto` (0-1 e- in 0.05 steps,
    /// coarser above, 5 % steps up to the brightest expected pixel) or start:stop:step
    /// (at most 100,000 levels).
    #[arg(long, default_value = "auto", allow_hyphen_values = true)]
    pub bg_grid: String,
    /// Half-width of the random spot offset, px: offsets are uniform in [-h, h] in x and y;
    /// at most a quarter of the sub-aperture side (the spot stays mostly inside it).
    #[arg(long, default_value_t = 0.5, value_parser = real(Included(0.0), Unbounded, "px"))]
    pub position_range: f64,
    /// Largest fraction of empty frames (nothing above the level) for a level to be eligible.
    #[arg(long, default_value_t = 0.01, value_parser = real(Included(0.0), Included(1.0), ""))]
    pub max_empty_frac: f64,
}

impl SweepArgs {
    /// Check every option of the sweep (lists included) before any work.
    pub fn validate(&self) -> Result<()> {
        self.configs().map(|_| ())
    }

    /// Every configuration of the cartesian product sub-aperture x spot x signal.
    pub fn configs(&self) -> Result<Vec<SimConfig>> {
        let subaps_px = parse_list::<usize>(&self.subap, "--subap")?;
        let signals_photons = parse_list::<f64>(&self.signal, "--signal")?;
        let spots = Spot::parse_list(&self.spot)?;
        let shared = SimConfig {
            sampling: self.sampling,
            qe: self.qe,
            iters: self.iters,
            seed: self.seed,
            bg_grid: BgGrid::parse(&self.bg_grid)?,
            position_half_range_px: self.position_range,
            max_empty_frac: self.max_empty_frac,
            ..SimConfig::paper(subaps_px[0])
        };
        let grid = Grid {
            subaps_px,
            spots,
            signals_photons,
            shared,
        };
        grid.configs()
    }
}

/// Detector parameters of the readout models.
#[derive(clap::Args, Debug, Clone)]
pub struct DetectorArgs {
    /// EMCCD mean EM gain, output e- per input e-: 1 to 10,000 (cameras run at most at a few
    /// thousand; the exact register's table grows linearly with the gain).
    #[arg(long, default_value_t = 500.0, value_parser = real(Included(1.0), Included(MAX_EM_GAIN), "e-/e-"))]
    pub em_gain: f64,
    /// Retired spelling of `--em-gain`: refused, naming the new option.
    #[arg(long = "gain", hide = true, value_name = "VALUE", value_parser = renamed("`--em-gain` (EM gain, e-/e-); the conversion gain is `--gain-e-per-adu`"))]
    pub retired_gain: Option<String>,
    /// Stages of the EM register, 1 to 2000 stages, and at least log2(gain) (a stage at most
    /// doubles the charge: p = gain^(1/stages) - 1 <= 1).
    #[arg(long, default_value_t = 520, value_parser = whole::<u32>(1, MAX_STAGES as u64, "stages"))]
    pub stages: u32,
    /// EMCCD read noise before division by the gain, e- rms.
    #[arg(long, default_value_t = 50.0, value_parser = real(Included(0.0), Unbounded, "e-"))]
    pub emccd_read_noise: f64,
    /// Read noise of `scmos-constant` without its own `:SIGMA`, e- rms.
    #[arg(long, default_value_t = 1.0, value_parser = real(Included(0.0), Unbounded, "e-"))]
    pub sigma: f64,
    /// `emccd-distribution` draws N(n g, n g^2) instead of Gamma(n, g) above this many input
    /// electrons, e- (the paper's switch, corrected); default: always the exact Gamma.
    #[arg(long, value_parser = whole::<u32>(0, u32::MAX as u64, "input e-"))]
    pub gaussian_switch: Option<u32>,
    /// EM register sampler: `exact` (tabulated single-electron output, fast) or `cascade`
    /// (per-stage binomials, the slow reference).
    #[arg(long, value_parser = ["exact", "cascade"], default_value = "exact")]
    pub register: String,
    /// Seed of the fixed sCMOS noise patterns, unitless (`scmos-fixed:K` uses pattern K of it).
    #[arg(long, default_value_t = 2015, value_parser = whole::<u64>(0, u64::MAX, ""))]
    pub pattern_seed: u64,
    /// `emccd-pp` threshold rule (a reconstruction of Basden et al. 2003): poisson-prior
    /// (boundaries n(n+1)/lambda in units of g, lambda the sub-aperture mean or --pp-lambda),
    /// pixel-prior (the same with each pixel's own mean level in the centred noiseless spot, in
    /// photo-electrons: per-pixel thresholds and correction) or equal-density (fixed, ~0.203,
    /// 0.719, 1.896 g ...).
    #[arg(long, value_parser = ["poisson-prior", "equal-density", "pixel-prior"], default_value = "poisson-prior")]
    pub pp_rule: String,
    /// `emccd-pp` reference light level, photo-electrons per pixel; default: the sub-aperture mean
    /// (not with --pp-rule pixel-prior, whose levels are the pixels' own).
    #[arg(long, value_parser = real(Excluded(0.0), Unbounded, "photo-electrons per pixel"))]
    pub pp_lambda: Option<f64>,
    /// Per-pixel rms distribution of the sCMOS models: `paper` (Eq. 3 on [0, 10] e-) or the path
    /// of a `pdf_fit.json` written by `detnoise fit-pdf` (its best model unless --pdf-model).
    #[arg(long, default_value = "paper")]
    pub pdf: String,
    /// Name of the model to take from a `pdf_fit.json`: paper-scaled, paper-family,
    /// lognormal+tail or empirical.
    #[arg(long)]
    pub pdf_model: Option<String>,
    /// Measured read-noise map in e- (FITS/TIFF/EXR; e.g. `rms_e.fits` from `darks`) for the
    /// `scmos-map` model; non-finite pixels are excluded.
    #[arg(long)]
    pub map: Option<std::path::PathBuf>,
    /// Telegraph (RTS) pixels for `scmos-rts`: the rts.csv written by `darks` (with
    /// --gain-e-per-adu, so that it has the levels in e-), of the camera of --map.
    #[arg(long, value_name = "FILE")]
    pub rts_table: Option<std::path::PathBuf>,
    /// Row-noise amplitude of `scmos-correlated`, e- rms: one draw per row of the window per
    /// frame (darks: temporal_noise.row_rms_e in summary.json).
    #[arg(long, value_parser = real(Included(0.0), Unbounded, "e-"))]
    pub row_noise_e: Option<f64>,
    /// Column-noise amplitude of `scmos-correlated`, e- rms: one draw per column of the window
    /// per frame (darks: temporal_noise.column_rms_e in summary.json).
    #[arg(long, value_parser = real(Included(0.0), Unbounded, "e-"))]
    pub column_noise_e: Option<f64>,
    /// Dark frames for `scmos-frames` (files, a directory or a glob; FITS, TIFF, OpenEXR): each
    /// pixel's mean over the stack is subtracted and the values converted with
    /// --gain-e-per-adu.
    #[arg(long, num_args = 1.., value_name = "FILE")]
    pub dark_frames: Vec<std::path::PathBuf>,
    /// Memory bound of the dark frames kept for `scmos-frames`, MiB: a larger stack is sampled
    /// uniformly (a fixed-seed reservoir, reproducible) down to what fits, as f32 e-.
    #[arg(long, default_value_t = DEFAULT_MAX_MIB, value_parser = real(Excluded(0.0), Unbounded, "MiB"))]
    pub dark_frames_max_mib: f64,
    /// Conversion gain of --dark-frames, e- per adu.
    #[arg(long, value_parser = real(Excluded(0.0), Unbounded, "e- per adu"))]
    pub gain_e_per_adu: Option<f64>,
}

impl DetectorArgs {
    /// Check the detector options together (single values are checked while parsing), before
    /// any file is read; `specs` are the models the run will build.
    pub fn validate(&self, specs: &[ModelSpec]) -> Result<()> {
        EmRegister::check(self.em_gain, self.stages, "em_gain")?;
        if self.pdf == "paper" && self.pdf_model.is_some() {
            return Err(Error::invalid(
                "--pdf-model",
                "applies only with --pdf FILE",
            ));
        }
        if specs.contains(&ModelSpec::ScmosMap) && self.map.is_none() {
            return Err(Error::invalid(
                "--map",
                "the scmos-map model needs a measured noise map: give --map FILE",
            ));
        }
        for spec in specs {
            for field in spec.entry().params {
                if let Some((flag, what)) = self.missing(field) {
                    return Err(Error::invalid(
                        flag,
                        format!("the {} model needs {what}: give {flag}", spec.name()),
                    ));
                }
            }
        }
        if !self.dark_frames.is_empty() && self.gain_e_per_adu.is_none() {
            return Err(Error::invalid(
                "--gain-e-per-adu",
                "--dark-frames needs their conversion gain to convert them to e-: give \
                 --gain-e-per-adu",
            ));
        }
        Ok(())
    }

    /// The flag of model parameter `field` and what it is, when the parameter is not given.
    fn missing(&self, field: &str) -> Option<(&'static str, &'static str)> {
        match field {
            "map" if self.map.is_none() => Some(("--map", "a measured noise map (FILE, e-)")),
            "rts_table" if self.rts_table.is_none() => {
                Some(("--rts-table", "the telegraph pixels (rts.csv from darks)"))
            }
            "row_noise_e" if self.row_noise_e.is_none() => Some((
                "--row-noise-e",
                "the row-noise amplitude (e- rms; 0 for none)",
            )),
            "column_noise_e" if self.column_noise_e.is_none() => Some((
                "--column-noise-e",
                "the column-noise amplitude (e- rms; 0 for none)",
            )),
            "dark_frames" if self.dark_frames.is_empty() => Some((
                "--dark-frames",
                "the camera's dark frames (and --gain-e-per-adu)",
            )),
            _ => None,
        }
    }

    /// Model parameters, with the paper's rms pdf unless another is given.
    pub fn params(&self) -> Result<ModelParams> {
        self.validate(&[])?;
        Ok(ModelParams {
            em_gain: self.em_gain,
            stages: self.stages,
            emccd_read_noise_e: self.emccd_read_noise,
            gaussian_switch_e: self.gaussian_switch,
            cascade_register: self.register == "cascade",
            sigma_e: self.sigma,
            pdf: self.rms_pdf()?,
            pattern_seed: self.pattern_seed,
            map: self.noise_map()?,
            pp_rule: crate::detector::pp::PpRule::parse(&self.pp_rule)
                .expect("clap accepts only the rules' labels"),
            pp_lambda: self.pp_lambda,
            rts_table: self.rts_table()?,
            row_noise_e: self.row_noise_e,
            column_noise_e: self.column_noise_e,
            dark_frames: self.dark_frames()?,
        })
    }
}

impl DetectorArgs {
    /// The per-pixel rms distribution named by `--pdf`.
    fn rms_pdf(&self) -> Result<Arc<dyn crate::pdf::RmsPdf>> {
        // `validate` has refused --pdf-model without a file.
        match self.pdf.as_str() {
            "paper" => Ok(Arc::new(crate::pdf::paper())),
            file => crate::fit::pdf_fit::load_pdf_fit(file.as_ref(), self.pdf_model.as_deref()),
        }
    }

    /// The files these options read (`--map`, a `--pdf` file, `--rts-table`, `--dark-frames`),
    /// for the output-path checks.
    pub fn input_files(&self) -> Vec<std::path::PathBuf> {
        let pdf = (self.pdf != "paper").then(|| std::path::PathBuf::from(&self.pdf));
        let files = self.map.iter().cloned().chain(pdf);
        let files = files.chain(self.rts_table.iter().cloned());
        files.chain(self.dark_frames.iter().cloned()).collect()
    }

    /// The telegraph pixels named by `--rts-table`, if any; skipped rows are warned about.
    fn rts_table(&self) -> Result<Option<Arc<RtsTable>>> {
        self.rts_table
            .as_ref()
            .map(|path| Ok(Arc::new(RtsTable::read(path, &Terminal::default())?)))
            .transpose()
    }

    /// The dark frames named by `--dark-frames`, if any; says how many were kept.
    fn dark_frames(&self) -> Result<Option<Arc<DarkFrames>>> {
        if self.dark_frames.is_empty() {
            return Ok(None);
        }
        // `validate` has refused dark frames without a gain.
        let gain = self.gain_e_per_adu.unwrap_or(f64::NAN);
        let frames = DarkFrames::read(&self.dark_frames, gain, self.dark_frames_max_mib)?;
        eprintln!("scmos-frames: {}", frames.summary());
        Ok(Some(Arc::new(frames)))
    }

    /// The measured noise map named by `--map`, if any.
    fn noise_map(&self) -> Result<Option<Arc<Map>>> {
        self.map
            .as_ref()
            .map(|path| Ok(Arc::new(Map::read(path, Unit::Electrons)?)))
            .transpose()
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
        return Err(Error::invalid(
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
                Error::invalid(option, format!("'{s}' in '{text}' is not a valid number"))
            })
        })
        .collect::<Result<_>>()?;
    if items.is_empty() {
        return Err(Error::invalid(option, "empty list"));
    }
    Ok(items)
}

#[cfg(test)]
mod tests;

/// The centroiders to run (simulate, effective, report).
#[derive(clap::Args, Debug, Clone)]
pub struct CentroiderArgs {
    /// Centroiders, comma-separated `NAME[:PARAM]`; the help lists them from the registry.
    #[arg(long, default_value = "cog", help = centroider_short_help(), long_help = centroider_help())]
    pub centroider: String,
    /// Mask pixels whose read noise exceeds this many times the camera's median (sets the
    /// parameter of masked-cog in --centroider; times the median sigma).
    #[arg(long, value_parser = real(Excluded(0.0), Unbounded, ""))]
    pub mask_above: Option<f64>,
}

/// The short help of `--centroider`: what a PARAM is in, per method that takes one.
fn centroider_short_help() -> String {
    format!(
        "Centroiders, comma-separated `NAME[:PARAM]`; a PARAM fixes the method's parameter \
         instead of sweeping it ({}). Each is reported at its best setting; every method is \
         listed with --help",
        crate::centroid::centroider_units()
    )
}

/// The long help of `--centroider`: the methods and what each does.
fn centroider_help() -> String {
    format!(
        "Centroiders, comma-separated NAME[:PARAM]; a PARAM fixes the method's parameter instead \
         of sweeping it. Each is reported at its best setting (the eligible-level rule applies), \
         on the same frames as the others. Methods:{}",
        crate::centroid::centroiders_help()
    )
}

impl CentroiderArgs {
    /// The centroiders, `--mask-above` applied to those whose entry takes it (masked-cog).
    pub fn specs(&self) -> Result<Vec<crate::centroid::CentroiderSpec>> {
        use crate::centroid::{CentroiderSpec, CENTROIDERS};
        let mut specs: Vec<CentroiderSpec> = self
            .centroider
            .split(',')
            .filter(|s| !s.trim().is_empty())
            .map(|s| CentroiderSpec::parse(s.trim()))
            .collect::<Result<_>>()?;
        if specs.is_empty() {
            return Err(Error::invalid("--centroider", "no centroider given"));
        }
        if let Some(m) = self.mask_above {
            let mut any = false;
            for s in specs.iter_mut().filter(|s| s.entry.mask_above) {
                any = true;
                s.param.get_or_insert(m);
            }
            if !any {
                let takers: Vec<&str> = CENTROIDERS
                    .iter()
                    .filter(|e| e.mask_above)
                    .map(|e| e.name)
                    .collect();
                return Err(Error::invalid(
                    "--mask-above",
                    format!("applies to {}: add it to --centroider", takers.join(" or ")),
                ));
            }
        }
        let mut seen = std::collections::HashSet::new();
        for s in &specs {
            if !seen.insert(s.label()) {
                return Err(Error::invalid(
                    "--centroider",
                    format!("{} is given twice", s.label()),
                ));
            }
        }
        Ok(specs)
    }
}
