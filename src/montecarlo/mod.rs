//! The Shack-Hartmann sub-aperture Monte-Carlo of Basden (2015), section 2: one configuration
//! (`config`), the engine that runs it for several readout models (`engine`; an [`Experiment`]
//! can be continued, and keeps per-block sums for paired standard errors, `blocks`; shot noise
//! by placing a Poisson total of photons, `photons`), and the
//! sweep over a grid of configurations (`sweep`) whose rows are [`SimRecord`]s (`record`).

mod blocks;
mod config;
mod engine;
mod photons;
mod record;
mod sweep;

pub(crate) use blocks::Blocks;
pub use blocks::Term;
pub use config::{BgGrid, SimConfig};
pub use engine::{
    run, Arm, ErrorParts, Experiment, LevelStats, Moment, MomentTerm, SimResult, CHUNK,
};
pub(crate) use record::config_columns;
pub use record::SimRecord;
pub use sweep::{sweep, sweep_with, Grid};
