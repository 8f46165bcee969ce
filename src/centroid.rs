//! Centre of gravity with background subtraction, swept over background levels.
//!
//! At level b each pixel contributes v = max(x - b, 0) (the Durham platform's "subtract and
//! clip"). Positions are in pixels from the sub-aperture centre (n-1)/2.

/// Centre of gravity (x, y) in px from the centre of an n x n row-major image; None if the
/// image sums to zero or less.
pub fn cog(img: &[f64], n: usize) -> Option<(f64, f64)> {
    let c = (n as f64 - 1.0) / 2.0;
    let (mut s, mut sx, mut sy) = (0.0, 0.0, 0.0);
    for (i, row) in img.chunks_exact(n).enumerate() {
        for (j, &v) in row.iter().enumerate() {
            s += v;
            sx += v * j as f64;
            sy += v * i as f64;
        }
    }
    (s > 0.0).then(|| (sx / s - c, sy / s - c))
}

/// Background levels (e-), ascending, with reusable scratch for one sub-aperture size.
#[derive(Debug, Clone)]
pub struct BackgroundSweep {
    levels: Vec<f64>,
    n: usize,
    order: Vec<(f64, u32)>,
}

impl BackgroundSweep {
    /// Sweep over `levels` (e-, any order; sorted here) for n x n images.
    pub fn new(mut levels: Vec<f64>, n: usize) -> Self {
        levels.sort_by(f64::total_cmp);
        levels.dedup();
        BackgroundSweep {
            levels,
            n,
            order: Vec::with_capacity(n * n),
        }
    }

    /// The levels (e-), ascending.
    pub fn levels(&self) -> &[f64] {
        &self.levels
    }

    /// Add, for each level, the error of the centre of gravity of max(img - b, 0) against `truth`.
    ///
    /// Pixels are sorted by value once; walking the levels from the top adds each pixel once,
    /// so a frame costs O(n^2 log n + levels) instead of O(n^2 x levels). The sums are
    /// S(b) = sum(v) - b C, Sx(b) = sum(v j) - b sum(j), over the C pixels with v > b. An empty
    /// frame's estimate is the centre, so its error is the distance of the truth from the centre.
    pub fn accumulate(&mut self, img: &[f64], truth: (f64, f64), acc: &mut LevelSums) {
        let n = self.n;
        let c = (n as f64 - 1.0) / 2.0;
        self.order.clear();
        self.order
            .extend(img.iter().enumerate().map(|(k, &v)| (v, k as u32)));
        self.order.sort_unstable_by(|a, b| b.0.total_cmp(&a.0));
        // Distances are O(1) px: plain sqrt is exact enough and much cheaper than hypot.
        let centre_error = (truth.0 * truth.0 + truth.1 * truth.1).sqrt();
        let brightest = self.order.first().map_or(f64::NEG_INFINITY, |p| p.0);
        let first_empty = self.levels.partition_point(|l| *l < brightest);
        acc.tail_sum[first_empty] += centre_error;
        acc.tail_sum_sq[first_empty] += centre_error * centre_error;
        acc.tail_count[first_empty] += 1;
        let (mut sv, mut svx, mut svy, mut cnt, mut sj, mut si) = (0.0, 0.0, 0.0, 0.0, 0.0, 0.0);
        let mut next = 0;
        for k in (0..first_empty).rev() {
            let level = self.levels[k];
            while next < self.order.len() && self.order[next].0 > level {
                let (v, idx) = self.order[next];
                let (i, j) = ((idx as usize / n) as f64, (idx as usize % n) as f64);
                sv += v;
                svx += v * j;
                svy += v * i;
                cnt += 1.0;
                sj += j;
                si += i;
                next += 1;
            }
            let s = sv - level * cnt;
            if s > 0.0 {
                let inv = 1.0 / s;
                let ex = (svx - level * sj) * inv - c - truth.0;
                let ey = (svy - level * si) * inv - c - truth.1;
                let d2 = ex * ex + ey * ey;
                acc.sum[k] += d2.sqrt();
                acc.sum_sq[k] += d2;
            } else {
                // Round-off can leave a vanishing sum just below the brightest pixel.
                acc.sum[k] += centre_error;
                acc.sum_sq[k] += centre_error * centre_error;
                acc.empty[k] += 1;
            }
        }
    }
}

/// Per-level sums of the position error over frames: the sufficient statistics of R(b).
#[derive(Debug, Clone)]
pub struct LevelSums {
    sum: Vec<f64>,
    sum_sq: Vec<f64>,
    empty: Vec<u64>,
    // Levels at and above a frame's brightest pixel all see an empty frame with the same error;
    // they are recorded once at the first such level and spread by `finish` (prefix sums).
    tail_sum: Vec<f64>,
    tail_sum_sq: Vec<f64>,
    tail_count: Vec<u64>,
}

/// Finished per-level statistics: (sum of distances px, sum of squares px^2, empty frames).
pub type LevelTotals = Vec<(f64, f64, u64)>;

impl LevelSums {
    /// Zeroed sums for `levels` levels.
    pub fn new(levels: usize) -> Self {
        LevelSums {
            sum: vec![0.0; levels],
            sum_sq: vec![0.0; levels],
            empty: vec![0; levels],
            tail_sum: vec![0.0; levels + 1],
            tail_sum_sq: vec![0.0; levels + 1],
            tail_count: vec![0; levels + 1],
        }
    }

    /// Add another set of sums (same levels).
    pub fn merge(&mut self, other: &LevelSums) {
        fn add<T: Copy + std::ops::AddAssign>(a: &mut [T], b: &[T]) {
            a.iter_mut().zip(b).for_each(|(x, y)| *x += *y);
        }
        add(&mut self.sum, &other.sum);
        add(&mut self.sum_sq, &other.sum_sq);
        add(&mut self.empty, &other.empty);
        add(&mut self.tail_sum, &other.tail_sum);
        add(&mut self.tail_sum_sq, &other.tail_sum_sq);
        add(&mut self.tail_count, &other.tail_count);
    }

    /// Reset every sum to zero (same levels), keeping the allocations.
    pub fn clear(&mut self) {
        self.sum.fill(0.0);
        self.sum_sq.fill(0.0);
        self.empty.fill(0);
        self.tail_sum.fill(0.0);
        self.tail_sum_sq.fill(0.0);
        self.tail_count.fill(0);
    }

    /// Per-level totals with the empty tails spread over their levels.
    pub fn finish(&self) -> LevelTotals {
        let (mut ts, mut tq, mut tc) = (0.0, 0.0, 0u64);
        (0..self.sum.len())
            .map(|k| {
                ts += self.tail_sum[k];
                tq += self.tail_sum_sq[k];
                tc += self.tail_count[k];
                (self.sum[k] + ts, self.sum_sq[k] + tq, self.empty[k] + tc)
            })
            .collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn known_images_give_known_centroids() {
        // A single bright pixel at (row 1, col 3) of a 4x4: CoG at (3 - 1.5, 1 - 1.5).
        let mut img = vec![0.0; 16];
        img[4 + 3] = 5.0;
        assert_eq!(cog(&img, 4), Some((1.5, -0.5)));
        // Two equal pixels: midpoint.
        img[4 + 1] = 5.0;
        assert_eq!(cog(&img, 4), Some((0.5, -0.5)));
        assert_eq!(cog(&[0.0; 9], 3), None);
    }

    #[test]
    fn sweep_matches_direct_thresholded_cog() {
        let n = 5;
        let img: Vec<f64> = (0..25)
            .map(|k| ((k * 37 % 11) as f64 - 3.0) * 0.7)
            .collect();
        let levels = vec![0.0, 0.5, 1.0, 2.2, 4.0, 4.9, 100.0];
        let mut sweep = BackgroundSweep::new(levels.clone(), n);
        let truth = (0.1, -0.2);
        let mut acc = LevelSums::new(levels.len());
        sweep.accumulate(&img, truth, &mut acc);
        // A second, merged copy doubles every sum.
        let mut twice = acc.clone();
        twice.merge(&acc);
        for ((b, (d, d2, empty)), (d_2, _, e_2)) in
            levels.iter().zip(acc.finish()).zip(twice.finish())
        {
            let v: Vec<f64> = img.iter().map(|x| (x - b).max(0.0)).collect();
            let want = match cog(&v, n) {
                Some((x, y)) => {
                    assert_eq!(empty, 0, "level {b}");
                    (x - truth.0).hypot(y - truth.1)
                }
                None => {
                    assert_eq!(empty, 1, "level {b}");
                    truth.0.hypot(truth.1)
                }
            };
            assert!(
                (d - want).abs() < 1e-12 && (d2 - want * want).abs() < 1e-12,
                "level {b}"
            );
            assert!((d_2 - 2.0 * d).abs() < 1e-12 && e_2 == 2 * empty);
        }
        // Cleared sums are zero and merge like fresh ones.
        twice.clear();
        assert!(twice
            .finish()
            .iter()
            .all(|&(d, d2, e)| d == 0.0 && d2 == 0.0 && e == 0));
        twice.merge(&acc);
        assert_eq!(twice.finish(), acc.finish());
    }
}
