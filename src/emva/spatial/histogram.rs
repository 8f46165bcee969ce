//! The standard's logarithmic and accumulated histograms, its 5 x 5 highpass filter and the
//! defect pixel counts.

/// A histogram with the standard's binning (release 4.0, as `emva1288`'s `Histogram1288`):
/// integer bin width W >= 1 in the units of the values binned (sums of L frames), at most
/// `qmax` bins from the smallest value.
#[derive(Clone, Debug, PartialEq)]
pub struct Binned {
    /// Lower edge of each bin (units of the values).
    pub lower: Vec<f64>,
    /// Pixels per bin.
    pub counts: Vec<u64>,
    /// Bin width.
    pub width: f64,
    /// Mean and standard deviation (ddof 0) of the values.
    pub mean: f64,
    /// See `mean`.
    pub std: f64,
}

/// Bin `values` the standard's way (an empty histogram for no values).
pub fn bin1288(values: &[f64], qmax: usize) -> Binned {
    if values.is_empty() {
        return Binned {
            lower: Vec::new(),
            counts: Vec::new(),
            width: 1.0,
            mean: f64::NAN,
            std: f64::NAN,
        };
    }
    let lo = values.iter().copied().fold(f64::INFINITY, f64::min);
    let hi = values.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    let span = hi - lo;
    let qmax = qmax.max(1) as f64;
    let (width, q) = if span + 1.0 > qmax {
        let w = (span / qmax).floor() + 1.0;
        (w, (span / w).floor() + 1.0)
    } else {
        (1.0, span.floor() + 1.0)
    };
    let q = q as usize;
    let mut counts = vec![0u64; q];
    for v in values {
        let k = (((v - lo) / width).floor() as usize).min(q - 1);
        counts[k] += 1;
    }
    let n = values.len() as f64;
    let mean = values.iter().sum::<f64>() / n;
    let std = (values.iter().map(|v| (v - mean) * (v - mean)).sum::<f64>() / n).sqrt();
    Binned {
        lower: (0..q).map(|i| lo + i as f64 * width).collect(),
        counts,
        width,
        mean,
        std,
    }
}

impl Binned {
    /// The normal distribution of the values' mean and deviation, as pixels per bin at each
    /// lower edge (the standard's model line). The reference implementation scales by
    /// (max - min) / Q rather than by the bin width W; this uses W, so the model's total is the
    /// pixel count.
    pub fn normal_model(&self) -> Vec<f64> {
        let n: u64 = self.counts.iter().sum();
        let norm = self.width * n as f64 / ((2.0 * std::f64::consts::PI).sqrt() * self.std);
        self.lower
            .iter()
            .map(|b| norm * (-0.5 * ((b - self.mean) / self.std).powi(2)).exp())
            .collect()
    }

    /// The accumulated histogram: percent of pixels in each bin and above.
    pub fn accumulated_percent(&self) -> Vec<f64> {
        let n: u64 = self.counts.iter().sum();
        let mut acc = 0u64;
        let mut out: Vec<f64> = self
            .counts
            .iter()
            .rev()
            .map(|c| {
                acc += c;
                100.0 * acc as f64 / n as f64
            })
            .collect();
        out.reverse();
        out
    }
}

/// |v - trunc(mean)| of each value: the accumulated histograms' input (the standard's
/// deviation from the mean, the mean truncated to an integer as `emva1288` does so that
/// integer sums stay integers).
pub fn abs_deviation(values: &[f64]) -> Vec<f64> {
    let mean = (values.iter().sum::<f64>() / values.len().max(1) as f64).trunc();
    values.iter().map(|v| (v - mean).abs()).collect()
}

/// The standard's highpass filter of size `dim` (odd): `dim^2 y - box(y)` over the valid
/// region (the image less `dim/2` on each side), left multiplied by `dim^2` so integer input
/// stays integer. Returns the filtered image (row-major) and its shape (empty when the image
/// is smaller than the filter).
pub fn highpass(image: &[f64], shape: (usize, usize), dim: usize) -> (Vec<f64>, (usize, usize)) {
    let (rows, cols) = shape;
    if rows < dim || cols < dim {
        return (Vec::new(), (0, 0));
    }
    let half = dim / 2;
    let (orows, ocols) = (rows - 2 * half, cols - 2 * half);
    // Column sums over `dim` rows, then a sliding window along each output row.
    let mut out = Vec::with_capacity(orows * ocols);
    let mut colsum = vec![0.0; cols];
    for r in 0..orows {
        colsum.iter_mut().for_each(|c| *c = 0.0);
        for rr in r..r + dim {
            for (c, v) in colsum.iter_mut().zip(&image[rr * cols..(rr + 1) * cols]) {
                *c += v;
            }
        }
        for c in 0..ocols {
            let boxsum: f64 = colsum[c..c + dim].iter().sum();
            let centre = image[(r + half) * cols + c + half];
            out.push((dim * dim) as f64 * centre - boxsum);
        }
    }
    (out, (orows, ocols))
}

/// Each pixel less the median of the `dim` x `dim` box around it, over the valid region
/// (row-major; empty when the image is smaller than the box). Unlike the standard's box
/// highpass, one defect leaves its neighbours alone (a dead pixel would otherwise shift the 24
/// around it by 1/25 of its depth), so defects are counted once.
pub fn median_highpass(image: &[f64], shape: (usize, usize), dim: usize) -> Vec<f64> {
    let (rows, cols) = shape;
    if rows < dim || cols < dim {
        return Vec::new();
    }
    let half = dim / 2;
    let mut window = vec![0.0; dim * dim];
    let mut out = Vec::with_capacity((rows - 2 * half) * (cols - 2 * half));
    for r in half..rows - half {
        for c in half..cols - half {
            for (k, w) in window.iter_mut().enumerate() {
                *w = image[(r + k / dim - half) * cols + c + k % dim - half];
            }
            let median = *window
                .select_nth_unstable_by(dim * dim / 2, f64::total_cmp)
                .1;
            out.push(image[r * cols + c] - median);
        }
    }
    out
}

/// Pixels far from the bulk of an image: counts above and below the median by more than
/// `factor` robust standard deviations (1.4826 x the median absolute deviation, which a few
/// defects do not inflate as they do the standard deviation).
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct Outliers {
    /// The threshold's factor (robust standard deviations).
    pub factor: f64,
    /// The robust standard deviation, in the units of the image counted.
    pub robust_std: f64,
    /// Pixels above median + factor x robust_std.
    pub above: u64,
    /// Pixels below median - factor x robust_std.
    pub below: u64,
}

/// Count `values` far from their median (see [`Outliers`]).
pub fn outliers(values: &[f64], factor: f64) -> Outliers {
    let median = |v: &mut [f64]| -> f64 {
        if v.is_empty() {
            return f64::NAN;
        }
        let k = v.len() / 2;
        *v.select_nth_unstable_by(k, f64::total_cmp).1
    };
    let mut work = values.to_vec();
    let med = median(&mut work);
    work.iter_mut()
        .zip(values)
        .for_each(|(w, v)| *w = (v - med).abs());
    let robust_std = 1.4826 * median(&mut work);
    let t = factor * robust_std;
    Outliers {
        factor,
        robust_std,
        above: values.iter().filter(|&&v| v > med + t).count() as u64,
        below: values.iter().filter(|&&v| v < med - t).count() as u64,
    }
}
