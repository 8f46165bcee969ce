//! Maximum-likelihood fits of the distribution of per-pixel read noise (rms, e-) of a map,
//! the `pdf_fit.json` they produce, and the loader that turns that file back into a pdf.
//!
//! Layout: `fit` fits the models, `report` is the result (pdf_fit.json), `load` rebuilds a
//! fitted pdf, and `run` is the whole `fit-pdf` command as one call, with the chart.

mod fit;
mod load;
mod report;
mod run;
#[cfg(test)]
mod tests;

pub use fit::{fit_pdf, fit_pdf_of_map, PdfFitOptions, MIN_VALUES};
pub use load::load_pdf_fit;
pub use report::{ModelFit, PdfFitReport, RmsSummary, PDF_FIT_SCHEMA};
pub use run::{chart, run, FitPdfRun, FitPdfRunResult};
