//! Per-pixel statistics of a frame stack: mean, sample standard deviation, split-half maps,
//! clipping and a per-frame hook (common-mode removal, lamp normalisation).
//!
//! The frames are read in batches on a thread of their own ([`read_batches`]), which can
//! share them with the checksum thread. Each batch is swept tile by tile across pixels
//! (rayon; `kernel`), adding every sample to per-pixel sums over the whole stack (`tile`):
//! exact for integer samples, and the same for any thread count. The first pass also adds up
//! every frame's rows and columns (`lines`) for the temporal noise decomposition. Memory is
//! the sums (ten f64 per pixel, twelve with clipping, plus the tracked extremes; seven f64
//! and three i16 for stored 8- and 16-bit integers, `tile::Narrow`), the line sums of a
//! batch and a few batches of frames (`io::stream`), O(frame).

use rayon::prelude::*;

use super::decompose::TemporalNoise;
use super::kernel::{sweep, FrameView};
use super::kurtosis::{excess_kurtosis, PowerSums};
use super::lines::{LineAcc, TileLines};
use super::options::Clip;
use super::tile::{mean_var, Tile};
use crate::calib::summary::{with_inputs_hashed, Checksum, InputFile};
use crate::calib::{Map, Unit};
use crate::error::{Error, Result};
use crate::io::{read_batches, ByteTap, FrameData, FrameStack};

/// Pixels per tile (one rayon task per batch). Measured on 512 x 512 uint16 darks (AMD Zen 4,
/// 1 MiB L2): 8192 took 5-10 % less wall time than 4096 (the tile's sums, 640 KiB, still fit
/// in L2, and half as many tasks and line shares), 2048 13 % more, 16384 and above no less.
const TILE: usize = 8192;

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
    /// Excess kurtosis per pixel (G2, dimensionless; every sample, before clipping).
    pub excess_kurtosis: Vec<f64>,
    /// The temporal variance split into pixel, row and column components (every sample).
    pub temporal: TemporalNoise,
    /// Value returned by the frame hook for each frame.
    pub per_frame: Vec<f64>,
}

/// The sums of one pass over a stack.
struct Pass {
    tiles: Vec<Tile>,
    /// Row and column sums over frames (the first pass).
    lines: Option<LineAcc>,
    /// Values returned by the hook, one per frame used.
    per_frame: Vec<f64>,
    /// Frames used.
    frames: usize,
}

impl Pass {
    /// Frames of each parity (even, odd) of the frame index.
    fn parity_frames(&self) -> [f64; 2] {
        [self.frames.div_ceil(2) as f64, (self.frames / 2) as f64]
    }
}

/// Acceptance window of sigma clipping's second pass: per pixel shift, lowest and highest
/// sample kept.
type Window<'a> = (&'a [f64], &'a [f64], &'a [f64]);

/// Decode `frame` into `out` (the hook transforms values in place).
fn decode_into(frame: &FrameData, out: &mut Vec<f64>) {
    match frame {
        FrameData::Values(v) => {
            out.clear();
            out.extend_from_slice(v);
        }
        FrameData::Raw(bytes, layout) => {
            out.resize(bytes.len() / layout.width(), 0.0);
            layout.decode(bytes, out);
        }
    }
}

/// While a core hashes the stack with SHA-256 (`tap`), the statistics run on one worker thread
/// fewer than the global pool has, so that the checksum thread keeps its core (SHA-256 bounds
/// the run); with two cores that is one thread, and no hand-over between threads per batch.
fn hashing_pool(tap: Option<&ByteTap>) -> Option<rayon::ThreadPool> {
    let threads = rayon::current_num_threads();
    if !tap.is_some_and(ByteTap::needs_a_core) || threads < 2 {
        return None;
    }
    rayon::ThreadPoolBuilder::new()
        .num_threads(threads - 1)
        .thread_name(|i| format!("detnoise-stats-{i}"))
        .build()
        .ok()
}

/// Accumulate one pass over `stack`: the frames flagged in `select` (all when None), numbered
/// among themselves, transformed by `hook`, tracking `extremes` per pixel and end, within
/// `window`. Batches read go to `tap` too.
fn pass(
    stack: &FrameStack,
    hook: Option<FrameHook>,
    extremes: usize,
    window: Option<Window>,
    select: Option<&[bool]>,
    tap: Option<&ByteTap>,
) -> Result<Pass> {
    let npix = stack.pixels();
    let mut tiles = tiles_of(stack, extremes, window);
    let mut lines = window.is_none().then(|| LineAcc::new(stack.shape));
    let mut per_frame = Vec::new();
    let mut used = 0usize;
    let mut read = 0usize;
    // With a hook the tiles see transformed frames, so the raw maximum is kept here.
    let mut raw_max = match hook {
        Some(_) => vec![f64::NEG_INFINITY; npix],
        None => Vec::new(),
    };
    let mut decoded: Vec<Vec<f64>> = Vec::new();
    let mut reading = || {
        read_batches(stack, tap, |batch| {
            read = batch.origins().last().map_or(read, |o| o.index + 1);
            let chosen: Vec<&FrameData> = batch
                .frames()
                .iter()
                .zip(batch.origins())
                .filter(|(_, o)| select.is_none_or(|s| s[o.index]))
                .map(|(f, _)| f)
                .collect();
            if chosen.is_empty() {
                return Ok(());
            }
            let views: Vec<FrameView> = match hook {
                None => chosen.iter().map(|f| view(f)).collect(),
                Some(h) => {
                    let transformed = hooked(&chosen, h, used, &mut decoded, &mut raw_max);
                    per_frame.extend(transformed.per_frame);
                    transformed
                        .frames
                        .iter()
                        .map(|v| FrameView::Values(v))
                        .collect()
                }
            };
            tiles
                .par_iter_mut()
                .for_each(|t| sweep(t, &views, used, window.is_none(), extremes));
            if let Some(acc) = lines.as_mut() {
                let shares: Vec<&TileLines> =
                    tiles.iter().filter_map(|t| t.lines.as_ref()).collect();
                acc.add_batch(views.len(), &shares);
            }
            used += views.len();
            Ok(())
        })
    };
    match hashing_pool(tap) {
        Some(pool) => pool.install(reading)?,
        None => reading()?,
    }
    stack.require_all_read(read)?;
    tiles.par_iter_mut().for_each(Tile::widen);
    if !raw_max.is_empty() {
        for t in &mut tiles {
            t.max.copy_from_slice(&raw_max[t.start..t.start + t.len]);
        }
    }
    Ok(Pass {
        tiles,
        lines,
        per_frame,
        frames: used,
    })
}

/// The tiles of a pass over `stack`: tracking `extremes` per pixel and end and adding up
/// the frames' lines (the first pass), or within `window` (the second pass of sigma
/// clipping).
fn tiles_of(stack: &FrameStack, extremes: usize, window: Option<Window>) -> Vec<Tile> {
    let npix = stack.pixels();
    (0..npix.div_ceil(TILE))
        .map(|t| {
            let r = t * TILE..npix.min((t + 1) * TILE);
            match window {
                None => {
                    let mut tile = Tile::new(r.start, r.len(), extremes);
                    tile.lines = Some(TileLines::new(r.start, r.len(), stack.shape.1));
                    tile
                }
                Some((shift, lo, hi)) => {
                    Tile::windowed(r.start, &shift[r.clone()], &lo[r.clone()], &hi[r])
                }
            }
        })
        .collect()
}

/// A frame as read, for the sweep.
fn view(f: &FrameData) -> FrameView<'_> {
    match f {
        FrameData::Values(v) => FrameView::Values(v),
        FrameData::Raw(b, layout) => FrameView::Raw(b, *layout),
    }
}

/// Frames transformed by the hook, and the values it returned.
struct Hooked<'a> {
    frames: &'a [Vec<f64>],
    per_frame: Vec<f64>,
}

/// Decode `chosen` (stack frames `first`, `first + 1`, ...) into `decoded`, raise `raw_max`
/// to their samples, then transform them by `hook`.
fn hooked<'a>(
    chosen: &[&FrameData],
    hook: FrameHook,
    first: usize,
    decoded: &'a mut Vec<Vec<f64>>,
    raw_max: &mut [f64],
) -> Hooked<'a> {
    decoded.resize_with(chosen.len(), Vec::new);
    let decoded = &mut decoded[..chosen.len()];
    decoded
        .par_iter_mut()
        .zip(chosen)
        .for_each(|(out, f)| decode_into(f, out));
    raw_max.par_chunks_mut(TILE).enumerate().for_each(|(t, m)| {
        for f in decoded.iter() {
            for (mi, x) in m.iter_mut().zip(&f[t * TILE..]) {
                *mi = mi.max(*x);
            }
        }
    });
    let per_frame: Vec<f64> = decoded
        .par_iter_mut()
        .enumerate()
        .map(|(j, f)| hook(first + j, f))
        .collect();
    Hooked {
        frames: decoded,
        per_frame,
    }
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
    stats_tapped(stack, clip, hook, select, None)
}

/// [`pixel_stats`] with the `algorithm` digest of every input file, computed on another
/// thread from the frames the statistics read (one pass over the files, as `darks`).
pub fn pixel_stats_hashed(
    stack: &FrameStack,
    clip: Clip,
    hook: Option<FrameHook>,
    algorithm: Checksum,
) -> Result<(PixelStats, Vec<InputFile>)> {
    with_inputs_hashed(stack, algorithm, |tap| {
        stats_tapped(stack, clip, hook, None, Some(tap))
    })
}

/// [`pixel_stats_of`], handing the frames read in the first pass to `tap` (checksums).
pub(super) fn stats_tapped(
    stack: &FrameStack,
    clip: Clip,
    hook: Option<FrameHook>,
    select: Option<&[bool]>,
    tap: Option<&ByteTap>,
) -> Result<PixelStats> {
    check_frames(stack, clip, select)?;
    let extremes = match clip {
        Clip::Extremes(n) => n,
        _ => 0,
    };
    let mut p = pass(stack, hook, extremes, None, select, tap)?;
    let (rows, cols) = stack.shape;
    let frames = p.frames;
    let nf = p.parity_frames();
    let every = EverySample::of(&p);
    let line_vars = p.lines.take().expect("the first pass adds lines").finish();
    let temporal = TemporalNoise::decompose(&line_vars, &every.var, stack.shape);
    if extremes > 0 {
        p.tiles
            .par_iter_mut()
            .for_each(|t| t.remove_extremes(extremes, nf));
    }
    if let Clip::Sigma(k) = clip {
        let (shift, lo, hi) = sigma_window(&p, k, stack.pixels());
        // The second pass replays the hook so frames are transformed identically; it keeps
        // the first pass's shifts (samples, so integer data keep exact sums).
        p.tiles = pass(stack, hook, 0, Some((&shift, &lo, &hi)), select, None)?.tiles;
    }
    let kept = Kept::of(&p);
    Ok(PixelStats {
        frames,
        mean: Map::new(rows, cols, kept.mean, Unit::Adu),
        rms: Map::new(rows, cols, kept.rms, Unit::Adu),
        rms_even: Map::new(rows, cols, kept.rms_even, Unit::Adu),
        rms_odd: Map::new(rows, cols, kept.rms_odd, Unit::Adu),
        count: kept.count,
        von_neumann: every.vn_ratio,
        max: every.max,
        excess_kurtosis: every.kurt,
        temporal,
        per_frame: p.per_frame,
    })
}

/// Fail unless the stack, or its frames flagged in `select` (one flag per frame), are at
/// least 2, and more than twice the samples `clip` rejects at each end.
fn check_frames(stack: &FrameStack, clip: Clip, select: Option<&[bool]>) -> Result<()> {
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
    Ok(())
}

/// The per-pixel maps that see every sample (before clipping): the von Neumann ratio, the
/// maximum, the excess kurtosis and the variance (for the temporal noise decomposition).
struct EverySample {
    vn_ratio: Vec<f64>,
    max: Vec<f64>,
    kurt: Vec<f64>,
    var: Vec<f64>,
}

impl EverySample {
    /// The maps of the first pass `p`.
    fn of(p: &Pass) -> Self {
        let npix: usize = p.tiles.iter().map(|t| t.len).sum();
        let (frames, nf) = (p.frames, p.parity_frames());
        let mut vn_ratio = vec![f64::NAN; npix];
        let mut max = vec![f64::NAN; npix];
        let mut kurt = vec![f64::NAN; npix];
        let mut var_all = vec![f64::NAN; npix];
        let per_tile = vn_ratio
            .par_chunks_mut(TILE)
            .zip(max.par_chunks_mut(TILE))
            .zip(kurt.par_chunks_mut(TILE).zip(var_all.par_chunks_mut(TILE)));
        per_tile
            .zip(&p.tiles)
            .for_each(|(((vn_ratio, max), (kurt, var_all)), t)| {
                for i in 0..t.len {
                    let sums = t.sums(i, None, nf);
                    let (_, var) = mean_var(sums);
                    vn_ratio[i] = if var > 0.0 {
                        t.vn[i] / (frames as f64 - 1.0) / (2.0 * var)
                    } else {
                        f64::NAN
                    };
                    max[i] = t.max[i];
                    var_all[i] = var;
                    kurt[i] = excess_kurtosis(PowerSums {
                        n: sums.n,
                        s1: sums.s1,
                        s2: sums.s2,
                        s3: t.s3[i],
                        s4: t.s4[i],
                    });
                }
            });
        EverySample {
            vn_ratio,
            max,
            kurt,
            var: var_all,
        }
    }
}

/// Sigma clipping's window from the pass `p`: per pixel the shift of its sums and the
/// lowest and highest sample kept, `k` standard deviations around its mean.
fn sigma_window(p: &Pass, k: f64, npix: usize) -> (Vec<f64>, Vec<f64>, Vec<f64>) {
    let nf = p.parity_frames();
    let (mut lo, mut hi, mut shift) = (vec![0.0; npix], vec![0.0; npix], vec![0.0; npix]);
    for t in &p.tiles {
        for i in 0..t.len {
            let (m, var) = mean_var(t.sums(i, None, nf));
            let s = var.sqrt();
            lo[t.start + i] = m - k * s;
            hi[t.start + i] = m + k * s;
            shift[t.start + i] = t.shift[i];
        }
    }
    (shift, lo, hi)
}

/// The per-pixel maps of the samples kept (after clipping): mean, standard deviation, those
/// of the even and odd frames, and the count.
struct Kept {
    mean: Vec<f64>,
    rms: Vec<f64>,
    rms_even: Vec<f64>,
    rms_odd: Vec<f64>,
    count: Vec<f64>,
}

impl Kept {
    /// The maps of the last pass `p` (per tile in parallel: the serial loop was a tenth of
    /// the time after the reading).
    fn of(p: &Pass) -> Self {
        let npix: usize = p.tiles.iter().map(|t| t.len).sum();
        let nf = p.parity_frames();
        let mut mean = vec![f64::NAN; npix];
        let mut rms = vec![f64::NAN; npix];
        let mut rms_even = vec![f64::NAN; npix];
        let mut rms_odd = vec![f64::NAN; npix];
        let mut count = vec![0.0; npix];
        let per_tile = mean
            .par_chunks_mut(TILE)
            .zip(rms.par_chunks_mut(TILE))
            .zip(
                rms_even
                    .par_chunks_mut(TILE)
                    .zip(rms_odd.par_chunks_mut(TILE)),
            )
            .zip(count.par_chunks_mut(TILE));
        per_tile
            .zip(&p.tiles)
            .for_each(|((((mean, rms), (rms_even, rms_odd)), count), t)| {
                for i in 0..t.len {
                    let tot = t.sums(i, None, nf);
                    let (m, var) = mean_var(tot);
                    count[i] = tot.n;
                    mean[i] = m;
                    rms[i] = var.sqrt();
                    rms_even[i] = mean_var(t.sums(i, Some(0), nf)).1.sqrt();
                    rms_odd[i] = mean_var(t.sums(i, Some(1), nf)).1.sqrt();
                }
            });
        Kept {
            mean,
            rms,
            rms_even,
            rms_odd,
            count,
        }
    }
}
