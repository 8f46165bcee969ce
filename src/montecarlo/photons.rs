//! Shot noise of a frame: independent Poisson photo-electron counts per pixel.
//!
//! At low light most pixels receive nothing, so rather than a Poisson draw per pixel the frame
//! draws its total N ~ Poisson(sum of means) and places the N photo-electrons one by one with
//! probabilities proportional to the pixel means (a guide table over their cumulative sums).
//! The two are the same distribution: a Poisson total split multinomially gives independent
//! Poisson counts. Placement costs O(photons + pixels) with a small constant, a draw per pixel
//! O(pixels) with an exponential each; the cheaper one is chosen from the mean total.

use crate::rng::SimRng;
use crate::stats::poisson;
use rand::RngExt;

/// Mean photo-electrons per pixel up to which photons are placed (above, drawn per pixel):
/// placing one costs a few ns, a per-pixel draw ten or more.
const PLACE_UP_TO_PER_PIXEL: f64 = 2.0;

/// Reusable scratch for shot noise on frames of one size.
#[derive(Debug, Clone)]
pub struct ShotNoise {
    cumulative: Vec<f64>,
    guide: Vec<u32>,
}

impl ShotNoise {
    /// Scratch for frames of `pixels` pixels.
    pub fn new(pixels: usize) -> Self {
        ShotNoise {
            cumulative: Vec::with_capacity(pixels),
            guide: Vec::with_capacity(pixels),
        }
    }

    /// Independent Poisson counts with means `expected` (e-, >= 0, summing to `total`) into
    /// `out`, from `rng`.
    pub fn draw(&mut self, expected: &[f64], total: f64, rng: &mut SimRng, out: &mut [u32]) {
        if total <= PLACE_UP_TO_PER_PIXEL * expected.len() as f64 {
            self.place(expected, rng, out);
        } else {
            for (k, &lambda) in out.iter_mut().zip(expected) {
                *k = poisson(lambda, rng);
            }
        }
    }

    /// A Poisson total placed multinomially.
    fn place(&mut self, expected: &[f64], rng: &mut SimRng, out: &mut [u32]) {
        out.fill(0);
        self.cumulative.clear();
        let mut acc = 0.0;
        self.cumulative.extend(expected.iter().map(|&e| {
            acc += e;
            acc
        }));
        // The total used is the sum as accumulated here, so placement and total agree exactly.
        let total = acc;
        let photons = poisson(total, rng);
        if photons == 0 {
            return;
        }
        // guide[g]: the first pixel whose cumulative sum exceeds g / G of the total.
        let buckets = expected.len();
        let scale = buckets as f64 / total;
        self.guide.clear();
        let mut p = 0;
        for g in 0..buckets {
            let u = g as f64 / scale;
            while p + 1 < buckets && self.cumulative[p] <= u {
                p += 1;
            }
            self.guide.push(p as u32);
        }
        for _ in 0..photons {
            let u = rng.random::<f64>() * total;
            let mut p = self.guide[((u * scale) as usize).min(buckets - 1)] as usize;
            // Pixels with zero mean have the same cumulative sum as their predecessor, so
            // `<=` skips them: they never receive a photon.
            while p + 1 < buckets && self.cumulative[p] <= u {
                p += 1;
            }
            out[p] += 1;
        }
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
    fn an_empty_frame_gets_no_photons() {
        let mut shot = ShotNoise::new(4);
        let mut out = vec![7u32; 4];
        shot.draw(&[0.0; 4], 0.0, &mut stream(1, 0, 0), &mut out);
        assert_eq!(out, [0; 4]);
    }
}
