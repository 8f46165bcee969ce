//! Per-pixel statistics of a frame stack: offset (mean, adu), read noise (sample standard
//! deviation, adu), split-half maps, clipping, common-mode removal and pixel flags; and the
//! check that a dark stack saw no light ([`Illumination`]).
//!
//! Accumulation is in f64. Frames are added to per-pixel shifted sums (shift = the pixel's
//! first sample, which keeps the sums small and, for integer data, exact), and every
//! `BLOCK` frames the block's (count, mean, M2) is merged into the running Welford state
//! with Chan's formula. Even and odd frames have separate accumulators (the split-half
//! maps); the totals are their Chan merge. Frames are processed in batches, and each
//! batch is swept tile by tile across pixels (rayon), so the accumulators of one tile stay
//! in cache while it sees every frame of the batch. The reading runs on its own thread
//! (CFITSIO handles are not `Send`); memory is the accumulators plus a few frames.

use std::ops::Range;
use std::sync::mpsc;

use rayon::prelude::*;
use serde::Serialize;

use crate::error::{Error, Result};
use crate::io::{FrameData, FrameStack};
use crate::maps::Map;

/// Frames per parity accumulated as shifted sums before a Chan merge.
const BLOCK: usize = 64;
/// Frames read ahead and swept together.
const BATCH: usize = 4;
/// Pixels per tile.
const TILE: usize = 4096;
/// Pixels per cache block within a tile.
const SUB: usize = 256;

/// Flag bit: hot pixel (offset far above the frame's typical offset).
pub const FLAG_HOT: i32 = 1;
/// Flag bit: dead pixel (read noise far below typical, e.g. a stuck value).
pub const FLAG_DEAD: i32 = 2;
/// Flag bit: multi-level / random-telegraph pixel (successive samples correlated).
pub const FLAG_RTS: i32 = 4;
/// Flag bit: the pixel reached the largest value of the stored type.
pub const FLAG_SATURATED: i32 = 8;
/// Flag bit: fewer than two samples left after clipping.
pub const FLAG_NO_DATA: i32 = 16;

/// Rejection of outlying samples per pixel (cosmic rays).
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Clip {
    /// Keep every sample.
    None,
    /// Reject the N highest and the N lowest samples of each pixel.
    Extremes(usize),
    /// Reject samples more than K standard deviations from the pixel mean of a first pass
    /// (one iteration; the stack is read twice).
    Sigma(f64),
}

/// Options of the dark-stack statistics.
#[derive(Clone, Debug, Serialize)]
pub struct DarkOptions {
    /// Outlier rejection per pixel.
    pub clip: Clip,
    /// Subtract each frame's median (a per-frame common-mode offset) before accumulating.
    pub common_mode: bool,
    /// Hot threshold: offset above median + this many robust sigmas of the offset map.
    pub hot_sigma: f64,
    /// Dead threshold: rms below this fraction of the median rms.
    pub dead_fraction: f64,
    /// RTS threshold: von Neumann ratio below 1 - this many standard errors (1/sqrt(n)).
    pub rts_sigma: f64,
}

impl Default for DarkOptions {
    fn default() -> Self {
        DarkOptions {
            clip: Clip::None,
            common_mode: false,
            hot_sigma: 5.0,
            dead_fraction: 0.1,
            rts_sigma: 5.0,
        }
    }
}

/// A per-frame transformation applied before accumulation; returns a scalar recorded per
/// frame (common-mode offset, lamp level). Called on frames in order.
pub type FrameHook<'a> = &'a (dyn Fn(usize, &mut [f64]) -> f64 + Sync);

/// Per-pixel results of one stack.
#[derive(Clone, Debug)]
pub struct PixelStats {
    /// Number of frames read.
    pub frames: usize,
    /// Mean per pixel (adu).
    pub mean: Map,
    /// Sample standard deviation per pixel (adu).
    pub rms: Map,
    /// Sample standard deviation from even frames only (adu).
    pub rms_even: Map,
    /// Sample standard deviation from odd frames only (adu).
    pub rms_odd: Map,
    /// Samples used per pixel after clipping.
    pub count: Vec<f64>,
    /// Von Neumann ratio: mean squared successive difference / (2 variance); 1 for white noise.
    pub von_neumann: Vec<f64>,
    /// Largest sample per pixel (adu).
    pub max: Vec<f64>,
    /// Value returned by the frame hook for each frame.
    pub per_frame: Vec<f64>,
}

/// One tile of per-pixel accumulators (structure of arrays, for vectorisation).
struct Tile {
    start: usize,
    len: usize,
    shift: Vec<f64>,
    s1: [Vec<f64>; 2],
    s2: [Vec<f64>; 2],
    /// Per-pixel block counts; only with a window (otherwise every pixel has the block count).
    cnt: Option<[Vec<f64>; 2]>,
    n: [Vec<f64>; 2],
    mean: [Vec<f64>; 2],
    m2: [Vec<f64>; 2],
    prev: Vec<f64>,
    vn: Vec<f64>,
    max: Vec<f64>,
    /// Acceptance window (sigma clipping, second pass).
    window: Option<(Vec<f64>, Vec<f64>)>,
    /// N highest / lowest samples per pixel, with their parity (extremes clipping).
    hi: Vec<(f64, u8)>,
    lo: Vec<(f64, u8)>,
}

fn zeros(n: usize) -> Vec<f64> {
    vec![0.0; n]
}

impl Tile {
    fn new(start: usize, len: usize, extremes: usize) -> Tile {
        let pair = || [zeros(len), zeros(len)];
        Tile {
            start,
            len,
            shift: zeros(len),
            s1: pair(),
            s2: pair(),
            cnt: None,
            n: pair(),
            mean: pair(),
            m2: pair(),
            prev: zeros(len),
            vn: zeros(len),
            max: vec![f64::NEG_INFINITY; len],
            window: None,
            hi: vec![(f64::NEG_INFINITY, 0); len * extremes],
            lo: vec![(f64::INFINITY, 0); len * extremes],
        }
    }

    /// Add the samples `x` of tile-local pixels `r` of one frame.
    fn add(&mut self, x: &[f64], parity: usize, first: bool, extremes: usize, r: Range<usize>) {
        if first {
            self.shift[r.clone()].copy_from_slice(x);
            self.prev[r.clone()].copy_from_slice(x);
        }
        let n = x.len();
        let (s1, s2) = (
            &mut self.s1[parity][r.clone()],
            &mut self.s2[parity][r.clone()],
        );
        let shift = &self.shift[r.clone()];
        match &self.window {
            None => {
                // Index loops over equal-length slices: the bounds checks hoist and the body
                // vectorises.
                let (prev, vn, max) = (
                    &mut self.prev[r.clone()],
                    &mut self.vn[r.clone()],
                    &mut self.max[r.clone()],
                );
                let (s1, s2, shift, prev, vn, max) = (
                    &mut s1[..n],
                    &mut s2[..n],
                    &shift[..n],
                    &mut prev[..n],
                    &mut vn[..n],
                    &mut max[..n],
                );
                for i in 0..n {
                    let d = x[i] - shift[i];
                    s1[i] += d;
                    s2[i] += d * d;
                    let v = x[i] - prev[i];
                    vn[i] += v * v;
                    prev[i] = x[i];
                    max[i] = max[i].max(x[i]);
                }
            }
            Some((lo, hi)) => {
                let cnt =
                    &mut self.cnt.as_mut().expect("counts exist with a window")[parity][r.clone()];
                let (lo, hi) = (&lo[r.clone()], &hi[r.clone()]);
                for i in 0..n {
                    let keep = (x[i] >= lo[i] && x[i] <= hi[i]) as u8 as f64;
                    let d = (x[i] - shift[i]) * keep;
                    s1[i] += d;
                    s2[i] += d * d;
                    cnt[i] += keep;
                }
            }
        }
        if extremes > 0 {
            for (j, &v) in x.iter().enumerate() {
                let i = r.start + j;
                insert_extreme(
                    &mut self.hi[i * extremes..(i + 1) * extremes],
                    v,
                    parity as u8,
                    |a, b| a > b,
                );
                insert_extreme(
                    &mut self.lo[i * extremes..(i + 1) * extremes],
                    v,
                    parity as u8,
                    |a, b| a < b,
                );
            }
        }
    }

    /// Chan merge of the shifted block sums of `parity` into its running Welford state.
    fn flush(&mut self, parity: usize, block: f64) {
        for i in 0..self.len {
            let nb = self.cnt.as_ref().map_or(block, |c| c[parity][i]);
            if nb == 0.0 {
                continue;
            }
            let (s1, s2) = (self.s1[parity][i], self.s2[parity][i]);
            let mean_b = self.shift[i] + s1 / nb;
            let m2_b = (s2 - s1 * s1 / nb).max(0.0);
            let na = self.n[parity][i];
            let n = na + nb;
            let delta = mean_b - self.mean[parity][i];
            self.mean[parity][i] += delta * nb / n;
            self.m2[parity][i] += m2_b + delta * delta * na * nb / n;
            self.n[parity][i] = n;
        }
        self.s1[parity].fill(0.0);
        self.s2[parity].fill(0.0);
        if let Some(c) = self.cnt.as_mut() {
            c[parity].fill(0.0);
        }
    }

    /// Undo the Welford update of sample `v` in `parity` (extremes clipping).
    fn remove(&mut self, i: usize, parity: usize, v: f64) {
        let n = self.n[parity][i];
        if n <= 1.0 {
            self.n[parity][i] = 0.0;
            self.mean[parity][i] = 0.0;
            self.m2[parity][i] = 0.0;
            return;
        }
        let mean = self.mean[parity][i];
        let mean_new = (n * mean - v) / (n - 1.0);
        self.m2[parity][i] = (self.m2[parity][i] - (v - mean_new) * (v - mean)).max(0.0);
        self.mean[parity][i] = mean_new;
        self.n[parity][i] = n - 1.0;
    }
}

/// Keep `list` as the best samples under `better`, best first; `v` displaces the worst.
fn insert_extreme(list: &mut [(f64, u8)], v: f64, parity: u8, better: impl Fn(f64, f64) -> bool) {
    let last = list.len() - 1;
    if !better(v, list[last].0) {
        return;
    }
    let mut j = last;
    while j > 0 && better(v, list[j - 1].0) {
        list[j] = list[j - 1];
        j -= 1;
    }
    list[j] = (v, parity);
}

/// Chan merge of two (n, mean, M2) summaries.
fn merge(a: (f64, f64, f64), b: (f64, f64, f64)) -> (f64, f64, f64) {
    let n = a.0 + b.0;
    if n == 0.0 {
        return (0.0, f64::NAN, f64::NAN);
    }
    let delta = b.1 - a.1;
    let mean = if a.0 == 0.0 {
        b.1
    } else if b.0 == 0.0 {
        a.1
    } else {
        a.1 + delta * b.0 / n
    };
    (n, mean, a.2 + b.2 + delta * delta * a.0 * b.0 / n)
}

fn sample_std(n: f64, m2: f64) -> f64 {
    if n >= 2.0 {
        (m2 / (n - 1.0)).sqrt()
    } else {
        f64::NAN
    }
}

/// Run `consume` on batches of frames read on a separate thread (one being read while one is used).
fn stream_batches(
    stack: &FrameStack,
    mut consume: impl FnMut(&mut [FrameData], usize) -> Result<()>,
) -> Result<()> {
    let (tx, rx) = mpsc::sync_channel::<Result<(Vec<FrameData>, usize)>>(0);
    let (back_tx, back_rx) = mpsc::channel::<Vec<FrameData>>();
    std::thread::scope(|s| {
        let reader_stack = stack.clone();
        s.spawn(move || {
            let mut reader = reader_stack.reader();
            let mut first = 0;
            loop {
                let mut batch = back_rx.try_recv().unwrap_or_default();
                batch.resize_with(BATCH, || FrameData::Values(Vec::new()));
                let mut filled = 0;
                let mut failed = None;
                while filled < BATCH {
                    match reader.next_frame_data(&mut batch[filled]) {
                        Ok(Some(_)) => filled += 1,
                        Ok(None) => break,
                        Err(e) => {
                            failed = Some(e);
                            break;
                        }
                    }
                }
                if let Some(e) = failed {
                    let _ = tx.send(Err(e));
                    return;
                }
                if filled == 0 {
                    return;
                }
                batch.truncate(filled);
                if tx.send(Ok((batch, first))).is_err() {
                    return;
                }
                first += filled;
            }
        });
        let result = (|| {
            for msg in rx.iter() {
                let (mut batch, first) = msg?;
                consume(&mut batch, first)?;
                let _ = back_tx.send(batch);
            }
            Ok(())
        })();
        drop(rx);
        result
    })
}

/// Accumulate one pass over `stack`. `window` (per-pixel lo, hi) restricts the samples used;
/// `select` (one flag per stack frame) the frames, which are then numbered among themselves.
fn pass(
    stack: &FrameStack,
    hook: Option<FrameHook>,
    extremes: usize,
    window: Option<(&[f64], &[f64])>,
    shift: Option<&[f64]>,
    select: Option<&[bool]>,
) -> Result<(Vec<Tile>, Vec<f64>, usize)> {
    let npix = stack.pixels();
    let mut tiles: Vec<Tile> = (0..npix.div_ceil(TILE))
        .map(|t| Tile::new(t * TILE, TILE.min(npix - t * TILE), extremes))
        .collect();
    if let Some((lo, hi)) = window {
        for t in &mut tiles {
            t.window = Some((
                lo[t.start..t.start + t.len].to_vec(),
                hi[t.start..t.start + t.len].to_vec(),
            ));
            t.cnt = Some([zeros(t.len), zeros(t.len)]);
        }
    }
    let mut per_frame = Vec::with_capacity(stack.frames);
    let mut frames = 0usize;
    let mut pending = [0usize; 2];
    // With a hook the tiles see transformed frames, so the raw maximum is kept here.
    let mut raw_max = if hook.is_some() {
        vec![f64::NEG_INFINITY; npix]
    } else {
        Vec::new()
    };
    let mut read = 0usize;
    stream_batches(stack, |batch, first_read| {
        read = first_read + batch.len();
        // Selected frames move to the front of the batch and take the next indices.
        let (batch, first) = match select {
            None => (batch, first_read),
            Some(sel) => {
                let mut n = 0;
                for j in 0..batch.len() {
                    if sel[first_read + j] {
                        batch.swap(n, j);
                        n += 1;
                    }
                }
                (&mut batch[..n], frames)
            }
        };
        if batch.is_empty() {
            return Ok(());
        }
        if let Some(h) = hook {
            batch.par_iter_mut().for_each(|f| f.decode_in_place());
            raw_max.par_chunks_mut(TILE).enumerate().for_each(|(t, m)| {
                for f in batch.iter() {
                    for (mi, x) in m.iter_mut().zip(&f.values()[t * TILE..]) {
                        *mi = mi.max(*x);
                    }
                }
            });
            let values: Vec<f64> = batch
                .par_iter_mut()
                .enumerate()
                .map(|(j, f)| h(first + j, f.values_mut()))
                .collect();
            per_frame.extend(values);
        }
        tiles.par_iter_mut().for_each(|t| {
            if first == 0 {
                if let Some(sh) = shift {
                    // Second pass (window): prev and vn are not used.
                    t.shift.copy_from_slice(&sh[t.start..t.start + t.len]);
                }
            }
            // Cache blocking: each run of SUB pixels sees every frame of the batch while its
            // accumulators sit in L1.
            // Raw frames are decoded here, a run at a time, so the stored bytes cross between
            // threads instead of 8-byte values.
            let mut local = [0.0f64; SUB];
            for a in (0..t.len).step_by(SUB) {
                let r = a..(a + SUB).min(t.len);
                let (lo, hi) = (t.start + r.start, t.start + r.end);
                for (j, f) in batch.iter().enumerate() {
                    let k = first + j;
                    let x: &[f64] = match f {
                        FrameData::Values(v) => &v[lo..hi],
                        FrameData::Raw(b, layout) => {
                            let w = layout.width();
                            layout.decode(&b[lo * w..hi * w], &mut local[..r.len()]);
                            &local[..r.len()]
                        }
                    };
                    t.add(x, k % 2, k == 0 && shift.is_none(), extremes, r.clone());
                }
            }
        });
        for j in 0..batch.len() {
            let k = first + j;
            pending[k % 2] += 1;
        }
        for (p, count) in pending.iter_mut().enumerate() {
            if *count >= BLOCK {
                let block = *count as f64;
                tiles.par_iter_mut().for_each(|t| t.flush(p, block));
                *count = 0;
            }
        }
        frames = first + batch.len();
        Ok(())
    })?;
    tiles.par_iter_mut().for_each(|t| {
        t.flush(0, pending[0] as f64);
        t.flush(1, pending[1] as f64);
        if !raw_max.is_empty() {
            t.max.copy_from_slice(&raw_max[t.start..t.start + t.len]);
        }
    });
    if read != stack.frames {
        return Err(Error::input(
            &stack.sources[0].path,
            format!(
                "frame {read}: stack ended after {read} of {} frames",
                stack.frames
            ),
        ));
    }
    Ok((tiles, per_frame, frames))
}

/// Per-pixel statistics of `stack` (needs >= 2 frames). `hook` transforms each frame first.
pub fn pixel_stats(stack: &FrameStack, clip: Clip, hook: Option<FrameHook>) -> Result<PixelStats> {
    pixel_stats_of(stack, clip, hook, None)
}

/// Per-pixel statistics of the frames of `stack` flagged in `select` (one flag per frame; all
/// frames when None), as if they were a stack of their own (needs >= 2 of them).
pub fn pixel_stats_of(
    stack: &FrameStack,
    clip: Clip,
    hook: Option<FrameHook>,
    select: Option<&[bool]>,
) -> Result<PixelStats> {
    stack.require_frames(2, "a variance")?;
    let used = match select {
        Some(sel) => {
            assert_eq!(sel.len(), stack.frames, "one selection flag per frame");
            let n = sel.iter().filter(|s| **s).count();
            if n < 2 {
                return Err(Error::input(
                    &stack.sources[0].path,
                    format!("{n} frame(s) selected: a variance needs at least 2"),
                ));
            }
            n
        }
        None => stack.frames,
    };
    if let Clip::Extremes(n) = clip {
        if 2 * n + 2 > used {
            return Err(Error::invalid(
                "--clip",
                format!(
                    "rejecting {n} high and {n} low samples leaves fewer than 2 of {used} frames"
                ),
            ));
        }
    }
    let extremes = match clip {
        Clip::Extremes(n) => n,
        _ => 0,
    };
    let (mut tiles, per_frame, frames) = pass(stack, hook, extremes, None, None, select)?;
    let (rows, cols) = stack.shape;
    let npix = stack.pixels();
    let mut vn_ratio = vec![f64::NAN; npix];
    let mut max = vec![f64::NAN; npix];
    for t in &tiles {
        for i in 0..t.len {
            let tot = merge(
                (t.n[0][i], t.mean[0][i], t.m2[0][i]),
                (t.n[1][i], t.mean[1][i], t.m2[1][i]),
            );
            let var = tot.2 / (tot.0 - 1.0);
            vn_ratio[t.start + i] = if var > 0.0 {
                t.vn[i] / (frames as f64 - 1.0) / (2.0 * var)
            } else {
                f64::NAN
            };
            max[t.start + i] = t.max[i];
        }
    }
    if extremes > 0 {
        tiles.par_iter_mut().for_each(|t| {
            for i in 0..t.len {
                for j in 0..extremes {
                    let (v, p) = t.hi[i * extremes + j];
                    t.remove(i, p as usize, v);
                    let (v, p) = t.lo[i * extremes + j];
                    t.remove(i, p as usize, v);
                }
            }
        });
    }
    if let Clip::Sigma(k) = clip {
        let (mut lo, mut hi, mut centre) = (vec![0.0; npix], vec![0.0; npix], vec![0.0; npix]);
        for t in &tiles {
            for i in 0..t.len {
                let (n, m, m2) = merge(
                    (t.n[0][i], t.mean[0][i], t.m2[0][i]),
                    (t.n[1][i], t.mean[1][i], t.m2[1][i]),
                );
                let s = sample_std(n, m2);
                lo[t.start + i] = m - k * s;
                hi[t.start + i] = m + k * s;
                centre[t.start + i] = m;
            }
        }
        // The second pass replays the hook so frames are transformed identically.
        tiles = pass(stack, hook, 0, Some((&lo, &hi)), Some(&centre), select)?.0;
    }
    let mut mean = vec![f64::NAN; npix];
    let mut rms = vec![f64::NAN; npix];
    let mut rms_even = vec![f64::NAN; npix];
    let mut rms_odd = vec![f64::NAN; npix];
    let mut count = vec![0.0; npix];
    for t in &tiles {
        for i in 0..t.len {
            let e = (t.n[0][i], t.mean[0][i], t.m2[0][i]);
            let o = (t.n[1][i], t.mean[1][i], t.m2[1][i]);
            let tot = merge(e, o);
            let g = t.start + i;
            count[g] = tot.0;
            mean[g] = tot.1;
            rms[g] = sample_std(tot.0, tot.2);
            rms_even[g] = sample_std(e.0, e.2);
            rms_odd[g] = sample_std(o.0, o.2);
        }
    }
    Ok(PixelStats {
        frames,
        mean: Map::new(rows, cols, mean),
        rms: Map::new(rows, cols, rms),
        rms_even: Map::new(rows, cols, rms_even),
        rms_odd: Map::new(rows, cols, rms_odd),
        count,
        von_neumann: vn_ratio,
        max,
        per_frame,
    })
}

/// Median of the finite values (NaN if none).
pub fn median(values: &[f64]) -> f64 {
    percentile(values, 50.0)
}

/// Percentile `p` (0..100) of the finite values, linear interpolation (NaN if none).
pub fn percentile(values: &[f64], p: f64) -> f64 {
    let mut v: Vec<f64> = values.iter().copied().filter(|x| x.is_finite()).collect();
    if v.is_empty() {
        return f64::NAN;
    }
    v.sort_by(f64::total_cmp);
    percentile_sorted(&v, p)
}

/// Percentile `p` (0..100) of ascending finite values, linear interpolation (NaN if empty).
pub fn percentile_sorted(v: &[f64], p: f64) -> f64 {
    if v.is_empty() {
        return f64::NAN;
    }
    let pos = p / 100.0 * (v.len() - 1) as f64;
    let (i, f) = (pos.floor() as usize, pos.fract());
    if i + 1 < v.len() {
        v[i] * (1.0 - f) + v[i + 1] * f
    } else {
        v[i]
    }
}

/// Median of a frame, computed in O(n) by selection (for the common-mode offset).
pub fn frame_median(frame: &[f64]) -> f64 {
    let mut v = frame.to_vec();
    let mid = v.len() / 2;
    let (_, m, _) = v.select_nth_unstable_by(mid, f64::total_cmp);
    *m
}

/// Pearson correlation of two maps over pixels where both are finite.
pub fn correlation(a: &[f64], b: &[f64]) -> f64 {
    let pairs: Vec<(f64, f64)> = a
        .iter()
        .zip(b)
        .filter(|(x, y)| x.is_finite() && y.is_finite())
        .map(|(x, y)| (*x, *y))
        .collect();
    let n = pairs.len() as f64;
    if n < 2.0 {
        return f64::NAN;
    }
    let (ma, mb) = (
        pairs.iter().map(|p| p.0).sum::<f64>() / n,
        pairs.iter().map(|p| p.1).sum::<f64>() / n,
    );
    let (mut sab, mut saa, mut sbb) = (0.0, 0.0, 0.0);
    for (x, y) in &pairs {
        sab += (x - ma) * (y - mb);
        saa += (x - ma) * (x - ma);
        sbb += (y - mb) * (y - mb);
    }
    sab / (saa * sbb).sqrt()
}

/// Dark-stack calibration: offset and read-noise maps, flags and summary figures.
#[derive(Clone, Debug)]
pub struct DarkMaps {
    /// Per-pixel statistics.
    pub stats: PixelStats,
    /// Per-pixel offset (adu), including the mean common-mode level when removed.
    pub offset_adu: Map,
    /// Per-pixel read noise (adu).
    pub rms_adu: Map,
    /// Flag bits per pixel (`FLAG_*`).
    pub flags: Vec<i32>,
    /// Correlation of the even-frame and odd-frame noise maps.
    pub split_half_correlation: f64,
    /// Per-frame common-mode offsets removed (adu; empty when not requested).
    pub common_mode_adu: Vec<f64>,
}

/// Compute dark maps of `stack` with `opts`.
pub fn dark_maps(stack: &FrameStack, opts: &DarkOptions) -> Result<DarkMaps> {
    let cm = |_k: usize, f: &mut [f64]| {
        let m = frame_median(f);
        f.iter_mut().for_each(|v| *v -= m);
        m
    };
    let hook: Option<FrameHook> = if opts.common_mode { Some(&cm) } else { None };
    let stats = pixel_stats(stack, opts.clip, hook)?;
    let common_mode_adu = stats.per_frame.clone();
    let cm_mean = if common_mode_adu.is_empty() {
        0.0
    } else {
        common_mode_adu.iter().sum::<f64>() / common_mode_adu.len() as f64
    };
    let offset: Vec<f64> = stats.mean.data.iter().map(|m| m + cm_mean).collect();
    let offset_adu = Map::new(stats.mean.rows, stats.mean.cols, offset);
    let rms_adu = stats.rms.clone();
    let flags = flag_pixels(
        &stats,
        &offset_adu.data,
        stack.saturation_value().map(|s| s - cm_mean.max(0.0)),
        opts,
    );
    let split_half_correlation = correlation(&stats.rms_even.data, &stats.rms_odd.data);
    Ok(DarkMaps {
        stats,
        offset_adu,
        rms_adu,
        flags,
        split_half_correlation,
        common_mode_adu,
    })
}

/// Robust sigma (1.4826 x median absolute deviation) of the finite values.
pub fn robust_sigma(values: &[f64]) -> f64 {
    let m = median(values);
    let dev: Vec<f64> = values.iter().map(|v| (v - m).abs()).collect();
    1.4826 * median(&dev)
}

fn flag_pixels(
    stats: &PixelStats,
    offset: &[f64],
    saturation: Option<f64>,
    opts: &DarkOptions,
) -> Vec<i32> {
    let off_med = median(offset);
    let off_sigma = robust_sigma(offset);
    let rms_med = median(&stats.rms.data);
    let n = stats.frames as f64;
    // Von Neumann ratio of white noise: mean 1, standard error close to 1/sqrt(n).
    let rts_limit = 1.0 - opts.rts_sigma / n.sqrt();
    (0..offset.len())
        .map(|i| {
            let mut f = 0;
            let rms = stats.rms.data[i];
            if stats.count[i] < 2.0 || !rms.is_finite() {
                f |= FLAG_NO_DATA;
            }
            if off_sigma > 0.0 && offset[i] > off_med + opts.hot_sigma * off_sigma {
                f |= FLAG_HOT;
            }
            if rms.is_nan() || rms < opts.dead_fraction * rms_med {
                f |= FLAG_DEAD;
            }
            if n >= 25.0 && stats.von_neumann[i] < rts_limit {
                f |= FLAG_RTS;
            }
            if saturation.is_some_and(|s| stats.max[i] >= s) {
                f |= FLAG_SATURATED;
            }
            f
        })
        .collect()
}

/// Photon-transfer slopes with fewer standard errors than this are not evidence of light.
const LIGHT_SLOPE_T: f64 = 5.0;
/// Fewest photoelectrons per pixel and frame the slope must imply for light to matter (a
/// shot noise of 2 e-, above typical sCMOS read noise).
const LIGHT_MIN_ELECTRONS: f64 = 4.0;
/// Range of the fraction of the level a photon-transfer slope attributes to signal for a
/// flat: below, the correlation comes from rare events on a dark level (EMCCD clock-induced
/// charge: ~0.3 % of the level); above, the slope is too shallow for shot noise.
const LIGHT_SIGNAL_FRACTION: (f64, f64) = (0.05, 2.0);
/// A dark level above this fraction of the stored integer range is light (dark offsets sit a
/// few percent above zero to keep the dynamic range).
const LIGHT_LEVEL_FRACTION: f64 = 0.25;
/// Fewest pixels for the photon-transfer test across pixels.
const LIGHT_MIN_PIXELS: usize = 64;

/// Evidence that a dark stack saw light, from its per-pixel offset and read-noise maps.
///
/// Shot noise makes a pixel's temporal variance grow with its signal: across the pixels of a
/// flat, variance against mean has the photon-transfer slope (1/gain for illumination
/// differences, 2/gain for gain differences; adu), while a dark's variance does not follow
/// its offset. The slope b and the median variance v then imply the photoelectrons per pixel
/// and frame (v / b^2) and the signal (v / b, adu), which for a flat is a large part of the
/// level.
#[derive(Clone, Debug, Serialize)]
pub struct Illumination {
    /// Pixels used for the slope (central 98 % of the means, variance below its 99th percentile).
    pub pixels: usize,
    /// Median per-pixel mean (adu).
    pub level_adu: f64,
    /// The level as a fraction of the stored integer type's largest value (None for floats).
    pub level_fraction_of_range: Option<f64>,
    /// Median per-pixel variance (adu^2).
    pub variance_adu2: f64,
    /// Slope of per-pixel variance against per-pixel mean across pixels (adu).
    pub slope_adu: f64,
    /// The slope in units of its (heteroscedasticity-robust) standard error.
    pub slope_t: f64,
    /// Photoelectrons per pixel and frame the slope implies: variance / slope^2 (e-).
    pub implied_electrons: f64,
    /// Signal the slope implies as a fraction of the level: variance / (slope x level).
    pub implied_signal_fraction: f64,
    /// True when the frames look illuminated.
    pub illuminated: bool,
}

impl Illumination {
    /// Measure the evidence from per-pixel offsets (adu) and read noise (adu) of a stack whose
    /// stored type saturates at `type_max` (None for floats).
    pub fn measure(offset_adu: &[f64], rms_adu: &[f64], type_max: Option<f64>) -> Illumination {
        let var: Vec<f64> = rms_adu.iter().map(|r| r * r).collect();
        let level_adu = median(offset_adu);
        let variance_adu2 = median(&var);
        let level_fraction_of_range = type_max.map(|m| level_adu / m);
        let (lo, hi, vmax) = (
            percentile(offset_adu, 1.0),
            percentile(offset_adu, 99.0),
            percentile(&var, 99.0),
        );
        let (x, y): (Vec<f64>, Vec<f64>) = offset_adu
            .iter()
            .zip(&var)
            .filter(|(m, v)| **m >= lo && **m <= hi && v.is_finite() && **v <= vmax)
            .map(|(m, v)| (*m, *v))
            .unzip();
        let (slope_adu, slope_t) = if x.len() >= LIGHT_MIN_PIXELS {
            robust_slope(&x, &y)
        } else {
            (f64::NAN, f64::NAN)
        };
        let implied_electrons = variance_adu2 / (slope_adu * slope_adu);
        let implied_signal_fraction = variance_adu2 / (slope_adu * level_adu);
        let (f_lo, f_hi) = LIGHT_SIGNAL_FRACTION;
        let follows_light = slope_t >= LIGHT_SLOPE_T
            && implied_electrons >= LIGHT_MIN_ELECTRONS
            && (f_lo..=f_hi).contains(&implied_signal_fraction);
        let too_high = level_fraction_of_range.is_some_and(|f| f >= LIGHT_LEVEL_FRACTION);
        Illumination {
            pixels: x.len(),
            level_adu,
            level_fraction_of_range,
            variance_adu2,
            slope_adu,
            slope_t,
            implied_electrons,
            implied_signal_fraction,
            illuminated: follows_light || too_high,
        }
    }

    /// What was seen, in numbers (one sentence).
    pub fn describe(&self) -> String {
        let range = self
            .level_fraction_of_range
            .map(|f| format!(" ({:.1} % of the stored type's range)", 100.0 * f))
            .unwrap_or_default();
        let slope = if self.slope_t.is_finite() {
            format!(
                "across {} pixels the variance grows with the mean at {:.3} adu ({:.1} standard errors; darks show no such slope, flats about 1/gain to 2/gain): shot noise of {} photoelectrons per pixel and frame, a signal of {:.0} % of the level",
                self.pixels,
                self.slope_adu,
                self.slope_t,
                significant(self.implied_electrons),
                100.0 * self.implied_signal_fraction
            )
        } else {
            format!(
                "too few pixels ({}) to compare variance with mean",
                self.pixels
            )
        };
        format!(
            "median level {:.1} adu{range}, median variance {} adu^2; {slope}",
            self.level_adu,
            significant(self.variance_adu2)
        )
    }
}

/// `x` with three significant digits, without exponent for everyday magnitudes.
fn significant(x: f64) -> String {
    let digits = if x.abs() >= 100.0 || !x.is_finite() {
        0
    } else {
        (2 - x.abs().log10().floor() as i32).clamp(0, 6) as usize
    };
    format!("{x:.digits$}")
}

/// Least-squares slope of y on x and its t value with the heteroscedasticity-robust (White)
/// standard error: variances of noisier pixels scatter more, which plain OLS errors ignore.
fn robust_slope(x: &[f64], y: &[f64]) -> (f64, f64) {
    let n = x.len() as f64;
    let (mx, my) = (x.iter().sum::<f64>() / n, y.iter().sum::<f64>() / n);
    let (mut sxx, mut sxy) = (0.0, 0.0);
    for (a, b) in x.iter().zip(y) {
        sxx += (a - mx) * (a - mx);
        sxy += (a - mx) * (b - my);
    }
    if sxx <= 0.0 {
        return (f64::NAN, f64::NAN);
    }
    let slope = sxy / sxx;
    let meat: f64 = x
        .iter()
        .zip(y)
        .map(|(a, b)| {
            let e = b - my - slope * (a - mx);
            (a - mx) * (a - mx) * e * e
        })
        .sum();
    let se = meat.sqrt() / sxx;
    (slope, if se > 0.0 { slope / se } else { f64::NAN })
}

/// Refuse a dark stack that looks illuminated (naming the file and what was seen) unless
/// `accept_illuminated`; when illuminated frames are accepted, returns a warning to print.
pub fn require_dark(
    stack: &FrameStack,
    maps: &DarkMaps,
    accept_illuminated: bool,
) -> Result<Option<String>> {
    let seen = Illumination::measure(
        &maps.offset_adu.data,
        &maps.rms_adu.data,
        stack.saturation_value(),
    );
    let path = &stack.sources[0].path;
    match (seen.illuminated, accept_illuminated) {
        (false, _) => Ok(None),
        (true, true) => Ok(Some(format!(
            "{}: these frames look illuminated ({}); used as darks because of --accept-illuminated",
            path.display(),
            seen.describe()
        ))),
        (true, false) => Err(Error::input(
            path,
            format!(
                "these frames look illuminated, not dark: {}. Give frames taken without light (shutter closed, same exposure), or --accept-illuminated to use these anyway",
                seen.describe()
            ),
        )),
    }
}
