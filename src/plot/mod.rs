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
mod render;
mod scatter;
mod style;
mod ticks;

pub use heatmap::Heatmap;
pub use hist::{Bins, HistNorm, Histogram, Inset};
pub use images::{Image, ImageGrid};
pub use line::{LegendPos, LineChart, Point, RefLine, Series, SeriesStyle};
pub use render::ImageFormat;
pub use scatter::ScatterFit;

#[cfg(test)]
mod tests;
