//! Per-pixel statistics of a frame stack: mean, sample standard deviation, split-half maps,
//! clipping and a per-frame hook (common-mode removal, lamp normalisation).
//!
//! Accumulation is in f64. Frames are added to per-pixel shifted sums (shift = the pixel's
//! first sample, which keeps the sums small and, for integer data, exact), and every
//! `BLOCK` frames the block's (count, mean, M2) is merged into the running Welford state
//! with Chan's formula. Even and odd frames have separate accumulators (the split-half
//! maps); the totals are their Chan merge. Frames are processed in batches, and each
//! batch is swept tile by tile across pixels (rayon), so the accumulators of one tile stay
//! in cache while it sees every frame of the batch. The reading runs on its own thread
//! (CFITSIO handles are not `Send`); memory is the accumulators plus a few frames.

use std::sync::mpsc;

use rayon::prelude::*;

use super::options::Clip;
use super::tile::{merge, sample_std, zeros, Tile};
use crate::calib::{Map, Unit};
use crate::error::{Error, Result};
use crate::io::{FrameData, FrameStack};

/// Frames per parity accumulated as shifted sums before a Chan merge.
const BLOCK: usize = 64;
/// Frames read ahead and swept together.
const BATCH: usize = 4;
/// Pixels per tile.
const TILE: usize = 4096;
/// Pixels per cache block within a tile.
const SUB: usize = 256;

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
                "clip",
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
        mean: Map::new(rows, cols, mean, Unit::Adu),
        rms: Map::new(rows, cols, rms, Unit::Adu),
        rms_even: Map::new(rows, cols, rms_even, Unit::Adu),
        rms_odd: Map::new(rows, cols, rms_odd, Unit::Adu),
        count,
        von_neumann: vn_ratio,
        max,
        per_frame,
    })
}
