//! Shot noise of a frame: independent Poisson photo-electron counts per pixel.
//!
//! At low light most pixels receive nothing, so rather than a Poisson draw per pixel the frame
//! draws its total N ~ Poisson(sum of means) and places the N photo-electrons one by one with
//! probabilities proportional to the pixel means (a guide table over their cumulative sums).
//! The two are the same distribution: a Poisson total split multinomially gives independent
//! Poisson counts. Placement costs O(photons + pixels) with a small constant, a draw per pixel
//! O(pixels) with an exponential each; the cheaper one is chosen from the mean total.

use crate::rng::SimRng;
use crate::stats::{poisson, poisson_each};
use rand::RngExt;

/// Mean photo-electrons per pixel up to which photons are placed (above, drawn per pixel):
/// placing one costs a few ns, a per-pixel draw ten or more.
const PLACE_UP_TO_PER_PIXEL: f64 = 2.0;

/// Largest mean total whose Poisson distribution is tabulated (exp(-500) is still normal).
const TABLE_MAX_MEAN: f64 = 500.0;

/// Reusable scratch for shot noise on frames of one size.
#[derive(Debug, Clone)]
pub struct ShotNoise {
    cumulative: Vec<f64>,
    guide: Vec<u32>,
    totals: Option<PoissonTable>,
}

impl ShotNoise {
    /// Scratch for frames of `pixels` pixels.
    pub fn new(pixels: usize) -> Self {
        ShotNoise {
            cumulative: Vec::with_capacity(pixels),
            guide: Vec::with_capacity(pixels),
            totals: None,
        }
    }

    /// One Poisson(`mean`) total: by a table when every frame of a run has the same mean (the
    /// usual case: the spot is scaled to the signal), else drawn directly.
    fn total(&mut self, mean: f64, rng: &mut SimRng) -> u32 {
        if !(mean > 0.0 && mean <= TABLE_MAX_MEAN) {
            return poisson(mean, rng);
        }
        if self.totals.as_ref().is_none_or(|t| t.mean != mean) {
            self.totals = Some(PoissonTable::new(mean));
        }
        let table = self.totals.as_ref().expect("set above");
        table.sample(rng).unwrap_or_else(|| poisson(mean, rng))
    }

    /// Independent Poisson counts with means `expected` (e-, >= 0) into `out`, from `rng`.
    /// `total` is their sum as the run defines it (signal x QE, the same for every frame):
    /// the summed means differ from it in the last bits from frame to frame, and it keys the
    /// table of Poisson totals, which is then built once per run.
    pub fn draw(&mut self, expected: &[f64], total: f64, rng: &mut SimRng, out: &mut [u32]) {
        if total <= PLACE_UP_TO_PER_PIXEL * expected.len() as f64 {
            self.place(expected, total, rng, out);
        } else {
            poisson_each(expected, rng, out);
        }
    }

    /// Fill `guide` (one entry per pixel) from `cumulative` scaled by `scale` (buckets per
    /// unit of the cumulative sum): guide\[g\] counts the pixels whose scaled cumulative sum has
    /// an integer part below g. Rounding is monotone, so each of them has a cumulative sum
    /// below every deviate u with floor(u x scale) = g: the search from guide\[g\] starts at or
    /// before the answer and finds the same pixel as a search from 0. The pixels' buckets
    /// g_p = floor(c_p x scale) + 1 never decrease with p, so the count for g is the largest
    /// p + 1 with g_p <= g: each pixel stores p + 1 at its bucket (a later pixel of the same
    /// bucket overwrites), then a running maximum fills the buckets between. Plain stores and
    /// no data-dependent branches: a histogram's increments of one bucket wait on each other
    /// through memory, and a merge mispredicts an exit per bucket.
    fn build_guide(&mut self, scale: f64) {
        let buckets = self.cumulative.len();
        self.guide.clear();
        self.guide.resize(buckets + 1, 0);
        let guide = &mut self.guide[..=buckets];
        for (p, &c) in self.cumulative.iter().enumerate() {
            // c <= the last sum, so 0 <= c x scale <= buckets (up to rounding): truncation is
            // its integer part (as u32: one conversion instruction, where as usize takes five).
            let g = ((c * scale) as u32 as usize + 1).min(buckets);
            guide[g] = p as u32 + 1;
        }
        let mut below = 0;
        for slot in &mut self.guide[..buckets] {
            below = below.max(*slot);
            *slot = below.min(buckets as u32 - 1);
        }
    }

    /// A Poisson(`total`) total placed multinomially.
    fn place(&mut self, expected: &[f64], total: f64, rng: &mut SimRng, out: &mut [u32]) {
        out.fill(0);
        let acc = running_sums(expected, &mut self.cumulative);
        let photons = self.total(total, rng);
        if photons == 0 || acc <= 0.0 {
            return;
        }
        // Placement uses the sum as accumulated here, so every deviate lands on a pixel.
        let buckets = expected.len();
        let scale = buckets as f64 / acc;
        self.build_guide(scale);
        for _ in 0..photons {
            let u = rng.random::<f64>() * acc;
            out[self.pixel_of(u, scale)] += 1;
        }
    }

    /// The first pixel whose cumulative sum exceeds `u` (the last pixel if none does),
    /// searched from the guide's entry for `u`.
    #[inline]
    fn pixel_of(&self, u: f64, scale: f64) -> usize {
        let buckets = self.cumulative.len();
        let mut p = self.guide[((u * scale) as u32 as usize).min(buckets - 1)] as usize;
        // Pixels with zero mean have the same cumulative sum as their predecessor, so `<=`
        // skips them: they never receive a photon.
        while p + 1 < buckets && self.cumulative[p] <= u {
            p += 1;
        }
        p
    }
}

/// The running sums of `values` (>= 0) into `sums`, and the last (0 for none). Taken four at a
/// time: a block's partial sums are formed on their own and the sum before the block added to
/// each, so that one addition per block, not per value, waits on the one before (a plain
/// running sum costs an addition's latency per value). The sums never decrease (the base plus
/// a non-decreasing partial sum, rounded monotonically), and a zero value repeats the sum
/// before it exactly, so a pixel of zero mean is never chosen. They differ from a plain
/// running sum by rounding only.
fn running_sums(values: &[f64], sums: &mut Vec<f64>) -> f64 {
    sums.clear();
    let mut base = 0.0;
    let mut blocks = values.chunks_exact(4);
    for v in &mut blocks {
        let (p1, p2, p3) = (v[0] + v[1], v[0] + v[1] + v[2], v[0] + v[1] + v[2] + v[3]);
        let block = [base + v[0], base + p1, base + p2, base + p3];
        sums.extend(block);
        base = block[3];
    }
    for &v in blocks.remainder() {
        base += v;
        sums.push(base);
    }
    base
}

/// Inverse-CDF table of one Poisson distribution, with a guide over the uniform deviate.
#[derive(Debug, Clone)]
struct PoissonTable {
    mean: f64,
    cdf: Vec<f64>,
    guide: Vec<u32>,
}

impl PoissonTable {
    /// Buckets of the guide: the search from a bucket's start takes one or two steps.
    const GUIDE: usize = 256;

    /// Table of Poisson(`mean`), 0 < mean <= [`TABLE_MAX_MEAN`], out to 12 standard
    /// deviations past the mean (the mass beyond, < 1e-30, is drawn directly).
    fn new(mean: f64) -> Self {
        let last = (mean + 12.0 * mean.sqrt() + 20.0).ceil() as usize;
        let mut cdf = Vec::with_capacity(last + 1);
        let (mut p, mut acc) = ((-mean).exp(), 0.0);
        for k in 0..=last {
            acc += p;
            cdf.push(acc);
            p *= mean / (k + 1) as f64;
        }
        let mut guide = Vec::with_capacity(Self::GUIDE);
        let mut k = 0;
        for g in 0..Self::GUIDE {
            let u = g as f64 / Self::GUIDE as f64;
            while k < last && cdf[k] <= u {
                k += 1;
            }
            guide.push(k as u32);
        }
        PoissonTable { mean, cdf, guide }
    }

    /// One draw by inversion (the smallest k with CDF(k) > u, as the direct sampler does),
    /// or None for the far tail beyond the table.
    fn sample(&self, rng: &mut SimRng) -> Option<u32> {
        let u: f64 = rng.random();
        let mut k = self.guide[((u * Self::GUIDE as f64) as usize).min(Self::GUIDE - 1)] as usize;
        while self.cdf[k] <= u {
            k += 1;
            if k == self.cdf.len() {
                return None;
            }
        }
        Some(k as u32)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rng::stream;

    /// Per-pixel means and variances of `frames` draws, and the covariance of pixels 0 and 1.
    fn moments(expected: &[f64], frames: usize) -> (Vec<f64>, Vec<f64>, f64) {
        let total: f64 = expected.iter().sum();
        let mut shot = ShotNoise::new(expected.len());
        let mut rng = stream(11, 0, 0);
        let mut out = vec![0u32; expected.len()];
        let (mut s, mut s2) = (vec![0.0; out.len()], vec![0.0; out.len()]);
        let mut s01 = 0.0;
        for _ in 0..frames {
            shot.draw(expected, total, &mut rng, &mut out);
            for ((a, b), &k) in s.iter_mut().zip(s2.iter_mut()).zip(&out) {
                *a += k as f64;
                *b += (k as f64).powi(2);
            }
            s01 += out[0] as f64 * out[1] as f64;
        }
        let f = frames as f64;
        let means: Vec<f64> = s.iter().map(|a| a / f).collect();
        let vars = s2.iter().zip(&means).map(|(b, m)| b / f - m * m).collect();
        (means.clone(), vars, s01 / f - means[0] * means[1])
    }

    #[test]
    fn counts_are_independent_poisson_in_both_regimes() {
        // Mean = variance = lambda per pixel, no covariance: SE(mean) = sqrt(lambda / N),
        // SE(var) = lambda sqrt((2 + 1/lambda) / N), SE(cov) = sqrt(l0 l1 / N); 4 SE. A pixel of
        // mean 0 never receives a photon. Totals 4.35 (placed) and 435 (per pixel) on 6 pixels.
        let frames = 200_000;
        for scale in [1.0, 100.0] {
            let expected: Vec<f64> = [0.05, 1.2, 0.0, 2.5, 0.3, 0.3]
                .iter()
                .map(|l| l * scale)
                .collect();
            let (means, vars, cov) = moments(&expected, frames);
            let n = frames as f64;
            for ((&l, m), v) in expected.iter().zip(&means).zip(&vars) {
                if l == 0.0 {
                    assert_eq!((*m, *v), (0.0, 0.0));
                    continue;
                }
                assert!((m - l).abs() < 4.0 * (l / n).sqrt(), "{l}: mean {m}");
                let se_v = l * ((2.0 + 1.0 / l) / n).sqrt();
                assert!((v - l).abs() < 4.0 * se_v, "{l}: var {v}");
            }
            let se_cov = (expected[0] * expected[1] / n).sqrt();
            assert!(cov.abs() < 4.0 * se_cov, "cov {cov} (se {se_cov})");
        }
    }

    #[test]
    fn tabulated_totals_are_poisson() {
        // Mean, variance and P(0) of the tabulated totals: SE(mean) = sqrt(m / N), SE(var) =
        // m sqrt((2 + 1/m) / N), SE(P0) = sqrt(P0 (1 - P0) / N); 4 SE.
        let n = 200_000;
        for mean in [0.3, 4.5, 45.0, 480.0] {
            let table = PoissonTable::new(mean);
            let mut rng = stream(3, 0, 0);
            let xs: Vec<f64> = (0..n)
                .map(|_| table.sample(&mut rng).expect("tail beyond 12 sd") as f64)
                .collect();
            let (m, v) = crate::stats::mean_var(&xs);
            let nf = n as f64;
            assert!(
                (m - mean).abs() < 4.0 * (mean / nf).sqrt(),
                "{mean}: mean {m}"
            );
            let se_v = mean * ((2.0 + 1.0 / mean) / nf).sqrt();
            assert!((v - mean).abs() < 4.0 * se_v, "{mean}: var {v}");
            let p0 = (-mean).exp();
            let f0 = xs.iter().filter(|x| **x == 0.0).count() as f64 / nf;
            assert!((f0 - p0).abs() <= 4.0 * (p0 * (1.0 - p0) / nf).sqrt() + 1e-12);
        }
    }

    #[test]
    fn the_guide_finds_the_pixel_a_full_search_finds() {
        // Random means (a third of them 0) over 1-300 pixels; deviates at random, at every
        // cumulative sum and one ulp either side: the guided search equals the plain one.
        use rand::RngExt;
        let mut rng = stream(5, 0, 0);
        let mut shot = ShotNoise::new(1);
        for _ in 0..300 {
            let n = rng.random_range(1..300);
            let expected: Vec<f64> = (0..n)
                .map(|_| match rng.random_range(0..3) {
                    0 => 0.0,
                    _ => rng.random::<f64>() * 3.0,
                })
                .collect();
            let acc = running_sums(&expected, &mut shot.cumulative);
            if acc <= 0.0 {
                continue;
            }
            let scale = n as f64 / acc;
            shot.build_guide(scale);
            let plain = |u: f64| shot.cumulative.iter().position(|c| *c > u).unwrap_or(n - 1);
            let at_sums = shot
                .cumulative
                .iter()
                .flat_map(|&c| [c, c.next_down(), c.next_up()]);
            let random: Vec<f64> = (0..200).map(|_| rng.random::<f64>() * acc).collect();
            for u in at_sums.chain(random).filter(|u| (0.0..acc).contains(u)) {
                assert_eq!(shot.pixel_of(u, scale), plain(u), "u {u} of {acc}, {n} px");
            }
        }
    }

    #[test]
    fn running_sums_never_decrease_repeat_at_zeros_and_round_like_plain_sums() {
        // Lengths 0-40 (whole blocks of four and remainders), a third of the values 0: each sum
        // is at least the one before, equal to it after a 0, and within rounding of the plain
        // running sum (both add at most 40 values >= 0, each within 40 eps x their sum of the
        // exact sum, so within 80 eps of each other); the last is returned.
        use rand::RngExt;
        let mut rng = stream(6, 0, 0);
        let mut sums = Vec::new();
        for _ in 0..500 {
            let n = rng.random_range(0..=40);
            let values: Vec<f64> = (0..n)
                .map(|_| match rng.random_range(0..3) {
                    0 => 0.0,
                    _ => rng.random::<f64>() * 3.0,
                })
                .collect();
            let last = running_sums(&values, &mut sums);
            assert_eq!(sums.len(), n);
            assert_eq!(last, sums.last().copied().unwrap_or(0.0));
            let mut plain = 0.0;
            for (i, (&s, &v)) in sums.iter().zip(&values).enumerate() {
                plain += v;
                let before = if i == 0 { 0.0 } else { sums[i - 1] };
                assert!(s >= before, "sum {i} decreased");
                if v == 0.0 {
                    assert_eq!(s, before, "a zero at {i} moved the sum");
                }
                assert!(
                    (s - plain).abs() <= 2.0 * 40.0 * f64::EPSILON * plain,
                    "{s} vs {plain}"
                );
            }
        }
    }

    #[test]
    fn an_empty_frame_gets_no_photons() {
        let mut shot = ShotNoise::new(4);
        let mut out = vec![7u32; 4];
        shot.draw(&[0.0; 4], 0.0, &mut stream(1, 0, 0), &mut out);
        assert_eq!(out, [0; 4]);
    }
}
