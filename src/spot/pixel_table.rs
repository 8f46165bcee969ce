//! The pixel-integrated Airy disc, tabulated once per spot and extent and laid out so that one
//! frame reads a few small contiguous blocks.
//!
//! T(x, y) is the integral of the Airy intensity (peak 1) over the unit pixel centred at (x, y)
//! px from the spot centre. It is even in x and in y, so the table holds |x| and |y| below the
//! extent K (whole px) at P phases per px (a power of two): x = k + (q - 1)/P for k = 0..K and
//! phase nodes q = 0..P+3, one node before the pixel's phase range and two after it, so that the
//! cubic interpolation between nodes q and q+1 never crosses into the next k. Values are grouped
//! by phase, at index ((ky Q + qy) K + kx) Q + qx with Q = P + 3: a pixel's four x-nodes are
//! contiguous, and the pixels of a frame, which all share their sub-pixel phase (two phases per
//! axis, one either side of the spot centre), read 4 x 4 nodes from a few small blocks instead
//! of scattered cache lines of a multi-MB table.
//!
//! Accuracy (tested against an independent quadrature): cubic interpolation in both axes errs
//! by at most 5e-6 of the peak value T(0, 0) when P x D >= 64 (D the first-dark-ring diameter;
//! measured 4.6e-6 at D = 4 px, P = 16, and 1e-6 to 2e-6 for D = 0.1 to 2 px), falling as
//! (P D)^-4; the nodes themselves are exact to 2e-7 of the peak (their quadrature, and f32
//! storage). The build's memory budget lowers P only for small spots over large extents
//! (D < 0.25 px at 16x16 px, D < 2 px at 128x128 px), where the error grows as (P D)^-4: 1.4e-5
//! of the peak at D = 1 px and 128x128 px.

use super::cache::Footprint;
use super::kernel::{Kernel, Run};
use super::radial::{lagrange4, RadialTable};

/// Phases per px times the spot diameter (px) aimed at: the cubic interpolation error is then
/// at most 5e-6 of the peak (measured for D = 0.1 to 10 px).
const PHASES_TIMES_DIAMETER: f64 = 64.0;
/// Fewest phases per px (large spots).
const MIN_PHASES: usize = 16;
/// Most phases per px (spots below 0.125 px).
const MAX_PHASES: usize = 512;
/// Most memory one build takes (bytes): the table, and the cumulative integral it is taken from.
pub(super) const BUILD_BUDGET_BYTES: usize = 128 << 20;
/// Gauss-Legendre nodes on [0, 1] (two per axis per grid cell of 1/P px; equal weights 1/2):
/// a cell spans at most 1/64 of a spot diameter unless the budget lowered P.
const GL2: [f64; 2] = [0.211_324_865_405_187_1, 0.788_675_134_594_812_9];

/// The pixel-integrated Airy intensity of one spot over offsets |x|, |y| < extent px.
#[derive(Clone)]
pub(super) struct PixelTable {
    /// log2 of the phases per px P.
    shift: u32,
    /// Phase nodes per whole px, Q = P + 3.
    planes: usize,
    /// Whole px covered per axis, K.
    extent: usize,
    values: Vec<f32>,
}

impl std::fmt::Debug for PixelTable {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("PixelTable")
            .field("phases_per_px", &(1usize << self.shift))
            .field("extent_px", &self.extent)
            .field("bytes", &self.bytes())
            .finish()
    }
}

impl Footprint for PixelTable {
    fn bytes(&self) -> usize {
        self.values.len() * std::mem::size_of::<f32>()
    }
}

/// Whole px per axis a table needs for `n` x `n` px and offsets up to `max_offset_px`: every
/// pixel centre lies within (n-1)/2 + |offset| px of the spot centre.
pub(super) fn extent(n: usize, max_offset_px: f64) -> usize {
    // The margin absorbs the rounding of a pixel's offset computed at the largest offset.
    ((n as f64 - 1.0) / 2.0 + max_offset_px.abs() + 1e-9).floor() as usize + 1
}

/// Bytes a build at `phases` per px and `extent` px takes: f32 table, f64 cumulative integral.
pub(super) fn build_bytes(phases: usize, extent: usize) -> usize {
    let side = (phases + 3) * extent;
    let cumulative = (extent + 1) * phases + 1;
    side * side * 4 + cumulative * cumulative * 8
}

/// Phases per px for a spot of `diameter_px` over `extent` px: the power of two nearest above
/// 64 / D within [16, 512], halved while the build would exceed its memory budget.
pub(super) fn phases(diameter_px: f64, extent: usize) -> usize {
    let wanted = (PHASES_TIMES_DIAMETER / diameter_px).ceil().max(1.0) as usize;
    let mut p = wanted.next_power_of_two().clamp(MIN_PHASES, MAX_PHASES);
    while p > MIN_PHASES && build_bytes(p, extent) > BUILD_BUDGET_BYTES {
        p /= 2;
    }
    p
}

impl PixelTable {
    /// Table of a spot of first-dark-ring diameter `diameter_px` over `extent` whole px per axis,
    /// built on `threads` threads (the values do not depend on their number).
    ///
    /// The pixel integrals are differences of the cumulative integral F(X, Y) of the intensity
    /// over [0, X] x [0, Y] (odd in X and in Y): every pixel edge of every table node lies on
    /// the grid of 1/P px, where F is summed from 2 x 2-point Gauss-Legendre cell integrals. The
    /// cost is O((K P)^2) intensity evaluations whatever the spot size.
    pub(super) fn build(diameter_px: f64, extent: usize, threads: usize) -> Self {
        let p = phases(diameter_px, extent);
        let (q, k) = (p + 3, extent);
        let m = (k + 1) * p;
        let w = m + 1;
        let h = 1.0 / p as f64;
        let radial = RadialTable::new(diameter_px, (m as f64 * h + h) * std::f64::consts::SQRT_2);
        // Squared node coordinates of every cell along an axis.
        let sq: Vec<[f64; 2]> = (0..m)
            .map(|a| GL2.map(|t| ((a as f64 + t) * h).powi(2)))
            .collect();
        let cell_weight = h * h / 4.0;
        // cum[b w + a] = F(a h, b h). Row b + 1 first holds the running sum along x of cell row b.
        let mut cum = vec![0.0f64; w * w];
        par_rows(&mut cum[w..], w, threads, |b, row| {
            let mut acc = 0.0;
            for (a, sx) in sq.iter().enumerate() {
                let mut cell = 0.0;
                for sy in sq[b] {
                    for s in sx {
                        cell += radial.at_cubic((s + sy).sqrt());
                    }
                }
                acc += cell * cell_weight;
                row[a + 1] = acc;
            }
        });
        for b in 1..w {
            let (done, rest) = cum.split_at_mut(b * w);
            for (f, below) in rest[..w].iter_mut().zip(&done[(b - 1) * w..]) {
                *f += below;
            }
        }
        let f = |mx: i64, my: i64| -> f64 {
            let sign = (mx.signum() * my.signum()) as f64;
            sign * cum[my.unsigned_abs() as usize * w + mx.unsigned_abs() as usize]
        };
        let half = (p / 2) as i64;
        let mut values = vec![0.0f32; q * q * k * k];
        par_rows(&mut values, k * q, threads, |plane, row| {
            let my = ((plane / q) * p + plane % q) as i64 - 1;
            for (col, v) in row.iter_mut().enumerate() {
                let mx = ((col / q) * p + col % q) as i64 - 1;
                let t = f(mx + half, my + half) - f(mx - half, my + half) - f(mx + half, my - half)
                    + f(mx - half, my - half);
                *v = t as f32;
            }
        });
        PixelTable {
            shift: p.trailing_zeros(),
            planes: q,
            extent: k,
            values,
        }
    }

    /// Phases per px.
    #[cfg(test)]
    pub(super) fn phases(&self) -> usize {
        1 << self.shift
    }

    /// The stored values, for comparing builds.
    #[cfg(test)]
    pub(super) fn values(&self) -> &[f32] {
        &self.values
    }

    /// Pixel-integrated image of `n` x `n` px of the spot at offset (x0, y0) px, row-major
    /// into `out` (n x n values); pixels beyond the extent are 0.
    pub(super) fn render(&self, n: usize, x0: f64, y0: f64, out: &mut [f64]) {
        let c = (n as f64 - 1.0) / 2.0;
        let (cols, rows) = (self.axis(n, c, x0), self.axis(n, c, y0));
        let (above, below) = out.split_at_mut(rows.split * n);
        self.band(above.chunks_exact_mut(n).rev(), &rows.neg, &cols);
        self.band(below.chunks_exact_mut(n), &rows.pos, &cols);
    }

    /// The rows on one side of the spot centre, going away from it (whole px k, k + 1, ...):
    /// a quadrant either side of the centre column, each with fixed weights.
    fn band<'a>(&self, rows: impl Iterator<Item = &'a mut [f64]>, ry: &Side, cols: &Axis) {
        let stride = self.extent * self.planes;
        let kernels = [Kernel::new(ry.w, cols.neg.w), Kernel::new(ry.w, cols.pos.w)];
        for (r, row) in rows.enumerate() {
            let ky = ry.k + r;
            if ky >= self.extent {
                row.fill(0.0);
                continue;
            }
            let base = (ky * self.planes + ry.q) * stride;
            let (left, right) = row.split_at_mut(cols.split);
            self.fill_side(left.iter_mut().rev(), base, &cols.neg, &kernels[0]);
            self.fill_side(right.iter_mut(), base, &cols.pos, &kernels[1]);
        }
    }

    /// One side of a row: pixels going away from the spot centre, whole px k, k + 1, ...
    #[inline(always)]
    fn fill_side<'a>(
        &self,
        mut pixels: impl ExactSizeIterator<Item = &'a mut f64>,
        base: usize,
        side: &Side,
        kernel: &Kernel,
    ) {
        let run = Run {
            first: base + side.k * self.planes + side.q,
            step: self.planes,
            stride: self.extent * self.planes,
            count: self.extent.saturating_sub(side.k).min(pixels.len()),
        };
        kernel.fill(&self.values, run, &mut pixels);
        pixels.for_each(|o| *o = 0.0);
    }

    /// Where the pixels of one axis fall in the table for a spot at `offset` px. Pixel j sits at
    /// j + a px from the spot, a = -c - offset: its phase is that of a on the side a >= -j, and
    /// its mirror on the other side.
    #[inline(always)]
    fn axis(&self, n: usize, c: f64, offset: f64) -> Axis {
        let p = 1i64 << self.shift;
        // a in units of 1/P px, moved up by 2^20 > |a| so that truncation is the floor (f64::floor
        // is a libm call on baseline x86_64, and this chain of operations sets the pace of small
        // frames); t keeps 31 bits. Offsets beyond the table put every pixel outside it: the clamp
        // keeps the integers small.
        const LIFT: i64 = 1 << 20;
        let limit = ((n + self.extent + 2) as i64 * p).min(LIFT / 2) as f64;
        let lifted = ((-c - offset) * p as f64).clamp(-limit, limit) + LIFT as f64;
        let whole = lifted as i64;
        let t = lifted - whole as f64;
        let floor = whole - LIFT;
        // Pixels j >= split have j P + floor >= 0.
        let split = if floor >= 0 {
            0
        } else {
            ((-floor + p - 1) >> self.shift).min(n as i64)
        };
        let w = lagrange4(t).map(|v| v as f32);
        let side = |units: i64, w: [f32; 4]| Side {
            k: (units.max(0) >> self.shift) as usize,
            q: (units.max(0) & (p - 1)) as usize,
            w,
        };
        Axis {
            split: split as usize,
            // Pixel split - 1 sits at |j + a| = (P - 1 - (split P + floor)) / P + (1 - t) / P,
            // where the weights are those at t mirrored (the basis is symmetric about 1/2).
            neg: side(-(split - 1) * p - floor - 1, [w[3], w[2], w[1], w[0]]),
            pos: side(split * p + floor, w),
        }
    }
}

/// The pixels of one axis either side of the spot centre.
struct Axis {
    /// First pixel on the side of positive offsets.
    split: usize,
    /// Pixel split - 1 and those before it.
    neg: Side,
    /// Pixel split and those after it.
    pos: Side,
}

/// Where the pixel next to the spot centre falls in the table: whole px, phase node and
/// interpolation weights (shared by the pixels further out on its side, at k + 1, k + 2, ...).
struct Side {
    k: usize,
    q: usize,
    w: [f32; 4],
}

/// Run `f(row index, row)` over the rows (`row_len` items each) of `data` on `threads` scoped
/// threads, in contiguous bands. Plain threads, not the rayon pool: threads of that pool may be
/// waiting for this very build.
fn par_rows<T: Send>(
    data: &mut [T],
    row_len: usize,
    threads: usize,
    f: impl Fn(usize, &mut [T]) + Sync,
) {
    let rows = data.len() / row_len;
    let per_band = rows.div_ceil(threads.max(1)).max(1);
    let run = |first: usize, band: &mut [T]| {
        for (i, row) in band.chunks_exact_mut(row_len).enumerate() {
            f(first + i, row);
        }
    };
    std::thread::scope(|scope| {
        let mut bands = data.chunks_mut(per_band * row_len).enumerate();
        let own = bands.next();
        for (b, band) in bands {
            let run = &run;
            scope.spawn(move || run(b * per_band, band));
        }
        if let Some((_, band)) = own {
            run(0, band);
        }
    });
}
