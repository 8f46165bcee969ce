//! Detector readout models: photo-electrons in, an image in electrons out.
//!
//! Every model implements [`Readout`]. Users name models with [`ModelSpec`], which builds a
//! readout for one sub-aperture size. One readout per file (rand_distr's layout), each with its
//! exact test; the registry [`MODELS`] below lists every model's [`ModelEntry`] (name, argument,
//! one-line help, the [`ModelParams`] fields it reads, parser and builder), and
//! [`MODEL_NAMES`], [`models_help`] and [`ModelSpec::parse`] are generated from it.
//!
//! Adding a detector is two edits:
//! 1. a new file `src/detector/NAME.rs` with the readout type, its [`Readout`] impl, its exact
//!    test and `pub const ENTRY: ModelEntry` (with `parse: ModelSpec::registered`, its builder
//!    reading the argument from [`RegisteredModel::arg`]);
//! 2. one line `NAME: [ENTRY],` in the `readout_models!` list below (it declares the module
//!    and registers the entry).
//!
//! The other files: `readout` (the trait), `spec` (specs and entries), `params`,
//! `register` (the exact EM register), `pp` (Poisson-probability thresholds of `emccd-pp`),
//! `registry` (names, help and parsing over the table), `rts_table` (the telegraph pixels
//! `darks` measured, for `scmos-rts`), `telegraph` (those pixels as a readout draws them),
//! `sensor` (the camera kinds) and `dark_frames` (the reservoir of dark frames of
//! `scmos-frames`).

pub mod dark_frames;
mod params;
pub mod pp;
mod readout;
pub mod register;
mod registry;
pub mod rts_table;
pub(crate) mod sensor;
mod spec;
pub(crate) mod telegraph;

pub use camera_model::CameraReadout;
pub use dark_frames::DarkFrames;
pub use emccd_distribution::EmccdDistribution;
pub use emccd_pp::EmccdPp;
pub use emccd_simple::EmccdSimple;
pub use emccd_stochastic::EmccdStochastic;
pub use params::{operating_point, ModelParams};
pub use readout::{draw_normals, FrameInput, PhotonNoise, Readout};
pub use register::EmRegister;
pub use rts_table::{RtsPixel, RtsTable};
pub use scmos_constant::ScmosConstant;
pub use scmos_correlated::ScmosCorrelated;
pub use scmos_fixed::PerPixelSigma;
pub use scmos_frames::ScmosFrames;
pub use scmos_map::ScmosMap;
pub use scmos_random::ScmosRandom;
pub use scmos_rts::ScmosRts;
pub use spec::{ModelEntry, ModelSpec, RegisteredModel, Sensor};

use crate::Result;

/// Declares each readout module and lists its entries, in order, in [`MODELS`].
macro_rules! readout_models {
    ($($module:ident: [$($entry:ident),+],)+) => {
        $(pub mod $module;)+
        /// The registry: every readout model, in the order of [`MODEL_NAMES`] and the help.
        pub const MODELS: &[ModelEntry] = &[$($($module::$entry),+),+];
    };
}

readout_models! {
    emccd_simple: [ENTRY],
    emccd_stochastic: [ENTRY],
    emccd_distribution: [ENTRY],
    emccd_pp: [CORRECTED, UNCORRECTED],
    scmos_constant: [CONSTANT, MEDIAN, MEAN],
    scmos_fixed: [ENTRY],
    scmos_random: [ENTRY],
    scmos_map: [ENTRY],
    // Issue 13: the camera's real noise (telegraph pixels, row and column noise, its frames).
    scmos_rts: [ENTRY],
    scmos_correlated: [ENTRY],
    scmos_frames: [ENTRY],
    // Issue 31: a measured camera model at an operating point.
    camera_model: [ENTRY],
}

/// [`MODEL_NAMES`] as bytes, joined at compile time.
const NAMES: [u8; registry::names_len(MODELS)] = registry::names(MODELS);

/// Every model name accepted by [`ModelSpec::parse`], with its argument syntax, for help texts:
/// `emccd-simple, ..., scmos-constant[:SIGMA_E], ...`.
pub const MODEL_NAMES: &str = registry::as_str(&NAMES);

/// One line per model for the `model` option's help: its syntax, what it simulates, and the
/// [`ModelParams`] fields it reads as `` `field` ``.
pub fn models_help() -> String {
    registry::help(MODELS)
}

impl ModelSpec {
    /// Parse a model name such as `scmos-fixed:3` or `scmos-constant:1.2`.
    pub fn parse(text: &str) -> Result<Self> {
        registry::parse(MODELS, MODEL_NAMES, text)
    }

    /// The model's registry entry.
    pub fn entry(&self) -> &'static ModelEntry {
        match self {
            ModelSpec::Registered(r) => r.entry(),
            _ => registry::find(MODELS, self.name()).expect("every variant has an entry"),
        }
    }

    /// Build the readout for `subap_px` x `subap_px` sub-apertures.
    pub fn build(&self, params: &ModelParams, subap_px: usize) -> Result<Box<dyn Readout>> {
        (self.entry().build)(self, params, subap_px)
    }

    /// The camera the model simulates.
    pub fn sensor(&self) -> Sensor {
        self.entry().sensor
    }

    /// Whether it is an EMCCD model.
    pub fn is_emccd(&self) -> bool {
        self.sensor() == Sensor::Emccd
    }

    /// Whether it is an sCMOS model.
    pub fn is_scmos(&self) -> bool {
        self.sensor() == Sensor::Scmos
    }

    /// Whether its builder reads the [`ModelParams`] field `field` (e.g. `"map"`).
    pub fn uses(&self, field: &str) -> bool {
        self.entry().params.contains(&field)
    }

    /// Whether it draws from the per-pixel rms pdf (`pdf`).
    pub fn uses_pdf(&self) -> bool {
        self.uses("pdf")
    }
}

#[cfg(test)]
mod tests;
