//! Per-level sums of the position error over frames, and their merging.
//!
//! Per frame and level the sums take six terms of the error vector e = estimate - truth (px):
//! its length d (R's), d^2, e_x, e_y, e_x^2 and d^4 ([`ErrorTerms`]): R, its SE, and the
//! static (mean e) and random (spread of e about its mean) parts of the error, with SEs.

/// Number of error terms summed per frame and level ([`ErrorTerms`]).
pub const TERMS: usize = 6;

/// One frame's error terms at one level: d, d^2, e_x, e_y, e_x^2, d^4 (px, px^2, px, px, px^2,
/// px^4), in the order of [`LevelSums`]' sums.
pub type ErrorTerms = [f64; TERMS];

/// The terms of an error vector (`ex`, `ey`) (px) whose length is `d` (px; given, so that
/// each centroider keeps its own rounding of R).
#[inline(always)]
pub fn error_terms(d: f64, ex: f64, ey: f64) -> ErrorTerms {
    let q = d * d;
    [d, q, ex, ey, ex * ex, q * q]
}

/// Per-level sums of the position error over frames: the sufficient statistics of R(b) and of
/// the error vector's mean and spread.
#[derive(Debug, Clone)]
pub struct LevelSums {
    /// Per term ([`ErrorTerms`]), per level.
    pub(super) sums: [Vec<f64>; TERMS],
    pub(super) empty: Vec<u64>,
    // Levels at and above a frame's brightest pixel all see an empty frame with the same error;
    // they are recorded once at the first such level and spread by `finish` (prefix sums).
    pub(super) tail: [Vec<f64>; TERMS],
    pub(super) tail_count: Vec<u64>,
    /// Per level, sums of frames added a batch at a time
    /// ([`super::BackgroundSweep::accumulate_batch`]): one partial sum per lane, added up by
    /// `finish`. Empty until a batch is added.
    pub(super) lanes: Vec<LaneSums>,
}

/// Frames a batch of the sweep holds (one per vector lane).
pub const LANES: usize = 4;

/// One level's sums of the frames of each lane.
#[derive(Debug, Clone, Copy, Default)]
pub(super) struct LaneSums {
    /// Per term ([`ErrorTerms`]), per lane.
    pub(super) sums: [[f64; LANES]; TERMS],
    pub(super) empty: [u64; LANES],
}

impl LaneSums {
    fn add(&mut self, other: &LaneSums) {
        for (a, b) in self.sums.iter_mut().zip(&other.sums) {
            for f in 0..LANES {
                a[f] += b[f];
            }
        }
        for f in 0..LANES {
            self.empty[f] += other.empty[f];
        }
    }
}

/// Finished per-level statistics: (sum of distances px, sum of squares px^2, empty frames).
pub type LevelTotals = Vec<(f64, f64, u64)>;

/// Finished per-level sums of the error vector's terms beyond R's (see [`LevelSums::moments`]).
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct ErrorMoments {
    /// Sum of the error's x component (px).
    pub sum_x: f64,
    /// Sum of its y component (px).
    pub sum_y: f64,
    /// Sum of x^2 (px^2).
    pub sum_xx: f64,
    /// Sum of d^4, the squared distance squared (px^4).
    pub sum_d4: f64,
}

/// The empty frame's error terms: the estimate is the centre, so e = -truth (px).
#[inline(always)]
pub fn centre_terms(truth: (f64, f64)) -> ErrorTerms {
    // Distances are O(1) px: plain sqrt is exact enough and much cheaper than hypot.
    let d = (truth.0 * truth.0 + truth.1 * truth.1).sqrt();
    error_terms(d, -truth.0, -truth.1)
}

impl LevelSums {
    /// Zeroed sums for `levels` levels.
    pub fn new(levels: usize) -> Self {
        LevelSums {
            sums: std::array::from_fn(|_| vec![0.0; levels]),
            empty: vec![0; levels],
            tail: std::array::from_fn(|_| vec![0.0; levels + 1]),
            tail_count: vec![0; levels + 1],
            lanes: Vec::new(),
        }
    }

    /// Add one frame's error (`ex`, `ey`) (px, estimate - truth) of length `d` (px) at level
    /// `k`: the entry point of a centroider that computes its estimate per setting.
    #[inline]
    pub fn add_error(&mut self, k: usize, d: f64, (ex, ey): (f64, f64)) {
        for (s, t) in self.sums.iter_mut().zip(error_terms(d, ex, ey)) {
            s[k] += t;
        }
    }

    /// Add one empty frame at level `k`: nothing above the threshold, the estimate is the
    /// centre, so the error is -`truth` (px).
    #[inline]
    pub fn add_empty(&mut self, k: usize, truth: (f64, f64)) {
        for (s, t) in self.sums.iter_mut().zip(centre_terms(truth)) {
            s[k] += t;
        }
        self.empty[k] += 1;
    }

    /// Add an empty frame of error terms `centre` at level `k` and every level above it
    /// (recorded once, spread by `finish`).
    #[inline]
    pub(super) fn add_tail(&mut self, k: usize, centre: &ErrorTerms) {
        for (s, t) in self.tail.iter_mut().zip(centre) {
            s[k] += t;
        }
        self.tail_count[k] += 1;
    }

    /// The per-lane sums, allocated (zeroed) on first use.
    pub(super) fn lanes_mut(&mut self) -> &mut [LaneSums] {
        if self.lanes.is_empty() {
            self.lanes = vec![LaneSums::default(); self.empty.len()];
        }
        &mut self.lanes
    }

    /// Add another set of sums (same levels).
    pub fn merge(&mut self, other: &LevelSums) {
        fn add<T: Copy + std::ops::AddAssign>(a: &mut [T], b: &[T]) {
            a.iter_mut().zip(b).for_each(|(x, y)| *x += *y);
        }
        for q in 0..TERMS {
            add(&mut self.sums[q], &other.sums[q]);
            add(&mut self.tail[q], &other.tail[q]);
        }
        add(&mut self.empty, &other.empty);
        add(&mut self.tail_count, &other.tail_count);
        if !other.lanes.is_empty() {
            for (a, b) in self.lanes_mut().iter_mut().zip(&other.lanes) {
                a.add(b);
            }
        }
    }

    /// Reset every sum to zero (same levels), keeping the allocations.
    pub fn clear(&mut self) {
        for q in 0..TERMS {
            self.sums[q].fill(0.0);
            self.tail[q].fill(0.0);
        }
        self.empty.fill(0);
        self.tail_count.fill(0);
        self.lanes.fill(LaneSums::default());
    }

    /// Per-level totals of term `q` with the empty tails spread over their levels.
    fn finish_term(&self, q: usize) -> Vec<f64> {
        let mut tail = 0.0;
        (0..self.empty.len())
            .map(|k| {
                tail += self.tail[q][k];
                let mut s = self.sums[q][k];
                if let Some(lane) = self.lanes.get(k) {
                    for f in 0..LANES {
                        s += lane.sums[q][f];
                    }
                }
                s + tail
            })
            .collect()
    }

    /// Per-level totals with the empty tails spread over their levels.
    pub fn finish(&self) -> LevelTotals {
        let mut tc = 0u64;
        let empty = (0..self.empty.len()).map(|k| {
            tc += self.tail_count[k];
            let lanes: u64 = self.lanes.get(k).map_or(0, |l| l.empty.iter().sum());
            self.empty[k] + lanes + tc
        });
        let (d, q) = (self.finish_term(0), self.finish_term(1));
        d.into_iter()
            .zip(q)
            .zip(empty)
            .map(|((d, q), e)| (d, q, e))
            .collect()
    }

    /// Per-level totals of the error vector's terms beyond R's (the x and y components, x^2,
    /// d^4), tails spread as by [`Self::finish`].
    pub fn moments(&self) -> Vec<ErrorMoments> {
        let [x, y, xx, d4] = [2, 3, 4, 5].map(|q| self.finish_term(q));
        (0..self.empty.len())
            .map(|k| ErrorMoments {
                sum_x: x[k],
                sum_y: y[k],
                sum_xx: xx[k],
                sum_d4: d4[k],
            })
            .collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn errors_empties_and_tails_add_their_terms() {
        // Level 0: one error (0.3, -0.4) of length 0.5; level 1: an empty frame at truth
        // (0, -1); a tail from level 1 up at truth (0, 0.5). Merged twice: doubled.
        let mut s = LevelSums::new(3);
        s.add_error(0, 0.5, (0.3, -0.4));
        s.add_empty(1, (0.0, -1.0));
        s.add_tail(1, &centre_terms((0.0, 0.5)));
        let mut twice = s.clone();
        twice.merge(&s);
        assert_eq!(s.finish(), [(0.5, 0.25, 0), (1.5, 1.25, 2), (0.5, 0.25, 1)]);
        let m = s.moments();
        assert_eq!(
            m[0],
            ErrorMoments {
                sum_x: 0.3,
                sum_y: -0.4,
                sum_xx: 0.3 * 0.3,
                sum_d4: 0.0625
            }
        );
        assert_eq!((m[1].sum_x, m[1].sum_y, m[2].sum_y), (0.0, 0.5, -0.5));
        assert_eq!(twice.moments()[1].sum_y, 2.0 * m[1].sum_y);
        twice.clear();
        assert!(twice
            .moments()
            .iter()
            .all(|m| *m == ErrorMoments::default()));
    }
}
