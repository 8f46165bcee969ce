//! Numerical special functions: normal cdf and log-density, ln I1, Gauss-Legendre nodes, a
//! bisection root finder and a stable log-sum-exp.
//!
//! Each function states its accuracy, measured against mpmath at 40 digits; the tests check
//! it at known values. They were written for the Poisson-probability thresholds
//! ([`crate::detector::pp`]) and are general.

use std::sync::OnceLock;

use statrs::function::erf::erfc;

/// ln(2 pi).
pub const LN_2PI: f64 = 1.837_877_066_409_345_5;

/// Standard normal cdf Phi(z), through statrs' `erfc`: relative error below 2e-10 down to
/// z = -38 (about 5e-11 in the tails), 0 below about z = -38.5 (underflow).
pub fn norm_cdf(z: f64) -> f64 {
    0.5 * erfc(-z / std::f64::consts::SQRT_2)
}

/// ln Phi(z), accurate far into the lower tail: `ln(norm_cdf(z))` above z = -37 (absolute error
/// below 2e-10, that of [`norm_cdf`]), the Mills-ratio asymptotic series below (relative error
/// below 1e-15), so it stays finite where Phi(z) underflows.
pub fn ln_norm_cdf(z: f64) -> f64 {
    if z > -37.0 {
        norm_cdf(z).ln()
    } else {
        // Asymptotic series of the Mills ratio; at |z| >= 37 the next term is below 1e-15.
        let q = 1.0 / (z * z);
        let series =
            1.0 - q * (1.0 - 3.0 * q * (1.0 - 5.0 * q * (1.0 - 7.0 * q * (1.0 - 9.0 * q))));
        -0.5 * z * z - (-z).ln() - 0.5 * LN_2PI + series.ln()
    }
}

/// ln of the N(0, sigma^2) density at x (same unit as x and sigma); exact to round-off.
pub fn ln_gauss(x: f64, sigma: f64) -> f64 {
    -0.5 * (x / sigma).powi(2) - sigma.ln() - 0.5 * LN_2PI
}

/// ln I1(z) for z > 0 (modified Bessel function of the first kind, order 1): the power series
/// below z = 25 (absolute error about 1e-15), the 9-term Hankel expansion above (absolute error
/// 2e-12 at z = 25, 3e-13 at 30, round-off from 60 on).
pub fn ln_bessel_i1(z: f64) -> f64 {
    if z < 25.0 {
        let q = 0.25 * z * z;
        let (mut term, mut sum) = (1.0, 1.0);
        for k in 1..200 {
            term *= q / (k * (k + 1)) as f64;
            sum += term;
            if term < 1e-17 * sum {
                break;
            }
        }
        (0.5 * z).ln() + sum.ln()
    } else {
        // Hankel asymptotic expansion: I1(z) ~ e^z / sqrt(2 pi z) sum_k (-1)^k a_k(1) / z^k.
        let (mut term, mut sum) = (1.0, 1.0);
        for k in 1..10 {
            let odd = (2 * k - 1) as f64;
            term *= -(4.0 - odd * odd) / (k as f64 * 8.0 * z);
            sum += term;
        }
        z - 0.5 * (LN_2PI + z.ln()) + sum.ln()
    }
}

/// The 64-point Gauss-Legendre rule on [-1, 1] as (nodes, weights), computed once by Newton's
/// method on P64 (nodes to 1e-15); exact for polynomials of degree up to 127.
pub fn gauss_legendre() -> &'static (Vec<f64>, Vec<f64>) {
    static GL: OnceLock<(Vec<f64>, Vec<f64>)> = OnceLock::new();
    GL.get_or_init(|| {
        let n = 64;
        let (mut x, mut w) = (vec![0.0; n], vec![0.0; n]);
        for i in 0..n {
            let mut z = (std::f64::consts::PI * (i as f64 + 0.75) / (n as f64 + 0.5)).cos();
            let mut dp = 1.0;
            for _ in 0..100 {
                let (mut p0, mut p1) = (1.0, z);
                for k in 2..=n {
                    let p2 = ((2 * k - 1) as f64 * z * p1 - (k - 1) as f64 * p0) / k as f64;
                    p0 = p1;
                    p1 = p2;
                }
                dp = n as f64 * (z * p1 - p0) / (z * z - 1.0);
                let dz = p1 / dp;
                z -= dz;
                if dz.abs() < 1e-15 {
                    break;
                }
            }
            x[i] = z;
            w[i] = 2.0 / ((1.0 - z * z) * dp * dp);
        }
        (x, w)
    })
}

/// Root of `f` between `lo` (f > 0) and `hi` (f < 0) by bisection, to the precision of f64
/// (until the midpoint no longer differs from an end, at most 200 halvings).
pub fn bisect(f: impl Fn(f64) -> f64, mut lo: f64, mut hi: f64) -> f64 {
    for _ in 0..200 {
        let mid = 0.5 * (lo + hi);
        if mid <= lo || mid >= hi {
            break;
        }
        if f(mid) > 0.0 {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    0.5 * (lo + hi)
}

/// ln(sum_i e^(v_i)) without overflow (shifted by the largest term; relative error about
/// 1e-16 per term); -inf for an empty slice or all terms -inf.
pub fn log_sum_exp(v: &[f64]) -> f64 {
    let m = v.iter().cloned().fold(f64::NEG_INFINITY, f64::max);
    if m == f64::NEG_INFINITY {
        return m;
    }
    m + v.iter().map(|x| (x - m).exp()).sum::<f64>().ln()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// |got - want| <= tol * |want|.
    fn close(got: f64, want: f64, tol: f64) -> bool {
        (got - want).abs() <= tol * want.abs()
    }

    #[test]
    fn norm_cdf_matches_known_values() {
        // mpmath ncdf at 40 digits.
        for (z, want) in [
            (0.0, 0.5),
            (1.0, 0.841_344_746_068_542_9),
            (-1.0, 0.158_655_253_931_457_05),
            (-5.0, 2.866_515_718_791_939e-7),
            (-10.0, 7.619_853_024_160_526e-24),
        ] {
            assert!(
                close(norm_cdf(z), want, 2e-10),
                "Phi({z}) = {}",
                norm_cdf(z)
            );
        }
    }

    #[test]
    fn ln_norm_cdf_matches_known_values_on_both_branches() {
        // Above -37 the error is norm_cdf's (absolute, 2e-10); below, the series' (relative).
        for (z, want) in [
            (-1.0, -1.841_021_645_009_263_5),
            (-10.0, -53.231_285_150_512_47),
        ] {
            assert!(
                (ln_norm_cdf(z) - want).abs() < 2e-10,
                "ln Phi({z}) = {}",
                ln_norm_cdf(z)
            );
        }
        for (z, want) in [
            (-37.5, -707.668_989_317_507_2),
            (-38.0, -726.557_216_018_820_1),
            (-100.0, -5_005.524_208_694_205),
        ] {
            assert!(
                close(ln_norm_cdf(z), want, 1e-14),
                "ln Phi({z}) = {}",
                ln_norm_cdf(z)
            );
        }
    }

    #[test]
    fn ln_norm_cdf_is_accurate_in_the_far_tail() {
        // Both branches agree where both are representable (the switch is at -37).
        for z in [-36.0, -37.5, -38.0] {
            let direct = norm_cdf(z).ln();
            assert!(
                (ln_norm_cdf(z) - direct).abs() < 1e-9 * direct.abs(),
                "z = {z}"
            );
        }
        assert!(ln_norm_cdf(-100.0).is_finite());
    }

    #[test]
    fn ln_gauss_is_the_normal_log_density() {
        // N(0, 1) at 0: 1 / sqrt(2 pi); N(0, 2^2) at 2: e^(-1/2) / (2 sqrt(2 pi)).
        assert!(close(ln_gauss(0.0, 1.0), -0.918_938_533_204_672_8, 1e-15));
        let want = (-0.5f64).exp() / (2.0 * (2.0 * std::f64::consts::PI).sqrt());
        assert!(close(ln_gauss(2.0, 2.0), want.ln(), 1e-15));
    }

    #[test]
    fn bessel_series_and_asymptotic_agree() {
        // Both branches evaluated on either side of the switch at z = 25.
        let series = |z: f64| {
            let q = 0.25 * z * z;
            let (mut term, mut sum) = (1.0f64, 1.0f64);
            for k in 1..400 {
                term *= q / (k * (k + 1)) as f64;
                sum += term;
            }
            (0.5 * z).ln() + sum.ln()
        };
        for z in [25.0, 30.0, 60.0] {
            assert!((ln_bessel_i1(z) - series(z)).abs() < 1e-10, "z = {z}");
        }
        // I1(1) = 0.565159103992485.
        assert!((ln_bessel_i1(1.0) - 0.565_159_103_992_485f64.ln()).abs() < 1e-13);
    }

    #[test]
    fn ln_bessel_i1_matches_known_values() {
        // mpmath log(besseli(1, z)) at 40 digits; 25 and above take the asymptotic branch.
        for (z, want) in [
            (0.5, -1.355_205_447_025_334_5),
            (10.0, 7.890_203_834_104_212),
            (25.0, 22.456_312_472_475_35),
            (30.0, 27.367_748_089_282_41),
            (60.0, 57.027_586_326_030_33),
        ] {
            assert!((ln_bessel_i1(z) - want).abs() < 3e-12, "z = {z}");
        }
    }

    #[test]
    fn gauss_legendre_integrates_polynomials_exactly() {
        // Sum of weights = 2; int x^126 = 2/127; odd powers vanish; nodes lie in (-1, 1).
        let (x, w) = gauss_legendre();
        assert_eq!(x.len(), 64);
        assert!(close(w.iter().sum(), 2.0, 1e-14));
        for (p, want) in [(2, 2.0 / 3.0), (40, 2.0 / 41.0), (126, 2.0 / 127.0)] {
            let got: f64 = x.iter().zip(w).map(|(x, w)| w * x.powi(p)).sum();
            assert!(close(got, want, 1e-12), "x^{p}: {got}");
        }
        let odd: f64 = x.iter().zip(w).map(|(x, w)| w * x.powi(7)).sum();
        assert!(odd.abs() < 1e-15);
        assert!(x.iter().all(|x| x.abs() < 1.0));
    }

    #[test]
    fn bisect_finds_roots_to_full_precision() {
        let root = bisect(|x| 2.0 - x * x, 0.0, 2.0);
        assert!((root - std::f64::consts::SQRT_2).abs() <= 2.0 * f64::EPSILON);
        let root = bisect(|x| -x.ln_1p() + 0.5, 0.0, 10.0);
        assert!((root - (0.5f64.exp() - 1.0)).abs() <= 4.0 * f64::EPSILON);
    }

    #[test]
    fn log_sum_exp_is_stable() {
        assert_eq!(log_sum_exp(&[]), f64::NEG_INFINITY);
        assert_eq!(log_sum_exp(&[f64::NEG_INFINITY; 2]), f64::NEG_INFINITY);
        assert!(close(
            log_sum_exp(&[0.0, 0.0]),
            std::f64::consts::LN_2,
            1e-15
        ));
        // Terms far beyond exp's range: 1000 + ln(1 + e^-1).
        let want = 1000.0 + (-1.0f64).exp().ln_1p();
        assert!(close(log_sum_exp(&[1000.0, 999.0]), want, 1e-15));
    }
}
