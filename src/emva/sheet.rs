//! The datasheet as data: its numbers in sections (each a [`Quantity`] under a key that names
//! its unit) and its figures (curves with labelled axes), written as `datasheet.json`,
//! `datasheet.csv`, PNG and SVG charts and an HTML page (`page`).

use std::path::{Path, PathBuf};

use serde::Serialize;

use super::quantity::Quantity;
use crate::error::Result;
use crate::plot::{LineChart, Series, SeriesStyle};

/// One number of the datasheet.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Row {
    /// Its key, the unit in the name (`system_gain_dn_per_e`).
    pub key: String,
    /// What it is, for people (`System gain K`).
    pub label: String,
    /// Its unit as printed (`DN/e-`; empty for a ratio).
    pub unit: String,
    /// The number.
    #[serde(flatten)]
    pub quantity: Quantity,
}

impl Row {
    /// A row `key` (unit in the name) labelled `label`, in `unit`.
    pub fn new(key: &str, label: &str, unit: &str, quantity: Quantity) -> Self {
        Row {
            key: key.into(),
            label: label.into(),
            unit: unit.into(),
            quantity,
        }
    }
}

/// A titled group of numbers (e.g. "Photon transfer", "Spatial non-uniformity").
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Section {
    /// Its title.
    pub title: String,
    /// Its numbers, in page order.
    pub rows: Vec<Row>,
}

/// One curve of a figure; `y_se` (same unit as y) draws error bars.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Curve {
    /// Its legend entry.
    pub name: String,
    /// Abscissae, in the figure's x unit.
    pub x: Vec<f64>,
    /// Ordinates, in the figure's y unit.
    pub y: Vec<f64>,
    /// Standard errors of `y`, if known.
    pub y_se: Option<Vec<f64>>,
    /// Drawn as markers only (measured points) rather than a line (a fit or a model).
    pub markers: bool,
}

/// One figure of the datasheet: written as `<stem>.png` and `<stem>.svg`.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Figure {
    /// File stem (`photon_transfer`).
    pub stem: String,
    /// Title above the plot.
    pub title: String,
    /// x-axis label with its unit.
    pub x_label: String,
    /// y-axis label with its unit.
    pub y_label: String,
    /// Logarithmic x axis.
    pub log_x: bool,
    /// Logarithmic y axis.
    pub log_y: bool,
    /// Its curves.
    pub curves: Vec<Curve>,
    /// Caption under the figure on the page (plain text).
    pub caption: String,
}

/// A whole datasheet.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Sheet {
    /// Page title (`EMVA 1288 datasheet: <camera>`).
    pub title: String,
    /// Where the dataset was described (descriptor or manifest).
    pub source: PathBuf,
    /// The numbers, in sections.
    pub sections: Vec<Section>,
    /// The figures (their curves' data are in `datasheet.json`).
    pub figures: Vec<Figure>,
    /// Remarks shown under the title: rules the dataset breaks, where detnoise differs from
    /// the standard on purpose.
    pub notes: Vec<String>,
}

/// One line of `datasheet.csv`.
#[derive(Serialize)]
struct CsvRow<'a> {
    section: &'a str,
    key: &'a str,
    label: &'a str,
    unit: &'a str,
    value: Option<f64>,
    se: Option<f64>,
    status: &'static str,
    rule: Option<&'a str>,
}

/// The file names a sheet writes besides its figures.
pub const SHEET_FILES: [&str; 3] = ["datasheet.json", "datasheet.csv", "datasheet.html"];

impl Sheet {
    /// Every row, with its section's title.
    pub fn rows(&self) -> impl Iterator<Item = (&str, &Row)> {
        self.sections
            .iter()
            .flat_map(|s| s.rows.iter().map(move |r| (s.title.as_str(), r)))
    }

    /// The row of `key`, if any.
    pub fn get(&self, key: &str) -> Option<&Quantity> {
        self.rows()
            .find(|(_, r)| r.key == key)
            .map(|(_, r)| &r.quantity)
    }

    /// The CSV table: one line per number (section, key, label, unit, value, se, status, rule;
    /// an unknown value or SE is an empty field).
    pub fn csv(&self) -> Result<String> {
        let finite = |v: f64| v.is_finite().then_some(v);
        let rows: Vec<CsvRow> = self
            .rows()
            .map(|(section, r)| CsvRow {
                section,
                key: &r.key,
                label: &r.label,
                unit: &r.unit,
                value: finite(r.quantity.value),
                se: finite(r.quantity.se),
                status: r.quantity.status.label(),
                rule: r.quantity.status.rule(),
            })
            .collect();
        crate::output::render(&rows, crate::output::TableFormat::Csv)
    }

    /// The names of every file [`Sheet::write`] writes.
    pub fn file_names(&self) -> Vec<String> {
        let figures = self
            .figures
            .iter()
            .flat_map(|f| [format!("{}.png", f.stem), format!("{}.svg", f.stem)]);
        SHEET_FILES
            .iter()
            .map(|s| s.to_string())
            .chain(figures)
            .collect()
    }

    /// Write the JSON, CSV, figures and page into `dir` (each file atomically); the paths.
    pub fn write(&self, dir: &Path) -> Result<Vec<PathBuf>> {
        let mut written = Vec::new();
        let json = dir.join(SHEET_FILES[0]);
        crate::output::write_json(&json, self)?;
        written.push(json);
        let csv = dir.join(SHEET_FILES[1]);
        crate::output::write_atomic(&csv, self.csv()?.as_bytes())?;
        written.push(csv);
        for f in &self.figures {
            let chart = f.chart();
            for ext in ["png", "svg"] {
                let path = dir.join(format!("{}.{ext}", f.stem));
                chart.save(&path)?;
                written.push(path);
            }
        }
        let page = dir.join(SHEET_FILES[2]);
        crate::output::write_atomic(&page, super::page::html(self).as_bytes())?;
        written.push(page);
        Ok(written)
    }
}

impl Figure {
    /// The figure as a line chart (non-finite points left out).
    pub fn chart(&self) -> LineChart {
        let mut chart = LineChart::new(&self.title, &self.x_label, &self.y_label);
        chart.log_x = self.log_x;
        chart.log_y = self.log_y;
        for (i, c) in self.curves.iter().enumerate() {
            let usable = |x: f64, y: f64| {
                x.is_finite()
                    && y.is_finite()
                    && (!self.log_x || x > 0.0)
                    && (!self.log_y || y > 0.0)
            };
            let series = match &c.y_se {
                Some(se) => Series::with_errors(
                    &c.name,
                    c.x.iter()
                        .zip(&c.y)
                        .zip(se)
                        .filter(|((x, y), _)| usable(**x, **y))
                        .map(|((x, y), s)| (*x, *y, *s)),
                ),
                None => Series::new(
                    &c.name,
                    c.x.iter()
                        .zip(&c.y)
                        .filter(|(x, y)| usable(**x, **y))
                        .map(|(x, y)| (*x, *y)),
                ),
            };
            let style = if c.markers {
                SeriesStyle::Markers
            } else {
                SeriesStyle::Line
            };
            chart.series.push(series.styled(style).coloured(i));
        }
        chart
    }
}
