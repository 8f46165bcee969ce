//! The Shack-Hartmann sub-aperture Monte-Carlo of Basden (2015), section 2: one configuration
//! (`config`), the engine that runs it for several readout models (`engine`), and the sweep
//! over a grid of configurations (`sweep`) whose rows are [`SimRecord`]s (`record`).

mod config;
mod engine;
mod record;
mod sweep;

pub use config::{BgGrid, SimConfig};
pub use engine::{run, LevelStats, SimResult};
pub(crate) use record::config_columns;
pub use record::SimRecord;
pub use sweep::{sweep, Grid};
