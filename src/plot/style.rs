//! Shared look of all charts: fonts, colours, markers, the colour scale and its bar.

use plotters::coord::Shift;
use plotters::element::ComposedElement;
use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};
use plotters::style::{FontStyle, FontTransform, TextStyle};

use super::render::de;
use super::ticks::{fmt_tick, nice_ticks, AxisCoord, Coord2d};
use crate::error::Result;

/// Sans-serif font family registered by `ensure_fonts`.
pub const FAMILY: &str = "sans-serif";
/// Title size, px.
pub const TITLE_PX: f64 = 26.0;
/// Axis description size, px.
pub const DESC_PX: f64 = 20.0;
/// Tick label size, px.
pub const TICK_PX: f64 = 16.0;
/// Legend text size, px.
pub const LEGEND_PX: f64 = 16.0;
/// Light grid lines.
pub const GRID: RGBColor = RGBColor(225, 225, 225);
/// Minor grid lines.
pub const GRID_MINOR: RGBColor = RGBColor(242, 242, 242);
/// Axis lines and text.
pub const INK: RGBColor = RGBColor(30, 30, 30);

/// Text style of the given size and weight.
pub fn text(px: f64, bold: bool) -> TextStyle<'static> {
    let style = if bold {
        FontStyle::Bold
    } else {
        FontStyle::Normal
    };
    (FAMILY, px, style).into_font().color(&INK)
}

/// Width of `s` in pixels at `px`, from the font's advance widths.
pub fn text_width(s: &str, px: f64) -> u32 {
    text_width_styled(s, px, false)
}

/// Width of `s` in pixels at `px` in the regular or bold face.
pub fn text_width_styled(s: &str, px: f64, bold: bool) -> u32 {
    let style = if bold {
        FontStyle::Bold
    } else {
        FontStyle::Normal
    };
    (FAMILY, px, style)
        .into_font()
        .box_size(s)
        .map(|b| b.0)
        .unwrap_or((s.chars().count() as f64 * px * 0.6) as u32)
}

/// Colour-blind-safe qualitative palette (Okabe & Ito), black last.
const PALETTE: [RGBColor; 8] = [
    RGBColor(0, 114, 178),
    RGBColor(213, 94, 0),
    RGBColor(0, 158, 115),
    RGBColor(230, 159, 0),
    RGBColor(204, 121, 167),
    RGBColor(86, 180, 233),
    RGBColor(0, 0, 0),
    RGBColor(140, 140, 140),
];

/// Colour of series `i`.
pub fn series_colour(i: usize) -> RGBColor {
    PALETTE[i % PALETTE.len()]
}

/// Number of distinct marker shapes.
const MARKERS: usize = 6;

/// A marker: optional legend line plus a filled polygon, anchored at a data or pixel coordinate.
pub type Marker<C, DB> = ComposedElement<C, DB, PathElement<(i32, i32)>, Polygon<(i32, i32)>>;

/// Vertices (pixel offsets) of marker shape `kind`: circle, square, triangle, diamond,
/// inverted triangle, cross.
fn marker_outline(kind: usize) -> Vec<(i32, i32)> {
    let round = |v: &[(f64, f64)]| {
        v.iter()
            .map(|&(x, y)| (x.round() as i32, y.round() as i32))
            .collect()
    };
    match kind % MARKERS {
        0 => round(
            &(0..16)
                .map(|i| {
                    let a = i as f64 * std::f64::consts::PI / 8.0;
                    (5.5 * a.cos(), 5.5 * a.sin())
                })
                .collect::<Vec<_>>(),
        ),
        1 => vec![(-5, -5), (5, -5), (5, 5), (-5, 5)],
        2 => vec![(0, -7), (6, 4), (-6, 4)],
        3 => vec![(0, -7), (6, 0), (0, 7), (-6, 0)],
        4 => vec![(0, 7), (6, -4), (-6, -4)],
        _ => {
            let (w, l) = (1.6, 6.5);
            let plus = [
                (w, w),
                (w, l),
                (-w, l),
                (-w, w),
                (-l, w),
                (-l, -w),
                (-w, -w),
                (-w, -l),
                (w, -l),
                (w, -w),
                (l, -w),
                (l, w),
            ];
            let c = std::f64::consts::FRAC_1_SQRT_2;
            round(
                &plus
                    .iter()
                    .map(|&(x, y)| (c * (x - y), c * (x + y)))
                    .collect::<Vec<_>>(),
            )
        }
    }
}

/// Marker shape `kind` (cycled) centred on `at` in `colour`; with `legend_line`, a short
/// horizontal line through it (the legend sample of a line-and-marker series).
pub fn marker<C, DB: DrawingBackend>(
    kind: usize,
    at: C,
    colour: RGBColor,
    legend_line: bool,
) -> Marker<C, DB> {
    let sample = if legend_line {
        vec![(-14, 0), (14, 0)]
    } else {
        vec![]
    };
    EmptyElement::at(at)
        + PathElement::new(sample, colour.stroke_width(2))
        + Polygon::new(marker_outline(kind), colour.filled())
}

/// Colour for a value at fraction `f` (0..1) of the colour scale (viridis).
pub fn scale_colour(f: f64) -> RGBColor {
    let f = if f.is_finite() {
        f.clamp(0.0, 1.0)
    } else {
        0.0
    };
    ViridisRGB::get_color(f)
}

/// Black or white, whichever reads better on `bg`.
pub fn contrast_ink(bg: RGBColor) -> RGBColor {
    let lum = 0.2126 * bg.0 as f64 + 0.7152 * bg.1 as f64 + 0.0722 * bg.2 as f64;
    if lum > 140.0 {
        RGBColor(0, 0, 0)
    } else {
        RGBColor(255, 255, 255)
    }
}

/// Value range of the colour scale: the given one, or the finite min and max of `values`.
pub fn scale_range(values: impl Iterator<Item = f64>, given: Option<(f64, f64)>) -> (f64, f64) {
    if let Some((lo, hi)) = given {
        if lo.is_finite() && hi.is_finite() && hi > lo {
            return (lo, hi);
        }
    }
    let (lo, hi) = values
        .filter(|v| v.is_finite())
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), v| {
            (a.min(v), b.max(v))
        });
    if !lo.is_finite() {
        (0.0, 1.0)
    } else if hi > lo {
        (lo, hi)
    } else {
        (lo - 0.5, lo + 0.5)
    }
}

const BAR_LEFT: u32 = 12;
const BAR_W: u32 = 28;
const BAR_TICK: u32 = 5;

/// Widest tick label of a colour bar for `range`, px.
fn colour_bar_label_width(range: (f64, f64)) -> u32 {
    let (ticks, step) = nice_ticks(range.0, range.1, 6);
    ticks
        .iter()
        .map(|&t| text_width(&fmt_tick(t, step), TICK_PX))
        .max()
        .unwrap_or(30)
}

/// Width in px needed by a colour bar for `range` with its rotated title.
pub fn colour_bar_width(range: (f64, f64)) -> u32 {
    BAR_LEFT
        + BAR_W
        + 2 * BAR_TICK
        + colour_bar_label_width(range)
        + 12
        + (DESC_PX * 1.3) as u32
        + 12
}

/// Draws a vertical colour bar for `range` with a rotated `label` in `area` (the bar at its left,
/// vertically inset by `top` and `bottom` px).
pub fn draw_colour_bar<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    range: (f64, f64),
    label: &str,
    top: u32,
    bottom: u32,
) -> Result<()> {
    let (lo, hi) = range;
    let (ticks, step) = nice_ticks(lo, hi, 6);
    let (w, h) = area.dim_in_pixel();
    let label_w = w.saturating_sub(BAR_LEFT + BAR_W).max(20);
    let mut chart = ChartBuilder::on(area)
        .margin_top(top)
        .margin_bottom(bottom)
        .margin_left(BAR_LEFT)
        .set_label_area_size(LabelAreaPosition::Right, label_w)
        .build_cartesian_2d(
            AxisCoord::new(0.0, 1.0, vec![], vec![]),
            AxisCoord::new(lo, hi, ticks, vec![]),
        )
        .map_err(de)?;
    let n = 256;
    chart
        .draw_series((0..n).map(|i| {
            let a = lo + (hi - lo) * i as f64 / n as f64;
            let b = lo + (hi - lo) * (i + 1) as f64 / n as f64;
            let c = scale_colour((i as f64 + 0.5) / n as f64);
            Rectangle::new([(0.0, a), (1.0, b)], c.filled())
        }))
        .map_err(de)?;
    chart
        .configure_mesh()
        .disable_mesh()
        .disable_x_axis()
        .y_label_formatter(&|v| fmt_tick(*v, step))
        .y_label_style(text(TICK_PX, false))
        .axis_style(INK)
        .set_all_tick_mark_size(BAR_TICK)
        .draw()
        .map_err(de)?;
    chart
        .draw_series(std::iter::once(Rectangle::new(
            [(0.0, lo), (1.0, hi)],
            INK.stroke_width(1),
        )))
        .map_err(de)?;
    if !label.is_empty() {
        let x = BAR_LEFT
            + BAR_W
            + 2 * BAR_TICK
            + colour_bar_label_width(range)
            + 12
            + (DESC_PX * 0.65) as u32;
        let y = (top + h.saturating_sub(bottom)) / 2;
        let style = text(DESC_PX, false)
            .transform(FontTransform::Rotate270)
            .pos(Pos::new(HPos::Center, VPos::Center));
        area.draw_text(label, &style, (x.min(w) as i32, y as i32))
            .map_err(de)?;
    }
    Ok(())
}

/// Where a legend goes inside the plot area.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum LegendPos {
    /// The corner that covers the fewest data points.
    Auto,
    /// Upper left corner.
    UpperLeft,
    /// Upper right corner.
    UpperRight,
    /// Lower left corner.
    LowerLeft,
    /// Lower right corner.
    LowerRight,
    /// No legend.
    Hidden,
}

/// Top-left pixel offset (inside the plot area) of a legend box of `box_px` for `pos`, or None when
/// hidden. For `Auto` the candidate places (corners, edge middles, and beside each `blocked`
/// rectangle) are scored by how many `occupied` points (plot-area fractions, y up) they cover;
/// places overlapping a `blocked` rectangle (plot-area pixels: left, top, right, bottom) are skipped.
pub fn place_legend(
    pos: LegendPos,
    occupied: &[(f64, f64)],
    plot_px: (u32, u32),
    box_px: (u32, u32),
    blocked: &[(i32, i32, i32, i32)],
) -> Option<(i32, i32)> {
    let (pw, ph) = (plot_px.0 as i32, plot_px.1 as i32);
    let (bw, bh) = (box_px.0 as i32, box_px.1 as i32);
    let pad = 8;
    let (left, right) = (pad, pw - bw - pad);
    let (top, bottom) = (pad, ph - bh - pad);
    match pos {
        LegendPos::Hidden => return None,
        LegendPos::UpperLeft => return Some((left, top)),
        LegendPos::UpperRight => return Some((right, top)),
        LegendPos::LowerLeft => return Some((left, bottom)),
        LegendPos::LowerRight => return Some((right, bottom)),
        LegendPos::Auto => {}
    }
    // Preference order: upper right, upper left, lower right, lower left, then the rest.
    let mut candidates = vec![
        (right, top),
        (left, top),
        (right, bottom),
        (left, bottom),
        (right, (ph - bh) / 2),
        (left, (ph - bh) / 2),
        ((pw - bw) / 2, top),
    ];
    for &(l, _, r, b) in blocked {
        candidates.push((r - bw, b + pad));
        candidates.push((l - bw - pad, top));
    }
    let overlaps = |(x, y): (i32, i32), &(l, t, r, b): &(i32, i32, i32, i32)| {
        x < r && x + bw > l && y < b && y + bh > t
    };
    let covered = |(x, y): (i32, i32)| {
        occupied
            .iter()
            .filter(|(fx, fy)| {
                let (px, py) = (fx * pw as f64, (1.0 - fy) * ph as f64);
                px >= (x - 10) as f64
                    && px <= (x + bw + 10) as f64
                    && py >= (y - 10) as f64
                    && py <= (y + bh + 10) as f64
            })
            .count()
    };
    candidates
        .into_iter()
        .filter(|&(x, y)| x >= 0 && y >= 0 && x + bw <= pw && y + bh <= ph)
        .filter(|&c| !blocked.iter().any(|b| overlaps(c, b)))
        .enumerate()
        .min_by_key(|&(i, c)| (covered(c), i))
        .map(|(_, c)| c)
        .or(Some((right, top)))
}

/// Draws the legend of the labelled series of `chart` with its top-left corner at `at`
/// (plot-area pixels; nothing for None).
pub fn draw_legend<'a, DB: DrawingBackend + 'a>(
    chart: &mut ChartContext<'a, DB, Coord2d>,
    at: Option<(i32, i32)>,
) -> Result<()> {
    let Some((x, y)) = at else { return Ok(()) };
    chart
        .configure_series_labels()
        .position(SeriesLabelPosition::Coordinate(x, y))
        .margin(LEGEND_MARGIN)
        .legend_area_size(LEGEND_SAMPLE)
        .background_style(WHITE.mix(0.92))
        .border_style(RGBColor(170, 170, 170))
        .label_font(text(LEGEND_PX, false))
        .draw()
        .map_err(de)
}

const LEGEND_MARGIN: u32 = 12;
const LEGEND_SAMPLE: u32 = 34;

/// Legend box size in pixels for entries named `names`.
pub fn legend_box(names: &[&str]) -> (u32, u32) {
    let w = names
        .iter()
        .map(|n| text_width(n, LEGEND_PX))
        .max()
        .unwrap_or(0);
    let line = (LEGEND_PX * 1.25).ceil() as u32;
    (
        w + LEGEND_SAMPLE + 2 * LEGEND_MARGIN + 6,
        names.len() as u32 * line + 2 * LEGEND_MARGIN,
    )
}

/// Samples the polyline `pts` (plot-area fractions) densely so legend placement sees lines, not just vertices.
pub fn densify(pts: &[(f64, f64)], out: &mut Vec<(f64, f64)>) {
    out.extend_from_slice(pts);
    for w in pts.windows(2) {
        for k in 1..16 {
            let f = k as f64 / 16.0;
            out.push((
                w[0].0 + f * (w[1].0 - w[0].0),
                w[0].1 + f * (w[1].1 - w[0].1),
            ));
        }
    }
}
