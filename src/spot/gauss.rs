//! The elongated Gaussian spot: separable, so a frame costs one profile per axis and a product
//! per pixel, with no table and no allocation.

use std::f64::consts::SQRT_2;

/// Image of `n` x `n` px of a Gaussian of standard deviations (`sx`, `sy`) px at offset
/// (x0, y0) px (peak 1 when point-sampled, unit volume when integrated), row-major into `out`.
pub(super) fn render(
    (sx, sy): (f64, f64),
    integrated: bool,
    n: usize,
    (x0, y0): (f64, f64),
    out: &mut [f64],
) {
    let c = (n as f64 - 1.0) / 2.0;
    // The x profile goes into row 0, which rows n-1 .. 1 read before row 0 is scaled last.
    let (first, _) = out.split_at_mut(n);
    Profile::new(sx, integrated, c, x0, 0).fill(first);
    let mut rows = Profile::new(sy, integrated, c, y0, n);
    for i in (0..n).rev() {
        let py = rows.next_down(i);
        let (head, tail) = out.split_at_mut(i * n);
        if i == 0 {
            tail[..n].iter_mut().for_each(|p| *p *= py);
        } else {
            for (o, p) in tail[..n].iter_mut().zip(&head[..n]) {
                *o = p * py;
            }
        }
    }
}

/// The 1-D profile of one axis: exp(-d^2 / 2 s^2) at pixel centres (point), or the integral of
/// the unit Gaussian over the pixel, 0.5 (erf(upper edge) - erf(lower edge)) with edges shared
/// by neighbouring pixels (integrated): n + 1 erf calls per axis instead of 2 n.
struct Profile {
    s: f64,
    integrated: bool,
    /// 1 / (s sqrt 2): scales pixel edges for erf.
    k: f64,
    c: f64,
    offset: f64,
    /// erf at the edge of the pixel taken next (going up in `fill`, down in `next_down`).
    edge: f64,
}

impl Profile {
    /// Profile of standard deviation `s` px for a spot at `offset` px, pixel centres at j - `c`;
    /// its walk starts at pixel `start` (0 for `fill`, n for `next_down`).
    fn new(s: f64, integrated: bool, c: f64, offset: f64, start: usize) -> Self {
        let mut profile = Profile {
            s,
            integrated,
            k: 1.0 / (s * SQRT_2),
            c,
            offset,
            edge: 0.0,
        };
        if integrated {
            profile.edge = profile.erf_edge(start);
        }
        profile
    }

    /// erf of the scaled lower edge of pixel `j` (the upper edge of pixel j - 1).
    fn erf_edge(&self, j: usize) -> f64 {
        libm::erf((j as f64 - self.c - self.offset - 0.5) * self.k)
    }

    /// The profiles of pixels 0..n, in order, into `out` (a walk started at pixel 0).
    fn fill(mut self, out: &mut [f64]) {
        for (j, o) in out.iter_mut().enumerate() {
            *o = if self.integrated {
                let upper = self.erf_edge(j + 1);
                let v = 0.5 * (upper - self.edge);
                self.edge = upper;
                v
            } else {
                self.point(j)
            };
        }
    }

    /// The profile of pixel `j`, taken from the last pixel down (a walk started at pixel n).
    fn next_down(&mut self, j: usize) -> f64 {
        if self.integrated {
            let lower = self.erf_edge(j);
            let v = 0.5 * (self.edge - lower);
            self.edge = lower;
            v
        } else {
            self.point(j)
        }
    }

    fn point(&self, j: usize) -> f64 {
        let d = j as f64 - self.c - self.offset;
        (-0.5 * (d / self.s).powi(2)).exp()
    }
}
