//! `detnoise fit-pdf`: fit models of the per-pixel read-noise pdf to a measured noise map.

use std::ops::Bound::{Excluded, Unbounded};
use std::path::{Path, PathBuf};

use super::args::real;
use crate::error::{Error, Result};
use crate::fit::pdf_fit::fit_pdf_of_map;
use crate::fit::{PdfFitOptions, PdfFitReport, PdfModel};
use crate::maps::read_map;
use crate::output::{DirPlan, OutputDir};
use crate::plot::{Bins, HistNorm, Histogram, Inset, Series, SeriesStyle};

/// Unit of the map's values.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum MapUnit {
    /// Electrons rms.
    E,
    /// adu rms (needs --gain-e-per-adu).
    Adu,
}

/// Options of `detnoise fit-pdf`.
#[derive(clap::Args, Debug)]
pub struct FitPdfArgs {
    /// Per-pixel read-noise map (FITS/TIFF/EXR, first frame), e.g. rms_e.fits from `darks`.
    pub map: PathBuf,
    /// Output directory: pdf_fit.json and pdf_fit.png, written only when the fit succeeds; an
    /// existing directory is replaced only if detnoise wrote it.
    #[arg(long)]
    pub out: PathBuf,
    /// Write into an existing --out that holds other files (they are never replaced or deleted).
    #[arg(long)]
    pub force: bool,
    /// Unit of the map values. Default: e.
    #[arg(long, value_enum, default_value = "e")]
    pub unit: MapUnit,
    /// Conversion gain (e per adu) for --unit adu. Default: none.
    #[arg(long, value_parser = real(Excluded(0.0), Unbounded, "e- per adu"))]
    pub gain_e_per_adu: Option<f64>,
    /// Flag map (non-zero = hot/dead/RTS pixel, excluded). Default: flags.fits beside MAP if present.
    #[arg(long)]
    pub flags: Option<PathBuf>,
    /// Keep flagged pixels in the fit. Default: off.
    #[arg(long)]
    pub keep_flagged: bool,
    /// Models to fit, comma separated (paper-scaled, paper-family, lognormal+tail, empirical). Default: all.
    #[arg(long, value_delimiter = ',')]
    pub models: Vec<String>,
    /// Upper cut of the support (e-); larger values are excluded. Default: the map's largest value.
    #[arg(long, value_parser = real(Excluded(0.0), Unbounded, "e-"))]
    pub upper_cut_e: Option<f64>,
}

impl FitPdfArgs {
    /// Check the options together (models, unit and gain) before the map is read.
    pub fn validate(&self) -> Result<()> {
        self.models()?;
        self.scale().map(|_| ())
    }

    /// The models to fit (all by default).
    fn models(&self) -> Result<Vec<PdfModel>> {
        if self.models.is_empty() {
            return Ok(PdfModel::ALL.to_vec());
        }
        self.models
            .iter()
            .map(|m| {
                PdfModel::from_name(m.trim()).ok_or_else(|| {
                    Error::invalid(
                        "--models",
                        format!("unknown model {m:?} (paper-scaled, paper-family, lognormal+tail, empirical)"),
                    )
                })
            })
            .collect()
    }

    /// Factor from the map's unit to electrons.
    fn scale(&self) -> Result<f64> {
        match (self.unit, self.gain_e_per_adu) {
            (MapUnit::E, None) => Ok(1.0),
            (MapUnit::E, Some(_)) => Err(Error::invalid(
                "--gain-e-per-adu",
                "only applies with --unit adu (the map is already in electrons)",
            )),
            (MapUnit::Adu, Some(g)) => Ok(g),
            (MapUnit::Adu, None) => Err(Error::invalid(
                "--unit adu",
                "needs a positive --gain-e-per-adu to convert the map to electrons",
            )),
        }
    }
}

/// Run `detnoise fit-pdf`.
pub fn run(args: &FitPdfArgs) -> Result<()> {
    args.validate()?;
    let inputs: Vec<PathBuf> = [Some(args.map.clone()), flags_path(args)]
        .into_iter()
        .flatten()
        .collect();
    let dir = OutputDir::prepare(
        &args.out,
        DirPlan {
            command: "fit-pdf",
            force: args.force,
            inputs: &inputs,
            names: &["pdf_fit.json", "pdf_fit.png"],
        },
    )?;
    let values = map_values_e(args)?;
    let models = args.models()?;
    let opts = PdfFitOptions {
        models,
        upper_cut_e: args.upper_cut_e,
    };
    let report = fit_pdf_of_map(&args.map, &values, &opts)?;
    report.write_json(&dir.path("pdf_fit.json"))?;
    chart(&report, &values, &dir.path("pdf_fit.png"))?;
    dir.commit()?;
    print!("{}", table(&report));
    Ok(())
}

/// The map's values in e-, without flagged pixels (unless kept).
fn map_values_e(args: &FitPdfArgs) -> Result<Vec<f64>> {
    let scale = args.scale()?;
    let map = read_map(&args.map)?;
    let flags = match (&flags_path(args), args.keep_flagged) {
        (Some(p), false) => {
            let f = read_map(p)?;
            if (f.rows, f.cols) != (map.rows, map.cols) {
                return Err(Error::input(
                    p,
                    format!(
                        "frame 0: flag map {}x{} differs from the noise map {}x{}",
                        f.rows, f.cols, map.rows, map.cols
                    ),
                ));
            }
            Some(f.data)
        }
        _ => None,
    };
    Ok(map
        .data
        .iter()
        .enumerate()
        .filter(|(i, _)| flags.as_ref().is_none_or(|f| f[*i] == 0.0))
        .map(|(_, v)| v * scale)
        .collect())
}

/// The flag map: --flags, else flags.fits beside the map if present.
fn flags_path(args: &FitPdfArgs) -> Option<PathBuf> {
    args.flags.clone().or_else(|| {
        let p = args
            .map
            .parent()
            .unwrap_or(Path::new("."))
            .join("flags.fits");
        p.exists().then_some(p)
    })
}

/// Histogram of the map with each fitted pdf, linear with a log-scale inset (paper Fig. 1).
pub fn chart(report: &PdfFitReport, values: &[f64], path: &Path) -> Result<()> {
    let hi = report.upper_cut_e;
    // hi * (i / 600), not hi * i / 600: the product overflows for a cut near f64::MAX.
    let xs: Vec<f64> = (1..=600).map(|i| hi * (i as f64 / 600.0)).collect();
    let mut curves = vec![];
    for (i, name) in report.models.keys().enumerate() {
        if name == "empirical" {
            continue;
        }
        let pdf = report.pdf(Some(name))?;
        let d = hi * 1e-3;
        let pts = xs
            .iter()
            .map(|x| (*x, (pdf.cdf(x + d) - pdf.cdf(x - d)) / (2.0 * d)));
        let label = if *name == report.best_model {
            format!("{name} (best AIC)")
        } else {
            name.clone()
        };
        curves.push(
            Series::new(label, pts)
                .styled(SeriesStyle::Line)
                .coloured(i + 1),
        );
    }
    let mut h = Histogram::new(
        format!(
            "Per-pixel read noise: {} pixels, median {:.3} e-",
            report.n_values, report.data.median_e
        ),
        "read noise rms (e-)",
        "probability density (1/e-)",
        values
            .iter()
            .copied()
            .filter(|v| *v > 0.0 && *v <= hi)
            .collect(),
    );
    h.sample_label = "map".into();
    h.bins = Bins::Count(200);
    h.range = Some((0.0, hi));
    h.norm = HistNorm::Density;
    h.curves = curves;
    h.inset = Some(Inset {
        title: "log scale".into(),
        x_range: None,
    });
    h.save(path)
}

/// Plain-text summary of every model.
fn table(r: &PdfFitReport) -> String {
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
