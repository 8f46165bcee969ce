//! The background sweep: a frame's centre-of-gravity error at every background level at once.

use super::levels::LevelIndex;
use super::sums::LevelSums;

/// Sums over the pixels of one bucket: value, value x column, value x row, count, column, row.
type Bin = [f64; 6];

/// Background levels (e-), ascending, with reusable scratch for one sub-aperture size.
#[derive(Debug, Clone)]
pub struct BackgroundSweep {
    levels: Vec<f64>,
    n: usize,
    index: LevelIndex,
    bins: Vec<Bin>,
}

impl BackgroundSweep {
    /// Sweep over `levels` (e-, any order; sorted here) for n x n images.
    pub fn new(mut levels: Vec<f64>, n: usize) -> Self {
        levels.sort_by(f64::total_cmp);
        levels.dedup();
        BackgroundSweep {
            index: LevelIndex::new(&levels),
            bins: vec![[0.0; 6]; levels.len() + 1],
            levels,
            n,
        }
    }

    /// The levels (e-), ascending.
    pub fn levels(&self) -> &[f64] {
        &self.levels
    }

    /// Add, for each level, the error of the centre of gravity of max(img - b, 0) against `truth`.
    ///
    /// Each pixel goes to the bucket of the levels below it (k levels below: bucket k), found in
    /// O(1); walking the buckets from the top then adds each pixel once, so a frame costs
    /// O(n^2 + levels) rather than O(n^2 x levels) or a sort. The sums are S(b) = sum(v) - b C,
    /// Sx(b) = sum(v j) - b sum(j), over the C pixels with v > b. An empty frame's estimate is
    /// the centre, so its error is the distance of the truth from the centre.
    pub fn accumulate(&mut self, img: &[f64], truth: (f64, f64), acc: &mut LevelSums) {
        let n = self.n;
        let mut top = 0;
        for (i, row) in img.chunks_exact(n).enumerate() {
            for (j, &v) in row.iter().enumerate() {
                let k = self.index.count_below(v);
                if k > 0 {
                    let (i, j) = (i as f64, j as f64);
                    let b = &mut self.bins[k];
                    b[0] += v;
                    b[1] += v * j;
                    b[2] += v * i;
                    b[3] += 1.0;
                    b[4] += j;
                    b[5] += i;
                    top = top.max(k);
                }
            }
        }
        // Distances are O(1) px: plain sqrt is exact enough and much cheaper than hypot.
        let centre_error = (truth.0 * truth.0 + truth.1 * truth.1).sqrt();
        // Levels at and above the brightest pixel see an empty frame (recorded once).
        acc.tail_sum[top] += centre_error;
        acc.tail_sum_sq[top] += centre_error * centre_error;
        acc.tail_count[top] += 1;
        let c = (n as f64 - 1.0) / 2.0;
        let (tx, ty) = (truth.0 + c, truth.1 + c);
        let mut run: Bin = [0.0; 6];
        for k in (0..top).rev() {
            // Bucket k + 1 holds the pixels whose value lies in (level k, level k + 1].
            let bin = std::mem::take(&mut self.bins[k + 1]);
            for (r, b) in run.iter_mut().zip(bin) {
                *r += b;
            }
            let [sv, svx, svy, cnt, sj, si] = run;
            let level = self.levels[k];
            let s = sv - level * cnt;
            if s > 0.0 {
                let inv = 1.0 / s;
                let ex = (svx - level * sj) * inv - tx;
                let ey = (svy - level * si) * inv - ty;
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
