//! Start values of an EM-gain fit: bias from the leftmost dominant peak, read noise from the
//! values below it, gain and light level from the tail (notes 6.2); or gain and light level
//! from the moments when bias and read noise are known.

use super::histogram::ValueHistogram;
use super::model::{excess_noise_factor_sq, law_gain};
use super::options::EmShape;
use super::result::EmStart;
use crate::error::{Error, Result};

/// Fewest pixel-samples for a stable fit.
pub const MIN_SAMPLES: usize = 2_000;
/// Fewest samples above bias + 5 read noise (about 0.6 expected from read noise alone
/// per million samples) for the EM signal to be measurable.
pub const MIN_SIGNAL_SAMPLES: usize = 50;

/// Start values from the histogram (notes 6.2), or an error if there is no EM signal.
pub fn start_values(h: &ValueHistogram) -> Result<EmStart> {
    let n = h.total();
    if (n as usize) < MIN_SAMPLES {
        return Err(Error::Numeric(format!(
            "only {n} pixel-samples: an EM-gain fit needs at least {MIN_SAMPLES} for stable start values and a meaningful histogram"
        )));
    }
    let bias = bias_peak(h);
    let read_noise = read_noise_below(h, bias);
    let threshold = bias + 5.0 * read_noise;
    let above: f64 = h
        .counts()
        .iter()
        .enumerate()
        .filter(|(i, _)| h.centre(*i) > threshold)
        .map(|(_, v)| v)
        .sum();
    if (above as usize) < MIN_SIGNAL_SAMPLES {
        return Err(Error::Numeric(format!(
            "no EM signal above the read noise: {above} of {n} pixel-samples lie above bias + 5 read noise ({bias:.1} + 5 x {read_noise:.2} adu); at least {MIN_SIGNAL_SAMPLES} are needed to measure a gain. Dark frames: use more or brighter frames. Bright frames (no zero-electron peak left): give the bias and read noise from no-signal frames (--offset and --read-noise)"
        )));
    }
    let p0 = (2.0 * h.cdf(bias)).clamp(1e-6, 1.0 - 1e-6);
    let lambda = (-p0.ln()).max(above / n);
    let gain = start_gain(h, bias, read_noise, lambda);
    if !(gain > 0.0 && gain.is_finite()) {
        return Err(Error::Numeric(
            "no EM signal: the mean does not exceed the bias".into(),
        ));
    }
    Ok(EmStart {
        bias_adu: bias,
        read_noise_adu: read_noise,
        gain_adu_per_e: gain,
        lambda_e: lambda,
    })
}

/// The bias (adu): the leftmost peak of the smoothed histogram that dominates +-2 scales
/// around it, the scale from the low tail (its quantile spacing), refined with a parabola
/// through the log of the peak and its neighbours.
fn bias_peak(h: &ValueHistogram) -> f64 {
    let (q4, scale) = h.low_tail();
    let scale = scale.max(h.width());
    let w = h.width();
    let c = h.counts();
    let smooth = smoothed(c, ((scale / 3.0) / w).ceil() as usize);
    let global = smooth.iter().cloned().fold(0.0, f64::max);
    let reach = ((2.0 * scale) / w).ceil() as usize;
    let first = ((q4 / w).round() as i64).saturating_sub(h.start).max(0) as usize;
    let around = sliding_max(&smooth, reach);
    let peak = (first..c.len())
        .find(|&i| smooth[i] >= 0.05 * global && around[i] <= smooth[i])
        .unwrap_or(first.min(c.len() - 1));
    let mut bias = h.centre(peak);
    if peak > 0 && peak + 1 < c.len() {
        let (l, m, r) = (smooth[peak - 1], smooth[peak], smooth[peak + 1]);
        if l > 0.0 && m > 0.0 && r > 0.0 {
            let (l, m, r) = (l.ln(), m.ln(), r.ln());
            let d = l - 2.0 * m + r;
            if d < 0.0 {
                bias += (0.5 * (l - r) / d).clamp(-1.0, 1.0) * w;
            }
        }
    }
    bias
}

/// Moving average of `c` over i-half..=i+half (fewer at the ends), from prefix sums.
fn smoothed(c: &[f64], half: usize) -> Vec<f64> {
    let mut pre = vec![0.0; c.len() + 1];
    for (i, v) in c.iter().enumerate() {
        pre[i + 1] = pre[i] + v;
    }
    (0..c.len())
        .map(|i| {
            let (a, b) = (i.saturating_sub(half), (i + half + 1).min(c.len()));
            (pre[b] - pre[a]) / (b - a) as f64
        })
        .collect()
}

/// Read noise (adu): the rms of the values below `bias`, within 6 of a first, quantile-based
/// estimate (the Gaussian half below the bias holds 0.3173 of its mass beyond 1 sigma), so
/// that a far outlier below the bias does not count; at least the bins' quantisation noise.
fn read_noise_below(h: &ValueHistogram, bias: f64) -> f64 {
    let w = h.width();
    let sigma_q = (bias - h.quantile(0.3173 * h.cdf(bias))).max(w / 12f64.sqrt());
    let (mut s2, mut nb) = (0.0, 0.0);
    for (i, v) in h.counts().iter().enumerate() {
        let d = h.centre(i) - bias;
        if d < 0.0 && d >= -6.0 * sigma_q {
            s2 += v * d * d;
            nb += v;
        }
    }
    // Values on a grid of width w carry w^2/12 of quantisation variance.
    if nb > 0.0 {
        (s2 / nb).sqrt().max(w / 12f64.sqrt())
    } else {
        w
    }
}

/// Start gain (adu per e-). At low light the excess over bias + 6 read noise is exponential
/// of mean G (memorylessness), whose median is G ln 2 (robust to outliers, unlike the
/// mean); at higher light (mean - bias) / lambda, the mean taken within the far limit.
fn start_gain(h: &ValueHistogram, bias: f64, read_noise: f64, lambda: f64) -> f64 {
    let (_, median_excess) = h.tail_above(bias + 6.0 * read_noise);
    if lambda < 0.3 && median_excess > 0.0 {
        median_excess / std::f64::consts::LN_2
    } else {
        let far = far_limit(h, bias, read_noise);
        let (_, mean, _) = h.moments_within(bias - 10.0 * read_noise, far);
        (mean - bias) / lambda
    }
}

/// Running maximum of `v` over i-reach..=i+reach for every i, in O(n) (monotonic deque).
fn sliding_max(v: &[f64], reach: usize) -> Vec<f64> {
    let mut out = vec![0.0; v.len()];
    let mut dq: std::collections::VecDeque<usize> = std::collections::VecDeque::new();
    let mut next = 0;
    for (i, o) in out.iter_mut().enumerate() {
        let hi = (i + reach).min(v.len() - 1);
        while next <= hi {
            while dq.back().is_some_and(|&j| v[j] <= v[next]) {
                dq.pop_back();
            }
            dq.push_back(next);
            next += 1;
        }
        while dq.front().is_some_and(|&j| j + reach < i) {
            dq.pop_front();
        }
        *o = v[*dq.front().expect("window holds i")];
    }
    out
}

/// Upper limit (adu) beyond which values are far outliers, not EM signal: with k values
/// above t = bias + 6 read noise and G the median of their excess / ln 2, the largest of
/// k exponential excesses exceeds G (ln k + 30) with probability below e^-29 (and a
/// compound-Poisson tail at high light has a median excess above G, widening the limit).
pub(super) fn far_limit(h: &ValueHistogram, bias: f64, read_noise: f64) -> f64 {
    let t = bias + 6.0 * read_noise;
    let (k, median_excess) = h.tail_above(t);
    if k < 1.0 || median_excess <= 0.0 {
        return f64::INFINITY;
    }
    t + median_excess / std::f64::consts::LN_2 * (k.ln() + 30.0)
}

/// Start values with bias `b` and read noise `s` (adu) known: gain and lambda from the
/// moments, mean = b + lambda G and var = s^2 + lambda G^2 F^2. Errors if the frames
/// hold no signal beyond the read noise.
pub(super) fn start_from_moments(
    h: &ValueHistogram,
    b: f64,
    s: f64,
    shape: EmShape,
    conv: Option<f64>,
) -> Result<EmStart> {
    let n = h.total();
    if (n as usize) < MIN_SAMPLES {
        return Err(Error::Numeric(format!(
            "only {n} pixel-samples: an EM-gain fit needs at least {MIN_SAMPLES}"
        )));
    }
    let (_, mean, var) = h.moments_within(b - 10.0 * s, far_limit(h, b, s));
    // The mean's SE is sqrt(var/n): the signal must exceed 5 of them, and the excess
    // variance 5 of its SE var sqrt(2/n).
    if mean - b < 5.0 * (var / n).sqrt() || var - s * s < 5.0 * var * (2.0 / n).sqrt() {
        return Err(Error::Numeric(format!(
            "no EM signal above the read noise: mean {mean:.2} adu vs bias {b:.2} adu, variance {var:.2} adu^2 vs read noise^2 {:.2} adu^2",
            s * s
        )));
    }
    let mut g = (var - s * s) / ((mean - b) * 2.0);
    // The register's F^2 depends on the gain itself: two fixed-point steps suffice.
    for _ in 0..2 {
        g = (var - s * s) / ((mean - b) * excess_noise_factor_sq(shape, law_gain(g, conv)));
    }
    Ok(EmStart {
        bias_adu: b,
        read_noise_adu: s,
        gain_adu_per_e: g,
        lambda_e: (mean - b) / g,
    })
}
