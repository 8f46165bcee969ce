//! The static and random parts of the centroid error at one setting: what a closed loop sees.
//!
//! A fixed per-pixel noise map biases the clipped centroid the same way every frame: the mean
//! error vector over frames (the static part) is a slope offset that a loop builds into a
//! static aberration unless its reference slopes are taken with the camera at the operating
//! flux. What varies from frame to frame (the random part, the slope noise the loop averages)
//! is the spread of the error about its mean. The two add up to the mean squared error:
//! random_rms^2 + static^2 = E|e|^2 exactly (population moments over the frames run).

use crate::centroid::ErrorMoments;

/// The error vector's mean (static part) and spread about it (random part) at one setting
/// over the frames run, with standard errors.
#[derive(Debug, Clone, Copy, Default, PartialEq, serde::Serialize)]
pub struct ErrorParts {
    /// Mean error along x, estimate - truth (px): the static slope offset.
    pub static_x_px: f64,
    /// Standard error of `static_x_px` (px), from the frames' spread in x.
    pub static_x_se_px: f64,
    /// Mean error along y (px).
    pub static_y_px: f64,
    /// Standard error of `static_y_px` (px).
    pub static_y_se_px: f64,
    /// Length of the mean error vector (px). Biased upwards near zero: its square's expectation
    /// is the true square plus the variances of the two means (see `static_sq_unbiased_px2`).
    pub static_px: f64,
    /// Standard error of `static_px` (px; delta method, the covariance of x and y left out;
    /// at a zero mean, the rms of the two axes' SEs).
    pub static_se_px: f64,
    /// Unbiased estimate of the squared static offset (px^2): |mean|^2 less the variances of
    /// the two means; may be negative when the offset is consistent with zero.
    pub static_sq_unbiased_px2: f64,
    /// True when `static_px` is at least 3 times its SE: a static part is resolved; false: the
    /// static part is consistent with zero at this precision. (With no static part the ratio is
    /// Rayleigh-distributed: 3 SE is passed by chance 1.1 % of the time, 2 SE 13.5 %.)
    pub static_resolved: bool,
    /// Rms of the error about its mean (px): sqrt(E|e - mean e|^2), the random slope noise.
    pub random_rms_px: f64,
    /// Standard error of `random_rms_px` (px; from the scatter of |e|^2, which bounds that of
    /// |e - mean|^2 from above for errors symmetric about their mean).
    pub random_rms_se_px: f64,
    /// Rms error about the truth (px): sqrt(E|e|^2), both parts together.
    pub rms_px: f64,
    /// Standard error of `rms_px` (px).
    pub rms_se_px: f64,
}

impl ErrorParts {
    /// The parts from one setting's sums over `n` frames: the sum of squared distances
    /// `sum_sq` (px^2) and the vector moments `m`.
    pub fn of(sum_sq: f64, m: &ErrorMoments, n: f64) -> Self {
        if n < 2.0 {
            return ErrorParts {
                static_x_px: f64::NAN,
                static_x_se_px: f64::NAN,
                static_y_px: f64::NAN,
                static_y_se_px: f64::NAN,
                static_px: f64::NAN,
                static_se_px: f64::NAN,
                static_sq_unbiased_px2: f64::NAN,
                static_resolved: false,
                random_rms_px: f64::NAN,
                random_rms_se_px: f64::NAN,
                rms_px: f64::NAN,
                rms_se_px: f64::NAN,
            };
        }
        let (mx, my) = (m.sum_x / n, m.sum_y / n);
        let ms = sum_sq / n;
        let (exx, eyy) = (m.sum_xx / n, (sum_sq - m.sum_xx) / n);
        // Per-axis variances of one frame (unbiased), hence of the means.
        let unbiased = n / (n - 1.0);
        let var_x = ((exx - mx * mx) * unbiased).max(0.0);
        let var_y = ((eyy - my * my) * unbiased).max(0.0);
        let (se_x, se_y) = ((var_x / n).sqrt(), (var_y / n).sqrt());
        let length = mx.hypot(my);
        let se = if length > 0.0 {
            (mx * mx * se_x * se_x + my * my * se_y * se_y).sqrt() / length
        } else {
            (0.5 * (se_x * se_x + se_y * se_y)).sqrt()
        };
        // Population moments, so that the identity random^2 + static^2 = E|e|^2 holds.
        let random_ms = (ms - mx * mx - my * my).max(0.0);
        let var_sq = ((m.sum_d4 / n - ms * ms) * unbiased).max(0.0);
        let se_ms = (var_sq / n).sqrt();
        let (rms, random_rms) = (ms.sqrt(), random_ms.sqrt());
        ErrorParts {
            static_x_px: mx,
            static_x_se_px: se_x,
            static_y_px: my,
            static_y_se_px: se_y,
            static_px: length,
            static_se_px: se,
            static_sq_unbiased_px2: mx * mx + my * my - se_x * se_x - se_y * se_y,
            static_resolved: length >= 3.0 * se,
            random_rms_px: random_rms,
            random_rms_se_px: se_ms / (2.0 * random_rms),
            rms_px: rms,
            rms_se_px: se_ms / (2.0 * rms),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parts_of_known_errors() {
        // Four frames with errors (1, 0), (1, 0), (1, 2), (1, -2): mean (1, 0), spread about it
        // 0, 0, 2, 2 (rms sqrt(2)); E|e|^2 = (1 + 1 + 5 + 5) / 4 = 3 = 2 + 1.
        let errors = [(1.0, 0.0), (1.0, 0.0), (1.0, 2.0), (1.0, -2.0)];
        let mut m = ErrorMoments::default();
        let mut sum_sq = 0.0;
        for (x, y) in errors {
            let q: f64 = x * x + y * y;
            sum_sq += q;
            m.sum_x += x;
            m.sum_y += y;
            m.sum_xx += x * x;
            m.sum_d4 += q * q;
        }
        let p = ErrorParts::of(sum_sq, &m, 4.0);
        assert_eq!((p.static_x_px, p.static_y_px, p.static_px), (1.0, 0.0, 1.0));
        assert_eq!(p.static_x_se_px, 0.0);
        // var y = 8 / 3 per frame, SE of the mean sqrt(8 / 12).
        assert!((p.static_y_se_px - (8.0f64 / 12.0).sqrt()).abs() < 1e-15);
        assert_eq!(p.static_se_px, 0.0);
        assert!(p.static_resolved);
        assert!((p.random_rms_px - 2f64.sqrt()).abs() < 1e-15);
        assert!((p.rms_px - 3f64.sqrt()).abs() < 1e-15);
        assert!((p.random_rms_px.powi(2) + p.static_px.powi(2) - p.rms_px.powi(2)).abs() < 1e-14);
        assert!(ErrorParts::of(1.0, &m, 1.0).random_rms_px.is_nan());
    }
}
