//! Synthetic frame stacks with known truth: sCMOS darks/flats (per-pixel offset, gain and
//! read noise drawn from an rms pdf) and EMCCD darks/low-light frames (exact EM register).
//!
//! Per-pixel truth is drawn from `stream(seed, pixel, PURPOSE_PIXELS)`, so stacks made
//! with one seed at several light levels share their pixels (a photon-transfer series);
//! frame noise comes from `stream(seed, frame, purpose)` with a purpose that depends on
//! the light level, so each level has independent noise. Results do not depend on the
//! thread count.
//!
//! Layout: `spec` says what to simulate, `truth` draws the pixels and frames, `defects` adds
//! RTS pixels (`rts`: their Markov chain), row and column noise and hot pixels, `write`
//! writes the stack (in a `format`), its truth maps and table, and its manifest.

mod camera;
mod defects;
mod format;
mod rts;
mod spec;
mod truth;
mod write;

pub use camera::{camera_dark_files, write_camera_darks, CameraDarks, CameraDarksSummary};
pub use defects::{add_defects, ChainStates, DefectTruth, Defects, RtsParams, RtsPixelTruth};
pub use format::SynthFormat;
pub use rts::RtsChain;
pub use spec::{
    parse_shape, rms_pdf, Camera, EmccdParams, ScmosParams, SynthSpec, MAX_FRAMES, MAX_LIGHT_E,
    MAX_PIXELS,
};
pub use truth::{draw_truth, frame, frame_with, Truth};
pub use write::{
    defect_files, output_files, output_files_for, stack_stem, write_synthetic, write_synthetic_in,
    DefectsManifest, Manifest,
};
