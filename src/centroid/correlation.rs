//! `correlation`: the correlation centroider of the Durham simulation platform (DASP): the frame
//! cross-correlated with the mean spot (the template), the integer peak of the correlation, then
//! a sub-pixel peak by a 3-point parabola in each axis through the peak and its two neighbours.
//!
//! The correlation is direct and not periodic (the template slides over the frame with zeros
//! outside it): C(dx, dy) = sum_p I(p) T(p - (dx, dy)) for shifts of -r..=r px in each axis,
//! r = min(n - 1, n / 4 + 2): the engine's spot offsets are at most a quarter of the side, so
//! farther peaks are noise (13 x 13 shifts, about 20,000 products per 16x16 frame, instead of
//! 31 x 31). The peak is the first largest value in row-major order; in an axis where it lies on the edge of the shifts, or where the three
//! points are not a maximum (a flat or upward parabola), the integer peak is kept. The parabola's
//! vertex is at d + (C(d-1) - C(d+1)) / (2 (C(d-1) - 2 C(d) + C(d+1))). The position is the
//! template's own centroid plus the shift. No background is subtracted (the template weights
//! the pixels), and it takes no parameter.

use super::centroider::{CentroidFrame, CentroidWorker, Centroider, SettingSums};
use super::image::ImageSums;
use super::spec::CentroiderEntry;

/// `correlation`'s registry entry.
pub const ENTRY: CentroiderEntry = CentroiderEntry {
    name: "correlation",
    help: "cross-correlation with the mean spot, integer peak, then a 3-point parabola per axis (DASP)",
    param: None,
    mask_above: false,
    build: |_, _, ctx| {
        Ok(Box::new(Correlation {
            n: ctx.subap_px,
        }))
    },
};

/// The correlation centroider for n x n sub-apertures.
#[derive(Debug, Clone)]
pub(super) struct Correlation {
    n: usize,
}

impl Centroider for Correlation {
    fn name(&self) -> String {
        ENTRY.name.into()
    }

    fn needs_noise_map(&self) -> bool {
        false
    }

    fn worker(&self) -> Box<dyn CentroidWorker + '_> {
        let reach = reach(self.n);
        let side = 2 * reach + 1;
        Box::new(CorrelationWorker {
            n: self.n,
            reach,
            corr: vec![0.0; side * side],
        })
    }
}

/// The largest shift searched (px) for n x n sub-apertures: min(n - 1, n / 4 + 2).
pub(super) fn reach(n: usize) -> usize {
    (n - 1).min(n / 4 + 2)
}

/// A thread's correlation map: shifts -reach..=reach, row-major (dy outer).
struct CorrelationWorker {
    n: usize,
    reach: usize,
    corr: Vec<f64>,
}

/// The vertex offset (within -1..1 px) of the parabola through (-1, a), (0, b), (1, c); 0 when
/// the three points are not a maximum.
pub(super) fn parabola_peak(a: f64, b: f64, c: f64) -> f64 {
    let curve = a - 2.0 * b + c;
    if curve < 0.0 {
        (a - c) / (2.0 * curve)
    } else {
        0.0
    }
}

impl CorrelationWorker {
    /// Fill `corr` with the correlation of `img` and `template`.
    fn correlate(&mut self, img: &[f64], template: &[f64]) {
        let (n, r) = (self.n as isize, self.reach as isize);
        let side = 2 * r + 1;
        for dy in -r..=r {
            // Frame rows y with template rows y - dy inside 0..n.
            let (y0, y1) = (dy.max(0), (n + dy).min(n));
            for dx in -r..=r {
                let (x0, x1) = (dx.max(0), (n + dx).min(n));
                let mut s = 0.0;
                for y in y0..y1 {
                    let row = &img[(y * n + x0) as usize..(y * n + x1) as usize];
                    let t0 = ((y - dy) * n + x0 - dx) as usize;
                    let trow = &template[t0..t0 + row.len()];
                    s += row.iter().zip(trow).map(|(a, b)| a * b).sum::<f64>();
                }
                self.corr[((dy + r) * side + dx + r) as usize] = s;
            }
        }
    }

    /// The shift (px) of `img` against `template`: integer peak plus parabola per axis.
    fn shift(&mut self, img: &[f64], template: &[f64]) -> (f64, f64) {
        self.correlate(img, template);
        let side = 2 * self.reach + 1;
        let mut peak = 0;
        for (k, &v) in self.corr.iter().enumerate() {
            if v > self.corr[peak] {
                peak = k;
            }
        }
        let (py, px) = (peak / side, peak % side);
        let at = |y: usize, x: usize| self.corr[y * side + x];
        let sub = |p: usize, get: &dyn Fn(usize) -> f64| {
            if p == 0 || p + 1 == side {
                0.0
            } else {
                parabola_peak(get(p - 1), get(p), get(p + 1))
            }
        };
        let fx = sub(px, &|x| at(py, x));
        let fy = sub(py, &|y| at(y, px));
        let centre = self.reach as f64;
        (px as f64 - centre + fx, py as f64 - centre + fy)
    }
}

impl CentroidWorker for CorrelationWorker {
    fn accumulate(&mut self, f: &CentroidFrame, acc: &mut SettingSums) {
        let n = self.n;
        let template = &f.mean_e[..n * n];
        let origin = ImageSums::of(template, n).centroid(n);
        let estimate = origin.map(|(ox, oy)| {
            let (sx, sy) = self.shift(&f.image_e[..n * n], template);
            (ox + sx, oy + sy)
        });
        let sums = acc.part_mut(0);
        let Some((x, y)) = estimate else {
            return sums.add_empty(0, f.truth_px);
        };
        let (ex, ey) = (x - f.truth_px.0, y - f.truth_px.1);
        sums.add_error(0, ex.hypot(ey), (ex, ey));
    }
}

#[cfg(test)]
mod tests {
    use super::parabola_peak;

    #[test]
    fn the_parabola_finds_the_vertex_of_a_parabola() {
        // y = -(x - 0.3)^2 at -1, 0, 1: vertex 0.3; a flat or upward triple keeps the integer.
        let y = |x: f64| -(x - 0.3) * (x - 0.3);
        assert!((parabola_peak(y(-1.0), y(0.0), y(1.0)) - 0.3).abs() < 1e-15);
        assert_eq!(parabola_peak(1.0, 1.0, 1.0), 0.0);
        assert_eq!(parabola_peak(2.0, 1.0, 2.0), 0.0);
    }
}
