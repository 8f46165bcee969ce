//! Per-level sums of the position error over frames, and their merging.

/// Per-level sums of the position error over frames: the sufficient statistics of R(b).
#[derive(Debug, Clone)]
pub struct LevelSums {
    pub(super) sum: Vec<f64>,
    pub(super) sum_sq: Vec<f64>,
    pub(super) empty: Vec<u64>,
    // Levels at and above a frame's brightest pixel all see an empty frame with the same error;
    // they are recorded once at the first such level and spread by `finish` (prefix sums).
    pub(super) tail_sum: Vec<f64>,
    pub(super) tail_sum_sq: Vec<f64>,
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
    pub(super) sum: [f64; LANES],
    pub(super) sum_sq: [f64; LANES],
    pub(super) empty: [u64; LANES],
}

impl LaneSums {
    fn add(&mut self, other: &LaneSums) {
        for f in 0..LANES {
            self.sum[f] += other.sum[f];
            self.sum_sq[f] += other.sum_sq[f];
            self.empty[f] += other.empty[f];
        }
    }
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
            lanes: Vec::new(),
        }
    }

    /// The per-lane sums, allocated (zeroed) on first use.
    pub(super) fn lanes_mut(&mut self) -> &mut [LaneSums] {
        if self.lanes.is_empty() {
            self.lanes = vec![LaneSums::default(); self.sum.len()];
        }
        &mut self.lanes
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
        if !other.lanes.is_empty() {
            for (a, b) in self.lanes_mut().iter_mut().zip(&other.lanes) {
                a.add(b);
            }
        }
    }

    /// Reset every sum to zero (same levels), keeping the allocations.
    pub fn clear(&mut self) {
        self.sum.fill(0.0);
        self.sum_sq.fill(0.0);
        self.empty.fill(0);
        self.tail_sum.fill(0.0);
        self.tail_sum_sq.fill(0.0);
        self.tail_count.fill(0);
        self.lanes.fill(LaneSums::default());
    }

    /// Per-level totals with the empty tails spread over their levels.
    pub fn finish(&self) -> LevelTotals {
        let (mut ts, mut tq, mut tc) = (0.0, 0.0, 0u64);
        (0..self.sum.len())
            .map(|k| {
                ts += self.tail_sum[k];
                tq += self.tail_sum_sq[k];
                tc += self.tail_count[k];
                let (mut s, mut q, mut e) = (self.sum[k], self.sum_sq[k], self.empty[k]);
                if let Some(lane) = self.lanes.get(k) {
                    for f in 0..LANES {
                        s += lane.sum[f];
                        q += lane.sum_sq[f];
                        e += lane.empty[f];
                    }
                }
                (s + ts, q + tq, e + tc)
            })
            .collect()
    }
}
