//! `scmos-constant`, `scmos-median` and `scmos-mean`: one read-noise sigma for every pixel.


use super::readout::{FrameInput, Readout};
use super::spec::{ModelEntry, ModelSpec, Sensor};
use crate::rng::SimRng;

/// The registry entry of `scmos-constant[:SIGMA_E]`.
pub const CONSTANT: ModelEntry = ModelEntry {
    name: "scmos-constant",
    arg: Some("SIGMA_E"),
    help: "sCMOS with one read-noise sigma for every pixel: SIGMA_E (e-) or else `sigma_e`",
    sensor: Sensor::Scmos,
    params: &["sigma_e"],
    parse: |_, arg| match arg {
        None => Ok(ModelSpec::ScmosConstant(None)),
        // The same range as `--sigma` (the registry's), so `scmos-constant:1e20` is refused
        // as `--sigma 1e20` is, not run into single-precision overflow.
        Some(a) => crate::settings::SIGMA_E
            .parse(a)
            .and_then(|v| match v {
                crate::settings::Value::Real(s) => Ok(ModelSpec::ScmosConstant(Some(s))),
                _ => Err("sigma must be a number of e-".into()),
            })
            .map_err(|e| format!("sigma {e}")),
    },
    build: |spec, p, _| {
        let ModelSpec::ScmosConstant(s) = spec else {
            unreachable!("scmos-constant builds only its own spec")
        };
        let sigma = s.unwrap_or(p.sigma_e);
        Ok(Box::new(ScmosConstant::new(
            sigma,
            format!("scmos-constant:{sigma}"),
        )))
    },
};

/// The registry entry of `scmos-median`.
pub const MEDIAN: ModelEntry = ModelEntry {
    name: "scmos-median",
    arg: None,
    help: "sCMOS with one sigma for every pixel, the rms pdf's median",
    sensor: Sensor::Scmos,
    params: &["pdf"],
    parse: |_, _| Ok(ModelSpec::ScmosMedian),
    build: |_, p, _| Ok(Box::new(ScmosConstant::new(p.pdf.median(), "scmos-median".into()))),
};

/// The registry entry of `scmos-mean`.
pub const MEAN: ModelEntry = ModelEntry {
    name: "scmos-mean",
    arg: None,
    help: "sCMOS with one sigma for every pixel, the rms pdf's mean",
    sensor: Sensor::Scmos,
    params: &["pdf"],
    parse: |_, _| Ok(ModelSpec::ScmosMean),
    build: |_, p, _| Ok(Box::new(ScmosConstant::new(p.pdf.mean(), "scmos-mean".into()))),
};

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

    fn read(&self, input: &FrameInput, _aux: &mut SimRng, out: &mut [f64]) {
        for ((o, &k), &z) in out.iter_mut().zip(input.photo_e).zip(input.normals) {
            *o = k as f64 + self.sigma_e * z;
        }
    }

    fn noise_scale_e(&self) -> f64 {
        self.sigma_e
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::detector::readout::sampling::pixel_samples;
    use crate::stats::mean_var;

    #[test]
    fn output_is_poisson_plus_gaussian_read_noise() {
        // Poisson(lambda) + N(0, sigma^2): mean lambda, variance lambda + sigma^2; fourth
        // cumulant lambda, so SE(var) = sqrt((2 var^2 + lambda) / N); 4 SE.
        let n = 200_000;
        for (lambda, sigma) in [(0.0, 1.5), (3.0, 0.8), (50.0, 2.0)] {
            let model = ScmosConstant::new(sigma, "scmos-constant".into());
            let (m, v) = mean_var(&pixel_samples(&model, lambda, n));
            let var = lambda + sigma * sigma;
            assert!((m - lambda).abs() < 4.0 * (var / n as f64).sqrt(), "mean {m}");
            let se = ((2.0 * var * var + lambda) / n as f64).sqrt();
            assert!((v - var).abs() < 4.0 * se, "{lambda}, {sigma}: var {v}");
        }
    }
}
