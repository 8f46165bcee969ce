//! sCMOS readout models: Poisson photo-electrons plus per-pixel Gaussian read noise.

use super::{FrameInput, Readout};
use crate::pdf::RmsPdf;
use crate::rng::{stream, SimRng};
use rand_distr::{Distribution, StandardNormal};
use std::sync::Arc;

/// Stream role used for fixed noise patterns.
const PATTERN_STREAM: u64 = 0x5c05;

/// One read-noise sigma (e-) for every pixel (`scmos-constant`, `scmos-median`, `scmos-mean`).
#[derive(Debug, Clone)]
pub struct ScmosConstant {
    sigma_e: f64,
    name: String,
}

impl ScmosConstant {
    /// Constant sigma (e-) reported under `name`.
    pub fn new(sigma_e: f64, name: String) -> Self {
        ScmosConstant { sigma_e, name }
    }
}

impl Readout for ScmosConstant {
    fn name(&self) -> String {
        self.name.clone()
    }

    fn read(&self, input: &FrameInput, noise: &mut SimRng, _aux: &mut SimRng, out: &mut [f64]) {
        for (o, &k) in out.iter_mut().zip(input.photo_e) {
            let z: f64 = StandardNormal.sample(noise);
            *o = k as f64 + self.sigma_e * z;
        }
    }

    fn noise_scale_e(&self) -> f64 {
        self.sigma_e
    }
}

/// A sigma (e-) per pixel held for the whole run (`scmos-fixed`, and measured maps).
#[derive(Debug, Clone)]
pub struct PerPixelSigma {
    sigma_e: Vec<f64>,
    name: String,
}

impl PerPixelSigma {
    /// A given n x n sigma map (e-), row-major.
    pub fn new(sigma_e: Vec<f64>, name: String) -> Self {
        PerPixelSigma { sigma_e, name }
    }

    /// Seeded pattern number `pattern` of `subap_px`^2 sigmas drawn from `pdf`.
    pub fn fixed_pattern(pdf: &dyn RmsPdf, subap_px: usize, seed: u64, pattern: u32) -> Self {
        let mut rng = stream(seed, pattern as u64, PATTERN_STREAM);
        let sigma_e = (0..subap_px * subap_px)
            .map(|_| pdf.sample(&mut rng))
            .collect();
        PerPixelSigma::new(sigma_e, format!("scmos-fixed:{pattern}"))
    }

    /// The per-pixel sigmas (e-), row-major.
    pub fn sigma_e(&self) -> &[f64] {
        &self.sigma_e
    }
}

impl Readout for PerPixelSigma {
    fn name(&self) -> String {
        self.name.clone()
    }

    fn read(&self, input: &FrameInput, noise: &mut SimRng, _aux: &mut SimRng, out: &mut [f64]) {
        for ((o, &k), s) in out.iter_mut().zip(input.photo_e).zip(&self.sigma_e) {
            let z: f64 = StandardNormal.sample(noise);
            *o = k as f64 + s * z;
        }
    }

    fn noise_scale_e(&self) -> f64 {
        let n = self.sigma_e.len() as f64;
        (self.sigma_e.iter().map(|s| s * s).sum::<f64>() / n).sqrt()
    }
}

/// `scmos-random`: every pixel's sigma drawn anew from the pdf every frame.
#[derive(Debug, Clone)]
pub struct ScmosRandom {
    pdf: Arc<dyn RmsPdf>,
}

impl ScmosRandom {
    /// Draw sigmas from `pdf`.
    pub fn new(pdf: Arc<dyn RmsPdf>) -> Self {
        ScmosRandom { pdf }
    }
}

impl Readout for ScmosRandom {
    fn name(&self) -> String {
        "scmos-random".into()
    }

    fn read(&self, input: &FrameInput, noise: &mut SimRng, aux: &mut SimRng, out: &mut [f64]) {
        // Gaussian deviates come from `noise` as in the constant models, sigmas from `aux`:
        // the two then differ only by the sigmas (common random numbers).
        for (o, &k) in out.iter_mut().zip(input.photo_e) {
            let z: f64 = StandardNormal.sample(noise);
            *o = k as f64 + self.pdf.sample(aux) * z;
        }
    }

    fn noise_scale_e(&self) -> f64 {
        self.pdf.rms()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::stats::mean_var;

    #[test]
    fn random_model_noise_power_is_pdf_second_moment() {
        // Zero light: output variance = E[sigma^2] = rms^2 = 2.16 e-^2 for the paper pdf.
        // Heavy tailed (sigma up to 10 e-): use the sample's own 4th moment for the SE.
        let pdf = Arc::new(crate::pdf::paper());
        let model = ScmosRandom::new(pdf.clone());
        let n = 400_000;
        let (mut noise, mut aux) = (stream(2, 0, 0), stream(2, 0, 1));
        let zeros = [0u32];
        let expected = [0.0];
        let input = FrameInput {
            subap_px: 1,
            expected_e: &expected,
            photo_e: &zeros,
        };
        let mut out = [0.0];
        let xs: Vec<f64> = (0..n)
            .map(|_| {
                model.read(&input, &mut noise, &mut aux, &mut out);
                out[0]
            })
            .collect();
        let (_, v) = mean_var(&xs);
        let m4 = xs.iter().map(|x| x.powi(4)).sum::<f64>() / n as f64;
        let se = ((m4 - v * v) / n as f64).sqrt();
        assert!((v - pdf.rms().powi(2)).abs() < 4.0 * se, "var {v} se {se}");
    }

    #[test]
    fn fixed_patterns_are_reproducible_and_distinct() {
        let pdf = crate::pdf::paper();
        let a = PerPixelSigma::fixed_pattern(&pdf, 16, 1, 0);
        let b = PerPixelSigma::fixed_pattern(&pdf, 16, 1, 0);
        let c = PerPixelSigma::fixed_pattern(&pdf, 16, 1, 1);
        assert_eq!(a.sigma_e(), b.sigma_e());
        assert_ne!(a.sigma_e(), c.sigma_e());
        assert_eq!(a.sigma_e().len(), 256);
    }
}

/// A measured per-pixel read-noise map (e-), row-major.
#[derive(Debug, Clone)]
pub struct NoiseMap {
    /// Rows of the map.
    pub rows: usize,
    /// Columns of the map.
    pub cols: usize,
    /// rms read noise per pixel (e-), row-major; non-finite values mark excluded pixels.
    pub rms_e: Vec<f64>,
    /// Where the map came from (file name), for labels.
    pub source: String,
}

/// `scmos-map`: each frame reads through an n x n window of a measured noise map at a random
/// place, so the simulation sees the camera's own spatial mix of quiet and noisy pixels.
#[derive(Debug, Clone)]
pub struct ScmosMap {
    map: Arc<NoiseMap>,
    n: usize,
    rms_e: f64,
}

impl ScmosMap {
    /// Windows of `n` x `n` pixels of `map`; the map must be at least that large.
    pub fn new(map: Arc<NoiseMap>, n: usize) -> crate::Result<Self> {
        if map.rows < n || map.cols < n {
            return Err(crate::Error::input(
                &map.source,
                format!(
                    "noise map is {}x{} px, smaller than the {n}x{n} px sub-aperture",
                    map.rows, map.cols
                ),
            ));
        }
        // Excluded (non-finite) pixels read as the map's median: a flagged pixel is replaced
        // the way a pipeline would interpolate it, rather than breaking the frame.
        let finite: Vec<f64> = map
            .rms_e
            .iter()
            .copied()
            .filter(|v| v.is_finite())
            .collect();
        if finite.is_empty() {
            return Err(crate::Error::input(
                &map.source,
                "noise map has no finite pixel",
            ));
        }
        let rms_e = (finite.iter().map(|v| v * v).sum::<f64>() / finite.len() as f64).sqrt();
        Ok(ScmosMap { map, n, rms_e })
    }
}

impl Readout for ScmosMap {
    fn name(&self) -> String {
        "scmos-map".into()
    }

    fn read(&self, input: &FrameInput, noise: &mut SimRng, aux: &mut SimRng, out: &mut [f64]) {
        use rand::RngExt;
        let n = self.n;
        let r0 = aux.random_range(0..=self.map.rows - n);
        let c0 = aux.random_range(0..=self.map.cols - n);
        for (i, (orow, krow)) in out
            .chunks_exact_mut(n)
            .zip(input.photo_e.chunks_exact(n))
            .enumerate()
        {
            let mrow = &self.map.rms_e[(r0 + i) * self.map.cols + c0..][..n];
            for ((o, &k), &s) in orow.iter_mut().zip(krow).zip(mrow) {
                let z: f64 = StandardNormal.sample(noise);
                let s = if s.is_finite() { s } else { self.rms_e };
                *o = k as f64 + s * z;
            }
        }
    }

    fn noise_scale_e(&self) -> f64 {
        self.rms_e
    }
}

#[cfg(test)]
mod map_tests {
    use super::*;
    use crate::stats::mean_var;

    #[test]
    fn map_windows_cover_the_map_and_reproduce_its_noise_power() {
        // A 3x4 map with two noise levels; 2x2 windows. Zero light: output variance over
        // many frames = mean of sigma^2 over the window positions' pixels.
        let map = NoiseMap {
            rows: 3,
            cols: 4,
            rms_e: vec![1.0, 1.0, 3.0, 3.0, 1.0, 1.0, 3.0, 3.0, 1.0, 1.0, 3.0, 3.0],
            source: "t".into(),
        };
        let m = ScmosMap::new(Arc::new(map), 2).unwrap();
        let (mut noise, mut aux) = (stream(8, 0, 0), stream(8, 0, 1));
        let (zeros, expected) = ([0u32; 4], [0.0; 4]);
        let input = FrameInput {
            subap_px: 2,
            expected_e: &expected,
            photo_e: &zeros,
        };
        let mut out = [0.0; 4];
        let n = 100_000;
        let mut left = Vec::with_capacity(n);
        for _ in 0..n {
            m.read(&input, &mut noise, &mut aux, &mut out);
            left.push(out[0]);
        }
        // Top-left pixel of a window sits in column 0, 1 or 2: sigma^2 = 1, 1, 9 equally often.
        let (_, v) = mean_var(&left);
        let expect = (1.0 + 1.0 + 9.0) / 3.0;
        // Mixture variance SE from its 4th moment: E[x^4] = 3 E[s^4] = 3 (1 + 1 + 81)/3.
        let se = ((83.0 - expect * expect) / n as f64).sqrt();
        assert!((v - expect).abs() < 4.0 * se, "{v} vs {expect}");
        let small = NoiseMap {
            rows: 1,
            cols: 8,
            rms_e: vec![1.0; 8],
            source: "small.fits".into(),
        };
        let err = ScmosMap::new(Arc::new(small), 2).unwrap_err();
        assert!(err.to_string().contains("small.fits"));
    }
}
