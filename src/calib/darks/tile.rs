//! One tile of per-pixel accumulators, and the moments they give.
//!
//! Per pixel and parity of the frame index: the sums of the samples less a per-pixel shift
//! (the pixel's first sample) and of their squares, over the whole stack; per pixel the sums
//! of their cubes and fourth powers (kurtosis, every sample), the sum of squared successive
//! differences, the previous sample and the largest; with `lines`, the tile's share of every
//! frame's row and column sums (the temporal noise decomposition). Sigma clipping's
//! second pass adds an acceptance window and per-pixel counts; extremes clipping keeps the
//! N highest and lowest samples and takes them out of the sums at the end.
//!
//! For integer samples every sum is an integer below 2^53 (16-bit samples: up to 2^21
//! frames), so f64 holds it exactly, in any order of addition; [`mean_var`] then forms the
//! mean and variance from exact integers with one rounding each. The results are the same
//! whatever the format, the thread count or the vector width.

use super::lines::TileLines;

/// One tile of per-pixel accumulators (structure of arrays, for vectorisation).
pub(super) struct Tile {
    pub(super) start: usize,
    pub(super) len: usize,
    /// Shifts, previous samples and maxima as values: empty until [`Tile::widen`] (while the
    /// tile is new or [`Tile::narrow`]).
    pub(super) shift: Vec<f64>,
    pub(super) s1: [Vec<f64>; 2],
    pub(super) s2: [Vec<f64>; 2],
    /// Sums of (x - shift)^3 and (x - shift)^4 over every sample of the first pass.
    pub(super) s3: Vec<f64>,
    pub(super) s4: Vec<f64>,
    /// The tile's share of each frame's row and column sums (first pass only).
    pub(super) lines: Option<TileLines>,
    /// Samples per pixel and parity, when they differ between pixels (a window, or after
    /// extremes are removed); otherwise every pixel has every frame of its parity.
    pub(super) cnt: Option<[Vec<f64>; 2]>,
    pub(super) prev: Vec<f64>,
    pub(super) vn: Vec<f64>,
    pub(super) max: Vec<f64>,
    /// Shifts, previous samples and maxima of a tile seeded and swept by stored integers only.
    pub(super) narrow: Option<Narrow>,
    /// Acceptance window (sigma clipping, second pass).
    pub(super) window: Option<(Vec<f64>, Vec<f64>)>,
    /// N highest / lowest samples per pixel, with their parity (extremes clipping).
    pub(super) hi: Vec<(f64, u8)>,
    pub(super) lo: Vec<(f64, u8)>,
}

/// Shifts, previous samples and maxima of integer frames as 16-bit integers less `base` (the
/// zero of the layout that seeded them; the stored integers themselves for that layout).
/// A quarter of the bytes of f64 values: every pixel's sums should stay in the last-level
/// cache from one batch to the next, and with the 18 bytes a pixel saved (80 -> 62) the
/// 1 GiB benchmark took 7 % less wall time and 10 % less CPU (medians of 12 alternated runs).
pub(super) struct Narrow {
    pub(super) base: f64,
    pub(super) shift: Vec<i16>,
    pub(super) prev: Vec<i16>,
    pub(super) max: Vec<i16>,
}

impl Narrow {
    /// Largest |base| (and layout zero) kept narrow: values of 16-bit samples stay integers
    /// far below 2^53, so every conversion is exact.
    const MAX_BASE: f64 = 2_147_483_648.0;

    /// Whether the stored integers `lo..=hi` of a layout with `zero` fit as 16-bit offsets
    /// from `base`.
    pub(super) fn holds(&self, lo: i32, hi: i32, zero: f64) -> bool {
        let off = zero - self.base;
        zero.abs() < Self::MAX_BASE
            && lo as f64 + off >= i16::MIN as f64
            && hi as f64 + off <= i16::MAX as f64
    }
}

/// `n` zeros, written: `vec![0.0; n]` takes memory the system hands out as zero pages, whose
/// first read maps the shared zero page and whose first write then faults again, copies the
/// page and flushes the other cores' TLBs (perf: a quarter of the dark statistics' first 60
/// ms). `black_box` keeps the compiler from turning the writes back into such an allocation.
pub(super) fn zeros(n: usize) -> Vec<f64> {
    let mut v = Vec::with_capacity(n);
    v.resize(n, std::hint::black_box(0.0));
    v
}

impl Tile {
    pub(super) fn new(start: usize, len: usize, extremes: usize) -> Tile {
        let pair = || [zeros(len), zeros(len)];
        Tile {
            start,
            len,
            shift: Vec::new(),
            s1: pair(),
            s2: pair(),
            s3: zeros(len),
            s4: zeros(len),
            lines: None,
            cnt: None,
            prev: Vec::new(),
            vn: zeros(len),
            max: Vec::new(),
            narrow: None,
            window: None,
            hi: vec![(f64::NEG_INFINITY, 0); len * extremes],
            lo: vec![(f64::INFINITY, 0); len * extremes],
        }
    }

    /// A tile of the second pass of sigma clipping: samples outside [lo, hi] are left out;
    /// `shift` is the first pass's.
    pub(super) fn windowed(start: usize, shift: &[f64], lo: &[f64], hi: &[f64]) -> Tile {
        let len = shift.len();
        let mut t = Tile::new(start, len, 0);
        t.widen();
        t.shift.copy_from_slice(shift);
        t.window = Some((lo.to_vec(), hi.to_vec()));
        t.cnt = Some([zeros(len), zeros(len)]);
        t
    }

    /// The shifts, previous samples and maxima as values from now on: converted from
    /// [`Narrow`] ones, or a new tile's (0, 0 and -inf).
    pub(super) fn widen(&mut self) {
        if let Some(n) = self.narrow.take() {
            let value = |v: &Vec<i16>| v.iter().map(|&x| x as f64 + n.base).collect();
            (self.shift, self.prev, self.max) = (value(&n.shift), value(&n.prev), value(&n.max));
        } else if self.shift.len() != self.len {
            self.shift = zeros(self.len);
            self.prev = zeros(self.len);
            self.max = vec![f64::NEG_INFINITY; self.len];
        }
    }

    /// Seed a new tile with the first frame's stored integers `x` (values `x + zero`) as
    /// [`Narrow`] shifts, previous samples and maxima (nothing when `zero` is too large).
    pub(super) fn seed_narrow(&mut self, x: impl Iterator<Item = i16>, zero: f64) {
        if zero.abs() >= Narrow::MAX_BASE || !self.shift.is_empty() {
            return;
        }
        let shift: Vec<i16> = x.collect();
        assert_eq!(shift.len(), self.len, "one sample per pixel");
        let (prev, max) = (shift.clone(), shift.clone());
        self.narrow = Some(Narrow {
            base: zero,
            shift,
            prev,
            max,
        });
    }

    /// Take the first frame's samples `x` of tile-local pixels from `a` as shifts.
    pub(super) fn seed(&mut self, a: usize, x: &[f64]) {
        self.widen();
        self.shift[a..a + x.len()].copy_from_slice(x);
        self.prev[a..a + x.len()].copy_from_slice(x);
    }

    /// Add samples `x` of tile-local pixels from `a` of a frame of `parity`, inside the
    /// window.
    pub(super) fn add_windowed(&mut self, a: usize, x: &[f64], parity: usize) {
        let n = x.len();
        let (lo, hi) = self.window.as_ref().expect("a windowed tile");
        let cnt = &mut self.cnt.as_mut().expect("counts exist with a window")[parity];
        let (lo, hi, shift) = (&lo[a..a + n], &hi[a..a + n], &self.shift[a..a + n]);
        let (s1, s2, cnt) = (
            &mut self.s1[parity][a..a + n],
            &mut self.s2[parity][a..a + n],
            &mut cnt[a..a + n],
        );
        for i in 0..n {
            let keep = (x[i] >= lo[i] && x[i] <= hi[i]) as u8 as f64;
            let d = (x[i] - shift[i]) * keep;
            s1[i] += d;
            s2[i] += d * d;
            cnt[i] += keep;
        }
    }

    /// Keep track of the extremes among samples `x` of tile-local pixels from `a`.
    pub(super) fn add_extremes(&mut self, a: usize, x: &[f64], parity: usize, extremes: usize) {
        for (j, &v) in x.iter().enumerate() {
            let i = a + j;
            let range = i * extremes..(i + 1) * extremes;
            insert_extreme(&mut self.hi[range.clone()], v, parity as u8, |a, b| a > b);
            insert_extreme(&mut self.lo[range], v, parity as u8, |a, b| a < b);
        }
    }

    /// Samples of pixel `i` in `parity` when every pixel has `frames[parity]` of them.
    pub(super) fn count(&self, i: usize, parity: usize, frames: [f64; 2]) -> f64 {
        self.cnt.as_ref().map_or(frames[parity], |c| c[parity][i])
    }

    /// (count, shift, shifted sum, shifted sum of squares) of pixel `i` in `parity`, or in
    /// both parities when None.
    pub(super) fn sums(&self, i: usize, parity: Option<usize>, frames: [f64; 2]) -> Sums {
        let one = |p: usize| Sums {
            n: self.count(i, p, frames),
            shift: self.shift[i],
            s1: self.s1[p][i],
            s2: self.s2[p][i],
        };
        match parity {
            Some(p) => one(p),
            None => {
                let (e, o) = (one(0), one(1));
                Sums {
                    n: e.n + o.n,
                    s1: e.s1 + o.s1,
                    s2: e.s2 + o.s2,
                    ..e
                }
            }
        }
    }

    /// Take the tracked extremes (`extremes` > 0 per pixel and end) out of every pixel's
    /// sums (extremes clipping); `frames` counts the frames of each parity in the pass.
    pub(super) fn remove_extremes(&mut self, extremes: usize, frames: [f64; 2]) {
        let cnt = self
            .cnt
            .get_or_insert_with(|| frames.map(|n| vec![n; self.len]));
        let tracked = self
            .hi
            .chunks_exact(extremes)
            .zip(self.lo.chunks_exact(extremes));
        for (i, (hi, lo)) in tracked.enumerate() {
            for (v, p) in hi.iter().chain(lo) {
                let (p, d) = (*p as usize, v - self.shift[i]);
                self.s1[p][i] -= d;
                self.s2[p][i] -= d * d;
                cnt[p][i] -= 1.0;
            }
        }
    }
}

/// Keep `list` as the best samples under `better`, best first; `v` displaces the worst.
fn insert_extreme(list: &mut [(f64, u8)], v: f64, parity: u8, better: impl Fn(f64, f64) -> bool) {
    let last = list.len() - 1;
    if !better(v, list[last].0) {
        return;
    }
    let mut j = last;
    while j > 0 && better(v, list[j - 1].0) {
        list[j] = list[j - 1];
        j -= 1;
    }
    list[j] = (v, parity);
}

/// The sums of one pixel's samples: n samples x_k, sum (x_k - shift), sum (x_k - shift)^2.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) struct Sums {
    pub(super) n: f64,
    pub(super) shift: f64,
    pub(super) s1: f64,
    pub(super) s2: f64,
}

/// Largest integer below which f64 holds every integer.
const EXACT: f64 = 9_007_199_254_740_992.0;

/// Mean and sample variance (NaN with fewer than 1 and 2 samples).
///
/// Integer sums (integer samples) are exact, and so are n * sum x = n shift + s1 and
/// n s2 - s1^2 = n^2 M2 in 128-bit integers: the mean and the variance, M2 / (n - 1), are
/// then each rounded once or twice from the exact value, and never lose digits to
/// cancellation. Other sums take the usual shifted-data formulas.
pub(super) fn mean_var(s: Sums) -> (f64, f64) {
    let Sums { n, shift, s1, s2 } = s;
    if n < 1.0 {
        return (f64::NAN, f64::NAN);
    }
    // (A conversion to i64 and back keeps the check to two instructions.)
    let integral = |v: f64| v.abs() < EXACT && (v as i64) as f64 == v;
    if integral(shift) && integral(s1) && integral(s2) && integral(n) {
        let [ni, si, s1i, s2i] = [n, shift, s1, s2].map(|v| v as i64);
        // n sum x and n^2 M2 as exact integers: in i64 when they fit (16-bit samples: always
        // below 46,000 frames), else in i128; rounded once to f64.
        let in_i64 = || {
            Some((
                ni.checked_mul(si)?.checked_add(s1i)?,
                ni.checked_mul(s2i)?.checked_sub(s1i.checked_mul(s1i)?)?,
            ))
        };
        let (sum, m2n) = match in_i64() {
            Some((a, b)) => (a as f64, b.max(0) as f64),
            None => {
                let [ni, si, s1i, s2i] = [ni, si, s1i, s2i].map(i128::from);
                ((ni * si + s1i) as f64, (ni * s2i - s1i * s1i).max(0) as f64)
            }
        };
        let var = if n >= 2.0 {
            m2n / (n * (n - 1.0))
        } else {
            f64::NAN
        };
        return (sum / n, var);
    }
    let mean = shift + s1 / n;
    let var = if n >= 2.0 {
        (s2 - s1 * s1 / n).max(0.0) / (n - 1.0)
    } else {
        f64::NAN
    };
    (mean, var)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sums_of(x: &[f64], shift: f64) -> Sums {
        Sums {
            n: x.len() as f64,
            shift,
            s1: x.iter().map(|v| v - shift).sum(),
            s2: x.iter().map(|v| (v - shift) * (v - shift)).sum(),
        }
    }

    #[test]
    fn integer_sums_give_the_exact_mean_and_variance() {
        // 3, 5, 4, 10, 6, 2: mean 5, M2 40, variance 8; shifted by the first sample.
        let (m, v) = mean_var(sums_of(&[3.0, 5.0, 4.0, 10.0, 6.0, 2.0], 3.0));
        assert_eq!((m, v), (5.0, 8.0));
        // Mean 1/3 and variance 1/3 are rounded once from the exact fractions.
        let (m, v) = mean_var(sums_of(&[0.0, 0.0, 1.0], 0.0));
        assert_eq!((m, v), (1.0 / 3.0, 1.0 / 3.0));
        // A large level with a small spread, 40000001 + {0, 1, 3}, not shifted: the sums are
        // exact (sum x^2 < 2^53) but (sum x)^2 is not, and the shifted-data formula gives a
        // variance of 2.5 instead of 7/3; the exact one does not.
        let base = 40_000_001.0;
        let x = [base, base + 1.0, base + 3.0];
        let s = sums_of(&x, 0.0);
        assert_eq!((s.s2 - s.s1 * s.s1 / 3.0) / 2.0, 2.5);
        assert_eq!(mean_var(s), (base + 4.0 / 3.0, 7.0 / 3.0));
        // Products beyond i64 (n sum (x - shift)^2 = 2^64) take 128-bit integers.
        let big = Sums {
            n: 4096.0,
            shift: 0.0,
            s1: 0.0,
            s2: 4_503_599_627_370_496.0,
        };
        assert_eq!(mean_var(big), (0.0, 4_503_599_627_370_496.0 / 4095.0));
        // One sample: a mean, no variance; none: neither.
        let (m, v) = mean_var(sums_of(&[7.0], 7.0));
        assert!(m == 7.0 && v.is_nan());
        let (m, v) = mean_var(sums_of(&[], 0.0));
        assert!(m.is_nan() && v.is_nan());
    }

    #[test]
    fn fractional_sums_take_the_shifted_formulas() {
        // 0.5, 1.25, 3.0: mean 19/12, M2 = sum (x - mean)^2 = 3.791666...
        let x = [0.5, 1.25, 3.0];
        let (m, v) = mean_var(sums_of(&x, 0.5));
        let mean = 19.0 / 12.0;
        let m2: f64 = x.iter().map(|v| (v - mean) * (v - mean)).sum();
        assert!((m - mean).abs() < 1e-15 && (v - m2 / 2.0).abs() < 1e-15);
    }

    #[test]
    fn extremes_are_tracked_and_removed_exactly() {
        // Samples 1, 2, 3, 100 with one extreme kept at each end: 100 (odd) and 1 (even) are
        // removed, leaving 3 (even) and 2 (odd): mean 2.5, variance 0.5.
        let mut t = Tile::new(0, 1, 1);
        t.seed(0, &[1.0]);
        for (k, x) in [1.0f64, 2.0, 3.0, 100.0].into_iter().enumerate() {
            let d = x - 1.0;
            t.s1[k % 2][0] += d;
            t.s2[k % 2][0] += d * d;
            t.add_extremes(0, &[x], k % 2, 1);
        }
        assert_eq!((t.hi[0], t.lo[0]), ((100.0, 1), (1.0, 0)));
        let frames = [2.0, 2.0];
        t.remove_extremes(1, frames);
        let (m, v) = mean_var(t.sums(0, Some(0), frames));
        assert!(m == 3.0 && v.is_nan());
        assert_eq!(t.sums(0, Some(1), frames).n, 1.0);
        assert_eq!(mean_var(t.sums(0, None, frames)), (2.5, 0.5));
    }

    #[test]
    fn a_window_leaves_out_samples_and_counts_the_rest() {
        let mut t = Tile::windowed(0, &[10.0, 10.0], &[8.0, 8.0], &[12.0, 12.0]);
        t.add_windowed(0, &[9.0, 20.0], 0);
        t.add_windowed(0, &[11.0, 11.0], 1);
        t.add_windowed(0, &[12.0, 7.0], 0);
        let frames = [2.0, 1.0];
        assert_eq!(t.sums(0, None, frames).n, 3.0);
        assert_eq!(mean_var(t.sums(0, None, frames)), (32.0 / 3.0, 7.0 / 3.0));
        // Pixel 1 kept only the 11.
        let s = t.sums(1, None, frames);
        assert_eq!((s.n, s.s1, s.s2), (1.0, 1.0, 1.0));
    }
}
