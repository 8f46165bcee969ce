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
