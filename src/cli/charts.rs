//! Charts drawn by the Monte-Carlo commands.

use super::simulate::SimRecord;
use crate::Result;
use std::path::Path;

/// R against the swept axis (signal, sub-aperture or spot), one line per model.
pub fn r_against_sweep(_records: &[SimRecord], _path: &Path) -> Result<()> {
    Err(crate::Error::usage(
        "--plot",
        "charts are not available in this build yet",
    ))
}

/// One heatmap per signal level: sub-aperture size x spot, colour = sigma_eff_e.
pub fn effective_heatmaps(
    _records: &[super::effective::EffectiveRecord],
    _dir: &crate::output::OutputDir,
) -> Result<Vec<std::path::PathBuf>> {
    Ok(Vec::new())
}
