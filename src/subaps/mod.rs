//! The effective read noise of every sub-aperture of a real detector: each sub-aperture reads
//! through its own fixed window of the camera's measured noise map (e-), and gets the constant
//! sigma whose R (through the same centroider) equals its R, with SE and status, in one
//! configuration, every sub-aperture on the same seed (common random numbers: differences
//! between sub-apertures are the map's, not the Monte-Carlo's).
//!
//! Because every sub-aperture reads the same frames, the constant-sigma references are run
//! once for the whole map (`ladder`), and each sub-aperture runs only its own window
//! (`solve`), in groups that share each frame's spot, photons and deviates.
//!
//! The geometry (`geometry`) is a regular grid of sub-apertures (size, pitch, origin), or the
//! valid cells of a mask. Sub-apertures are solved in parallel (`run`); a run into a directory
//! (`resume`) appends each finished one durably to its shard's part file (`part`), so a rerun
//! resumes and shards (`--shard K/N`: index K-1 modulo N) can run on several machines; `merge`
//! combines the parts, and `outputs` writes the FITS images, the CSV, the chart and the summary
//! from them, identical whether the job ran as one or as shards.

mod chart;
pub mod crlb;
mod geometry;
mod ladder;
mod lock;
mod merge;
mod outputs;
mod part;
mod resume;
mod run;
mod solve;
mod static_maps;

#[cfg(test)]
mod tests;

pub use geometry::{Geometry, GridSpec, Layout, Subap, ValidMask};
pub use merge::{expand_parts, is_part_name, merge_parts, Merged};
pub use outputs::{
    status_code, write_outputs, Spread, SubapRow, SubapsSummary, NO_SUBAP_CODE, OUTPUT_NAMES,
};
pub use part::{
    map_digest, read_part, Binding, PartContent, PartHeader, PartRecord, Shard, PART_FORMAT,
};
pub use resume::{merge_into_dir, run_into_dir, DirRun, DirTarget};
pub use run::{solve_all, solve_each, Plan, SubapsJob};
pub use solve::{check_centroider, solve_subap, NoiseMap, WindowStats};
pub use static_maps::{write_maps as write_static_maps, STATIC_MAP_NAMES};
