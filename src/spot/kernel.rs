//! The bicubic interpolation kernel of the pixel table. In one quadrant about the spot centre
//! the weights are fixed, and each pixel combines 4 x 4 nodes (x-nodes contiguous, y-nodes
//! `stride` apart) as v = (sum_b wy_b t_b) . wx, the dot product summed as (p0 + p2) + (p1 + p3),
//! in f32, clamped at 0 (which the true integral never falls below). The x86_64 version runs on
//! SSE (part of every x86_64 CPU) and reads the nodes unchecked after one bounds check per run of
//! pixels; the portable twin does the same f32 operations in the same order, so the images are
//! the same on every machine (tested).

/// Fixed weights of one quadrant about the spot centre.
#[derive(Clone, Copy)]
pub(super) struct Kernel {
    #[cfg(any(test, not(target_arch = "x86_64")))]
    wy: [f32; 4],
    #[cfg(any(test, not(target_arch = "x86_64")))]
    wx: [f32; 4],
    /// The weights as SSE vectors (wy broadcast), made once per kernel.
    #[cfg(target_arch = "x86_64")]
    vectors: sse::Weights,
}

/// A run of pixels in a table: pixel i has its x-nodes at `first + i step .. + 4` and its
/// y-nodes `stride` apart.
#[derive(Clone, Copy)]
pub(super) struct Run {
    /// Index of the first pixel's first node.
    pub first: usize,
    /// Distance between successive pixels.
    pub step: usize,
    /// Distance between y-nodes.
    pub stride: usize,
    /// Pixels.
    pub count: usize,
}

impl Kernel {
    /// Kernel of y-weights `wy` and x-weights `wx` (cubic Lagrange, nodes -1, 0, 1, 2).
    pub(super) fn new(wy: [f32; 4], wx: [f32; 4]) -> Self {
        Kernel {
            #[cfg(any(test, not(target_arch = "x86_64")))]
            wy,
            #[cfg(any(test, not(target_arch = "x86_64")))]
            wx,
            #[cfg(target_arch = "x86_64")]
            vectors: sse::Weights::new(wy, wx),
        }
    }

    /// Interpolate the pixels of `run` in `values` into `out`, in order (as many as both hold).
    /// Panics if the run reaches past the end of `values`.
    #[inline(always)]
    pub(super) fn fill<'o>(
        &self,
        values: &[f32],
        run: Run,
        out: &mut impl Iterator<Item = &'o mut f64>,
    ) {
        if run.count == 0 {
            return;
        }
        // Pixel i < count reads values[first + b stride + i step + a] for a, b <= 3: all below
        // `end` (computed without overflow), hence inside `values` once checked.
        let end = (run.count - 1)
            .checked_mul(run.step)
            .and_then(|x| x.checked_add(run.stride.checked_mul(3)?))
            .and_then(|x| x.checked_add(run.first.checked_add(4)?));
        assert!(
            end.is_some_and(|end| end <= values.len()),
            "a run of pixels inside the table"
        );
        let mut i = 0;
        while i + 1 < run.count {
            let [a, b] = self.two(values, run, i);
            let (Some(oa), Some(ob)) = (out.next(), out.next()) else {
                return;
            };
            (*oa, *ob) = (a, b);
            i += 2;
        }
        if i < run.count {
            if let Some(o) = out.next() {
                *o = self.one(values, run, i);
            }
        }
    }

    /// Pixel `i < run.count` of a run checked by `fill`.
    #[inline(always)]
    fn one(&self, values: &[f32], run: Run, i: usize) -> f64 {
        #[cfg(target_arch = "x86_64")]
        {
            // SAFETY: `fill` checked that the run lies inside `values`.
            unsafe { sse::one(&self.vectors, values.as_ptr(), run, i) }
        }
        #[cfg(not(target_arch = "x86_64"))]
        {
            self.one_portable(values, run, i)
        }
    }

    /// Pixels `i` and `i + 1 < run.count` of a run checked by `fill`.
    #[inline(always)]
    fn two(&self, values: &[f32], run: Run, i: usize) -> [f64; 2] {
        #[cfg(target_arch = "x86_64")]
        {
            // SAFETY: `fill` checked that the run lies inside `values`.
            unsafe { sse::two(&self.vectors, values.as_ptr(), run, i) }
        }
        #[cfg(not(target_arch = "x86_64"))]
        {
            [
                self.one_portable(values, run, i),
                self.one_portable(values, run, i + 1),
            ]
        }
    }

    #[cfg(any(test, not(target_arch = "x86_64")))]
    fn one_portable(&self, values: &[f32], run: Run, i: usize) -> f64 {
        let at = run.first + i * run.step;
        let t: [&[f32]; 4] = std::array::from_fn(|b| &values[at + b * run.stride..][..4]);
        let (wy, wx) = (&self.wy, &self.wx);
        let p: [f32; 4] = std::array::from_fn(|a| {
            (((t[0][a] * wy[0] + t[1][a] * wy[1]) + t[2][a] * wy[2]) + t[3][a] * wy[3]) * wx[a]
        });
        let sum = (p[0] + p[2]) + (p[1] + p[3]);
        f64::from(if sum > 0.0 { sum } else { 0.0 })
    }
}

#[cfg(target_arch = "x86_64")]
mod sse {
    use super::Run;
    use std::arch::x86_64::*;

    /// A kernel's weights: wy_b in every lane, and wx.
    #[derive(Clone, Copy)]
    pub(super) struct Weights {
        wy: [__m128; 4],
        wx: __m128,
    }

    impl Weights {
        pub(super) fn new(wy: [f32; 4], wx: [f32; 4]) -> Self {
            // SSE is part of x86_64. (Its intrinsics are safe to call from Rust 1.87 on: the
            // blocks are for older compilers.)
            #[allow(unused_unsafe)]
            unsafe {
                Weights {
                    wy: wy.map(|w| _mm_set1_ps(w)),
                    wx: _mm_loadu_ps(wx.as_ptr()),
                }
            }
        }
    }

    /// The products p_a = (sum_b wy_b t_ba) wx_a of pixel `i` of `run`.
    ///
    /// # Safety
    /// `values` points to at least `run.first + 3 run.stride + i run.step + 4` f32.
    #[inline(always)]
    unsafe fn products(w: &Weights, values: *const f32, run: Run, i: usize) -> __m128 {
        let at = values.add(run.first + i * run.step);
        let row = |b: usize| _mm_mul_ps(_mm_loadu_ps(at.add(b * run.stride)), w.wy[b]);
        let acc = _mm_add_ps(_mm_add_ps(_mm_add_ps(row(0), row(1)), row(2)), row(3));
        _mm_mul_ps(acc, w.wx)
    }

    /// # Safety
    /// As for `products`.
    #[inline(always)]
    pub(super) unsafe fn one(w: &Weights, values: *const f32, run: Run, i: usize) -> f64 {
        let p = products(w, values, run, i);
        // [p0 + p2, p1 + p3, ..], then lane 0 + lane 1.
        let pairs = _mm_add_ps(p, _mm_movehl_ps(p, p));
        let sum = _mm_add_ss(pairs, _mm_shuffle_ps::<0x55>(pairs, pairs));
        f64::from(_mm_cvtss_f32(_mm_max_ss(sum, _mm_setzero_ps())))
    }

    /// # Safety
    /// As for `products`, for pixel i + 1.
    #[inline(always)]
    pub(super) unsafe fn two(w: &Weights, values: *const f32, run: Run, i: usize) -> [f64; 2] {
        let (p, q) = (products(w, values, run, i), products(w, values, run, i + 1));
        // [p0 + p2, q0 + q2, p1 + p3, q1 + q3], then lanes 0 + 2 and 1 + 3.
        let pairs = _mm_add_ps(_mm_unpacklo_ps(p, q), _mm_unpackhi_ps(p, q));
        let sums = _mm_add_ps(pairs, _mm_movehl_ps(pairs, pairs));
        let clamped = _mm_max_ps(sums, _mm_setzero_ps());
        let mut out = [0.0; 2];
        _mm_storeu_pd(out.as_mut_ptr(), _mm_cvtps_pd(clamped));
        out
    }

    #[cfg(test)]
    mod tests {
        use super::super::Kernel;
        use super::Run;
        use rand::RngExt;

        #[test]
        fn sse_and_portable_kernels_agree_bit_for_bit() {
            let mut rng = crate::rng::stream(7, 0, 0);
            let v: Vec<f32> = (0..4096).map(|_| rng.random_range(-0.1..1.0)).collect();
            for _ in 0..2000 {
                let w = |rng: &mut crate::rng::SimRng| -> [f32; 4] {
                    std::array::from_fn(|_| rng.random_range(-0.2..1.2))
                };
                let k = Kernel::new(w(&mut rng), w(&mut rng));
                let run = Run {
                    first: rng.random_range(0..1000),
                    step: rng.random_range(4..40),
                    stride: rng.random_range(4..700),
                    count: rng.random_range(1..20),
                };
                let mut out = vec![0.0; run.count];
                k.fill(&v, run, &mut out.iter_mut());
                for (i, got) in out.iter().enumerate() {
                    assert_eq!(got.to_bits(), k.one_portable(&v, run, i).to_bits());
                }
            }
        }
    }
}
