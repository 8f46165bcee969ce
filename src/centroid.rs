//! Centre of gravity with background subtraction, swept over background levels.
//!
//! At level b each pixel contributes v = max(x - b, 0) (the Durham platform's "subtract and
//! clip"). Positions are in pixels from the sub-aperture centre (n-1)/2.

/// Centre of gravity (x, y) in px from the centre of an n x n row-major image; None if the
/// image sums to zero or less.
pub fn cog(img: &[f64], n: usize) -> Option<(f64, f64)> {
    let c = (n as f64 - 1.0) / 2.0;
    let (mut s, mut sx, mut sy) = (0.0, 0.0, 0.0);
    for (i, row) in img.chunks_exact(n).enumerate() {
        for (j, &v) in row.iter().enumerate() {
            s += v;
            sx += v * j as f64;
            sy += v * i as f64;
        }
    }
    (s > 0.0).then(|| (sx / s - c, sy / s - c))
}

/// Background levels (e-), ascending, with reusable scratch for one sub-aperture size.
#[derive(Debug, Clone)]
pub struct BackgroundSweep {
    levels: Vec<f64>,
    n: usize,
    order: Vec<(f64, u32)>,
}

/// Position error of one frame at one background level.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LevelError {
    /// Distance between the estimated and the true position (px).
    pub distance_px: f64,
    /// True when no pixel exceeded the level (the estimate is then the centre).
    pub empty: bool,
}

impl BackgroundSweep {
    /// Sweep over `levels` (e-, any order; sorted here) for n x n images.
    pub fn new(mut levels: Vec<f64>, n: usize) -> Self {
        levels.sort_by(f64::total_cmp);
        levels.dedup();
        BackgroundSweep {
            levels,
            n,
            order: Vec::with_capacity(n * n),
        }
    }

    /// The levels (e-), ascending.
    pub fn levels(&self) -> &[f64] {
        &self.levels
    }

    /// For each level, the error of the centre of gravity of max(img - b, 0) against `truth`.
    ///
    /// Pixels are sorted by value once; walking the levels from the top adds each pixel once,
    /// so a frame costs O(n^2 log n + levels) instead of O(n^2 x levels). The sums are
    /// S(b) = sum(v) - b C, Sx(b) = sum(v j) - b sum(j), over the C pixels with v > b.
    pub fn errors(&mut self, img: &[f64], truth: (f64, f64), out: &mut [LevelError]) {
        let n = self.n;
        let c = (n as f64 - 1.0) / 2.0;
        self.order.clear();
        self.order
            .extend(img.iter().enumerate().map(|(k, &v)| (v, k as u32)));
        self.order.sort_unstable_by(|a, b| b.0.total_cmp(&a.0));
        let (mut sv, mut svx, mut svy, mut cnt, mut sj, mut si) = (0.0, 0.0, 0.0, 0.0, 0.0, 0.0);
        let mut next = 0;
        // Distances are O(1) px: plain sqrt is exact enough and much cheaper than hypot.
        let centre_error = (truth.0 * truth.0 + truth.1 * truth.1).sqrt();
        for (level, o) in self.levels.iter().zip(out.iter_mut()).rev() {
            while next < self.order.len() && self.order[next].0 > *level {
                let (v, k) = self.order[next];
                let (i, j) = ((k as usize / n) as f64, (k as usize % n) as f64);
                sv += v;
                svx += v * j;
                svy += v * i;
                cnt += 1.0;
                sj += j;
                si += i;
                next += 1;
            }
            let s = sv - level * cnt;
            *o = if cnt > 0.0 && s > 0.0 {
                let x = (svx - level * sj) / s - c;
                let y = (svy - level * si) / s - c;
                LevelError {
                    distance_px: (x - truth.0).hypot(y - truth.1),
                    empty: false,
                }
            } else {
                LevelError {
                    distance_px: centre_error,
                    empty: true,
                }
            };
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn known_images_give_known_centroids() {
        // A single bright pixel at (row 1, col 3) of a 4x4: CoG at (3 - 1.5, 1 - 1.5).
        let mut img = vec![0.0; 16];
        img[4 + 3] = 5.0;
        assert_eq!(cog(&img, 4), Some((1.5, -0.5)));
        // Two equal pixels: midpoint.
        img[4 + 1] = 5.0;
        assert_eq!(cog(&img, 4), Some((0.5, -0.5)));
        assert_eq!(cog(&[0.0; 9], 3), None);
    }

    #[test]
    fn sweep_matches_direct_thresholded_cog() {
        let n = 5;
        let img: Vec<f64> = (0..25)
            .map(|k| ((k * 37 % 11) as f64 - 3.0) * 0.7)
            .collect();
        let levels = vec![0.0, 0.5, 1.0, 2.2, 4.0, 100.0];
        let mut sweep = BackgroundSweep::new(levels.clone(), n);
        let truth = (0.1, -0.2);
        let mut out = vec![
            LevelError {
                distance_px: 0.0,
                empty: false
            };
            levels.len()
        ];
        sweep.errors(&img, truth, &mut out);
        for (b, e) in levels.iter().zip(&out) {
            let v: Vec<f64> = img.iter().map(|x| (x - b).max(0.0)).collect();
            match cog(&v, n) {
                Some((x, y)) => {
                    assert!(!e.empty);
                    assert!((e.distance_px - (x - truth.0).hypot(y - truth.1)).abs() < 1e-12);
                }
                None => {
                    assert!(e.empty, "level {b}");
                    assert!((e.distance_px - truth.0.hypot(truth.1)).abs() < 1e-15);
                }
            }
        }
    }
}
