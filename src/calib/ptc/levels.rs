//! Light levels within one flat stack: frames grouped by their mean signal, checked for a
//! clean separation, and described for messages.

use crate::io::FrameStack;
use crate::stats::median;

/// Frames of one stack at one light level.
#[derive(Clone, Debug, PartialEq)]
pub struct LightLevel {
    /// Stack frame indices, in order.
    pub frames: Vec<usize>,
    /// Mean of their mean signals above the dark (adu).
    pub mean_adu: f64,
    /// Smallest and largest frame mean signal (adu).
    pub range_adu: (f64, f64),
}

/// Levels differ by more than this fraction of the brighter one (lamp flicker is ~1 %).
const LEVEL_RELATIVE_GAP: f64 = 0.05;
/// ... and by more than this many frame-to-frame standard deviations of the mean signal.
const LEVEL_NOISE_GAP: f64 = 10.0;

/// Group frames by their mean signal (adu above the dark) into light levels, dimmest first:
/// sorted signals split wherever neighbours differ by more than `LEVEL_RELATIVE_GAP` of the
/// brighter and `LEVEL_NOISE_GAP` frame-to-frame deviations. The deviation comes from
/// successive frames (robust: 1.4826 x median |difference| / sqrt 2), so a few jumps between
/// levels acquired one after the other do not inflate it.
pub fn light_levels(frame_signal_adu: &[f64]) -> Vec<LightLevel> {
    let diffs: Vec<f64> = frame_signal_adu
        .windows(2)
        .map(|w| (w[1] - w[0]).abs())
        .collect();
    let noise = 1.4826 * median(&diffs) / std::f64::consts::SQRT_2;
    let noise = if noise.is_finite() { noise } else { 0.0 };
    let mut order: Vec<usize> = (0..frame_signal_adu.len()).collect();
    order.sort_by(|a, b| frame_signal_adu[*a].total_cmp(&frame_signal_adu[*b]));
    let mut groups: Vec<Vec<usize>> = Vec::new();
    for (j, &k) in order.iter().enumerate() {
        let starts_new = j == 0 || {
            let (lo, hi) = (frame_signal_adu[order[j - 1]], frame_signal_adu[k]);
            hi - lo > (LEVEL_RELATIVE_GAP * hi.abs()).max(LEVEL_NOISE_GAP * noise)
        };
        if starts_new {
            groups.push(Vec::new());
        }
        groups.last_mut().expect("pushed above").push(k);
    }
    groups
        .into_iter()
        .map(|mut frames| {
            frames.sort_unstable();
            let v: Vec<f64> = frames.iter().map(|k| frame_signal_adu[*k]).collect();
            LightLevel {
                mean_adu: v.iter().sum::<f64>() / v.len() as f64,
                range_adu: (
                    v.iter().copied().fold(f64::INFINITY, f64::min),
                    v.iter().copied().fold(f64::NEG_INFINITY, f64::max),
                ),
                frames,
            }
        })
        .collect()
}

/// Levels are clean when each has at least 2 frames, a mean signal above the dark and a spread
/// under half the gap to either neighbour.
pub(super) fn clean(levels: &[LightLevel]) -> bool {
    levels.iter().enumerate().all(|(i, l)| {
        let spread = l.range_adu.1 - l.range_adu.0;
        let gap_below = i
            .checked_sub(1)
            .map_or(f64::INFINITY, |j| l.range_adu.0 - levels[j].range_adu.1);
        let gap_above = levels
            .get(i + 1)
            .map_or(f64::INFINITY, |n| n.range_adu.0 - l.range_adu.1);
        l.frames.len() >= 2 && l.mean_adu > 0.0 && spread < 0.5 * gap_below.min(gap_above)
    })
}

/// "50 frame(s) at 400.1 adu above the dark (398.3 to 401.2) from a.fits; ..." for messages.
pub(super) fn describe_levels(stack: &FrameStack, levels: &[LightLevel]) -> String {
    levels
        .iter()
        .map(|l| {
            format!(
                "{} frame(s) at {:.1} adu above the dark ({:.1} to {:.1}) from {}",
                l.frames.len(),
                l.mean_adu,
                l.range_adu.0,
                l.range_adu.1,
                files_of(stack, &l.frames)
            )
        })
        .collect::<Vec<_>>()
        .join("; ")
}

/// Names of the files holding stack frames `frames` (ascending): up to three, then a count.
fn files_of(stack: &FrameStack, frames: &[usize]) -> String {
    let mut names: Vec<String> = Vec::new();
    let (mut file, mut end) = (0, stack.sources[0].frames);
    for &k in frames {
        while k >= end && file + 1 < stack.sources.len() {
            file += 1;
            end += stack.sources[file].frames;
        }
        let p = &stack.sources[file].path;
        let name = p.file_name().map_or_else(
            || p.display().to_string(),
            |n| n.to_string_lossy().into_owned(),
        );
        if names.last() != Some(&name) {
            names.push(name);
        }
    }
    match names.len() {
        0..=3 => names.join(", "),
        n => format!("{} and {} more", names[..3].join(", "), n - 3),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn frames_split_into_clean_levels() {
        // Levels near 100 and 400 adu acquired out of order. Successive differences 1, 2,
        // 301, 2, 4, 297.5 have median 3: noise 1.4826 x 3 / sqrt 2 = 3.1 adu, so a gap must
        // exceed max(5 % of the brighter, 31 adu): only 101 -> 398 does.
        let l = light_levels(&[100.0, 101.0, 99.0, 400.0, 402.0, 398.0, 100.5]);
        assert_eq!(l.len(), 2);
        assert_eq!(
            (l[0].frames.as_slice(), l[1].frames.as_slice()),
            (&[0, 1, 2, 6][..], &[3, 4, 5][..])
        );
        assert!((l[0].mean_adu - 100.125).abs() < 1e-12);
        assert_eq!(
            (l[0].range_adu, l[1].range_adu),
            ((99.0, 101.0), (398.0, 402.0))
        );
        assert!(clean(&l));
        // A level of a single frame is not clean; a 3 % spread is one level.
        assert!(!clean(&light_levels(&[100.0, 101.0, 100.5, 99.5, 400.0])));
        assert_eq!(light_levels(&[100.0, 102.0, 101.0, 103.0]).len(), 1);
    }
}
