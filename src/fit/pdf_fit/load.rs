//! A fitted pdf back from its report or its `pdf_fit.json`, ready for sampling.

use std::path::Path;
use std::sync::Arc;

use super::report::{PdfFitReport, PDF_FIT_SCHEMA};
use crate::error::{Error, Result};
use crate::fit::pdf_models::{tabulate, PdfModel};
use crate::pdf::{EmpiricalPdf, RmsPdf};

impl PdfFitReport {
    /// The fitted pdf of `model` (the best model if `None`), ready for sampling.
    pub fn pdf(&self, model: Option<&str>) -> Result<Arc<dyn RmsPdf>> {
        let name = model.unwrap_or(&self.best_model);
        let fit = self.models.get(name).ok_or_else(|| {
            Error::invalid(
                "pdf_model",
                format!(
                    "model {name:?} is not in this fit (available: {})",
                    self.models.keys().cloned().collect::<Vec<_>>().join(", ")
                ),
            )
        })?;
        let kind = PdfModel::from_name(name)
            .ok_or_else(|| Error::invalid("pdf_model", format!("unknown model {name:?}")))?;
        if kind == PdfModel::Empirical {
            let values = fit.values_e.as_deref().ok_or_else(|| {
                Error::Numeric("the empirical model was stored without its values_e".into())
            })?;
            let pdf = EmpiricalPdf::new(values, "empirical (fitted map)")
                .ok_or_else(|| Error::Numeric("the empirical model has no usable values".into()))?;
            return Ok(Arc::new(pdf));
        }
        let p =
            kind.params()
                .iter()
                .map(|(k, _)| {
                    fit.params.get(*k).copied().ok_or_else(|| {
                        Error::Numeric(format!("model {name}: parameter {k} missing"))
                    })
                })
                .collect::<Result<Vec<f64>>>()?;
        let upper = fit
            .params
            .get("upper_cut_e")
            .copied()
            .unwrap_or(self.upper_cut_e);
        let pdf = tabulate(kind, &p, upper)
            .ok_or_else(|| Error::Numeric(format!("model {name}: density is not normalisable")))?;
        Ok(Arc::new(pdf))
    }

    /// Write as pretty JSON to `path`, atomically.
    pub fn write_json(&self, path: &Path) -> Result<()> {
        crate::output::write_json(path, self)
    }
}

/// What a pdf file setting (`pdf`) expects, for errors about the file given; the settings
/// are named as fields, which the command line shows as `--pdf`, `--model`, `--map`.
const PDF_FILE_HINT: &str = "`pdf` takes the pdf_fit.json written by `detnoise fit-pdf` or `detnoise report` (or the word `paper`); a read-noise map goes to `model` scmos-map `map` FILE";

/// Load the fitted pdf `model` (the best model if `None`) from a `pdf_fit.json`.
pub fn load_pdf_fit(path: &Path, model: Option<&str>) -> Result<Arc<dyn RmsPdf>> {
    let bytes = std::fs::read(path).map_err(|e| Error::io(path, e))?;
    if let Ok(format) = crate::io::StackFormat::detect(path) {
        return Err(Error::input(
            path,
            format!(
                "a {} image, not a pdf_fit.json: {PDF_FILE_HINT}",
                format!("{format:?}").to_uppercase()
            ),
        ));
    }
    let text = String::from_utf8(bytes).map_err(|_| {
        Error::input(
            path,
            format!("not a text file, so not a pdf_fit.json: {PDF_FILE_HINT}"),
        )
    })?;
    let report: PdfFitReport = serde_json::from_str(&text)
        .map_err(|e| Error::input(path, format!("not a pdf_fit.json ({e}): {PDF_FILE_HINT}")))?;
    if report.schema != PDF_FIT_SCHEMA {
        return Err(Error::input(
            path,
            format!("schema {:?}, expected {PDF_FIT_SCHEMA:?}", report.schema),
        ));
    }
    report.pdf(model).map_err(|e| crate::io::name_file(path, e))
}
