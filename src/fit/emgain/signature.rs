//! Whether frames show an EM register at work, decided in seconds from a sample of the first
//! frames, before an EM-gain fit that would otherwise search for minutes and fail.
//!
//! Electrons multiplied in an EM register turn the pixel values into a read-noise peak at the
//! bias with a long one-sided (exponential) tail above it: samples far above the peak greatly
//! outnumber samples as far below it. sCMOS and CCD frames, dark or lit, scatter about their
//! level with both tails alike (near-Gaussian per pixel; pooled over pixels, heavy but
//! symmetric). Pixels that sit in a tail in most frames (hot or cold pixels) are a property of
//! the pixel, not of a register, and are set aside.

use serde::Serialize;

use super::histogram::ValueHistogram;
use super::start::start_values;
use crate::error::{Error, Result};
use crate::io::FrameStack;

/// Pixel-samples examined at most (8 bytes each).
const MAX_SAMPLES: usize = 1 << 22;
/// Frames examined at least, when the stack has them (persistence needs several).
const MIN_FRAMES: usize = 16;
/// Tails start this many read-noise widths from the bias (the fit's own signal threshold).
const TAIL_WIDTHS: f64 = 5.0;
/// A register's tail above holds at least this many times the samples of the tail below.
const ONE_SIDED_RATIO: f64 = 4.0;
/// Standard errors by which the tail above must exceed the tail below.
const EXCESS_SIGMAS: f64 = 5.0;
/// Tail samples (both sides) enough to call two tails alike when only part of the stack was
/// examined; with fewer, the fit's own checks on the whole stack decide.
const MIN_TAIL_SAMPLES: usize = 100;

/// What the examined samples show.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Verdict {
    /// A one-sided tail above the bias peak: an EM register.
    Present,
    /// Tails alike on both sides (or no tail in the whole stack): no EM register.
    Absent,
    /// Too few tail samples in the part examined to tell.
    Unclear,
}

/// Tail counts of the first frames of a stack about the bias peak.
#[derive(Clone, Debug, Serialize)]
pub struct EmSignature {
    /// Frames examined.
    pub frames: usize,
    /// Pixels examined per frame (every `stride`-th pixel).
    pub pixels: usize,
    /// Whether every sample of the stack was examined.
    pub whole_stack: bool,
    /// Bias: the peak of the pooled values (adu).
    pub bias_adu: f64,
    /// Read noise: rms of the values below the bias (adu).
    pub read_noise_adu: f64,
    /// Samples above bias + 5 read noise, persistent pixels excluded.
    pub above: usize,
    /// Samples below bias - 5 read noise, persistent pixels excluded.
    pub below: usize,
    /// Pixels in a tail in most frames (hot or cold), excluded from the counts.
    pub persistent_pixels: usize,
    /// The decision.
    pub verdict: Verdict,
}

impl EmSignature {
    /// Examine the first frames of `stack` (at most `MAX_SAMPLES` samples, at least
    /// `MIN_FRAMES` frames when it has them). Errors if the whole stack was examined and has no
    /// usable bias peak or signal (the fit's start-value checks), naming the first file.
    pub fn measure(stack: &FrameStack) -> Result<EmSignature> {
        let path = &stack.sources[0].path;
        let p = stack.pixels().max(1);
        let frames = stack.frames.min(MIN_FRAMES.max(MAX_SAMPLES / p));
        let stride = (p * frames).div_ceil(MAX_SAMPLES).max(1);
        let pixels = p.div_ceil(stride);
        let whole_stack = frames == stack.frames && stride == 1;
        let samples = read_samples(stack, frames, stride)?;
        let width = if stack.sample_type.is_float() {
            float_bin_width(&samples)
        } else {
            1.0
        };
        let hist = ValueHistogram::from_values(&samples, width)
            .map_err(|e| Error::input(path, e.to_string()))?;
        let start = match start_values(&hist) {
            Ok(s) => s,
            Err(e) if whole_stack => return Err(Error::input(path, e.to_string())),
            Err(_) => {
                return Ok(EmSignature {
                    frames,
                    pixels,
                    whole_stack,
                    bias_adu: f64::NAN,
                    read_noise_adu: f64::NAN,
                    above: 0,
                    below: 0,
                    persistent_pixels: 0,
                    verdict: Verdict::Unclear,
                })
            }
        };
        let (above, below, persistent_pixels) = tail_counts(
            &samples,
            pixels,
            start.bias_adu,
            TAIL_WIDTHS * start.read_noise_adu,
        );
        Ok(EmSignature {
            frames,
            pixels,
            whole_stack,
            bias_adu: start.bias_adu,
            read_noise_adu: start.read_noise_adu,
            above,
            below,
            persistent_pixels,
            verdict: verdict(above, below, whole_stack),
        })
    }

    /// What was seen, in numbers.
    pub fn describe(&self) -> String {
        format!(
            "{} samples above bias + {TAIL_WIDTHS} read noise ({:.1} + {TAIL_WIDTHS} x {:.2} adu) and {} as far below, in {} frames of {} pixels{}",
            self.above,
            self.bias_adu,
            self.read_noise_adu,
            self.below,
            self.frames,
            self.pixels,
            if self.persistent_pixels > 0 {
                format!(
                    " ({} hot or cold pixels, in a tail in most frames, left out)",
                    self.persistent_pixels
                )
            } else {
                String::new()
            }
        )
    }
}

/// The decision from the tail counts.
fn verdict(above: usize, below: usize, whole_stack: bool) -> Verdict {
    let (a, b) = (above as f64, below as f64);
    let tails = a + b;
    if a >= ONE_SIDED_RATIO * b && a - b >= EXCESS_SIGMAS * tails.sqrt() && tails > 0.0 {
        Verdict::Present
    } else if whole_stack || above + below >= MIN_TAIL_SAMPLES {
        Verdict::Absent
    } else {
        Verdict::Unclear
    }
}

/// Every `stride`-th pixel of the first `frames` frames, frame after frame.
fn read_samples(stack: &FrameStack, frames: usize, stride: usize) -> Result<Vec<f64>> {
    let mut frame = vec![0.0; stack.pixels()];
    let mut out = Vec::with_capacity(frames * stack.pixels().div_ceil(stride));
    let mut reader = stack.reader();
    for _ in 0..frames {
        if reader.next_frame(&mut frame)?.is_none() {
            break;
        }
        out.extend(frame.iter().step_by(stride));
    }
    Ok(out)
}

/// Bin width for float samples: 1/200 of their interquartile range (1 if it is zero).
fn float_bin_width(samples: &[f64]) -> f64 {
    let mut v: Vec<f64> = samples.to_vec();
    v.sort_by(f64::total_cmp);
    let q = |p: f64| v[((v.len() - 1) as f64 * p) as usize];
    let iqr = q(0.75) - q(0.25);
    if iqr > 0.0 && iqr.is_finite() {
        iqr / 200.0
    } else {
        1.0
    }
}

/// Samples above `bias + reach` and below `bias - reach`, leaving out pixels that are in a
/// tail in most frames: more than half of them, and more than 5 binomial standard errors
/// above the tail's rate over all pixels. Returns (above, below, persistent pixels).
fn tail_counts(samples: &[f64], pixels: usize, bias: f64, reach: f64) -> (usize, usize, usize) {
    let frames = samples.len() / pixels.max(1);
    let (mut hi, mut lo) = (vec![0usize; pixels], vec![0usize; pixels]);
    for f in samples.chunks_exact(pixels) {
        for (i, v) in f.iter().enumerate() {
            hi[i] += (*v > bias + reach) as usize;
            lo[i] += (*v < bias - reach) as usize;
        }
    }
    let limit = |counts: &[usize]| {
        let n = frames as f64;
        let rate = counts.iter().sum::<usize>() as f64 / (n * pixels as f64);
        (0.5 * n).max(n * rate + 5.0 * (n * rate * (1.0 - rate)).sqrt())
    };
    let (hi_limit, lo_limit) = (limit(&hi), limit(&lo));
    let (mut above, mut below, mut persistent) = (0, 0, 0);
    for (h, l) in hi.iter().zip(&lo) {
        if *h as f64 > hi_limit || *l as f64 > lo_limit {
            persistent += 1;
        } else {
            above += h;
            below += l;
        }
    }
    (above, below, persistent)
}

/// Refuse frames without an EM signature before an EM-gain fit, naming the first file and
/// what was seen. Stacks too sparse to judge from their first frames pass (the fit's own
/// checks then decide).
pub fn require_em_signature(stack: &FrameStack) -> Result<EmSignature> {
    let s = EmSignature::measure(stack)?;
    if s.verdict == Verdict::Absent {
        let seen = if (s.above as f64) < ONE_SIDED_RATIO * s.below as f64 {
            "the values scatter alike on both sides"
        } else {
            "too few values lie far above it"
        };
        return Err(Error::input(
            &stack.sources[0].path,
            format!(
                "no EM signal: an EM register leaves a long one-sided (exponential) tail above the bias peak, with at least {ONE_SIDED_RATIO} times as many samples far above it as far below, but {seen}: {}. These look like sCMOS or CCD frames (use `detnoise darks` or `detnoise report --detector scmos`), or EMCCD frames without EM gain",
                s.describe()
            ),
        ));
    }
    Ok(s)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn tails_alike_are_absent_one_sided_present_few_unclear() {
        assert_eq!(verdict(1173, 1183, false), Verdict::Absent);
        assert_eq!(verdict(719, 0, true), Verdict::Present);
        assert_eq!(verdict(30, 20, false), Verdict::Unclear);
        assert_eq!(verdict(30, 20, true), Verdict::Absent);
        assert_eq!(verdict(0, 0, true), Verdict::Absent);
        // One-sided but not significant: 20 samples, none below (z = 4.5).
        assert_eq!(verdict(20, 0, false), Verdict::Unclear);
    }

    #[test]
    fn persistent_pixels_are_left_out_of_the_tails() {
        // 100 pixels, 20 frames: pixel 0 always hot, pixel 1 twice high, pixel 2 once low.
        let mut s = vec![0.0; 2000];
        for f in 0..20 {
            s[f * 100] = 100.0;
        }
        s[100 + 1] = 50.0;
        s[200 + 1] = 60.0;
        s[300 + 2] = -70.0;
        assert_eq!(tail_counts(&s, 100, 0.0, 10.0), (2, 1, 1));
    }
}
