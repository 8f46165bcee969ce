//! Telegraph (RTS) pixels as a readout draws them: each pixel's levels, occupancies and
//! widths ([`Telegraph`]), and a table's pixels indexed by row ([`TelegraphPixels`]), shared by
//! `scmos-rts` and the camera model.

use super::rts_table::{RtsPixel, RtsTable, MAX_LEVELS};
use crate::{Error, Result};

/// One telegraph pixel as the readout draws it: cumulative occupancies, levels and widths.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct Telegraph {
    /// Cumulative occupancy up to each level; the last used one is exactly 1.
    cumulative: [f64; MAX_LEVELS],
    /// Level relative to the pixel's offset (e-).
    pub(super) level_e: [f64; MAX_LEVELS],
    /// Gaussian width around the level (e-).
    pub(super) width_e: [f64; MAX_LEVELS],
}

impl Telegraph {
    /// A placeholder, overwritten before use.
    const UNUSED: Telegraph = Telegraph {
        cumulative: [1.0; MAX_LEVELS],
        level_e: [0.0; MAX_LEVELS],
        width_e: [0.0; MAX_LEVELS],
    };

    /// The telegraph pixel `p` of the table (1 to [`MAX_LEVELS`] levels).
    fn of(p: &RtsPixel) -> Telegraph {
        let mut t = Telegraph::UNUSED;
        let mut sum = 0.0;
        for k in 0..p.levels_e.len() {
            sum += p.occupancy[k];
            t.cumulative[k] = sum;
            t.level_e[k] = p.levels_e[k];
            t.width_e[k] = p.widths_e[k];
        }
        // The last level takes whatever round-off left: every u in [0, 1) finds a level.
        t.cumulative[p.levels_e.len() - 1] = 1.0;
        t
    }

    /// The level a uniform deviate `u` in [0, 1) falls in.
    pub(super) fn level(&self, u: f64) -> usize {
        self.cumulative.iter().position(|&c| u < c).unwrap_or(0)
    }

    /// One frame's value (e-, about the offset): the level a uniform deviate `u` in [0, 1)
    /// falls in, plus its width times the normal deviate `z`.
    pub(crate) fn value(&self, u: f64, z: f64) -> f64 {
        let k = self.level(u);
        self.level_e[k] + self.width_e[k] * z
    }

    /// Occupancy of each level (levels past the pixel's last have 0).
    fn occupancies(&self) -> impl Iterator<Item = (usize, f64)> + '_ {
        (0..MAX_LEVELS).map(|k| {
            let below = if k == 0 { 0.0 } else { self.cumulative[k - 1] };
            (k, self.cumulative[k] - below)
        })
    }

    /// Mean value, e-: sum_k occupancy_k level_k (0 for a table of `darks`, whose levels are
    /// about the pixel's mean).
    pub(crate) fn mean_e(&self) -> f64 {
        self.occupancies().map(|(k, o)| o * self.level_e[k]).sum()
    }

    /// Variance of the value, e-^2: sum_k occupancy_k ((level_k - mean)^2 + width_k^2).
    pub(crate) fn variance_e2(&self) -> f64 {
        let m = self.mean_e();
        self.occupancies()
            .map(|(k, o)| o * ((self.level_e[k] - m).powi(2) + self.width_e[k].powi(2)))
            .sum()
    }
}

/// The telegraph pixels of a table on a frame, by row: those of row r are
/// `pixels[row_start[r]..row_start[r + 1]]`, each with its column, sorted by column.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct TelegraphPixels {
    row_start: Vec<usize>,
    pixels: Vec<(usize, Telegraph)>,
}

impl TelegraphPixels {
    /// The `ok` pixels of `table` on a `rows` x `cols` frame; a pixel outside it is an error
    /// naming the table, its line and `frame` (what the frame is, e.g. the noise map's file).
    pub(crate) fn new(table: &RtsTable, rows: usize, cols: usize, frame: &str) -> Result<Self> {
        // Telegraph pixels by row in linear time (a counting sort; a million rows are read):
        // each row's in table order, then sorted by column (stably, as one sort by (row,
        // column) would leave them).
        let mut row_start = vec![0; rows + 1];
        for p in &table.pixels {
            if p.x_px >= cols || p.y_px >= rows {
                return Err(Error::input(
                    &table.source,
                    format!(
                        "line {}: pixel (x_px {}, y_px {}) is outside the {rows}x{cols} px {frame}: \
                         the table and the map must come from the same camera (x_px is the \
                         column, y_px the row, 0-based, of the full frame)",
                        p.line, p.x_px, p.y_px
                    ),
                ));
            }
            row_start[p.y_px + 1] += 1;
        }
        for r in 0..rows {
            row_start[r + 1] += row_start[r];
        }
        let mut next = row_start.clone();
        let mut pixels = vec![(0, Telegraph::UNUSED); table.pixels.len()];
        for p in &table.pixels {
            pixels[next[p.y_px]] = (p.x_px, Telegraph::of(p));
            next[p.y_px] += 1;
        }
        for r in 0..rows {
            pixels[row_start[r]..row_start[r + 1]].sort_by_key(|&(c, _)| c);
        }
        Ok(TelegraphPixels { row_start, pixels })
    }

    /// Number of telegraph pixels.
    pub(crate) fn len(&self) -> usize {
        self.pixels.len()
    }

    /// The telegraph pixels of row `row` from column `c0` to before `c0 + n`, with their columns.
    pub(crate) fn in_row(
        &self,
        row: usize,
        c0: usize,
        n: usize,
    ) -> impl Iterator<Item = &(usize, Telegraph)> {
        let row = &self.pixels[self.row_start[row]..self.row_start[row + 1]];
        let first = row.partition_point(|&(c, _)| c < c0);
        row[first..].iter().take_while(move |&&(c, _)| c < c0 + n)
    }

    /// The telegraph pixel at (`row`, `col`), if it is one.
    pub(crate) fn at(&self, row: usize, col: usize) -> Option<&Telegraph> {
        self.in_row(row, col, 1).next().map(|(_, t)| t)
    }
}
