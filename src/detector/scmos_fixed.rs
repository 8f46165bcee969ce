//! `scmos-fixed[:PATTERN]`: a per-pixel read-noise sigma drawn once from the rms pdf.


use super::readout::{FrameInput, Readout};
use super::spec::{ModelEntry, ModelSpec, Sensor};
use crate::pdf::RmsPdf;
use crate::rng::{stream, SimRng};

/// The registry entry of `scmos-fixed[:PATTERN]`.
pub const ENTRY: ModelEntry = ModelEntry {
    name: "scmos-fixed",
    arg: Some("PATTERN"),
    help: "sCMOS with per-pixel sigmas drawn once from the rms pdf; PATTERN (default 0) picks the seeded pattern",
    sensor: Sensor::Scmos,
    params: &["pdf", "pattern_seed"],
    parse: |_, arg| match arg {
        None => Ok(ModelSpec::ScmosFixed(0)),
        Some(a) => a
            .parse::<u32>()
            .map(ModelSpec::ScmosFixed)
            .map_err(|_| "pattern must be a whole number".into()),
    },
    build: |spec, p, subap_px| {
        let ModelSpec::ScmosFixed(k) = spec else {
            unreachable!("scmos-fixed builds only its own spec")
        };
        Ok(Box::new(PerPixelSigma::fixed_pattern(
            p.pdf.as_ref(),
            subap_px,
            p.pattern_seed,
            *k,
        )))
    },
};

/// Stream role used for fixed noise patterns.
const PATTERN_STREAM: u64 = 0x5c05;

/// A sigma (e-) per pixel held for the whole run (`scmos-fixed`, and measured maps).
#[derive(Debug, Clone)]
pub struct PerPixelSigma {
    sigma_e: Vec<f64>,
    name: String,
    /// The camera's median sigma (e-) when this is a window of a larger map.
    median_e: Option<f64>,
}

impl PerPixelSigma {
    /// A given n x n sigma map (e-), row-major.
    pub fn new(sigma_e: Vec<f64>, name: String) -> Self {
        PerPixelSigma {
            sigma_e,
            name,
            median_e: None,
        }
    }

    /// The same sigmas, with the median (e-) of the whole camera they were cut from (the
    /// reference of noise-map masking; by default the median of these sigmas).
    pub fn with_median_e(mut self, median_e: f64) -> Self {
        self.median_e = Some(median_e);
        self
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

    fn read(&self, input: &FrameInput, _aux: &mut SimRng, out: &mut [f64]) {
        for (((o, &k), s), &z) in out
            .iter_mut()
            .zip(input.photo_e)
            .zip(&self.sigma_e)
            .zip(input.normals)
        {
            *o = k as f64 + s * z;
        }
    }

    fn noise_scale_e(&self) -> f64 {
        let n = self.sigma_e.len() as f64;
        (self.sigma_e.iter().map(|s| s * s).sum::<f64>() / n).sqrt()
    }

    fn read_known(&self, input: &FrameInput, aux: &mut SimRng, out: &mut [f64], sigma_e: &mut [f64]) {
        self.read(input, aux, out);
        sigma_e.copy_from_slice(&self.sigma_e);
    }

    fn median_sigma_e(&self) -> f64 {
        self.median_e
            .unwrap_or_else(|| crate::stats::median(&self.sigma_e))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::detector::readout::sampling::dark_samples;
    use crate::stats::mean_var;

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

    #[test]
    fn each_pixel_reads_with_its_own_sigma() {
        // Zero light: pixel i is N(0, sigma_i^2) in every frame, so its sample variance is
        // sigma_i^2 within 4 SE, SE = sigma_i^2 sqrt(2 / N); the scale is the sigmas' rms.
        let sigma = vec![0.5, 1.0, 2.0, 4.0];
        let model = PerPixelSigma::new(sigma.clone(), "map".into());
        let n = 50_000;
        for (s, xs) in sigma.iter().zip(dark_samples(&model, 2, n, 9)) {
            let (m, v) = mean_var(&xs);
            assert!(m.abs() < 4.0 * s / (n as f64).sqrt(), "mean {m}");
            assert!((v - s * s).abs() < 4.0 * s * s * (2.0 / n as f64).sqrt(), "{s}: {v}");
        }
        assert_eq!(model.noise_scale_e(), (21.25f64 / 4.0).sqrt());
    }
}
