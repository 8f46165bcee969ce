//! The telegraph pixels of a dark stack: the time series of the RTS-flagged pixels, read in a
//! second pass over the stack (only when some pixel is flagged), their telegraph fits, a
//! few example series for the report, and the figures of summary.json.
//!
//! Memory is bounded: at most [`MAX_RTS_PIXELS`] pixels and [`MAX_RTS_SAMPLES`] samples in
//! all (64 MiB of f64) are kept, the pixels with the lowest von Neumann ratio (the clearest
//! telegraphs) first; the rest are counted, not fitted.

use rayon::prelude::*;
use serde::Serialize;

use super::accumulate::PixelStats;
use super::flags::FLAG_RTS;
use super::rts_table::RtsRow;
use super::telegraph::{fit_telegraph, FitStatus, TelegraphFit};
use crate::error::Result;
use crate::io::{read_batches, FrameData, FrameStack};
use crate::stats::median;

/// Most RTS pixels fitted.
pub const MAX_RTS_PIXELS: usize = 4096;
/// Most samples kept for the fits (pixels x frames).
pub const MAX_RTS_SAMPLES: usize = 1 << 23;
/// Example pixels whose series are written for the report.
pub const EXAMPLE_PIXELS: usize = 4;
/// Frames of each example series.
pub const EXAMPLE_FRAMES: usize = 1000;

/// One fitted telegraph pixel.
#[derive(Clone, Debug)]
pub struct RtsPixel {
    /// Pixel index (row-major).
    pub index: usize,
    /// Its telegraph fit.
    pub fit: TelegraphFit,
}

/// The telegraph pixels of a dark stack.
#[derive(Clone, Debug, Default)]
pub struct RtsFits {
    /// Pixels flagged RTS.
    pub flagged: usize,
    /// Pixels fitted (ascending index).
    pub fitted: Vec<RtsPixel>,
    /// Example series: pixel index and its samples less its mean (adu), first frames.
    pub examples: Vec<(usize, Vec<f64>)>,
    /// Whether the stack was read a second time for them.
    pub second_pass: bool,
}

/// The telegraph fits of the pixels flagged RTS in `flags`, from their series read again
/// from `stack` (less each frame's common-mode offset in `stats.per_frame`, if removed).
pub(super) fn fit_rts(stack: &FrameStack, stats: &PixelStats, flags: &[i32]) -> Result<RtsFits> {
    let mut chosen: Vec<usize> = (0..flags.len())
        .filter(|i| flags[*i] & FLAG_RTS != 0)
        .collect();
    let flagged = chosen.len();
    let frames = stats.frames;
    let cap = MAX_RTS_PIXELS.min(MAX_RTS_SAMPLES / frames.max(1));
    if chosen.is_empty() || cap == 0 {
        return Ok(RtsFits {
            flagged,
            ..RtsFits::default()
        });
    }
    chosen.sort_by(|a, b| {
        stats.von_neumann[*a]
            .total_cmp(&stats.von_neumann[*b])
            .then(a.cmp(b))
    });
    chosen.truncate(cap);
    chosen.sort_unstable();
    let mut series = vec![vec![0.0; frames]; chosen.len()];
    let mut one = [0.0];
    read_batches(stack, None, |batch| {
        for (frame, origin) in batch.frames().iter().zip(batch.origins()) {
            let k = origin.index;
            let cm = stats.per_frame.get(k).copied().unwrap_or(0.0);
            for (s, &i) in series.iter_mut().zip(&chosen) {
                let v = match frame {
                    FrameData::Values(v) => v[i],
                    FrameData::Raw(bytes, layout) => {
                        let w = layout.width();
                        layout.decode(&bytes[i * w..(i + 1) * w], &mut one);
                        one[0]
                    }
                };
                s[k] = v - cm;
            }
        }
        Ok(())
    })?;
    let fits: Vec<Option<TelegraphFit>> = series.par_iter().map(|s| fit_telegraph(s)).collect();
    let fitted: Vec<RtsPixel> = chosen
        .iter()
        .zip(fits)
        .filter_map(|(i, f)| f.map(|fit| RtsPixel { index: *i, fit }))
        .collect();
    let examples = examples(&fitted)
        .into_iter()
        .map(|i| {
            let s = &series[chosen.binary_search(&i).expect("a chosen pixel")];
            let m = s.iter().sum::<f64>() / s.len() as f64;
            (i, s.iter().take(EXAMPLE_FRAMES).map(|v| v - m).collect())
        })
        .collect();
    Ok(RtsFits {
        flagged,
        fitted,
        examples,
        second_pass: true,
    })
}

/// Up to [`EXAMPLE_PIXELS`] `ok` pixels with the clearest levels (largest gap between
/// neighbouring levels over the wider of their widths), by pixel index.
fn examples(fitted: &[RtsPixel]) -> Vec<usize> {
    let contrast = |f: &TelegraphFit| {
        f.levels
            .windows(2)
            .map(|w| (w[1].mean - w[0].mean) / w[0].width.max(w[1].width))
            .fold(f64::INFINITY, f64::min)
    };
    let mut ok: Vec<(f64, usize)> = fitted
        .iter()
        .filter(|p| p.fit.status == FitStatus::Ok)
        .map(|p| (contrast(&p.fit), p.index))
        .collect();
    ok.sort_by(|a, b| b.0.total_cmp(&a.0).then(a.1.cmp(&b.1)));
    let mut idx: Vec<usize> = ok.into_iter().take(EXAMPLE_PIXELS).map(|p| p.1).collect();
    idx.sort_unstable();
    idx
}

impl RtsFits {
    /// The table rows of frames `cols` pixels wide, e- columns with `gain` (e- per adu).
    pub fn rows(&self, cols: usize, gain: Option<f64>) -> Vec<RtsRow> {
        self.fitted
            .iter()
            .map(|p| RtsRow::of_fit(p.index % cols, p.index / cols, &p.fit, gain))
            .collect()
    }

    /// `rts-series.csv`: a `frame` column and one `x{X}_y{Y}_adu` column per example pixel.
    pub fn series_csv(&self, cols: usize) -> String {
        let mut s = String::from("frame");
        for (i, _) in &self.examples {
            s.push_str(&format!(",x{}_y{}_adu", i % cols, i / cols));
        }
        s.push('\n');
        let n = self.examples.iter().map(|e| e.1.len()).max().unwrap_or(0);
        for k in 0..n {
            s.push_str(&k.to_string());
            for (_, v) in &self.examples {
                s.push(',');
                if let Some(x) = v.get(k) {
                    s.push_str(&x.to_string());
                }
            }
            s.push('\n');
        }
        s
    }

    /// The figures of summary.json, e- with `gain` (e- per adu).
    pub fn summary(&self, cols: usize, gain: Option<f64>) -> RtsSummary {
        let ok: Vec<&TelegraphFit> = self
            .fitted
            .iter()
            .map(|p| &p.fit)
            .filter(|f| f.status == FitStatus::Ok)
            .collect();
        let med = |v: Vec<f64>| (!v.is_empty()).then(|| median(&v));
        let span: Vec<f64> = ok
            .iter()
            .map(|f| f.levels.last().map_or(0.0, |l| l.mean) - f.levels[0].mean)
            .collect();
        let dwell: Vec<f64> = ok
            .iter()
            .flat_map(|f| f.levels.iter().map(|l| l.dwell_frames))
            .collect();
        let span_adu = med(span);
        RtsSummary {
            flagged: self.flagged,
            fitted: self.fitted.len(),
            ok: ok.len(),
            imprecise: self.fitted.len() - ok.len(),
            two_level: ok.iter().filter(|f| f.levels.len() == 2).count(),
            three_level: ok.iter().filter(|f| f.levels.len() == 3).count(),
            median_span_adu: span_adu,
            median_span_e: span_adu.and_then(|s| gain.map(|g| s * g)),
            median_dwell_frames: med(dwell),
            example_pixels: self
                .examples
                .iter()
                .map(|(i, _)| [i % cols, i / cols])
                .collect(),
            max_pixels: MAX_RTS_PIXELS,
            max_samples: MAX_RTS_SAMPLES,
            second_pass: self.second_pass,
            method: format!(
                "RTS-flagged pixels (von Neumann ratio test) read again in a second pass over the stack, at most {MAX_RTS_PIXELS} pixels and {MAX_RTS_SAMPLES} samples (lowest ratio first); each series (less the pixel's mean) fitted by a 2- and a 3-level hidden Markov chain with Gaussian levels (Baum-Welch), the level count chosen by BIC; `ok` when it beats one Gaussian and every level was left at least 3 times"
            ),
        }
    }
}

/// `rts` in summary.json.
#[derive(Clone, Debug, Default, Serialize)]
pub struct RtsSummary {
    /// Pixels flagged RTS.
    pub flagged: usize,
    /// Pixels fitted (rows of rts.csv).
    pub fitted: usize,
    /// Fits with status `ok`.
    pub ok: usize,
    /// Fits with status `imprecise`.
    pub imprecise: usize,
    /// `ok` fits with two levels.
    pub two_level: usize,
    /// `ok` fits with three levels.
    pub three_level: usize,
    /// Median over `ok` fits of highest minus lowest level (adu; null without any).
    pub median_span_adu: Option<f64>,
    /// The same in e- (null without a gain).
    pub median_span_e: Option<f64>,
    /// Median over the levels of `ok` fits of the mean dwell time (frames).
    pub median_dwell_frames: Option<f64>,
    /// Pixels of rts-series.csv, [x, y].
    pub example_pixels: Vec<[usize; 2]>,
    /// Most pixels fitted.
    pub max_pixels: usize,
    /// Most samples kept for the fits.
    pub max_samples: usize,
    /// Whether the stack was read a second time.
    pub second_pass: bool,
    /// How the fits were made (one sentence).
    pub method: String,
}
