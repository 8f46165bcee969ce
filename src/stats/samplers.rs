//! Exact samplers of the discrete laws the simulation draws from (Poisson, Binomial(k, 1/2)).

use crate::rng::SimRng;
use rand::RngExt;
use rand_distr::{Distribution, Poisson};

/// Mean at which Poisson sampling switches from inversion to rand_distr's rejection method.
const POISSON_INVERSION_MAX: f64 = 30.0;

/// Most steps of the inversion's search, a count it never exceeds: the bound only guards
/// against a deviate within round-off of 1 (the mass beyond 1000 at a mean below 30 is
/// ~1e-1100).
const MAX_INVERSION_STEPS: u32 = 1000;

/// One Poisson(lambda) draw; lambda <= 0 gives 0.
///
/// Inversion by sequential search below lambda = 30 (exact, and cheap for the small means
/// of most sub-aperture pixels); rand_distr's PTRS rejection sampler above.
pub fn poisson(lambda: f64, rng: &mut SimRng) -> u32 {
    if lambda <= 0.0 {
        return 0;
    }
    if lambda >= POISSON_INVERSION_MAX {
        return Poisson::new(lambda)
            .expect("finite positive mean")
            .sample(rng) as u32;
    }
    let u: f64 = rng.random();
    let mut p = (-lambda).exp();
    let mut cdf = p;
    let mut k = 0u32;
    while u > cdf && k < MAX_INVERSION_STEPS {
        k += 1;
        p *= lambda / k as f64;
        cdf += p;
    }
    k
}

/// Means searched together by [`poisson_each`] (vector lanes).
const LANES: usize = 8;
/// Means whose deviates and exponentials [`poisson_each`] prepares at once (a multiple of
/// [`LANES`], at most 64: one bit each in a mask).
const BLOCK: usize = 64;

/// Independent Poisson counts with means `lambdas` into `out` (same length); a mean <= 0
/// gives 0 and draws nothing.
///
/// The same law and the same deviates, in the same order, as [`poisson`] called pixel by
/// pixel: the deviates are drawn first, in order (one uniform per mean in (0, 30); rand_distr's
/// rejection sampler, drawn there and then, for a mean of 30 or more), then the means below 30
/// are inverted by sequential search, eight in lockstep (one vector step moves every lane, a
/// lane stops counting once its CDF passes its deviate), so a frame costs no mispredicted loop
/// exit per pixel and no division per step. Two roundings differ from [`poisson`]:
/// exp(-lambda) from [`exp_neg`] (within 2 ulp of the platform's `exp`) and
/// p x (lambda x 1/k) instead of p x (lambda / k); a count differs only when a deviate falls
/// within a few ulp of a CDF value (probability ~1e-15 per draw).
pub fn poisson_each(lambdas: &[f64], rng: &mut SimRng, out: &mut [u32]) {
    assert_eq!(lambdas.len(), out.len(), "one count per mean");
    #[cfg(target_arch = "x86_64")]
    if std::arch::is_x86_feature_detected!("avx2") {
        // SAFETY: the CPU has AVX2 (checked just above).
        return unsafe { poisson_each_avx2(lambdas, rng, out) };
    }
    poisson_each_inline(lambdas, rng, out)
}

/// [`poisson_each_inline`] compiled for AVX2: the same operations in the same order (no fused
/// multiply-add), so the same counts, with wider vectors.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
unsafe fn poisson_each_avx2(lambdas: &[f64], rng: &mut SimRng, out: &mut [u32]) {
    poisson_each_inline(lambdas, rng, out)
}

#[inline(always)]
fn poisson_each_inline(lambdas: &[f64], rng: &mut SimRng, out: &mut [u32]) {
    for (means, counts) in lambdas.chunks(BLOCK).zip(out.chunks_mut(BLOCK)) {
        // Lanes left at mean 0 and deviate 0 count 0: means <= 0, and those drawn directly
        // (bit i of `direct`).
        let (mut lambda, mut u) = ([0.0; BLOCK], [0.0; BLOCK]);
        let mut direct = 0u64;
        for (i, (&m, c)) in means.iter().zip(counts.iter_mut()).enumerate() {
            if m > 0.0 && m < POISSON_INVERSION_MAX {
                lambda[i] = m;
                u[i] = rng.random();
            } else if m > 0.0 || m.is_nan() {
                *c = poisson(m, rng);
                direct |= 1 << i;
            }
        }
        // Every exponential of the block in one loop: independent lanes, so the polynomial's
        // latency overlaps.
        let used = means.len().div_ceil(LANES) * LANES;
        let mut p0 = [0.0; BLOCK];
        for (p, &l) in p0[..used].iter_mut().zip(&lambda[..used]) {
            *p = exp_neg(l);
        }
        for start in (0..used).step_by(LANES) {
            let lanes = start..start + LANES;
            let k = invert_lanes(
                lambda[lanes.clone()].try_into().expect("LANES"),
                u[lanes.clone()].try_into().expect("LANES"),
                p0[lanes].try_into().expect("LANES"),
            );
            for (i, &k) in k.iter().enumerate().take(means.len().saturating_sub(start)) {
                if direct & (1 << (start + i)) == 0 {
                    counts[start + i] = k;
                }
            }
        }
    }
}

/// 1/k for k = 1..=[`MAX_INVERSION_STEPS`] (entry 0 unused): each step of [`invert_lanes`]
/// loads its factor instead of dividing (a division per step set the pace of the search).
/// Evaluated at compile time, correctly rounded like the division at run time: the same bits.
static RECIPROCALS: [f64; MAX_INVERSION_STEPS as usize + 1] = {
    let mut table = [0.0; MAX_INVERSION_STEPS as usize + 1];
    let mut k = 1;
    while k <= MAX_INVERSION_STEPS as usize {
        table[k] = 1.0 / k as f64;
        k += 1;
    }
    table
};

/// The smallest k with CDF(k) >= u per lane (Poisson(lambda), 0 <= lambda < 30, p0 =
/// exp(-lambda); at most [`MAX_INVERSION_STEPS`], as [`poisson`]). A lane of
/// mean 0 and deviate 0 gives 0.
#[inline(always)]
fn invert_lanes(lambda: [f64; LANES], u: [f64; LANES], p0: [f64; LANES]) -> [u32; LANES] {
    let mut p = p0;
    let mut cdf = p;
    let mut k = [0u32; LANES];
    for step in 1..=MAX_INVERSION_STEPS {
        let mut going = 0u32;
        for i in 0..LANES {
            let go = u32::from(u[i] > cdf[i]);
            k[i] += go;
            going |= go;
        }
        if going == 0 {
            break;
        }
        let inv = RECIPROCALS[step as usize];
        for i in 0..LANES {
            p[i] *= lambda[i] * inv;
            cdf[i] += p[i];
        }
    }
    k
}

/// exp(-x) for 0 <= x <= 700, within 2 ulp of the platform's `exp` (tested; so within 3 of the
/// correctly rounded value): Cody-Waite reduction by ln 2 and the Taylor polynomial of degree 13 on
/// |r| <= ln(2)/2 (truncation below 1e-17). Plain arithmetic without fused multiply-adds, so
/// every CPU and vector width gives the same bits, and it vectorises.
#[inline(always)]
pub fn exp_neg(x: f64) -> f64 {
    // ln 2 split so that n x LN2_HI is exact for |n| < 2^11.
    const LN2_HI: f64 = f64::from_bits(0x3fe6_2e42_fee0_0000);
    const LN2_LO: f64 = f64::from_bits(0x3dea_39ef_3579_3c76);
    const INV_FACT: [f64; 14] = [
        1.0,
        1.0,
        0.5,
        1.0 / 6.0,
        1.0 / 24.0,
        1.0 / 120.0,
        1.0 / 720.0,
        1.0 / 5040.0,
        1.0 / 40320.0,
        1.0 / 362_880.0,
        1.0 / 3_628_800.0,
        1.0 / 39_916_800.0,
        1.0 / 479_001_600.0,
        1.0 / 6_227_020_800.0,
    ];
    let n = (-x * std::f64::consts::LOG2_E).round_ties_even();
    let r = (-x - n * LN2_HI) - n * LN2_LO;
    let mut poly = INV_FACT[13];
    for c in INV_FACT[..13].iter().rev() {
        poly = poly * r + c;
    }
    // 2^n for -1010 < n <= 0, built from its exponent bits: 2^52 + 1023 + n holds the biased
    // exponent in its low mantissa bits (an integer conversion would not vectorise).
    let biased = n + (4_503_599_627_370_496.0 + 1023.0);
    let scale = f64::from_bits(biased.to_bits() << 52);
    poly * scale
}

/// One Binomial(k, 1/2) draw: the number of set bits among k fair random bits.
#[inline(always)]
pub fn binomial_half(k: u32, rng: &mut SimRng) -> u32 {
    let mut left = k;
    let mut total = 0;
    while left > 0 {
        let take = left.min(64);
        let bits: u64 = rng.random();
        let mask = if take == 64 {
            u64::MAX
        } else {
            (1u64 << take) - 1
        };
        total += (bits & mask).count_ones();
        left -= take;
    }
    total
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rng::stream;
    use crate::stats::mean_var;

    #[test]
    fn poisson_moments_both_regimes() {
        // Mean and variance both equal lambda; SE(mean) = sqrt(lambda/N),
        // SE(var) ~ lambda * sqrt(2/N) (excess kurtosis 1/lambda is small); 4 SE.
        let n = 200_000;
        for (i, lambda) in [0.05, 0.7, 5.0, 29.0, 31.0, 400.0].into_iter().enumerate() {
            let mut rng = stream(5, i as u64, 0);
            let xs: Vec<f64> = (0..n).map(|_| poisson(lambda, &mut rng) as f64).collect();
            let (m, v) = mean_var(&xs);
            assert!(
                (m - lambda).abs() < 4.0 * (lambda / n as f64).sqrt(),
                "{lambda}: mean {m}"
            );
            let se_v = lambda * ((2.0 + 1.0 / lambda) / n as f64).sqrt();
            assert!((v - lambda).abs() < 4.0 * se_v, "{lambda}: var {v}");
        }
        assert_eq!(poisson(0.0, &mut stream(1, 1, 1)), 0);
    }

    #[test]
    fn exp_neg_within_two_ulp_of_libm() {
        // libm's exp is within 1 ulp of the correctly rounded value: 2 ulp of it bounds ours
        // within 3. Dense over the inversion range, sparse out to 700, and the ends.
        let xs = (0..300_000)
            .map(|i| i as f64 * 1e-4)
            .chain((0..70_000).map(|i| i as f64 * 0.01 + 0.005))
            .chain([0.0, f64::MIN_POSITIVE, 1e-300, 700.0]);
        for x in xs {
            let (ours, libm) = (exp_neg(x), (-x).exp());
            let ulp = libm.next_up() - libm;
            assert!(
                (ours - libm).abs() <= 2.0 * ulp,
                "exp(-{x}): {ours} vs {libm}"
            );
        }
    }

    #[test]
    fn poisson_each_draws_what_poisson_draws() {
        // Frames of 1-40 means (0, tiny, up to past the inversion limit, NaN-free), the same
        // stream through both: the same counts and the same deviates consumed. A difference is
        // possible only within a few ulp of a CDF value (~1e-15 per draw): none expected.
        let mut pick = stream(31, 0, 0);
        let (mut a, mut b) = (stream(31, 1, 0), stream(31, 1, 0));
        let mut draws = 0;
        for frame in 0..20_000 {
            let n = 1 + frame % 40;
            let lambdas: Vec<f64> = (0..n)
                .map(|_| match pick.random_range(0..10) {
                    0 => 0.0,
                    1 => pick.random_range(0.0..1e-3),
                    2 => pick.random_range(30.0..80.0),
                    _ => pick.random_range(0.0..30.0),
                })
                .collect();
            let mut out = vec![0; n];
            poisson_each(&lambdas, &mut a, &mut out);
            let want: Vec<u32> = lambdas.iter().map(|&l| poisson(l, &mut b)).collect();
            assert_eq!(out, want, "frame {frame}: {lambdas:?}");
            draws += n;
        }
        assert_eq!(a.random::<u64>(), b.random::<u64>(), "streams in step");
        assert!(draws > 400_000);
    }

    #[test]
    fn poisson_each_moments() {
        // Mean and variance lambda per lane position; SEs as in poisson_moments_both_regimes.
        let lambdas = [0.3, 2.5, 7.0, 12.0, 29.5, 31.0, 0.0, 4.0, 18.0];
        let n = 100_000;
        let mut rng = stream(33, 0, 0);
        let mut out = vec![0u32; lambdas.len()];
        let mut samples = vec![Vec::with_capacity(n); lambdas.len()];
        for _ in 0..n {
            poisson_each(&lambdas, &mut rng, &mut out);
            for (s, &k) in samples.iter_mut().zip(&out) {
                s.push(k as f64);
            }
        }
        for (&lambda, xs) in lambdas.iter().zip(&samples) {
            let (m, v) = mean_var(xs);
            if lambda == 0.0 {
                assert!(xs.iter().all(|&x| x == 0.0));
                continue;
            }
            assert!(
                (m - lambda).abs() < 4.0 * (lambda / n as f64).sqrt(),
                "{lambda}: {m}"
            );
            let se_v = lambda * ((2.0 + 1.0 / lambda) / n as f64).sqrt();
            assert!((v - lambda).abs() < 4.0 * se_v, "{lambda}: var {v}");
        }
    }

    #[test]
    fn binomial_half_moments() {
        // Binomial(k, 1/2): mean k/2, variance k/4; 4 SE.
        let n = 100_000;
        let mut rng = stream(9, 0, 0);
        for k in [1u32, 7, 64, 65, 300] {
            let xs: Vec<f64> = (0..n).map(|_| binomial_half(k, &mut rng) as f64).collect();
            let (m, v) = mean_var(&xs);
            let var = k as f64 / 4.0;
            assert!((m - k as f64 / 2.0).abs() < 4.0 * (var / n as f64).sqrt());
            assert!((v - var).abs() < 4.0 * var * (2.0 / n as f64).sqrt());
            assert!(xs.iter().all(|x| *x <= k as f64));
        }
    }
}
