//! A readout model as the user names it ([`ModelSpec`]) and as the registry knows it
//! ([`ModelEntry`]: name, argument, help, the parameters it reads, its parser and builder).
//! Each readout file defines its entries; the registry in `detector` lists them, and parsing,
//! building and a spec's properties go through its entry.

use super::params::ModelParams;
use super::readout::Readout;
use crate::Result;

/// A readout model named on the command line.
#[derive(Debug, Clone, PartialEq)]
pub enum ModelSpec {
    /// A fraction q of the flux (None: the paper's half), Poisson, + Normal(0, read noise /
    /// EM gain).
    EmccdSimple(Option<f64>),
    /// Exact 520-stage register + Normal(0, 50 e-), divided by the gain.
    EmccdStochastic,
    /// `emccd-stochastic` then Poisson-probability thresholding; `true` = photometrically corrected.
    EmccdPp(bool),
    /// Gamma(k, g) register + Normal(0, 50 e-), divided by the gain.
    EmccdDistribution,
    /// One sigma for all pixels (e-); None takes the run's `sigma_e`.
    ScmosConstant(Option<f64>),
    /// Constant sigma equal to the pdf's median.
    ScmosMedian,
    /// Constant sigma equal to the pdf's mean.
    ScmosMean,
    /// Per-pixel sigma drawn once from the pdf; the number selects the seeded pattern.
    ScmosFixed(u32),
    /// Per-pixel sigma drawn anew from the pdf every frame.
    ScmosRandom,
    /// Per-pixel sigma from a random window of a measured noise map (`map`).
    ScmosMap,
    /// A model known only through its registry entry: a detector added as one new file and
    /// one registry line, without a variant of its own.
    Registered(RegisteredModel),
}

/// A registry model without a variant of its own: its entry and its `:ARG` text as given.
#[derive(Debug, Clone)]
pub struct RegisteredModel {
    entry: &'static ModelEntry,
    arg: Option<String>,
}

impl RegisteredModel {
    /// The model's registry entry.
    pub fn entry(&self) -> &'static ModelEntry {
        self.entry
    }

    /// The text after `name:`, if any; the entry's builder interprets it.
    pub fn arg(&self) -> Option<&str> {
        self.arg.as_deref()
    }
}

impl PartialEq for RegisteredModel {
    fn eq(&self, other: &Self) -> bool {
        self.entry.name == other.entry.name && self.arg == other.arg
    }
}

impl ModelSpec {
    /// The spec of a model that has no variant of its own: use `parse: ModelSpec::registered`
    /// in its registry entry. The argument is kept as text for the entry's builder.
    pub fn registered(
        entry: &'static ModelEntry,
        arg: Option<&str>,
    ) -> std::result::Result<ModelSpec, String> {
        Ok(ModelSpec::Registered(RegisteredModel {
            entry,
            arg: arg.map(str::to_string),
        }))
    }

    /// The model's registry name, without its argument (`scmos-fixed` for `scmos-fixed:3`).
    pub fn name(&self) -> &'static str {
        match self {
            ModelSpec::EmccdSimple(_) => "emccd-simple",
            ModelSpec::EmccdStochastic => "emccd-stochastic",
            ModelSpec::EmccdPp(true) => "emccd-pp",
            ModelSpec::EmccdPp(false) => "emccd-pp-uncorrected",
            ModelSpec::EmccdDistribution => "emccd-distribution",
            ModelSpec::ScmosConstant(_) => "scmos-constant",
            ModelSpec::ScmosMedian => "scmos-median",
            ModelSpec::ScmosMean => "scmos-mean",
            ModelSpec::ScmosFixed(_) => "scmos-fixed",
            ModelSpec::ScmosRandom => "scmos-random",
            ModelSpec::ScmosMap => "scmos-map",
            ModelSpec::Registered(r) => r.entry.name,
        }
    }
}

pub use super::sensor::Sensor;

/// One readout model of the registry.
#[derive(Debug, Clone, Copy)]
pub struct ModelEntry {
    /// Name on the command line and in tables, e.g. `scmos-fixed`.
    pub name: &'static str,
    /// Placeholder of the optional `:ARG` after the name (e.g. `PATTERN`); None = takes none.
    pub arg: Option<&'static str>,
    /// One-line description for the `model` help.
    pub help: &'static str,
    /// The camera it simulates.
    pub sensor: Sensor,
    /// The [`ModelParams`] fields its builder reads.
    pub params: &'static [&'static str],
    /// The spec of `name[:ARG]` from this entry and the argument text (None = no `:ARG`);
    /// Err says what is wrong with the argument.
    pub parse: fn(&'static ModelEntry, Option<&str>) -> std::result::Result<ModelSpec, String>,
    /// Builds the readout of a spec this entry parsed, for `subap_px` x `subap_px` pixels.
    pub build: fn(&ModelSpec, &ModelParams, usize) -> Result<Box<dyn Readout>>,
}

impl ModelEntry {
    /// Length in bytes of [`ModelEntry::write_syntax`]'s output.
    pub const fn syntax_len(&self) -> usize {
        match self.arg {
            Some(arg) => self.name.len() + arg.len() + 3,
            None => self.name.len(),
        }
    }

    /// Writes the name with its argument syntax (`scmos-fixed[:PATTERN]`) into `out` from
    /// byte `at`; returns the end. A const fn, so that `MODEL_NAMES` is built at compile time.
    pub const fn write_syntax(&self, out: &mut [u8], at: usize) -> usize {
        let at = copy(self.name.as_bytes(), out, at);
        match self.arg {
            Some(arg) => {
                let at = copy(b"[:", out, at);
                let at = copy(arg.as_bytes(), out, at);
                copy(b"]", out, at)
            }
            None => at,
        }
    }

    /// The name with its argument syntax, e.g. `scmos-fixed[:PATTERN]`.
    pub fn syntax(&self) -> String {
        let mut out = vec![0; self.syntax_len()];
        self.write_syntax(&mut out, 0);
        String::from_utf8(out).expect("names and placeholders are UTF-8")
    }
}

/// Copies `bytes` into `out` from `at` (const); returns the end.
const fn copy(bytes: &[u8], out: &mut [u8], at: usize) -> usize {
    let mut i = 0;
    while i < bytes.len() {
        out[at + i] = bytes[i];
        i += 1;
    }
    at + bytes.len()
}
