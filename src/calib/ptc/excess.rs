//! Whether the flats were amplified by an EM register, from their third moment.
//!
//! Mean m and variance v alone cannot tell a camera of gain K from an EMCCD of gain K G F^2
//! read without its EM gain: both give the same straight photon-transfer line. The third
//! cumulant does. Light of n e- scaled by 1/K has k3 = n / K^3, so R = k3 m / v^2 = 1 (any K).
//! Each electron multiplied by an EM register (exponential output, F^2 = 2) gives compound
//! Poisson moments E[X^j] = j! G^j: R = 6 x 1 / 2^2 = 1.5. Read noise is symmetric and adds
//! nothing to k3; lamp flicker is removed as for the variances.
//!
//! Per level, each pixel's k3 comes from its first `MAX_FRAMES` frames; their mean over pixels
//! (outliers such as cosmic rays left out) times m / v^2 is that level's R, and the levels are
//! combined by inverse-variance weights.

use serde::Serialize;

use crate::error::Result;
use crate::io::FrameStack;
use crate::stats::{mean_var, median};

/// Frames per level read for the third moment (the variances use all of them).
const MAX_FRAMES: usize = 64;
/// Pixels whose k3 is this many robust widths from the median are left out (cosmic rays).
const CLIP_WIDTHS: f64 = 10.0;
/// R above this is called an EM register, below it shot noise (halfway from 1 to 1.5).
const R_SPLIT: f64 = 1.25;
/// Standard errors by which R must be away from the other case's value to decide.
const DECIDE_SIGMAS: f64 = 5.0;

/// What the third moment of the flats shows.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum ExcessVerdict {
    /// R near 1: shot noise scaled by one gain, no EM register.
    ShotNoise,
    /// R near 1.5: electrons multiplied by an EM register (F^2 near 2).
    EmRegister,
    /// Too noisy to tell (few frames or pixels, or bright levels only).
    Unclear,
}

/// The flats' excess-noise signature R = k3 m / v^2 (1 for shot noise, 1.5 for an EM register).
#[derive(Clone, Copy, Debug, Serialize)]
pub struct ExcessNoise {
    /// R over the levels (unitless).
    pub ratio: f64,
    /// Its standard error (unitless).
    pub ratio_se: f64,
    /// The decision.
    pub verdict: ExcessVerdict,
}

impl ExcessNoise {
    /// Combine per-level (R, SE) by inverse-variance weights and decide.
    pub(super) fn combine(levels: &[(f64, f64)]) -> ExcessNoise {
        let (mut sw, mut swr) = (0.0, 0.0);
        for (r, se) in levels.iter().filter(|(r, se)| r.is_finite() && *se > 0.0) {
            let w = 1.0 / (se * se);
            sw += w;
            swr += w * r;
        }
        let (ratio, ratio_se) = if sw > 0.0 {
            (swr / sw, 1.0 / sw.sqrt())
        } else {
            (f64::NAN, f64::NAN)
        };
        let verdict = if ratio > R_SPLIT && ratio - 1.0 > DECIDE_SIGMAS * ratio_se {
            ExcessVerdict::EmRegister
        } else if ratio < R_SPLIT && 1.5 - ratio > DECIDE_SIGMAS * ratio_se {
            ExcessVerdict::ShotNoise
        } else {
            ExcessVerdict::Unclear
        };
        ExcessNoise {
            ratio,
            ratio_se,
            verdict,
        }
    }
}

/// One level's R and its standard error. `select` flags the level's frames (all when None),
/// `scale` is each selected frame's flicker factor (stack mean signal / frame mean signal; 1
/// without flicker removal), `mean_adu` each pixel's mean (adu, the centre that avoids
/// cancellation), `usable` the pixels the level uses, (`m`, `v`) the level's dark-subtracted
/// mean (adu) and variance (adu^2).
#[allow(clippy::too_many_arguments)]
pub(super) fn level_ratio(
    stack: &FrameStack,
    select: Option<&[bool]>,
    scale: &[f64],
    offset: &[f64],
    mean_adu: &[f64],
    usable: &[bool],
    (m, v): (f64, f64),
) -> Result<(f64, f64)> {
    let npix = stack.pixels();
    let (mut s1, mut s2, mut s3) = (vec![0.0; npix], vec![0.0; npix], vec![0.0; npix]);
    let mut frame = vec![0.0; npix];
    let mut reader = stack.reader();
    let (mut k, mut used) = (0usize, 0usize);
    while used < MAX_FRAMES.min(scale.len()) {
        if reader.next_frame(&mut frame)?.is_none() {
            break;
        }
        k += 1;
        if select.is_some_and(|s| !s[k - 1]) {
            continue;
        }
        let f = scale[used];
        used += 1;
        for i in 0..npix {
            let y = offset[i] + (frame[i] - offset[i]) * f - mean_adu[i];
            s1[i] += y;
            s2[i] += y * y;
            s3[i] += y * y * y;
        }
    }
    if used < 3 {
        return Ok((f64::NAN, f64::NAN));
    }
    let n = used as f64;
    let k3: Vec<f64> = (0..npix)
        .filter(|&i| usable[i])
        .map(|i| {
            let d = s1[i] / n;
            let c3 = s3[i] - 3.0 * d * s2[i] + 2.0 * n * d * d * d;
            c3 * n / ((n - 1.0) * (n - 2.0))
        })
        .collect();
    // The mean over pixels, not the median: each pixel's k3 is skewed itself (the median is
    // 18 % low for EM flats of 20 e-). Pixels beyond `CLIP_WIDTHS` robust widths (cosmic rays)
    // are left out.
    let med = median(&k3);
    let dev: Vec<f64> = k3.iter().map(|x| (x - med).abs()).collect();
    let reach = CLIP_WIDTHS * 1.4826 * median(&dev);
    let kept: Vec<f64> = k3
        .into_iter()
        .filter(|x| (x - med).abs() <= reach)
        .collect();
    if kept.len() < 2 {
        return Ok((f64::NAN, f64::NAN));
    }
    let (mean, var) = mean_var(&kept);
    let factor = m / (v * v);
    Ok((mean * factor, (var / kept.len() as f64).sqrt() * factor))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn verdicts_need_five_standard_errors() {
        let one = |r, se| ExcessNoise::combine(&[(r, se)]).verdict;
        assert_eq!(one(1.5, 0.05), ExcessVerdict::EmRegister);
        assert_eq!(one(1.02, 0.05), ExcessVerdict::ShotNoise);
        assert_eq!(one(1.3, 0.1), ExcessVerdict::Unclear);
        // Two equal-weight levels average, with SE / sqrt 2.
        let c = ExcessNoise::combine(&[(1.4, 0.1), (1.6, 0.1)]);
        assert!((c.ratio - 1.5).abs() < 1e-12 && (c.ratio_se - 0.1 / 2f64.sqrt()).abs() < 1e-12);
        assert_eq!(
            ExcessNoise::combine(&[(f64::NAN, f64::NAN)]).verdict,
            ExcessVerdict::Unclear
        );
    }
}
