//! Log-log scatter with a fitted curve (photon transfer curve: variance or noise against signal).

use std::path::Path;

use super::line::{LegendPos, LineChart, Series, SeriesStyle};
use crate::error::Result;

/// Measured points plus a fitted curve on log-log axes; fill the fields (or use
/// [`ScatterFit::new`] and [`ScatterFit::with_fit_fn`]) and call [`ScatterFit::save`].
#[derive(Clone, Debug, PartialEq)]
pub struct ScatterFit {
    /// Title above the plot.
    pub title: String,
    /// x-axis label with unit, e.g. "mean signal (adu)".
    pub x_label: String,
    /// y-axis label with unit, e.g. "variance (adu²)".
    pub y_label: String,
    /// Measured (x, y) points.
    pub points: Vec<(f64, f64)>,
    /// Legend entry of the points.
    pub points_label: String,
    /// The fitted curve as (x, y) samples, drawn as a line.
    pub fit: Vec<(f64, f64)>,
    /// Legend entry of the fit, e.g. "fit: gain 0.46 e⁻/adu".
    pub fit_label: String,
    /// Logarithmic axes (both true by default).
    pub log_x: bool,
    /// Logarithmic y axis.
    pub log_y: bool,
    /// Canvas size in pixels.
    pub size: (u32, u32),
}

impl ScatterFit {
    /// A log-log scatter of `points` without a fit.
    pub fn new(
        title: impl Into<String>,
        x_label: impl Into<String>,
        y_label: impl Into<String>,
        points: Vec<(f64, f64)>,
        points_label: impl Into<String>,
    ) -> Self {
        ScatterFit {
            title: title.into(),
            x_label: x_label.into(),
            y_label: y_label.into(),
            points,
            points_label: points_label.into(),
            fit: Vec::new(),
            fit_label: String::new(),
            log_x: true,
            log_y: true,
            size: LineChart::SIZE,
        }
    }

    /// Adds the fitted curve `f` sampled at 200 log-spaced x over the points' positive x range.
    pub fn with_fit_fn(mut self, label: impl Into<String>, f: impl Fn(f64) -> f64) -> Self {
        let xs = self
            .points
            .iter()
            .map(|p| p.0)
            .filter(|x| x.is_finite() && *x > 0.0);
        let (lo, hi) = xs.fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), x| {
            (a.min(x), b.max(x))
        });
        if lo.is_finite() {
            let (l0, l1) = (lo.ln(), hi.ln());
            self.fit = (0..200)
                .map(|i| (l0 + (l1 - l0) * i as f64 / 199.0).exp())
                .map(|x| (x, f(x)))
                .collect();
        }
        self.fit_label = label.into();
        self
    }

    /// The equivalent line chart (markers for the points, a line for the fit).
    pub fn to_line_chart(&self) -> LineChart {
        let mut c = LineChart::new(&self.title, &self.x_label, &self.y_label);
        c.log_x = self.log_x;
        c.log_y = self.log_y;
        c.size = self.size;
        c.legend = LegendPos::Auto;
        c.series.push(
            Series::new(&self.points_label, self.points.iter().cloned())
                .styled(SeriesStyle::Markers)
                .coloured(0),
        );
        if !self.fit.is_empty() {
            c.series.push(
                Series::new(&self.fit_label, self.fit.iter().cloned())
                    .styled(SeriesStyle::Line)
                    .coloured(1),
            );
        }
        c
    }

    /// Writes the chart to `path` (.png or .svg), atomically.
    pub fn save(&self, path: impl AsRef<Path>) -> Result<()> {
        self.to_line_chart().save(path)
    }
}
