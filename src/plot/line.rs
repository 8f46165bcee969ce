//! Line chart: named series of (x, y, optional standard error) with error bars, optional log axes,
//! legend and horizontal reference lines (e.g. R against signal, gain or sub-aperture size).

use std::path::Path;

use plotters::coord::Shift;
use plotters::prelude::*;

use super::axis::{frame, Axis, FrameText};
use super::render::{de, save_chart, Chart};
use super::style::{densify, draw_legend, legend_box, marker, place_legend, series_colour};
use super::ticks::Coord2d;
use crate::error::Result;

pub use super::style::LegendPos;

/// One data point; `y_se` is the standard error of y, drawn as a +-1 SE bar.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Point {
    /// Abscissa, in the x axis unit.
    pub x: f64,
    /// Ordinate, in the y axis unit.
    pub y: f64,
    /// Standard error of y (same unit), if known.
    pub y_se: Option<f64>,
}

/// How a series is drawn.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SeriesStyle {
    /// Line through the points.
    Line,
    /// Markers only (scatter).
    Markers,
    /// Line and markers.
    LineMarkers,
}

/// A named series.
#[derive(Clone, Debug, PartialEq)]
pub struct Series {
    /// Legend entry ("" for none).
    pub name: String,
    /// Points in drawing order.
    pub points: Vec<Point>,
    /// Line, markers or both.
    pub style: SeriesStyle,
    /// Palette index of colour and marker (default: the series' position), so one model keeps its
    /// colour across charts.
    pub colour: Option<usize>,
}

impl Series {
    /// A line-and-marker series of (x, y) points without error bars.
    pub fn new(name: impl Into<String>, xy: impl IntoIterator<Item = (f64, f64)>) -> Self {
        Series {
            name: name.into(),
            points: xy
                .into_iter()
                .map(|(x, y)| Point { x, y, y_se: None })
                .collect(),
            style: SeriesStyle::LineMarkers,
            colour: None,
        }
    }

    /// A line-and-marker series of (x, y, standard error of y) points.
    pub fn with_errors(
        name: impl Into<String>,
        xys: impl IntoIterator<Item = (f64, f64, f64)>,
    ) -> Self {
        Series {
            name: name.into(),
            points: xys
                .into_iter()
                .map(|(x, y, se)| Point {
                    x,
                    y,
                    y_se: Some(se),
                })
                .collect(),
            style: SeriesStyle::LineMarkers,
            colour: None,
        }
    }

    /// The same series drawn with `style`.
    pub fn styled(mut self, style: SeriesStyle) -> Self {
        self.style = style;
        self
    }

    /// The same series with palette index `i`.
    pub fn coloured(mut self, i: usize) -> Self {
        self.colour = Some(i);
        self
    }
}

/// A horizontal dashed reference line at `y` (legend entry `label`, "" for none).
#[derive(Clone, Debug, PartialEq)]
pub struct RefLine {
    /// Height, in the y axis unit.
    pub y: f64,
    /// Legend entry.
    pub label: String,
}

/// A line chart; fill the fields (or use [`LineChart::new`]) and call [`LineChart::save`].
#[derive(Clone, Debug, PartialEq)]
pub struct LineChart {
    /// Title above the plot.
    pub title: String,
    /// x-axis label with unit, e.g. "signal (photons)".
    pub x_label: String,
    /// y-axis label with unit, e.g. "R (px)".
    pub y_label: String,
    /// Logarithmic x axis (non-positive x are not drawn).
    pub log_x: bool,
    /// Logarithmic y axis (non-positive y are not drawn).
    pub log_y: bool,
    /// The data.
    pub series: Vec<Series>,
    /// Horizontal reference lines.
    pub reference: Vec<RefLine>,
    /// Fixed x range (data units); automatic if None.
    pub x_range: Option<(f64, f64)>,
    /// Fixed y range (data units); automatic if None.
    pub y_range: Option<(f64, f64)>,
    /// Legend placement.
    pub legend: LegendPos,
    /// Canvas size in pixels.
    pub size: (u32, u32),
}

impl LineChart {
    /// Default canvas size, px.
    pub const SIZE: (u32, u32) = (1000, 680);

    /// An empty chart with linear axes and an automatic legend.
    pub fn new(
        title: impl Into<String>,
        x_label: impl Into<String>,
        y_label: impl Into<String>,
    ) -> Self {
        LineChart {
            title: title.into(),
            x_label: x_label.into(),
            y_label: y_label.into(),
            log_x: false,
            log_y: false,
            series: Vec::new(),
            reference: Vec::new(),
            x_range: None,
            y_range: None,
            legend: LegendPos::Auto,
            size: Self::SIZE,
        }
    }

    /// Writes the chart to `path` (.png or .svg), atomically.
    pub fn save(&self, path: impl AsRef<Path>) -> Result<()> {
        save_chart(self, path.as_ref())
    }

    fn axes(&self) -> Result<(Axis, Axis)> {
        let pts = || self.series.iter().flat_map(|s| s.points.iter());
        let x = Axis::new(pts().map(|p| p.x), self.log_x, self.x_range, 0.04, "x")?;
        let ys = pts()
            .flat_map(|p| {
                let se = p.y_se.filter(|s| s.is_finite()).unwrap_or(0.0);
                [p.y, p.y - se, p.y + se]
            })
            .chain(self.reference.iter().map(|r| r.y));
        // On a log axis a lower error bar end <= 0 must not stretch the axis to 0: it is clamped.
        let y = Axis::new(ys, self.log_y, self.y_range, 0.06, "y")?;
        Ok((x, y))
    }
}

/// The drawable (x, y) of a point in drawing coordinates, if it can be shown.
fn xy(x: &Axis, y: &Axis, p: &Point) -> Option<(f64, f64)> {
    Some((x.t(p.x)?, y.t(p.y)?))
}

impl LineChart {
    /// Half the height (px) of a marker: an error bar no longer than this hides behind its
    /// marker.
    pub const MARKER_HALF_PX: f64 = 7.0;

    /// The error bars as drawn at this chart's size: the longest arm of any bar (from the point
    /// to either end, px) and the largest standard error (y units); None without error bars.
    /// A caption that promises error bars can say, when the longest arm is at most
    /// [`LineChart::MARKER_HALF_PX`], that they are smaller than the markers.
    pub fn error_bar_extent(&self) -> Result<Option<(f64, f64)>> {
        super::render::ensure_fonts()?;
        let largest_se = self
            .series
            .iter()
            .flat_map(|s| s.points.iter())
            .filter_map(|p| p.y_se.filter(|v| v.is_finite() && *v > 0.0))
            .fold(None, |m: Option<f64>, v| Some(m.map_or(v, |m| m.max(v))));
        let Some(largest_se) = largest_se else {
            return Ok(None);
        };
        let mut svg = String::new();
        let root = SVGBackend::with_string(&mut svg, self.size).into_drawing_area();
        let arm_px = self.draw_measured(&root)?;
        Ok(Some((arm_px, largest_se)))
    }

    /// Draw the chart; returns the longest error-bar arm drawn (px, 0 without bars).
    fn draw_measured<'a, DB: DrawingBackend + 'a>(
        &self,
        root: &'a DrawingArea<DB, Shift>,
    ) -> Result<f64> {
        root.fill(&WHITE).map_err(de)?;
        let (xa, ya) = self.axes()?;
        let text = FrameText::main(&self.title, &self.x_label, &self.y_label);
        let mut chart = frame(root, &text, &xa, &ya)?;
        let mut occupied = Vec::new();
        let mut longest_arm_px = 0.0f64;
        let frac =
            |(u, v): (f64, f64)| ((u - xa.lo) / (xa.hi - xa.lo), (v - ya.lo) / (ya.hi - ya.lo));

        for (i, s) in self.series.iter().enumerate() {
            let ci = s.colour.unwrap_or(i);
            let colour = series_colour(ci);
            let pts: Vec<(f64, f64)> = s.points.iter().filter_map(|p| xy(&xa, &ya, p)).collect();
            let fr: Vec<(f64, f64)> = pts.iter().map(|&p| frac(p)).collect();
            densify(&fr, &mut occupied);

            // (x, y, low end, high end) in drawing coordinates.
            let bars: Vec<[f64; 4]> = s
                .points
                .iter()
                .filter_map(|p| {
                    let se = p.y_se.filter(|v| v.is_finite() && *v > 0.0)?;
                    let (tx, ty) = xy(&xa, &ya, p)?;
                    Some([
                        tx,
                        ty,
                        ya.t_clamped(p.y - se).min(ty),
                        ya.t_clamped(p.y + se).max(ty),
                    ])
                })
                .collect();
            for &[x, y, lo, hi] in &bars {
                let px = |v: f64| chart.backend_coord(&(x, v)).1 as f64;
                let arm = (px(lo) - px(y)).abs().max((px(hi) - px(y)).abs());
                longest_arm_px = longest_arm_px.max(arm);
            }
            draw_error_bars(&mut chart, &bars, colour)?;

            let line = matches!(s.style, SeriesStyle::Line | SeriesStyle::LineMarkers);
            let marks = matches!(s.style, SeriesStyle::Markers | SeriesStyle::LineMarkers);
            if line && marks {
                chart
                    .draw_series(LineSeries::new(pts.clone(), colour.stroke_width(2)))
                    .map_err(de)?;
            }
            // The last drawing of the series carries the legend entry.
            let anno = if marks {
                chart
                    .draw_series(pts.iter().map(|&p| marker::<_, DB>(ci, p, colour, false)))
                    .map_err(de)?
            } else {
                chart
                    .draw_series(LineSeries::new(pts.clone(), colour.stroke_width(2)))
                    .map_err(de)?
            };
            if !s.name.is_empty() {
                // A line-only series gets a marker-less sample: an empty polygon.
                let (with_line, with_marker) = (line, marks);
                anno.label(s.name.clone()).legend(move |at| {
                    let mut m = marker::<_, DB>(ci, at, colour, with_line);
                    if !with_marker {
                        m = EmptyElement::at(at)
                            + PathElement::new(vec![(-14, 0), (14, 0)], colour.stroke_width(2))
                            + Polygon::new(vec![], colour.filled());
                    }
                    m
                });
            }
        }

        for r in &self.reference {
            let Some(ty) = ya.t(r.y) else { continue };
            let style = RGBColor(90, 90, 90).stroke_width(2);
            let anno = chart
                .draw_series(DashedLineSeries::new(
                    vec![(xa.lo, ty), (xa.hi, ty)],
                    10,
                    6,
                    style,
                ))
                .map_err(de)?;
            if !r.label.is_empty() {
                anno.label(r.label.clone()).legend(move |(px, py)| {
                    EmptyElement::at((px, py))
                        + PathElement::new(vec![(-14, 0), (-4, 0)], style)
                        + PathElement::new(vec![(4, 0), (14, 0)], style)
                });
            }
            occupied.push(frac((xa.lo, ty)));
            occupied.push(frac((xa.hi, ty)));
        }

        let names: Vec<&str> = self
            .series
            .iter()
            .map(|s| s.name.as_str())
            .chain(self.reference.iter().map(|r| r.label.as_str()))
            .filter(|n| !n.is_empty())
            .collect();
        if !names.is_empty() {
            let plot_px = chart.plotting_area().dim_in_pixel();
            let at = place_legend(self.legend, &occupied, plot_px, legend_box(&names), &[]);
            draw_legend(&mut chart, at)?;
        }
        Ok(longest_arm_px)
    }
}

impl Chart for LineChart {
    fn size(&self) -> (u32, u32) {
        self.size
    }

    fn draw<'a, DB: DrawingBackend + 'a>(&self, root: &'a DrawingArea<DB, Shift>) -> Result<()> {
        self.draw_measured(root).map(|_| ())
    }
}

/// Vertical error bars (x, y, low end, high end in drawing coordinates) with 10 px caps.
fn draw_error_bars<'a, DB: DrawingBackend + 'a>(
    chart: &mut ChartContext<'a, DB, Coord2d>,
    bars: &[[f64; 4]],
    colour: RGBColor,
) -> Result<()> {
    let style = colour.stroke_width(2);
    chart
        .draw_series(
            bars.iter()
                .map(|&[x, _, lo, hi]| PathElement::new(vec![(x, lo), (x, hi)], style)),
        )
        .map_err(de)?;
    let ends = bars.iter().flat_map(|&[x, _, lo, hi]| [(x, lo), (x, hi)]);
    chart
        .draw_series(
            ends.map(|p| EmptyElement::at(p) + PathElement::new(vec![(-5, 0), (5, 0)], style)),
        )
        .map_err(de)?;
    Ok(())
}
