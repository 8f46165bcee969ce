//! The dark temporal variance split into pixel, row, column and frame components (EMVA 1288
//! style), with standard errors.
//!
//! Per pixel the offset (its mean over the stack) is removed; what is left in frame k is
//! pixel noise (variance p, averaged over pixels), a row term shared by the pixels of a row
//! (r), a column term shared by those of a column (c), and a frame term shared by every
//! pixel (f). With M rows, N columns, the four measured variances are
//!
//! - mean over pixels of the temporal variance: V_tot = p + r + c + f;
//! - mean over rows of the variance over frames of the row's mean: V_row = r + f + (p + c) / N;
//! - mean over columns of that of the column's mean: V_col = c + f + (p + r) / M;
//! - variance over frames of the frame's mean: V_frm = f + r / M + c / N + p / (M N);
//!
//! a linear system solved for (p, r, c, f), so each component is counted once (with a single
//! row or column the frame term is one with the line term that spans the frame, and is not
//! separated). After `--common-mode` the frame term is what taking off an estimated level
//! leaves: the estimate's own noise, less the pixel noise it takes with it (-p / (M N) for
//! the frame mean), with the row and column terms unchanged. Standard errors are those of Gaussian
//! noise: a sample variance over n frames has variance 2 v^2 / (n - 1), and two of them
//! 2 cov^2 / (n - 1), with the covariances the components imply (pixels of a row share
//! r + f, of a column c + f, any two f; row means share c / N + f, column means r / M + f),
//! so a frame term is one draw per frame for every line, not one per line.

use serde::Serialize;

use super::lines::LineVariances;

/// The temporal variance components of a dark stack (adu^2), with their standard errors.
#[derive(Clone, Debug, PartialEq)]
pub struct TemporalNoise {
    /// Frames used.
    pub frames: usize,
    /// Mean over pixels of the temporal variance, and its SE (adu^2).
    pub total: (f64, f64),
    /// Pixel component (adu^2; may come out negative by chance), and its SE.
    pub pixel: (f64, f64),
    /// Row component (adu^2), and its SE; None with a single column.
    pub row: Option<(f64, f64)>,
    /// Column component (adu^2), and its SE; None with a single row.
    pub column: Option<(f64, f64)>,
    /// Frame component: noise common to the whole frame (adu^2), and its SE; None with a
    /// single row or column.
    pub frame: Option<(f64, f64)>,
}

/// Which components a frame shape separates: pixel always, row with more than one column,
/// column with more than one row, frame with both.
fn present(shape: (usize, usize)) -> [bool; 4] {
    let (r, c) = (shape.1 > 1, shape.0 > 1);
    [true, r, c, r && c]
}

impl TemporalNoise {
    /// The components from the line variances and each pixel's temporal variance (adu^2,
    /// non-finite values left out) of a stack of frames `shape` (rows, cols).
    pub fn decompose(lines: &LineVariances, pixel_var: &[f64], shape: (usize, usize)) -> Self {
        let (m, n) = (shape.0 as f64, shape.1 as f64);
        let finite: Vec<f64> = pixel_var
            .iter()
            .copied()
            .filter(|v| v.is_finite())
            .collect();
        let npix = finite.len().max(1) as f64;
        let mean = |v: &[f64]| v.iter().sum::<f64>() / v.len().max(1) as f64;
        let measured = [
            finite.iter().sum::<f64>() / npix,
            mean(&lines.row_var_adu2),
            mean(&lines.col_var_adu2),
            lines.frame_var_adu2,
        ];
        // Equation e, component j: the share of component j in the variance of equation e's
        // means (each mean along a row divides the terms that vary along it by N, ...).
        let weight = |e: usize, j: usize| {
            let along_row = if matches!(j, 0 | 2) { 1.0 / n } else { 1.0 };
            let along_col = if matches!(j, 0 | 1) { 1.0 / m } else { 1.0 };
            match e {
                0 => 1.0,
                1 => along_row,
                2 => along_col,
                _ => along_row * along_col,
            }
        };
        let idx: Vec<usize> = (0..4).filter(|j| present(shape)[*j]).collect();
        let a: Vec<Vec<f64>> = idx
            .iter()
            .map(|e| idx.iter().map(|j| weight(*e, *j)).collect())
            .collect();
        let inv = invert(a);
        let solve = |v: &[f64]| -> Vec<f64> {
            inv.iter()
                .map(|row| row.iter().zip(v).map(|(a, b)| a * b).sum())
                .collect()
        };
        let v: Vec<f64> = idx.iter().map(|e| measured[*e]).collect();
        let est = solve(&v);
        let mut theta = [0.0; 4];
        for (i, j) in idx.iter().enumerate() {
            theta[*j] = est[i];
        }
        let clamped = theta.map(|x| x.max(0.0));
        let cov_all = measured_covariance(lines.frames, pixel_var, shape, clamped);
        let cov: Vec<Vec<f64>> = idx
            .iter()
            .map(|e| idx.iter().map(|f| cov_all[*e][*f]).collect())
            .collect();
        // Cov(theta) = A^-1 Cov(V) A^-T.
        let se = |i: usize| -> f64 {
            let w = &inv[i];
            let var: f64 = (0..idx.len())
                .map(|e| (0..idx.len()).map(|f| w[e] * cov[e][f] * w[f]).sum::<f64>())
                .sum();
            var.max(0.0).sqrt()
        };
        let comp = |j: usize| idx.iter().position(|x| *x == j).map(|i| (theta[j], se(i)));
        TemporalNoise {
            frames: lines.frames,
            total: (measured[0], cov_all[0][0].max(0.0).sqrt()),
            pixel: comp(0).expect("the pixel component is always present"),
            row: comp(1),
            column: comp(2),
            frame: comp(3),
        }
    }

    /// The figures of summary.json: rms in adu, and in e- with the conversion gain `gain`
    /// (e- per adu).
    pub fn summary(&self, gain: Option<f64>) -> TemporalNoiseSummary {
        let rms = |c: Option<(f64, f64)>| c.map(rms_of);
        let (p, r, c, f, t) = (
            rms(Some(self.pixel)),
            rms(self.row),
            rms(self.column),
            rms(self.frame),
            rms(Some(self.total)),
        );
        let first = |x: Option<(f64, f64)>| x.map(|v| v.0);
        let second = |x: Option<(f64, f64)>| x.map(|v| v.1);
        let e = |x: Option<f64>| gain.and_then(|g| x.map(|v| v * g));
        TemporalNoiseSummary {
            pixel_rms_adu: first(p),
            pixel_rms_se_adu: second(p),
            row_rms_adu: first(r),
            row_rms_se_adu: second(r),
            column_rms_adu: first(c),
            column_rms_se_adu: second(c),
            frame_rms_adu: first(f),
            frame_rms_se_adu: second(f),
            total_rms_adu: first(t),
            total_rms_se_adu: second(t),
            pixel_rms_e: e(first(p)),
            pixel_rms_se_e: e(second(p)),
            row_rms_e: e(first(r)),
            row_rms_se_e: e(second(r)),
            column_rms_e: e(first(c)),
            column_rms_se_e: e(second(c)),
            frame_rms_e: e(first(f)),
            frame_rms_se_e: e(second(f)),
            total_rms_e: e(first(t)),
            total_rms_se_e: e(second(t)),
            frames: self.frames,
            method: METHOD.into(),
        }
    }
}

/// Covariances of the measured (V_tot, V_row, V_col, V_frm) for Gaussian noise with the
/// components `[_, r, c, f]` (adu^2, clamped at 0) and each pixel's own variance its temporal
/// variance less r + c + f (the mean of the others for a pixel without one). Everything comes
/// from the model, none from the measured line variances, so the matrix is a covariance
/// (positive semi-definite) and the near-cancelling combination that gives the frame term
/// keeps its true variance. The covariance of two sample variances over k + 1 frames is
/// 2 cov^2 / k, summed over the pairs of means the two averages hold.
fn measured_covariance(
    frames: usize,
    pixel_var: &[f64],
    shape: (usize, usize),
    [_, r, c, f]: [f64; 4],
) -> [[f64; 4]; 4] {
    let (rows, cols) = shape;
    let (m, n) = (rows as f64, cols as f64);
    let mn = m * n;
    let k = frames as f64 - 1.0;
    let own: Vec<f64> = pixel_var
        .iter()
        .filter(|v| v.is_finite())
        .map(|v| (v - r - c - f).max(0.0))
        .collect();
    let fill = own.iter().sum::<f64>() / own.len().max(1) as f64;
    let p: Vec<f64> = pixel_var
        .iter()
        .map(|v| {
            if v.is_finite() {
                (v - r - c - f).max(0.0)
            } else {
                fill
            }
        })
        .collect();
    let (mut row_p, mut col_p) = (vec![0.0; rows], vec![0.0; cols]);
    for (i, x) in p.iter().enumerate() {
        row_p[(i / cols).min(rows - 1)] += x;
        col_p[i % cols] += x;
    }
    let total_p: f64 = p.iter().sum();
    let sum = |x: &[f64], g: &dyn Fn(f64) -> f64| x.iter().map(|x| g(*x)).sum::<f64>();
    // Shared by any row mean and any column mean, by two row means, by two column means.
    let (common, rr, cc) = (r / m + c / n + f, c / n + f, r / m + f);
    let tt = (sum(&p, &|p| (p + r + c + f).powi(2))
        + mn * ((n - 1.0) * (r + f).powi(2)
            + (m - 1.0) * (c + f).powi(2)
            + (m - 1.0) * (n - 1.0) * f * f))
        / (mn * mn);
    let ww = (sum(&row_p, &|s| (s / (n * n) + r + rr).powi(2)) + m * (m - 1.0) * rr * rr) / (m * m);
    let ll = (sum(&col_p, &|s| (s / (m * m) + c + cc).powi(2)) + n * (n - 1.0) * cc * cc) / (n * n);
    let ff = (total_p / (mn * mn) + common).powi(2);
    let tw = sum(&p, &|p| (p / n + r + rr).powi(2) + (m - 1.0) * rr * rr) / (mn * m);
    let tl = sum(&p, &|p| (p / m + c + cc).powi(2) + (n - 1.0) * cc * cc) / (mn * n);
    // A pixel and the frame's mean share as much as its row's mean and its column's mean.
    let tf = sum(&p, &|p| (p / mn + common).powi(2)) / mn;
    let wf = sum(&row_p, &|s| (s / (m * n * n) + common).powi(2)) / m;
    let lf = sum(&col_p, &|s| (s / (m * m * n) + common).powi(2)) / n;
    [
        [tt, tw, tl, tf],
        [tw, ww, tf, wf],
        [tl, tf, ll, lf],
        [tf, wf, lf, ff],
    ]
    .map(|row| row.map(|x| 2.0 / k * x))
}

/// The inverse of the small square matrix `a` (Gauss-Jordan with partial pivoting; the
/// decomposition's matrices are well conditioned for any frame of at least 2 x 2).
fn invert(mut a: Vec<Vec<f64>>) -> Vec<Vec<f64>> {
    let d = a.len();
    let mut inv: Vec<Vec<f64>> = (0..d)
        .map(|i| (0..d).map(|j| f64::from(u8::from(i == j))).collect())
        .collect();
    for col in 0..d {
        let piv = (col..d)
            .max_by(|x, y| a[*x][col].abs().total_cmp(&a[*y][col].abs()))
            .expect("a row");
        a.swap(col, piv);
        inv.swap(col, piv);
        let p = a[col][col];
        for j in 0..d {
            a[col][j] /= p;
            inv[col][j] /= p;
        }
        for i in (0..d).filter(|i| *i != col) {
            let g = a[i][col];
            for j in 0..d {
                a[i][j] -= g * a[col][j];
                inv[i][j] -= g * inv[col][j];
            }
        }
    }
    inv
}

/// The rms of a variance component and its SE: sqrt(max(v, 0)), and se_v / (2 rms + sqrt(se_v))
/// (the delta method's se_v / (2 rms) for a clear component, sqrt(se_v), the smallest
/// detectable rms, for one near 0).
pub fn rms_of((v, se): (f64, f64)) -> (f64, f64) {
    let rms = v.max(0.0).sqrt();
    let d = 2.0 * rms + se.sqrt();
    (rms, if d > 0.0 { se / d } else { 0.0 })
}

/// What `temporal_noise` is, in one sentence.
const METHOD: &str = "EMVA 1288 style split of the dark temporal variance over all samples (before clipping): after each pixel's mean is removed, the mean per-pixel variance and the variances over frames of the row, column and frame means, each a known mix of the pixel, row, column and frame components, are solved for the four components (each counted once); rms = sqrt(variance, 0 if negative), standard errors for Gaussian noise";

/// `temporal_noise` in summary.json: rms components in adu and e- (null without a gain, or
/// row/column with a single column/row, frame with either), each with its standard error.
#[derive(Clone, Debug, Default, Serialize, PartialEq)]
pub struct TemporalNoiseSummary {
    /// Pixel component (adu).
    pub pixel_rms_adu: Option<f64>,
    /// Its standard error (adu).
    pub pixel_rms_se_adu: Option<f64>,
    /// Row component: rms of a noise shared along a row (adu).
    pub row_rms_adu: Option<f64>,
    /// Its standard error (adu).
    pub row_rms_se_adu: Option<f64>,
    /// Column component: rms of a noise shared along a column (adu).
    pub column_rms_adu: Option<f64>,
    /// Its standard error (adu).
    pub column_rms_se_adu: Option<f64>,
    /// Frame component: rms of a noise shared by the whole frame (adu).
    pub frame_rms_adu: Option<f64>,
    /// Its standard error (adu).
    pub frame_rms_se_adu: Option<f64>,
    /// Total: square root of the mean per-pixel temporal variance (adu).
    pub total_rms_adu: Option<f64>,
    /// Its standard error (adu).
    pub total_rms_se_adu: Option<f64>,
    /// Pixel component (e-).
    pub pixel_rms_e: Option<f64>,
    /// Its standard error (e-).
    pub pixel_rms_se_e: Option<f64>,
    /// Row component (e-).
    pub row_rms_e: Option<f64>,
    /// Its standard error (e-).
    pub row_rms_se_e: Option<f64>,
    /// Column component (e-).
    pub column_rms_e: Option<f64>,
    /// Its standard error (e-).
    pub column_rms_se_e: Option<f64>,
    /// Frame component (e-).
    pub frame_rms_e: Option<f64>,
    /// Its standard error (e-).
    pub frame_rms_se_e: Option<f64>,
    /// Total (e-).
    pub total_rms_e: Option<f64>,
    /// Its standard error (e-).
    pub total_rms_se_e: Option<f64>,
    /// Frames used.
    pub frames: usize,
    /// How the components were computed (one sentence).
    pub method: String,
}

#[cfg(test)]
mod tests;
