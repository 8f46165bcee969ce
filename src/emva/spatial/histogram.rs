//! The standard's logarithmic and accumulated histograms, its 5 x 5 highpass filter and the
//! defect pixel counts.

use rayon::prelude::*;

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
    let ocols = cols - 2 * half;
    let mut out = vec![0.0; (rows - 2 * half) * ocols];
    // 5 x 5 boxes of numbers (no NaN, whose place in the order the network's comparisons do
    // not follow) go through the selection network, LANES pixels at a time; other boxes are
    // selected one by one. Output rows in parallel: each pixel's value is its own.
    let network = dim == 5 && !image.iter().any(|v| v.is_nan());
    out.par_chunks_mut(ocols)
        .enumerate()
        .for_each(|(orow, line)| {
            let r = orow + half;
            if network {
                median5_row(image, cols, r, line);
            } else {
                median_row(image, cols, dim, r, line);
            }
        });
    out
}

/// Output `line` of [`median_highpass`] (box centred on image row `r`), one pixel at a time.
fn median_row(image: &[f64], cols: usize, dim: usize, r: usize, line: &mut [f64]) {
    let half = dim / 2;
    let mut window = vec![0.0; dim * dim];
    for (oc, o) in line.iter_mut().enumerate() {
        let c = oc + half;
        for (wr, w) in window.chunks_exact_mut(dim).enumerate() {
            let from = (r + wr - half) * cols + c - half;
            w.copy_from_slice(&image[from..from + dim]);
        }
        let median = *window
            .select_nth_unstable_by(dim * dim / 2, f64::total_cmp)
            .1;
        *o = image[r * cols + c] - median;
    }
}

/// Output pixels whose 5 x 5 medians [`median25`] takes at once.
const LANES: usize = 8;

/// Output `line` of [`median_highpass`] for a 5 x 5 box (centred on image row `r`), LANES
/// pixels at a time through [`median25`].
fn median5_row(image: &[f64], cols: usize, r: usize, line: &mut [f64]) {
    let ocols = line.len();
    for c0 in (0..ocols).step_by(LANES) {
        let mut w = [[0.0; LANES]; 25];
        for (k, lanes) in w.iter_mut().enumerate() {
            let from = (r + k / 5 - 2) * cols + k % 5;
            for (l, x) in lanes.iter_mut().enumerate() {
                // Lanes past the row's end repeat its last box (their medians are not used).
                *x = image[from + (c0 + l).min(ocols - 1)];
            }
        }
        let median = median25(&mut w);
        for (l, o) in line[c0..].iter_mut().take(LANES).enumerate() {
            *o = image[r * cols + c0 + l + 2] - median[l];
        }
    }
}

/// Batcher's odd-even merge sort of 32 inputs, the last 7 of them +inf, pruned to the
/// compare-exchanges (min to the first wire, max to the second) that the 13th smallest, on
/// wire 12, depends on (scripts/median25_network.py writes and checks it).
#[rustfmt::skip]
const NET: [(u8, u8); 113] = [
    (0, 1), (2, 3), (4, 5), (6, 7), (8, 9), (10, 11), (12, 13), (14, 15), (16, 17), (18, 19),
    (20, 21), (22, 23), (0, 2), (1, 3), (4, 6), (5, 7), (8, 10), (9, 11), (12, 14), (13, 15),
    (16, 18), (17, 19), (20, 22), (21, 23), (1, 2), (5, 6), (9, 10), (13, 14), (17, 18),
    (21, 22), (0, 4), (1, 5), (2, 6), (3, 7), (8, 12), (9, 13), (10, 14), (11, 15), (16, 20),
    (17, 21), (18, 22), (19, 23), (2, 4), (3, 5), (10, 12), (11, 13), (18, 20), (19, 21),
    (1, 2), (3, 4), (5, 6), (9, 10), (11, 12), (13, 14), (17, 18), (19, 20), (21, 22), (0, 8),
    (1, 9), (2, 10), (3, 11), (4, 12), (5, 13), (6, 14), (7, 15), (16, 24), (4, 8), (5, 9),
    (6, 10), (7, 11), (20, 24), (2, 4), (3, 5), (6, 8), (7, 9), (10, 12), (11, 13), (18, 20),
    (19, 21), (22, 24), (1, 2), (3, 4), (5, 6), (7, 8), (9, 10), (11, 12), (13, 14), (17, 18),
    (19, 20), (21, 22), (23, 24), (0, 16), (1, 17), (2, 18), (3, 19), (4, 20), (5, 21),
    (6, 22), (7, 23), (8, 24), (8, 16), (9, 17), (10, 18), (11, 19), (12, 20), (13, 21),
    (6, 10), (7, 11), (12, 16), (13, 17), (10, 12), (11, 13), (11, 12),
];

crate::io::widest! {
    /// The medians of LANES boxes of 25 numbers at once (box `l`'s values in `w[..][l]`):
    /// [`NET`]'s compare-exchanges, branch-free, leave the 13th smallest value on wire 12, the
    /// value a sort puts in the middle.
    fn median25(w: &mut [[f64; LANES]; 25]) -> [f64; LANES] {
        for &(a, b) in &NET {
            let (x, y) = (w[a as usize], w[b as usize]);
            for l in 0..LANES {
                let lower = x[l] < y[l];
                w[a as usize][l] = if lower { x[l] } else { y[l] };
                w[b as usize][l] = if lower { y[l] } else { x[l] };
            }
        }
        w[12]
    }
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

#[cfg(test)]
mod tests {
    use super::*;

    /// A 37 x 29 image (output rows of 25 pixels: three full groups of LANES and a part one)
    /// of values from a hash, drawn from `levels` distinct values so that boxes hold ties.
    fn image(levels: u64, seed: u64) -> Vec<f64> {
        (0..37 * 29)
            .map(|i| {
                let h = (i as u64 ^ seed).wrapping_mul(0x9e37_79b9_7f4a_7c15);
                ((h >> 40) % levels) as f64 * 0.5 - 3.0
            })
            .collect()
    }

    #[test]
    fn the_median_network_gives_the_middle_of_every_box() {
        let shape = (37, 29);
        for (levels, seed) in [(3, 1), (7, 2), (1000, 3), (1 << 20, 4)] {
            let img = image(levels, seed);
            let got = median_highpass(&img, shape, 5);
            let mut want = vec![0.0; got.len()];
            for (orow, line) in want.chunks_mut(25).enumerate() {
                median_row(&img, 29, 5, orow + 2, line);
            }
            assert_eq!(got, want, "{levels} levels");
        }
        // Every one of the 25 ranks on the middle wire for some box: a sort's middle element.
        for k in 0..25 {
            let mut w = [[0.0; LANES]; 25];
            for (i, v) in w.iter_mut().enumerate() {
                *v = [((i + k) % 25) as f64; LANES];
            }
            assert_eq!(median25(&mut w), [12.0; LANES]);
        }
        // A NaN anywhere: every box is selected one by one (NaN sorts last).
        let mut img = image(7, 5);
        img[100] = f64::NAN;
        let got = median_highpass(&img, shape, 5);
        assert!(got.iter().filter(|v| v.is_nan()).count() == 1);
    }
}
