//! Batch means: per-level sums of the radial error per block of iterations, kept beside a
//! run's totals, so that after the run the standard error of any linear combination of the
//! models' R at chosen levels can be computed, with the correlation that common random numbers
//! give it (the paired difference of the effective-noise solver).
//!
//! Iterations are independent, so the block means of a sum of terms scatter with the variance
//! of that sum; blocks only trade degrees of freedom for memory. Block j covers iterations
//! [j B, (j + 1) B) of the run; B starts at [`SUB_BLOCK`] and doubles (pairs merge) whenever more
//! than [`MAX_BLOCKS`] would be needed, so memory stays bounded whatever the iteration count.

/// Iterations of the smallest block: a chunk of the engine is cut into sub-blocks of this size.
pub(crate) const SUB_BLOCK: u64 = 32;
/// Most blocks kept; past it the block size doubles (256 to 512 blocks: ample degrees of freedom).
pub(crate) const MAX_BLOCKS: usize = 512;

/// One term of a linear combination of R values: `coef` x R of arm `model` at setting `level`
/// (indices into the run's arms, see [`super::Experiment::with_arms`], and that arm's
/// settings; with [`super::Experiment::new`] the arms are the models and the settings the
/// background levels).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Term {
    /// Index of the arm (model read through a centroider) in the run.
    pub model: usize,
    /// Index of the setting (background level) in the arm's settings.
    pub level: usize,
    /// Coefficient of the term (dimensionless).
    pub coef: f64,
}

/// Per-block sums of the radial error (px) for every arm and setting of a run.
#[derive(Debug, Clone)]
pub(crate) struct Blocks {
    /// Start of each arm's settings in a block's sums, and their total at the end.
    offsets: Vec<usize>,
    /// Iterations per full block (a power-of-two multiple of [`SUB_BLOCK`]).
    size: u64,
    /// Iterations in each block (the last may be partial).
    counts: Vec<u64>,
    /// Sums, block-major, then model, then level.
    sums: Vec<f64>,
}

impl Blocks {
    /// No blocks yet, for arms of `sizes` settings each.
    pub fn new(sizes: &[usize]) -> Self {
        let offsets = std::iter::once(0)
            .chain(sizes.iter().scan(0, |acc, &n| {
                *acc += n;
                Some(*acc)
            }))
            .collect();
        Blocks {
            offsets,
            size: SUB_BLOCK,
            counts: Vec::new(),
            sums: Vec::new(),
        }
    }

    fn stride(&self) -> usize {
        *self.offsets.last().expect("offsets start with 0")
    }

    /// Add the per-arm, per-setting sums (arm-major) of the `count`
    /// iterations starting at `start`; they lie inside one sub-block, after every earlier add.
    pub fn add(&mut self, start: u64, count: u64, sums: &[f64]) {
        debug_assert_eq!(sums.len(), self.stride());
        let mut j = (start / self.size) as usize;
        if j >= self.counts.len() {
            if self.counts.len() == MAX_BLOCKS {
                self.double();
                j = (start / self.size) as usize;
            }
            let stride = self.stride();
            while self.counts.len() <= j {
                self.counts.push(0);
                self.sums.extend(std::iter::repeat_n(0.0, stride));
            }
        }
        debug_assert_eq!(j + 1, self.counts.len(), "blocks are filled in order");
        self.counts[j] += count;
        let stride = self.stride();
        self.sums[j * stride..(j + 1) * stride]
            .iter_mut()
            .zip(sums)
            .for_each(|(a, b)| *a += *b);
    }

    /// The blocks of one setting per arm, `keep` being `(arm, setting)` pairs: the result has
    /// an arm of one setting per pair (e.g. each reference at its best level, kept to be
    /// combined with many other runs, at a fraction of the memory).
    pub fn select(&self, keep: &[(usize, usize)]) -> Blocks {
        let stride = self.stride();
        let sums = (0..self.counts.len())
            .flat_map(|j| {
                keep.iter()
                    .map(move |&(arm, level)| self.sums[j * stride + self.offsets[arm] + level])
            })
            .collect();
        Blocks {
            offsets: (0..=keep.len()).collect(),
            size: self.size,
            counts: self.counts.clone(),
            sums,
        }
    }

    /// Merge blocks pairwise: the block size doubles and the count halves.
    fn double(&mut self) {
        let stride = self.stride();
        let pairs = self.counts.len().div_ceil(2);
        for p in 0..pairs {
            let (a, b) = (2 * p, 2 * p + 1);
            let count = self.counts[a] + self.counts.get(b).copied().unwrap_or(0);
            self.counts[p] = count;
            for k in 0..stride {
                let second = if b < self.counts.len() {
                    self.sums[b * stride + k]
                } else {
                    0.0
                };
                self.sums[p * stride + k] = self.sums[a * stride + k] + second;
            }
        }
        self.counts.truncate(pairs);
        self.sums.truncate(pairs * stride);
        self.size *= 2;
    }

    /// Standard error (px) of sum(coef x R) over `terms`, from the scatter of the block means:
    /// with x_j the block sums of the combination and n_j the block sizes, the mean is
    /// m = sum x_j / sum n_j and var(m) = J / (J - 1) sum (x_j - n_j m)^2 / (sum n_j)^2.
    /// Infinite with fewer than two blocks.
    pub fn standard_error(&self, terms: &[Term]) -> f64 {
        Self::standard_error_across(&[(self, terms)])
    }

    /// [`Blocks::standard_error`] of a combination whose terms lie in several runs of the same
    /// iterations on common random numbers (`(run's blocks, its terms)`; e.g. a detector run
    /// beside references run once for many detectors): every run over the same iterations has
    /// the same blocks. Infinite when their blocks differ or with fewer than two blocks.
    pub fn standard_error_across(parts: &[(&Blocks, &[Term])]) -> f64 {
        let Some((first, _)) = parts.first() else {
            return f64::INFINITY;
        };
        let blocks = first.counts.len();
        if blocks < 2 || parts.iter().any(|(b, _)| b.counts != first.counts) {
            return f64::INFINITY;
        }
        let x: Vec<f64> = (0..blocks)
            .map(|j| {
                parts
                    .iter()
                    .flat_map(|(b, terms)| {
                        let at = j * b.stride();
                        terms
                            .iter()
                            .map(move |t| t.coef * b.sums[at + b.offsets[t.model] + t.level])
                    })
                    .sum()
            })
            .collect();
        let counts = &first.counts;
        let n: f64 = counts.iter().sum::<u64>() as f64;
        let mean = x.iter().sum::<f64>() / n;
        let ss: f64 = x
            .iter()
            .zip(counts)
            .map(|(xj, &nj)| (xj - nj as f64 * mean).powi(2))
            .sum();
        let j = blocks as f64;
        (ss * j / (j - 1.0)).sqrt() / n
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rng::stream;
    use rand_distr::{Distribution, StandardNormal};

    #[test]
    fn doubling_keeps_the_sums_and_bounds_the_count() {
        // One model, two levels; per-iteration values k and 2k for iteration k.
        let mut b = Blocks::new(&[2]);
        let total = SUB_BLOCK * MAX_BLOCKS as u64 * 3 + 17;
        let mut start = 0;
        while start < total {
            let end = ((start / SUB_BLOCK + 1) * SUB_BLOCK).min(total);
            let s: f64 = (start..end).map(|k| k as f64).sum();
            b.add(start, end - start, &[s, 2.0 * s]);
            start = end;
        }
        let len = b.counts.len();
        assert!(len <= MAX_BLOCKS && len > MAX_BLOCKS / 4, "{len}");
        assert_eq!(b.counts.iter().sum::<u64>(), total);
        let want = (total * (total - 1) / 2) as f64;
        let got: f64 = b.sums.iter().step_by(2).sum();
        assert_eq!(got, want);
        // Every block but the last is full.
        let full = b.counts[..len - 1].iter().all(|&c| c == b.size);
        assert!(full);
    }

    #[test]
    fn a_combination_across_runs_of_the_same_iterations_is_the_one_of_a_joint_run() {
        // Two models of two levels run together, or each alone over the same iterations (the
        // second kept at one level only): the same SE of any combination; runs over other
        // iterations have other blocks, so no SE.
        let (mut joint, mut first, mut second) =
            (Blocks::new(&[2, 2]), Blocks::new(&[2]), Blocks::new(&[2]));
        let mut rng = stream(3, 0, 0);
        for start in (0..64 * SUB_BLOCK).step_by(SUB_BLOCK as usize) {
            let v: [f64; 4] = std::array::from_fn(|_| StandardNormal.sample(&mut rng));
            joint.add(start, SUB_BLOCK, &v);
            first.add(start, SUB_BLOCK, &v[..2]);
            second.add(start, SUB_BLOCK, &v[2..]);
        }
        let term = |model, level, coef| Term { model, level, coef };
        let want = joint.standard_error(&[term(0, 1, 1.0), term(1, 0, -0.7), term(1, 1, -0.3)]);
        let kept = second.select(&[(0, 1), (0, 0)]);
        let parts = [
            (&first, &[term(0, 1, 1.0)][..]),
            // kept: arm 0 is the second model's level 1, arm 1 its level 0.
            (&kept, &[term(1, 0, -0.7), term(0, 0, -0.3)][..]),
        ];
        let got = Blocks::standard_error_across(&parts);
        assert!((got / want - 1.0).abs() < 1e-12, "{got} vs {want}");
        let mut shorter = Blocks::new(&[2]);
        shorter.add(0, SUB_BLOCK, &[1.0, 2.0]);
        shorter.add(SUB_BLOCK, SUB_BLOCK, &[1.0, 2.0]);
        let mismatched = [(&first, parts[0].1), (&shorter, parts[0].1)];
        assert_eq!(Blocks::standard_error_across(&mismatched), f64::INFINITY);
    }

    #[test]
    fn standard_error_of_a_paired_difference_is_the_sample_one() {
        // Per iteration: x ~ N(0, 1) and y = x + 0.1 z (strongly correlated). The SE of
        // mean(y - x) must be near 0.1 / sqrt(N), far below the independent sqrt(2) / sqrt(N):
        // with 2 models x 1 level, 4096 iterations in blocks of 32 (128 blocks), the SE estimate
        // has a relative standard error near 1 / sqrt(2 x 127) = 6.3 %, so 4 of them is 25 %.
        let n = 4096u64;
        let mut b = Blocks::new(&[1, 1]);
        let mut rng = stream(7, 0, 0);
        for start in (0..n).step_by(SUB_BLOCK as usize) {
            let (mut sx, mut sy) = (0.0, 0.0);
            for _ in 0..SUB_BLOCK {
                let x: f64 = StandardNormal.sample(&mut rng);
                let z: f64 = StandardNormal.sample(&mut rng);
                sx += x;
                sy += x + 0.1 * z;
            }
            b.add(start, SUB_BLOCK, &[sx, sy]);
        }
        let terms = [
            Term {
                model: 1,
                level: 0,
                coef: 1.0,
            },
            Term {
                model: 0,
                level: 0,
                coef: -1.0,
            },
        ];
        let se = b.standard_error(&terms);
        let want = 0.1 / (n as f64).sqrt();
        assert!((se / want - 1.0).abs() < 0.25, "se {se}, want {want}");
        let single = b.standard_error(&terms[..1]);
        assert!((single * (n as f64).sqrt() - 1.0).abs() < 0.25, "{single}");
    }
}
