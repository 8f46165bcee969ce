//! The level `--common-mode` takes off each frame: the frame's median, read between the grid
//! steps when the data sit on a grid (integers).
//!
//! A median of integer samples is an integer (or a half): taking it off leaves the frame's
//! true common level rounded, a residue of about 1 / sqrt(12) adu common to the whole frame,
//! as large as a camera's row noise. The median of grouped data (the tied values at the
//! median taken as spread evenly over their grid step, the cumulative count interpolated
//! across it) follows the level continuously and keeps the median's robustness (it depends
//! only on which values are below, at and above the median); a mean over robustly chosen
//! pixels would too, but would differ from the median on float data, whose outputs stay as
//! they were: without ties at the median the level is the median, bit for bit.

use crate::stats::median;

/// A [`super::FrameHook`] for `--common-mode`: takes the frame's common level off every
/// sample and returns it (adu), frame index unused.
pub fn take_common_level(_frame_index: usize, frame: &mut [f64]) -> f64 {
    let m = common_level(frame);
    frame.iter_mut().for_each(|v| *v -= m);
    m
}

/// The mean of the levels [`take_common_level`] took off a stack's frames (adu; 0 when none
/// were): added back to the per-pixel means, it keeps them the stack's own levels.
pub fn mean_common_level(levels: &[f64]) -> f64 {
    if levels.is_empty() {
        0.0
    } else {
        levels.iter().sum::<f64>() / levels.len() as f64
    }
}

/// The common level of a frame (adu; its finite values): the median, interpolated within the
/// grid step when several values equal it; NaN without finite values.
pub(super) fn common_level(frame: &[f64]) -> f64 {
    let m = median(frame);
    let (mut below, mut at, mut n) = (0usize, 0usize, 0usize);
    let (mut lower, mut upper) = (f64::NEG_INFINITY, f64::INFINITY);
    for &x in frame.iter().filter(|x| x.is_finite()) {
        n += 1;
        if x < m {
            below += 1;
            lower = lower.max(x);
        } else if x > m {
            upper = upper.min(x);
        } else {
            at += 1;
        }
    }
    // The grid step: the distance to the nearer distinct value (1 for integers).
    let step = (m - lower).min(upper - m);
    if at < 2 || !step.is_finite() {
        return m;
    }
    m - 0.5 * step + (0.5 * n as f64 - below as f64) / at as f64 * step
}

#[cfg(test)]
mod tests {
    use rand_distr::{Distribution, StandardNormal};

    use super::*;
    use crate::rng::stream;

    #[test]
    fn without_ties_at_the_median_the_level_is_the_median() {
        assert_eq!(common_level(&[3.5, 1.25, 2.0]), 2.0);
        assert_eq!(common_level(&[4.0, 1.0, 3.0, 2.0]), 2.5);
        assert_eq!(common_level(&[1.0, f64::NAN, 7.0]), 4.0);
        assert!(common_level(&[]).is_nan());
        let mut rng = stream(5, 0, 0xc0);
        let x: Vec<f64> = (0..1001).map(|_| StandardNormal.sample(&mut rng)).collect();
        assert_eq!(common_level(&x).to_bits(), median(&x).to_bits());
    }

    #[test]
    fn integer_frames_give_their_level_not_its_rounding() {
        // 2000 pixels of 4 adu Gaussian noise about a level moved in steps of 0.05 adu,
        // rounded to integers: the median steps with the integer grid (errors up to 0.5 adu,
        // rms 0.29), the interpolated level follows the true one to a tenth of that, well
        // inside the level's own sampling noise (1.25 x 4 / sqrt(2000) = 0.11 adu); the same
        // noise draws for every level.
        let mut rng = stream(6, 0, 0xc1);
        let noise: Vec<f64> = (0..2000)
            .map(|_| {
                let g: f64 = StandardNormal.sample(&mut rng);
                4.0 * g
            })
            .collect();
        let level0 = common_level(
            &noise
                .iter()
                .map(|e| (100.0 + e).round())
                .collect::<Vec<_>>(),
        );
        let (mut worst_median, mut worst_level) = (0.0f64, 0.0f64);
        for s in 1..20 {
            let shift = 0.05 * s as f64;
            let frame: Vec<f64> = noise.iter().map(|e| (100.0 + shift + e).round()).collect();
            let m0 = median(
                &noise
                    .iter()
                    .map(|e| (100.0 + e).round())
                    .collect::<Vec<_>>(),
            );
            worst_median = worst_median.max((median(&frame) - m0 - shift).abs());
            worst_level = worst_level.max((common_level(&frame) - level0 - shift).abs());
        }
        assert!(worst_median > 0.4, "{worst_median}");
        assert!(worst_level < 0.05, "{worst_level}");
    }
}
