//! The dark temporal variance split into pixel, row and column components (EMVA 1288 style),
//! with standard errors.
//!
//! Per pixel the offset (its mean over the stack) is removed; what is left in frame k is
//! pixel noise (variance p, averaged over pixels), a row term shared by the pixels of a row
//! (r), and a column term shared by those of a column (c). With M rows, N columns:
//!
//! - mean over pixels of the temporal variance: V_tot = p + r + c;
//! - mean over rows of the variance over frames of the row's mean: V_row = r + (p + c) / N;
//! - mean over columns of that of the column's mean: V_col = c + (p + r) / M;
//!
//! so r = (N V_row - V_tot) / (N - 1), c = (M V_col - V_tot) / (M - 1), p = V_tot - r - c
//! (the row means' pixel and column noise is corrected for). Noise common to the whole frame
//! counts in both r and c (and p is lower by as much); `--common-mode` removes it first.
//! Standard errors are those of Gaussian noise: a sample variance over n frames has variance
//! 2 v^2 / (n - 1), and two of them 2 cov^2 / (n - 1), with the covariances the components
//! imply (rows share the column term's mean c / N, columns the row term's r / M, pixels of a
//! row r, of a column c, and each pixel, row and column with the lines it lies on).

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
}

impl TemporalNoise {
    /// The components from the line variances and each pixel's temporal variance (adu^2,
    /// non-finite values left out) of a stack of frames `shape` (rows, cols).
    pub fn decompose(lines: &LineVariances, pixel_var: &[f64], shape: (usize, usize)) -> Self {
        let (m, n) = (shape.0 as f64, shape.1 as f64);
        let k = lines.frames as f64 - 1.0;
        let finite: Vec<f64> = pixel_var
            .iter()
            .copied()
            .filter(|v| v.is_finite())
            .collect();
        let npix = finite.len().max(1) as f64;
        let v_tot = finite.iter().sum::<f64>() / npix;
        let mean = |v: &[f64]| v.iter().sum::<f64>() / v.len().max(1) as f64;
        let sq = |v: &[f64]| v.iter().map(|x| x * x).sum::<f64>();
        let (v_row, v_col) = (mean(&lines.row_var_adu2), mean(&lines.col_var_adu2));
        let r = (shape.1 > 1).then(|| (n * v_row - v_tot) / (n - 1.0));
        let c = (shape.0 > 1).then(|| (m * v_col - v_tot) / (m - 1.0));
        let (r0, c0) = (r.unwrap_or(0.0).max(0.0), c.unwrap_or(0.0).max(0.0));
        // Variances and covariances of V_tot, V_row, V_col (Gaussian noise; the covariance of
        // two sample variances over k + 1 frames is 2 cov^2 / k).
        let var_tot = 2.0 / (k * npix * npix)
            * (sq(&finite) + npix * (n - 1.0) * r0 * r0 + npix * (m - 1.0) * c0 * c0);
        let var_row =
            2.0 / (k * m * m) * (sq(&lines.row_var_adu2) + m * (m - 1.0) * (c0 / n).powi(2));
        let var_col =
            2.0 / (k * n * n) * (sq(&lines.col_var_adu2) + n * (n - 1.0) * (r0 / m).powi(2));
        let sum_i = |f: &dyn Fn(f64) -> f64| finite.iter().map(|v| f(*v)).sum::<f64>();
        // A pixel covaries with its row's mean by (v + (N - 1) r) / N, with another row's by
        // c / N; with its column's by (v + (M - 1) c) / M, with another column's by r / M; a
        // row's mean with a column's by (v + (N - 1) r + (M - 1) c) / (M N).
        let cov_tot_row = 2.0 / (k * npix * m)
            * sum_i(&|v| ((v + (n - 1.0) * r0) / n).powi(2) + (m - 1.0) * (c0 / n).powi(2));
        let cov_tot_col = 2.0 / (k * npix * n)
            * sum_i(&|v| ((v + (m - 1.0) * c0) / m).powi(2) + (n - 1.0) * (r0 / m).powi(2));
        let cov_row_col =
            2.0 / (k * npix) * sum_i(&|v| ((v + (n - 1.0) * r0 + (m - 1.0) * c0) / npix).powi(2));
        let (bn, bm) = (n / (n - 1.0), m / (m - 1.0));
        let (an, am) = (1.0 / (n - 1.0), 1.0 / (m - 1.0));
        // r = bn V_row - an V_tot, c = bm V_col - am V_tot, p = V_tot - r - c.
        let var_r = bn * bn * var_row + an * an * var_tot - 2.0 * bn * an * cov_tot_row;
        let var_c = bm * bm * var_col + am * am * var_tot - 2.0 * bm * am * cov_tot_col;
        let row = r.map(|r| (r, var_r.max(0.0).sqrt()));
        let column = c.map(|c| (c, var_c.max(0.0).sqrt()));
        let (a, b, d) = (
            1.0 + row.map_or(0.0, |_| an) + column.map_or(0.0, |_| am),
            row.map_or(0.0, |_| bn),
            column.map_or(0.0, |_| bm),
        );
        let var_p = a * a * var_tot + b * b * var_row + d * d * var_col
            - 2.0 * a * b * cov_tot_row
            - 2.0 * a * d * cov_tot_col
            + 2.0 * b * d * cov_row_col;
        TemporalNoise {
            frames: lines.frames,
            total: (v_tot, var_tot.sqrt()),
            pixel: (
                v_tot - r.unwrap_or(0.0) - c.unwrap_or(0.0),
                var_p.max(0.0).sqrt(),
            ),
            row,
            column,
        }
    }

    /// The figures of summary.json: rms in adu, and in e- with the conversion gain `gain`
    /// (e- per adu).
    pub fn summary(&self, gain: Option<f64>) -> TemporalNoiseSummary {
        let rms = |c: Option<(f64, f64)>| c.map(rms_of);
        let (p, r, c, t) = (
            rms(Some(self.pixel)),
            rms(self.row),
            rms(self.column),
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
            total_rms_adu: first(t),
            total_rms_se_adu: second(t),
            pixel_rms_e: e(first(p)),
            pixel_rms_se_e: e(second(p)),
            row_rms_e: e(first(r)),
            row_rms_se_e: e(second(r)),
            column_rms_e: e(first(c)),
            column_rms_se_e: e(second(c)),
            total_rms_e: e(first(t)),
            total_rms_se_e: e(second(t)),
            frames: self.frames,
            method: METHOD.into(),
        }
    }
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
const METHOD: &str = "EMVA 1288 style split of the dark temporal variance over all samples (before clipping): after each pixel's mean is removed, the variances over frames of the row and column means, corrected for the pixel noise and the other line term that average into them, give the row and column components, the rest of the mean per-pixel variance is the pixel component (noise common to whole frames counts in both line components); rms = sqrt(variance, 0 if negative), standard errors for Gaussian noise";

/// `temporal_noise` in summary.json: rms components in adu and e- (null without a gain, or
/// row/column with a single column/row), each with its standard error.
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
