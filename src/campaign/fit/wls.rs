//! Weighted linear least squares of a few parameters, without allocation: the per-pixel
//! solver of the decomposition (millions of small fits).

/// The normal equations of one fit of `p <= P` parameters, accumulated one observation at a
/// time. `P` is a compile-time bound so the arrays of millions of per-pixel fits stay small.
#[derive(Clone, Copy)]
pub(crate) struct Normal<const P: usize> {
    p: usize,
    a: [[f64; P]; P],
    b: [f64; P],
}

/// The solution of one fit: parameters and their standard errors (chi2 is
/// the caller's, from the residuals: y'Wy - b'x cancels catastrophically at large offsets).
#[derive(Clone, Copy, Debug)]
pub(crate) struct Solution<const P: usize> {
    /// Parameters (first `p` used).
    pub x: [f64; P],
    /// Standard errors from the diagonal of the inverse normal matrix (the weights taken as
    /// inverse variances, not rescaled by chi2).
    pub se: [f64; P],
}

impl<const P: usize> Normal<P> {
    /// Empty normal equations of `p` (<= `P`) parameters.
    pub fn new(p: usize) -> Self {
        debug_assert!(p <= P);
        Normal {
            p,
            a: [[0.0; P]; P],
            b: [0.0; P],
        }
    }

    /// Add observation `y` with design row `x` (first `p` entries) and weight `w` (1/variance).
    #[inline]
    #[allow(clippy::needless_range_loop)] // triangular index arithmetic reads best as indices
    pub fn add(&mut self, x: &[f64], y: f64, w: f64) {
        for i in 0..self.p {
            let wx = w * x[i];
            self.b[i] += wx * y;
            for j in 0..=i {
                self.a[i][j] += wx * x[j];
            }
        }
    }

    /// Solve by Cholesky after scaling to a unit diagonal (the columns differ by orders of
    /// magnitude: 1 adu against G t / K). `None` if the matrix is singular to working
    /// precision (a design that does not separate the parameters).
    #[allow(clippy::needless_range_loop)] // triangular index arithmetic reads best as indices
    pub fn solve(&self) -> Option<Solution<P>> {
        let p = self.p;
        let mut s = [0.0; P];
        for i in 0..p {
            if !(self.a[i][i].is_finite() && self.a[i][i] > 0.0) {
                return None;
            }
            s[i] = 1.0 / self.a[i][i].sqrt();
        }
        // Lower Cholesky factor of the scaled matrix.
        let mut l = [[0.0; P]; P];
        for i in 0..p {
            for j in 0..=i {
                let mut sum = self.a[i][j] * s[i] * s[j];
                for k in 0..j {
                    sum -= l[i][k] * l[j][k];
                }
                if i == j {
                    if sum <= 1e-10 {
                        return None;
                    }
                    l[i][i] = sum.sqrt();
                } else {
                    l[i][j] = sum / l[j][j];
                }
            }
        }
        // Inverse of L, then inverse of the scaled matrix = L^-T L^-1.
        let mut li = [[0.0; P]; P];
        for i in 0..p {
            li[i][i] = 1.0 / l[i][i];
            for j in 0..i {
                let mut sum = 0.0;
                for k in j..i {
                    sum -= l[i][k] * li[k][j];
                }
                li[i][j] = sum / l[i][i];
            }
        }
        let mut inv = [[0.0; P]; P];
        for i in 0..p {
            for j in 0..=i {
                let mut sum = 0.0;
                for k in i..p {
                    sum += li[k][i] * li[k][j];
                }
                inv[i][j] = sum * s[i] * s[j];
                inv[j][i] = inv[i][j];
            }
        }
        let mut x = [0.0; P];
        let mut se = [0.0; P];
        for i in 0..p {
            x[i] = (0..p).map(|j| inv[i][j] * self.b[j]).sum();
            se[i] = inv[i][i].max(0.0).sqrt();
        }
        Some(Solution { x, se })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_straight_line_through_exact_points_has_zero_chi2_and_textbook_errors() {
        // y = 2 + 3x at x = 0, 1, 2 with unit weights: var(slope) = 1/sum((x - 1)^2) = 1/2.
        let mut n = Normal::<2>::new(2);
        for x in [0.0, 1.0, 2.0] {
            n.add(&[1.0, x], 2.0 + 3.0 * x, 1.0);
        }
        let s = n.solve().unwrap();
        assert!((s.x[0] - 2.0).abs() < 1e-12 && (s.x[1] - 3.0).abs() < 1e-12);
        assert!((s.se[1] - 0.5f64.sqrt()).abs() < 1e-12);
        assert!((s.se[0] - (5.0f64 / 6.0).sqrt()).abs() < 1e-12);
    }

    #[test]
    fn proportional_columns_are_singular() {
        let mut n = Normal::<2>::new(2);
        for x in [1.0, 2.0, 3.0] {
            n.add(&[x, 100.0 * x], x, 1.0);
        }
        assert!(n.solve().is_none());
    }
}
