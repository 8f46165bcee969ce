//! Heatmap of a value over two categorical axes with a labelled colour bar and the value printed in
//! each cell (paper Fig. 12: effective read noise over sub-aperture size x spot diameter).

use std::path::Path;

use plotters::coord::Shift;
use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};

use super::axis::{frame, Axis, FrameText};
use super::render::{de, save_chart, Chart};
use super::style::{
    colour_bar_width, contrast_ink, draw_colour_bar, scale_colour, scale_range, FAMILY,
};
use crate::error::{Error, Result};

/// A heatmap chart; fill the fields (or use [`Heatmap::new`]) and call [`Heatmap::save`].
#[derive(Clone, Debug, PartialEq)]
pub struct Heatmap {
    /// Title above the plot.
    pub title: String,
    /// x-axis label with unit, e.g. "sub-aperture size (px)".
    pub x_label: String,
    /// y-axis label with unit, e.g. "spot diameter D (px)".
    pub y_label: String,
    /// Names of the columns, left to right.
    pub x_categories: Vec<String>,
    /// Names of the rows, bottom to top.
    pub y_categories: Vec<String>,
    /// `values[row][column]`; NaN marks a missing cell (grey, printed as "–").
    pub values: Vec<Vec<f64>>,
    /// Colour-bar label with unit, e.g. "σ_eff (e⁻)".
    pub colour_label: String,
    /// Decimals of the printed values.
    pub decimals: usize,
    /// Colour scale range; the finite min and max of the values if None.
    pub range: Option<(f64, f64)>,
    /// Canvas size in pixels.
    pub size: (u32, u32),
}

impl Heatmap {
    /// A heatmap of `values[row][column]` with 2 decimals and an automatic colour range.
    pub fn new(
        title: impl Into<String>,
        x_label: impl Into<String>,
        y_label: impl Into<String>,
        x_categories: Vec<String>,
        y_categories: Vec<String>,
        values: Vec<Vec<f64>>,
        colour_label: impl Into<String>,
    ) -> Self {
        Heatmap {
            title: title.into(),
            x_label: x_label.into(),
            y_label: y_label.into(),
            x_categories,
            y_categories,
            values,
            colour_label: colour_label.into(),
            decimals: 2,
            range: None,
            size: (1000, 720),
        }
    }

    /// Writes the chart to `path` (.png or .svg), atomically.
    pub fn save(&self, path: impl AsRef<Path>) -> Result<()> {
        save_chart(self, path.as_ref())
    }

    fn check(&self) -> Result<()> {
        let (nx, ny) = (self.x_categories.len(), self.y_categories.len());
        if nx == 0 || ny == 0 {
            return Err(Error::invalid(
                "heatmap_values",
                "needs at least one row and one column",
            ));
        }
        if self.values.len() != ny || self.values.iter().any(|r| r.len() != nx) {
            return Err(Error::invalid(
                "heatmap_values",
                format!("values must be {ny} rows of {nx} columns, one per category"),
            ));
        }
        Ok(())
    }
}

/// Axis over categories 0..n with one tick per category, labelled by name.
fn category_axis(n: usize) -> Axis {
    let mut a = Axis::new(
        std::iter::empty(),
        false,
        Some((-0.5, n as f64 - 0.5)),
        0.0,
        "category",
    )
    .expect("a non-empty range");
    a.set_ticks((0..n).map(|i| i as f64).collect());
    a
}

impl Chart for Heatmap {
    fn size(&self) -> (u32, u32) {
        self.size
    }

    fn draw<'a, DB: DrawingBackend + 'a>(&self, root: &'a DrawingArea<DB, Shift>) -> Result<()> {
        self.check()?;
        root.fill(&WHITE).map_err(de)?;
        let (nx, ny) = (self.x_categories.len(), self.y_categories.len());
        let range = scale_range(self.values.iter().flatten().cloned(), self.range);
        let cb_w = colour_bar_width(range);
        let (w, _) = root.dim_in_pixel();
        let (main, bar) = root.split_horizontally(w.saturating_sub(cb_w));

        let mut xa = category_axis(nx);
        let mut ya = category_axis(ny);
        xa.set_names(self.x_categories.clone());
        ya.set_names(self.y_categories.clone());
        let text_spec = FrameText::main(&self.title, &self.x_label, &self.y_label);
        let mut chart = frame(&main, &text_spec, &xa, &ya)?;

        let (pw, ph) = chart.plotting_area().dim_in_pixel();
        let cell = ((pw as f64 / nx as f64), (ph as f64 / ny as f64));
        let longest = self
            .values
            .iter()
            .flatten()
            .map(|v| self.fmt(*v).chars().count())
            .max()
            .unwrap_or(1) as f64;
        let font_px = (cell.1 * 0.38)
            .min(cell.0 / (0.62 * longest + 0.8))
            .clamp(8.0, 22.0);

        let mut cells = Vec::with_capacity(nx * ny);
        let mut labels = Vec::with_capacity(nx * ny);
        for (j, row) in self.values.iter().enumerate() {
            for (i, &v) in row.iter().enumerate() {
                let (x, y) = (i as f64, j as f64);
                let bg = if v.is_finite() {
                    scale_colour((v - range.0) / (range.1 - range.0))
                } else {
                    RGBColor(200, 200, 200)
                };
                cells.push(Rectangle::new(
                    [(x - 0.5, y - 0.5), (x + 0.5, y + 0.5)],
                    bg.filled(),
                ));
                let style = (FAMILY, font_px)
                    .into_font()
                    .color(&contrast_ink(bg))
                    .pos(Pos::new(HPos::Center, VPos::Center));
                labels.push(Text::new(self.fmt(v), (x, y), style));
            }
        }
        chart.draw_series(cells).map_err(de)?;
        // Thin white separators make neighbouring cells of similar colour readable.
        let grid = WHITE.stroke_width(2);
        chart
            .draw_series((1..nx).map(|i| {
                PathElement::new(
                    vec![(i as f64 - 0.5, -0.5), (i as f64 - 0.5, ny as f64 - 0.5)],
                    grid,
                )
            }))
            .map_err(de)?;
        chart
            .draw_series((1..ny).map(|j| {
                PathElement::new(
                    vec![(-0.5, j as f64 - 0.5), (nx as f64 - 0.5, j as f64 - 0.5)],
                    grid,
                )
            }))
            .map_err(de)?;
        chart.draw_series(labels).map_err(de)?;

        let (_, py) = chart.plotting_area().get_pixel_range();
        let (_, h) = root.dim_in_pixel();
        draw_colour_bar(
            &bar,
            range,
            &self.colour_label,
            py.start.max(0) as u32,
            h.saturating_sub(py.end.max(0) as u32),
        )?;
        Ok(())
    }
}

impl Heatmap {
    fn fmt(&self, v: f64) -> String {
        if v.is_finite() {
            format!("{v:.*}", self.decimals)
        } else {
            "–".to_string()
        }
    }
}
