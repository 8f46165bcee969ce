//! EMCCD gain from the histogram of dark or low-light frames (SPEC 2.4, notes 6).
//!
//! Model of one pixel value x (adu): x = b + Z/c + N(0, s^2), with Z the EM register
//! output (e-) for Poisson(lambda) input electrons and c the conversion (e- per adu).
//! Fitted by binned maximum likelihood (multinomial, i.e. Poisson with the total fixed)
//! in (b, ln s, ln G, ln lambda), G = g/c the gain in adu per input electron.
//!
//! The bin probabilities are computed exactly from the characteristic function
//!   phi(t) = exp(i t b - s^2 t^2 / 2 + lambda (phi1(t) - 1))
//! (compound Poisson register output, Gaussian read noise), multiplied by the box of a
//! bin and inverted with one FFT. This is the numerical convolution of the Poisson-Gamma
//! (Bessel closed form) with the Gaussian, done in Fourier space where it is a product:
//! no series in n, no Bessel function, and any single-electron law phi1 fits in:
//! `Gamma` (paper Eq. 2: exponential of mean G, phi1 = 1/(1 - i t G)) or the exact
//! `Register` of N stages (pgf iterated N times on e^{i t / c}).

use super::optim::{correlations, hessian, minimise, spd_inverse, INVALID_COST};
use crate::error::{Error, Result};
use rustfft::{num_complex::Complex64, Fft, FftPlanner};
use serde::{Deserialize, Serialize};
use std::sync::Arc;

/// Fewest pixel-samples for a stable fit.
pub const MIN_SAMPLES: usize = 2_000;
/// Fewest samples above bias + 5 read noise (about 0.6 expected from read noise alone
/// per million samples) for the EM signal to be measurable.
pub const MIN_SIGNAL_SAMPLES: usize = 50;
/// Largest FFT used for the model (2^18 points: an 8-fold margin over the grids of real
/// EMCCD histograms, 4096 to 32768 cells).
const MAX_FFT: usize = 1 << 18;
/// Work budget of one fit in model cells evaluated (2^26: a few seconds at most); the
/// limit on cost evaluations is derived from it, between 300 and 1200 (real fits need
/// 220 to 300).
const WORK_CELLS: u64 = 1 << 26;

/// Law of the EM register output for one input electron.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase", tag = "kind")]
pub enum EmShape {
    /// Exponential of mean G (the Erlang/Gamma model of paper Eq. 2; F^2 = 2).
    Gamma,
    /// The exact register of `stages` stages (needs the conversion gain to place the
    /// electron lattice; F^2 = 1 + var1/g^2).
    Register {
        /// Number of multiplication stages.
        stages: u32,
    },
}

/// How to fit.
#[derive(Debug, Clone)]
pub struct EmGainOptions {
    /// Single-electron output law.
    pub shape: EmShape,
    /// Conversion gain (e- per adu); the gain is then reported in e-/e-.
    pub gain_e_per_adu: Option<f64>,
    /// Values above this (adu) are excluded (cosmics, hot pixels). Default: bias + 40 G
    /// (1 + lambda + 5 sqrt(lambda)) from the start values.
    pub max_value_adu: Option<f64>,
    /// Bias (adu) known from no-signal frames: held fixed (with the read noise).
    pub fixed_bias_adu: Option<f64>,
    /// Read noise (adu rms) known from no-signal frames: held fixed (with the bias).
    pub fixed_read_noise_adu: Option<f64>,
    /// Also fit serial clock-induced charge (electrons born inside the register, with
    /// partial gain); needs the exact register shape. Parallel CIC is part of lambda.
    pub serial_cic: bool,
}

impl Default for EmGainOptions {
    fn default() -> Self {
        EmGainOptions {
            shape: EmShape::Gamma,
            gain_e_per_adu: None,
            max_value_adu: None,
            fixed_bias_adu: None,
            fixed_read_noise_adu: None,
            serial_cic: false,
        }
    }
}

/// A histogram of pixel values (adu) on bins of width `width` centred on multiples of it,
/// filled one frame at a time (memory O(range), not O(stack)).
///
/// The bins cover a window of at most [`MAX_HIST_BINS`] bins, placed around the bulk of the
/// first frame (its median) and grown towards later values while it fits; values outside
/// the window are far outliers (a hot pixel, a corrupt sample), only counted. So one wild
/// sample costs neither memory nor time.
#[derive(Debug, Clone)]
pub struct ValueHistogram {
    width: f64,
    start: i64,
    counts: Vec<f64>,
    sum: f64,
    sum2: f64,
    outside: f64,
}

/// Widest value range a histogram may span, in bins (2^22: 32 MiB of counts; 4 Mi adu at
/// the 1 adu bins of integer data, far beyond any camera's range of EM-gain frames).
const MAX_HIST_BINS: i64 = 1 << 22;

impl ValueHistogram {
    /// Empty histogram with bins of `width_adu` (1 for integer data).
    pub fn new(width_adu: f64) -> Self {
        assert!(width_adu > 0.0);
        ValueHistogram {
            width: width_adu,
            start: 0,
            counts: Vec::new(),
            sum: 0.0,
            sum2: 0.0,
            outside: 0.0,
        }
    }

    /// Histogram of `values` (adu).
    pub fn from_values(values: &[f64], width_adu: f64) -> Result<Self> {
        let mut h = Self::new(width_adu);
        h.add_all(values)?;
        Ok(h)
    }

    /// Add values (adu); non-finite values are an error.
    pub fn add_all(&mut self, values: &[f64]) -> Result<()> {
        let (mut lo, mut hi) = (i64::MAX, i64::MIN);
        for v in values {
            if !v.is_finite() {
                return Err(Error::Numeric(format!("non-finite pixel value {v}")));
            }
            if let Some(k) = self.key(*v) {
                lo = lo.min(k);
                hi = hi.max(k);
            }
        }
        if lo > hi {
            // Nothing to bin (no values, or only values beyond any key).
            self.outside += values.len() as f64;
            return Ok(());
        }
        if self.counts.is_empty() {
            self.place_window(values, lo, hi);
        } else {
            self.grow_window(lo, hi);
        }
        let end = self.end();
        for v in values {
            match self.key(*v) {
                Some(k) if k >= self.start && k < end => {
                    self.counts[(k - self.start) as usize] += 1.0;
                    self.sum += v;
                    self.sum2 += v * v;
                }
                _ => self.outside += 1.0,
            }
        }
        Ok(())
    }

    /// Bin key of `v`: its bin index counted from 0 adu; None beyond +-2^61 bins, far
    /// from any window (so that key arithmetic cannot overflow).
    fn key(&self, v: f64) -> Option<i64> {
        let k = (v / self.width + 0.5).floor();
        (k.abs() < (1u64 << 61) as f64).then_some(k as i64)
    }

    /// One past the last key of the window.
    fn end(&self) -> i64 {
        self.start + self.counts.len() as i64
    }

    /// The first window: all of [lo, hi] if it fits, else MAX_HIST_BINS around the median.
    fn place_window(&mut self, values: &[f64], lo: i64, hi: i64) {
        let (start, end) = if hi - lo < MAX_HIST_BINS {
            (lo, hi + 1)
        } else {
            let mut keys: Vec<i64> = values.iter().filter_map(|v| self.key(*v)).collect();
            let mid = keys.len() / 2;
            let median = *keys.select_nth_unstable(mid).1;
            let start = (median - MAX_HIST_BINS / 2).max(lo);
            (start, (start + MAX_HIST_BINS).min(hi + 1))
        };
        self.start = start;
        self.counts = vec![0.0; (end - start) as usize];
    }

    /// Extend the window towards [lo, hi] as far as MAX_HIST_BINS allows.
    fn grow_window(&mut self, lo: i64, hi: i64) {
        let end = self.end();
        let new_start = lo.min(self.start).max(end - MAX_HIST_BINS);
        let new_end = (hi + 1).max(end).min(new_start + MAX_HIST_BINS);
        if new_start < self.start {
            let mut c = vec![0.0; (self.start - new_start) as usize];
            c.extend_from_slice(&self.counts);
            self.counts = c;
            self.start = new_start;
        }
        self.counts.resize((new_end - self.start) as usize, 0.0);
    }

    /// Values that fell outside the histogram's window (far outliers, not in any bin).
    pub fn outside(&self) -> f64 {
        self.outside
    }

    /// Number of values.
    pub fn total(&self) -> f64 {
        self.counts.iter().sum()
    }

    /// Mean and variance of the values (adu, adu^2).
    pub fn mean_var(&self) -> (f64, f64) {
        let n = self.total();
        let m = self.sum / n;
        (m, (self.sum2 / n - m * m) * n / (n - 1.0))
    }

    /// Bin width (adu).
    pub fn width(&self) -> f64 {
        self.width
    }

    /// Centre of bin `i` (adu).
    pub fn centre(&self, i: usize) -> f64 {
        (self.start + i as i64) as f64 * self.width
    }

    /// Counts per bin.
    pub fn counts(&self) -> &[f64] {
        &self.counts
    }

    /// Approximate p-quantile (adu), at bin resolution.
    fn quantile(&self, p: f64) -> f64 {
        let target = p * self.total();
        let mut acc = 0.0;
        for (i, c) in self.counts.iter().enumerate() {
            if acc + c >= target && *c > 0.0 {
                let frac = ((target - acc) / c).clamp(0.0, 1.0);
                return self.centre(i) + (frac - 0.5) * self.width;
            }
            acc += c;
        }
        self.centre(self.counts.len() - 1)
    }

    /// The lower tail of the values: a low quantile and the scale (adu, a Gaussian sigma)
    /// from its spacing to a higher one. The quantiles are 1e-4 and 1e-3 (0.63 sigma apart)
    /// with many values, but at least the 20th and 200th lowest value, so that a few far
    /// outliers below the bias move neither.
    fn low_tail(&self) -> (f64, f64) {
        let n = self.total().max(1.0);
        let p_lo = (1e-4f64).max(20.0 / n).min(0.05);
        let p_hi = (10.0 * p_lo).min(0.5);
        let z = |p: f64| -> f64 {
            -std::f64::consts::SQRT_2 * statrs::function::erf::erfc_inv(2.0 * p)
        };
        let (q_lo, q_hi) = (self.quantile(p_lo), self.quantile(p_hi));
        (q_lo, (q_hi - q_lo) / (z(p_hi) - z(p_lo)))
    }

    /// Count, mean and variance (adu, adu^2) of the binned values whose bins lie within
    /// [lo, hi] adu: the moments with far outliers trimmed.
    fn moments_within(&self, lo: f64, hi: f64) -> (f64, f64, f64) {
        let (mut n, mut s, mut s2) = (0.0, 0.0, 0.0);
        for (i, c) in self.counts.iter().enumerate() {
            let x = self.centre(i);
            if *c > 0.0 && x >= lo && x <= hi {
                n += c;
                s += c * x;
                s2 += c * x * x;
            }
        }
        let m = s / n;
        (n, m, (s2 / n - m * m) * n / (n - 1.0))
    }

    /// Number of values above `t` (adu) and the median of their excess over `t`.
    fn tail_above(&self, t: f64) -> (f64, f64) {
        let above: Vec<(f64, f64)> = self
            .counts
            .iter()
            .enumerate()
            .filter(|(i, c)| **c > 0.0 && self.centre(*i) > t)
            .map(|(i, c)| (self.centre(i) - t, *c))
            .collect();
        let k: f64 = above.iter().map(|a| a.1).sum();
        let mut acc = 0.0;
        let median = above
            .iter()
            .find(|(_, c)| {
                acc += c;
                acc >= 0.5 * k
            })
            .map_or(0.0, |a| a.0);
        (k, median)
    }

    /// Fraction of values below `x` (adu), interpolating within the bin.
    fn cdf(&self, x: f64) -> f64 {
        let mut acc = 0.0;
        for (i, c) in self.counts.iter().enumerate() {
            let a = self.centre(i) - 0.5 * self.width;
            if x < a {
                break;
            }
            acc += c * ((x - a) / self.width).min(1.0);
        }
        acc / self.total()
    }
}

/// Start values of the fit (notes 6.2).
#[derive(Debug, Clone, Copy, Serialize, Deserialize)]
pub struct EmStart {
    /// Bias: leftmost significant peak of the smoothed histogram (adu).
    pub bias_adu: f64,
    /// Read noise: rms of the values below the bias (adu).
    pub read_noise_adu: f64,
    /// Gain: mean excess over bias + 6 read noise (tail memorylessness) at low light,
    /// else (mean - bias) / lambda (adu per e-).
    pub gain_adu_per_e: f64,
    /// Mean input electrons from the fraction below the bias: -ln(2 P(x < b)).
    pub lambda_e: f64,
}

/// Cross-check routes to the gain, beside the histogram fit.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct EmCrossChecks {
    /// Excess noise factor squared used (2 for the Gamma model).
    pub excess_noise_factor_sq: f64,
    /// (variance - read noise^2) / ((mean - bias) F^2): photon transfer with the ENF (adu/e-).
    pub mean_variance_gain_adu_per_e: f64,
    /// The same ignoring the excess noise factor (what a naive photon transfer gives).
    pub mean_variance_gain_no_enf_adu_per_e: f64,
    /// Mean signal above bias (adu) and variance (adu^2) of the fitted values.
    pub mean_signal_adu: f64,
    /// Variance of the fitted values (adu^2).
    pub variance_adu2: f64,
}

/// The result of an EM-gain fit: the content of `emgain.json`.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct EmGainFit {
    /// EM gain in `em_gain_units`.
    pub em_gain: f64,
    /// Its standard error.
    pub em_gain_se: f64,
    /// "e-/e-" (output electrons per input electron, conversion gain given) or "adu/e-".
    pub em_gain_units: String,
    /// Gain in adu per input electron (G = g / conversion).
    pub gain_adu_per_e: f64,
    /// Its standard error (adu/e-).
    pub gain_adu_per_e_se: f64,
    /// Bias (adu).
    pub bias_adu: f64,
    /// Its standard error (adu).
    pub bias_adu_se: f64,
    /// Read noise (adu rms).
    pub read_noise_adu: f64,
    /// Its standard error (adu).
    pub read_noise_adu_se: f64,
    /// Read noise referred to the input (e- rms) = read noise / G.
    pub read_noise_input_e: f64,
    /// Mean input electrons per pixel-sample (photo + dark + parallel CIC).
    pub lambda_e: f64,
    /// Its standard error.
    pub lambda_e_se: f64,
    /// Serial CIC electrons per pixel-sample (born inside the register), if fitted.
    pub serial_cic_e: Option<f64>,
    /// Its standard error.
    pub serial_cic_e_se: Option<f64>,
    /// The conversion gain used (e- per adu), if given.
    pub gain_e_per_adu: Option<f64>,
    /// Single-electron law of the model.
    pub shape: EmShape,
    /// Whether Nelder-Mead converged (always true: a failed fit is an error).
    pub converged: bool,
    /// Nelder-Mead iterations.
    pub iterations: u64,
    /// Maximised multinomial log-likelihood of the binned values.
    pub log_likelihood: f64,
    /// Pixel-samples fitted.
    pub n_samples: f64,
    /// Pixel-samples excluded (above `max_value_adu`).
    pub n_excluded: f64,
    /// Upper limit of the fitted values (adu).
    pub max_value_adu: f64,
    /// Width of the fitted bins (adu).
    pub bin_width_adu: f64,
    /// Correlations of the free parameters among (bias, ln read noise, ln G, ln lambda,
    /// ln serial CIC), in that order.
    pub correlations: Option<Vec<Vec<f64>>>,
    /// Start values.
    pub start: EmStart,
    /// Other routes to the gain.
    pub cross_checks: EmCrossChecks,
}

/// The ratio-of-means route: EM gain (e-/e-) from the mean signal above bias at gain and
/// at unity EM gain under the same light (both adu).
pub fn gain_from_mean_ratio(signal_adu: f64, reference_signal_adu: f64) -> f64 {
    signal_adu / reference_signal_adu
}

/// Start values from the histogram (notes 6.2), or an error if there is no EM signal.
pub fn start_values(h: &ValueHistogram) -> Result<EmStart> {
    let n = h.total();
    if (n as usize) < MIN_SAMPLES {
        return Err(Error::Numeric(format!(
            "only {n} pixel-samples: an EM-gain fit needs at least {MIN_SAMPLES} for stable start values and a meaningful histogram"
        )));
    }
    // A scale from the low tail (its quantile spacing) sets the smoothing; the bias is the
    // leftmost peak that dominates +-2 scales around it.
    let (q4, scale) = h.low_tail();
    let scale = scale.max(h.width());
    let w = h.width();
    let half = ((scale / 3.0) / w).ceil() as usize;
    let c = h.counts();
    let mut pre = vec![0.0; c.len() + 1];
    for (i, v) in c.iter().enumerate() {
        pre[i + 1] = pre[i] + v;
    }
    let smooth: Vec<f64> = (0..c.len())
        .map(|i| {
            let (a, b) = (i.saturating_sub(half), (i + half + 1).min(c.len()));
            (pre[b] - pre[a]) / (b - a) as f64
        })
        .collect();
    let global = smooth.iter().cloned().fold(0.0, f64::max);
    let reach = ((2.0 * scale) / w).ceil() as usize;
    let first = ((q4 / w).round() as i64).saturating_sub(h.start).max(0) as usize;
    let around = sliding_max(&smooth, reach);
    let peak = (first..c.len())
        .find(|&i| smooth[i] >= 0.05 * global && around[i] <= smooth[i])
        .unwrap_or(first.min(c.len() - 1));
    // Refine with a parabola through the log of the smoothed peak and its neighbours.
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
    // Read noise: rms of the values below the bias, within 6 of a first, quantile-based
    // estimate (the Gaussian half below the bias holds 0.3173 of its mass beyond 1 sigma),
    // so that a far outlier below the bias does not count.
    let sigma_q = (bias - h.quantile(0.3173 * h.cdf(bias))).max(w / 12f64.sqrt());
    let (mut s2, mut nb) = (0.0, 0.0);
    for (i, v) in c.iter().enumerate() {
        let d = h.centre(i) - bias;
        if d < 0.0 && d >= -6.0 * sigma_q {
            s2 += v * d * d;
            nb += v;
        }
    }
    // Values on a grid of width w carry w^2/12 of quantisation variance.
    let read_noise = if nb > 0.0 {
        (s2 / nb).sqrt().max(w / 12f64.sqrt())
    } else {
        w
    };
    let threshold = bias + 5.0 * read_noise;
    let above: f64 = c
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
    // Gain at low light: the excess over bias + 6 read noise is exponential of mean G
    // (memorylessness), whose median is G ln 2 (robust to outliers, unlike the mean).
    // At higher light: (mean - bias) / lambda, the mean taken within the far limit.
    let (_, median_excess) = h.tail_above(bias + 6.0 * read_noise);
    let gain = if lambda < 0.3 && median_excess > 0.0 {
        median_excess / std::f64::consts::LN_2
    } else {
        let far = far_limit(h, bias, read_noise);
        let (_, mean, _) = h.moments_within(bias - 10.0 * read_noise, far);
        (mean - bias) / lambda
    };
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
fn far_limit(h: &ValueHistogram, bias: f64, read_noise: f64) -> f64 {
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
fn start_from_moments(
    h: &ValueHistogram,
    b: f64,
    s: f64,
    shape: EmShape,
    conv: f64,
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
        g = (var - s * s) / ((mean - b) * excess_noise_factor_sq(shape, g * conv));
    }
    Ok(EmStart {
        bias_adu: b,
        read_noise_adu: s,
        gain_adu_per_e: g,
        lambda_e: (mean - b) / g,
    })
}

/// The exact bin probabilities of the model on a fine periodic grid.
struct Model {
    shape: EmShape,
    conv: f64,
    /// Lower edge of the grid (adu).
    x0: f64,
    /// Fine cell width (adu).
    h: f64,
    fft: Arc<dyn Fft<f64>>,
    m: usize,
}

impl Model {
    /// Fine cell probabilities for (b, s, G, lambda) and a rate `cic` of serial CIC
    /// electrons (born at a uniformly random stage, register model only), or `None`
    /// outside the domain.
    fn cells(&self, b: f64, s: f64, g: f64, lambda: f64, cic: f64) -> Option<Vec<f64>> {
        let m = self.m;
        let period = m as f64 * self.h;
        let reg = match self.shape {
            EmShape::Register { stages } => {
                let ge = g * self.conv;
                if ge < 1.0 {
                    return None;
                }
                Some((ge.powf(1.0 / stages as f64) - 1.0, stages))
            }
            EmShape::Gamma => None,
        };
        let mut a = vec![Complex64::new(0.0, 0.0); m];
        // Frequencies beyond 9/s carry < e^-40 of the Gaussian factor: left at zero.
        let kmax = ((9.0 / s) * period / (2.0 * std::f64::consts::PI)).ceil() as usize;
        let kmax = kmax.min(m / 2 - 1);
        for k in 0..=kmax {
            let t = 2.0 * std::f64::consts::PI * k as f64 / period;
            // phi1: one input electron through the whole register; phis: one electron
            // born at stage k = 1..N (uniform), which passes the N - k stages after it.
            let (phi1, phis) = match reg {
                None => (
                    Complex64::new(1.0, 0.0) / Complex64::new(1.0, -t * g),
                    Complex64::new(1.0, 0.0),
                ),
                Some((p, stages)) => {
                    let z = Complex64::from_polar(1.0, t / self.conv);
                    let mut v = z;
                    let mut partial = Complex64::new(0.0, 0.0);
                    for _ in 0..stages {
                        partial += v;
                        v *= (1.0 - p) + p * v;
                    }
                    (v, partial / stages as f64)
                }
            };
            let x = t * (self.h * 0.5);
            let sinc = if x == 0.0 { 1.0 } else { x.sin() / x };
            let log_phi = Complex64::new(-0.5 * s * s * t * t, t * (b - self.x0 - 0.5 * self.h))
                + lambda * (phi1 - 1.0)
                + cic * (phis - 1.0);
            let v = log_phi.exp() * sinc;
            a[k] = v;
            if k > 0 {
                a[m - k] = v.conj();
            }
        }
        self.fft.process(&mut a);
        Some(a.iter().map(|v| v.re / m as f64).collect())
    }
}

/// The binned data and the model grid of one fit.
struct Problem {
    model: Model,
    /// Fine cells per data bin.
    per_bin: usize,
    /// Data counts per fitted bin, starting at fine cell 0.
    counts: Vec<f64>,
    n: f64,
    /// Samples outside the fitted range.
    excluded: f64,
    bias0: f64,
    s0: f64,
    guard_gain: f64,
    /// Internal coordinates of the parameters that are not free.
    base: [f64; 5],
    /// Indices (into bias, ln s, ln G, ln lambda) of the free parameters.
    free: Vec<usize>,
}

impl Problem {
    /// Natural parameters (b, s, G, lambda, serial CIC) from the free internal coordinates `u`.
    fn params(&self, u: &[f64]) -> [f64; 5] {
        let mut v = self.base;
        for (k, i) in self.free.iter().enumerate() {
            v[*i] = u[k];
        }
        [
            self.bias0 + v[0] * self.s0,
            v[1].exp(),
            v[2].exp(),
            v[3].exp(),
            v[4].exp(),
        ]
    }

    /// Internal coordinates of all natural parameters `p` (a zero CIC rate maps to -inf,
    /// which `params` maps back to 0 while the rate is not free).
    fn internal(&self, p: &[f64; 5]) -> [f64; 5] {
        [
            (p[0] - self.bias0) / self.s0,
            p[1].ln(),
            p[2].ln(),
            p[3].ln(),
            p[4].ln(),
        ]
    }

    /// Probabilities of the fitted bins, normalised over the fitted range.
    fn bin_probs(&self, p: &[f64; 5]) -> Option<Vec<f64>> {
        let [b, s, g, lambda, cic] = *p;
        // The model is valid while the fine cells resolve the Gaussian and the EM tail
        // does not wrap around the period.
        if s < 2.5 * self.model.h || g > self.guard_gain || lambda > 1e5 {
            return None;
        }
        let cells = self.model.cells(b, s, g, lambda, cic)?;
        let probs: Vec<f64> = cells
            .chunks(self.per_bin)
            .take(self.counts.len())
            .map(|c| c.iter().sum::<f64>().max(0.0))
            .collect();
        let total: f64 = probs.iter().sum();
        (total > 0.0).then(|| probs.into_iter().map(|q| q / total).collect())
    }

    /// Negative log-likelihood per sample.
    fn nll(&self, u: &[f64]) -> f64 {
        let Some(probs) = self.bin_probs(&self.params(u)) else {
            return INVALID_COST;
        };
        let mut s = 0.0;
        for (c, q) in self.counts.iter().zip(&probs) {
            if *c > 0.0 {
                s -= c * q.max(1e-300).ln();
            }
        }
        s / self.n
    }
}

/// Binning of one fit: fitted bins of width `w` (a multiple of the histogram's) from `lo`
/// to `cut` (adu), fine model cells of `h`.
struct Layout {
    lo: f64,
    cut: f64,
    w: f64,
    per_bin: usize,
    hfine: f64,
}

impl Layout {
    /// Bins at most `s_min`/2 wide; fine cells at most `s_min`/4.5 so that the Gaussian
    /// factor vanishes at the grid's Nyquist frequency; from 10 `sq` below `q4`.
    fn new(h: &ValueHistogram, s_min: f64, sq: f64, q4: f64, cut: f64) -> Self {
        let w0 = h.width();
        let data_lo = h.centre(0) - 0.5 * w0;
        let merge = ((0.5 * s_min / w0).floor() as usize).max(1);
        let w = merge as f64 * w0;
        let per_bin = ((4.5 * w / s_min).ceil() as usize).max(1);
        // From 10 read noises below the 1e-4 quantile (lower values are far outliers),
        // aligned with the histogram's bins.
        let lo = data_lo + ((q4 - 10.0 * sq - data_lo) / w).floor() * w;
        Layout {
            lo,
            cut,
            w,
            per_bin,
            hfine: w / per_bin as f64,
        }
    }

    /// The fit problem with a model period reaching `pad` adu beyond the cut.
    fn problem(&self, h: &ValueHistogram, shape: EmShape, conv: f64, pad: f64) -> Result<Problem> {
        // Sizes are checked before anything is allocated from them.
        let span = self.cut - self.lo + pad;
        let cells = (span / self.hfine).ceil();
        if cells.is_nan() || cells > MAX_FFT as f64 {
            return Err(Error::Numeric(format!(
                "the value range ({span:.0} adu) is too wide for model cells of {:.3} adu (set by the read noise): more than {MAX_FFT} cells, where real EMCCD histograms need at most 32768; if these are EMCCD frames, lower --max-value-adu or widen --bin-width-adu",
                self.hfine
            )));
        }
        let m = (cells as usize).max(2).next_power_of_two();
        let n_bins = ((self.cut - self.lo) / self.w).ceil().max(0.0) as usize;
        let mut counts = vec![0.0; n_bins];
        let mut excluded = 0.0;
        for (i, v) in h.counts().iter().enumerate() {
            let j = ((h.centre(i) - self.lo) / self.w).floor();
            if j >= 0.0 && (j as usize) < n_bins {
                counts[j as usize] += v;
            } else {
                excluded += v;
            }
        }
        let n: f64 = counts.iter().sum();
        Ok(Problem {
            model: Model {
                shape,
                conv,
                x0: self.lo,
                h: self.hfine,
                fft: FftPlanner::new().plan_fft_forward(m),
                m,
            },
            per_bin: self.per_bin,
            counts,
            n,
            excluded,
            bias0: 0.0,
            s0: 1.0,
            base: [0.0, 0.0, 0.0, 0.0, f64::NEG_INFINITY],
            free: vec![0, 1, 2, 3],
            guard_gain: (m as f64 * self.hfine - (self.cut - self.lo)) / 25.0,
        })
    }
}

/// [`fit_emgain`] of the histogram of `stack`'s values: a failure names its first file.
pub fn fit_emgain_of_stack(
    stack: &crate::io::FrameStack,
    h: &ValueHistogram,
    opts: &EmGainOptions,
) -> Result<EmGainFit> {
    fit_emgain(h, opts).map_err(|e| crate::io::name_file(&stack.sources[0].path, e))
}

/// Fit bias, read noise, gain and lambda to a histogram of EMCCD pixel values (adu).
pub fn fit_emgain(h: &ValueHistogram, opts: &EmGainOptions) -> Result<EmGainFit> {
    if let Some(c) = opts.gain_e_per_adu {
        if !(c > 0.0 && c.is_finite()) {
            return Err(Error::invalid(
                "--gain-e-per-adu",
                "must be a positive number",
            ));
        }
    }
    let conv = match (opts.shape, opts.gain_e_per_adu) {
        (EmShape::Register { .. }, None) => {
            return Err(Error::invalid(
                "--stages",
                "the exact register model needs the conversion gain (--gain-e-per-adu)",
            ))
        }
        (_, c) => c.unwrap_or(1.0),
    };
    let n = h.total();
    let all = n + h.outside();
    if h.outside() > 0.01 * all {
        return Err(Error::Numeric(format!(
            "{} of {all} pixel values fall outside the histogram's window of {MAX_HIST_BINS} bins ({} adu) around the bulk of the values: spread far wider than the values of EMCCD frames (check the files, or widen --bin-width-adu)",
            h.outside(),
            MAX_HIST_BINS as f64 * h.width()
        )));
    }
    if (n as usize) < MIN_SAMPLES {
        return Err(Error::Numeric(format!(
            "only {n} pixel-samples: an EM-gain fit needs at least {MIN_SAMPLES} for stable start values and a meaningful histogram"
        )));
    }
    let w0 = h.width();
    let c = h.counts();
    let ((q4, sq), q50) = (h.low_tail(), h.quantile(0.5));
    let sq = sq.max(w0 / 12f64.sqrt());
    if opts.serial_cic && opts.shape == EmShape::Gamma {
        return Err(Error::invalid(
            "--serial-cic",
            "serial CIC has partial gain, modelled only with the exact register (--stages)",
        ));
    }
    let st =
        match (opts.fixed_bias_adu, opts.fixed_read_noise_adu) {
            (Some(b), Some(s)) if !(b.is_finite() && s.is_finite() && s > 0.0) => return Err(Error::invalid(
                "--offset/--read-noise",
                format!("the maps give a bias of {b} adu and a read noise of {s} adu: both must be finite, the read noise > 0"),
            )),
            (Some(b), Some(s)) => start_from_moments(h, b, s, opts.shape, conv)?,
            (None, None) => start_values(h)?,
            _ => return Err(Error::invalid(
                "--offset/--read-noise",
                "bias and read noise are fixed together (both from no-signal frames) or not at all",
            )),
        };
    let fixed = opts.fixed_bias_adu.is_some();
    let (l0, g0) = (st.lambda_e, st.gain_adu_per_e);
    // Far outliers (beyond the EM tail, or 10 read noises below the lowest quantile) are
    // left out of the moments and of the fitted range.
    let far = far_limit(h, st.bias_adu, st.read_noise_adu);
    let data_hi = (h.centre(c.len() - 1) + 0.5 * w0).min(far);
    let (_, mean, var) = h.moments_within(q4 - 10.0 * sq, far);
    let cut = opts
        .max_value_adu
        .unwrap_or(st.bias_adu + 40.0 * g0 * (1.0 + l0 + 5.0 * l0.sqrt()))
        .min(data_hi);
    // Candidate starts: the peak-based values, and a grid of biases between the lowest
    // values and the median with read noises from the spacing of the lowest quantiles
    // (where the bias peak drowns in the EM signal, e.g. low gain at high light), each
    // with gain and lambda from the moments: mean = b + lambda G,
    // var = s^2 + lambda G^2 F^2.
    let f2 = excess_noise_factor_sq(opts.shape, g0 * conv);
    let mut cands = vec![[st.bias_adu, st.read_noise_adu, g0, l0, 0.0]];
    for s in [st.read_noise_adu, 0.6 * sq, sq] {
        for k in 0..=24 {
            let b = q4 + (q50 - q4) * k as f64 / 24.0;
            let g = (var - s * s) / ((mean - b) * f2);
            let l = (mean - b) / g;
            if !fixed && g > 0.0 && l > 0.0 && g.is_finite() && l.is_finite() {
                cands.push([b, s, g, l, 0.0]);
            }
        }
    }
    let s_min = cands
        .iter()
        .map(|c| c[1])
        .fold(f64::INFINITY, f64::min)
        .min(sq);
    let g_max = cands.iter().map(|c| c[2]).fold(0.0, f64::max).min(4.0 * g0);
    let grid = Layout::new(h, s_min, sq, q4, cut);
    let mut problem = grid.problem(h, opts.shape, conv, (10.0 * sq).max(25.0 * g_max))?;
    let best = cands
        .iter()
        .map(|p| (problem.nll(&problem.internal(p)), *p))
        .min_by(|a, b| a.0.total_cmp(&b.0))
        .expect("at least one candidate");
    if best.0 >= INVALID_COST {
        return Err(Error::Numeric(
            "EM-gain fit: no start value gives a valid model (read noise below the bin resolution?)".into(),
        ));
    }
    // The period must hold the EM tail of any gain the optimiser may try (25 scale
    // lengths: wrapped mass < 1e-10): up to 3x the best start.
    problem = grid.problem(h, opts.shape, conv, (10.0 * sq).max(75.0 * best.1[2]))?;
    problem.bias0 = best.1[0];
    problem.s0 = best.1[1];
    problem.base = problem.internal(&best.1);
    if fixed {
        problem.free = vec![2, 3];
    }
    if opts.serial_cic {
        // Start the rate at a tenth of the light: the Nelder-Mead steps find the scale.
        problem.base[4] = (0.1 * best.1[3]).max(1e-4).ln();
        problem.free.push(4);
    }
    let (n, w, lo, cut, excluded) = (problem.n, grid.w, grid.lo, grid.cut, problem.excluded);
    let s0 = problem.s0;
    let u0: Vec<f64> = problem.free.iter().map(|i| problem.base[*i]).collect();
    let steps = [0.3, 0.1, 0.2, 0.2, 1.0];
    let step: Vec<f64> = problem.free.iter().map(|i| steps[*i]).collect();
    let cost = |u: &[f64]| problem.nll(u);
    // Stop when the simplex spans 1e-4 in total log-likelihood.
    let tol = 1e-4 / n;
    // Bounded work: at most WORK_CELLS model cells in all (one FFT of m cells per cost,
    // the exact register costing more per cell); past the budget every cost is invalid,
    // which ends Nelder-Mead at once, and the fit is refused.
    let m = problem.model.m;
    let weight = match opts.shape {
        EmShape::Gamma => 1,
        EmShape::Register { stages } => 1 + u64::from(stages) / 64,
    };
    let max_evals = (WORK_CELLS / (m as u64 * weight)).clamp(300, 1200);
    let evals = std::cell::Cell::new(0u64);
    let capped = |u: &[f64]| {
        evals.set(evals.get() + 1);
        if evals.get() > max_evals {
            INVALID_COST
        } else {
            problem.nll(u)
        }
    };
    let fit = minimise(capped, &u0, &step, tol, 20_000, "EM-gain fit");
    if evals.get() > max_evals {
        return Err(Error::Numeric(format!(
            "EM-gain fit: not converged after {max_evals} model evaluations on a grid of {m} cells (real EMCCD histograms, a Gaussian zero-electron peak and an exponential EM tail, converge in 220 to 300): these frames do not look like EMCCD darks or low-light frames (check the files, or give --max-value-adu to leave out what is not EM signal)"
        )));
    }
    let fit = fit?;
    let p = problem.params(&fit.x);
    let hm: Vec<Vec<f64>> = hessian(cost, &fit.x, &vec![1e-3; u0.len()])
        .into_iter()
        .map(|r| r.into_iter().map(|v| v * n).collect())
        .collect();
    let cov = spd_inverse(&hm).ok_or_else(|| {
        Error::Numeric(
            "EM-gain fit: the likelihood is flat in some direction at the optimum (Hessian not positive definite): the data do not constrain gain and light level separately".into(),
        )
    })?;
    // Fixed parameters have no standard error here (0): theirs is the no-signal frames'.
    let mut se = [0.0; 5];
    for (k, i) in problem.free.iter().enumerate() {
        let scale = if *i == 0 { s0 } else { p[*i] };
        se[*i] = cov[k][k].sqrt() * scale;
    }
    let f2 = excess_noise_factor_sq(opts.shape, p[2] * conv);
    let (mean, var) = fitted_moments(&problem, lo, w);
    let signal = mean - p[0];
    let (em_gain, em_gain_se, units) = match opts.gain_e_per_adu {
        Some(c) => (p[2] * c, se[2] * c, "e-/e-"),
        None => (p[2], se[2], "adu/e-"),
    };
    Ok(EmGainFit {
        em_gain,
        em_gain_se,
        em_gain_units: units.into(),
        gain_adu_per_e: p[2],
        gain_adu_per_e_se: se[2],
        bias_adu: p[0],
        bias_adu_se: se[0],
        read_noise_adu: p[1],
        read_noise_adu_se: se[1],
        read_noise_input_e: p[1] / p[2],
        lambda_e: p[3],
        lambda_e_se: se[3],
        serial_cic_e: opts.serial_cic.then_some(p[4]),
        serial_cic_e_se: opts.serial_cic.then_some(se[4]),
        gain_e_per_adu: opts.gain_e_per_adu,
        shape: opts.shape,
        converged: true,
        iterations: fit.iterations,
        log_likelihood: -fit.cost * n,
        n_samples: n,
        n_excluded: excluded + h.outside(),
        max_value_adu: cut,
        bin_width_adu: w,
        correlations: Some(correlations(&cov)),
        start: st,
        cross_checks: EmCrossChecks {
            excess_noise_factor_sq: f2,
            mean_variance_gain_adu_per_e: (var - p[1] * p[1]) / (signal * f2),
            mean_variance_gain_no_enf_adu_per_e: (var - p[1] * p[1]) / signal,
            mean_signal_adu: signal,
            variance_adu2: var,
        },
    })
}

/// Mean and variance (adu) of the fitted (not excluded) values, from their bins, with the
/// bin quantisation variance w^2/12 removed.
fn fitted_moments(p: &Problem, lo: f64, w: f64) -> (f64, f64) {
    let (mut s, mut s2) = (0.0, 0.0);
    for (i, c) in p.counts.iter().enumerate() {
        let x = lo + (i as f64 + 0.5) * w;
        s += c * x;
        s2 += c * x * x;
    }
    let m = s / p.n;
    (m, s2 / p.n - m * m - w * w / 12.0)
}

/// Excess noise factor squared of the single-electron law at gain `g_e` (e-/e-).
pub fn excess_noise_factor_sq(shape: EmShape, g_e: f64) -> f64 {
    match shape {
        EmShape::Gamma => 2.0,
        EmShape::Register { stages } => {
            let p = g_e.max(1.0).powf(1.0 / stages as f64) - 1.0;
            let m = 1.0 + p;
            let n = stages as i32;
            1.0 + (1.0 - p) * m.powi(n - 1) * (m.powi(n) - 1.0) / (g_e * g_e)
        }
    }
}

/// One bin of the chart of a fit: data and model counts (pixel-samples).
#[derive(Debug, Clone, Copy)]
pub struct CurveBin {
    /// Bin centre (adu).
    pub x_adu: f64,
    /// Observed pixel-samples.
    pub data: f64,
    /// Expected pixel-samples of the fitted model.
    pub model: f64,
    /// Expected pixel-samples with no input electron (bias + read noise only).
    pub zero_electron: f64,
}

/// The data and the fitted model on at most `max_bins` bins (whole histogram bins merged)
/// up to the fit's upper limit, with the zero-electron component.
pub fn model_curve(h: &ValueHistogram, fit: &EmGainFit, max_bins: usize) -> Vec<CurveBin> {
    let (b, s, g, l) = (
        fit.bias_adu,
        fit.read_noise_adu,
        fit.gain_adu_per_e,
        fit.lambda_e,
    );
    let w = h.width();
    // From 10 read noises below the bias (lower values are far outliers) to the cut.
    let first = h
        .counts()
        .iter()
        .enumerate()
        .position(|(i, _)| h.centre(i) >= b - 10.0 * s)
        .unwrap_or(0);
    let counts = &h.counts()[first..];
    let used = (0..counts.len())
        .take_while(|i| h.centre(first + i) <= fit.max_value_adu)
        .count()
        .max(1)
        .min(counts.len());
    let group = used.div_ceil(max_bins.max(1));
    let lo = h.centre(first) - 0.5 * w;
    let per_bin = ((4.5 * w / s).ceil() as usize).clamp(1, 1024);
    let hfine = w / per_bin as f64;
    let span = used as f64 * w + (10.0 * s).max(100.0 * g);
    let m = ((span / hfine).ceil().min(MAX_FFT as f64) as usize)
        .max(2)
        .next_power_of_two();
    let model = Model {
        shape: fit.shape,
        conv: fit.gain_e_per_adu.unwrap_or(1.0),
        x0: lo,
        h: hfine,
        fft: FftPlanner::new().plan_fft_forward(m),
        m,
    };
    let zeros = vec![0.0; m];
    let cic = fit.serial_cic_e.unwrap_or(0.0);
    let total = model
        .cells(b, s, g, l, cic)
        .unwrap_or_else(|| zeros.clone());
    // No input and no serial-CIC electron: the bias peak alone.
    let gauss = model.cells(b, s, g, 0.0, 0.0).unwrap_or(zeros);
    let n = fit.n_samples;
    let sum = |v: &[f64], i0: usize, i1: usize| -> f64 {
        v.get(i0 * per_bin..(i1 * per_bin).min(v.len()))
            .map_or(0.0, |c| c.iter().sum())
    };
    (0..used)
        .step_by(group)
        .map(|i0| {
            let i1 = (i0 + group).min(used);
            CurveBin {
                x_adu: lo + 0.5 * (i0 + i1) as f64 * w,
                data: counts[i0..i1].iter().sum(),
                model: n * sum(&total, i0, i1),
                zero_electron: n * (-l - cic).exp() * sum(&gauss, i0, i1),
            }
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::detector::EmRegister;
    use crate::rng::stream;
    use crate::stats::poisson;
    use rand_distr::{Distribution, Normal};

    /// Integer-rounded values (adu) of an EMCCD: bias 1000 adu, Poisson(lambda) input,
    /// exact register of `stages`, read noise `sigma_e` (e-), conversion `c` e-/adu.
    fn synth(n: usize, g: f64, lambda: f64, sigma_e: f64, c: f64, seed: u64) -> Vec<f64> {
        let reg = EmRegister::new(g, 512).unwrap();
        let noise = Normal::new(0.0, sigma_e).unwrap();
        let mut rng = stream(seed, 0, 0);
        (0..n)
            .map(|_| {
                let k = poisson(lambda, &mut rng) as u64;
                let e = reg.sample(k, &mut rng) + noise.sample(&mut rng);
                (1000.0 + e / c).round()
            })
            .collect()
    }

    #[test]
    fn recovers_gain_and_read_noise_of_exact_register() {
        // 400k samples: the gain's relative SE is about sqrt(2/(N lambda)) at low light
        // (0.5 % at lambda = 0.05) and smaller at high light; 2 % is the tolerance,
        // > 4 SE everywhere. Read noise: SE ~ 1/sqrt(2 N e^-lambda) (0.1 % to 1.3 %).
        let opts = EmGainOptions {
            shape: EmShape::Register { stages: 512 },
            gain_e_per_adu: Some(1.0),
            ..Default::default()
        };
        let mut bad = vec![];
        for (i, (g, lambda)) in [
            (5.0f64, 0.05f64),
            (5.0, 5.0),
            (50.0, 0.05),
            (50.0, 1.0),
            (300.0, 0.2),
            (300.0, 5.0),
            (1000.0, 0.05),
            (1000.0, 2.0),
        ]
        .into_iter()
        .enumerate()
        {
            let sigma: f64 = (0.2 * g).min(50.0);
            let v = synth(400_000, g, lambda, sigma, 1.0, i as u64);
            let h = ValueHistogram::from_values(&v, 1.0).unwrap();
            let t = std::time::Instant::now();
            let f = fit_emgain(&h, &opts).unwrap();
            let (eg, es) = (f.em_gain / g - 1.0, f.read_noise_adu / sigma - 1.0);
            eprintln!(
                "g {g} lambda {lambda}: gain {:.3} +- {:.3} ({:+.2}%), read {:.3} +- {:.3} ({:+.2}%), lambda {:.4}, {:.2} s, {} it, mv {:.2}",
                f.em_gain, f.em_gain_se, 100.0 * eg, f.read_noise_adu, f.read_noise_adu_se, 100.0 * es, f.lambda_e,
                t.elapsed().as_secs_f64(), f.iterations, f.cross_checks.mean_variance_gain_adu_per_e
            );
            // 2 % unless 2 % is under 4 SE at this sample size (read noise at lambda = 5,
            // where only e^-5 = 0.7 % of the samples carry no electron).
            let tol_g = 0.02f64.max(4.0 * f.em_gain_se / g);
            let tol_s = 0.02f64.max(4.0 * f.read_noise_adu_se / sigma);
            // Photon transfer with the ENF: the sample variance of a compound-Poisson pixel
            // has relative SE ~ sqrt(kurtosis / N), kurtosis ~ 6 / lambda + 3 here, which
            // is <= 1.8 % at N = 4e5; 6 % is > 3 SE.
            let mv = f.cross_checks.mean_variance_gain_adu_per_e / f.gain_adu_per_e - 1.0;
            if eg.abs() > tol_g || es.abs() > tol_s || mv.abs() > 0.06 {
                bad.push(format!(
                    "g {g} lambda {lambda}: {eg:+.4} (tol {tol_g:.3}) {es:+.4} (tol {tol_s:.3})"
                ));
            }
        }
        assert!(bad.is_empty(), "{bad:?}");
    }

    #[test]
    fn serial_cic_is_separated_from_light() {
        // Serial CIC electrons are born at a uniform stage k and see the N - k stages after
        // it (per-stage binomial reference). g = 1000, 512 stages, lambda 0.05, serial CIC
        // 0.03, read noise 50 e-, 400k samples. SEs from the Hessian (printed): the gain's is
        // ~1.1 % here, so it must lie within max(2 %, 4 SE); read noise within 2 % (SE
        // 0.15 %); CIC rate and lambda within 4 SE.
        let (g, stages, lambda, cic, sigma) = (1000.0, 512u32, 0.05, 0.03, 50.0);
        let reg = EmRegister::new(g, stages).unwrap();
        let p = reg.p();
        let noise = Normal::new(0.0, sigma).unwrap();
        let mut rng = stream(17, 0, 0);
        let v: Vec<f64> = (0..400_000)
            .map(|_| {
                let k = poisson(lambda, &mut rng) as u64;
                let mut e = reg.sample(k, &mut rng);
                for _ in 0..poisson(cic, &mut rng) {
                    let born = rand::RngExt::random_range(&mut rng, 1..=stages);
                    let mut m = 1u64;
                    for _ in born..stages {
                        m += rand_distr::Binomial::new(m, p).unwrap().sample(&mut rng);
                    }
                    e += m as f64;
                }
                (1000.0 + e + noise.sample(&mut rng)).round()
            })
            .collect();
        let h = ValueHistogram::from_values(&v, 1.0).unwrap();
        let opts = EmGainOptions {
            shape: EmShape::Register { stages },
            gain_e_per_adu: Some(1.0),
            serial_cic: true,
            ..Default::default()
        };
        let f = fit_emgain(&h, &opts).unwrap();
        let (c, cse) = (f.serial_cic_e.unwrap(), f.serial_cic_e_se.unwrap());
        eprintln!(
            "serial CIC {c:.4} +- {cse:.4} (true {cic}), gain {:.1} +- {:.1}, lambda {:.4} +- {:.4}, read {:.2}",
            f.em_gain, f.em_gain_se, f.lambda_e, f.lambda_e_se, f.read_noise_adu
        );
        assert!((c - cic).abs() < 4.0 * cse, "cic {c} +- {cse}");
        let tol = 0.02f64.max(4.0 * f.em_gain_se / g);
        assert!((f.em_gain / g - 1.0).abs() < tol, "gain {}", f.em_gain);
        assert!((f.read_noise_adu / sigma - 1.0).abs() < 0.02);
        assert!(
            (f.lambda_e - lambda).abs() < 4.0 * f.lambda_e_se,
            "lambda {}",
            f.lambda_e
        );
    }

    #[test]
    fn gamma_model_without_conversion_reports_adu_per_electron() {
        // 5 e- per adu, g = 300: G = 60 adu/e-. The Gamma model's single-electron variance
        // g^2 exceeds the register's by 1/0.997 at this gain (notes 2.1): a bias far below
        // the 0.5 % SE of 4e5 samples at lambda 0.2; 2 % tolerance.
        let v = synth(400_000, 300.0, 0.2, 50.0, 5.0, 9);
        let h = ValueHistogram::from_values(&v, 1.0).unwrap();
        let f = fit_emgain(&h, &EmGainOptions::default()).unwrap();
        assert_eq!(f.em_gain_units, "adu/e-");
        assert!((f.em_gain / 60.0 - 1.0).abs() < 0.02, "{}", f.em_gain);
        assert!(
            (f.read_noise_adu / 10.0 - 1.0).abs() < 0.02,
            "{}",
            f.read_noise_adu
        );
        assert!(
            (f.bias_adu - 1000.0).abs() < 4.0 * f.bias_adu_se + 0.1,
            "{}",
            f.bias_adu
        );
    }

    #[test]
    fn bad_input_gets_a_reason() {
        // Read noise only: no sample-rate of signal above 5 sigma beyond chance.
        let noise = Normal::new(500.0f64, 3.0).unwrap();
        let mut rng = stream(4, 0, 0);
        let v: Vec<f64> = (0..100_000)
            .map(|_| noise.sample(&mut rng).round())
            .collect();
        let h = ValueHistogram::from_values(&v, 1.0).unwrap();
        let e = fit_emgain(&h, &EmGainOptions::default())
            .unwrap_err()
            .to_string();
        assert!(e.contains("no EM signal"), "{e}");
        let h = ValueHistogram::from_values(&v[..500], 1.0).unwrap();
        let e = fit_emgain(&h, &EmGainOptions::default())
            .unwrap_err()
            .to_string();
        assert!(e.contains("pixel-samples"), "{e}");
        assert!(ValueHistogram::from_values(&[1.0, f64::NAN], 1.0).is_err());
    }
}
