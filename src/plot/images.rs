//! Grid of small 2-D images with titles and one shared colour scale (paper Fig. 2: ten 16x16
//! per-pixel noise patterns).

use std::path::Path;

use plotters::coord::Shift;
use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};

use super::render::{de, save_chart, Chart};
use super::style::{
    colour_bar_width, draw_colour_bar, scale_colour, scale_range, text, INK, TITLE_PX,
};
use crate::error::{Error, Result};

/// Largest image side drawn cell by cell; bigger images are block-averaged down to it.
const MAX_SIDE: usize = 128;

/// One image: `data[row * width + col]`, row 0 drawn at the top.
#[derive(Clone, Debug, PartialEq)]
pub struct Image {
    /// Panel title ("" for none).
    pub title: String,
    /// Columns.
    pub width: usize,
    /// Rows.
    pub height: usize,
    /// Row-major values; NaN is drawn grey.
    pub data: Vec<f64>,
}

/// A grid of images sharing one colour scale; fill the fields (or use [`ImageGrid::new`]) and call
/// [`ImageGrid::save`]. The canvas size follows from the panel size and the grid shape.
#[derive(Clone, Debug, PartialEq)]
pub struct ImageGrid {
    /// Title above the grid.
    pub title: String,
    /// The panels, filled row by row.
    pub images: Vec<Image>,
    /// Panels per row (0: about square grid).
    pub columns: usize,
    /// Colour-bar label with unit, e.g. "read noise rms (e⁻)".
    pub colour_label: String,
    /// Shared colour range; the finite min and max over all images if None.
    pub range: Option<(f64, f64)>,
    /// Side of one panel's image area, px.
    pub panel_px: u32,
}

impl ImageGrid {
    /// A grid of `images` with 5 columns (or fewer) and 180 px panels.
    pub fn new(
        title: impl Into<String>,
        images: Vec<Image>,
        colour_label: impl Into<String>,
    ) -> Self {
        ImageGrid {
            title: title.into(),
            images,
            columns: 0,
            colour_label: colour_label.into(),
            range: None,
            panel_px: 180,
        }
    }

    /// Writes the chart to `path` (.png or .svg), atomically.
    pub fn save(&self, path: impl AsRef<Path>) -> Result<()> {
        save_chart(self, path.as_ref())
    }

    fn shape(&self) -> (usize, usize) {
        let n = self.images.len().max(1);
        let cols = if self.columns > 0 {
            self.columns.min(n)
        } else {
            (n as f64).sqrt().ceil().max(1.0) as usize
        };
        (cols, n.div_ceil(cols))
    }

    fn range(&self) -> (f64, f64) {
        scale_range(
            self.images.iter().flat_map(|i| i.data.iter().cloned()),
            self.range,
        )
    }

    fn check(&self) -> Result<()> {
        if self.images.is_empty() {
            return Err(Error::invalid("image_grid", "needs at least one image"));
        }
        for (k, im) in self.images.iter().enumerate() {
            if im.width == 0 || im.height == 0 || im.data.len() != im.width * im.height {
                return Err(Error::invalid(
                    "image_grid",
                    format!(
                        "image {k}: {} values for {}x{} pixels",
                        im.data.len(),
                        im.width,
                        im.height
                    ),
                ));
            }
        }
        Ok(())
    }
}

const GAP: u32 = 22;
const PANEL_TITLE: u32 = 26;
const HEADER: u32 = 56;
const MARGIN: u32 = 16;

impl Chart for ImageGrid {
    fn size(&self) -> (u32, u32) {
        let (cols, rows) = self.shape();
        let w =
            MARGIN + cols as u32 * (self.panel_px + GAP) + colour_bar_width(self.range()) + MARGIN;
        let h = HEADER + rows as u32 * (self.panel_px + PANEL_TITLE + GAP) + MARGIN;
        (w, h)
    }

    fn draw<'a, DB: DrawingBackend + 'a>(&self, root: &'a DrawingArea<DB, Shift>) -> Result<()> {
        self.check()?;
        root.fill(&WHITE).map_err(de)?;
        let (w, h) = root.dim_in_pixel();
        let (cols, rows) = self.shape();
        let range = self.range();
        if !self.title.is_empty() {
            let px = super::axis::fitted_px(&self.title, TITLE_PX, w);
            let style = text(px, true).pos(Pos::new(HPos::Center, VPos::Center));
            root.draw_text(&self.title, &style, ((w / 2) as i32, (HEADER / 2) as i32))
                .map_err(de)?;
        }
        let p = self.panel_px as i32;
        for (k, im) in self.images.iter().enumerate() {
            let (c, r) = ((k % cols) as i32, (k / cols) as i32);
            let x0 = (MARGIN + GAP / 2) as i32 + c * (p + GAP as i32);
            let y0 = HEADER as i32 + r * (p + (PANEL_TITLE + GAP) as i32);
            if !im.title.is_empty() {
                let style = text(16.0, false).pos(Pos::new(HPos::Center, VPos::Center));
                root.draw_text(&im.title, &style, (x0 + p / 2, y0 + PANEL_TITLE as i32 / 2))
                    .map_err(de)?;
            }
            draw_image(root, im, (x0, y0 + PANEL_TITLE as i32), p, range)?;
        }
        let grid_w = MARGIN + cols as u32 * (self.panel_px + GAP);
        let (_, bar) = root.split_horizontally(grid_w);
        let top = HEADER + PANEL_TITLE;
        let bottom = h - (HEADER + rows as u32 * (self.panel_px + PANEL_TITLE + GAP) - GAP);
        draw_colour_bar(&bar, range, &self.colour_label, top, bottom)
    }
}

/// Draws `im` with square pixels centred in a `side` x `side` box at `origin` (pixels), framed.
fn draw_image<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    im: &Image,
    origin: (i32, i32),
    side: i32,
    range: (f64, f64),
) -> Result<()> {
    let (w, h, data) = reduce(im);
    let cell = (side as f64 / w.max(h) as f64).max(0.01);
    let (iw, ih) = (cell * w as f64, cell * h as f64);
    let ox = origin.0 as f64 + (side as f64 - iw) / 2.0;
    let oy = origin.1 as f64 + (side as f64 - ih) / 2.0;
    let px = |v: f64| v.round() as i32;
    let mut rects = Vec::with_capacity(w * h);
    for row in 0..h {
        for col in 0..w {
            let v = data[row * w + col];
            let colour = if v.is_finite() {
                scale_colour((v - range.0) / (range.1 - range.0))
            } else {
                RGBColor(200, 200, 200)
            };
            let a = (px(ox + col as f64 * cell), px(oy + row as f64 * cell));
            let b = (
                px(ox + (col + 1) as f64 * cell),
                px(oy + (row + 1) as f64 * cell),
            );
            rects.push(Rectangle::new([a, b], colour.filled()));
        }
    }
    for r in rects {
        root.draw(&r).map_err(de)?;
    }
    let frame = [(px(ox) - 1, px(oy) - 1), (px(ox + iw), px(oy + ih))];
    root.draw(&Rectangle::new(frame, INK.stroke_width(1)))
        .map_err(de)?;
    Ok(())
}

/// The image, block-averaged so that neither side exceeds `MAX_SIDE` (NaN cells are skipped).
fn reduce(im: &Image) -> (usize, usize, std::borrow::Cow<'_, [f64]>) {
    let f = im.width.max(im.height).div_ceil(MAX_SIDE);
    if f <= 1 {
        return (im.width, im.height, std::borrow::Cow::Borrowed(&im.data));
    }
    let (w, h) = (im.width.div_ceil(f), im.height.div_ceil(f));
    let mut out = vec![0.0; w * h];
    for (r, row) in out.chunks_mut(w).enumerate() {
        for (c, o) in row.iter_mut().enumerate() {
            let (mut s, mut n) = (0.0, 0usize);
            for y in r * f..((r + 1) * f).min(im.height) {
                for x in c * f..((c + 1) * f).min(im.width) {
                    let v = im.data[y * im.width + x];
                    if v.is_finite() {
                        s += v;
                        n += 1;
                    }
                }
            }
            *o = if n > 0 { s / n as f64 } else { f64::NAN };
        }
    }
    (w, h, std::borrow::Cow::Owned(out))
}
