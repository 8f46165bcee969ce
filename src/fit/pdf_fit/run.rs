//! `detnoise fit-pdf` as one library call: a read-noise map in (adu or e-, flagged pixels
//! left out), the fit written as pdf_fit.json and pdf_fit.png to an output directory that
//! appears only when the fit succeeds; and the chart of a fit.

use std::path::{Path, PathBuf};

use super::fit::{fit_pdf_of_map, PdfFitOptions};
use super::report::PdfFitReport;
use crate::calib::{Map, Unit};
use crate::error::{Error, Result};
use crate::fit::pdf_models::PdfModel;
use crate::output::{DirPlan, OutputDir};
use crate::plot::{Bins, HistNorm, Histogram, Inset, Series, SeriesStyle};

/// A pdf fit of a read-noise map to run.
#[derive(Clone, Debug)]
pub struct FitPdfRun {
    /// Per-pixel read-noise map (FITS/TIFF/EXR, first frame), e.g. rms_e.fits from `darks`.
    pub map: PathBuf,
    /// Output directory: pdf_fit.json and pdf_fit.png (replaced only if detnoise wrote it).
    pub out: PathBuf,
    /// Write into an existing `out` that holds other files (never replacing them).
    pub force: bool,
    /// Unit of the map's values: electrons, or adu (with `gain_e_per_adu`).
    pub unit: Unit,
    /// Conversion gain (e- per adu) of a map in adu.
    pub gain_e_per_adu: Option<f64>,
    /// Flag map (non-zero pixels are left out); default flags.fits beside the map if present.
    pub flags: Option<PathBuf>,
    /// Keep flagged pixels in the fit.
    pub keep_flagged: bool,
    /// Models to fit (all when empty).
    pub models: Vec<PdfModel>,
    /// Upper cut of the support (e-); default the map's largest value.
    pub upper_cut_e: Option<f64>,
}

/// What a pdf-fit run produced.
#[derive(Debug)]
pub struct FitPdfRunResult {
    /// The content of pdf_fit.json.
    pub report: PdfFitReport,
    /// The output directory written.
    pub out: PathBuf,
}

impl FitPdfRun {
    /// Check the unit and the gain together before the map is read.
    pub fn validate(&self) -> Result<()> {
        match (self.unit, self.gain_e_per_adu) {
            (Unit::Electrons, None) => Ok(()),
            (Unit::Electrons, Some(_)) => Err(Error::invalid(
                "gain_e_per_adu",
                "only applies with `unit` adu (the map is already in electrons)",
            )),
            (Unit::Adu, Some(g)) if g > 0.0 && g.is_finite() => Ok(()),
            (Unit::Adu, _) => Err(Error::invalid(
                "unit",
                "adu needs a positive `gain_e_per_adu` to convert the map to electrons",
            )),
            (u, _) => Err(Error::invalid(
                "unit",
                format!(
                    "a read-noise map is in electrons or adu, not {:?}",
                    u.bunit()
                ),
            )),
        }
    }

    /// The flag map: `flags`, else flags.fits beside the map if present.
    pub fn flags_path(&self) -> Option<PathBuf> {
        self.flags.clone().or_else(|| {
            let p = self
                .map
                .parent()
                .unwrap_or(Path::new("."))
                .join("flags.fits");
            p.exists().then_some(p)
        })
    }

    /// The map's values in e-, without flagged pixels (unless kept).
    pub fn values_e(&self) -> Result<Vec<f64>> {
        self.validate()?;
        let map = Map::read_noise(&self.map, self.unit)?;
        let map = match (map.unit, self.gain_e_per_adu) {
            (Unit::Adu, Some(g)) => map.to_electrons(g),
            _ => map,
        };
        let flags = match (&self.flags_path(), self.keep_flagged) {
            (Some(p), false) => {
                let f = Map::read(p, Unit::Flags)?;
                if f.shape() != map.shape() {
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
            .map(|(_, v)| *v)
            .collect())
    }
}

/// Fit the map's pdf and write pdf_fit.json and pdf_fit.png.
pub fn run(job: &FitPdfRun) -> Result<FitPdfRunResult> {
    job.validate()?;
    let inputs: Vec<PathBuf> = [Some(job.map.clone()), job.flags_path()]
        .into_iter()
        .flatten()
        .collect();
    let dir = OutputDir::prepare(
        &job.out,
        DirPlan {
            command: "fit-pdf",
            force: job.force,
            inputs: &inputs,
            names: &["pdf_fit.json", "pdf_fit.png"],
        },
    )?;
    let values = job.values_e()?;
    let opts = PdfFitOptions {
        models: if job.models.is_empty() {
            PdfModel::ALL.to_vec()
        } else {
            job.models.clone()
        },
        upper_cut_e: job.upper_cut_e,
    };
    let report = fit_pdf_of_map(&job.map, &values, &opts)?;
    report.write_json(&dir.path("pdf_fit.json"))?;
    chart(&report, &values, &dir.path("pdf_fit.png"))?;
    Ok(FitPdfRunResult {
        report,
        out: dir.commit()?,
    })
}

/// Histogram of the map with each fitted pdf, linear with a log-scale inset (paper Fig. 1),
/// written to `path` (PNG or SVG by extension), atomically.
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
