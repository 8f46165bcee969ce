//! Per-pixel excess kurtosis from the shifted power sums of the dark statistics, and the
//! figures of its map for the summary.
//!
//! The estimator is the adjusted Fisher-Pearson G2 = ((n + 1) g2 + 6) (n - 1) / ((n - 2)
//! (n - 3)), with g2 = m4 / m2^2 - 3 from the central moments: unbiased for Gaussian samples,
//! whose G2 has standard error sqrt(24 n (n - 1)^2 / ((n - 3) (n - 2) (n + 3) (n + 5))),
//! about sqrt(24 / n). For integer samples the power sums are integers, exact while they stay
//! below 2^53 (e.g. |x - first sample| below 1450 adu in every one of 2000 frames); the
//! central moments are then formed from them in 128-bit integers, so G2 is rounded from its
//! exact value in a few operations. Other sums (floats, or beyond 2^53) take the shifted
//! formulas in f64: a relative error of about n x 2^-53 times (shift - mean)^4 / m4.

use serde::Serialize;

use crate::stats::median;

/// The shifted power sums of one pixel: n samples x, shift, sum (x - shift)^p for p = 1..4.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) struct PowerSums {
    pub(super) n: f64,
    pub(super) s1: f64,
    pub(super) s2: f64,
    pub(super) s3: f64,
    pub(super) s4: f64,
}

/// Largest integer below which f64 holds every integer.
const EXACT: f64 = 9_007_199_254_740_992.0;

/// Excess kurtosis G2 of one pixel's samples (NaN with fewer than 4 samples or none spread).
pub(super) fn excess_kurtosis(p: PowerSums) -> f64 {
    let PowerSums { n, s1, s2, s3, s4 } = p;
    if n < 4.0 {
        return f64::NAN;
    }
    let integral = |v: f64| v.abs() < EXACT && (v as i64) as f64 == v;
    // With central moments m2, m4: n^2 m2 = n s2 - s1^2 and n^4 m4 = n^3 s4 - 4 n^2 s1 s3
    // + 6 n s1^2 s2 - 3 s1^4, whatever the shift; m4 / m2^2 = n^4 m4 / (n^2 m2)^2.
    let ratio = if [n, s1, s2, s3, s4].into_iter().all(integral) {
        // Through i64 (one instruction; f64 to i128 is a library call), exact for integers
        // below 2^53.
        let [n, s1, s2, s3, s4] = [n, s1, s2, s3, s4].map(|v| v as i64 as i128);
        let m2n2 = n * s2 - s1 * s1;
        let m4n4 = if far_inside_i128(p) {
            Some(m4n4_unchecked([n, s1, s2, s3, s4]))
        } else {
            m4n4_checked([n, s1, s2, s3, s4])
        };
        match m4n4 {
            // m4 / m2^2 = (n^4 m4) / (n^2 m2)^2: both exact integers, rounded once each.
            Some(m4n4) if m2n2 > 0 => {
                let (m4n4, m2n2) = (rounded(m4n4), rounded(m2n2));
                m4n4 / (m2n2 * m2n2)
            }
            Some(_) => return f64::NAN,
            None => shifted_ratio(p),
        }
    } else {
        shifted_ratio(p)
    };
    let g2 = ratio - 3.0;
    ((n + 1.0) * g2 + 6.0) * (n - 1.0) / ((n - 2.0) * (n - 3.0))
}

/// Whether every product and partial sum of n^4 m4 (in integers) is below 2^120, far inside
/// i128, bounded in f64 with each factor taken as at least 1 (so a product's factors are
/// bounded too). Then [`m4n4_unchecked`] needs no overflow check: an i128 `checked_mul` is a
/// library call, which made the kurtosis a third of a dark stack's maps after the reading.
fn far_inside_i128(p: PowerSums) -> bool {
    let a = |v: f64| v.abs().max(1.0);
    let (n, s1, s2, s3, s4) = (a(p.n), a(p.s1), a(p.s2), a(p.s3), a(p.s4));
    let bound = n * n * n * s4 + 4.0 * n * n * s1 * s3 + 6.0 * n * s1 * s1 * s2 + 3.0 * s1.powi(4);
    bound < 2f64.powi(120)
}

/// n^4 m4 = n^3 s4 - 4 n^2 s1 s3 + 6 n s1^2 s2 - 3 s1^4 from integer sums that
/// [`far_inside_i128`] bounds.
fn m4n4_unchecked([n, s1, s2, s3, s4]: [i128; 5]) -> i128 {
    n * n * n * s4 - 4 * n * n * s1 * s3 + 6 * n * (s1 * s1) * s2 - (s1 * s1) * (s1 * s1) * 3
}

/// n^4 m4 with every term checked (None beyond i128: the f64 formula takes over).
fn m4n4_checked([n, s1, s2, s3, s4]: [i128; 5]) -> Option<i128> {
    n.checked_mul(n)
        .and_then(|nn| nn.checked_mul(n))
        .and_then(|n3| n3.checked_mul(s4))
        .and_then(|a| {
            let b = (4 * n * n).checked_mul(s1)?.checked_mul(s3)?;
            let c = (6 * n).checked_mul(s1 * s1)?.checked_mul(s2)?;
            let d = (s1 * s1).checked_mul(s1 * s1)?.checked_mul(3)?;
            a.checked_sub(b)?.checked_add(c)?.checked_sub(d)
        })
}

/// `v` rounded to the nearest f64 (ties to even), through i64 when it fits: the same value
/// as `v as f64`, without the library call that converts an i128.
fn rounded(v: i128) -> f64 {
    match i64::try_from(v) {
        Ok(v) => v as f64,
        Err(_) => v as f64,
    }
}

/// m4 / m2^2 from the shifted sums in f64.
fn shifted_ratio(p: PowerSums) -> f64 {
    let PowerSums { n, s1, s2, s3, s4 } = p;
    let m = s1 / n;
    let m2 = s2 / n - m * m;
    let m4 = s4 / n - 4.0 * m * s3 / n + 6.0 * m * m * s2 / n - 3.0 * m * m * m * m;
    if m2 > 0.0 {
        m4 / (m2 * m2)
    } else {
        f64::NAN
    }
}

/// Standard error of G2 for `n` Gaussian samples.
pub fn kurtosis_se(n: usize) -> f64 {
    let n = n as f64;
    if n < 4.0 {
        return f64::NAN;
    }
    (24.0 * n * (n - 1.0) * (n - 1.0) / ((n - 3.0) * (n - 2.0) * (n + 3.0) * (n + 5.0))).sqrt()
}

/// Pixels whose |G2| exceeds this many Gaussian standard errors are counted as non-Gaussian.
pub const KURTOSIS_SIGMAS: f64 = 5.0;

/// The excess-kurtosis map in summary.json.
#[derive(Clone, Debug, Serialize)]
pub struct KurtosisSummary {
    /// Estimator and what the counts mean (one sentence).
    pub method: String,
    /// Pixels with a finite excess kurtosis.
    pub pixels: usize,
    /// Median excess kurtosis over pixels (dimensionless; null without pixels).
    pub median: Option<f64>,
    /// Mean excess kurtosis over pixels (dimensionless; null without pixels).
    pub mean: Option<f64>,
    /// Standard error of one pixel's excess kurtosis if its samples were Gaussian.
    pub gaussian_se: Option<f64>,
    /// Threshold on |excess kurtosis| for the counts below (KURTOSIS_SIGMAS x gaussian_se).
    pub threshold: Option<f64>,
    /// Pixels beyond the threshold.
    pub pixels_beyond_threshold: usize,
    /// Pixels beyond the threshold that are not flagged RTS (non-Gaussian for other reasons).
    pub pixels_beyond_threshold_not_rts: usize,
}

impl KurtosisSummary {
    /// Figures of the map `g2` from `frames` samples per pixel, with `rts` telling the
    /// RTS-flagged pixels.
    pub fn of(g2: &[f64], frames: usize, rts: impl Fn(usize) -> bool) -> KurtosisSummary {
        let finite: Vec<f64> = g2.iter().copied().filter(|v| v.is_finite()).collect();
        let se = Some(kurtosis_se(frames)).filter(|s| s.is_finite());
        let threshold = se.map(|s| KURTOSIS_SIGMAS * s);
        let beyond = |i: &usize| threshold.is_some_and(|t| g2[*i].abs() > t);
        let idx: Vec<usize> = (0..g2.len()).filter(beyond).collect();
        let n = finite.len();
        KurtosisSummary {
            method: format!(
                "adjusted Fisher-Pearson excess kurtosis G2 of every sample of each pixel (before clipping); 0 for Gaussian noise, counts of |G2| above {KURTOSIS_SIGMAS} Gaussian standard errors"
            ),
            pixels: n,
            median: (n > 0).then(|| median(&finite)),
            mean: (n > 0).then(|| finite.iter().sum::<f64>() / n as f64),
            gaussian_se: se,
            threshold,
            pixels_beyond_threshold: idx.len(),
            pixels_beyond_threshold_not_rts: idx.iter().filter(|i| !rts(**i)).count(),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sums(x: &[f64], shift: f64) -> PowerSums {
        let p = |k: i32| x.iter().map(|v| (v - shift).powi(k)).sum::<f64>();
        PowerSums {
            n: x.len() as f64,
            s1: p(1),
            s2: p(2),
            s3: p(3),
            s4: p(4),
        }
    }

    /// G2 from the definition with exact rationals (small integer samples, f64 is exact).
    fn direct(x: &[f64]) -> f64 {
        let n = x.len() as f64;
        let m = x.iter().sum::<f64>() / n;
        let m2 = x.iter().map(|v| (v - m).powi(2)).sum::<f64>() / n;
        let m4 = x.iter().map(|v| (v - m).powi(4)).sum::<f64>() / n;
        let g2 = m4 / (m2 * m2) - 3.0;
        ((n + 1.0) * g2 + 6.0) * (n - 1.0) / ((n - 2.0) * (n - 3.0))
    }

    #[test]
    fn integer_sums_give_g2_of_the_definition() {
        // A two-level pixel (levels 0 and 8 in 3:1) and a pixel with an outlier; any shift.
        let two: Vec<f64> = (0..40)
            .map(|i| if i % 4 == 0 { 8.0 } else { 0.0 })
            .collect();
        let spike: Vec<f64> = (0..40)
            .map(|i| if i == 7 { 60.0 } else { (i % 5) as f64 })
            .collect();
        for x in [&two, &spike] {
            for shift in [x[0], 0.0, -300.0] {
                let g = excess_kurtosis(sums(x, shift));
                assert!((g - direct(x)).abs() < 1e-12 * direct(x).abs().max(1.0));
            }
        }
        // A symmetric two-level mixture with equal weights has g2 = -2 exactly.
        let half: Vec<f64> = (0..40).map(|i| (i % 2) as f64 * 2.0).collect();
        let n = 40.0;
        let want = ((n + 1.0) * -2.0 + 6.0) * (n - 1.0) / ((n - 2.0) * (n - 3.0));
        assert_eq!(excess_kurtosis(sums(&half, 0.0)), want);
        // Fractional samples take the shifted formula; a constant pixel has none.
        let f: Vec<f64> = spike.iter().map(|v| v * 0.37 + 0.1).collect();
        assert!((excess_kurtosis(sums(&f, f[0])) - direct(&f)).abs() < 1e-9);
        assert!(excess_kurtosis(sums(&[3.0; 10], 3.0)).is_nan());
        assert!(excess_kurtosis(sums(&[1.0, 2.0, 3.0], 1.0)).is_nan());
    }

    #[test]
    fn rounding_through_i64_is_the_i128_conversion() {
        let big = [
            0i128,
            1,
            -1,
            (1 << 53) + 1,
            (1 << 62) + 513,
            i64::MAX as i128,
            i64::MIN as i128,
            i64::MAX as i128 + 1,
            -(1i128 << 100) - 12_345,
            i128::MAX,
        ];
        for v in big
            .into_iter()
            .chain((0..200).map(|k| (k * 0x9E37_79B9_7F4A_7C15) >> 3))
        {
            assert_eq!(rounded(v).to_bits(), (v as f64).to_bits(), "{v}");
            assert_eq!(rounded(-v).to_bits(), (-v as f64).to_bits(), "{v}");
        }
    }

    #[test]
    fn the_unchecked_fourth_moment_is_the_checked_one_wherever_it_is_taken() {
        // Sums from 4 samples to 2^20 of them, spreads of 1 to 2^13 adu, both signs of s1 and
        // s3, up to the bound and past it (where the checked path alone is used).
        let mut taken = 0;
        for n in [4.0f64, 200.0, 65536.0, 1048576.0] {
            for spread in [1.0f64, 30.0, 1000.0, 8192.0] {
                for sign in [-1.0, 1.0] {
                    let s1 = sign * (n * spread / 3.0).floor();
                    let s2 = (n * spread * spread).floor();
                    let s3 = sign * (n * spread.powi(3) / 5.0).floor();
                    let s4 = (3.0 * n * spread.powi(4)).floor();
                    let p = PowerSums { n, s1, s2, s3, s4 };
                    let ints = [n, s1, s2, s3, s4].map(|v| v as i64 as i128);
                    if far_inside_i128(p) {
                        taken += 1;
                        assert_eq!(Some(m4n4_unchecked(ints)), m4n4_checked(ints), "{p:?}");
                    }
                }
            }
        }
        assert!(
            (20..32).contains(&taken),
            "{taken} of 32 sums below the bound"
        );
    }

    #[test]
    fn gaussian_se_is_near_sqrt_24_over_n() {
        let n = 10_000;
        assert!((kurtosis_se(n) / (24.0 / n as f64).sqrt() - 1.0).abs() < 1e-3);
        assert!(kurtosis_se(3).is_nan());
    }

    #[test]
    fn the_summary_counts_pixels_beyond_the_threshold() {
        // 100 frames: threshold 5 x 0.4640 = 2.32; pixels 1 (RTS) and 3 (not) beyond it.
        let g2 = [0.1, -2.5, 0.3, 6.0, f64::NAN];
        let s = KurtosisSummary::of(&g2, 100, |i| i == 1);
        assert_eq!(s.pixels, 4);
        assert_eq!(s.pixels_beyond_threshold, 2);
        assert_eq!(s.pixels_beyond_threshold_not_rts, 1);
        assert_eq!(s.median, Some(0.2));
        assert!((s.threshold.unwrap() - 5.0 * kurtosis_se(100)).abs() < 1e-15);
    }
}
