//! The kernel against the obvious loop, for every vector width and both frame kinds.

use super::*;
use crate::calib::darks::lines::{LineAcc, LineVariances, TileLines};
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
    reference_of(len, frames, sample)
}

/// [`reference`] of the stack `sample(frame, pixel)`.
fn reference_of(len: usize, frames: usize, sample: impl Fn(usize, usize) -> f64) -> Tile {
    let mut t = Tile::new(0, len, 0);
    t.widen();
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

/// 11 frames of `len` pixels: values, and their stored bytes (16-bit, big-endian).
fn frames(len: usize) -> (Vec<Vec<f64>>, Vec<Vec<u8>>, RawLayout) {
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
    (values, bytes, layout)
}

/// Sweep 11 frames in batches of 4, 4 and 3 (odd first frames included) with `run`.
fn swept(len: usize, raw: bool, run: impl Fn(&mut Tile, &[FrameView], usize)) -> Tile {
    let (values, bytes, layout) = frames(len);
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
    t.widen();
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

/// The row and column variances of 11 frames of `shape` cut into tiles of `tile` pixels
/// (with their line shares), swept in batches of 4, 4 and 3 by `run`, from stored bytes or
/// from values.
fn line_variances(
    shape: (usize, usize),
    tile: usize,
    raw: bool,
    run: impl Fn(&mut Tile, &[FrameView], usize),
) -> (LineVariances, Vec<Tile>) {
    let npix = shape.0 * shape.1;
    let (values, bytes, layout) = frames(npix);
    let mut tiles: Vec<Tile> = (0..npix.div_ceil(tile))
        .map(|t| {
            let (start, len) = (t * tile, tile.min(npix - t * tile));
            let mut tile = Tile::new(start, len, 0);
            tile.lines = Some(TileLines::new(start, len, shape.1));
            tile
        })
        .collect();
    let mut acc = LineAcc::new(shape);
    for first in [0, 4, 8] {
        let views: Vec<FrameView> = (first..(first + 4).min(11))
            .map(|k| match raw {
                true => FrameView::Raw(&bytes[k], layout),
                false => FrameView::Values(&values[k]),
            })
            .collect();
        for t in &mut tiles {
            run(t, &views, first);
        }
        let shares: Vec<&TileLines> = tiles.iter().filter_map(|t| t.lines.as_ref()).collect();
        acc.add_batch(views.len(), &shares);
    }
    tiles.iter_mut().for_each(Tile::widen);
    (acc.finish(), tiles)
}

#[test]
fn integer_frames_give_the_line_sums_of_decoded_ones() {
    // Frames 9 x 37: tiles shorter than a row (some wrapping from one row into the next), a
    // row long, spanning rows from mid-row, the whole frame; stored integers take the fused
    // sweep, whose line shares are integer sums frame by frame, decoded frames the other
    // sweep, which adds values block by block: the same sums, bit for bit.
    let shape = (9, 37);
    for tile in [5, 20, 37, 50, 333] {
        let (want, want_tiles) =
            line_variances(shape, tile, false, |t, v, k| sweep(t, v, k, true, 0));
        assert_eq!(want.frames, 11);
        assert!(want.row_var_adu2.iter().all(|v| *v > 0.0));
        for width in [0, 1, 4, 16] {
            let (got, tiles) = line_variances(shape, tile, true, |t, v, k| match width {
                0 => sweep(t, v, k, true, 0),
                1 => sweep_w::<1>(t, v, k, true, 0),
                4 => sweep_w::<4>(t, v, k, true, 0),
                _ => sweep_w::<16>(t, v, k, true, 0),
            });
            assert_eq!(got, want, "tile {tile}, width {width}");
            for (a, b) in tiles.iter().zip(&want_tiles) {
                same(a, b);
            }
        }
    }
}

/// The stored bytes of `values` in `layout` (integers of its kind less its zero).
fn stored(values: &[f64], layout: RawLayout) -> Vec<u8> {
    let int = |x: &f64| x - layout.zero;
    match (layout.kind, layout.big_endian) {
        (RawKind::U8, _) => values.iter().map(|x| int(x) as u8).collect(),
        (RawKind::I16, true) => values
            .iter()
            .flat_map(|x| (int(x) as i16).to_be_bytes())
            .collect(),
        (RawKind::I16, false) => values
            .iter()
            .flat_map(|x| (int(x) as i16).to_le_bytes())
            .collect(),
        _ => unreachable!("8- and 16-bit layouts only"),
    }
}

#[test]
fn layouts_changing_between_batches_give_the_sums_of_the_obvious_loop() {
    // A stack of several files: each batch of 4, 4 and 3 frames in its own layout. A tile
    // seeded by 8-bit samples keeps its shifts, previous samples and maxima as 16-bit
    // offsets (`Narrow`) while later layouts fit them (another zero: an offset), and turns
    // them into values when one does not (16-bit samples with another zero) or when a batch
    // of values comes.
    let small =
        |k: usize, i: usize| 100.0 + (i % 17) as f64 + ((k * 7919 + i * 104_729) % 23) as f64;
    let want = reference_of(300, 11, small);
    let values: Vec<Vec<f64>> = (0..11)
        .map(|k| (0..300).map(|i| small(k, i)).collect())
        .collect();
    let layout = |kind, big_endian, zero| RawLayout {
        kind,
        big_endian,
        scale: 1.0,
        zero,
    };
    let u8_at_50 = layout(RawKind::U8, false, 50.0);
    let u8_at_0 = layout(RawKind::U8, false, 0.0);
    let i16_le_at_0 = layout(RawKind::I16, false, 0.0);
    let i16_be_at_7 = layout(RawKind::I16, true, 7.0);
    let cases: [([Option<RawLayout>; 3], bool); 5] = [
        ([Some(u8_at_50), Some(u8_at_0), Some(u8_at_50)], true),
        ([Some(u8_at_50), Some(u8_at_0), Some(i16_le_at_0)], false),
        (
            [Some(i16_le_at_0), Some(i16_le_at_0), Some(i16_be_at_7)],
            false,
        ),
        ([Some(i16_be_at_7), Some(u8_at_0), None], false),
        ([None, Some(u8_at_0), Some(u8_at_50)], false),
    ];
    for (layouts, narrow) in cases {
        let bytes: Vec<Vec<u8>> = (0..11)
            .map(|k| match layouts[k / 4] {
                Some(l) => stored(&values[k], l),
                None => Vec::new(),
            })
            .collect();
        for width in [0, 1, 4, 16] {
            let mut t = Tile::new(0, 300, 0);
            for first in [0, 4, 8] {
                let views: Vec<FrameView> = (first..(first + 4).min(11))
                    .map(|k| match layouts[k / 4] {
                        Some(l) => FrameView::Raw(&bytes[k], l),
                        None => FrameView::Values(&values[k]),
                    })
                    .collect();
                match width {
                    0 => sweep(&mut t, &views, first, true, 0),
                    1 => sweep_w::<1>(&mut t, &views, first, true, 0),
                    4 => sweep_w::<4>(&mut t, &views, first, true, 0),
                    _ => sweep_w::<16>(&mut t, &views, first, true, 0),
                }
            }
            assert_eq!(t.narrow.is_some(), narrow, "{layouts:?}");
            t.widen();
            same(&t, &want);
        }
    }
}
