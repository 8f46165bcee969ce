//! Maximum-likelihood fits of the distribution of per-pixel read noise (rms, e-) of a map,
//! the `pdf_fit.json` they produce, and the loader that turns that file back into a pdf.

use super::optim::{correlations, hessian, minimise, spd_inverse, INVALID_COST};
use super::pdf_models::{density, paper_family_from_scale, tabulate, Grid, PdfModel};
use crate::error::{Error, Result};
use crate::pdf::{EmpiricalPdf, RmsPdf};
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;
use std::path::Path;
use std::sync::Arc;

/// Version tag of the `pdf_fit.json` layout.
pub const PDF_FIT_SCHEMA: &str = "detnoise.pdf_fit/1";

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
    fn of(pdf: &dyn RmsPdf) -> Self {
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
    let cut = opts.upper_cut_e.unwrap_or(f64::INFINITY);
    if cut.is_nan() || cut <= 0.0 {
        return Err(Error::invalid("--upper-cut", "must be positive (e-)"));
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
    let upper = opts
        .upper_cut_e
        .unwrap_or(*sorted.last().expect("non-empty"));
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
    let emp = EmpiricalPdf::new(&data.sorted, "map").expect("non-empty");
    let (median, q10) = (emp.median(), emp.quantile(0.1));

    let mut models = BTreeMap::new();
    let mut failures = BTreeMap::new();
    let mut scale_fit: Option<f64> = None;
    for &model in &opts.models {
        let fit = if model == PdfModel::Empirical {
            Ok(fit_empirical(&data.sorted))
        } else {
            let mut start = model.start(median, q10);
            if let (PdfModel::PaperFamily, Some(s)) = (model, scale_fit) {
                start = paper_family_from_scale(s);
            }
            fit_parametric(model, &data, upper, start)
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
    let best = models
        .iter()
        .filter_map(|(k, m)| m.aic.map(|a| (k.clone(), a)))
        .min_by(|a, b| a.1.total_cmp(&b.1));
    let (best_model, selection) = match best {
        Some((name, best_aic)) => {
            for m in models.values_mut() {
                m.delta_aic = m.aic.map(|a| a - best_aic);
            }
            (
                name,
                "lowest AIC among the parametric models (empirical has no likelihood to compare)"
                    .to_string(),
            )
        }
        None if models.contains_key("empirical") => (
            "empirical".to_string(),
            "no parametric model was fitted successfully".to_string(),
        ),
        None => {
            return Err(Error::Numeric(format!(
                "no model could be fitted: {}",
                failures
                    .iter()
                    .map(|(k, v)| format!("{k}: {v}"))
                    .collect::<Vec<_>>()
                    .join("; ")
            )))
        }
    };
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
            super::pdf_models::Transform::Logit => 0.5,
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
    let mut params = BTreeMap::new();
    let mut param_se = BTreeMap::new();
    for (i, (name, t)) in spec.iter().enumerate() {
        params.insert(name.to_string(), p[i]);
        let se = cov
            .as_ref()
            .map(|c| c[i][i].sqrt() * t.derivative(p[i]).abs());
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
    let k = spec.len() + 1;
    let log_likelihood = -m.cost * n;
    let note = match &cov {
        None => "Hessian not positive definite at the optimum: some parameters are not constrained by the data (param_se null)".to_string(),
        Some(c) if correlations(c).iter().flatten().any(|r| r.abs() > 0.95 && r.abs() < 0.999_999) => {
            "some parameters are strongly correlated (|r| > 0.95): individually they are poorly constrained".to_string()
        }
        _ => String::new(),
    };
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

impl PdfFitReport {
    /// The fitted pdf of `model` (the best model if `None`), ready for sampling.
    pub fn pdf(&self, model: Option<&str>) -> Result<Arc<dyn RmsPdf>> {
        let name = model.unwrap_or(&self.best_model);
        let fit = self.models.get(name).ok_or_else(|| {
            Error::invalid(
                "--pdf-model",
                format!(
                    "model {name:?} is not in this fit (available: {})",
                    self.models.keys().cloned().collect::<Vec<_>>().join(", ")
                ),
            )
        })?;
        let kind = PdfModel::from_name(name)
            .ok_or_else(|| Error::invalid("--pdf-model", format!("unknown model {name:?}")))?;
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

/// What `--pdf FILE` expects, for errors about the file given.
const PDF_FILE_HINT: &str = "--pdf takes the pdf_fit.json written by `detnoise fit-pdf` or `detnoise report` (or the word `paper`); a read-noise map goes to `--model scmos-map --map FILE`";

/// Load the fitted pdf `model` (the best model if `None`) from a `pdf_fit.json`.
pub fn load_pdf_fit(path: &Path, model: Option<&str>) -> Result<Arc<dyn RmsPdf>> {
    let bytes = std::fs::read(path).map_err(|e| Error::io(path, e))?;
    if let Ok(format) = crate::io::Format::detect(path) {
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

/// [`fit_pdf`] of the values of the map file `path`: a failure names the file.
pub fn fit_pdf_of_map(path: &Path, values: &[f64], opts: &PdfFitOptions) -> Result<PdfFitReport> {
    fit_pdf(values, opts).map_err(|e| crate::io::name_file(path, e))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::pdf::paper;
    use crate::rng::stream;
    use rand_distr::{Distribution, LogNormal};

    fn paper_map(side: usize, seed: u64) -> Vec<f64> {
        let p = paper();
        let mut rng = stream(seed, 0, 0);
        (0..side * side).map(|_| p.sample(&mut rng)).collect()
    }

    /// Recovery on a map drawn from the paper's pdf. The paper-scaled scale must contain 1
    /// within 3 of its standard errors (a 99.7 % interval if the Hessian SE is right).
    /// Medians and means: the fitted pdf is compared with the map it was fitted to, so the
    /// sampling error of the map cancels; 2 % is the tolerance (the SE of the map's
    /// mean itself is sd/sqrt(n) = 1.05/64 = 1.6 % at 64x64, so a model that matched the
    /// true pdf instead of the map would still pass at 2 % only narrowly, which is why
    /// the comparison is with the map).
    fn check_paper_recovery(side: usize, seed: u64) -> PdfFitReport {
        let values = paper_map(side, seed);
        let t = std::time::Instant::now();
        let r = fit_pdf(&values, &PdfFitOptions::default()).unwrap();
        eprintln!("{side}x{side}: fit in {:.2} s", t.elapsed().as_secs_f64());
        assert!(r.failures.is_empty(), "{:?}", r.failures);
        let ps = &r.models["paper-scaled"];
        let s = ps.params["scale"];
        let se = ps.param_se["scale"].unwrap();
        eprintln!(
            "{side}x{side}: scale {s:.5} +- {se:.5} ({:.2} SE from 1)",
            (s - 1.0) / se
        );
        assert!((s - 1.0).abs() < 3.0 * se, "scale {s} +- {se}");
        for (name, m) in &r.models {
            let dm = m.median_e / r.data.median_e - 1.0;
            let da = m.mean_e / r.data.mean_e - 1.0;
            eprintln!(
                "{side}x{side} {name}: lnL {:?} aic {:?} ks {:.4} median {:+.4}% mean {:+.4}% it {}",
                m.log_likelihood, m.aic, m.max_cdf_distance, 100.0 * dm, 100.0 * da, m.iterations
            );
            assert!(dm.abs() < 0.02 && da.abs() < 0.02, "{name}: {dm} {da}");
        }
        r
    }

    #[test]
    fn paper_map_64x64_is_recovered() {
        check_paper_recovery(64, 1);
    }

    #[test]
    fn paper_map_512x512_is_recovered() {
        check_paper_recovery(512, 2);
    }

    #[test]
    fn lognormal_map_prefers_lognormal_tail() {
        let ln = LogNormal::new(0.2, 0.25).unwrap();
        let mut rng = stream(3, 0, 0);
        let values: Vec<f64> = (0..64 * 64).map(|_| ln.sample(&mut rng)).collect();
        let r = fit_pdf(&values, &PdfFitOptions::default()).unwrap();
        let a_ln = r.models["lognormal+tail"].aic.unwrap();
        let a_ps = r.models["paper-scaled"].aic.unwrap();
        eprintln!(
            "lognormal map: AIC lognormal+tail {a_ln:.1}, paper-scaled {a_ps:.1}, best {}",
            r.best_model
        );
        assert!(a_ln < a_ps);
    }

    #[test]
    fn bad_maps_get_a_reason() {
        let e = fit_pdf(&[1.0; 10], &PdfFitOptions::default()).unwrap_err();
        assert!(e.to_string().contains("at least 50"), "{e}");
        let e = fit_pdf(&[1.0; 100], &PdfFitOptions::default()).unwrap_err();
        assert!(e.to_string().contains("same"), "{e}");
        let mut v = paper_map(16, 5);
        v.extend([f64::NAN, -1.0, 0.0]);
        let r = fit_pdf(
            &v,
            &PdfFitOptions {
                models: vec![PdfModel::Empirical],
                upper_cut_e: None,
            },
        )
        .unwrap();
        assert_eq!((r.n_values, r.n_excluded), (256, 3));
        assert_eq!(r.best_model, "empirical");
    }

    #[test]
    fn json_round_trip_rebuilds_the_fitted_pdf() {
        let r = fit_pdf(&paper_map(32, 6), &PdfFitOptions::default()).unwrap();
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("pdf_fit.json");
        r.write_json(&path).unwrap();
        for (name, m) in &r.models {
            let pdf = load_pdf_fit(&path, Some(name)).unwrap();
            assert!((pdf.median() - m.median_e).abs() < 1e-12, "{name}");
            assert!((pdf.mean() - m.mean_e).abs() < 1e-12, "{name}");
        }
        let best = load_pdf_fit(&path, None).unwrap();
        assert!((best.median() - r.models[&r.best_model].median_e).abs() < 1e-12);
    }
}
