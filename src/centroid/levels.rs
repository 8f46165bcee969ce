//! Which background levels lie below a pixel value, in O(1): the sweep's bucket index.

/// Most cells of the lookup grid (32 KiB of `u32`): small enough to stay in the L1/L2 cache.
const MAX_CELLS: usize = 8192;

/// Counts the levels strictly below a value with a uniform grid of cells over the levels'
/// range: cell c starts at `base[c]` levels, and only the few levels inside the value's own
/// cell are compared (at most one when the cell is no wider than the closest pair of levels).
#[derive(Debug, Clone)]
pub(super) struct LevelIndex {
    /// The levels, then +infinity (so one comparison past the last level needs no check).
    padded: Vec<f64>,
    lo: f64,
    inv_width: f64,
    base: Vec<u32>,
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
        let width = closest.max(range / MAX_CELLS as f64);
        let (cells, inv_width) = if range > 0.0 && width > 0.0 {
            (((range / width) as usize + 1).min(MAX_CELLS), 1.0 / width)
        } else {
            (1, 0.0)
        };
        let mut index = LevelIndex {
            padded: levels.iter().copied().chain([f64::INFINITY]).collect(),
            lo,
            inv_width,
            base: Vec::new(),
        };
        // base[c] = levels whose cell is below c; the last entry holds them all.
        let mut base = vec![0u32; cells + 1];
        for &l in levels {
            base[index.cell(l, cells) + 1] += 1;
        }
        for c in 1..=cells {
            base[c] += base[c - 1];
        }
        index.base = base;
        index
    }

    /// Cell of value `v` among `cells` (values below the first level, and NaN, in cell 0);
    /// monotone in `v`, so a level in a lower cell is below `v` and one in a higher cell above.
    #[inline]
    fn cell(&self, v: f64, cells: usize) -> usize {
        (((v - self.lo) * self.inv_width).max(0.0) as usize).min(cells - 1)
    }

    /// Number of levels strictly below `v` (0 for NaN).
    #[inline]
    pub(super) fn count_below(&self, v: f64) -> usize {
        let c = self.cell(v, self.base.len() - 1);
        let (mut k, end) = (self.base[c] as usize, self.base[c + 1] as usize);
        // A cell holds at most one level unless levels are closer than the cell width: one
        // branch-free step, then a loop that rarely runs (`padded[end]` exists).
        k += usize::from((k < end) & (self.padded[k] < v));
        while k < end && self.padded[k] < v {
            k += 1;
        }
        k
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
