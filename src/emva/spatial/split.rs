//! The spatial variance of an averaged image and its release 4.0 split into row, column and
//! pixel parts, corrected for the temporal noise left after averaging L frames, with the
//! sampling variance of each part.
//!
//! The standard's estimators (as the reference implementation `emva1288` computes them,
//! `process/data.py` and `results.py`): with `<y>` the averaged M x N image, mu its mean,
//! sigma^2_stack the mean temporal variance of one frame,
//!
//! - s^2_y = var(<y>, ddof 1) - sigma^2_stack / L
//! - s^2_cav = (1/N) sum_n (mu[n] - mu)^2 - sigma^2_stack / (L M)   (column means mu[n])
//! - s^2_rav = (1/M) sum_m (mu[m] - mu)^2 - sigma^2_stack / (L N)   (row means mu[m])
//!
//! and the parts solve s^2_cav = s^2_col + s^2_pixel / M, s^2_rav = s^2_row + s^2_pixel / N,
//! s^2_y = s^2_col + s^2_row + s^2_pixel.
//!
//! Sampling variances (Gaussian model y = mu + r[m] + c[n] + p[m,n] + temporal, the parts
//! drawn independently, so an SE says how well the dataset fixes the camera's row, column and
//! pixel variances): the column means, the row means and the residual image after removing
//! both are orthogonal projections, hence independent, with N - 1, M - 1 and (M-1)(N-1)
//! degrees of freedom and per-unit variances v_col = s^2_col + w / M, v_row = s^2_row + w / N
//! and w = s^2_pixel + sigma^2_stack / L. Row and column parts: Var = 2 v^2 / dof (too few
//! lines for a fourth moment); pixel part: (m4 - m2^2) / dof from the residual's own fourth
//! moment (defect pixels make it heavy-tailed), plus the sampling variance of the temporal
//! correction, 2 sigma^4_stack / (M N (L - 1)) / L^2, which lands on the pixel part only (it
//! cancels in the row and column parts). The total is the sum of the three.

/// The spatial variances of one averaged image (DN^2) with their sampling variances.
#[derive(Clone, Debug, PartialEq)]
pub struct VarianceSplit {
    /// Rows M and columns N.
    pub shape: (usize, usize),
    /// mu_y: mean of the averaged image (DN).
    pub mean_dn: f64,
    /// Sampling variance of `mean_dn` (DN^2).
    pub mean_var: f64,
    /// Temporal variance left in the averaged image, sigma^2_y.stack / L (DN^2).
    pub residual_dn2: f64,
    /// s^2_y.measured: variance of the averaged image, ddof 1 (DN^2).
    pub measured_dn2: f64,
    /// s^2_y.cav: variance of the column means, corrected (DN^2).
    pub cav_dn2: f64,
    /// s^2_y.rav: variance of the row means, corrected (DN^2).
    pub rav_dn2: f64,
    /// The parts (DN^2): total, row, column, pixel.
    pub parts: Parts<f64>,
    /// Sampling variances of the parts (DN^4).
    pub parts_var: Parts<f64>,
    /// Per-unit variance (DN^2) and degrees of freedom of the row, column and pixel parts, in
    /// that order, for the covariance of two images' parts (PRNU's SE).
    pub units: [(f64, f64); 3],
}

/// One value per part of a spatial non-uniformity.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub struct Parts<T> {
    /// The whole non-uniformity.
    pub total: T,
    /// Row part (each row offset as a whole).
    pub row: T,
    /// Column part.
    pub col: T,
    /// Pixel part (what is left).
    pub pixel: T,
}

impl<T> Parts<T> {
    /// Apply `f` to each part, with its name (`total`, `row`, `col`, `pixel`).
    pub fn map<U>(self, mut f: impl FnMut(&'static str, T) -> U) -> Parts<U> {
        Parts {
            total: f("total", self.total),
            row: f("row", self.row),
            col: f("col", self.col),
            pixel: f("pixel", self.pixel),
        }
    }

    /// Pair two sets of parts.
    pub fn zip<U>(self, other: Parts<U>) -> Parts<(T, U)> {
        Parts {
            total: (self.total, other.total),
            row: (self.row, other.row),
            col: (self.col, other.col),
            pixel: (self.pixel, other.pixel),
        }
    }
}

/// Split the averaged image `image` (row-major, `shape`) whose temporal variance left after
/// averaging is `residual_dn2` (sigma^2_y.stack / L), known to a sampling variance
/// `residual_var` (DN^4). Needs M, N >= 2 and M N - M - N > 0 (callers mark the parts
/// unavailable otherwise).
pub fn split(
    image: &[f64],
    shape: (usize, usize),
    residual_dn2: f64,
    residual_var: f64,
) -> VarianceSplit {
    let (m, n) = shape;
    let (mf, nf) = (m as f64, n as f64);
    let count = mf * nf;
    let mean = image.iter().sum::<f64>() / count;
    let mut row_means = vec![0.0; m];
    let mut col_means = vec![0.0; n];
    let mut ss = 0.0;
    for (r, line) in image.chunks_exact(n).enumerate() {
        for (c, &y) in line.iter().enumerate() {
            row_means[r] += y;
            col_means[c] += y;
            ss += (y - mean) * (y - mean);
        }
    }
    row_means.iter_mut().for_each(|v| *v /= nf);
    col_means.iter_mut().for_each(|v| *v /= mf);
    let measured = ss / (count - 1.0);
    let spread =
        |v: &[f64]| v.iter().map(|x| (x - mean) * (x - mean)).sum::<f64>() / v.len() as f64;
    let corr = residual_dn2;
    let total = measured - corr;
    let cav = spread(&col_means) - corr / mf;
    let rav = spread(&row_means) - corr / nf;
    let denom = count - mf - nf;
    let col = (count - mf) / denom * cav - nf / denom * (total - rav);
    let row = (count - nf) / denom * rav - mf / denom * (total - cav);
    let pixel = count / denom * (total - cav - rav);

    // The residual after removing row and column means: the pixel part's fourth moment.
    let (mut m2, mut m4) = (0.0, 0.0);
    for (r, line) in image.chunks_exact(n).enumerate() {
        for (c, &y) in line.iter().enumerate() {
            let e = y - row_means[r] - col_means[c] + mean;
            m2 += e * e;
            m4 += e * e * e * e;
        }
    }
    let dof_pixel = (mf - 1.0) * (nf - 1.0);
    let m2 = m2 / dof_pixel;
    let m4 = m4 / count;
    let w = pixel.max(0.0) + corr;
    let v_row = row.max(0.0) + w / nf;
    let v_col = col.max(0.0) + w / mf;
    let var_row = 2.0 * v_row * v_row / (mf - 1.0);
    let var_col = 2.0 * v_col * v_col / (nf - 1.0);
    // Floored at a third of the Gaussian value: a light-tailed residual (uniform: 0.8 m2^2)
    // is fine, a chance m4 near m2^2 would claim a pixel part known exactly.
    let var_pixel = (m4 - m2 * m2).max(2.0 * m2 * m2 / 3.0) / dof_pixel + residual_var;
    VarianceSplit {
        shape,
        mean_dn: mean,
        mean_var: v_row / mf + v_col / nf + w / count,
        residual_dn2,
        measured_dn2: measured,
        cav_dn2: cav,
        rav_dn2: rav,
        parts: Parts {
            total,
            row,
            col,
            pixel,
        },
        parts_var: Parts {
            total: var_row + var_col + var_pixel,
            row: var_row,
            col: var_col,
            pixel: var_pixel,
        },
        units: [(v_row, mf - 1.0), (v_col, nf - 1.0), (w, dof_pixel)],
    }
}
