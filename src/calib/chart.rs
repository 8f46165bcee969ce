//! Charts of calibration results (PNG, drawn with plotters and the embedded DejaVu Sans).
//! Temporary home until the shared `plot` module offers the same charts.

use plotters::prelude::*;
use plotters::style::FontStyle;

use crate::error::{Error, Result};

static FONT: &[u8] = include_bytes!("../../assets/fonts/DejaVuSans.ttf");

fn register_font() {
    static ONCE: std::sync::Once = std::sync::Once::new();
    ONCE.call_once(|| {
        // The font is embedded and known valid; a failure would only lose the text.
        let _ = plotters::style::register_font("sans-serif", FontStyle::Normal, FONT);
    });
}

fn draw_err(e: impl std::fmt::Display) -> Error {
    Error::Numeric(format!("drawing chart: {e}"))
}

fn encode_png(buf: &[u8], w: u32, h: u32) -> Result<Vec<u8>> {
    let mut out = Vec::new();
    image::codecs::png::PngEncoder::new(&mut out)
        .write_image(buf, w, h, image::ExtendedColorType::Rgb8)
        .map_err(draw_err)?;
    Ok(out)
}

use image::ImageEncoder;

/// PNG histogram of `values` (finite ones) with a log count axis; `xlabel` names the unit.
pub fn histogram_png(values: &[f64], xlabel: &str, title: &str) -> Result<Vec<u8>> {
    register_font();
    let v: Vec<f64> = values.iter().copied().filter(|x| x.is_finite()).collect();
    let (w, h) = (900u32, 600u32);
    let mut buf = vec![255u8; (w * h * 3) as usize];
    let lo = v.iter().copied().fold(f64::INFINITY, f64::min).min(0.0);
    let mut hi = v.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    if hi.partial_cmp(&lo) != Some(std::cmp::Ordering::Greater) {
        hi = lo + 1.0;
    }
    let bins = 100usize;
    let width = (hi - lo) / bins as f64;
    let mut counts = vec![0u64; bins];
    for x in &v {
        counts[(((x - lo) / width) as usize).min(bins - 1)] += 1;
    }
    let top = counts.iter().copied().max().unwrap_or(1).max(1) as f64;
    {
        let root = BitMapBackend::with_buffer(&mut buf, (w, h)).into_drawing_area();
        root.fill(&WHITE).map_err(draw_err)?;
        let mut chart = ChartBuilder::on(&root)
            .caption(title, ("sans-serif", 22))
            .margin(15)
            .x_label_area_size(50)
            .y_label_area_size(70)
            .build_cartesian_2d(lo..hi, (0.5f64..top * 2.0).log_scale())
            .map_err(draw_err)?;
        chart
            .configure_mesh()
            .x_desc(xlabel)
            .y_desc("pixels")
            .label_style(("sans-serif", 15))
            .draw()
            .map_err(draw_err)?;
        chart
            .draw_series(
                counts
                    .iter()
                    .enumerate()
                    .filter(|(_, c)| **c > 0)
                    .map(|(i, c)| {
                        let x0 = lo + i as f64 * width;
                        Rectangle::new([(x0, 0.5), (x0 + width, *c as f64)], BLUE.mix(0.6).filled())
                    }),
            )
            .map_err(draw_err)?;
        root.present().map_err(draw_err)?;
    }
    encode_png(&buf, w, h)
}

/// PNG log-log photon-transfer chart: points (mean, variance) in adu and the fitted line
/// variance = read_var + mean / gain.
pub fn ptc_png(
    points: &[(f64, f64)],
    gain_e_per_adu: f64,
    read_var_adu2: f64,
    title: &str,
) -> Result<Vec<u8>> {
    register_font();
    let (w, h) = (900u32, 600u32);
    let mut buf = vec![255u8; (w * h * 3) as usize];
    let pos: Vec<(f64, f64)> = points
        .iter()
        .copied()
        .filter(|(m, v)| *m > 0.0 && *v > 0.0)
        .collect();
    let xmin = pos
        .iter()
        .map(|p| p.0)
        .fold(f64::INFINITY, f64::min)
        .min(1.0);
    let xmax = pos.iter().map(|p| p.0).fold(1.0, f64::max) * 2.0;
    let ymin = pos
        .iter()
        .map(|p| p.1)
        .fold(f64::INFINITY, f64::min)
        .min(read_var_adu2.max(1e-3))
        / 2.0;
    let ymax = pos.iter().map(|p| p.1).fold(1.0, f64::max) * 2.0;
    {
        let root = BitMapBackend::with_buffer(&mut buf, (w, h)).into_drawing_area();
        root.fill(&WHITE).map_err(draw_err)?;
        let mut chart = ChartBuilder::on(&root)
            .caption(title, ("sans-serif", 22))
            .margin(15)
            .x_label_area_size(50)
            .y_label_area_size(80)
            .build_cartesian_2d((xmin..xmax).log_scale(), (ymin..ymax).log_scale())
            .map_err(draw_err)?;
        chart
            .configure_mesh()
            .x_desc("dark-subtracted mean (adu)")
            .y_desc("variance (adu^2)")
            .label_style(("sans-serif", 15))
            .draw()
            .map_err(draw_err)?;
        chart
            .draw_series(pos.iter().map(|p| Circle::new(*p, 5, RED.filled())))
            .map_err(draw_err)?;
        let line: Vec<(f64, f64)> = (0..=200)
            .map(|i| xmin * (xmax / xmin).powf(i as f64 / 200.0))
            .map(|m| (m, read_var_adu2.max(0.0) + m / gain_e_per_adu))
            .filter(|(_, v)| *v >= ymin && *v <= ymax)
            .collect();
        chart
            .draw_series(LineSeries::new(line, BLUE.stroke_width(2)))
            .map_err(draw_err)?
            .label(format!("fit: {gain_e_per_adu:.4} e/adu"))
            .legend(|(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], BLUE.stroke_width(2)));
        chart
            .configure_series_labels()
            .background_style(WHITE)
            .border_style(BLACK)
            .label_font(("sans-serif", 15))
            .draw()
            .map_err(draw_err)?;
        root.present().map_err(draw_err)?;
    }
    encode_png(&buf, w, h)
}
