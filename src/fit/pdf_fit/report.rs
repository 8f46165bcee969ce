//! The result of a pdf fit, exactly the content of `pdf_fit.json`: every fitted model with
//! its parameters, errors and figures, and the model chosen; with a plain-text summary.

use std::collections::BTreeMap;

use serde::{Deserialize, Serialize};

use crate::pdf::RmsPdf;

/// Version tag of the `pdf_fit.json` layout.
pub const PDF_FIT_SCHEMA: &str = "detnoise.pdf_fit/1";

/// Summary statistics of a distribution of rms values (e-).
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
pub struct RmsSummary {
    /// Median rms (e-).
    pub median_e: f64,
    /// Mean rms (e-).
    pub mean_e: f64,
    /// sqrt(E[rms^2]) (e-).
    pub rms_e: f64,
    /// Fraction of pixels above 3x the median.
    pub frac_above_3x_median: f64,
}

impl RmsSummary {
    pub(super) fn of(pdf: &dyn RmsPdf) -> Self {
        RmsSummary {
            median_e: pdf.median(),
            mean_e: pdf.mean(),
            rms_e: pdf.rms(),
            frac_above_3x_median: pdf.frac_above_median_times(3.0),
        }
    }
}

/// One fitted model, as stored in `pdf_fit.json`.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct ModelFit {
    /// Formula of the density.
    pub formula: String,
    /// Parameters in natural units (names carry the unit), including `upper_cut_e`.
    pub params: BTreeMap<String, f64>,
    /// Standard errors of the parameters (null where the Hessian is not positive definite).
    pub param_se: BTreeMap<String, Option<f64>>,
    /// The free parameters, in the order of `correlations`.
    pub free_params: Vec<String>,
    /// Correlation matrix of the free parameters (from the inverse Hessian), if defined.
    pub correlations: Option<Vec<Vec<f64>>>,
    /// Maximised log-likelihood (per-pixel densities in 1/e-); null for `empirical`.
    pub log_likelihood: Option<f64>,
    /// Akaike information criterion 2k - 2 lnL (k counts the upper cut); null for `empirical`.
    pub aic: Option<f64>,
    /// AIC minus the best model's AIC.
    pub delta_aic: Option<f64>,
    /// Largest distance between the model's CDF and the map's empirical CDF (KS statistic).
    pub max_cdf_distance: f64,
    /// Median of the fitted pdf (e-).
    pub median_e: f64,
    /// Mean of the fitted pdf (e-).
    pub mean_e: f64,
    /// sqrt(E[rms^2]) of the fitted pdf (e-).
    pub rms_e: f64,
    /// Fraction of the fitted pdf above 3x its median.
    pub frac_above_3x_median: f64,
    /// Nelder-Mead iterations.
    pub iterations: u64,
    /// For `empirical`: the sorted values (e-), or equal-mass quantiles of a large map.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub values_e: Option<Vec<f64>>,
    /// Anything the reader should know (weak constraints, table instead of values).
    pub note: String,
}

/// The result of `fit-pdf`: exactly the content of `pdf_fit.json`.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct PdfFitReport {
    /// Layout version, [`PDF_FIT_SCHEMA`].
    pub schema: String,
    /// Values used in the fit.
    pub n_values: usize,
    /// Values excluded (non-finite, not positive, or above the upper cut).
    pub n_excluded: usize,
    /// Upper cut of the support of every parametric model (e-).
    pub upper_cut_e: f64,
    /// The map's own statistics.
    pub data: RmsSummary,
    /// The parametric model with the lowest AIC.
    pub best_model: String,
    /// How `best_model` was chosen.
    pub selection: String,
    /// Every model that was fitted, by name.
    pub models: BTreeMap<String, ModelFit>,
    /// Models whose fit failed, with the reason.
    pub failures: BTreeMap<String, String>,
}

impl PdfFitReport {
    /// A plain-text summary: the map's figures, one row per model with its parameters and
    /// notes, the failures, and the model chosen.
    pub fn summary_text(&self) -> String {
        let r = self;
        let mut s = format!(
            "{} values ({} excluded), cut {:.3} e-; map: median {:.4} e-, mean {:.4} e-, rms {:.4} e-, >3x median {:.4}\n",
            r.n_values, r.n_excluded, r.upper_cut_e, r.data.median_e, r.data.mean_e, r.data.rms_e, r.data.frac_above_3x_median
        );
        s += &format!(
            "{:<16} {:>12} {:>10} {:>8} {:>9} {:>9} {:>9} {:>8}\n",
            "model", "lnL", "dAIC", "maxCDF", "median_e", "mean_e", "rms_e", ">3xmed"
        );
        for (name, m) in &r.models {
            let f = |v: Option<f64>, p: usize| v.map_or("-".to_string(), |v| format!("{v:.p$}"));
            s += &format!(
                "{:<16} {:>12} {:>10} {:>8.4} {:>9.4} {:>9.4} {:>9.4} {:>8.4}\n",
                name,
                f(m.log_likelihood, 1),
                f(m.delta_aic, 1),
                m.max_cdf_distance,
                m.median_e,
                m.mean_e,
                m.rms_e,
                m.frac_above_3x_median
            );
            for (k, v) in &m.params {
                let se = m.param_se.get(k).copied().flatten();
                s += &format!(
                    "    {k} = {v:.6}{}\n",
                    se.map_or(String::new(), |e| format!(" +- {e:.6}"))
                );
            }
            if let Some(c) = &m.correlations {
                let max_r = c
                    .iter()
                    .enumerate()
                    .flat_map(|(i, row)| row.iter().enumerate().filter(move |(j, _)| *j != i))
                    .map(|(_, r)| r.abs())
                    .fold(0.0, f64::max);
                if c.len() > 1 {
                    s += &format!("    largest |correlation| between parameters: {max_r:.3}\n");
                }
            }
            if !m.note.is_empty() {
                s += &format!("    note: {}\n", m.note);
            }
        }
        for (k, v) in &r.failures {
            s += &format!("{k}: FAILED: {v}\n");
        }
        s += &format!("best model: {} ({})\n", r.best_model, r.selection);
        s
    }
}
