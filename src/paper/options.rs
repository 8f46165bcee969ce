//! What a figure run takes (options) and what it gives back (one entry per figure).

use crate::spot::Sampling;

/// Options of a figure run.
#[derive(Debug, Clone)]
pub struct PaperOptions {
    /// Monte-Carlo iterations per configuration.
    pub iters: u64,
    /// Seed.
    pub seed: u64,
    /// Spot sampling.
    pub sampling: Sampling,
    /// Coarser grids for a fast smoke run (same files, fewer points).
    pub quick: bool,
}

/// One produced figure.
#[derive(Debug, Clone, serde::Serialize)]
pub struct FigureInfo {
    /// Figure number in the paper.
    pub number: u32,
    /// Title.
    pub title: String,
    /// Caption, with the settings used.
    pub caption: String,
    /// Files written (relative to the output directory).
    pub files: Vec<String>,
}
