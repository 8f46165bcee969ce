//! Rendering: the embedded fonts, the image format chosen by the file extension, and the
//! in-memory drawing of a chart written atomically.

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
pub(super) fn ensure_fonts() -> Result<()> {
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
pub enum ImageFormat {
    /// Raster PNG (RGB, 8 bit).
    Png,
    /// Scalable vector graphics.
    Svg,
}

impl ImageFormat {
    /// The format named by the extension of `path` (`.png` or `.svg`, any case); otherwise a usage error.
    pub fn from_path(path: &Path) -> Result<Self> {
        let ext = path
            .extension()
            .and_then(|e| e.to_str())
            .map(str::to_ascii_lowercase);
        match ext.as_deref() {
            Some("png") => Ok(ImageFormat::Png),
            Some("svg") => Ok(ImageFormat::Svg),
            _ => Err(Error::invalid(
                "chart_path",
                format!("{}: the extension must be .png or .svg", path.display()),
            )),
        }
    }
}

/// A chart that can draw itself on any plotters backend.
pub(super) trait Chart {
    /// Canvas size in pixels (width, height).
    fn size(&self) -> (u32, u32);
    /// Draws the whole chart on `root`.
    fn draw<'a, DB: DrawingBackend + 'a>(&self, root: &'a DrawingArea<DB, Shift>) -> Result<()>;
}

/// Converts a plotters drawing error into the crate's error.
pub(super) fn de<E: std::fmt::Display>(e: E) -> Error {
    Error::Numeric(format!("chart drawing failed: {e}"))
}

/// Renders `chart` in memory in the format of `path`, then writes it atomically.
pub(super) fn save_chart<C: Chart>(chart: &C, path: &Path) -> Result<()> {
    let format = ImageFormat::from_path(path)?;
    ensure_fonts()?;
    let (w, h) = chart.size();
    if !(64..=20_000).contains(&w) || !(64..=20_000).contains(&h) {
        return Err(Error::invalid(
            "chart_size_px",
            format!("{w}x{h} px is outside 64..20000 px per side"),
        ));
    }
    let bytes = match format {
        ImageFormat::Svg => {
            let mut s = String::new();
            {
                let root = SVGBackend::with_string(&mut s, (w, h)).into_drawing_area();
                chart.draw(&root)?;
                root.present().map_err(de)?;
            }
            s.into_bytes()
        }
        ImageFormat::Png => {
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
