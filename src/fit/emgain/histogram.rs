//! The histogram an EM-gain fit works on: pixel values (adu) binned one frame at a time in a
//! window that follows the bulk of the values, with the quantiles, moments and tail figures
//! the start values need.

use crate::error::{Error, Result};

/// A histogram of pixel values (adu) on bins of width `width` centred on multiples of it,
/// filled one frame at a time (memory O(range), not O(stack)).
///
/// The bins cover a window of at most 2^22 bins (`MAX_HIST_BINS`), placed around the bulk of
/// the first frame (its median) and grown towards later values while it fits; values outside
/// the window are far outliers (a hot pixel, a corrupt sample), only counted. So one wild
/// sample costs neither memory nor time.
#[derive(Debug, Clone)]
pub struct ValueHistogram {
    width: f64,
    /// Key (bin index counted from 0 adu) of the first bin.
    pub(super) start: i64,
    counts: Vec<f64>,
    sum: f64,
    sum2: f64,
    outside: f64,
}

/// Widest value range a histogram may span, in bins (2^22: 32 MiB of counts; 4 Mi adu at
/// the 1 adu bins of integer data, far beyond any camera's range of EM-gain frames).
pub(super) const MAX_HIST_BINS: i64 = 1 << 22;

impl ValueHistogram {
    /// Empty histogram with bins of `width_adu` (1 for integer data).
    pub fn new(width_adu: f64) -> Self {
        assert!(width_adu > 0.0);
        ValueHistogram {
            width: width_adu,
            start: 0,
            counts: Vec::new(),
            sum: 0.0,
            sum2: 0.0,
            outside: 0.0,
        }
    }

    /// Histogram of `values` (adu).
    pub fn from_values(values: &[f64], width_adu: f64) -> Result<Self> {
        let mut h = Self::new(width_adu);
        h.add_all(values)?;
        Ok(h)
    }

    /// Add values (adu); non-finite values are an error.
    pub fn add_all(&mut self, values: &[f64]) -> Result<()> {
        let (mut lo, mut hi) = (i64::MAX, i64::MIN);
        for v in values {
            if !v.is_finite() {
                return Err(Error::Numeric(format!("non-finite pixel value {v}")));
            }
            if let Some(k) = self.key(*v) {
                lo = lo.min(k);
                hi = hi.max(k);
            }
        }
        if lo > hi {
            // Nothing to bin (no values, or only values beyond any key).
            self.outside += values.len() as f64;
            return Ok(());
        }
        if self.counts.is_empty() {
            self.place_window(values, lo, hi);
        } else {
            self.grow_window(lo, hi);
        }
        let end = self.end();
        for v in values {
            match self.key(*v) {
                Some(k) if k >= self.start && k < end => {
                    self.counts[(k - self.start) as usize] += 1.0;
                    self.sum += v;
                    self.sum2 += v * v;
                }
                _ => self.outside += 1.0,
            }
        }
        Ok(())
    }

    /// Bin key of `v`: its bin index counted from 0 adu; None beyond +-2^61 bins, far
    /// from any window (so that key arithmetic cannot overflow).
    fn key(&self, v: f64) -> Option<i64> {
        let k = (v / self.width + 0.5).floor();
        (k.abs() < (1u64 << 61) as f64).then_some(k as i64)
    }

    /// One past the last key of the window.
    fn end(&self) -> i64 {
        self.start + self.counts.len() as i64
    }

    /// The first window: all of [lo, hi] if it fits, else MAX_HIST_BINS around the median.
    fn place_window(&mut self, values: &[f64], lo: i64, hi: i64) {
        let (start, end) = if hi - lo < MAX_HIST_BINS {
            (lo, hi + 1)
        } else {
            let mut keys: Vec<i64> = values.iter().filter_map(|v| self.key(*v)).collect();
            let mid = keys.len() / 2;
            let median = *keys.select_nth_unstable(mid).1;
            let start = (median - MAX_HIST_BINS / 2).max(lo);
            (start, (start + MAX_HIST_BINS).min(hi + 1))
        };
        self.start = start;
        self.counts = vec![0.0; (end - start) as usize];
    }

    /// Extend the window towards [lo, hi] as far as MAX_HIST_BINS allows.
    fn grow_window(&mut self, lo: i64, hi: i64) {
        let end = self.end();
        let new_start = lo.min(self.start).max(end - MAX_HIST_BINS);
        let new_end = (hi + 1).max(end).min(new_start + MAX_HIST_BINS);
        if new_start < self.start {
            let mut c = vec![0.0; (self.start - new_start) as usize];
            c.extend_from_slice(&self.counts);
            self.counts = c;
            self.start = new_start;
        }
        self.counts.resize((new_end - self.start) as usize, 0.0);
    }

    /// Values that fell outside the histogram's window (far outliers, not in any bin).
    pub fn outside(&self) -> f64 {
        self.outside
    }

    /// Number of values.
    pub fn total(&self) -> f64 {
        self.counts.iter().sum()
    }

    /// Mean and variance of the values (adu, adu^2).
    pub fn mean_var(&self) -> (f64, f64) {
        let n = self.total();
        let m = self.sum / n;
        (m, (self.sum2 / n - m * m) * n / (n - 1.0))
    }

    /// Bin width (adu).
    pub fn width(&self) -> f64 {
        self.width
    }

    /// Centre of bin `i` (adu).
    pub fn centre(&self, i: usize) -> f64 {
        (self.start + i as i64) as f64 * self.width
    }

    /// Counts per bin.
    pub fn counts(&self) -> &[f64] {
        &self.counts
    }

    /// Approximate p-quantile (adu), at bin resolution.
    pub(super) fn quantile(&self, p: f64) -> f64 {
        let target = p * self.total();
        let mut acc = 0.0;
        for (i, c) in self.counts.iter().enumerate() {
            if acc + c >= target && *c > 0.0 {
                let frac = ((target - acc) / c).clamp(0.0, 1.0);
                return self.centre(i) + (frac - 0.5) * self.width;
            }
            acc += c;
        }
        self.centre(self.counts.len() - 1)
    }

    /// The lower tail of the values: a low quantile and the scale (adu, a Gaussian sigma)
    /// from its spacing to a higher one. The quantiles are 1e-4 and 1e-3 (0.63 sigma apart)
    /// with many values, but at least the 20th and 200th lowest value, so that a few far
    /// outliers below the bias move neither.
    pub(super) fn low_tail(&self) -> (f64, f64) {
        let n = self.total().max(1.0);
        let p_lo = (1e-4f64).max(20.0 / n).min(0.05);
        let p_hi = (10.0 * p_lo).min(0.5);
        let z = |p: f64| -> f64 {
            -std::f64::consts::SQRT_2 * statrs::function::erf::erfc_inv(2.0 * p)
        };
        let (q_lo, q_hi) = (self.quantile(p_lo), self.quantile(p_hi));
        (q_lo, (q_hi - q_lo) / (z(p_hi) - z(p_lo)))
    }

    /// Count, mean and variance (adu, adu^2) of the binned values whose bins lie within
    /// [lo, hi] adu: the moments with far outliers trimmed.
    pub(super) fn moments_within(&self, lo: f64, hi: f64) -> (f64, f64, f64) {
        let (mut n, mut s, mut s2) = (0.0, 0.0, 0.0);
        for (i, c) in self.counts.iter().enumerate() {
            let x = self.centre(i);
            if *c > 0.0 && x >= lo && x <= hi {
                n += c;
                s += c * x;
                s2 += c * x * x;
            }
        }
        let m = s / n;
        (n, m, (s2 / n - m * m) * n / (n - 1.0))
    }

    /// Number of values above `t` (adu) and the median of their excess over `t`.
    pub(super) fn tail_above(&self, t: f64) -> (f64, f64) {
        let above: Vec<(f64, f64)> = self
            .counts
            .iter()
            .enumerate()
            .filter(|(i, c)| **c > 0.0 && self.centre(*i) > t)
            .map(|(i, c)| (self.centre(i) - t, *c))
            .collect();
        let k: f64 = above.iter().map(|a| a.1).sum();
        let mut acc = 0.0;
        let median = above
            .iter()
            .find(|(_, c)| {
                acc += c;
                acc >= 0.5 * k
            })
            .map_or(0.0, |a| a.0);
        (k, median)
    }

    /// Fraction of values below `x` (adu), interpolating within the bin.
    pub(super) fn cdf(&self, x: f64) -> f64 {
        let mut acc = 0.0;
        for (i, c) in self.counts.iter().enumerate() {
            let a = self.centre(i) - 0.5 * self.width;
            if x < a {
                break;
            }
            acc += c * ((x - a) / self.width).min(1.0);
        }
        acc / self.total()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn values_fall_in_bins_centred_on_multiples_of_the_width() {
        // Keys floor(v / w + 1/2): 0.9 and 1.1 -> 1, 2.0 and 2.49 -> 2, 2.51 -> 3.
        let h = ValueHistogram::from_values(&[0.9, 1.1, 2.0, 2.49, 2.51], 1.0).unwrap();
        assert_eq!(h.counts(), [2.0, 2.0, 1.0]);
        assert_eq!((h.centre(0), h.centre(2), h.total()), (1.0, 3.0, 5.0));
        // Moments of the values themselves: mean 9/5, unbiased variance 2.3202 / 4.
        let (m, v) = h.mean_var();
        assert!(
            (m - 1.8).abs() < 1e-12 && (v - 0.58005).abs() < 1e-12,
            "{m} {v}"
        );
        // Half-width bins: 0.9 -> key 2 (centre 1.0), 1.1 -> 2, 2.0 -> 4 (centre 2.0).
        let h = ValueHistogram::from_values(&[0.9, 1.1, 2.0], 0.5).unwrap();
        assert_eq!((h.counts(), h.centre(0)), (&[2.0, 0.0, 1.0][..], 1.0));
    }

    #[test]
    fn far_outliers_are_counted_outside_and_non_finite_values_refused() {
        let mut h = ValueHistogram::from_values(&[1.0, 1e300], 1.0).unwrap();
        assert_eq!((h.counts(), h.outside()), (&[1.0][..], 1.0));
        h.add_all(&[2.0, 0.0]).unwrap();
        assert_eq!(h.counts(), [1.0, 1.0, 1.0]);
        assert!(h.add_all(&[f64::INFINITY]).is_err());
    }
}
