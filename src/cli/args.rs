//! Argument groups shared by the Monte-Carlo commands, list parsing, and the value parsers
//! that check every numeric option's range while the command line is parsed.

use super::progress::Terminal;
use super::settings::settings_group;
use crate::detector::{ModelParams, ModelSpec, MODEL_NAMES};
use crate::effective::{Precision, Status};
use crate::montecarlo::{BgGrid, Grid, SimConfig};
use crate::settings;
use crate::spot::{Sampling, Spot};
use crate::{Error, Result};
use std::fmt::Write as _;
use std::ops::Bound::{self, Excluded, Unbounded};

/// A clap value parser for a finite real number between `lo` and `hi`; `unit` follows the
/// range in the message (clap names the option, e.g. `invalid value '-1' for '--qe <QE>':
/// must be a number in (0, 1]`).
pub fn real(
    lo: Bound<f64>,
    hi: Bound<f64>,
    unit: &'static str,
) -> impl Fn(&str) -> std::result::Result<f64, String> + Clone + Send + Sync + 'static {
    move |text: &str| settings::parse_real(text, lo, hi, unit)
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
        let v = settings::parse_whole(text, lo, hi, unit)?;
        T::try_from(v).map_err(|_| format!("{v}: too large"))
    }
}

settings_group!(
    /// The sub-aperture, spot, signal and sampling options of a Monte-Carlo sweep: one option
    /// per entry of [`settings::RUN`].
    SweepArgs = settings::RUN
);

impl SweepArgs {
    /// Check every option of the sweep (lists included) before any work.
    pub fn validate(&self) -> Result<()> {
        self.configs().map(|_| ())
    }

    /// Monte-Carlo iterations per configuration.
    pub fn iters(&self) -> u64 {
        self.values.whole(&settings::ITERS).expect("has a default")
    }

    /// The sub-aperture sizes as typed, px.
    pub fn subap_text(&self) -> String {
        self.values
            .text(&settings::SUBAP_PX)
            .expect("has a default")
    }

    /// The spot texts as typed.
    pub fn spot_texts(&self) -> Vec<String> {
        self.values.texts(&settings::SPOT)
    }

    /// Every configuration of the cartesian product sub-aperture x spot x signal.
    pub fn configs(&self) -> Result<Vec<SimConfig>> {
        let v = &self.values;
        let text = |s| v.text(s).expect("has a default");
        let real = |s| v.real(s).expect("has a default");
        let subaps_px = parse_list::<usize>(&text(&settings::SUBAP_PX), "--subap")?;
        let signals_photons = parse_list::<f64>(&text(&settings::SIGNAL_PHOTONS), "--signal")?;
        let spots = Spot::parse_list(&self.spot_texts())?;
        let shared = SimConfig {
            sampling: Sampling::parse(&text(&settings::SAMPLING)).expect("a checked choice"),
            qe: real(&settings::QE),
            iters: self.iters(),
            seed: v.whole(&settings::SEED).expect("has a default"),
            bg_grid: BgGrid::parse(&text(&settings::BG_GRID))?,
            position_half_range_px: real(&settings::POSITION_HALF_RANGE_PX),
            max_empty_frac: real(&settings::MAX_EMPTY_FRAC),
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

settings_group!(
    /// Detector parameters of the readout models: one option per entry of
    /// [`settings::READOUT`].
    DetectorArgs = settings::READOUT,
    finish = |cmd| cmd.arg(ambiguous_gain())
);

/// `--gain`, which could mean either gain: refused, naming both (clap's tip names only one).
fn ambiguous_gain() -> clap::Arg {
    clap::Arg::new("ambiguous_gain")
        .long("gain")
        .hide(true)
        .value_name("VALUE")
        .value_parser(|_: &str| -> std::result::Result<String, String> {
            Err(
                "which gain? `--em-gain` is the EM gain (e-/e-), `--gain-e-per-adu` the \
                 conversion gain (e- per adu)"
                    .into(),
            )
        })
}

impl DetectorArgs {
    /// Check the detector options together (single values are checked while parsing), before
    /// any file is read; `specs` are the models the run will build.
    pub fn validate(&self, specs: &[ModelSpec]) -> Result<()> {
        ModelParams::check_settings(&self.values, specs)
    }

    /// Model parameters, with the paper's rms pdf unless another is given; the files named
    /// are read (skipped RTS rows are warned about, the dark frames kept are told).
    pub fn params(&self) -> Result<ModelParams> {
        let params = ModelParams::from_settings(&self.values, &Terminal::default())?;
        if let Some(frames) = &params.dark_frames {
            eprintln!("scmos-frames: {}", frames.summary());
        }
        Ok(params)
    }

    /// The files these options read (`--map`, a `--pdf` file, `--rts-table`, `--dark-frames`),
    /// for the output-path checks.
    pub fn input_files(&self) -> Vec<std::path::PathBuf> {
        ModelParams::input_files(&self.values)
    }

    /// The EM gain, e-/e-.
    pub fn em_gain(&self) -> f64 {
        self.values.real(&settings::EM_GAIN).expect("has a default")
    }

    /// The EM register's stages.
    pub fn stages(&self) -> u32 {
        self.values.whole(&settings::STAGES).expect("has a default") as u32
    }

    /// The conversion gain, e- per adu, if given.
    pub fn gain_e_per_adu(&self) -> Option<f64> {
        self.values.real(&settings::GAIN_E_PER_ADU)
    }
}

settings_group!(
    /// The precision target of the effective read noise and the iteration cap (`effective`,
    /// `report`, `subaps`): one option per entry of [`settings::PRECISION`].
    PrecisionArgs = settings::PRECISION,
    finish = |cmd| cmd.mut_arg("target_se_e", |a| a.long_help(precision_long_help()))
);

impl PrecisionArgs {
    /// The library's precision settings for runs starting at `iters` iterations: the cap as
    /// given, or by default [`Precision::DEFAULT_MAX_ITERS`] raised to `iters`.
    pub fn precision(&self, iters: u64) -> Precision {
        let v = &self.values;
        Precision {
            target_se_e: v.real(&settings::TARGET_SE_E).expect("has a default"),
            target_rel: v.real(&settings::TARGET_REL).expect("has a default"),
            max_iters: v
                .whole(&settings::MAX_ITERS)
                .unwrap_or(Precision::DEFAULT_MAX_ITERS.max(iters)),
        }
    }
}

/// The long help of `--target-se-e`: the rule, then every status and what it means.
fn precision_long_help() -> String {
    let mut h = String::from(
        "Target standard error of each effective read noise, e- (0 = off). A value is `ok` when \
         its SE is at most this or at most --target-rel times the value; until then iterations \
         are added to its configuration (the same experiment continued, on the same random \
         numbers), up to --max-iters.\n\nStatuses (the `status` column):",
    );
    for s in Status::ALL {
        let meaning = super::fields::flags_in(s.meaning());
        let _ = write!(h, "\n  {:<18} {meaning}", s.label());
    }
    h
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

pub use crate::settings::parse_list;

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
        crate::centroid::parse_specs(&self.centroider, self.mask_above)
    }
}
