//! The inner loop of the dark statistics: a batch of frames swept across one tile.
//!
//! The tile is cut into blocks of [`SUB`] pixels. A block's samples of every frame of the
//! batch are decoded (stored integers to f64) into a small scratch buffer, then added to the
//! block's sums a few pixels at a time, with those pixels' sums held in vector registers
//! across all the frames of the batch: the per-pixel state is read and written once per
//! batch, not once per frame. The loop is compiled for AVX-512, AVX2 and the baseline and
//! chosen at run time; every variant does the same IEEE operations per pixel in the same
//! order (no fused multiply-add), so the results do not depend on it.

use super::tile::Tile;
use crate::io::RawLayout;

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
    // 16 pixels: each running sum is two 512-bit registers, 14 in all.
    sweep_w::<16>(tile, frames, first, seed, extremes)
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
    let count = frames.len();
    let mut rows = vec![0.0; count * SUB];
    if let Some(lines) = tile.lines.as_mut() {
        lines.begin(count);
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

/// The running sums of a run of pixels.
struct Acc<'a> {
    shift: &'a [f64],
    s1: [&'a mut [f64]; 2],
    s2: [&'a mut [f64]; 2],
    s3: &'a mut [f64],
    s4: &'a mut [f64],
    vn: &'a mut [f64],
    prev: &'a mut [f64],
    max: &'a mut [f64],
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
    let r = a..a + n;
    let [s1e, s1o] = &mut tile.s1;
    let [s2e, s2o] = &mut tile.s2;
    let mut acc = Acc {
        shift: &tile.shift[r.clone()],
        s1: [&mut s1e[r.clone()], &mut s1o[r.clone()]],
        s2: [&mut s2e[r.clone()], &mut s2o[r.clone()]],
        s3: &mut tile.s3[r.clone()],
        s4: &mut tile.s4[r.clone()],
        vn: &mut tile.vn[r.clone()],
        prev: &mut tile.prev[r.clone()],
        max: &mut tile.max[r],
    };
    let mut c = 0;
    while c + W <= n {
        chunk::<W>(&mut acc, c, rows, count, parity);
        c += W;
    }
    while c < n {
        chunk::<1>(&mut acc, c, rows, count, parity);
        c += 1;
    }
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
fn chunk<const W: usize>(acc: &mut Acc, c: usize, rows: &[f64], count: usize, parity: usize) {
    let ld = |v: &[f64]| -> [f64; W] { v[c..c + W].try_into().expect("W pixels") };
    let (mut s1e, mut s1o) = (ld(acc.s1[0]), ld(acc.s1[1]));
    let (mut s2e, mut s2o) = (ld(acc.s2[0]), ld(acc.s2[1]));
    let mut p = Shared {
        shift: ld(acc.shift),
        s3: ld(acc.s3),
        s4: ld(acc.s4),
        vn: ld(acc.vn),
        prev: ld(acc.prev),
        max: ld(acc.max),
    };
    let row = |j: usize| -> &[f64; W] {
        rows[j * SUB + c..j * SUB + c + W]
            .try_into()
            .expect("W pixels")
    };
    let mut j = 0;
    if parity == 1 && count > 0 {
        step(row(0), &mut s1o, &mut s2o, &mut p);
        j = 1;
    }
    while j + 1 < count {
        step(row(j), &mut s1e, &mut s2e, &mut p);
        step(row(j + 1), &mut s1o, &mut s2o, &mut p);
        j += 2;
    }
    if j < count {
        step(row(j), &mut s1e, &mut s2e, &mut p);
    }
    let st = |v: &mut [f64], x: [f64; W]| v[c..c + W].copy_from_slice(&x);
    st(acc.s1[0], s1e);
    st(acc.s1[1], s1o);
    st(acc.s2[0], s2e);
    st(acc.s2[1], s2o);
    st(acc.s3, p.s3);
    st(acc.s4, p.s4);
    st(acc.vn, p.vn);
    st(acc.prev, p.prev);
    st(acc.max, p.max);
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::io::RawKind;

    /// Samples of a 300-pixel, 11-frame stack: integers with a large offset, some pixels
    /// constant, one with a jump.
    fn sample(k: usize, i: usize) -> f64 {
        let noise = ((k * 7919 + i * 104_729) % 23) as f64 - 11.0;
        let jump = if i == 5 && k > 6 { 5000.0 } else { 0.0 };
        if i % 50 == 3 {
            40_000.0
        } else {
            30_000.0 + (i % 17) as f64 + noise + jump
        }
    }

    /// The sums of `tile` computed one sample at a time, the obvious way.
    fn reference(len: usize, frames: usize) -> Tile {
        let mut t = Tile::new(0, len, 0);
        for i in 0..len {
            t.shift[i] = sample(0, i);
            for k in 0..frames {
                let x = sample(k, i);
                let d = x - t.shift[i];
                t.s1[k % 2][i] += d;
                t.s2[k % 2][i] += d * d;
                t.s3[i] += d * d * d;
                t.s4[i] += d * d * d * d;
                if k > 0 {
                    let e = x - sample(k - 1, i);
                    t.vn[i] += e * e;
                }
                t.max[i] = t.max[i].max(x);
            }
            t.prev[i] = sample(frames - 1, i);
        }
        t
    }

    fn same(a: &Tile, b: &Tile) {
        assert_eq!(a.shift, b.shift);
        assert_eq!(a.s1, b.s1);
        assert_eq!(a.s2, b.s2);
        assert_eq!(a.s3, b.s3);
        assert_eq!(a.s4, b.s4);
        assert_eq!(a.vn, b.vn);
        assert_eq!(a.prev, b.prev);
        assert_eq!(a.max, b.max);
    }

    /// Sweep 11 frames in batches of 4, 4 and 3 (odd first frames included) with `run`.
    fn swept(len: usize, raw: bool, run: impl Fn(&mut Tile, &[FrameView], usize)) -> Tile {
        let layout = RawLayout {
            kind: RawKind::I16,
            big_endian: true,
            scale: 1.0,
            zero: 32768.0,
        };
        let values: Vec<Vec<f64>> = (0..11)
            .map(|k| (0..len).map(|i| sample(k, i)).collect())
            .collect();
        let bytes: Vec<Vec<u8>> = values
            .iter()
            .map(|f| {
                f.iter()
                    .flat_map(|x| ((*x - 32768.0) as i16).to_be_bytes())
                    .collect()
            })
            .collect();
        let mut t = Tile::new(0, len, 0);
        for first in [0, 4, 8] {
            let views: Vec<FrameView> = (first..(first + 4).min(11))
                .map(|k| match raw {
                    true => FrameView::Raw(&bytes[k], layout),
                    false => FrameView::Values(&values[k]),
                })
                .collect();
            run(&mut t, &views, first);
        }
        t
    }

    #[test]
    fn every_vector_width_gives_the_sums_of_the_obvious_loop() {
        // 300 pixels: a full block of 256 and a tail that is not a multiple of any width.
        let want = reference(300, 11);
        for raw in [false, true] {
            same(&swept(300, raw, |t, v, k| sweep(t, v, k, true, 0)), &want);
            same(
                &swept(300, raw, |t, v, k| sweep_w::<1>(t, v, k, true, 0)),
                &want,
            );
            same(
                &swept(300, raw, |t, v, k| sweep_w::<4>(t, v, k, true, 0)),
                &want,
            );
            same(
                &swept(300, raw, |t, v, k| sweep_w::<16>(t, v, k, true, 0)),
                &want,
            );
            #[cfg(target_arch = "x86_64")]
            {
                if std::arch::is_x86_feature_detected!("avx2") {
                    // SAFETY: the CPU supports AVX2.
                    let t = swept(300, raw, |t, v, k| unsafe { sweep_avx2(t, v, k, true, 0) });
                    same(&t, &want);
                }
                if std::arch::is_x86_feature_detected!("avx512f") {
                    // SAFETY: the CPU supports AVX-512F.
                    let t = swept(300, raw, |t, v, k| unsafe {
                        sweep_avx512(t, v, k, true, 0)
                    });
                    same(&t, &want);
                }
            }
        }
    }
}
