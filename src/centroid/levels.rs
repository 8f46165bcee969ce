//! Which background levels lie below a pixel value, in O(1): the sweep's bucket index.

/// Most cells of the lookup grid (128 KiB): small enough to stay in the L2 cache.
const MAX_CELLS: usize = 8192;

/// Counts the levels strictly below a value with a uniform grid of cells over the levels'
/// range: a cell holds the number of levels in the cells below it and its own first level, so
/// one load and one comparison answer unless the cell holds several levels (only the last
/// cell, when the range needs more than [`MAX_CELLS`] cells).
#[derive(Debug, Clone)]
pub(super) struct LevelIndex {
    levels: Vec<f64>,
    lo: f64,
    inv_width: f64,
    last_cell: f64,
    cells: Vec<Cell>,
}

/// One cell of the grid.
#[derive(Debug, Clone, Copy)]
struct Cell {
    /// The cell's first level, or +infinity when it has none.
    first: f64,
    /// Levels in the cells below.
    below: u32,
    /// Levels in this cell.
    count: u32,
}

impl LevelIndex {
    /// Index of `levels` (ascending, distinct, finite).
    pub(super) fn new(levels: &[f64]) -> Self {
        let (lo, hi) = match (levels.first(), levels.last()) {
            (Some(&lo), Some(&hi)) => (lo, hi),
            _ => (0.0, 0.0),
        };
        let range = hi - lo;
        let closest = levels
            .windows(2)
            .map(|w| w[1] - w[0])
            .fold(f64::INFINITY, f64::min);
        // Cells as wide as the closest levels, so no cell holds two levels, up to MAX_CELLS of
        // them; values beyond fall in the last cell, which then holds the rest of the levels
        // (searched by bisection: bright pixels only). Wider cells over the whole range would
        // put several of the automatic grid's fine levels in the cells of most dark pixels.
        let width = closest;
        let (count, inv_width) = if range > 0.0 && width > 0.0 {
            (((range / width) as usize + 1).min(MAX_CELLS), 1.0 / width)
        } else {
            (1, 0.0)
        };
        let mut index = LevelIndex {
            levels: levels.to_vec(),
            lo,
            inv_width,
            last_cell: (count - 1) as f64,
            cells: Vec::new(),
        };
        let empty = Cell {
            first: f64::INFINITY,
            below: 0,
            count: 0,
        };
        let mut cells = vec![empty; count];
        for (k, &l) in levels.iter().enumerate() {
            let cell = &mut cells[index.cell(l)];
            if cell.count == 0 {
                cell.first = l;
                cell.below = k as u32;
            }
            cell.count += 1;
        }
        // Empty cells: every level of the cells below.
        let mut below = 0;
        for cell in &mut cells {
            if cell.count == 0 {
                cell.below = below;
            }
            below = cell.below + cell.count;
        }
        index.cells = cells;
        index
    }

    /// Cell of value `v` (values below the first level, and NaN, in cell 0); monotone in `v`,
    /// so a level in a lower cell is below `v` and one in a higher cell above it.
    #[inline]
    pub(super) fn cell(&self, v: f64) -> usize {
        // `max` sends NaN to 0; the value is then finite and within 0..cells.
        let t = ((v - self.lo) * self.inv_width)
            .max(0.0)
            .min(self.last_cell);
        // SAFETY: t is finite, >= 0 and at most the last cell index (< 8192), so it fits.
        // (i32: one conversion instruction; an unsigned one takes several.)
        unsafe { t.to_int_unchecked::<i32>() as usize }
    }

    /// Number of levels strictly below `v` (0 for NaN).
    #[cfg(test)]
    pub(super) fn count_below(&self, v: f64) -> usize {
        self.count_below_in(self.cell(v), v)
    }

    /// [`Self::count_below`] with `v`'s cell ([`Self::cell`]) already found: a frame's cells
    /// are computed in one loop that vectorises.
    #[inline]
    pub(super) fn count_below_in(&self, cell: usize, v: f64) -> usize {
        let cell = self.cells[cell];
        let k = cell.below as usize + usize::from(cell.first < v);
        if cell.count <= 1 {
            return k;
        }
        let end = (cell.below + cell.count) as usize;
        k + self.levels[k..end].partition_point(|l| *l < v)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn check(levels: &[f64], values: impl Iterator<Item = f64>) {
        let index = LevelIndex::new(levels);
        for v in values {
            let want = levels.partition_point(|l| *l < v);
            assert_eq!(index.count_below(v), want, "{v} in {levels:?}");
        }
    }

    #[test]
    fn counts_levels_below_like_a_binary_search() {
        // The automatic grid's shape (fine, coarser, then geometric), values on and beside
        // every level and far outside; a grid wider than the cell limit; one level; uneven.
        let mut auto: Vec<f64> = (0..20).map(|k| k as f64 * 0.05).collect();
        auto.extend((0..20).map(|k| 1.0 + k as f64 * 0.1));
        let mut b = 40.0;
        while b < 4000.0 {
            auto.push(b);
            b *= 1.05;
        }
        for levels in [
            auto,
            (0..20_000).map(|k| k as f64 * 0.01).collect(),
            (0..20)
                .map(|k| k as f64 * 0.05)
                .chain([5e3, 1e4, 2e4])
                .collect(),
            vec![0.0],
            vec![-1.0, 0.0, 1e-9, 2e-9, 3.0, 1e6],
        ] {
            let around = levels
                .iter()
                .flat_map(|&l| [l, l.next_down(), l.next_up(), l - 0.013, l + 0.013]);
            check(&levels, around.chain([-1e300, 1e300, 0.0, f64::NAN]));
        }
    }
}
