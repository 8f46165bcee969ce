//! The lenslet geometry over the detector: a regular grid of square sub-apertures (size,
//! pitch, origin in px), optionally restricted to the valid ones of a mask (one pixel per
//! grid cell, non-zero = valid), laid out on a map of given shape.

use crate::calib::{Map, Unit};
use crate::montecarlo::SimConfig;
use crate::{Error, Result};
use std::path::Path;

/// A regular grid of square sub-apertures: `size_px` per side, `pitch_px` apart, the first
/// one's lower-left pixel (row 0 = the map's first row) at (`x0_px`, `y0_px`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub struct GridSpec {
    /// Sub-aperture side (px).
    pub size_px: usize,
    /// Distance between neighbouring sub-apertures' origins (px), at least the size.
    pub pitch_px: usize,
    /// Column of the first sub-aperture's first pixel (px).
    pub x0_px: usize,
    /// Row of the first sub-aperture's first pixel (px).
    pub y0_px: usize,
}

impl GridSpec {
    /// Parse `SIZE[,PITCH[,X0,Y0]]` (px): pitch defaults to the size, the origin to 0,0.
    /// Errors name `subap_grid`.
    pub fn parse(text: &str) -> Result<GridSpec> {
        let bad = |why: String| {
            Error::invalid(
                "subap_grid",
                format!(
                    "{text:?}: {why}; expected SIZE[,PITCH[,X0,Y0]] in px, e.g. 16 or 16,18,4,4"
                ),
            )
        };
        let parts: Vec<usize> = text
            .split(',')
            .map(|p| {
                p.trim()
                    .parse::<usize>()
                    .map_err(|_| bad(format!("{:?} is not a whole number of px", p.trim())))
            })
            .collect::<Result<_>>()?;
        let (size_px, pitch_px, x0_px, y0_px) = match parts[..] {
            [s] => (s, s, 0, 0),
            [s, p] => (s, p, 0, 0),
            [s, p, x, y] => (s, p, x, y),
            _ => return Err(bad(format!("{} numbers given", parts.len()))),
        };
        let spec = GridSpec {
            size_px,
            pitch_px,
            x0_px,
            y0_px,
        };
        spec.validate().map_err(|e| match e {
            Error::Usage { message, .. } => bad(message),
            other => other,
        })?;
        Ok(spec)
    }

    /// Check the size against the engine's limits and the pitch against the size.
    pub fn validate(&self) -> Result<()> {
        let (lo, hi) = (SimConfig::MIN_SUBAP_PX, SimConfig::MAX_SUBAP_PX);
        if !(lo..=hi).contains(&self.size_px) {
            return Err(Error::invalid(
                "subap_grid",
                format!(
                    "a sub-aperture of {} px per side: must be {lo} to {hi} px",
                    self.size_px
                ),
            ));
        }
        if self.pitch_px < self.size_px {
            return Err(Error::invalid(
                "subap_grid",
                format!(
                    "pitch {} px is below the size {} px: sub-apertures must not overlap",
                    self.pitch_px, self.size_px
                ),
            ));
        }
        // The first window's far edge must be a number of px: an origin near the largest
        // integer would wrap around and lay out windows outside any map.
        for (axis, origin) in [("X0", self.x0_px), ("Y0", self.y0_px)] {
            if origin.checked_add(self.size_px).is_none() {
                return Err(Error::invalid(
                    "subap_grid",
                    format!(
                        "{axis} = {origin} px: the first sub-aperture would end beyond the \
                         largest pixel index"
                    ),
                ));
            }
        }
        Ok(())
    }

    /// The grid as typed: `SIZE,PITCH,X0,Y0`.
    pub fn text(&self) -> String {
        format!(
            "{},{},{},{}",
            self.size_px, self.pitch_px, self.x0_px, self.y0_px
        )
    }

    /// Grid cells (rows, columns) that fit a map of `rows` x `cols` px; the grid must have
    /// passed [`GridSpec::validate`] (its pitch is then not zero).
    pub(crate) fn shape_on(&self, rows: usize, cols: usize) -> [usize; 2] {
        [
            self.fitting(rows, self.y0_px),
            self.fitting(cols, self.x0_px),
        ]
    }

    /// Grid cells along an axis of `len` px from `origin` whose sub-aperture fits (checked
    /// arithmetic: an origin beyond the map fits none, whatever its size).
    fn fitting(&self, len: usize, origin: usize) -> usize {
        match origin
            .checked_add(self.size_px)
            .and_then(|end| len.checked_sub(end))
        {
            Some(spare) => spare / self.pitch_px + 1,
            None => 0,
        }
    }

    /// The first pixel along an axis of grid cell `cell` from `origin` (px), checked: a
    /// fitting cell always has one.
    fn start(&self, origin: usize, cell: usize) -> Result<usize> {
        cell.checked_mul(self.pitch_px)
            .and_then(|d| d.checked_add(origin))
            .ok_or_else(|| {
                Error::invalid(
                    "subap_grid",
                    format!(
                        "{}: cell {cell} starts beyond the largest pixel index",
                        self.text()
                    ),
                )
            })
    }
}

/// Which cells of the grid hold a sub-aperture: one value per cell (row-major), non-zero =
/// valid.
#[derive(Debug, Clone, PartialEq)]
pub struct ValidMask {
    /// Grid rows.
    pub rows: usize,
    /// Grid columns.
    pub cols: usize,
    /// Whether each cell is valid, row-major.
    pub valid: Vec<bool>,
    /// BLAKE3 of the cells (hex), for the part files' binding.
    pub blake3: String,
}

impl ValidMask {
    /// A mask of `rows` x `cols` cells from their validity, row-major.
    pub fn new(rows: usize, cols: usize, valid: Vec<bool>) -> ValidMask {
        assert_eq!(valid.len(), rows * cols, "one value per cell");
        let bytes: Vec<u8> = [rows as u64, cols as u64]
            .iter()
            .flat_map(|v| v.to_le_bytes())
            .chain(valid.iter().map(|&v| v as u8))
            .collect();
        ValidMask {
            rows,
            cols,
            valid,
            blake3: blake3::hash(&bytes).to_hex().to_string(),
        }
    }

    /// Read a mask image (FITS/TIFF/EXR, first frame): non-zero = valid. A non-finite cell is
    /// refused, naming the file.
    pub fn read(path: &Path) -> Result<ValidMask> {
        let m = Map::read(path, Unit::Flags)?;
        if let Some(i) = m.data.iter().position(|v| !v.is_finite()) {
            return Err(Error::input(
                path,
                format!(
                    "mask cell (row {}, column {}) is not a number: a mask holds 0 (invalid) or \
                     non-zero (valid) per sub-aperture",
                    i / m.cols,
                    i % m.cols
                ),
            ));
        }
        Ok(ValidMask::new(
            m.rows,
            m.cols,
            m.data.iter().map(|v| *v != 0.0).collect(),
        ))
    }
}

/// The lenslet geometry: the grid, and the mask of its valid cells if any.
#[derive(Debug, Clone, PartialEq)]
pub struct Geometry {
    /// The grid.
    pub grid: GridSpec,
    /// Valid cells; None: every cell whose sub-aperture fits the map.
    pub mask: Option<ValidMask>,
}

/// One sub-aperture: its index among the valid ones (row-major over the grid), its grid cell
/// and its window's first pixel.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Subap {
    /// Index among the sub-apertures laid out (0-based, row-major over the grid).
    pub index: usize,
    /// Grid row (0 = the map's first rows).
    pub grid_row: usize,
    /// Grid column.
    pub grid_col: usize,
    /// Row of the window's first pixel in the map (px).
    pub y0_px: usize,
    /// Column of the window's first pixel in the map (px).
    pub x0_px: usize,
}

/// The sub-apertures of a geometry on a map.
#[derive(Debug, Clone, PartialEq)]
pub struct Layout {
    /// Grid rows (as many as fit the map; a mask has exactly this shape).
    pub grid_rows: usize,
    /// Grid columns.
    pub grid_cols: usize,
    /// The sub-apertures, row-major.
    pub subaps: Vec<Subap>,
    /// Cells the mask marks invalid.
    pub masked: usize,
}

impl Geometry {
    /// Lay the sub-apertures out on a map of `rows` x `cols` px: the grid holds every
    /// sub-aperture that fits, and a mask must have the grid's shape (a mask of another shape
    /// is refused naming both, rather than shrinking or cutting the grid). No sub-aperture
    /// fitting is an error of `subap_grid`; a mask of another shape, or marking none valid, of
    /// `subap_mask`.
    pub fn layout(&self, rows: usize, cols: usize) -> Result<Layout> {
        let g = &self.grid;
        g.validate()?;
        let (grid_rows, grid_cols) = (g.fitting(rows, g.y0_px), g.fitting(cols, g.x0_px));
        if grid_rows == 0 || grid_cols == 0 {
            return Err(Error::invalid(
                "subap_grid",
                format!(
                    "{}: no {}x{} px sub-aperture from ({}, {}) fits the {rows}x{cols} px map",
                    g.text(),
                    g.size_px,
                    g.size_px,
                    g.x0_px,
                    g.y0_px
                ),
            ));
        }
        if let Some(m) = &self.mask {
            if (m.rows, m.cols) != (grid_rows, grid_cols) {
                return Err(Error::invalid(
                    "subap_mask",
                    format!(
                        "the mask is {}x{} cells but the grid {} on the {rows}x{cols} px map is \
                         {grid_rows}x{grid_cols} sub-apertures: give one mask cell per \
                         sub-aperture of the grid",
                        m.rows,
                        m.cols,
                        g.text()
                    ),
                ));
            }
        }
        let mut layout = Layout {
            grid_rows,
            grid_cols,
            subaps: Vec::new(),
            masked: 0,
        };
        for r in 0..grid_rows {
            for c in 0..grid_cols {
                if self.mask.as_ref().is_some_and(|m| !m.valid[r * m.cols + c]) {
                    layout.masked += 1;
                    continue;
                }
                layout.subaps.push(Subap {
                    index: layout.subaps.len(),
                    grid_row: r,
                    grid_col: c,
                    y0_px: g.start(g.y0_px, r)?,
                    x0_px: g.start(g.x0_px, c)?,
                });
            }
        }
        if layout.subaps.is_empty() {
            return Err(Error::invalid(
                "subap_mask",
                format!(
                    "the mask marks none of the {grid_rows}x{grid_cols} sub-apertures of the \
                     grid {} as valid",
                    g.text()
                ),
            ));
        }
        Ok(layout)
    }
}

impl Layout {
    /// BLAKE3 (hex) of the grid shape and every sub-aperture's cell and window: parts of one
    /// job share it, and a merge recomputes it from the records.
    pub fn digest(&self) -> String {
        layout_digest(
            (self.grid_rows, self.grid_cols),
            self.subaps.iter().map(|s| (s.grid_row, s.grid_col)),
        )
    }

    /// Sub-apertures of shard `k` of `n` (1-based k): those whose index is k - 1 modulo n.
    pub fn shard(&self, k: usize, n: usize) -> Vec<Subap> {
        self.subaps
            .iter()
            .filter(|s| s.index % n == k - 1)
            .copied()
            .collect()
    }
}

/// BLAKE3 (hex) of a grid shape and its sub-apertures' cells, in index order.
pub(crate) fn layout_digest(
    shape: (usize, usize),
    cells: impl Iterator<Item = (usize, usize)>,
) -> String {
    let mut h = blake3::Hasher::new();
    for v in [shape.0, shape.1] {
        h.update(&(v as u64).to_le_bytes());
    }
    for (r, c) in cells {
        h.update(&(r as u64).to_le_bytes());
        h.update(&(c as u64).to_le_bytes());
    }
    h.finalize().to_hex().to_string()
}
