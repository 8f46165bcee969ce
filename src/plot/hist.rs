//! Histogram of samples with overlaid named curves (fitted pdfs), an optional log-y inset panel
//! (paper Fig. 1: linear main plot, log-scale inset) or a log-y main axis.

use std::path::Path;

use plotters::coord::Shift;
use plotters::prelude::*;

use super::axis::{frame, Axis, FrameText};
use super::line::{LegendPos, Series};
use super::render::{de, save_chart, Chart};
use super::style::{densify, draw_legend, legend_box, place_legend, series_colour};
use super::ticks::Coord2d;
use crate::error::{Error, Result};

/// How the samples are binned.
#[derive(Clone, Debug, PartialEq)]
pub enum Bins {
    /// Freedman-Diaconis width over the range, 10 to 200 bins.
    Auto,
    /// This many equal bins over the range.
    Count(usize),
    /// These bin edges (strictly increasing, at least two).
    Edges(Vec<f64>),
}

/// What the bar heights are.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum HistNorm {
    /// Number of samples per bin.
    Count,
    /// Probability density: count / (number of finite samples x bin width), comparable with a pdf.
    Density,
}

/// A small panel in the upper right of the plot showing the same data on a log y axis.
#[derive(Clone, Debug, PartialEq)]
pub struct Inset {
    /// Panel title, e.g. "log scale".
    pub title: String,
    /// x range of the panel (data units); the histogram's if None.
    pub x_range: Option<(f64, f64)>,
}

/// A histogram chart; fill the fields (or use [`Histogram::new`]) and call [`Histogram::save`].
#[derive(Clone, Debug, PartialEq)]
pub struct Histogram {
    /// Title above the plot.
    pub title: String,
    /// x-axis label with unit, e.g. "read noise rms (e⁻)".
    pub x_label: String,
    /// y-axis label with unit, e.g. "probability density (1/e⁻)".
    pub y_label: String,
    /// The samples (non-finite ones are ignored).
    pub samples: Vec<f64>,
    /// Legend entry of the bars ("" for none).
    pub sample_label: String,
    /// Binning.
    pub bins: Bins,
    /// Binning range (data units); the samples' min and max if None. Samples outside are not drawn.
    pub range: Option<(f64, f64)>,
    /// The quantity cannot be negative (an rms, a count): without `range`, bins and x axis
    /// start at 0 instead of at the smallest sample.
    pub from_zero: bool,
    /// Counts or density.
    pub norm: HistNorm,
    /// Logarithmic y axis for the main plot (empty bins are not drawn).
    pub log_y: bool,
    /// Curves drawn over the bars, in the same y unit (e.g. fitted pdfs for `Density`).
    pub curves: Vec<Series>,
    /// Optional log-y inset panel.
    pub inset: Option<Inset>,
    /// Legend placement (never under the inset).
    pub legend: LegendPos,
    /// Canvas size in pixels.
    pub size: (u32, u32),
}

impl Histogram {
    /// A density histogram of `samples` with automatic bins, linear axes, no curves and no inset.
    pub fn new(
        title: impl Into<String>,
        x_label: impl Into<String>,
        y_label: impl Into<String>,
        samples: Vec<f64>,
    ) -> Self {
        Histogram {
            title: title.into(),
            x_label: x_label.into(),
            y_label: y_label.into(),
            samples,
            sample_label: String::new(),
            bins: Bins::Auto,
            range: None,
            from_zero: false,
            norm: HistNorm::Density,
            log_y: false,
            curves: Vec::new(),
            inset: None,
            legend: LegendPos::Auto,
            size: (1000, 680),
        }
    }

    /// Writes the chart to `path` (.png or .svg), atomically.
    pub fn save(&self, path: impl AsRef<Path>) -> Result<()> {
        save_chart(self, path.as_ref())
    }

    /// Bin edges and bar heights (count or density).
    pub fn binned(&self) -> Result<(Vec<f64>, Vec<f64>)> {
        let finite: Vec<f64> = self
            .samples
            .iter()
            .cloned()
            .filter(|v| v.is_finite())
            .collect();
        if finite.is_empty() {
            return self.curves_only_range();
        }
        let (lo, hi) = match self.range {
            Some((a, b)) if a.is_finite() && b.is_finite() && b > a => (a, b),
            Some((a, b)) => {
                return Err(Error::invalid("hist_range", format!("[{a}, {b}] is empty")));
            }
            None => {
                let lo = finite.iter().cloned().fold(f64::INFINITY, f64::min);
                let lo = if self.from_zero { lo.min(0.0) } else { lo };
                let hi = finite.iter().cloned().fold(f64::NEG_INFINITY, f64::max);
                if hi > lo {
                    (lo, hi)
                } else {
                    (lo - 0.5, lo + 0.5)
                }
            }
        };
        let edges = match &self.bins {
            Bins::Edges(e) => {
                if e.len() < 2
                    || e.windows(2)
                        .any(|w| w[1].partial_cmp(&w[0]) != Some(std::cmp::Ordering::Greater))
                    || e.iter().any(|v| !v.is_finite())
                {
                    return Err(Error::invalid(
                        "hist_edges",
                        "edges must be finite and strictly increasing",
                    ));
                }
                e.clone()
            }
            Bins::Count(n) => uniform_edges(lo, hi, (*n).max(1)),
            Bins::Auto => uniform_edges(lo, hi, auto_bins(&finite, lo, hi)),
        };
        let n_bins = edges.len() - 1;
        let mut counts = vec![0.0; n_bins];
        for &v in &finite {
            if v < edges[0] || v > edges[n_bins] {
                continue;
            }
            // The last bin is closed on the right so the maximum sample is counted.
            let i = edges.partition_point(|&e| e <= v).clamp(1, n_bins) - 1;
            counts[i] += 1.0;
        }
        if self.norm == HistNorm::Density {
            let n = finite.len() as f64;
            for (c, w) in counts.iter_mut().zip(edges.windows(2)) {
                *c /= n * (w[1] - w[0]);
            }
        }
        Ok((edges, counts))
    }
}

impl Histogram {
    /// Without samples, the chart is just the curves (e.g. a model pdf with a log inset): one empty
    /// bin spanning the range or the curves' x extent.
    fn curves_only_range(&self) -> Result<(Vec<f64>, Vec<f64>)> {
        let xs = self
            .curves
            .iter()
            .flat_map(|c| c.points.iter())
            .map(|p| p.x);
        let (lo, hi) = match self.range {
            Some((a, b)) if a.is_finite() && b.is_finite() && b > a => (a, b),
            _ => xs
                .filter(|x| x.is_finite())
                .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), x| {
                    (a.min(x), b.max(x))
                }),
        };
        if !(lo.is_finite() && hi > lo) {
            return Err(Error::Numeric(
                "histogram: no finite samples and no curve to draw".into(),
            ));
        }
        Ok((vec![lo, hi], vec![0.0]))
    }
}

fn uniform_edges(lo: f64, hi: f64, n: usize) -> Vec<f64> {
    // Interpolated, not lo + (hi - lo) * i / n, which overflows to inf for huge ranges.
    (0..=n)
        .map(|i| {
            let t = i as f64 / n as f64;
            lo * (1.0 - t) + hi * t
        })
        .collect()
}

/// Freedman-Diaconis bin count over [lo, hi], falling back to sqrt(n) when the IQR is 0.
fn auto_bins(v: &[f64], lo: f64, hi: f64) -> usize {
    let mut s: Vec<f64> = v.iter().cloned().filter(|x| *x >= lo && *x <= hi).collect();
    s.sort_by(f64::total_cmp);
    let n = s.len().max(1);
    let q = |f: f64| s[((n - 1) as f64 * f).round() as usize];
    let iqr = if s.is_empty() { 0.0 } else { q(0.75) - q(0.25) };
    let bins = if iqr > 0.0 {
        ((hi - lo) / (2.0 * iqr / (n as f64).cbrt())).ceil()
    } else {
        (n as f64).sqrt().ceil()
    };
    (bins as usize).clamp(10, 200)
}

/// Light fill of the bars and their outline.
const BAR_FILL: RGBColor = RGBColor(166, 196, 226);
const BAR_EDGE: RGBColor = RGBColor(70, 110, 160);

impl Chart for Histogram {
    fn size(&self) -> (u32, u32) {
        self.size
    }

    fn draw<'a, DB: DrawingBackend + 'a>(&self, root: &'a DrawingArea<DB, Shift>) -> Result<()> {
        root.fill(&WHITE).map_err(de)?;
        let (edges, heights) = self.binned()?;
        let x_fixed = Some((edges[0], edges[edges.len() - 1]));
        let xa = Axis::new(std::iter::empty(), false, x_fixed, 0.0, "x")?;
        let ya = self.y_axis(&heights, self.log_y, x_fixed)?;
        let text = FrameText::main(&self.title, &self.x_label, &self.y_label);
        let mut chart = frame(root, &text, &xa, &ya)?;
        let mut occupied = Vec::new();
        draw_bars(
            &mut chart,
            &xa,
            &ya,
            &edges,
            &heights,
            &self.sample_label,
            &mut occupied,
        )?;
        draw_curves(&mut chart, &xa, &ya, &self.curves, true, &mut occupied)?;

        let names: Vec<&str> = std::iter::once(self.sample_label.as_str())
            .chain(self.curves.iter().map(|c| c.name.as_str()))
            .filter(|n| !n.is_empty())
            .collect();
        let plot_px = chart.plotting_area().dim_in_pixel();
        let (px_range, py_range) = chart.plotting_area().get_pixel_range();
        let mut blocked = Vec::new();
        if let Some(inset) = &self.inset {
            // Upper right 45 % x 48 % of the plot area, inset from its edges.
            let w = (plot_px.0 as f64 * 0.45) as u32;
            let h = (plot_px.1 as f64 * 0.48) as u32;
            let (left, top) = (plot_px.0 as i32 - w as i32 - 12, 12);
            let area = root
                .clone()
                .shrink((px_range.start + left, py_range.start + top), (w, h));
            self.draw_inset(&area, inset, &edges, &heights)?;
            blocked.push((left, top, left + w as i32, top + h as i32));
        }
        if !names.is_empty() {
            let at = place_legend(
                self.legend,
                &occupied,
                plot_px,
                legend_box(&names),
                &blocked,
            );
            draw_legend(&mut chart, at)?;
        }
        Ok(())
    }
}

impl Histogram {
    /// y axis of bars and curves: from 0 (linear) or the smallest positive height (log).
    fn y_axis(&self, heights: &[f64], log: bool, x_window: Option<(f64, f64)>) -> Result<Axis> {
        let inside = |x: f64| x_window.is_none_or(|(a, b)| x >= a && x <= b);
        let curve_y = self
            .curves
            .iter()
            .flat_map(|c| c.points.iter())
            .filter(|p| inside(p.x))
            .map(|p| p.y);
        let ys: Vec<f64> = heights
            .iter()
            .cloned()
            .chain(curve_y)
            .filter(|v| v.is_finite())
            .collect();
        if log {
            // The floor comes from the bars (a pdf's far tail would stretch the axis to 1e-20);
            // curves only raise the top.
            let floor = heights
                .iter()
                .cloned()
                .filter(|h| *h > 0.0)
                .fold(f64::INFINITY, f64::min);
            let top = ys.iter().cloned().fold(0.0, f64::max);
            if floor.is_finite() && top > floor {
                let (l0, l1) = (floor.log10(), top.log10());
                let pad = 0.05 * (l1 - l0).max(0.5);
                let range = (10f64.powf(l0 - 2.0 * pad), 10f64.powf(l1 + pad));
                return Axis::new(std::iter::empty(), true, Some(range), 0.0, "y");
            }
            // Curves only: a pdf's far tail would stretch the axis over dozens of decades, so the
            // floor is at most 6 decades below the top.
            let top = ys.iter().cloned().fold(0.0, f64::max);
            let ys = ys.into_iter().map(|y| y.max(top * 1e-6));
            Axis::new(ys, true, None, 0.05, "y")
        } else {
            let max = ys.iter().cloned().fold(0.0, f64::max);
            let top = if max > 0.0 { max * 1.08 } else { 1.0 };
            Axis::new(std::iter::empty(), false, Some((0.0, top)), 0.0, "y")
        }
    }

    fn draw_inset<DB: DrawingBackend>(
        &self,
        area: &DrawingArea<DB, Shift>,
        inset: &Inset,
        edges: &[f64],
        heights: &[f64],
    ) -> Result<()> {
        area.fill(&WHITE).map_err(de)?;
        let (w, h) = area.dim_in_pixel();
        area.draw(&Rectangle::new(
            [(0, 0), (w as i32 - 1, h as i32 - 1)],
            RGBColor(150, 150, 150),
        ))
        .map_err(de)?;
        let x_range = inset.x_range.unwrap_or((edges[0], edges[edges.len() - 1]));
        let xa = Axis::new(std::iter::empty(), false, Some(x_range), 0.0, "inset x")?;
        let in_window: Vec<f64> = edges
            .windows(2)
            .zip(heights)
            .filter(|(e, _)| e[1] > x_range.0 && e[0] < x_range.1)
            .map(|(_, h)| *h)
            .collect();
        let ya = self.y_axis(&in_window, true, Some(x_range))?;
        let text = FrameText {
            title: &inset.title,
            x_desc: "",
            y_desc: "",
            title_px: 15.0,
            desc_px: 14.0,
            tick_px: 13.0,
            margin: 8,
        };
        let mut chart = frame(area, &text, &xa, &ya)?;
        let mut sink = Vec::new();
        draw_bars(&mut chart, &xa, &ya, edges, heights, "", &mut sink)?;
        draw_curves(&mut chart, &xa, &ya, &self.curves, false, &mut sink)?;
        Ok(())
    }
}

/// Draws the bars (clipped to the x axis; empty bins skipped on a log axis) and records their
/// extent as plot-area fractions in `occupied`.
fn draw_bars<'a, DB: DrawingBackend + 'a>(
    chart: &mut ChartContext<'a, DB, Coord2d>,
    xa: &Axis,
    ya: &Axis,
    edges: &[f64],
    heights: &[f64],
    label: &str,
    occupied: &mut Vec<(f64, f64)>,
) -> Result<()> {
    let outline = heights.len() <= 80;
    // One bar per bin, None where nothing is drawn (empty, or outside the x axis).
    let bars: Vec<Option<[(f64, f64); 2]>> = edges
        .windows(2)
        .zip(heights)
        .map(|(e, &h)| {
            let (x0, x1) = (e[0].max(xa.lo), e[1].min(xa.hi));
            let top = ya.t(h)?;
            (x1 > x0 && h > 0.0).then_some([(x0, ya.lo), (x1, top.min(ya.hi))])
        })
        .collect();
    let rects: Vec<[(f64, f64); 2]> = bars.iter().flatten().copied().collect();
    for r in &rects {
        let fx = ((r[0].0 + r[1].0) / 2.0 - xa.lo) / (xa.hi - xa.lo);
        let fy = (r[1].1 - ya.lo) / (ya.hi - ya.lo);
        for k in 0..=40 {
            occupied.push((fx, fy * k as f64 / 40.0));
        }
    }
    let anno = chart
        .draw_series(rects.iter().map(|r| Rectangle::new(*r, BAR_FILL.filled())))
        .map_err(de)?;
    if !label.is_empty() {
        anno.label(label.to_string())
            .legend(|(x, y)| Rectangle::new([(x - 12, y - 6), (x + 12, y + 6)], BAR_FILL.filled()));
    }
    if outline {
        chart
            .draw_series(
                rects
                    .iter()
                    .map(|r| Rectangle::new(*r, BAR_EDGE.stroke_width(1))),
            )
            .map_err(de)?;
    } else {
        // Many thin bins: an outline per bar would be a solid block; trace the envelope instead.
        for run in outline_runs(&bars, ya.lo) {
            chart
                .draw_series(LineSeries::new(run, BAR_EDGE.stroke_width(1)))
                .map_err(de)?;
        }
    }
    Ok(())
}

/// The envelope of `bars` (per bin `[(x0, floor), (x1, top)]`, None where no bar is drawn) as
/// polylines of horizontal tops joined by vertical steps. A run starts and ends on `floor`
/// and stops at every bin without a bar, so no line crosses an empty bin.
pub(super) fn outline_runs(bars: &[Option<[(f64, f64); 2]>], floor: f64) -> Vec<Vec<(f64, f64)>> {
    let mut runs = Vec::new();
    let mut run: Vec<(f64, f64)> = Vec::new();
    let close = |run: &mut Vec<(f64, f64)>, runs: &mut Vec<Vec<(f64, f64)>>| {
        if let Some(&(x, _)) = run.last() {
            run.push((x, floor));
            runs.push(std::mem::take(run));
        }
    };
    for bar in bars {
        match bar {
            Some([(x0, _), (x1, top)]) => {
                // A gap in x (clipped bars) also ends the run: its step would be a diagonal.
                if run.last().is_some_and(|&(x, _)| x != *x0) {
                    close(&mut run, &mut runs);
                }
                if run.is_empty() {
                    run.push((*x0, floor));
                }
                run.extend([(*x0, *top), (*x1, *top)]);
            }
            None => close(&mut run, &mut runs),
        }
    }
    close(&mut run, &mut runs);
    runs
}

/// Draws named curves as lines; with `label`, they get legend entries.
fn draw_curves<'a, DB: DrawingBackend + 'a>(
    chart: &mut ChartContext<'a, DB, Coord2d>,
    xa: &Axis,
    ya: &Axis,
    curves: &[Series],
    label: bool,
    occupied: &mut Vec<(f64, f64)>,
) -> Result<()> {
    for (i, c) in curves.iter().enumerate() {
        // Colour 0 is close to the bars' blue: curves start at the second palette colour.
        let colour = series_colour(c.colour.unwrap_or(i + 1));
        // Runs of points inside the plot; a point outside (e.g. below a log floor) breaks the line.
        let mut runs: Vec<Vec<(f64, f64)>> = vec![Vec::new()];
        for p in &c.points {
            let v = (p.x >= xa.lo && p.x <= xa.hi)
                .then(|| Some((xa.t(p.x)?, ya.t(p.y)?)))
                .flatten()
                .filter(|q| q.1 >= ya.lo && q.1 <= ya.hi);
            match v {
                Some(q) => runs.last_mut().expect("non-empty").push(q),
                None if !runs.last().expect("non-empty").is_empty() => runs.push(Vec::new()),
                None => {}
            }
        }
        for run in &runs {
            let fr: Vec<(f64, f64)> = run
                .iter()
                .map(|(x, y)| ((x - xa.lo) / (xa.hi - xa.lo), (y - ya.lo) / (ya.hi - ya.lo)))
                .collect();
            densify(&fr, occupied);
        }
        let mut anno = None;
        for run in runs.into_iter().filter(|r| !r.is_empty()) {
            anno = Some(
                chart
                    .draw_series(LineSeries::new(run, colour.stroke_width(3)))
                    .map_err(de)?,
            );
        }
        if let (Some(anno), true) = (anno, label && !c.name.is_empty()) {
            anno.label(c.name.clone()).legend(move |(x, y)| {
                PathElement::new(vec![(x - 14, y), (x + 14, y)], colour.stroke_width(3))
            });
        }
    }
    Ok(())
}
