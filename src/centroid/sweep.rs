//! The background sweep: a frame's centre-of-gravity error at every background level at once.

use super::levels::LevelIndex;
use super::sums::LevelSums;

/// Sums over the pixels of one bucket, positions relative to the truth: value, value x
/// column offset, value x row offset, count, column offset, row offset.
type Bin = [f64; 6];

/// Background levels (e-), ascending, with reusable scratch for one sub-aperture size.
#[derive(Debug, Clone)]
pub struct BackgroundSweep {
    levels: Vec<f64>,
    n: usize,
    index: LevelIndex,
    bins: Vec<Bin>,
    /// One bit per bucket that received a pixel this frame.
    occupied: Vec<u64>,
    /// Per level: the thresholded sum S(b) and squared first moment about the truth.
    mass: Vec<f32>,
    moment_sq: Vec<f32>,
    /// Per level: the distance of the centre of gravity from the truth (px).
    dist: Vec<f32>,
}

impl BackgroundSweep {
    /// Sweep over `levels` (e-, any order; sorted here) for n x n images.
    pub fn new(mut levels: Vec<f64>, n: usize) -> Self {
        levels.sort_by(f64::total_cmp);
        levels.dedup();
        let count = levels.len();
        BackgroundSweep {
            index: LevelIndex::new(&levels),
            // Buckets 0..=count, then 8 spare ones for pixels below every level.
            bins: vec![[0.0; 6]; count + 9],
            occupied: vec![0; count / 64 + 1],
            mass: vec![0.0; count],
            moment_sq: vec![0.0; count],
            dist: vec![0.0; count],
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
    /// O(1). Between two occupied buckets the pixels above the level do not change, so the sums
    /// S(b) = sum(v) - b C and Sx(b) = sum(v x) - b sum(x) (x: column offset from the truth;
    /// likewise rows) are linear in b there: a frame costs O(n^2 + levels) and the per-level
    /// loops vectorise. The error at a level is |(Sx, Sy)| / S, computed in single precision
    /// from double-precision sums (relative error below 1e-6; R's standard error is ~1e-3 of
    /// R). An empty frame's estimate is the centre, so its error is the distance of the truth
    /// from the centre.
    pub fn accumulate(&mut self, img: &[f64], truth: (f64, f64), acc: &mut LevelSums) {
        let top = self.bin_pixels(img, truth);
        // Distances are O(1) px: plain sqrt is exact enough and much cheaper than hypot.
        let centre_error = (truth.0 * truth.0 + truth.1 * truth.1).sqrt();
        // Levels at and above the brightest pixel see an empty frame (recorded once).
        acc.tail_sum[top] += centre_error;
        acc.tail_sum_sq[top] += centre_error * centre_error;
        acc.tail_count[top] += 1;
        self.level_sums(top);
        // Two simple loops over equal-length slices, so that both vectorise: distances, then
        // the sums (a level whose sum S(b) is not positive, left by round-off just below the
        // brightest pixel, counts as an empty frame).
        let (mass, moment_sq) = (&self.mass[..top], &self.moment_sq[..top]);
        let dist = &mut self.dist[..top];
        for k in 0..top {
            dist[k] = moment_sq[k].sqrt() / mass[k];
        }
        let (sum, sum_sq, empty) = (
            &mut acc.sum[..top],
            &mut acc.sum_sq[..top],
            &mut acc.empty[..top],
        );
        let centre_sq = centre_error * centre_error;
        for k in 0..top {
            let lit = mass[k] > 0.0;
            let d = f64::from(dist[k]);
            sum[k] += if lit { d } else { centre_error };
            sum_sq[k] += if lit { d * d } else { centre_sq };
            empty[k] += u64::from(!lit);
        }
    }

    /// Put every pixel of `img` in its bucket (positions relative to `truth`, px from the
    /// centre); the highest bucket used, which is the number of levels below the brightest
    /// pixel.
    fn bin_pixels(&mut self, img: &[f64], truth: (f64, f64)) -> usize {
        let n = self.n;
        let c = (n as f64 - 1.0) / 2.0;
        let (tx, ty) = (truth.0 + c, truth.1 + c);
        let mut top = 0;
        // Occupancy of the first 128 buckets (the low levels, where most pixels fall) is kept
        // in registers: a read-modify-write of memory per pixel would chain every pixel to the
        // previous one.
        let (mut low, mut mid) = (0u64, 0u64);
        let junk = self.levels.len() + 1;
        for (i, row) in img.chunks_exact(n).enumerate() {
            let y = i as f64 - ty;
            for (j, &v) in row.iter().enumerate() {
                let k = self.index.count_below(v);
                // A pixel below every level counts nowhere; it is added to one of 8 spare
                // buckets in turn, without a branch (at low light about half the pixels are
                // such, unpredictably) and without chaining them all through one bucket.
                let slot = if k == 0 { junk + (j & 7) } else { k };
                let x = j as f64 - tx;
                let b = &mut self.bins[slot];
                b[0] += v;
                b[1] += v * x;
                b[2] += v * y;
                b[3] += 1.0;
                b[4] += x;
                b[5] += y;
                low |= u64::from(k < 64) << (k % 64);
                mid |= u64::from((64..128).contains(&k)) << (k % 64);
                if k >= 128 {
                    self.occupied[k / 64] |= 1 << (k % 64);
                }
                top = top.max(k);
            }
        }
        self.occupied[0] |= low;
        if let Some(w) = self.occupied.get_mut(1) {
            *w |= mid;
        }
        self.bins[junk..].fill([0.0; 6]);
        top
    }

    /// Fill `mass` and `moment_sq` for levels 0..top from the occupied buckets (cleared).
    fn level_sums(&mut self, top: usize) {
        let mut run: Bin = [0.0; 6];
        let mut hi = top;
        for w in (0..=top / 64).rev() {
            let mut word = std::mem::take(&mut self.occupied[w]);
            while word != 0 {
                let bit = 63 - word.leading_zeros() as usize;
                word &= !(1u64 << bit);
                let m = w * 64 + bit;
                if m == 0 {
                    break;
                }
                // Levels m..hi see the pixels of buckets above m only.
                self.segment(&run, m..hi);
                for (r, b) in run.iter_mut().zip(std::mem::take(&mut self.bins[m])) {
                    *r += b;
                }
                hi = m;
            }
        }
        self.segment(&run, 0..hi);
    }

    /// Levels `range` with the same pixels above them, summed in `run`.
    fn segment(&mut self, run: &Bin, range: std::ops::Range<usize>) {
        let [a0, a1, a2, b0, b1, b2] = *run;
        for ((l, s), q) in self.levels[range.clone()]
            .iter()
            .zip(&mut self.mass[range.clone()])
            .zip(&mut self.moment_sq[range])
        {
            let x = a1 - l * b1;
            let y = a2 - l * b2;
            *s = (a0 - l * b0) as f32;
            *q = (x * x + y * y) as f32;
        }
    }
}
