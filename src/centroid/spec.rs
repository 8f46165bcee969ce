//! A centroider as the user names it ([`CentroiderSpec`]: `NAME[:PARAM]`) and as the registry
//! knows it ([`CentroiderEntry`]: name, help, its parameter's names, unit, range and sweep grid,
//! and its builder), and what building one for a run needs ([`CentroidContext`]: the grid
//! depends on the spot, the sub-aperture and the camera).

use super::centroider::Centroider;
use crate::spot::{Sampling, Spot};
use crate::{Error, Result};

/// One centroider of the registry (`centroid::CENTROIDERS`).
#[derive(Debug, Clone, Copy)]
pub struct CentroiderEntry {
    /// Name on the command line and in tables, e.g. `masked-cog`.
    pub name: &'static str,
    /// One line of help for `--centroider`.
    pub help: &'static str,
    /// Its own parameter, swept unless `NAME:PARAM` fixes it; None = takes none.
    pub param: Option<CentroiderParam>,
    /// Whether `--mask-above` sets its parameter.
    pub mask_above: bool,
    /// Builds it for a run from the values of its parameter (the fixed one, or its sweep grid;
    /// empty when it takes none).
    pub build: BuildFn,
}

/// A centroider's builder: its entry, the values of its parameter (the fixed one, or its sweep
/// grid; empty when it takes none) and the run.
pub type BuildFn =
    fn(&'static CentroiderEntry, &[f64], &CentroidContext) -> Result<Box<dyn Centroider>>;

impl PartialEq for CentroiderEntry {
    fn eq(&self, other: &Self) -> bool {
        self.name == other.name
    }
}

/// A centroider's own parameter: its names, unit, meaning, allowed range and sweep grid.
#[derive(Debug, Clone, Copy)]
pub struct CentroiderParam {
    /// Column name with its unit, as tables and records write it (e.g. `k_sigma`).
    pub name: &'static str,
    /// Its letter in help and errors (e.g. `K`).
    pub symbol: &'static str,
    /// Its unit in words (e.g. `sigmas`, `px`).
    pub unit: &'static str,
    /// What it sets, in a few words.
    pub meaning: &'static str,
    /// The values a fixed parameter may take.
    pub range: ParamRange,
    /// The values swept when none is fixed, for the run of `ctx`.
    pub grid: fn(&CentroidContext) -> Vec<f64>,
}

/// Allowed values of a parameter: at or above (or strictly above) a bound, whole or real.
#[derive(Debug, Clone, Copy)]
pub struct ParamRange {
    /// The bound, in the parameter's unit.
    pub least: f64,
    /// Whether the bound itself is allowed.
    pub inclusive: bool,
    /// Whether only whole numbers are allowed (a count).
    pub whole: bool,
}

impl ParamRange {
    /// Whether `v` is allowed.
    pub fn contains(&self, v: f64) -> bool {
        let above = if self.inclusive {
            v >= self.least
        } else {
            v > self.least
        };
        above && (!self.whole || v.fract() == 0.0)
    }
}

impl CentroiderParam {
    /// The rule a fixed value breaks, as errors state it: `K must be >= 0 (sigmas)`, or for a
    /// count (whose unit "whole number" says) `N must be a whole number >= 1`.
    pub fn rule(&self) -> String {
        let r = &self.range;
        let op = if r.inclusive { ">=" } else { ">" };
        if r.whole {
            format!("{} must be a whole number {op} {}", self.symbol, r.least)
        } else {
            format!("{} must be {op} {} ({})", self.symbol, r.least, self.unit)
        }
    }
}

/// A centroider as chosen: its registry entry and, optionally, its parameter fixed instead of
/// swept.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct CentroiderSpec {
    /// The method.
    #[serde(rename = "kind", serialize_with = "entry_name")]
    pub entry: &'static CentroiderEntry,
    /// Its parameter (unit of [`CentroiderParam::name`]) when given; swept when None.
    pub param: Option<f64>,
}

/// Serialises an entry as its name.
fn entry_name<S: serde::Serializer>(
    entry: &&'static CentroiderEntry,
    s: S,
) -> std::result::Result<S::Ok, S::Error> {
    s.serialize_str(entry.name)
}

/// What building a centroider for a run needs to know.
#[derive(Clone, Copy)]
pub struct CentroidContext<'a> {
    /// Sub-aperture side (px).
    pub subap_px: usize,
    /// The run's background levels (e-), ascending.
    pub levels_e: &'a [f64],
    /// The centred spot's expected photo-electrons per pixel (row-major).
    pub mean_e: &'a [f64],
    /// The spot.
    pub spot: Spot,
    /// How the spot is sampled (the weighted centroid's response is calibrated with it).
    pub sampling: Sampling,
    /// The camera's median per-pixel read noise (e-).
    pub median_sigma_e: f64,
}

impl CentroiderSpec {
    /// `entry` with its parameter swept.
    pub fn of(entry: &'static CentroiderEntry) -> Self {
        CentroiderSpec { entry, param: None }
    }

    /// Check a given parameter's range.
    pub fn validate(&self) -> Result<()> {
        let Some(p) = self.param else { return Ok(()) };
        let rule = match &self.entry.param {
            Some(param) if param.range.contains(p) => return Ok(()),
            Some(param) => param.rule(),
            None => "no parameter is taken".to_string(),
        };
        Err(Error::invalid(
            "centroider",
            format!("{}:{p}: {rule}", self.entry.name),
        ))
    }

    /// Text form, as [`CentroiderSpec::parse`] takes it.
    pub fn label(&self) -> String {
        match self.param {
            Some(p) => format!("{}:{p}", self.entry.name),
            None => self.entry.name.to_string(),
        }
    }

    /// The centroider for a run described by `ctx`: its entry's builder over the fixed
    /// parameter or the entry's sweep grid.
    pub fn build(&self, ctx: &CentroidContext) -> Result<Box<dyn Centroider>> {
        let values = match (self.param, &self.entry.param) {
            (Some(p), _) => vec![p],
            (None, Some(param)) => (param.grid)(ctx),
            (None, None) => Vec::new(),
        };
        (self.entry.build)(self.entry, &values, ctx)
    }
}
