//! `brightest-n`: the centre of gravity of a frame's N brightest pixels, each less the value
//! of the (N+1)-th brightest (the selection of the Durham simulation platform), N swept.
//!
//! With the pixels sorted once per frame, running sums over the sorted order give every N's
//! centroid in O(1): sum(v) = sum(x) - N t, sum(v X) = sum(x X) - t sum(X), with t the
//! (N+1)-th value and X the positions relative to the truth.

use super::centroider::{CentroidFrame, CentroidWorker, Centroider, Setting, SettingSums};
use super::spec::{CentroiderEntry, CentroiderParam, ParamRange};
use crate::stats::total_order_key;
use crate::Error;

/// `brightest-n`'s registry entry.
pub const ENTRY: CentroiderEntry = CentroiderEntry {
    name: "brightest-n",
    help: "centre of gravity of the N brightest pixels above the (N+1)-th (N swept, or given)",
    param: Some(CentroiderParam {
        name: "n_pixels",
        symbol: "N",
        unit: "pixels",
        meaning: "number of brightest pixels kept",
        range: ParamRange {
            least: 1.0,
            inclusive: true,
            whole: true,
        },
        grid: |ctx| {
            let pixels = ctx.subap_px * ctx.subap_px;
            n_grid(pixels.saturating_sub(1))
                .into_iter()
                .map(|k| k as f64)
                .collect()
        },
    }),
    mask_above: false,
    build: |_, counts, ctx| {
        let pixels = ctx.subap_px * ctx.subap_px;
        if pixels < 2 {
            return Err(Error::invalid(
                "centroider",
                "brightest-n needs a sub-aperture of at least 2 pixels",
            ));
        }
        if let Some(p) = counts.iter().find(|&&k| k as usize >= pixels) {
            return Err(Error::invalid(
                "centroider",
                format!("brightest-n:{p}: N must be below the {pixels} pixels of the sub-aperture"),
            ));
        }
        let grid = counts.iter().map(|&k| k as usize).collect();
        Ok(Box::new(BrightestN::new(grid, ctx.subap_px)))
    },
};

/// Pixel counts N: 1 to 16, then 25 % steps, and `most` (none when `most` is 0).
fn n_grid(most: usize) -> Vec<usize> {
    let mut n: Vec<usize> = (1..=most.min(16)).collect();
    let mut v = 16.0f64;
    loop {
        v *= 1.25;
        let k = v.round() as usize;
        if k >= most {
            break;
        }
        n.push(k);
    }
    if n.last().is_some_and(|&last| last < most) {
        n.push(most);
    }
    n
}

/// The brightest-N centroider over a grid of N.
#[derive(Debug, Clone)]
pub(super) struct BrightestN {
    /// Pixel counts N, ascending, each below n^2.
    grid: Vec<usize>,
    n: usize,
}

impl BrightestN {
    /// N over `grid` (ascending, each in 1..n^2) for n x n sub-apertures.
    pub(super) fn new(grid: Vec<usize>, n: usize) -> Self {
        debug_assert!(grid.windows(2).all(|w| w[0] < w[1]) && grid.iter().all(|&k| k < n * n));
        BrightestN { grid, n }
    }
}

impl Centroider for BrightestN {
    fn name(&self) -> String {
        ENTRY.name.into()
    }

    fn param_name(&self) -> Option<&'static str> {
        ENTRY.param.map(|p| p.name)
    }

    fn settings(&self) -> Vec<Setting> {
        self.grid
            .iter()
            .map(|&k| Setting {
                param: Some(k as f64),
                b_e: 0.0,
                part: 0,
            })
            .collect()
    }

    fn sums(&self) -> SettingSums {
        SettingSums::new(&[self.grid.len()])
    }

    fn needs_noise_map(&self) -> bool {
        false
    }

    fn worker(&self) -> Box<dyn CentroidWorker + '_> {
        Box::new(BrightestWorker {
            c: self,
            keys: Vec::with_capacity(self.n * self.n),
        })
    }
}

/// A thread's pixel order: per pixel, a key that sorts brightest first and then by pixel
/// index, and the index.
struct BrightestWorker<'c> {
    c: &'c BrightestN,
    keys: Vec<(u64, u32)>,
}

/// A key of `v` that orders ascending as `v` does descending by `f64::total_cmp`.
fn descending(v: f64) -> u64 {
    !total_order_key(v)
}

impl CentroidWorker for BrightestWorker<'_> {
    fn accumulate(&mut self, f: &CentroidFrame, acc: &mut SettingSums) {
        let (img, n) = (f.image_e, self.c.n);
        let c = (n as f64 - 1.0) / 2.0;
        let (tx, ty) = (f.truth_px.0 + c, f.truth_px.1 + c);
        // Brightest first; ties broken by pixel index so the order is reproducible. Sorted
        // as integer pairs (the values' total order, then the index): no look-up of the
        // image and no float comparison inside the sort, which was most of this centroider's
        // time.
        self.keys.clear();
        self.keys.extend(
            img[..n * n]
                .iter()
                .enumerate()
                .map(|(i, &v)| (descending(v), i as u32)),
        );
        self.keys.sort_unstable();
        let order = |k: usize| self.keys[k].1 as usize;
        let sums = acc.part_mut(0);
        // Running sums over the brightest pixels: value, value x X, value x Y, X, Y.
        let mut run = [0.0f64; 5];
        let mut taken = 0;
        for (k, &want) in self.c.grid.iter().enumerate() {
            while taken < want {
                let p = order(taken);
                let (x, y) = ((p % n) as f64 - tx, (p / n) as f64 - ty);
                let v = img[p];
                run[0] += v;
                run[1] += v * x;
                run[2] += v * y;
                run[3] += x;
                run[4] += y;
                taken += 1;
            }
            let t = img[order(want)];
            let mass = run[0] - want as f64 * t;
            if mass > 0.0 {
                let (mx, my) = (run[1] - t * run[3], run[2] - t * run[4]);
                let d = (mx * mx + my * my).sqrt() / mass;
                sums.add_error(k, d, (mx / mass, my / mass));
            } else {
                // All N equal to the (N+1)-th: nothing above the threshold, the centre is
                // the estimate.
                sums.add_empty(k, f.truth_px);
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::{descending, n_grid};

    #[test]
    fn n_grid_is_ascending_and_ends_at_most() {
        for most in [1, 3, 15, 16, 17, 63, 255] {
            let n = n_grid(most);
            assert!(n.windows(2).all(|w| w[0] < w[1]), "{n:?}");
            assert_eq!((n[0], *n.last().unwrap()), (1, most));
        }
        assert!(n_grid(0).is_empty());
    }

    #[test]
    fn keys_sort_brightest_first_as_total_cmp_does() {
        let v = crate::stats::AWKWARD;
        let mut want: Vec<usize> = (0..v.len()).collect();
        want.sort_by(|&a, &b| v[b].total_cmp(&v[a]).then(a.cmp(&b)));
        let mut keys: Vec<(u64, u32)> = v
            .iter()
            .enumerate()
            .map(|(i, &x)| (descending(x), i as u32))
            .collect();
        keys.sort_unstable();
        let got: Vec<usize> = keys.iter().map(|k| k.1 as usize).collect();
        assert_eq!(got, want);
    }
}
