//! Charts for every command: line charts, histograms, heatmaps, image grids and log-log scatter
//! with a fitted line, written as PNG or SVG (chosen by the file extension).
//!
//! The API takes plain data structs (no plotters types). Each chart has a `save(path)` method
//! that renders in memory and then writes atomically (temporary file in the same directory,
//! then rename), so a failure never leaves a partial file. Text uses DejaVu Sans, embedded in
//! the binary (assets/fonts, Bitstream Vera licence beside it), because plotters is built
//! without system font libraries. SVG files name the font family `sans-serif`, so viewers use
//! their own sans-serif face.
//!
//! ```
//! use detnoise::plot::{LineChart, Series};
//! let mut c = LineChart::new("R vs signal", "signal (photons)", "R (px)");
//! c.log_x = true;
//! c.series.push(Series::with_errors("EMCCD", [(20.0, 0.3, 0.01), (100.0, 0.1, 0.005)]));
//! let dir = tempfile::tempdir().unwrap();
//! c.save(dir.path().join("r.png"))?;
//! c.save(dir.path().join("r.svg"))?;
//! assert!(c.save(dir.path().join("r.jpg")).is_err());
//! # Ok::<(), detnoise::Error>(())
//! ```

mod axis;
mod heatmap;
mod hist;
mod images;

mod line;
mod scatter;
mod style;

pub use heatmap::Heatmap;
pub use hist::{Bins, HistNorm, Histogram, Inset};
pub use images::{Image, ImageGrid};
pub use line::{LegendPos, LineChart, Point, RefLine, Series, SeriesStyle};
pub use scatter::ScatterFit;

use std::path::Path;
use std::sync::OnceLock;

use plotters::coord::Shift;
use plotters::prelude::*;
use plotters::style::{register_font, FontStyle};

use crate::error::{Error, Result};

static FONT_REGULAR: &[u8] = include_bytes!(concat!(
    env!("CARGO_MANIFEST_DIR"),
    "/assets/fonts/DejaVuSans.ttf"
));
static FONT_BOLD: &[u8] = include_bytes!(concat!(
    env!("CARGO_MANIFEST_DIR"),
    "/assets/fonts/DejaVuSans-Bold.ttf"
));

/// Registers the embedded fonts with plotters once per process.
fn ensure_fonts() -> Result<()> {
    static DONE: OnceLock<std::result::Result<(), String>> = OnceLock::new();
    DONE.get_or_init(|| {
        register_font("sans-serif", FontStyle::Normal, FONT_REGULAR)
            .and_then(|_| register_font("sans-serif", FontStyle::Bold, FONT_BOLD))
            .map_err(|_| "embedded DejaVu Sans font is invalid".to_string())
    })
    .clone()
    .map_err(Error::Numeric)
}

/// Output file format of a chart.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Format {
    /// Raster PNG (RGB, 8 bit).
    Png,
    /// Scalable vector graphics.
    Svg,
}

impl Format {
    /// The format named by the extension of `path` (`.png` or `.svg`, any case); otherwise a usage error.
    pub fn from_path(path: &Path) -> Result<Self> {
        let ext = path
            .extension()
            .and_then(|e| e.to_str())
            .map(str::to_ascii_lowercase);
        match ext.as_deref() {
            Some("png") => Ok(Format::Png),
            Some("svg") => Ok(Format::Svg),
            _ => Err(Error::invalid(
                "chart_path",
                format!("{}: the extension must be .png or .svg", path.display()),
            )),
        }
    }
}

/// A chart that can draw itself on any plotters backend.
trait Chart {
    /// Canvas size in pixels (width, height).
    fn size(&self) -> (u32, u32);
    /// Draws the whole chart on `root`.
    fn draw<'a, DB: DrawingBackend + 'a>(&self, root: &'a DrawingArea<DB, Shift>) -> Result<()>;
}

/// Converts a plotters drawing error into the crate's error.
fn de<E: std::fmt::Display>(e: E) -> Error {
    Error::Numeric(format!("chart drawing failed: {e}"))
}

/// Renders `chart` in memory in the format of `path`, then writes it atomically.
fn save_chart<C: Chart>(chart: &C, path: &Path) -> Result<()> {
    let format = Format::from_path(path)?;
    ensure_fonts()?;
    let (w, h) = chart.size();
    if !(64..=20_000).contains(&w) || !(64..=20_000).contains(&h) {
        return Err(Error::invalid(
            "chart_size_px",
            format!("{w}x{h} px is outside 64..20000 px per side"),
        ));
    }
    let bytes = match format {
        Format::Svg => {
            let mut s = String::new();
            {
                let root = SVGBackend::with_string(&mut s, (w, h)).into_drawing_area();
                chart.draw(&root)?;
                root.present().map_err(de)?;
            }
            s.into_bytes()
        }
        Format::Png => {
            let mut buf = vec![255u8; w as usize * h as usize * 3];
            {
                let root = BitMapBackend::with_buffer(&mut buf, (w, h)).into_drawing_area();
                chart.draw(&root)?;
                root.present().map_err(de)?;
            }
            encode_png(buf, w, h)?
        }
    };
    crate::output::write_atomic(path, &bytes)
}

fn encode_png(rgb: Vec<u8>, w: u32, h: u32) -> Result<Vec<u8>> {
    use image::ImageEncoder;
    let mut out = Vec::new();
    image::codecs::png::PngEncoder::new(&mut out)
        .write_image(&rgb, w, h, image::ExtendedColorType::Rgb8)
        .map_err(|e| Error::Numeric(format!("PNG encoding failed: {e}")))?;
    Ok(out)
}

#[cfg(test)]
mod tests;
