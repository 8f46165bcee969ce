//! Maximum-likelihood fits of the distribution of per-pixel read noise (rms, e-) of a map:
//! every parametric model on a binned grid with Hessian errors, and the empirical model.

use std::collections::BTreeMap;
use std::path::Path;

use super::report::{ModelFit, PdfFitReport, RmsSummary, PDF_FIT_SCHEMA};
use crate::error::{Error, Result};
use crate::fit::optim::{correlations, hessian, minimise, spd_inverse, INVALID_COST};
use crate::fit::pdf_models::{
    density, paper_family_from_scale, tabulate, Grid, PdfModel, Transform,
};
use crate::pdf::{EmpiricalPdf, RmsPdf, TabulatedPdf};

/// Fewest values a map must have for a parametric fit.
pub const MIN_VALUES: usize = 50;

/// Largest number of values the empirical model stores; above it, equal-mass quantiles.
const EMPIRICAL_TABLE_MAX: usize = 65_536;

/// What to fit.
#[derive(Debug, Clone)]
pub struct PdfFitOptions {
    /// Models to fit (all by default).
    pub models: Vec<PdfModel>,
    /// Upper cut of the support (e-); values above it are excluded. Default: the largest
    /// value of the map, which is the maximum-likelihood estimate of a cut.
    pub upper_cut_e: Option<f64>,
}

impl Default for PdfFitOptions {
    fn default() -> Self {
        PdfFitOptions {
            models: PdfModel::ALL.to_vec(),
            upper_cut_e: None,
        }
    }
}

/// The map's values prepared for fitting: sorted, and binned on the model grid.
struct Data {
    sorted: Vec<f64>,
    grid: Grid,
    /// (cell index, count) of occupied cells.
    counts: Vec<(usize, f64)>,
}

impl Data {
    /// Negative log-likelihood per value of `model` at natural parameters `p`.
    fn nll(&self, model: PdfModel, p: &[f64]) -> f64 {
        let Some(norms) = self.grid.norms(model, p) else {
            return INVALID_COST;
        };
        let mut s = 0.0;
        for &(i, c) in &self.counts {
            let d = density(model, p, &norms, self.grid.mids[i]);
            if !(d > 0.0 && d.is_finite()) {
                return INVALID_COST;
            }
            s -= c * d.ln();
        }
        s / self.sorted.len() as f64
    }
}

/// Fit every requested model to the rms values `values` (e-) of a map.
pub fn fit_pdf(values: &[f64], opts: &PdfFitOptions) -> Result<PdfFitReport> {
    let (data, upper, n_excluded) = Data::prepare(values, opts.upper_cut_e)?;
    let emp = EmpiricalPdf::new(&data.sorted, "map").expect("non-empty");
    let (mut models, failures) = fit_models(&data, &opts.models, upper, &emp);
    let (best_model, selection) = select_best(&mut models, &failures)?;
    Ok(PdfFitReport {
        schema: PDF_FIT_SCHEMA.to_string(),
        n_values: data.sorted.len(),
        n_excluded,
        upper_cut_e: upper,
        data: RmsSummary::of(&emp),
        best_model,
        selection,
        models,
        failures,
    })
}

impl Data {
    /// The usable values of `values` (finite, positive, at most `upper_cut_e`) sorted and
    /// binned; with the support's upper end (the cut, or the largest value) and the count
    /// of values left out.
    fn prepare(values: &[f64], upper_cut_e: Option<f64>) -> Result<(Data, f64, usize)> {
        let cut = upper_cut_e.unwrap_or(f64::INFINITY);
        if cut.is_nan() || cut <= 0.0 {
            return Err(Error::invalid("upper_cut_e", "must be positive (e-)"));
        }
        let mut sorted: Vec<f64> = values
            .iter()
            .copied()
            .filter(|v| v.is_finite() && *v > 0.0 && *v <= cut)
            .collect();
        let n_excluded = values.len() - sorted.len();
        if sorted.len() < MIN_VALUES {
            return Err(Error::Numeric(format!(
                "only {} usable values (finite, positive, below the cut) in the map; a pdf fit needs at least {MIN_VALUES}",
                sorted.len()
            )));
        }
        sorted.sort_by(f64::total_cmp);
        let upper = upper_cut_e.unwrap_or(*sorted.last().expect("non-empty"));
        if sorted[0] == upper {
            return Err(Error::Numeric(
                "every value of the map is the same: no distribution to fit".into(),
            ));
        }
        let grid = Grid::new(upper);
        let mut binned = vec![0.0; grid.mids.len()];
        for v in &sorted {
            binned[grid.index(*v)] += 1.0;
        }
        let counts = binned
            .iter()
            .enumerate()
            .filter(|(_, c)| **c > 0.0)
            .map(|(i, c)| (i, *c))
            .collect();
        let data = Data {
            sorted,
            grid,
            counts,
        };
        Ok((data, upper, n_excluded))
    }
}

/// Fits of `requested` models by name, and the errors of those that failed. Starts come
/// from the median and 10 % quantile of `emp`; the paper family starts from the fitted
/// paper-scaled scale when that model came first.
fn fit_models(
    data: &Data,
    requested: &[PdfModel],
    upper: f64,
    emp: &EmpiricalPdf,
) -> (BTreeMap<String, ModelFit>, BTreeMap<String, String>) {
    let (median, q10) = (emp.median(), emp.quantile(0.1));
    let mut models = BTreeMap::new();
    let mut failures = BTreeMap::new();
    let mut scale_fit: Option<f64> = None;
    for &model in requested {
        let fit = if model == PdfModel::Empirical {
            Ok(fit_empirical(&data.sorted))
        } else {
            let mut start = model.start(median, q10);
            if let (PdfModel::PaperFamily, Some(s)) = (model, scale_fit) {
                start = paper_family_from_scale(s);
            }
            fit_parametric(model, data, upper, start)
        };
        match fit {
            Ok(f) => {
                if model == PdfModel::PaperScaled {
                    scale_fit = f.params.get("scale").copied();
                }
                models.insert(model.name().to_string(), f);
            }
            Err(e) => {
                failures.insert(model.name().to_string(), e.to_string());
            }
        }
    }
    (models, failures)
}

/// The best model's name and why it was chosen (the lowest AIC, each model's delta AIC set
/// from it; else the empirical model), or an error listing every failure.
fn select_best(
    models: &mut BTreeMap<String, ModelFit>,
    failures: &BTreeMap<String, String>,
) -> Result<(String, String)> {
    let best = models
        .iter()
        .filter_map(|(k, m)| m.aic.map(|a| (k.clone(), a)))
        .min_by(|a, b| a.1.total_cmp(&b.1));
    match best {
        Some((name, best_aic)) => {
            for m in models.values_mut() {
                m.delta_aic = m.aic.map(|a| a - best_aic);
            }
            Ok((
                name,
                "lowest AIC among the parametric models (empirical has no likelihood to compare)"
                    .to_string(),
            ))
        }
        None if models.contains_key("empirical") => Ok((
            "empirical".to_string(),
            "no parametric model was fitted successfully".to_string(),
        )),
        None => Err(Error::Numeric(format!(
            "no model could be fitted: {}",
            failures
                .iter()
                .map(|(k, v)| format!("{k}: {v}"))
                .collect::<Vec<_>>()
                .join("; ")
        ))),
    }
}

/// Maximum-likelihood fit of one parametric model from `start` (natural units).
fn fit_parametric(model: PdfModel, data: &Data, upper: f64, start: Vec<f64>) -> Result<ModelFit> {
    let spec = model.params();
    let n = data.sorted.len() as f64;
    let natural = |u: &[f64]| -> Vec<f64> {
        u.iter()
            .zip(spec)
            .map(|(v, (_, t))| t.to_natural(*v))
            .collect()
    };
    let cost = |u: &[f64]| data.nll(model, &natural(u));
    let u0: Vec<f64> = start
        .iter()
        .zip(spec)
        .map(|(v, (_, t))| t.to_internal(*v))
        .collect();
    let step: Vec<f64> = spec
        .iter()
        .map(|(_, t)| match t {
            Transform::Logit => 0.5,
            _ => 0.1,
        })
        .collect();
    // Stop when the simplex spans 1e-4 in total log-likelihood: far below the 0.5 that
    // marks one standard error.
    let tol = 1e-4 / n;
    let what = format!("fit of {}", model.name());
    let m = minimise(cost, &u0, &step, tol, 20_000, &what)?;
    let p = natural(&m.x);
    let pdf = tabulate(model, &p, upper)
        .ok_or_else(|| Error::Numeric(format!("{what}: fitted density is not normalisable")))?;

    // Uncertainties: inverse Hessian of the total negative log-likelihood in internal
    // coordinates, propagated to natural units by the transform's derivative.
    let h: Vec<Vec<f64>> = hessian(cost, &m.x, &vec![1e-3; m.x.len()])
        .into_iter()
        .map(|row| row.into_iter().map(|v| v * n).collect())
        .collect();
    let cov = spd_inverse(&h);
    let (params, param_se) = with_errors(spec, &p, cov.as_deref(), upper, &pdf, n);
    let k = spec.len() + 1;
    let log_likelihood = -m.cost * n;
    let note = constraint_note(cov.as_deref());
    let summary = RmsSummary::of(&pdf);
    Ok(ModelFit {
        formula: model.formula().to_string(),
        params,
        param_se,
        free_params: spec.iter().map(|(s, _)| s.to_string()).collect(),
        correlations: cov.as_deref().map(correlations),
        log_likelihood: Some(log_likelihood),
        aic: Some(2.0 * k as f64 - 2.0 * log_likelihood),
        delta_aic: None,
        max_cdf_distance: max_cdf_distance(&pdf, &data.sorted),
        median_e: summary.median_e,
        mean_e: summary.mean_e,
        rms_e: summary.rms_e,
        frac_above_3x_median: summary.frac_above_3x_median,
        iterations: m.iterations,
        values_e: None,
        note,
    })
}

/// The fitted parameters `p` by name with their standard errors (from `cov`, none where it
/// is missing), and the cut `upper` with the spacing of the top order statistic,
/// 1/(n f(U)), as its spread.
fn with_errors(
    spec: &[(&str, Transform)],
    p: &[f64],
    cov: Option<&[Vec<f64>]>,
    upper: f64,
    pdf: &TabulatedPdf,
    n: f64,
) -> (BTreeMap<String, f64>, BTreeMap<String, Option<f64>>) {
    let mut params = BTreeMap::new();
    let mut param_se = BTreeMap::new();
    for (i, (name, t)) in spec.iter().enumerate() {
        params.insert(name.to_string(), p[i]);
        let se = cov.map(|c| c[i][i].sqrt() * t.derivative(p[i]).abs());
        param_se.insert(name.to_string(), se);
    }
    // The cut is the sample maximum; its spread is the spacing of the top order
    // statistic, 1/(n f(U)).
    params.insert("upper_cut_e".into(), upper);
    let f_top = pdf.density(upper * (1.0 - 1e-9));
    param_se.insert(
        "upper_cut_e".into(),
        (f_top > 0.0).then(|| 1.0 / (n * f_top)),
    );
    (params, param_se)
}

/// A note when the data do not constrain the parameters well: the Hessian not positive
/// definite (no covariance), or strongly correlated parameters; else empty.
fn constraint_note(cov: Option<&[Vec<f64>]>) -> String {
    match cov {
        None => "Hessian not positive definite at the optimum: some parameters are not constrained by the data (param_se null)".to_string(),
        Some(c) if correlations(c).iter().flatten().any(|r| r.abs() > 0.95 && r.abs() < 0.999_999) => {
            "some parameters are strongly correlated (|r| > 0.95): individually they are poorly constrained".to_string()
        }
        _ => String::new(),
    }
}

/// The empirical model: the values themselves, or equal-mass quantiles of a large map.
fn fit_empirical(sorted: &[f64]) -> ModelFit {
    let (table, note) = if sorted.len() <= EMPIRICAL_TABLE_MAX {
        (
            sorted.to_vec(),
            "values_e holds every value of the map".to_string(),
        )
    } else {
        let emp = EmpiricalPdf::new(sorted, "map").expect("non-empty");
        let m = EMPIRICAL_TABLE_MAX;
        (
            (0..m)
                .map(|k| emp.quantile((k as f64 + 0.5) / m as f64))
                .collect(),
            format!("values_e holds {m} equal-mass quantiles of the map"),
        )
    };
    let pdf = EmpiricalPdf::new(&table, "empirical").expect("non-empty");
    let s = RmsSummary::of(&pdf);
    ModelFit {
        formula: PdfModel::Empirical.formula().to_string(),
        params: BTreeMap::new(),
        param_se: BTreeMap::new(),
        free_params: vec![],
        correlations: None,
        log_likelihood: None,
        aic: None,
        delta_aic: None,
        max_cdf_distance: max_cdf_distance(&pdf, sorted),
        median_e: s.median_e,
        mean_e: s.mean_e,
        rms_e: s.rms_e,
        frac_above_3x_median: s.frac_above_3x_median,
        iterations: 0,
        values_e: Some(table),
        note,
    }
}

/// Kolmogorov-Smirnov distance between `pdf` and the empirical CDF of `sorted`.
fn max_cdf_distance(pdf: &dyn RmsPdf, sorted: &[f64]) -> f64 {
    let n = sorted.len() as f64;
    sorted
        .iter()
        .enumerate()
        .map(|(i, x)| {
            let f = pdf.cdf(*x);
            (f - i as f64 / n).abs().max((f - (i + 1) as f64 / n).abs())
        })
        .fold(0.0, f64::max)
}

/// [`fit_pdf`] of the values of the map file `path`: a failure names the file.
pub fn fit_pdf_of_map(path: &Path, values: &[f64], opts: &PdfFitOptions) -> Result<PdfFitReport> {
    fit_pdf(values, opts).map_err(|e| crate::io::name_file(path, e))
}
