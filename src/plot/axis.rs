//! Axis ranges and ticks. Log axes are drawn as linear axes of log10(value), so every chart uses one
//! coordinate type and tick labels stay under our control.

use std::ops::Range;

use plotters::coord::ranged1d::{DefaultFormatting, KeyPointHint, Ranged};
use plotters::coord::Shift;
use plotters::prelude::*;

use super::de;
use super::style::{text, GRID, GRID_MINOR, INK};
use crate::error::{Error, Result};

/// The coordinate system of every x-y chart.
pub type Coord2d = Cartesian2d<AxisCoord, AxisCoord>;

/// A linear f64 coordinate with fixed tick (bold) and grid (light) positions.
#[derive(Clone, Debug)]
pub struct AxisCoord {
    lo: f64,
    hi: f64,
    ticks: Vec<f64>,
    minor: Vec<f64>,
}

impl AxisCoord {
    /// Range [lo, hi] with labelled `ticks` and light grid lines at `minor`.
    pub fn new(lo: f64, hi: f64, ticks: Vec<f64>, minor: Vec<f64>) -> Self {
        AxisCoord {
            lo,
            hi,
            ticks,
            minor,
        }
    }
}

impl Ranged for AxisCoord {
    type ValueType = f64;
    type FormatOption = DefaultFormatting;

    fn map(&self, v: &f64, limit: (i32, i32)) -> i32 {
        let f = (v - self.lo) / (self.hi - self.lo);
        let len = (limit.1 - limit.0) as f64;
        if !f.is_finite() {
            return if f > 0.0 { limit.1 } else { limit.0 };
        }
        // Far outside values are clamped so the backend never sees absurd pixel positions.
        limit.0 + (len * f.clamp(-10.0, 11.0) + 1e-3).floor() as i32
    }

    fn key_points<H: KeyPointHint>(&self, hint: H) -> Vec<f64> {
        if hint.weight().allow_light_points() {
            self.minor.clone()
        } else {
            self.ticks.clone()
        }
    }

    fn range(&self) -> Range<f64> {
        self.lo..self.hi
    }
}

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

/// About `target` ticks at 1, 2, 2.5 or 5 times a power of ten covering [lo, hi]; returns the ticks and the step.
pub fn nice_ticks(lo: f64, hi: f64, target: usize) -> (Vec<f64>, f64) {
    let span = hi - lo;
    if !(span.is_finite() && span > 0.0) {
        return (vec![lo], 1.0);
    }
    let raw = span / target.max(2) as f64;
    let mag = 10f64.powf(raw.log10().floor());
    let step = [1.0, 2.0, 2.5, 5.0, 10.0]
        .iter()
        .map(|m| m * mag)
        .find(|s| *s >= raw)
        .unwrap_or(10.0 * mag);
    let first = (lo / step).ceil() as i64;
    let last = (hi / step).floor() as i64;
    let ticks = (first..=last)
        .map(|i| {
            let v = i as f64 * step;
            if v.abs() < step * 1e-9 {
                0.0
            } else {
                v
            }
        })
        .collect();
    (ticks, step)
}

/// Log-axis ticks between 10^lo and 10^hi (exponents given): decades, with 2 and 5 (or all
/// multiples) added when there are too few decades; minor lines at every integer multiple.
fn log_ticks(lo: f64, hi: f64) -> (Vec<f64>, Vec<f64>) {
    let (d0, d1) = (lo.floor() as i32, hi.ceil() as i32);
    let within = |v: f64| v >= lo - 1e-9 && v <= hi + 1e-9;
    let pick = |mults: &[f64]| -> Vec<f64> {
        (d0..=d1)
            .flat_map(|d| mults.iter().map(move |m| d as f64 + m.log10()))
            .filter(|v| within(*v))
            .collect()
    };
    let all: Vec<f64> = (1..10).map(|m| m as f64).collect();
    let mut ticks = pick(&[1.0]);
    // Many decades: label every second or third only, so the labels never collide.
    if ticks.len() > 8 {
        let every = ticks.len().div_ceil(8);
        ticks.retain(|v| (v.round() as i64).rem_euclid(every as i64) == 0);
    }
    if ticks.len() < 3 {
        ticks = pick(&[1.0, 2.0, 5.0]);
    }
    if ticks.len() < 3 {
        ticks = pick(&all);
    }
    let minor = if hi - lo > 12.0 {
        Vec::new()
    } else {
        pick(&all)
    };
    (ticks, minor)
}

/// Tick label of a value on a linear axis with tick spacing `step`.
pub fn fmt_tick(v: f64, step: f64) -> String {
    if v == 0.0 {
        return "0".into();
    }
    let a = v.abs();
    if !(1e-4..1e6).contains(&a) {
        return fmt_sci(v);
    }
    let decimals = if step > 0.0 {
        (-(step.log10().floor()) as i32).max(0) as usize + usize::from(is_quarter(step))
    } else {
        3
    };
    format!("{v:.decimals$}")
}

fn is_quarter(step: f64) -> bool {
    let m = step / 10f64.powf(step.log10().floor());
    (m - 2.5).abs() < 1e-9
}

/// Label for a value on a log axis: plain numbers between 1e-3 and 1e5, powers of ten outside.
pub fn fmt_log(v: f64) -> String {
    let a = v.abs();
    if (1e-3..1e5).contains(&a) {
        let s = format!("{v:.6}");
        let s = s.trim_end_matches('0').trim_end_matches('.');
        s.to_string()
    } else {
        fmt_sci(v)
    }
}

/// `m×10ⁿ` with superscript digits (`10ⁿ` when the mantissa is 1).
fn fmt_sci(v: f64) -> String {
    let e = v.abs().log10().floor() as i32;
    let m = v / 10f64.powi(e);
    let sup: String = e
        .to_string()
        .chars()
        .map(|c| match c {
            '-' => '⁻',
            d => ['⁰', '¹', '²', '³', '⁴', '⁵', '⁶', '⁷', '⁸', '⁹'][d as usize - '0' as usize],
        })
        .collect();
    let ms = format!("{m:.2}");
    let ms = ms.trim_end_matches('0').trim_end_matches('.');
    if ms == "1" {
        format!("10{sup}")
    } else if ms == "-1" {
        format!("−10{sup}")
    } else {
        format!("{ms}×10{sup}")
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ticks_and_labels() {
        let (t, s) = nice_ticks(0.0, 1.0, 7);
        assert_eq!(s, 0.2);
        assert_eq!(t.len(), 6);
        assert_eq!(fmt_tick(0.4, 0.2), "0.4");
        assert_eq!(fmt_tick(2.5, 2.5), "2.5");
        assert_eq!(fmt_tick(1500.0, 500.0), "1500");
        assert_eq!(fmt_log(200.0), "200");
        assert_eq!(fmt_log(0.02), "0.02");
        assert_eq!(fmt_log(1e6), "10⁶");
        assert_eq!(fmt_log(2e-5), "2×10⁻⁵");
        // 20..1000: decades 100, 1000 only, so 2 and 5 are added.
        let (t, _) = log_ticks(20f64.log10(), 1000f64.log10());
        let labels: Vec<String> = t.iter().map(|v| fmt_log(10f64.powf(*v))).collect();
        assert_eq!(labels, ["20", "50", "100", "200", "500", "1000"]);
    }
}
