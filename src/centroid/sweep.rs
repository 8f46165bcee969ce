//! The background sweep: a frame's centre-of-gravity error at every background level at once.

use super::levels::LevelIndex;
use super::sums::LevelSums;

/// Sums over the pixels of one bucket, positions relative to the truth: value, value x
/// column offset, value x row offset, 0, then count, column offset, row offset, 0 (each
/// pixel's terms multiplied by its weight w; count and offsets by its threshold scale s too).
/// Two halves of four lanes with the same layout, so a pixel's terms, the running sums and a
/// level's (S, Sx, Sy) = first half - level x second half are each one vector operation.
/// Aligned on a cache line, so that no half straddles two lines (a split load or store costs
/// several times a whole one).
#[derive(Debug, Clone, Copy, Default)]
#[repr(C, align(64))]
struct Bin([f64; 8]);

/// A pixel's terms in one half of a [`Bin`]: (1, column offset, row offset, 0) times `f`.
#[inline(always)]
fn half(f: f64, x: f64, y: f64) -> [f64; 4] {
    [f, f * x, f * y, 0.0]
}

/// Per-pixel terms of a sweep. At level l pixel i contributes w_i max(x_i - l s_i, 0): a
/// weight w (0 leaves the pixel out) and a threshold scale s (the level is in units of s),
/// and the centroid's x and y are multiplied by `gain` (a bias correction). The plain sweep has w = s =
/// gain = 1, constants the compiler folds away.
pub trait PixelTerms {
    /// Weight of pixel `i` (>= 0).
    fn weight(&self, i: usize) -> f64;
    /// Threshold scale of pixel `i` (> 0).
    fn scale(&self, i: usize) -> f64;
    /// Factors applied to the centroid's (x, y) (dimensionless).
    fn gain(&self) -> (f64, f64);
}

/// The plain centre of gravity: w = s = gain = 1.
#[derive(Debug, Clone, Copy)]
pub struct Plain;

impl PixelTerms for Plain {
    #[inline(always)]
    fn weight(&self, _: usize) -> f64 {
        1.0
    }
    #[inline(always)]
    fn scale(&self, _: usize) -> f64 {
        1.0
    }
    #[inline(always)]
    fn gain(&self) -> (f64, f64) {
        (1.0, 1.0)
    }
}

/// Per-pixel weights (s = 1) and a centroid gain.
#[derive(Debug, Clone, Copy)]
pub struct Weighted<'a> {
    /// Weight per pixel (>= 0), row-major.
    pub weight: &'a [f64],
    /// Factors applied to the centroid's (x, y).
    pub gain: (f64, f64),
}

impl PixelTerms for Weighted<'_> {
    #[inline(always)]
    fn weight(&self, i: usize) -> f64 {
        self.weight[i]
    }
    #[inline(always)]
    fn scale(&self, _: usize) -> f64 {
        1.0
    }
    #[inline(always)]
    fn gain(&self) -> (f64, f64) {
        self.gain
    }
}

/// Per-pixel threshold scales (w = 1, gain = 1): levels in units of each pixel's own scale.
#[derive(Debug, Clone, Copy)]
pub struct Scaled<'a> {
    /// Threshold scale per pixel (> 0), row-major.
    pub scale: &'a [f64],
}

impl PixelTerms for Scaled<'_> {
    #[inline(always)]
    fn weight(&self, _: usize) -> f64 {
        1.0
    }
    #[inline(always)]
    fn scale(&self, i: usize) -> f64 {
        self.scale[i]
    }
    #[inline(always)]
    fn gain(&self) -> (f64, f64) {
        (1.0, 1.0)
    }
}

/// Background levels (e-), ascending, with reusable scratch for one sub-aperture size.
#[derive(Debug, Clone)]
pub struct BackgroundSweep {
    levels: Vec<f64>,
    n: usize,
    index: LevelIndex,
    bins: Vec<Bin>,
    /// Per frame: (row, column, bucket) of the pixels above the first level, in pixel order.
    lit: Vec<(u16, u16, u32)>,
    /// Per frame: each pixel's cell in the level index.
    cells: Vec<u32>,
    /// Per level: the thresholded sum S(b) and squared first moment about the truth.
    mass: Vec<f32>,
    moment_sq: Vec<f32>,
    /// Per level: the distance of the centre of gravity from the truth (px).
    dist: Vec<f32>,
    /// The CPU has AVX2 (the per-level loops run twice as wide).
    avx2: bool,
}

impl BackgroundSweep {
    /// Sweep over `levels` (e-, any order; sorted here) for n x n images.
    pub fn new(mut levels: Vec<f64>, n: usize) -> Self {
        levels.sort_by(f64::total_cmp);
        levels.dedup();
        let count = levels.len();
        BackgroundSweep {
            index: LevelIndex::new(&levels),
            // Buckets 0..=count (bucket 0, below every level, stays empty).
            bins: vec![Bin::default(); count + 1],
            lit: vec![(0, 0, 0); n * n],
            cells: vec![0; n * n],
            mass: vec![0.0; count],
            moment_sq: vec![0.0; count],
            dist: vec![0.0; count],
            levels,
            n,
            #[cfg(target_arch = "x86_64")]
            avx2: std::arch::is_x86_feature_detected!("avx2"),
            #[cfg(not(target_arch = "x86_64"))]
            avx2: false,
        }
    }

    /// The levels (e-), ascending.
    pub fn levels(&self) -> &[f64] {
        &self.levels
    }

    /// Add, for each level, the error of the centre of gravity of max(img - b, 0) against `truth`.
    ///
    /// Each pixel goes to the bucket of the levels below it (k levels below: bucket k), found in
    /// O(1). The pixels above level l are those of the buckets above l, so one pass down the
    /// levels accumulates their sums and gives S(b) = sum(v) - b C and Sx(b) = sum(v x) -
    /// b sum(x) (x: column offset from the truth; likewise rows): a frame costs O(n^2 +
    /// levels), without a sort. The error at a level is |(Sx, Sy)| / S, computed in single precision
    /// from double-precision sums (relative error below 1e-6; R's standard error is ~1e-3 of
    /// R). An empty frame's estimate is the centre, so its error is the distance of the truth
    /// from the centre.
    pub fn accumulate(&mut self, img: &[f64], truth: (f64, f64), acc: &mut LevelSums) {
        self.accumulate_terms(img, &Plain, truth, acc)
    }

    /// [`Self::accumulate`] for the centroid of w_i max(x_i - b s_i, 0) times a gain, the
    /// terms given by `terms` ([`PixelTerms`]): each pixel goes to the bucket of x_i / s_i, and
    /// the positions are taken from truth / gain (per axis), so that gain x centroid - truth =
    /// gain x (centroid - truth / gain). A pixel of weight 0 never contributes.
    pub fn accumulate_terms<T: PixelTerms>(
        &mut self,
        img: &[f64],
        terms: &T,
        truth: (f64, f64),
        acc: &mut LevelSums,
    ) {
        #[cfg(target_arch = "x86_64")]
        if self.avx2 {
            // SAFETY: `avx2` is set only when the CPU has AVX2 (checked in `new`).
            return unsafe { self.accumulate_avx2(img, terms, truth, acc) };
        }
        self.accumulate_inline(img, terms, truth, acc)
    }

    /// [`Self::accumulate_terms`] compiled for AVX2: the same operations in the same order (no
    /// fused multiply-add), so the results are identical bit for bit, with wider vectors.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2")]
    unsafe fn accumulate_avx2<T: PixelTerms>(
        &mut self,
        img: &[f64],
        terms: &T,
        truth: (f64, f64),
        acc: &mut LevelSums,
    ) {
        self.accumulate_inline(img, terms, truth, acc)
    }

    #[inline(always)]
    fn accumulate_inline<T: PixelTerms>(
        &mut self,
        img: &[f64],
        terms: &T,
        truth: (f64, f64),
        acc: &mut LevelSums,
    ) {
        let g = terms.gain();
        let top = self.bin_pixels(img, terms, (truth.0 / g.0, truth.1 / g.1));
        // Distances are O(1) px: plain sqrt is exact enough and much cheaper than hypot.
        let centre_error = (truth.0 * truth.0 + truth.1 * truth.1).sqrt();
        // Levels at and above the brightest pixel see an empty frame (recorded once).
        acc.tail_sum[top] += centre_error;
        acc.tail_sum_sq[top] += centre_error * centre_error;
        acc.tail_count[top] += 1;
        self.level_sums(top, g);
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
            // Selects, not branches: left to itself the compiler turns each into a pair of
            // masked loads and stores, which are microcoded and ~10x slower on AMD Zen.
            sum[k] += std::hint::select_unpredictable(lit, d, centre_error);
            sum_sq[k] += std::hint::select_unpredictable(lit, d * d, centre_sq);
            empty[k] += u64::from(!lit);
        }
    }

    /// Put every pixel of `img` in its bucket (positions relative to `truth`, px from the
    /// centre); the highest bucket used, which is the number of levels below the brightest
    /// pixel.
    ///
    /// Two passes: first every pixel's bucket (its cell in the level index for all pixels in a
    /// loop that vectorises, then independent look-ups that pipeline), keeping
    /// the pixels above the first level (at low light about half are not, unpredictably: kept
    /// without a branch); then their sums, in pixel order. With the buckets known ahead, a
    /// pixel's load is not held behind the previous pixel's store while its address is
    /// computed.
    #[inline(always)]
    fn bin_pixels<T: PixelTerms>(&mut self, img: &[f64], terms: &T, truth: (f64, f64)) -> usize {
        let n = self.n;
        let c = (n as f64 - 1.0) / 2.0;
        let (tx, ty) = (truth.0 + c, truth.1 + c);
        let (mut top, mut kept) = (0, 0);
        let (lit, cells) = (&mut self.lit[..n * n], &mut self.cells[..n * n]);
        for (i, (&v, c)) in img[..n * n].iter().zip(cells.iter_mut()).enumerate() {
            *c = self.index.cell(v / terms.scale(i)) as u32;
        }
        for (row, line) in img[..n * n].chunks_exact(n).enumerate() {
            for (col, &v) in line.iter().enumerate() {
                let i = row * n + col;
                // A pixel of weight 0 counts nowhere, like one below every level.
                let k = if terms.weight(i) > 0.0 {
                    self.index
                        .count_below_in(cells[i] as usize, v / terms.scale(i))
                } else {
                    0
                };
                // SAFETY: kept <= i < n * n = lit.len().
                *unsafe { lit.get_unchecked_mut(kept) } = (row as u16, col as u16, k as u32);
                kept += usize::from(k > 0);
                top = top.max(k);
            }
        }
        for &(row, col, k) in &lit[..kept] {
            let (row, col) = (usize::from(row), usize::from(col));
            let i = row * n + col;
            let (w, s, v) = (terms.weight(i), terms.scale(i), img[i]);
            let (x, y) = (col as f64 - tx, row as f64 - ty);
            // SAFETY: 0 < k <= levels (count_below) < bins.len().
            let b = unsafe { self.bins.get_unchecked_mut(k as usize) };
            let (a, c) = (half(w * v, x, y), half(w * s, x, y));
            for (t, d) in b.0.iter_mut().zip(a.into_iter().chain(c)) {
                *t += d;
            }
        }
        top
    }

    /// Fill `mass` and `moment_sq` for levels 0..top from the buckets (cleared), the first
    /// moments multiplied by the gains.
    #[inline(always)]
    fn level_sums(&mut self, top: usize, (gx, gy): (f64, f64)) {
        let mut run = [0.0; 8];
        let gain = [1.0, gx, gy, 0.0];
        for l in (0..top).rev() {
            // Level l sees the pixels of buckets above it.
            let bin = std::mem::take(&mut self.bins[l + 1]);
            for (r, b) in run.iter_mut().zip(bin.0) {
                *r += b;
            }
            let lv = self.levels[l];
            // (S, Sx, Sy) at this level, the moments times their gains (S times 1).
            let mut t = [0.0; 4];
            for i in 0..4 {
                t[i] = (run[i] - lv * run[i + 4]) * gain[i];
            }
            self.mass[l] = t[0] as f32;
            self.moment_sq[l] = (t[1] * t[1] + t[2] * t[2]) as f32;
        }
    }
}
