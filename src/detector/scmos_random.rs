//! `scmos-random`: every pixel's read-noise sigma drawn anew from the rms pdf every frame.

use std::sync::Arc;


use super::readout::{FrameInput, Readout};
use super::spec::{ModelEntry, ModelSpec, Sensor};
use crate::pdf::RmsPdf;
use crate::rng::SimRng;

/// The registry entry of `scmos-random`.
pub const ENTRY: ModelEntry = ModelEntry {
    name: "scmos-random",
    arg: None,
    help: "sCMOS with per-pixel sigmas drawn anew from the rms pdf every frame (the expected detector)",
    sensor: Sensor::Scmos,
    params: &["pdf"],
    parse: |_, _| Ok(ModelSpec::ScmosRandom),
    build: |_, p, _| Ok(Box::new(ScmosRandom::new(p.pdf.clone()))),
};

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

    fn read(&self, input: &FrameInput, aux: &mut SimRng, out: &mut [f64]) {
        // Gaussian deviates come from `noise` as in the constant models, sigmas from `aux`:
        // the two then differ only by the sigmas (common random numbers).
        let out = &mut out[..input.photo_e.len()];
        self.pdf.sample_into(aux, out);
        for ((o, &k), &z) in out.iter_mut().zip(input.photo_e).zip(input.normals) {
            *o = k as f64 + *o * z;
        }
    }

    fn noise_scale_e(&self) -> f64 {
        self.pdf.rms()
    }

    fn read_known(&self, input: &FrameInput, aux: &mut SimRng, out: &mut [f64], sigma_e: &mut [f64]) {
        // The same draws in the same order as `read`, each sigma kept.
        let out = &mut out[..input.photo_e.len()];
        self.pdf.sample_into(aux, &mut sigma_e[..out.len()]);
        for (((o, &k), &z), &s) in out
            .iter_mut()
            .zip(input.photo_e)
            .zip(input.normals)
            .zip(sigma_e.iter())
        {
            *o = k as f64 + s * z;
        }
    }

    fn median_sigma_e(&self) -> f64 {
        self.pdf.median()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::detector::readout::sampling::dark_samples;
    use crate::stats::mean_var;

    #[test]
    fn random_model_noise_power_is_pdf_second_moment() {
        // Zero light: output variance = E[sigma^2] = rms^2 = 2.16 e-^2 for the paper pdf.
        // Heavy tailed (sigma up to 10 e-): use the sample's own 4th moment for the SE.
        let pdf = Arc::new(crate::pdf::paper());
        let model = ScmosRandom::new(pdf.clone());
        let n = 400_000;
        let xs = dark_samples(&model, 1, n, 2).remove(0);
        let (_, v) = mean_var(&xs);
        let m4 = xs.iter().map(|x| x.powi(4)).sum::<f64>() / n as f64;
        let se = ((m4 - v * v) / n as f64).sqrt();
        assert!((v - pdf.rms().powi(2)).abs() < 4.0 * se, "var {v} se {se}");
    }
}
