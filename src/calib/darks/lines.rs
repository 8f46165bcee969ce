//! Row and column sums of every frame, streamed, for the temporal noise decomposition.
//!
//! The kernel adds each frame of a batch to its tile's share of the frame's row sums and
//! column sums ([`TileLines`]): stored integers frame by frame before its sweep
//! ([`TileLines::add_stored`]), other samples a block of decoded values at a time
//! ([`TileLines::add`]); after the batch the shares are added up
//! across tiles in tile order ([`LineAcc::add_batch`]) and every row's and column's sum goes
//! into per-line sums over frames (shifted by the line's first frame, as the per-pixel sums
//! are). Integer samples give integer sums, exact in any order while below 2^53. Memory: per
//! tile and frame of a batch, the rows it touches and up to a frame width of columns (for
//! frames at most [`TILE`](super::accumulate) pixels wide, one eighth of the batch's pixels
//! or less); per line three f64.

use rayon::prelude::*;

use super::tile::{mean_var, Sums};

/// One tile's share of the row and column sums of the frames of one batch.
pub(super) struct TileLines {
    /// Frame width (pixels).
    cols: usize,
    /// First pixel of the tile (frame index).
    start: usize,
    /// Pixels in the tile.
    len: usize,
    /// First row the tile touches.
    row0: usize,
    /// Rows the tile touches.
    rows: usize,
    /// Columns kept per frame: the tile's pixels when it is at most a row long (each in a
    /// column of its own), else every column.
    span: usize,
    /// Frames of the current batch.
    count: usize,
    /// Row sums, `rows` per frame, each in eight lanes.
    row_part: Vec<f64>,
    /// Column sums, `span` per frame.
    col_part: Vec<f64>,
    /// Pixels of the tile in each column share.
    col_count: Vec<u32>,
    /// Scratch: one frame's integer column sums.
    col_int: Vec<i32>,
}

impl TileLines {
    /// The shares of the tile of `len` pixels from `start` of frames `cols` pixels wide.
    pub(super) fn new(start: usize, len: usize, cols: usize) -> TileLines {
        let row0 = start / cols;
        let rows = (start + len.max(1) - 1) / cols - row0 + 1;
        let span = len.min(cols);
        let mut col_count = vec![0u32; span];
        for i in 0..len {
            col_count[if len <= cols { i } else { (start + i) % cols }] += 1;
        }
        TileLines {
            cols,
            start,
            len,
            row0,
            rows,
            span,
            count: 0,
            row_part: Vec::new(),
            col_part: Vec::new(),
            col_count,
            col_int: Vec::new(),
        }
    }

    /// Start a batch of `count` frames: row shares zero; column shares zero with
    /// `clear_cols`, else left to [`TileLines::add_stored`], which writes every one.
    pub(super) fn begin(&mut self, count: usize, clear_cols: bool) {
        self.count = count;
        self.row_part.clear();
        self.row_part.resize(count * self.rows * 8, 0.0);
        if clear_cols {
            self.col_part.clear();
        }
        self.col_part.resize(count * self.span, 0.0);
    }

    /// Add frame `j` of the batch from its stored integer samples of the tile (`bytes`, `N`
    /// bytes a sample, whose value is `int(sample) + zero`, `zero` an integer). The samples
    /// are added as integers, frame by frame and row by row, and each share takes its
    /// samples' `zero`s once: integer sums below 2^53, the same as adding the values in any
    /// order. (Inside the fused sweep, which holds every frame of the batch at once, each
    /// addition to a share was a load and a store per frame and vector of pixels: a quarter
    /// of the statistics' time.)
    #[inline(always)]
    pub(super) fn add_stored<const N: usize>(
        &mut self,
        j: usize,
        bytes: &[u8],
        zero: f64,
        int: impl Fn([u8; N]) -> i32,
    ) {
        // |sample| <= 2^15 and at most 2^15 samples a share keep every i32 sum in range.
        assert!(self.len <= 1 << 15 && bytes.len() == self.len * N);
        self.col_int.clear();
        self.col_int.resize(self.span, 0);
        let rows = &mut self.row_part[j * self.rows * 8..(j + 1) * self.rows * 8];
        let (mut p, end) = (self.start, self.start + self.len);
        while p < end {
            let r = p / self.cols;
            let seg_end = end.min((r + 1) * self.cols);
            let c = if self.len <= self.cols {
                p - self.start
            } else {
                p % self.cols
            };
            let seg = &bytes[(p - self.start) * N..(seg_end - self.start) * N];
            let mut total = 0i32;
            for (acc, b) in self.col_int[c..c + (seg_end - p)]
                .iter_mut()
                .zip(seg.chunks_exact(N))
            {
                let v = int(b.try_into().expect("N bytes"));
                *acc += v;
                total += v;
            }
            rows[(r - self.row0) * 8] = total as f64 + (seg_end - p) as f64 * zero;
            p = seg_end;
        }
        let cols = &mut self.col_part[j * self.span..(j + 1) * self.span];
        for ((d, s), n) in cols.iter_mut().zip(&self.col_int).zip(&self.col_count) {
            *d = *s as f64 + *n as f64 * zero;
        }
    }

    /// Add the samples `x` of tile-local pixels from `a` of frame `j` of the batch (inlined
    /// into the kernel, so that it is compiled with the kernel's vector instructions).
    #[inline(always)]
    pub(super) fn add(&mut self, a: usize, x: &[f64], j: usize) {
        let (mut p, end) = (self.start + a, self.start + a + x.len());
        let rows = &mut self.row_part[j * self.rows * 8..(j + 1) * self.rows * 8];
        let cols = &mut self.col_part[j * self.span..(j + 1) * self.span];
        while p < end {
            let r = p / self.cols;
            let seg_end = end.min((r + 1) * self.cols);
            let seg = &x[p - self.start - a..seg_end - self.start - a];
            let c = if self.len <= self.cols {
                p - self.start
            } else {
                p % self.cols
            };
            let lanes = &mut rows[(r - self.row0) * 8..(r - self.row0 + 1) * 8];
            add_and_sum(
                &mut cols[c..c + seg.len()],
                seg,
                lanes.try_into().expect("8 lanes"),
            );
            p = seg_end;
        }
    }

    /// Add this tile's shares of frame `j` to the frame's row sums `rows` and column sums
    /// `cols` (whole frame).
    fn add_to(&self, j: usize, rows: &mut [f64], cols: &mut [f64]) {
        let part = &self.row_part[j * self.rows * 8..(j + 1) * self.rows * 8];
        for (s, l) in rows[self.row0..self.row0 + self.rows]
            .iter_mut()
            .zip(part.chunks_exact(8))
        {
            *s += lanes_total(l);
        }
        let part = &self.col_part[j * self.span..(j + 1) * self.span];
        if self.len <= self.cols {
            // Tile pixel i is in column (start + i) % cols: at most two runs of columns.
            let c0 = self.start % self.cols;
            let first = (self.cols - c0).min(self.span);
            add_into(&mut cols[c0..c0 + first], &part[..first]);
            add_into(&mut cols[..self.span - first], &part[first..]);
        } else {
            add_into(cols, part);
        }
    }
}

/// Add `x` to `dst` element by element and its sum to the eight lanes `lanes` (lane i gets
/// the samples i mod 8, in two interleaved vectors; the order is fixed, so the result is
/// too, and the lanes are added up once per frame, not per block). Written with whole
/// eight-lane arrays so that the compiler keeps each in one vector register.
#[inline(always)]
fn add_and_sum(dst: &mut [f64], x: &[f64], lanes: &mut [f64; 8]) {
    #[inline(always)]
    fn add8(a: [f64; 8], b: &[f64; 8]) -> [f64; 8] {
        let mut r = [0.0; 8];
        for i in 0..8 {
            r[i] = a[i] + b[i];
        }
        r
    }
    let n = x.len();
    let dst = &mut dst[..n];
    let (mut a0, mut a1) = ([0.0f64; 8], [0.0f64; 8]);
    let whole = n / 16 * 16;
    let mut k = 0;
    while k < whole {
        let x0: &[f64; 8] = x[k..k + 8].try_into().expect("8 samples");
        let x1: &[f64; 8] = x[k + 8..k + 16].try_into().expect("8 samples");
        a0 = add8(a0, x0);
        a1 = add8(a1, x1);
        let d0: &mut [f64; 8] = (&mut dst[k..k + 8]).try_into().expect("8 sums");
        *d0 = add8(*d0, x0);
        let d1: &mut [f64; 8] = (&mut dst[k + 8..k + 16]).try_into().expect("8 sums");
        *d1 = add8(*d1, x1);
        k += 16;
    }
    *lanes = add8(*lanes, &add8(a0, &a1));
    for j in whole..n {
        dst[j] += x[j];
        lanes[j % 8] += x[j];
    }
}

/// Sum of eight lanes, in a fixed order.
fn lanes_total(l: &[f64]) -> f64 {
    ((l[0] + l[1]) + (l[2] + l[3])) + ((l[4] + l[5]) + (l[6] + l[7]))
}

/// `dst[i] += src[i]` (same lengths).
#[inline(always)]
fn add_into(dst: &mut [f64], src: &[f64]) {
    let n = dst.len().min(src.len());
    let (dst, src) = (&mut dst[..n], &src[..n]);
    for i in 0..n {
        dst[i] += src[i];
    }
}

/// Sums over frames of a set of lines' sums (rows, columns or the whole frame), each shifted
/// by its first frame's value.
#[derive(Clone, Debug, Default)]
struct LineSums {
    shift: Vec<f64>,
    s1: Vec<f64>,
    s2: Vec<f64>,
}

impl LineSums {
    fn new(n: usize) -> LineSums {
        LineSums {
            shift: vec![0.0; n],
            s1: vec![0.0; n],
            s2: vec![0.0; n],
        }
    }

    /// Add one frame's line sums `x` (the first frame sets the shifts).
    fn add(&mut self, x: &[f64], first: bool) {
        if first {
            self.shift.copy_from_slice(x);
        }
        for (i, v) in x.iter().enumerate() {
            let d = v - self.shift[i];
            self.s1[i] += d;
            self.s2[i] += d * d;
        }
    }

    /// Sample variance over `n` frames of each line's sum.
    fn variances(&self, n: usize) -> Vec<f64> {
        (0..self.s1.len())
            .map(|i| {
                mean_var(Sums {
                    n: n as f64,
                    shift: self.shift[i],
                    s1: self.s1[i],
                    s2: self.s2[i],
                })
                .1
            })
            .collect()
    }
}

/// The row and column sums of every frame of a stack, accumulated over frames.
#[derive(Clone, Debug)]
pub(super) struct LineAcc {
    shape: (usize, usize),
    rows: LineSums,
    cols: LineSums,
    frame: LineSums,
    frames: usize,
    /// Scratch: the row and column sums of the frames of a batch.
    row_buf: Vec<f64>,
    col_buf: Vec<f64>,
}

impl LineAcc {
    /// Sums for frames of `shape` (rows, cols).
    pub(super) fn new(shape: (usize, usize)) -> LineAcc {
        LineAcc {
            shape,
            rows: LineSums::new(shape.0),
            cols: LineSums::new(shape.1),
            frame: LineSums::new(1),
            frames: 0,
            row_buf: Vec::new(),
            col_buf: Vec::new(),
        }
    }

    /// Add the `count` frames of a batch from the shares of every tile (`tiles`, in tile
    /// order); frames are added up in parallel, then into the sums in order.
    pub(super) fn add_batch(&mut self, count: usize, tiles: &[&TileLines]) {
        let (rows, cols) = self.shape;
        self.row_buf.clear();
        self.row_buf.resize(count * rows, 0.0);
        self.col_buf.clear();
        self.col_buf.resize(count * cols, 0.0);
        self.row_buf
            .par_chunks_mut(rows)
            .zip(self.col_buf.par_chunks_mut(cols))
            .enumerate()
            .for_each(|(j, (r, c))| {
                for t in tiles {
                    t.add_to(j, r, c);
                }
            });
        for j in 0..count {
            let (r, c) = (
                &self.row_buf[j * rows..(j + 1) * rows],
                &self.col_buf[j * cols..(j + 1) * cols],
            );
            let first = self.frames == 0;
            let total = r.iter().sum::<f64>();
            self.rows.add(r, first);
            self.cols.add(c, first);
            self.frame.add(&[total], first);
            self.frames += 1;
        }
    }

    /// The variances over frames of the row, column and frame means.
    pub(super) fn finish(&self) -> LineVariances {
        let (rows, cols) = self.shape;
        let scale = |v: Vec<f64>, n: usize| -> Vec<f64> {
            let n2 = (n * n) as f64;
            v.into_iter().map(|x| x / n2).collect()
        };
        LineVariances {
            frames: self.frames,
            row_var_adu2: scale(self.rows.variances(self.frames), cols),
            col_var_adu2: scale(self.cols.variances(self.frames), rows),
            frame_var_adu2: scale(self.frame.variances(self.frames), rows * cols)[0],
        }
    }
}

/// Variances over frames of line means (adu^2): of each row's mean, of each column's mean,
/// and of the whole frame's mean.
#[derive(Clone, Debug, PartialEq)]
pub struct LineVariances {
    /// Frames accumulated.
    pub frames: usize,
    /// Per row: sample variance over frames of the row's mean (adu^2).
    pub row_var_adu2: Vec<f64>,
    /// Per column: sample variance over frames of the column's mean (adu^2).
    pub col_var_adu2: Vec<f64>,
    /// Sample variance over frames of the frame's mean (adu^2).
    pub frame_var_adu2: f64,
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Sample of frame `k` at (r, c): integers with row, column and frame structure.
    fn sample(k: usize, r: usize, c: usize) -> f64 {
        let h = ((k * 7919 + r * 104_729 + c * 1_299_709) % 97) as f64;
        1000.0 + h + ((k * 31 + r * 17) % 13) as f64 + ((k * 11 + c * 5) % 7) as f64
    }

    /// Variances the obvious way: line means per frame, then their sample variance.
    fn reference(shape: (usize, usize), frames: usize) -> LineVariances {
        let var = |x: &[f64]| {
            let n = x.len() as f64;
            let m = x.iter().sum::<f64>() / n;
            x.iter().map(|v| (v - m) * (v - m)).sum::<f64>() / (n - 1.0)
        };
        let (rows, cols) = shape;
        let row_mean = |k: usize, r: usize| (0..cols).map(|c| sample(k, r, c)).sum::<f64>();
        let col_mean = |k: usize, c: usize| (0..rows).map(|r| sample(k, r, c)).sum::<f64>();
        let rv = (0..rows)
            .map(|r| {
                let x: Vec<f64> = (0..frames).map(|k| row_mean(k, r) / cols as f64).collect();
                var(&x)
            })
            .collect();
        let cv = (0..cols)
            .map(|c| {
                let x: Vec<f64> = (0..frames).map(|k| col_mean(k, c) / rows as f64).collect();
                var(&x)
            })
            .collect();
        let f: Vec<f64> = (0..frames)
            .map(|k| (0..rows).map(|r| row_mean(k, r)).sum::<f64>() / (rows * cols) as f64)
            .collect();
        LineVariances {
            frames,
            row_var_adu2: rv,
            col_var_adu2: cv,
            frame_var_adu2: var(&f),
        }
    }

    fn close(a: &[f64], b: &[f64]) {
        assert_eq!(a.len(), b.len());
        for (x, y) in a.iter().zip(b) {
            assert!((x - y).abs() <= 1e-9 * y.abs().max(1e-3), "{x} vs {y}");
        }
    }

    #[test]
    fn tile_shares_add_up_to_the_line_variances_for_any_tiling() {
        // Frames 7 x 10 cut into tiles shorter than a row (wrapping rows), a row long and
        // longer than a row; blocks of 3 pixels inside each tile, 2 batches of frames.
        let shape = (7, 10);
        let frames = 9;
        let want = reference(shape, frames);
        for tile in [4, 10, 23, 70] {
            let npix = shape.0 * shape.1;
            let mut tiles: Vec<TileLines> = (0..npix.div_ceil(tile))
                .map(|t| TileLines::new(t * tile, tile.min(npix - t * tile), shape.1))
                .collect();
            let mut acc = LineAcc::new(shape);
            for batch in [0..5, 5..frames] {
                for t in &mut tiles {
                    t.begin(batch.len(), true);
                    for (j, k) in batch.clone().enumerate() {
                        for a in (0..t.len).step_by(3) {
                            let n = 3.min(t.len - a);
                            let x: Vec<f64> = (t.start + a..t.start + a + n)
                                .map(|p| sample(k, p / shape.1, p % shape.1))
                                .collect();
                            t.add(a, &x, j);
                        }
                    }
                }
                let refs: Vec<&TileLines> = tiles.iter().collect();
                acc.add_batch(batch.len(), &refs);
            }
            let got = acc.finish();
            assert_eq!(got.frames, frames);
            close(&got.row_var_adu2, &want.row_var_adu2);
            close(&got.col_var_adu2, &want.col_var_adu2);
            close(&[got.frame_var_adu2], &[want.frame_var_adu2]);
        }
    }

    /// The row and column sums of frame 0 of `t`'s shares, in a frame of `shape`.
    fn shares(t: &TileLines, shape: (usize, usize)) -> (Vec<f64>, Vec<f64>) {
        let (mut rows, mut cols) = (vec![0.0; shape.0], vec![0.0; shape.1]);
        t.add_to(0, &mut rows, &mut cols);
        (rows, cols)
    }

    /// Stored samples of `N` bytes (pseudo-random, every byte value) read as `int`, plus
    /// `zero`: the shares added as integers are those of the values, for any tiling.
    fn stored_like_values<const N: usize>(int: impl Fn([u8; N]) -> i32 + Copy, zero: f64) {
        let shape = (7, 10);
        let npix = shape.0 * shape.1;
        let bytes: Vec<u8> = (0..npix * N).map(|i| (i * 151 % 256) as u8).collect();
        let values: Vec<f64> = bytes
            .chunks_exact(N)
            .map(|b| int(b.try_into().unwrap()) as f64 + zero)
            .collect();
        for tile in [4, 10, 23, 70] {
            for start in (0..npix).step_by(tile) {
                let len = tile.min(npix - start);
                let mut want = TileLines::new(start, len, shape.1);
                want.begin(1, true);
                want.add(0, &values[start..start + len], 0);
                let mut got = TileLines::new(start, len, shape.1);
                got.begin(1, false);
                got.add_stored(0, &bytes[start * N..(start + len) * N], zero, int);
                assert_eq!(
                    shares(&got, shape),
                    shares(&want, shape),
                    "tile {tile} at {start}"
                );
            }
        }
    }

    #[test]
    fn stored_integers_give_the_line_shares_of_their_values() {
        stored_like_values(|b: [u8; 2]| i16::from_be_bytes(b) as i32, 32768.0);
        stored_like_values(|b: [u8; 2]| i16::from_le_bytes(b) as i32, 0.0);
        stored_like_values(|b: [u8; 2]| i16::from_le_bytes(b) as i32, -7.0);
        stored_like_values(|b: [u8; 1]| b[0] as i32, 0.0);
        stored_like_values(|b: [u8; 1]| b[0] as i32, -128.0);
    }

    #[test]
    fn add_and_sum_adds_and_sums() {
        for n in [0, 5, 32, 77] {
            let x: Vec<f64> = (0..n).map(|i| (i * i % 11) as f64).collect();
            let mut dst: Vec<f64> = (0..n).map(|i| i as f64).collect();
            let mut lanes = [1.0; 8];
            add_and_sum(&mut dst, &x, &mut lanes);
            assert_eq!(lanes_total(&lanes), 8.0 + x.iter().sum::<f64>());
            assert!(dst.iter().enumerate().all(|(i, d)| *d == i as f64 + x[i]));
        }
    }
}
