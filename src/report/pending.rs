//! Items the report uses that still live in the command line while issue 10 moves them into
//! the library (records, dark outputs, the calibration charts, the EM histogram). Nothing else
//! in `report` names `crate::cli`: when they move, only these lines change.

/// One Monte-Carlo result row (moves to `crate::montecarlo::SimRecord`).
pub use crate::cli::simulate::SimRecord;

/// One configuration's effective read noise (moves to `crate::effective::EffectiveRecord`).
pub use crate::cli::effective::EffectiveRecord;

/// The dark calibration's outputs (maps, histogram, summary) and its summary type.
pub(crate) use crate::cli::darks::write_outputs as write_dark_outputs;

/// The chart of a fitted read-noise pdf (`pdf_fit.png`).
pub(crate) use crate::cli::fit_pdf::chart as pdf_fit_chart;

/// The photon-transfer chart (`ptc.png`).
pub(crate) use crate::cli::ptc::chart as ptc_chart;

/// The histogram of every pixel-sample of a stack, and the EM-gain fit's chart.
pub(crate) use crate::cli::emgain::{accumulate as emgain_histogram, chart as emgain_chart};
