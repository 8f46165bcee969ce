//! The mean radial error of a centred bivariate normal error (the Hoyt distribution's mean) and
//! the quadrature of the spot positions it is averaged over.

use std::f64::consts::{FRAC_2_PI, PI};

/// Gauss-Legendre rule of 6 points on [-1, 1] as (node, weight): exact for polynomials of
/// degree up to 11, enough for a mean radial error that varies smoothly with the position.
pub const GL6: [(f64, f64); 6] = [
    (-0.932_469_514_203_152, 0.171_324_492_379_170),
    (-0.661_209_386_466_265, 0.360_761_573_048_139),
    (-0.238_619_186_083_197, 0.467_913_934_572_691),
    (0.238_619_186_083_197, 0.467_913_934_572_691),
    (0.661_209_386_466_265, 0.360_761_573_048_139),
    (0.932_469_514_203_152, 0.171_324_492_379_170),
];

/// Complete elliptic integral of the second kind E(m), parameter m = k^2 in [0, 1], by the
/// arithmetic-geometric mean (to round-off in a handful of steps).
pub fn elliptic_e(m: f64) -> f64 {
    let m = m.clamp(0.0, 1.0);
    if m >= 1.0 - 1e-15 {
        return 1.0;
    }
    let (mut a, mut b) = (1.0f64, (1.0 - m).sqrt());
    let mut sum = 0.5 * m;
    let mut power = 0.5;
    for _ in 0..40 {
        let c = 0.5 * (a - b);
        power *= 2.0;
        sum += power * c * c;
        (a, b) = (0.5 * (a + b), (a * b).sqrt());
        if c.abs() < 1e-16 * a {
            break;
        }
    }
    PI / (2.0 * a) * (1.0 - sum)
}

/// E|e| (px) for e ~ N(0, `cov`) in 2-D (`cov` = [[xx, xy], [xy, yy]] in px^2):
/// sqrt(2 a / pi) E(1 - b / a) with a >= b the eigenvalues; sigma sqrt(pi / 2) when isotropic.
pub fn mean_radius(cov: [[f64; 2]; 2]) -> f64 {
    let (xx, xy, yy) = (cov[0][0], cov[0][1], cov[1][1]);
    let half_trace = 0.5 * (xx + yy);
    let spread = (0.25 * (xx - yy).powi(2) + xy * xy).sqrt();
    let a = half_trace + spread;
    let b = (half_trace - spread).max(0.0);
    if a <= 0.0 {
        return 0.0;
    }
    (FRAC_2_PI * a).sqrt() * elliptic_e(1.0 - b / a)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn mean_radius_of_the_known_limits() {
        // Isotropic: the Rayleigh mean s sqrt(pi/2); one axis only: the half-normal mean.
        let s: f64 = 0.3;
        let iso = mean_radius([[s * s, 0.0], [0.0, s * s]]);
        assert!((iso - s * (PI / 2.0).sqrt()).abs() < 1e-14, "{iso}");
        let line = mean_radius([[0.0, 0.0], [0.0, s * s]]);
        assert!((line - s * FRAC_2_PI.sqrt()).abs() < 1e-14, "{line}");
        // E(0.5) = 1.3506438810476755 (tables).
        assert!((elliptic_e(0.5) - 1.350_643_881_047_675_5).abs() < 1e-14);
        // A rotated ellipse has the mean radius of its axes.
        let (a, b, t): (f64, f64, f64) = (0.04, 0.01, 0.7);
        let (c, si) = (t.cos(), t.sin());
        let rot = [
            [a * c * c + b * si * si, (a - b) * c * si],
            [(a - b) * c * si, a * si * si + b * c * c],
        ];
        assert!((mean_radius(rot) - mean_radius([[a, 0.0], [0.0, b]])).abs() < 1e-14);
    }

    #[test]
    fn mean_radius_matches_a_direct_integral() {
        // E|e| = int int r N(x; 0, a) N(y; 0, b) dx dy on a fine grid.
        let (a, b): (f64, f64) = (0.09, 0.01);
        let (step, half) = (0.004, 2.0);
        let count = (2.0 * half / step) as i64;
        let mut sum = 0.0;
        for i in 0..count {
            let x = -half + (i as f64 + 0.5) * step;
            for j in 0..count {
                let y = -half + (j as f64 + 0.5) * step;
                let pdf = (-0.5 * (x * x / a + y * y / b)).exp() / (2.0 * PI * (a * b).sqrt());
                sum += (x * x + y * y).sqrt() * pdf * step * step;
            }
        }
        let want = mean_radius([[a, 0.0], [0.0, b]]);
        assert!((sum - want).abs() < 1e-5 * want, "{sum} vs {want}");
    }
}
