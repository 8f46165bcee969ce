//! Charts of results that several commands draw (`report`, `paper`, `effective`, `simulate`):
//! the effective-noise heatmaps, R against a swept axis, and the simple EMCCD model's effective
//! QE factor. Drawn with [`crate::plot`]; they know the result records, no command.

pub mod heatmaps;
pub mod qe_factor;
pub mod sweep;
