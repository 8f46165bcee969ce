//! Which background levels lie below a pixel value, in O(1): the sweep's bucket index.

/// Most cells of the lookup grid (32 KiB): small enough to stay in the L1 cache.
const MAX_CELLS: usize = 8192;

/// Flag of a cell entry: the cell holds more than one level.
const MULTI: u32 = 1 << 31;

/// Counts the levels strictly below a value with a uniform grid of cells over the levels'
/// range: a cell holds the number of levels in the cells below it, `b`, so that the levels
/// below a value of the cell are `b`, plus one when level `b` (the cell's own level, or one in
/// a higher cell, which is above the value) is below it: one small load from the grid, one
/// from the levels and one comparison, unless the cell holds several levels (the last cell,
/// when the range needs more than [`MAX_CELLS`] cells, or two levels that round into one).
#[derive(Debug, Clone)]
pub(super) struct LevelIndex {
    /// The levels, then +infinity (the level "above" every cell past the last level).
    levels: Vec<f64>,
    lo: f64,
    inv_width: f64,
    last_cell: f64,
    /// Per cell: the levels in the cells below it, with [`MULTI`] when it holds several.
    cells: Vec<u32>,
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
            levels: levels.iter().copied().chain([f64::INFINITY]).collect(),
            lo,
            inv_width,
            last_cell: (count - 1) as f64,
            cells: Vec::new(),
        };
        let mut in_cell = vec![0u32; count];
        for &l in levels {
            in_cell[index.cell(l)] += 1;
        }
        let mut below = 0;
        index.cells = in_cell
            .iter()
            .map(|&n| {
                let entry = below | if n > 1 { MULTI } else { 0 };
                below += n;
                entry
            })
            .collect();
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
        // SAFETY: the cell is `Self::cell`'s.
        unsafe { self.count_below_in(self.cell(v), v) }
    }

    /// The number of levels strictly below `v` (as the tests' `count_below`) with `v`'s cell
    /// ([`Self::cell`]) already found: a frame's cells are computed in one loop that
    /// vectorises. The two look-ups go unchecked: with their bounds checks the sweep's pixel
    /// loop ran out of registers and reloaded the tables' lengths and addresses for every
    /// pixel.
    ///
    /// # Safety
    /// `cell` is [`Self::cell`] of some value (so less than the number of cells).
    #[inline]
    pub(super) unsafe fn count_below_in(&self, cell: usize, v: f64) -> usize {
        debug_assert!(cell < self.cells.len());
        // SAFETY: the caller's `cell` is a cell (`Self::cell` is at most the last).
        let entry = unsafe { *self.cells.get_unchecked(cell) };
        let below = (entry & !MULTI) as usize;
        // SAFETY: below <= levels (the levels in lower cells), and `self.levels` has one more
        // element (+infinity).
        let k = below + usize::from(unsafe { *self.levels.get_unchecked(below) } < v);
        if entry & MULTI == 0 {
            return k;
        }
        let end = self
            .cells
            .get(cell + 1)
            .map_or(self.levels.len() - 1, |&e| (e & !MULTI) as usize);
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
