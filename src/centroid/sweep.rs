//! The background sweep: a frame's centre-of-gravity error at every background level at once.

use super::centroider::CentroidFrame;
use super::levels::LevelIndex;
use super::sums::{centre_terms, error_terms, ErrorTerms, LaneSums, LevelSums, LANES, TERMS};

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

/// A bucket's sums for a batch of frames, one frame per lane: the six sums of a [`Bin`]
/// (value, value x column, value x row, count, column, row), each across the frames.
#[derive(Debug, Clone, Copy, Default)]
#[repr(C, align(64))]
struct LaneBin([[f64; LANES]; 6]);

/// `a` if `pick`, else `b`, by masking their bits: no branch and no masked memory access
/// whatever the compiler's choice, and lanes of a vector select independently.
#[inline(always)]
fn select(pick: bool, a: f64, b: f64) -> f64 {
    let mask = u64::from(pick).wrapping_neg();
    f64::from_bits((a.to_bits() & mask) | (b.to_bits() & !mask))
}

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
    /// Per frame: the pixels above the first level, in pixel order.
    lit: Vec<LitPixel>,
    /// Per frame: each pixel's cell in the level index.
    cells: Vec<u32>,
    /// Per level: the thresholded sum S(b) and squared first moment about the truth.
    mass: Vec<f32>,
    moment_sq: Vec<f32>,
    /// Per level: the first moments (Sx, Sy), then the error vector (Sx, Sy) / S (px).
    ex: Vec<f32>,
    ey: Vec<f32>,
    /// Per level: the distance of the centre of gravity from the truth (px).
    dist: Vec<f32>,
    /// The same for a batch of frames (allocated on the first batch).
    batch: BatchScratch,
    /// The CPU has AVX2 (the per-level loops run twice as wide).
    avx2: bool,
}

/// A batch's buckets and per-level values, one frame per lane.
#[derive(Debug, Clone, Default)]
struct BatchScratch {
    bins: Vec<LaneBin>,
    mass: Vec<[f32; LANES]>,
    moment_sq: Vec<[f32; LANES]>,
    ex: Vec<[f32; LANES]>,
    ey: Vec<[f32; LANES]>,
    dist: Vec<[f32; LANES]>,
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
            lit: vec![LitPixel(0); n * n],
            cells: vec![0; n * n],
            mass: vec![0.0; count],
            moment_sq: vec![0.0; count],
            ex: vec![0.0; count],
            ey: vec![0.0; count],
            dist: vec![0.0; count],
            batch: BatchScratch::default(),
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

    /// [`Self::accumulate`] for each of `frames` (the plain centre of gravity; at most
    /// [`LANES`] frames): the same error per frame and level, summed per lane. A full batch
    /// is swept once for all its frames, one per vector lane: each level's sums, distances
    /// and additions are one vector operation for [`LANES`] frames (a level of one frame
    /// costs the same operations, one lane wide). A shorter batch is added frame by frame.
    pub fn accumulate_batch(&mut self, frames: &[CentroidFrame], acc: &mut LevelSums) {
        if frames.len() != LANES {
            for f in frames {
                self.accumulate(f.image_e, f.truth_px, acc);
            }
            return;
        }
        #[cfg(target_arch = "x86_64")]
        if self.avx2 {
            // SAFETY: `avx2` is set only when the CPU has AVX2 (checked in `new`).
            return unsafe { self.accumulate_batch_avx2(frames, acc) };
        }
        self.accumulate_batch_inline(frames, acc)
    }

    /// [`Self::accumulate_batch`] compiled for AVX2 (the same operations in the same order).
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2")]
    unsafe fn accumulate_batch_avx2(&mut self, frames: &[CentroidFrame], acc: &mut LevelSums) {
        self.accumulate_batch_inline(frames, acc)
    }

    #[inline(always)]
    fn accumulate_batch_inline(&mut self, frames: &[CentroidFrame], acc: &mut LevelSums) {
        let count = self.levels.len();
        if self.batch.bins.is_empty() {
            self.batch = BatchScratch {
                bins: vec![LaneBin::default(); count + 1],
                mass: vec![[0.0; LANES]; count],
                moment_sq: vec![[0.0; LANES]; count],
                ex: vec![[0.0; LANES]; count],
                ey: vec![[0.0; LANES]; count],
                dist: vec![[0.0; LANES]; count],
            };
        }
        // The empty frame's terms per lane, term-major (one vector per term).
        let (mut top, mut centre) = (0, [[0.0; LANES]; TERMS]);
        for (lane, f) in frames.iter().enumerate() {
            let t = f.truth_px;
            let c = centre_terms(t);
            for q in 0..TERMS {
                centre[q][lane] = c[q];
            }
            top = top.max(self.bin_pixels_lane(f.image_e, t, lane));
        }
        // Levels at and above the brightest pixel of the batch see empty frames (recorded once
        // per frame); below it, a frame above its own brightest pixel has every sum exactly 0:
        // not lit, so empty there too, as in `accumulate`.
        for lane in 0..LANES {
            acc.add_tail(top, &centre.map(|t| t[lane]));
        }
        // Disjoint slices, so that the compiler keeps the running sums in registers.
        let BatchScratch {
            bins,
            mass,
            moment_sq,
            ex,
            ey,
            dist,
        } = &mut self.batch;
        let (bins, mass, moment_sq) = (&mut bins[..=top], &mut mass[..top], &mut moment_sq[..top]);
        let (ex, ey) = (&mut ex[..top], &mut ey[..top]);
        let levels = &self.levels[..top];
        let mut run = [[0.0; LANES]; 6];
        for l in (0..top).rev() {
            let bin = std::mem::take(&mut bins[l + 1]);
            for (r, add) in run.iter_mut().zip(bin.0) {
                for f in 0..LANES {
                    r[f] += add[f];
                }
            }
            let lv = levels[l];
            let (mut m, mut q) = ([0.0f32; LANES], [0.0f32; LANES]);
            let (mut mx, mut my) = ([0.0f32; LANES], [0.0f32; LANES]);
            for f in 0..LANES {
                // As `level_sums` with gains 1: S, Sx, Sy = first half - level x second.
                let x = run[1][f] - lv * run[4][f];
                let y = run[2][f] - lv * run[5][f];
                m[f] = (run[0][f] - lv * run[3][f]) as f32;
                q[f] = (x * x + y * y) as f32;
                mx[f] = x as f32;
                my[f] = y as f32;
            }
            mass[l] = m;
            moment_sq[l] = q;
            ex[l] = mx;
            ey[l] = my;
        }
        let dist = &mut dist[..top];
        for ((((d, m), q), x), y) in dist
            .iter_mut()
            .zip(&*mass)
            .zip(&*moment_sq)
            .zip(ex.iter_mut())
            .zip(ey.iter_mut())
        {
            for f in 0..LANES {
                d[f] = q[f].sqrt() / m[f];
                // One division for both components (the distance keeps its own, as before).
                let inv = 1.0 / m[f];
                x[f] *= inv;
                y[f] *= inv;
            }
        }
        let lanes = &mut acc.lanes_mut()[..top];
        let per_level = PerLevel { mass, dist, ex, ey };
        #[cfg(target_arch = "x86_64")]
        if self.avx2 {
            // SAFETY: `avx2` is set only when the CPU has AVX2 (checked in `new`).
            return unsafe { add_lanes_avx2(lanes, &per_level, &centre) };
        }
        add_lanes(lanes, &per_level, &centre);
    }

    /// [`Self::bin_pixels`] for the plain centre of gravity into lane `lane` of the batch's
    /// buckets (the same sums, in the same order).
    #[inline(always)]
    fn bin_pixels_lane(&mut self, img: &[f64], truth: (f64, f64), lane: usize) -> usize {
        let origin = self.origin(truth);
        let (kept, top) = self.lit_pixels(img, &Plain);
        let bins = &mut self.batch.bins;
        sum_lit(&self.lit[..kept], img, self.n, origin, &Plain, |k, t| {
            // SAFETY: 0 < k <= levels (count_below) < bins.len().
            let b = unsafe { bins.get_unchecked_mut(k) };
            // Plain terms (w = s = 1): the six sums v, v x, v y, 1, x, y.
            for (sum, term) in b.0.iter_mut().zip([t[0], t[1], t[2], t[4], t[5], t[6]]) {
                sum[lane] += term;
            }
        });
        top
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
        let centre = centre_terms(truth);
        // Levels at and above the brightest pixel see an empty frame (recorded once).
        acc.add_tail(top, &centre);
        self.level_sums(top, g);
        // Two simple loops over equal-length slices, so that both vectorise: distances and
        // error vectors, then the sums (a level whose sum S(b) is not positive, left by
        // round-off just below the brightest pixel, counts as an empty frame).
        let (mass, moment_sq) = (&self.mass[..top], &self.moment_sq[..top]);
        let (dist, ex, ey) = (
            &mut self.dist[..top],
            &mut self.ex[..top],
            &mut self.ey[..top],
        );
        for k in 0..top {
            dist[k] = moment_sq[k].sqrt() / mass[k];
            let inv = 1.0 / mass[k];
            ex[k] *= inv;
            ey[k] *= inv;
        }
        let [s_d, s_q, s_x, s_y, s_xx, s_d4] = &mut acc.sums;
        let (s_d, s_q, s_x) = (&mut s_d[..top], &mut s_q[..top], &mut s_x[..top]);
        let (s_y, s_xx, s_d4) = (&mut s_y[..top], &mut s_xx[..top], &mut s_d4[..top]);
        let empty = &mut acc.empty[..top];
        for k in 0..top {
            let lit = mass[k] > 0.0;
            let t = error_terms(f64::from(dist[k]), f64::from(ex[k]), f64::from(ey[k]));
            // Selects by masks, not branches: left to itself the compiler turns each into a
            // pair of masked loads and stores, which are microcoded and ~10x slower on AMD Zen.
            s_d[k] += select(lit, t[0], centre[0]);
            s_q[k] += select(lit, t[1], centre[1]);
            s_x[k] += select(lit, t[2], centre[2]);
            s_y[k] += select(lit, t[3], centre[3]);
            s_xx[k] += select(lit, t[4], centre[4]);
            s_d4[k] += select(lit, t[5], centre[5]);
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
        let origin = self.origin(truth);
        let (kept, top) = self.lit_pixels(img, terms);
        let bins = &mut self.bins;
        sum_lit(&self.lit[..kept], img, self.n, origin, terms, |k, t| {
            // SAFETY: 0 < k <= levels (count_below) < bins.len().
            let b = unsafe { bins.get_unchecked_mut(k) };
            for (sum, term) in b.0.iter_mut().zip(t) {
                *sum += term;
            }
        });
        top
    }

    /// The pixel grid's origin for positions relative to `truth` (px from the centre).
    #[inline(always)]
    fn origin(&self, truth: (f64, f64)) -> (f64, f64) {
        let c = (self.n as f64 - 1.0) / 2.0;
        (truth.0 + c, truth.1 + c)
    }

    /// Fill `lit` with (row, column, bucket) of the pixels above the first level, in pixel
    /// order: how many, and the highest bucket.
    #[inline(always)]
    fn lit_pixels<T: PixelTerms>(&mut self, img: &[f64], terms: &T) -> (usize, usize) {
        let n = self.n;
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
                    // SAFETY: cells[i] is `self.index.cell` of the same value.
                    unsafe {
                        self.index
                            .count_below_in(cells[i] as usize, v / terms.scale(i))
                    }
                } else {
                    0
                };
                // SAFETY: kept <= i < n * n = lit.len().
                *unsafe { lit.get_unchecked_mut(kept) } = LitPixel::new(row, col, k);
                kept += usize::from(k > 0);
                top = top.max(k);
            }
        }
        (kept, top)
    }

    /// Fill `mass`, `moment_sq` and the first moments (`ex`, `ey`) for levels 0..top from the
    /// buckets (cleared), the first moments multiplied by the gains.
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
            self.ex[l] = t[1] as f32;
            self.ey[l] = t[2] as f32;
        }
    }
}

/// A pixel above the first level: its row (bits 0-15), column (16-31) and bucket (32-63), one
/// 8-byte store for the pass that finds it (a tuple's three fields took three stores).
#[derive(Debug, Clone, Copy)]
struct LitPixel(u64);

impl LitPixel {
    /// The pixel at `row`, `col` (< 2^16) in bucket `k` (< 2^32).
    #[inline(always)]
    fn new(row: usize, col: usize, k: usize) -> Self {
        LitPixel(row as u64 & 0xffff | (col as u64 & 0xffff) << 16 | (k as u64) << 32)
    }

    /// Row, column and bucket.
    #[inline(always)]
    fn parts(self) -> (usize, usize, usize) {
        let r = self.0;
        (
            (r & 0xffff) as usize,
            (r >> 16 & 0xffff) as usize,
            (r >> 32) as usize,
        )
    }
}

/// For each of the `lit` pixels of the n x n `img`, in order: `add` its bucket and its terms
/// as a [`Bin`] holds them (w v, w v x, w v y, 0, w s, w s x, w s y, 0; x and y its offsets
/// from `origin`).
#[inline(always)]
fn sum_lit<T: PixelTerms>(
    lit: &[LitPixel],
    img: &[f64],
    n: usize,
    (tx, ty): (f64, f64),
    terms: &T,
    mut add: impl FnMut(usize, [f64; 8]),
) {
    for &pixel in lit {
        let (row, col, k) = pixel.parts();
        let i = row * n + col;
        let (w, s, v) = (terms.weight(i), terms.scale(i), img[i]);
        let (x, y) = (col as f64 - tx, row as f64 - ty);
        let (a, c) = (half(w * v, x, y), half(w * s, x, y));
        add(k, [a[0], a[1], a[2], a[3], c[0], c[1], c[2], c[3]]);
    }
}

/// A batch's per-level values, one lane a frame: the sum S (not positive: an empty frame),
/// the distance and the error vector (px).
struct PerLevel<'a> {
    mass: &'a [[f32; LANES]],
    dist: &'a [[f32; LANES]],
    ex: &'a [[f32; LANES]],
    ey: &'a [[f32; LANES]],
}

/// Add each level's error terms of every lane's frame to its lane sums: those of the error
/// where the level's sum is positive, else the centre's (`centre`, term-major: an empty
/// frame).
fn add_lanes(lanes: &mut [LaneSums], v: &PerLevel, centre: &[[f64; LANES]; TERMS]) {
    for ((((s, m), d), x), y) in lanes.iter_mut().zip(v.mass).zip(v.dist).zip(v.ex).zip(v.ey) {
        for f in 0..LANES {
            let lit = m[f] > 0.0;
            let t: ErrorTerms = error_terms(f64::from(d[f]), f64::from(x[f]), f64::from(y[f]));
            for q in 0..TERMS {
                s.sums[q][f] += select(lit, t[q], centre[q][f]);
            }
            s.empty[f] += u64::from(!lit);
        }
    }
}

/// [`add_lanes`] in AVX2 vectors, one lane a frame (the compiler leaves the portable loop
/// scalar): the same values.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
unsafe fn add_lanes_avx2(lanes: &mut [LaneSums], v: &PerLevel, centre: &[[f64; LANES]; TERMS]) {
    use std::arch::x86_64::*;
    const _: () = assert!(LANES == 4, "four f64 lanes per AVX2 vector");
    // SAFETY (every load and store): each pointer is to an array of four f32, f64 or u64.
    unsafe {
        let c: [__m256d; TERMS] = std::array::from_fn(|q| _mm256_loadu_pd(centre[q].as_ptr()));
        let one = _mm256_set1_epi64x(1);
        let per_level = v.mass.iter().zip(v.dist).zip(v.ex).zip(v.ey);
        for (s, (((m, d), x), y)) in lanes.iter_mut().zip(per_level) {
            // m > 0 (false for NaN), widened to 64-bit lane masks.
            let m = _mm_loadu_ps(m.as_ptr());
            let lit32 = _mm_cmp_ps::<_CMP_GT_OQ>(m, _mm_setzero_ps());
            let lit = _mm256_cvtepi32_epi64(_mm_castps_si128(lit32));
            let lit_pd = _mm256_castsi256_pd(lit);
            let d = _mm256_cvtps_pd(_mm_loadu_ps(d.as_ptr()));
            let x = _mm256_cvtps_pd(_mm_loadu_ps(x.as_ptr()));
            let y = _mm256_cvtps_pd(_mm_loadu_ps(y.as_ptr()));
            let q = _mm256_mul_pd(d, d);
            // The terms of `error_terms`, in its order.
            let t = [d, q, x, y, _mm256_mul_pd(x, x), _mm256_mul_pd(q, q)];
            for (i, sum) in s.sums.iter_mut().enumerate() {
                let add = _mm256_blendv_pd(c[i], t[i], lit_pd);
                _mm256_storeu_pd(
                    sum.as_mut_ptr(),
                    _mm256_add_pd(_mm256_loadu_pd(sum.as_ptr()), add),
                );
            }
            let empty_ptr = s.empty.as_mut_ptr().cast::<__m256i>();
            let empty =
                _mm256_add_epi64(_mm256_loadu_si256(empty_ptr), _mm256_andnot_si256(lit, one));
            _mm256_storeu_si256(empty_ptr, empty);
        }
    }
}

#[cfg(all(test, target_arch = "x86_64"))]
mod tests {
    use super::*;

    #[test]
    fn vector_lane_sums_equal_the_portable_ones() {
        // Random masses (with zeros, negatives and NaN: not lit) and distances: the AVX2 sums
        // equal the portable loop's bit for bit.
        use rand::RngExt;
        if !std::arch::is_x86_feature_detected!("avx2") {
            return;
        }
        let mut rng = crate::rng::stream(8, 0, 0);
        let levels = 300;
        let mass: Vec<[f32; LANES]> = (0..levels)
            .map(|_| {
                std::array::from_fn(|_| match rng.random_range(0..6) {
                    0 => 0.0,
                    1 => -rng.random_range(0.0..1.0f32),
                    2 => f32::NAN,
                    _ => rng.random_range(0.0..50.0f32),
                })
            })
            .collect();
        let mut draw = |lo: f32| -> Vec<[f32; LANES]> {
            (0..levels)
                .map(|_| std::array::from_fn(|_| rng.random_range(lo..2.0f32)))
                .collect()
        };
        let (dist, ex, ey) = (draw(0.0), draw(-2.0), draw(-2.0));
        let truths = [(0.1, 0.0), (0.7, -0.2), (0.0, 0.0), (0.45, 0.3)];
        let centre: [[f64; LANES]; TERMS] =
            std::array::from_fn(|q| std::array::from_fn(|f| centre_terms(truths[f])[q]));
        let v = PerLevel {
            mass: &mass,
            dist: &dist,
            ex: &ex,
            ey: &ey,
        };
        let (mut a, mut b) = (
            vec![LaneSums::default(); levels],
            vec![LaneSums::default(); levels],
        );
        for _ in 0..3 {
            add_lanes(&mut a, &v, &centre);
            // SAFETY: the CPU has AVX2 (checked above).
            unsafe { add_lanes_avx2(&mut b, &v, &centre) };
        }
        for (x, y) in a.iter().zip(&b) {
            for q in 0..TERMS {
                assert_eq!(x.sums[q].map(f64::to_bits), y.sums[q].map(f64::to_bits));
            }
            assert_eq!(x.empty, y.empty);
        }
        assert!(a.iter().any(|s| s.empty.iter().any(|&e| e > 0)));
    }
}
