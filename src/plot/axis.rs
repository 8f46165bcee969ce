//! Axis ranges and the chart frame: title, axes, tick labels and grid. Log axes are drawn as
//! linear axes of log10(value), so every chart uses one coordinate type and tick labels stay
//! under our control.

use plotters::coord::Shift;
use plotters::prelude::*;

use super::render::de;
use super::style::{text, GRID, GRID_MINOR, INK};
use super::ticks::{fmt_log, fmt_tick, log_ticks, nice_ticks, AxisCoord, Coord2d};
use crate::error::{Error, Result};

/// Texts and font sizes (px) of a chart frame.
pub struct FrameText<'s> {
    /// Title above the plot ("" for none).
    pub title: &'s str,
    /// x-axis description with unit.
    pub x_desc: &'s str,
    /// y-axis description with unit.
    pub y_desc: &'s str,
    /// Title size.
    pub title_px: f64,
    /// Axis description size.
    pub desc_px: f64,
    /// Tick label size.
    pub tick_px: f64,
    /// Outer margin.
    pub margin: u32,
}

impl<'s> FrameText<'s> {
    /// Full-size chart texts.
    pub fn main(title: &'s str, x_desc: &'s str, y_desc: &'s str) -> Self {
        use super::style::{DESC_PX, TICK_PX, TITLE_PX};
        FrameText {
            title,
            x_desc,
            y_desc,
            title_px: TITLE_PX,
            desc_px: DESC_PX,
            tick_px: TICK_PX,
            margin: 18,
        }
    }
}

/// Bold font size (at most `px`, at least 11) at which `s` fits in `width` pixels less a margin.
pub fn fitted_px(s: &str, px: f64, width: u32) -> f64 {
    let avail = width.saturating_sub(40) as f64;
    let w = super::style::text_width_styled(s, px, true) as f64;
    if w > avail && w > 0.0 {
        (px * avail / w).max(11.0)
    } else {
        px
    }
}

/// Draws the title, axes, ticks, labels and grid on `area`; returns the chart for the data.
pub fn frame<'a, DB: DrawingBackend>(
    area: &'a DrawingArea<DB, Shift>,
    t: &FrameText,
    x: &Axis,
    y: &Axis,
) -> Result<ChartContext<'a, DB, Coord2d>> {
    let desc_w = |s: &str, px: f64| if s.is_empty() { 0 } else { (px * 1.4) as u32 };
    let y_area = y.max_label_width(t.tick_px) + 14 + desc_w(t.y_desc, t.desc_px);
    let x_area = (t.tick_px * 1.3) as u32 + 10 + desc_w(t.x_desc, t.desc_px);
    let mut b = ChartBuilder::on(area);
    b.margin(t.margin)
        .margin_right(t.margin + 12)
        .x_label_area_size(x_area)
        .y_label_area_size(y_area);
    if !t.title.is_empty() {
        b.caption(
            t.title,
            text(fitted_px(t.title, t.title_px, area.dim_in_pixel().0), true),
        );
    }
    let mut chart = b.build_cartesian_2d(x.coord(), y.coord()).map_err(de)?;
    chart
        .configure_mesh()
        .x_label_formatter(&|v| x.label(*v))
        .y_label_formatter(&|v| y.label(*v))
        .x_label_style(text(t.tick_px, false))
        .y_label_style(text(t.tick_px, false))
        .axis_desc_style(text(t.desc_px, false))
        .x_desc(t.x_desc)
        .y_desc(t.y_desc)
        .bold_line_style(GRID)
        .light_line_style(GRID_MINOR)
        .axis_style(INK)
        .set_all_tick_mark_size(5)
        .draw()
        .map_err(de)?;
    Ok(chart)
}

/// One chart axis: range and ticks in drawing units (log10 of the value on a log axis).
#[derive(Clone, Debug)]
pub struct Axis {
    /// Logarithmic axis.
    pub log: bool,
    /// Lower end, drawing units.
    pub lo: f64,
    /// Upper end, drawing units.
    pub hi: f64,
    ticks: Vec<f64>,
    minor: Vec<f64>,
    step: f64,
    names: Option<Vec<String>>,
}

impl Axis {
    /// An axis covering the finite `values` (positive ones only on a log axis), padded by `pad`
    /// of the span at each end, or exactly `fixed` if given. `what` names the axis in errors.
    pub fn new(
        values: impl Iterator<Item = f64>,
        log: bool,
        fixed: Option<(f64, f64)>,
        pad: f64,
        what: &str,
    ) -> Result<Self> {
        let (lo, hi) = match fixed {
            Some((a, b)) => {
                if !(a.is_finite() && b.is_finite() && b > a && (!log || a > 0.0)) {
                    return Err(Error::invalid(
                        "axis_range",
                        format!("{what} range [{a}, {b}] is empty or not positive on a log axis"),
                    ));
                }
                (to_axis(a, log), to_axis(b, log))
            }
            None => {
                let (a, b) = values
                    .filter(|v| v.is_finite() && (!log || *v > 0.0))
                    .map(|v| to_axis(v, log))
                    .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), v| {
                        (a.min(v), b.max(v))
                    });
                if !a.is_finite() {
                    return Err(Error::Numeric(format!(
                        "chart: no finite {what} values to draw"
                    )));
                }
                let span = if b > a {
                    b - a
                } else if log {
                    1.0
                } else {
                    a.abs().max(1.0)
                };
                let (a, b) = if b > a {
                    (a, b)
                } else {
                    (a - 0.5 * span, a + 0.5 * span)
                };
                (a - pad * span, b + pad * span)
            }
        };
        let (ticks, minor, step) = if log {
            let (t, m) = log_ticks(lo, hi);
            (t, m, 0.0)
        } else {
            let (t, step) = nice_ticks(lo, hi, 7);
            (t, Vec::new(), step)
        };
        Ok(Axis {
            log,
            lo,
            hi,
            ticks,
            minor,
            step,
            names: None,
        })
    }

    /// Drawing coordinate of a data value (None if it cannot be shown, e.g. <= 0 on a log axis).
    pub fn t(&self, v: f64) -> Option<f64> {
        if !v.is_finite() || (self.log && v <= 0.0) {
            None
        } else {
            Some(to_axis(v, self.log))
        }
    }

    /// Drawing coordinate clamped into the axis range (for bar bottoms and error-bar ends).
    pub fn t_clamped(&self, v: f64) -> f64 {
        self.t(v).unwrap_or(self.lo).clamp(self.lo, self.hi)
    }

    /// Replaces the ticks (drawing coordinates); no minor grid lines.
    pub fn set_ticks(&mut self, ticks: Vec<f64>) {
        self.ticks = ticks;
        self.minor.clear();
    }

    /// Labels ticks at 0, 1, 2, ... with these names (a categorical axis).
    pub fn set_names(&mut self, names: Vec<String>) {
        self.names = Some(names);
    }

    /// Tick label for drawing coordinate `tv`.
    pub fn label(&self, tv: f64) -> String {
        if let Some(names) = &self.names {
            let i = tv.round();
            return if i >= 0.0 && (i as usize) < names.len() {
                names[i as usize].clone()
            } else {
                String::new()
            };
        }
        if self.log {
            fmt_log(10f64.powf(tv))
        } else {
            fmt_tick(tv, self.step)
        }
    }

    /// The plotters coordinate with our ticks (bold) and minor grid lines (light).
    pub fn coord(&self) -> AxisCoord {
        AxisCoord::new(self.lo, self.hi, self.ticks.clone(), self.minor.clone())
    }

    /// Widest tick label at `px`, in pixels.
    pub fn max_label_width(&self, px: f64) -> u32 {
        self.ticks
            .iter()
            .map(|&t| super::style::text_width(&self.label(t), px))
            .max()
            .unwrap_or(0)
    }
}

fn to_axis(v: f64, log: bool) -> f64 {
    if log {
        v.log10()
    } else {
        v
    }
}
