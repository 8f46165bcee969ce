//! EMCCD output densities in output electrons: the one-electron exponentially modified Gaussian
//! and the Poisson light level's compound density, with and without read noise. The 0|1 and
//! Rule B boundaries are where these densities cross.

use crate::special::{gauss_legendre, ln_bessel_i1, ln_gauss, ln_norm_cdf, log_sum_exp};

/// ln of the one-electron output density (exponential of scale g convolved with N(0, sigma^2)), per electron.
pub(super) fn ln_emg(x: f64, gain: f64, sigma: f64) -> f64 {
    -gain.ln() + sigma * sigma / (2.0 * gain * gain) - x / gain
        + ln_norm_cdf(x / sigma - sigma / gain)
}

/// ln of the continuous part of the noiseless output density for Poisson light level `lam`,
/// per output electron at y > 0: `e^(-lam - u) sqrt(lam / u) I1(2 sqrt(lam u)) / g`, u = y / g.
fn ln_compound_density(y: f64, lam: f64, gain: f64) -> f64 {
    let u = y / gain;
    let z = 2.0 * (lam * u).sqrt();
    let ln_h = if z < 1e-6 {
        lam.ln()
    } else {
        0.5 * (lam / u).ln() + ln_bessel_i1(z)
    };
    -lam - u + ln_h - gain.ln()
}

/// ln of the output density (per electron) at x for Poisson light level `lam`, including read noise.
pub(super) fn ln_output_density(x: f64, lam: f64, gain: f64, sigma: f64) -> f64 {
    if sigma == 0.0 {
        return ln_compound_density(x.max(f64::MIN_POSITIVE), lam, gain);
    }
    let (nodes, weights) = gauss_legendre();
    let a = (x - 10.0 * sigma).max(0.0);
    let b = x + 10.0 * sigma;
    let mut terms = vec![-lam + ln_gauss(x, sigma)];
    if b > a {
        let (mid, half) = (0.5 * (a + b), 0.5 * (b - a));
        for (z, w) in nodes.iter().zip(weights) {
            let y = mid + half * z;
            terms
                .push((w * half).ln() + ln_compound_density(y, lam, gain) + ln_gauss(x - y, sigma));
        }
    }
    log_sum_exp(&terms)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Simpson's rule for `f` on [a, b] with `steps` (even) intervals.
    fn simpson(f: impl Fn(f64) -> f64, a: f64, b: f64, steps: usize) -> f64 {
        let h = (b - a) / steps as f64;
        let inner: f64 = (1..steps)
            .map(|i| f(a + i as f64 * h) * if i % 2 == 1 { 4.0 } else { 2.0 })
            .sum();
        (f(a) + inner + f(b)) * h / 3.0
    }

    #[test]
    fn one_electron_density_has_unit_mass_and_mean_g() {
        // Exponential(scale g) + N(0, sigma^2): mass 1, mean g, variance g^2 + sigma^2.
        for (g, sigma) in [(500.0, 50.0), (10.0, 50.0)] {
            let (a, b) = (-12.0 * sigma, 60.0 * g + 12.0 * sigma);
            let pdf = |x: f64| ln_emg(x, g, sigma).exp();
            let mass = simpson(pdf, a, b, 200_000);
            let mean = simpson(|x| x * pdf(x), a, b, 200_000);
            let var = simpson(|x| (x - g).powi(2) * pdf(x), a, b, 200_000);
            assert!((mass - 1.0).abs() < 1e-9, "g {g}: mass {mass}");
            assert!((mean / g - 1.0).abs() < 1e-8, "g {g}: mean {mean}");
            assert!(
                (var / (g * g + sigma * sigma) - 1.0).abs() < 1e-8,
                "g {g}: var {var}"
            );
        }
    }

    #[test]
    fn compound_density_has_the_compound_poisson_moments() {
        // Continuous part of the noiseless output: mass 1 - e^-lam, mean lam g, and second
        // moment 2 lam g^2 + lam^2 g^2 (compound Poisson of exponentials), by quadrature in u = y/g.
        let g = 500.0;
        for lam in [0.1, 2.0, 15.0] {
            let pdf = |u: f64| g * ln_compound_density(g * u.max(1e-300), lam, g).exp();
            let b = lam + 20.0 * (2.0 * lam).sqrt() + 40.0;
            let mass = simpson(pdf, 0.0, b, 100_000);
            let m1 = simpson(|u| u * pdf(u), 0.0, b, 100_000);
            let m2 = simpson(|u| u * u * pdf(u), 0.0, b, 100_000);
            assert!(
                (mass - (1.0 - (-lam).exp())).abs() < 1e-9,
                "lam {lam}: mass {mass}"
            );
            assert!((m1 / lam - 1.0).abs() < 1e-9, "lam {lam}: mean {m1}");
            assert!(
                (m2 / (2.0 * lam + lam * lam) - 1.0).abs() < 1e-9,
                "lam {lam}: {m2}"
            );
        }
    }

    #[test]
    fn output_density_with_read_noise_has_unit_mass_and_mean_lam_g() {
        // The atom e^-lam at 0 and the compound part, both blurred by N(0, sigma^2): mass 1 and
        // mean lam g. The inner 64-point Gauss-Legendre rule limits the accuracy to about 1e-6.
        let (g, sigma) = (500.0, 50.0);
        for lam in [0.2, 2.0] {
            let pdf = |x: f64| ln_output_density(x, lam, g, sigma).exp();
            let (a, b) = (-12.0 * sigma, g * (lam + 20.0 * (2.0 * lam).sqrt() + 40.0));
            let mass = simpson(pdf, a, b, 40_000);
            let mean = simpson(|x| x * pdf(x), a, b, 40_000);
            assert!((mass - 1.0).abs() < 1e-6, "lam {lam}: mass {mass}");
            assert!(
                (mean / (lam * g) - 1.0).abs() < 1e-6,
                "lam {lam}: mean {mean}"
            );
        }
        // Without read noise it is the compound density itself.
        let x = 700.0;
        assert_eq!(
            ln_output_density(x, 2.0, g, 0.0),
            ln_compound_density(x, 2.0, g)
        );
    }
}
