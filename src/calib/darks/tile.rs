//! One tile of per-pixel accumulators: shifted block sums merged into Welford states (Chan's
//! formula), per parity of the frame index, with the running extremes for extremes clipping.

use std::ops::Range;

/// One tile of per-pixel accumulators (structure of arrays, for vectorisation).
pub(super) struct Tile {
    pub(super) start: usize,
    pub(super) len: usize,
    pub(super) shift: Vec<f64>,
    pub(super) s1: [Vec<f64>; 2],
    pub(super) s2: [Vec<f64>; 2],
    /// Per-pixel block counts; only with a window (otherwise every pixel has the block count).
    pub(super) cnt: Option<[Vec<f64>; 2]>,
    pub(super) n: [Vec<f64>; 2],
    pub(super) mean: [Vec<f64>; 2],
    pub(super) m2: [Vec<f64>; 2],
    pub(super) prev: Vec<f64>,
    pub(super) vn: Vec<f64>,
    pub(super) max: Vec<f64>,
    /// Acceptance window (sigma clipping, second pass).
    pub(super) window: Option<(Vec<f64>, Vec<f64>)>,
    /// N highest / lowest samples per pixel, with their parity (extremes clipping).
    pub(super) hi: Vec<(f64, u8)>,
    pub(super) lo: Vec<(f64, u8)>,
}

pub(super) fn zeros(n: usize) -> Vec<f64> {
    vec![0.0; n]
}

impl Tile {
    pub(super) fn new(start: usize, len: usize, extremes: usize) -> Tile {
        let pair = || [zeros(len), zeros(len)];
        Tile {
            start,
            len,
            shift: zeros(len),
            s1: pair(),
            s2: pair(),
            cnt: None,
            n: pair(),
            mean: pair(),
            m2: pair(),
            prev: zeros(len),
            vn: zeros(len),
            max: vec![f64::NEG_INFINITY; len],
            window: None,
            hi: vec![(f64::NEG_INFINITY, 0); len * extremes],
            lo: vec![(f64::INFINITY, 0); len * extremes],
        }
    }

    /// Add the samples `x` of tile-local pixels `r` of one frame.
    pub(super) fn add(
        &mut self,
        x: &[f64],
        parity: usize,
        first: bool,
        extremes: usize,
        r: Range<usize>,
    ) {
        if first {
            self.shift[r.clone()].copy_from_slice(x);
            self.prev[r.clone()].copy_from_slice(x);
        }
        let n = x.len();
        let (s1, s2) = (
            &mut self.s1[parity][r.clone()],
            &mut self.s2[parity][r.clone()],
        );
        let shift = &self.shift[r.clone()];
        match &self.window {
            None => {
                // Index loops over equal-length slices: the bounds checks hoist and the body
                // vectorises.
                let (prev, vn, max) = (
                    &mut self.prev[r.clone()],
                    &mut self.vn[r.clone()],
                    &mut self.max[r.clone()],
                );
                let (s1, s2, shift, prev, vn, max) = (
                    &mut s1[..n],
                    &mut s2[..n],
                    &shift[..n],
                    &mut prev[..n],
                    &mut vn[..n],
                    &mut max[..n],
                );
                for i in 0..n {
                    let d = x[i] - shift[i];
                    s1[i] += d;
                    s2[i] += d * d;
                    let v = x[i] - prev[i];
                    vn[i] += v * v;
                    prev[i] = x[i];
                    max[i] = max[i].max(x[i]);
                }
            }
            Some((lo, hi)) => {
                let cnt =
                    &mut self.cnt.as_mut().expect("counts exist with a window")[parity][r.clone()];
                let (lo, hi) = (&lo[r.clone()], &hi[r.clone()]);
                for i in 0..n {
                    let keep = (x[i] >= lo[i] && x[i] <= hi[i]) as u8 as f64;
                    let d = (x[i] - shift[i]) * keep;
                    s1[i] += d;
                    s2[i] += d * d;
                    cnt[i] += keep;
                }
            }
        }
        if extremes > 0 {
            for (j, &v) in x.iter().enumerate() {
                let i = r.start + j;
                insert_extreme(
                    &mut self.hi[i * extremes..(i + 1) * extremes],
                    v,
                    parity as u8,
                    |a, b| a > b,
                );
                insert_extreme(
                    &mut self.lo[i * extremes..(i + 1) * extremes],
                    v,
                    parity as u8,
                    |a, b| a < b,
                );
            }
        }
    }

    /// Chan merge of the shifted block sums of `parity` into its running Welford state.
    pub(super) fn flush(&mut self, parity: usize, block: f64) {
        for i in 0..self.len {
            let nb = self.cnt.as_ref().map_or(block, |c| c[parity][i]);
            if nb == 0.0 {
                continue;
            }
            let (s1, s2) = (self.s1[parity][i], self.s2[parity][i]);
            let mean_b = self.shift[i] + s1 / nb;
            let m2_b = (s2 - s1 * s1 / nb).max(0.0);
            let na = self.n[parity][i];
            let n = na + nb;
            let delta = mean_b - self.mean[parity][i];
            self.mean[parity][i] += delta * nb / n;
            self.m2[parity][i] += m2_b + delta * delta * na * nb / n;
            self.n[parity][i] = n;
        }
        self.s1[parity].fill(0.0);
        self.s2[parity].fill(0.0);
        if let Some(c) = self.cnt.as_mut() {
            c[parity].fill(0.0);
        }
    }

    /// Undo the Welford update of sample `v` in `parity` (extremes clipping).
    pub(super) fn remove(&mut self, i: usize, parity: usize, v: f64) {
        let n = self.n[parity][i];
        if n <= 1.0 {
            self.n[parity][i] = 0.0;
            self.mean[parity][i] = 0.0;
            self.m2[parity][i] = 0.0;
            return;
        }
        let mean = self.mean[parity][i];
        let mean_new = (n * mean - v) / (n - 1.0);
        self.m2[parity][i] = (self.m2[parity][i] - (v - mean_new) * (v - mean)).max(0.0);
        self.mean[parity][i] = mean_new;
        self.n[parity][i] = n - 1.0;
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

/// Chan merge of two (n, mean, M2) summaries.
pub(super) fn merge(a: (f64, f64, f64), b: (f64, f64, f64)) -> (f64, f64, f64) {
    let n = a.0 + b.0;
    if n == 0.0 {
        return (0.0, f64::NAN, f64::NAN);
    }
    let delta = b.1 - a.1;
    let mean = if a.0 == 0.0 {
        b.1
    } else if b.0 == 0.0 {
        a.1
    } else {
        a.1 + delta * b.0 / n
    };
    (n, mean, a.2 + b.2 + delta * delta * a.0 * b.0 / n)
}

pub(super) fn sample_std(n: f64, m2: f64) -> f64 {
    if n >= 2.0 {
        (m2 / (n - 1.0)).sqrt()
    } else {
        f64::NAN
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// (n, mean, M2) of both parities merged, for pixel 0.
    fn total(t: &Tile) -> (f64, f64, f64) {
        merge(
            (t.n[0][0], t.mean[0][0], t.m2[0][0]),
            (t.n[1][0], t.mean[1][0], t.m2[1][0]),
        )
    }

    #[test]
    fn block_sums_and_merges_give_the_exact_moments() {
        // Samples 3, 5, 4, 10, 6, 2: even frames 3, 4, 6 (mean 13/3, M2 = 61 - 169/3 = 14/3),
        // odd frames 5, 10, 2 (mean 17/3, M2 = 129 - 289/3 = 98/3); all six: mean 5, M2 40.
        // Blocks of 2 then 1 frame per parity exercise the Chan merge.
        let mut t = Tile::new(0, 1, 0);
        for (k, x) in [3.0, 5.0, 4.0, 10.0, 6.0, 2.0].into_iter().enumerate() {
            t.add(&[x], k % 2, k == 0, 0, 0..1);
            if k == 3 {
                t.flush(0, 2.0);
                t.flush(1, 2.0);
            }
        }
        t.flush(0, 1.0);
        t.flush(1, 1.0);
        let close = |a: f64, b: f64| (a - b).abs() < 1e-12;
        assert!(close(t.mean[0][0], 13.0 / 3.0) && close(t.m2[0][0], 14.0 / 3.0));
        assert!(close(t.mean[1][0], 17.0 / 3.0) && close(t.m2[1][0], 98.0 / 3.0));
        let (n, m, m2) = total(&t);
        assert!(n == 6.0 && close(m, 5.0) && close(m2, 40.0));
        assert!(close(sample_std(n, m2), 8f64.sqrt()));
        assert!(sample_std(1.0, 0.0).is_nan());
        // Squared successive differences 4 + 1 + 36 + 16 + 16; largest sample 10.
        assert_eq!((t.vn[0], t.max[0]), (73.0, 10.0));
    }

    #[test]
    fn extremes_are_tracked_and_removed_exactly() {
        // Samples 1, 2, 3, 100 with one extreme kept at each end: 100 (odd) and 1 (even) are
        // removed, leaving 3 (even) and 2 (odd): mean 2.5, M2 0.5.
        let mut t = Tile::new(0, 1, 1);
        for (k, x) in [1.0, 2.0, 3.0, 100.0].into_iter().enumerate() {
            t.add(&[x], k % 2, k == 0, 1, 0..1);
        }
        t.flush(0, 2.0);
        t.flush(1, 2.0);
        assert_eq!((t.hi[0], t.lo[0]), ((100.0, 1), (1.0, 0)));
        for (v, p) in [t.hi[0], t.lo[0]] {
            t.remove(0, p as usize, v);
        }
        assert_eq!((t.n[0][0], t.mean[0][0], t.m2[0][0]), (1.0, 3.0, 0.0));
        assert_eq!((t.n[1][0], t.mean[1][0], t.m2[1][0]), (1.0, 2.0, 0.0));
        assert_eq!(total(&t), (2.0, 2.5, 0.5));
    }
}
