//! The centre of gravity of an image and its first moments, the paper's centroid.

/// Centre of gravity (x, y) in px from the centre of an n x n row-major image; None if the
/// image sums to zero or less.
pub fn cog(img: &[f64], n: usize) -> Option<(f64, f64)> {
    ImageSums::of(img, n).centroid(n)
}

/// First moments of an n x n row-major image: its total, and the total weighted by column and
/// by row index (units of the image, times px for the weighted two).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ImageSums {
    /// Sum of the pixels.
    pub total: f64,
    /// Sum of pixel x column index.
    pub col: f64,
    /// Sum of pixel x row index.
    pub row: f64,
}

impl ImageSums {
    /// Partial sums kept per image column modulo 4.
    const LANES: usize = 4;

    /// The sums of the n x n `img`. Each is kept in four partial sums (columns 4k, 4k + 1, ...)
    /// added at the end: a single running sum is a chain of dependent additions (one addition's
    /// latency per pixel, ~1 ns per pixel of a frame on its own), four chains run side by side
    /// in one vector. The order differs from a plain running sum by rounding only (relative
    /// difference ~1e-16).
    pub fn of(img: &[f64], n: usize) -> Self {
        const L: usize = ImageSums::LANES;
        let index: [f64; L] = std::array::from_fn(|k| k as f64);
        let (mut s, mut sx, mut sy) = ([0.0; L], [0.0; L], [0.0; L]);
        for (i, line) in img[..n * n].chunks_exact(n).enumerate() {
            let y = i as f64;
            let mut chunks = line.chunks_exact(L);
            let mut j0 = 0.0;
            for c in &mut chunks {
                for k in 0..L {
                    s[k] += c[k];
                    sx[k] += c[k] * (j0 + index[k]);
                    sy[k] += c[k] * y;
                }
                j0 += L as f64;
            }
            for (k, &v) in chunks.remainder().iter().enumerate() {
                s[k] += v;
                sx[k] += v * (j0 + index[k]);
                sy[k] += v * y;
            }
        }
        let total = |a: [f64; L]| (a[0] + a[1]) + (a[2] + a[3]);
        ImageSums {
            total: total(s),
            col: total(sx),
            row: total(sy),
        }
    }

    /// The centre of gravity (x, y) in px from the centre of the n x n image; None if the
    /// total is zero or less.
    pub fn centroid(&self, n: usize) -> Option<(f64, f64)> {
        let c = (n as f64 - 1.0) / 2.0;
        (self.total > 0.0).then(|| (self.col / self.total - c, self.row / self.total - c))
    }
}
