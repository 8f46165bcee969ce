//! The inner loop of the dark statistics: a batch of frames swept across one tile.
//!
//! Integer frames (stored 8- or 16-bit integers plus an integer zero, the usual darks) take
//! the fused sweep: the tile's line shares are added up first, frame by frame in integers,
//! then `W` pixels' sums are held in vector registers across all the frames of the batch
//! while each frame's samples of those pixels are decoded into registers and added to the
//! sums, so the per-pixel state is read and written once per batch, and no sample goes
//! through memory after it is read; a tile seeded and swept by such frames only keeps its
//! shifts, previous samples and maxima as 16-bit integers ([`Narrow`]). Other frames
//! (values, scaled or wide integers, clipping) take the blocked sweep: the tile is cut into
//! blocks of [`SUB`] pixels, a block's samples of every frame are decoded into a small
//! scratch buffer, then added to the block's sums `W` pixels at a time in the same way. The
//! loop is compiled for AVX-512, AVX2 and the baseline and chosen at run time; every variant
//! does the same IEEE operations per pixel in the same order (no fused multiply-add), so the
//! results do not depend on it.

use std::ops::Range;

use super::tile::{Narrow, Tile};
use crate::io::{RawKind, RawLayout};

/// Pixels per cache block: a batch's rows of one block (f64) and the block's sums stay in
/// L1/L2 while the block sees every frame of the batch.
pub(super) const SUB: usize = 256;

/// One frame of a batch as the sweep reads it.
#[derive(Clone, Copy, Debug)]
pub(super) enum FrameView<'a> {
    /// Stored integer bytes of the whole frame and their layout.
    Raw(&'a [u8], RawLayout),
    /// Values of the whole frame.
    Values(&'a [f64]),
}

/// Add `frames` (stack frames `first`, `first + 1`, ... of the pass) to the sums of `tile`.
/// With `seed`, frame 0 of the pass (when in the batch) sets the shifts; `extremes` samples
/// per pixel and end are tracked for clipping.
pub(super) fn sweep(
    tile: &mut Tile,
    frames: &[FrameView],
    first: usize,
    seed: bool,
    extremes: usize,
) {
    #[cfg(target_arch = "x86_64")]
    {
        if std::arch::is_x86_feature_detected!("avx512f") {
            // SAFETY: the CPU supports AVX-512F (checked above).
            return unsafe { sweep_avx512(tile, frames, first, seed, extremes) };
        }
        if std::arch::is_x86_feature_detected!("avx2") {
            // SAFETY: the CPU supports AVX2 (checked above).
            return unsafe { sweep_avx2(tile, frames, first, seed, extremes) };
        }
    }
    sweep_w::<4>(tile, frames, first, seed, extremes)
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f")]
unsafe fn sweep_avx512(
    tile: &mut Tile,
    frames: &[FrameView],
    first: usize,
    seed: bool,
    extremes: usize,
) {
    // 8 pixels: each running sum is one 512-bit register. With 16 (two registers each) the
    // decoded samples spilled to the stack, and on AMD Zen 4 the 1 GiB benchmark took 5-7 %
    // more time (medians of 8 alternated runs).
    sweep_w::<8>(tile, frames, first, seed, extremes)
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
unsafe fn sweep_avx2(
    tile: &mut Tile,
    frames: &[FrameView],
    first: usize,
    seed: bool,
    extremes: usize,
) {
    sweep_w::<8>(tile, frames, first, seed, extremes)
}

/// The sweep with the plain sums of `W` pixels held in registers.
#[inline(always)]
fn sweep_w<const W: usize>(
    tile: &mut Tile,
    frames: &[FrameView],
    first: usize,
    seed: bool,
    extremes: usize,
) {
    if tile.window.is_none() && extremes == 0 {
        if let Some((raw, layout)) = integer_frames(frames) {
            match (layout.kind, layout.big_endian) {
                (RawKind::I16, true) => {
                    return fused::<W, 2>(tile, &raw, layout, first, seed, |a| {
                        i16::from_be_bytes(a) as i32
                    })
                }
                (RawKind::I16, false) => {
                    return fused::<W, 2>(tile, &raw, layout, first, seed, |a| {
                        i16::from_le_bytes(a) as i32
                    })
                }
                (RawKind::U8, _) => {
                    return fused::<W, 1>(tile, &raw, layout, first, seed, |a| {
                        u8::from_be_bytes(a) as i32
                    })
                }
                _ => {}
            }
        }
    }
    tile.widen();
    let count = frames.len();
    let mut rows = vec![0.0; count * SUB];
    if let Some(lines) = tile.lines.as_mut() {
        lines.begin(count, true);
    }
    for a in (0..tile.len).step_by(SUB) {
        let n = SUB.min(tile.len - a);
        let (lo, hi) = (tile.start + a, tile.start + a + n);
        for (j, frame) in frames.iter().enumerate() {
            let row = &mut rows[j * SUB..j * SUB + n];
            match frame {
                FrameView::Raw(bytes, layout) => {
                    let w = layout.width();
                    layout.decode(&bytes[lo * w..hi * w], row);
                }
                FrameView::Values(v) => row.copy_from_slice(&v[lo..hi]),
            }
        }
        let row = |j: usize| &rows[j * SUB..j * SUB + n];
        if let Some(lines) = tile.lines.as_mut() {
            for j in 0..count {
                lines.add(a, row(j), j);
            }
        }
        if seed && first == 0 {
            tile.seed(a, row(0));
        }
        if tile.window.is_some() {
            for j in 0..count {
                tile.add_windowed(a, row(j), (first + j) % 2);
            }
            continue;
        }
        plain::<W>(tile, a, n, &rows, count, first % 2);
        if extremes > 0 {
            for j in 0..count {
                tile.add_extremes(a, row(j), (first + j) % 2, extremes);
            }
        }
    }
}

/// The stored bytes of `frames` when all are raw frames of one layout whose values are the
/// stored integers plus an integer zero (unscaled), so that every sum of the batch is an
/// integer, exact in any order of addition.
fn integer_frames<'a>(frames: &[FrameView<'a>]) -> Option<(Vec<&'a [u8]>, RawLayout)> {
    let FrameView::Raw(_, layout) = *frames.first()? else {
        return None;
    };
    if layout.scale != 1.0 || layout.zero.fract() != 0.0 {
        return None;
    }
    frames
        .iter()
        .map(|f| match *f {
            FrameView::Raw(b, l) if l == layout => Some(b),
            _ => None,
        })
        .collect::<Option<Vec<_>>>()
        .map(|raw| (raw, layout))
}

/// The sweep of integer frames (`raw`, stored samples of `N` bytes, each the integer `int`
/// of its bytes plus the layout's zero): the line shares first, frame by frame in integers
/// ([`super::lines::TileLines::add_stored`]), then each frame's samples of `W` pixels decoded into
/// registers and added to the pixels' sums, with no scratch buffer in between; per pixel the
/// same operations in the same order as the other sweep, so the same sums.
#[inline(always)]
fn fused<'a, const W: usize, const N: usize>(
    tile: &mut Tile,
    raw: &[&'a [u8]],
    layout: RawLayout,
    first: usize,
    seed: bool,
    int: impl Fn([u8; N]) -> i32 + Copy,
) {
    let (count, start, len, zero) = (raw.len(), tile.start, tile.len, layout.zero);
    let range = start * N..(start + len) * N;
    let bytes = |frame: &'a [u8]| &frame[range.clone()];
    if seed && first == 0 {
        let stored = bytes(raw[0]).chunks_exact(N);
        tile.seed_narrow(
            stored.map(|a| int(a.try_into().expect("N bytes")) as i16),
            zero,
        );
        if tile.narrow.is_none() {
            tile.widen();
            layout.decode(bytes(raw[0]), &mut tile.shift);
            tile.prev.copy_from_slice(&tile.shift);
        }
    }
    if let Some(lines) = tile.lines.as_mut() {
        lines.begin(count, false);
        for (j, frame) in raw.iter().enumerate() {
            lines.add_stored(j, bytes(frame), zero, int);
        }
    }
    // The stored integers of this layout, as offsets from a narrow tile's base.
    let (lo, hi) = match layout.kind {
        RawKind::U8 => (0, u8::MAX as i32),
        _ => (i16::MIN as i32, i16::MAX as i32),
    };
    match &tile.narrow {
        Some(n) if n.holds(lo, hi, zero) => {
            let off = n.base - zero;
            sums::<W, N, i16>(tile, raw, first, off, int)
        }
        _ => {
            tile.widen();
            sums::<W, N, f64>(tile, raw, first, -zero, int)
        }
    }
}

/// The fused sweep's sums: `raw` as in [`fused`], the tile's shifts, previous samples and
/// maxima kept as `L`, which in the stored integers' terms are `off` more.
#[inline(always)]
fn sums<const W: usize, const N: usize, L: Level>(
    tile: &mut Tile,
    raw: &[&[u8]],
    first: usize,
    off: f64,
    int: impl Fn([u8; N]) -> i32 + Copy,
) {
    let (count, start, len) = (raw.len(), tile.start, tile.len);
    let mut acc = Acc::<L>::of(tile, 0..len, off);
    let mut c = 0;
    while c + W <= len {
        let p = start + c;
        if c % 8 == 0 {
            acc.prefetch(c + STATE_AHEAD);
        }
        chunk::<W, L>(&mut acc, c, count, first % 2, Stored { raw, p, int });
        c += W;
    }
    while c < len {
        let p = start + c;
        chunk::<1, L>(&mut acc, c, count, first % 2, Stored { raw, p, int });
        c += 1;
    }
}

/// How a tile keeps its shifts, previous samples and maxima: f64 values, or [`Narrow`]
/// 16-bit integers.
trait Level: Copy {
    /// As f64 (exact).
    fn get(self) -> f64;
    /// From an f64 that this type holds exactly.
    fn put(x: f64) -> Self;
    /// The shifts, previous samples and maxima kept as this type.
    fn of<'a>(wide: [&'a mut Vec<f64>; 3], narrow: Option<&'a mut Narrow>) -> [&'a mut [Self]; 3];
}

impl Level for f64 {
    #[inline(always)]
    fn get(self) -> f64 {
        self
    }

    #[inline(always)]
    fn put(x: f64) -> f64 {
        x
    }

    fn of<'a>(wide: [&'a mut Vec<f64>; 3], _: Option<&'a mut Narrow>) -> [&'a mut [f64]; 3] {
        wide.map(|v| v.as_mut_slice())
    }
}

impl Level for i16 {
    #[inline(always)]
    fn get(self) -> f64 {
        self as f64
    }

    #[inline(always)]
    fn put(x: f64) -> i16 {
        // An integer below 2^51 in magnitude plus 1.5 * 2^52 has it, in two's complement, in
        // its low mantissa bits: an addition and a truncation, which vectorise (`as`, which
        // saturates, was converted lane by lane).
        (x + 6_755_399_441_055_744.0).to_bits() as i16
    }

    fn of<'a>(_: [&'a mut Vec<f64>; 3], narrow: Option<&'a mut Narrow>) -> [&'a mut [i16]; 3] {
        let Narrow {
            shift, prev, max, ..
        } = narrow.expect("a narrow tile");
        [shift, prev, max].map(|v| v.as_mut_slice())
    }
}

/// The running sums of a run of pixels; the shifts, previous samples and maxima kept as `L`,
/// `off` less than in the terms of the samples.
struct Acc<'a, L> {
    shift: &'a [L],
    s1: [&'a mut [f64]; 2],
    s2: [&'a mut [f64]; 2],
    s3: &'a mut [f64],
    s4: &'a mut [f64],
    vn: &'a mut [f64],
    prev: &'a mut [L],
    max: &'a mut [L],
    off: f64,
}

impl<'a, L: Level> Acc<'a, L> {
    /// Ask for the cache lines of every sum of pixel `c` (from [`Acc::of`]'s first).
    #[inline(always)]
    fn prefetch(&self, c: usize) {
        let [s1e, s1o] = &self.s1;
        let [s2e, s2o] = &self.s2;
        for v in [s1e, s1o, s2e, s2o, &self.s3, &self.s4, &self.vn] {
            prefetch(v, c);
        }
        for v in [self.shift, self.prev, self.max] {
            prefetch(v, c);
        }
    }

    /// The sums of tile-local pixels `r` of `tile`, `off` as in [`Acc`].
    fn of(tile: &'a mut Tile, r: Range<usize>, off: f64) -> Acc<'a, L> {
        let Tile {
            shift,
            s1: [s1e, s1o],
            s2: [s2e, s2o],
            s3,
            s4,
            vn,
            prev,
            max,
            narrow,
            ..
        } = tile;
        let [shift, prev, max] = L::of([shift, prev, max], narrow.as_mut());
        Acc {
            shift: &shift[r.clone()],
            s1: [&mut s1e[r.clone()], &mut s1o[r.clone()]],
            s2: [&mut s2e[r.clone()], &mut s2o[r.clone()]],
            s3: &mut s3[r.clone()],
            s4: &mut s4[r.clone()],
            vn: &mut vn[r.clone()],
            prev: &mut prev[r.clone()],
            max: &mut max[r],
            off,
        }
    }
}

/// Add `count` rows (`SUB` apart in `rows`, the first of `parity`) to the plain sums of the
/// `n` tile-local pixels from `a`.
#[inline(always)]
fn plain<const W: usize>(
    tile: &mut Tile,
    a: usize,
    n: usize,
    rows: &[f64],
    count: usize,
    parity: usize,
) {
    let mut acc = Acc::<f64>::of(tile, a..a + n, 0.0);
    let mut c = 0;
    while c + W <= n {
        chunk::<W, f64>(&mut acc, c, count, parity, Rows { rows, c });
        c += W;
    }
    while c < n {
        chunk::<1, f64>(&mut acc, c, count, parity, Rows { rows, c });
        c += 1;
    }
}

/// Where [`chunk`] takes the samples of its `W` pixels in frame `j` of the batch from (a
/// trait rather than a closure, so that it is always inlined and the samples stay in
/// registers).
trait Samples<const W: usize> {
    /// The samples of frame `j` (stored integers: less their zero, see [`Stored`]).
    fn get(&mut self, j: usize) -> [f64; W];
}

/// Decoded rows, `SUB` values per frame, from block-local pixel `c`.
struct Rows<'a> {
    rows: &'a [f64],
    c: usize,
}

impl<const W: usize> Samples<W> for Rows<'_> {
    #[inline(always)]
    fn get(&mut self, j: usize) -> [f64; W] {
        let at = j * SUB + self.c;
        self.rows[at..at + W].try_into().expect("W pixels")
    }
}

/// Stored samples of frame pixel `p`, decoded in registers: the integers `int` of the
/// stored bytes, whose values are these plus the layout's zero. The sweep works in these
/// integers, whose differences are those of the values (all exact), and saves an addition
/// per sample; the shifts, previous samples and maxima are converted to their terms once a
/// batch ([`Acc`]'s `off`).
struct Stored<'a, I, const N: usize> {
    raw: &'a [&'a [u8]],
    p: usize,
    int: I,
}

impl<const W: usize, const N: usize, I: Fn([u8; N]) -> i32> Samples<W> for Stored<'_, I, N> {
    #[inline(always)]
    fn get(&mut self, j: usize) -> [f64; W] {
        let frame = self.raw[j];
        let b = &frame[self.p * N..(self.p + W) * N];
        let mut x = [0.0; W];
        for (o, a) in x.iter_mut().zip(b.chunks_exact(N)) {
            *o = (self.int)(a.try_into().expect("N bytes")) as f64;
        }
        x
    }
}

/// Pixels ahead of the fused sweep's position whose sums are fetched into cache: a tile's
/// sums (ten arrays) come from memory once per batch, and the hardware prefetchers, which
/// follow the ten streams, did not fetch them early enough (the run took 3-4 % less time
/// with the hint; the frames' bytes need none, as the line shares have just read them).
const STATE_AHEAD: usize = 64;

/// Ask for the cache line of element `at` of `v` (nothing when `at` is past the end).
#[inline(always)]
fn prefetch<T>(v: &[T], at: usize) {
    #[cfg(target_arch = "x86_64")]
    if at < v.len() {
        use std::arch::x86_64::{_mm_prefetch, _MM_HINT_T0};
        // SAFETY: a prefetch is a hint that never faults, and element `at` is inside `v`.
        unsafe { _mm_prefetch::<_MM_HINT_T0>(v.as_ptr().add(at).cast()) };
    }
    #[cfg(not(target_arch = "x86_64"))]
    let _ = (v, at);
}

/// The running sums of `W` pixels that do not depend on the parity of the frame.
struct Shared<const W: usize> {
    shift: [f64; W],
    s3: [f64; W],
    s4: [f64; W],
    vn: [f64; W],
    prev: [f64; W],
    max: [f64; W],
}

/// One sample of `W` pixels into sums of one parity.
#[inline(always)]
fn step<const W: usize>(x: &[f64; W], s1: &mut [f64; W], s2: &mut [f64; W], p: &mut Shared<W>) {
    for i in 0..W {
        let d = x[i] - p.shift[i];
        let d2 = d * d;
        s1[i] += d;
        s2[i] += d2;
        p.s3[i] += d2 * d;
        p.s4[i] += d2 * d2;
        let e = x[i] - p.prev[i];
        p.vn[i] += e * e;
        p.prev[i] = x[i];
        // Samples are never NaN (the readers refuse them), so a plain comparison will do.
        p.max[i] = if x[i] > p.max[i] { x[i] } else { p.max[i] };
    }
}

/// All rows of pixels `c..c + W`, their sums in registers; frames alternate in parity, so
/// they go in pairs (no run-time choice of accumulator inside the loop).
#[inline(always)]
fn chunk<const W: usize, L: Level>(
    acc: &mut Acc<L>,
    c: usize,
    count: usize,
    parity: usize,
    mut sample: impl Samples<W>,
) {
    let ld = |v: &[f64]| -> [f64; W] { v[c..c + W].try_into().expect("W pixels") };
    let (mut s1e, mut s1o) = (ld(acc.s1[0]), ld(acc.s1[1]));
    let (mut s2e, mut s2o) = (ld(acc.s2[0]), ld(acc.s2[1]));
    // The shifts, previous samples and maxima in the samples' terms: exact, as only stored
    // integers (integer values below 2^53) come with an offset.
    let off = acc.off;
    // (Loops, not `array::map`, which was not inlined.)
    let get = |v: &[L]| -> [f64; W] {
        let mut x = [0.0; W];
        for (x, v) in x.iter_mut().zip(&v[c..c + W]) {
            *x = if off == 0.0 { v.get() } else { v.get() + off };
        }
        x
    };
    let mut p = Shared {
        shift: get(acc.shift),
        s3: ld(acc.s3),
        s4: ld(acc.s4),
        vn: ld(acc.vn),
        prev: get(acc.prev),
        max: get(acc.max),
    };
    let mut j = 0;
    if parity == 1 && count > 0 {
        step(&sample.get(0), &mut s1o, &mut s2o, &mut p);
        j = 1;
    }
    while j + 1 < count {
        step(&sample.get(j), &mut s1e, &mut s2e, &mut p);
        step(&sample.get(j + 1), &mut s1o, &mut s2o, &mut p);
        j += 2;
    }
    if j < count {
        step(&sample.get(j), &mut s1e, &mut s2e, &mut p);
    }
    let st = |v: &mut [f64], x: [f64; W]| v[c..c + W].copy_from_slice(&x);
    st(acc.s1[0], s1e);
    st(acc.s1[1], s1o);
    st(acc.s2[0], s2e);
    st(acc.s2[1], s2o);
    st(acc.s3, p.s3);
    st(acc.s4, p.s4);
    st(acc.vn, p.vn);
    let put = |v: &mut [L], x: [f64; W]| {
        for (v, x) in v[c..c + W].iter_mut().zip(x) {
            *v = L::put(if off == 0.0 { x } else { x - off });
        }
    };
    put(acc.prev, p.prev);
    put(acc.max, p.max);
}

#[cfg(test)]
mod tests;
