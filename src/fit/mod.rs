//! Calibration fits with argmin: the per-pixel read-noise pdf of a map (`pdf_fit`, over the
//! families of `pdf_models`) and the gain of an EMCCD from the histogram of its frames
//! (`emgain`).

pub mod emgain;
mod optim;
pub mod pdf_fit;
pub mod pdf_models;

pub use pdf_fit::{fit_pdf, load_pdf_fit, ModelFit, PdfFitOptions, PdfFitReport, RmsSummary};
pub use pdf_models::PdfModel;
