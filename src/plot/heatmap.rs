//! Heatmap of a value over two categorical axes with a labelled colour bar and the value printed in
//! each cell (paper Fig. 12: effective read noise over sub-aperture size x spot diameter).
//!
//! Cells that hold no result (a status word instead of a value) are drawn grey and hatched with
//! their text, never in a colour of the scale; values above a fixed scale take its top colour and
//! a corner mark, so one scale can be shared by several charts.

use std::path::Path;

use plotters::coord::Shift;
use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};

use super::axis::{frame, Axis, FrameText};
use super::render::{de, save_chart, Chart};
use super::style::{
    colour_bar_width, contrast_ink, draw_colour_bar, scale_colour, scale_range, text, FAMILY, INK,
    TICK_PX,
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
    /// Cells that are not results: `marks[row][column]` = `Some(text)` draws the cell grey and
    /// hatched with `text` (lines split at `\n`) in grey instead of its value. Empty: no marks.
    pub marks: Vec<Vec<Option<String>>>,
    /// A line below the plot (the colour scale's rule, what the marks mean); "" for none.
    pub note: String,
    /// Colour-bar label with unit, e.g. "σ_eff (e⁻)".
    pub colour_label: String,
    /// Decimals of the printed values.
    pub decimals: usize,
    /// Colour scale range; the finite min and max of the values if None. Values above a given
    /// range take its top colour and a corner mark ([`Heatmap::CLIPPED_MARK`]).
    pub range: Option<(f64, f64)>,
    /// Canvas size in pixels.
    pub size: (u32, u32),
}

impl Heatmap {
    /// The mark in the upper right corner of a cell whose value is above the colour scale (the
    /// cell takes the scale's top colour): name it in [`Heatmap::note`].
    pub const CLIPPED_MARK: &'static str = "◥";

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
            marks: Vec::new(),
            note: String::new(),
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
        if !self.marks.is_empty()
            && (self.marks.len() != ny || self.marks.iter().any(|r| r.len() != nx))
        {
            return Err(Error::invalid(
                "heatmap_values",
                format!("marks must be empty or {ny} rows of {nx} columns, like the values"),
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

/// Grey of a cell that holds no result, its hatching, and its text.
const MARKED_BG: RGBColor = RGBColor(222, 222, 222);
const HATCH: RGBColor = RGBColor(185, 185, 185);
const MARKED_INK: RGBColor = RGBColor(85, 85, 85);
/// Hatch lines per cell diagonal.
const HATCH_LINES: usize = 7;

/// Height of the note below the plot, px.
fn note_height(note: &str) -> u32 {
    if note.is_empty() {
        0
    } else {
        (TICK_PX * 2.2) as u32
    }
}

impl Chart for Heatmap {
    fn size(&self) -> (u32, u32) {
        self.size
    }

    fn draw<'a, DB: DrawingBackend + 'a>(&self, root: &'a DrawingArea<DB, Shift>) -> Result<()> {
        self.check()?;
        root.fill(&WHITE).map_err(de)?;
        let (nx, ny) = (self.x_categories.len(), self.y_categories.len());
        let range = scale_range(self.coloured_values(), self.range);
        let (w, h) = root.dim_in_pixel();
        let (upper, footer) = root.split_vertically(h.saturating_sub(note_height(&self.note)));
        let cb_w = colour_bar_width(range);
        let (main, bar) = upper.split_horizontally(w.saturating_sub(cb_w));

        let mut xa = category_axis(nx);
        let mut ya = category_axis(ny);
        xa.set_names(self.x_categories.clone());
        ya.set_names(self.y_categories.clone());
        let text_spec = FrameText::main(&self.title, &self.x_label, &self.y_label);
        let mut chart = frame(&main, &text_spec, &xa, &ya)?;

        let (pw, ph) = chart.plotting_area().dim_in_pixel();
        let cell = ((pw as f64 / nx as f64), (ph as f64 / ny as f64));
        let fit = |longest: usize, max_px: f64| {
            (cell.1 * 0.38)
                .min(cell.0 / (0.62 * longest as f64 + 0.8))
                .clamp(8.0, max_px)
        };
        let longest_value = (0..ny)
            .flat_map(|j| (0..nx).map(move |i| (j, i)))
            .filter(|&(j, i)| self.mark(j, i).is_none())
            .map(|(j, i)| self.fmt(self.values[j][i]).chars().count())
            .max()
            .unwrap_or(1);
        let longest_mark = self
            .marks
            .iter()
            .flatten()
            .flatten()
            .flat_map(|m| m.split('\n'))
            .map(|l| l.chars().count())
            .max()
            .unwrap_or(1);
        let value_px = fit(longest_value, 22.0);
        // Marked cells share one (smaller) size, so a long status word never shrinks the values.
        let mark_px = fit(longest_mark, value_px.min(16.0));

        let mut cells = Vec::with_capacity(nx * ny);
        let mut hatches = Vec::new();
        let mut corners = Vec::new();
        let mut labels = Vec::with_capacity(nx * ny);
        for (j, row) in self.values.iter().enumerate() {
            for (i, &v) in row.iter().enumerate() {
                let (x, y) = (i as f64, j as f64);
                let (bg, ink, lines, px) = match self.mark(j, i) {
                    Some(m) => {
                        hatches.extend(hatch(x, y));
                        (MARKED_BG, MARKED_INK, m.split('\n').collect(), mark_px)
                    }
                    None if v.is_finite() => {
                        if v > range.1 && self.range.is_some() {
                            corners.push((x + 0.5, y + 0.5));
                        }
                        let bg = scale_colour((v - range.0) / (range.1 - range.0));
                        (bg, contrast_ink(bg), vec![], value_px)
                    }
                    None => (MARKED_BG, INK, vec![], value_px),
                };
                cells.push(Rectangle::new(
                    [(x - 0.5, y - 0.5), (x + 0.5, y + 0.5)],
                    bg.filled(),
                ));
                let value = self.fmt(v);
                let lines = if lines.is_empty() {
                    vec![value.as_str()]
                } else {
                    lines
                };
                let style = (FAMILY, px)
                    .into_font()
                    .color(&ink)
                    .pos(Pos::new(HPos::Center, VPos::Center));
                let step = (px * 1.2).round() as i32;
                let top = -(step * (lines.len() as i32 - 1)) / 2;
                for (k, line) in lines.iter().enumerate() {
                    labels.push(
                        EmptyElement::at((x, y))
                            + Text::new(
                                line.to_string(),
                                (0, top + k as i32 * step),
                                style.clone(),
                            ),
                    );
                }
            }
        }
        chart.draw_series(cells).map_err(de)?;
        chart
            .draw_series(hatches.into_iter().map(|l| PathElement::new(l, HATCH)))
            .map_err(de)?;
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
        // The clipped cells' corner mark: a triangle in the upper right corner, inside the
        // white separators.
        let top_ink = contrast_ink(scale_colour(1.0));
        chart
            .draw_series(corners.into_iter().map(|c| {
                EmptyElement::at(c)
                    + Polygon::new(vec![(-24, 2), (-2, 2), (-2, 24)], top_ink.filled())
            }))
            .map_err(de)?;

        let (_, py) = chart.plotting_area().get_pixel_range();
        let (_, uh) = upper.dim_in_pixel();
        draw_colour_bar(
            &bar,
            range,
            &self.colour_label,
            py.start.max(0) as u32,
            uh.saturating_sub(py.end.max(0) as u32),
        )?;
        if !self.note.is_empty() {
            let style = text(TICK_PX, false).pos(Pos::new(HPos::Center, VPos::Center));
            let (fw, fh) = footer.dim_in_pixel();
            footer
                .draw_text(&self.note, &style, (fw as i32 / 2, fh as i32 / 2))
                .map_err(de)?;
        }
        Ok(())
    }
}

/// Hatch lines of the cell centred on (x, y): parallels to its diagonal, clipped to the cell.
fn hatch(x: f64, y: f64) -> impl Iterator<Item = Vec<(f64, f64)>> {
    (1..2 * HATCH_LINES).map(move |k| {
        let t = k as f64 / HATCH_LINES as f64 - 1.0;
        let (x0, y0) = (x - 0.5, y - 0.5);
        vec![
            (x0 + t.max(0.0), y0 + (-t).max(0.0)),
            (x0 + 1.0 + t.min(0.0), y0 + 1.0 - t.max(0.0)),
        ]
    })
}

impl Heatmap {
    fn fmt(&self, v: f64) -> String {
        if v.is_finite() {
            format!("{v:.*}", self.decimals)
        } else {
            "–".to_string()
        }
    }

    /// The mark of cell (row `j`, column `i`), if it has one.
    fn mark(&self, j: usize, i: usize) -> Option<&str> {
        self.marks.get(j)?.get(i)?.as_deref()
    }

    /// The values that take a colour (unmarked cells), for the automatic range.
    fn coloured_values(&self) -> impl Iterator<Item = f64> + '_ {
        self.values.iter().enumerate().flat_map(move |(j, row)| {
            row.iter()
                .enumerate()
                .filter(move |&(i, _)| self.mark(j, i).is_none())
                .map(|(_, v)| *v)
        })
    }
}
