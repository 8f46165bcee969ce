//! Order statistics of samples: the median, percentiles with linear interpolation, and the
//! robust sigma (scaled median absolute deviation). Non-finite values are left out.

/// `lo` and `hi` interpolated at fraction `f` of the way: the one formula behind every
/// percentile here, so that [`median`] and [`percentile`] at 50 give the same bits.
fn between(lo: f64, hi: f64, f: f64) -> f64 {
    lo * (1.0 - f) + hi * f
}

/// Median of the finite values, interpolating between the two middle values of an even count
/// (NaN if none). Found by selection in O(n) (frames of millions of pixels, once per frame);
/// the result is bit for bit `percentile(values, 50.0)`.
pub fn median(values: &[f64]) -> f64 {
    let mut v: Vec<f64> = values.iter().copied().filter(|x| x.is_finite()).collect();
    let n = v.len();
    if n == 0 {
        return f64::NAN;
    }
    // percentile_sorted at p = 50: position (n - 1) / 2, between v[i] and v[i + 1].
    let i = (n - 1) / 2;
    let (_, lo, upper) = v.select_nth_unstable_by(i, f64::total_cmp);
    let lo = *lo;
    let Some(hi) = upper.iter().copied().min_by(f64::total_cmp) else {
        return lo;
    };
    between(lo, hi, if n.is_multiple_of(2) { 0.5 } else { 0.0 })
}

/// Percentile `p` (0..100) of the finite values, linear interpolation (NaN if none). Found
/// by selection in O(n); the result is bit for bit `percentile_sorted` of the sorted values.
pub fn percentile(values: &[f64], p: f64) -> f64 {
    let mut v: Vec<f64> = values.iter().copied().filter(|x| x.is_finite()).collect();
    if v.is_empty() {
        return f64::NAN;
    }
    let pos = p / 100.0 * (v.len() - 1) as f64;
    let (i, f) = (pos.floor() as usize, pos.fract());
    let (_, lo, upper) = v.select_nth_unstable_by(i, f64::total_cmp);
    let lo = *lo;
    match upper.iter().copied().min_by(f64::total_cmp) {
        Some(hi) => between(lo, hi, f),
        None => lo,
    }
}

/// Percentile `p` (0..100) of ascending finite values, linear interpolation (NaN if empty).
pub fn percentile_sorted(v: &[f64], p: f64) -> f64 {
    if v.is_empty() {
        return f64::NAN;
    }
    let pos = p / 100.0 * (v.len() - 1) as f64;
    let (i, f) = (pos.floor() as usize, pos.fract());
    if i + 1 < v.len() {
        between(v[i], v[i + 1], f)
    } else {
        v[i]
    }
}

/// An unsigned integer that orders as `v` does by `f64::total_cmp` (a negative value's bits
/// flipped, the sign bit set on the others): sorts of floats as integers.
pub fn total_order_key(v: f64) -> u64 {
    let b = v.to_bits();
    if b >> 63 == 1 {
        !b
    } else {
        b | 1 << 63
    }
}

/// The value whose [`total_order_key`] is `k`.
pub fn from_total_order_key(k: u64) -> f64 {
    f64::from_bits(if k >> 63 == 1 { k & !(1 << 63) } else { !k })
}

/// Values whose order is easy to get wrong (tests): both zeros, subnormals, infinities, the
/// extremes, NaNs of both signs, a repeat.
#[cfg(test)]
pub(crate) const AWKWARD: [f64; 14] = [
    3.5,
    -0.0,
    0.0,
    -1e-310,
    1e-310,
    f64::NAN,
    -f64::NAN,
    -2.0,
    f64::INFINITY,
    -f64::MAX,
    f64::MAX,
    f64::NEG_INFINITY,
    -2.0,
    7.25,
];

/// Robust sigma of the finite values: 1.4826 x the median absolute deviation from the median
/// (the standard deviation for Gaussian values, unmoved by a few outliers).
pub fn robust_sigma(values: &[f64]) -> f64 {
    median_and_robust_sigma(values).1
}

/// The median of the finite values and [`robust_sigma`] about it (NaN if none).
pub fn median_and_robust_sigma(values: &[f64]) -> (f64, f64) {
    let m = median(values);
    let dev: Vec<f64> = values.iter().map(|v| (v - m).abs()).collect();
    (m, 1.4826 * median(&dev))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rng::stream;
    use rand::RngExt;

    #[test]
    fn median_interpolates_and_skips_non_finite_values() {
        assert_eq!(median(&[3.0, 1.0, 2.0]), 2.0);
        assert_eq!(median(&[4.0, 1.0, 3.0, 2.0]), 2.5);
        assert_eq!(median(&[5.0]), 5.0);
        assert_eq!(median(&[1.0, f64::NAN, 7.0, f64::INFINITY]), 4.0);
        assert!(median(&[]).is_nan());
        assert!(median(&[f64::NAN]).is_nan());
    }

    #[test]
    fn median_is_percentile_50_bit_for_bit() {
        let mut rng = stream(3, 0, 0);
        for n in 1..60 {
            let v: Vec<f64> = (0..n)
                .map(|_| (rng.random::<f64>() * 10.0).round() / 3.0 - 1.0)
                .collect();
            assert_eq!(
                median(&v).to_bits(),
                percentile(&v, 50.0).to_bits(),
                "{v:?}"
            );
        }
    }

    #[test]
    fn percentiles_interpolate_linearly() {
        let v = [10.0, 20.0, 30.0, 40.0, 50.0];
        assert_eq!(percentile(&v, 0.0), 10.0);
        assert_eq!(percentile(&v, 100.0), 50.0);
        assert_eq!(percentile(&v, 25.0), 20.0);
        // Position 0.1 x 4 = 0.4: 10 + 0.4 x 10.
        assert!((percentile(&v, 10.0) - 14.0).abs() < 1e-12);
        assert!((percentile_sorted(&v, 90.0) - 46.0).abs() < 1e-12);
        assert!(percentile(&[f64::NAN], 50.0).is_nan());
        assert!(percentile_sorted(&[], 50.0).is_nan());
        // Selection gives the bits of the sorted values' percentile (unordered, repeated).
        let u: Vec<f64> = (0..101)
            .map(|i| ((i * 37) % 101 / 3) as f64 * 0.7)
            .collect();
        let mut sorted = u.clone();
        sorted.sort_by(f64::total_cmp);
        for p in [0.0, 0.3, 1.0, 25.0, 50.0, 63.7, 99.0, 99.9, 100.0] {
            assert_eq!(percentile(&u, p), percentile_sorted(&sorted, p), "p = {p}");
        }
    }

    #[test]
    fn keys_order_as_total_cmp_and_give_the_values_back() {
        let v = AWKWARD;
        for a in v {
            assert_eq!(
                from_total_order_key(total_order_key(a)).to_bits(),
                a.to_bits()
            );
            for b in v {
                assert_eq!(
                    total_order_key(a).cmp(&total_order_key(b)),
                    a.total_cmp(&b),
                    "{a} vs {b}"
                );
            }
        }
    }

    #[test]
    fn robust_sigma_is_the_scaled_mad() {
        // Median 3, absolute deviations 2, 1, 0, 1, 97: MAD 1.
        assert_eq!(robust_sigma(&[1.0, 2.0, 3.0, 4.0, 100.0]), 1.4826);
        // Gaussian values: 1.4826 MAD estimates sigma; its SE is about 1.17 sigma / sqrt(n)
        // (0.37 % at n = 1e5), so 2 % is more than 5 SE.
        let normal = rand_distr::Normal::new(5.0, 2.0).unwrap();
        let mut rng = stream(8, 0, 0);
        let v: Vec<f64> = (0..100_000)
            .map(|_| rand_distr::Distribution::sample(&normal, &mut rng))
            .collect();
        assert!((robust_sigma(&v) / 2.0 - 1.0).abs() < 0.02);
    }
}
