//! Moments of samples: mean and variance, correlation of two samples, and the slope of a
//! straight-line fit with its heteroscedasticity-robust t value.

/// Mean of the finite values (NaN if none).
pub fn finite_mean(values: &[f64]) -> f64 {
    let v: Vec<f64> = values.iter().copied().filter(|v| v.is_finite()).collect();
    v.iter().sum::<f64>() / v.len() as f64
}

/// Mean and unbiased variance (n - 1 denominator) of a slice (NaN for fewer than two values).
pub fn mean_var(xs: &[f64]) -> (f64, f64) {
    let n = xs.len() as f64;
    let m = xs.iter().sum::<f64>() / n;
    let v = xs.iter().map(|x| (x - m).powi(2)).sum::<f64>() / (n - 1.0);
    (m, v)
}

/// Pearson correlation of two samples over the pairs where both are finite (NaN for fewer
/// than two such pairs).
pub fn correlation(a: &[f64], b: &[f64]) -> f64 {
    let pairs: Vec<(f64, f64)> = a
        .iter()
        .zip(b)
        .filter(|(x, y)| x.is_finite() && y.is_finite())
        .map(|(x, y)| (*x, *y))
        .collect();
    let n = pairs.len() as f64;
    if n < 2.0 {
        return f64::NAN;
    }
    let (ma, mb) = (
        pairs.iter().map(|p| p.0).sum::<f64>() / n,
        pairs.iter().map(|p| p.1).sum::<f64>() / n,
    );
    let (mut sab, mut saa, mut sbb) = (0.0, 0.0, 0.0);
    for (x, y) in &pairs {
        sab += (x - ma) * (y - mb);
        saa += (x - ma) * (x - ma);
        sbb += (y - mb) * (y - mb);
    }
    sab / (saa * sbb).sqrt()
}

/// Least-squares slope of y on x and its t value with the heteroscedasticity-robust (White,
/// HC0) standard error: (slope, slope / se). Where y scatters more for some x (variances of
/// noisier pixels), plain OLS errors are too small. NaN slope when x does not vary; NaN t
/// when the fit is exact (se = 0).
pub fn robust_slope(x: &[f64], y: &[f64]) -> (f64, f64) {
    let n = x.len() as f64;
    let (mx, my) = (x.iter().sum::<f64>() / n, y.iter().sum::<f64>() / n);
    let (mut sxx, mut sxy) = (0.0, 0.0);
    for (a, b) in x.iter().zip(y) {
        sxx += (a - mx) * (a - mx);
        sxy += (a - mx) * (b - my);
    }
    if sxx <= 0.0 {
        return (f64::NAN, f64::NAN);
    }
    let slope = sxy / sxx;
    let meat: f64 = x
        .iter()
        .zip(y)
        .map(|(a, b)| {
            let e = b - my - slope * (a - mx);
            (a - mx) * (a - mx) * e * e
        })
        .sum();
    let se = meat.sqrt() / sxx;
    (slope, if se > 0.0 { slope / se } else { f64::NAN })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn mean_var_of_known_samples() {
        // 2, 4, 4, 4, 5, 5, 7, 9: mean 5, sum of squared deviations 32, 32 / 7.
        let (m, v) = mean_var(&[2.0, 4.0, 4.0, 4.0, 5.0, 5.0, 7.0, 9.0]);
        assert_eq!(m, 5.0);
        assert!((v - 32.0 / 7.0).abs() < 1e-15);
        assert!(mean_var(&[1.0]).1.is_nan());
        assert_eq!(
            finite_mean(&[1.0, f64::NAN, 2.0, f64::NEG_INFINITY, 6.0]),
            3.0
        );
        assert!(finite_mean(&[f64::NAN]).is_nan());
    }

    #[test]
    fn correlation_of_exact_and_known_relations() {
        let x = [1.0, 2.0, 3.0, 4.0, 5.0];
        let up: Vec<f64> = x.iter().map(|v| 3.0 * v - 1.0).collect();
        let down: Vec<f64> = x.iter().map(|v| -0.5 * v + 2.0).collect();
        assert!((correlation(&x, &up) - 1.0).abs() < 1e-15);
        assert!((correlation(&x, &down) + 1.0).abs() < 1e-15);
        // x = 1..4, y = 1, 3, 2, 4: sxy = 4, sxx = syy = 5, r = 0.8.
        assert!((correlation(&[1.0, 2.0, 3.0, 4.0], &[1.0, 3.0, 2.0, 4.0]) - 0.8).abs() < 1e-15);
        // Non-finite pairs are skipped; fewer than two pairs give NaN.
        let r = correlation(&[1.0, f64::NAN, 2.0, 3.0], &[2.0, 5.0, 4.0, 6.0]);
        assert!((r - 1.0).abs() < 1e-15);
        assert!(correlation(&[1.0, f64::NAN], &[1.0, 2.0]).is_nan());
    }

    #[test]
    fn robust_slope_matches_the_white_formula() {
        // x = 0..3, y = 0, 1, 1, 3: slope = sxy / sxx = 4.5 / 5 = 0.9; residuals
        // e = -0.1, 0.2, -0.7, 0.4 about the line through (1.5, 1.25); the White variance
        // sum (x - mx)^2 e^2 / sxx^2 = (2.25 (0.01 + 0.16) + 0.25 (0.04 + 0.49)) / 25 = 0.0206.
        let (b, t) = robust_slope(&[0.0, 1.0, 2.0, 3.0], &[0.0, 1.0, 1.0, 3.0]);
        assert!((b - 0.9).abs() < 1e-15);
        assert!((t - 0.9 / 0.0206f64.sqrt()).abs() < 1e-12, "{t}");
        // An exact line has no scatter (t undefined); constant x has no slope.
        let (b, t) = robust_slope(&[0.0, 1.0, 2.0], &[1.0, 3.0, 5.0]);
        assert!((b - 2.0).abs() < 1e-15 && t.is_nan());
        assert!(robust_slope(&[1.0, 1.0], &[0.0, 1.0]).0.is_nan());
    }
}
