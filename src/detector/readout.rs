//! The readout interface: what a model sees of a frame and what it must provide.

use crate::rng::SimRng;

/// What a readout sees of one frame.
#[derive(Debug, Clone, Copy)]
pub struct FrameInput<'a> {
    /// Sub-aperture side (pixels); images are row-major n x n.
    pub subap_px: usize,
    /// Expected photo-electrons per pixel (noiseless spot x signal x QE).
    pub expected_e: &'a [f64],
    /// Expected photo-electrons per pixel of the spot at the sub-aperture centre: the mean
    /// spot image a closed-loop controller knows (the same every frame of a run), for models
    /// and centroiders that use a per-pixel prior.
    pub mean_e: &'a [f64],
    /// Photo-electrons per pixel after shot noise (shared by all models of a sweep).
    pub photo_e: &'a [u32],
    /// One standard normal deviate per pixel, the frame's read-noise draws: every model of a
    /// sweep reads with the same ones (common random numbers), drawn once per frame.
    pub normals: &'a [f64],
}

/// Standard normal deviates, one per pixel, into `out` from `rng` (in pixel order).
pub fn draw_normals(rng: &mut SimRng, out: &mut [f64]) {
    use rand_distr::{Distribution, StandardNormal};
    out.iter_mut().for_each(|z| *z = StandardNormal.sample(rng));
}

/// How a readout turns expected photo-electrons into its output, as the Cramer-Rao floor
/// ([`crate::crlb`]) models a pixel (read noise from [`Readout::read_known`]'s sigmas).
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum PhotonNoise {
    /// Poisson counts of `thinning` x the expected photo-electrons plus Gaussian read noise:
    /// sCMOS (thinning 1) and `emccd-simple` (q).
    Poisson {
        /// Fraction of the expected photo-electrons counted.
        thinning: f64,
    },
    /// Poisson electrons through an EM register, Gamma(k, 1) in input electrons (excess-noise
    /// factor F^2 = 2), plus Gaussian read noise over the gain.
    EmRegister,
    /// Any other excess noise: variance `f2` per expected photo-electron, in the Gaussian
    /// approximation.
    Excess {
        /// Output variance per expected photo-electron.
        f2: f64,
    },
}

/// A detector readout model. Output is in electrons referred to the input (EMCCD output is
/// divided by the mean gain), so all models share one background scale.
pub trait Readout: Send + Sync {
    /// Model name as reported in tables, e.g. `emccd-stochastic` or `scmos-fixed:3`.
    fn name(&self) -> String;
    /// Read one frame into `out` (e-). The read noise scales `input.normals`; `aux` drives
    /// model-specific draws (per-pixel sigmas, the EM register), the same stream for every
    /// model of a sweep.
    fn read(&self, input: &FrameInput, aux: &mut SimRng, out: &mut [f64]);
    /// Typical per-pixel read noise (e-), used to size the default background grid.
    fn noise_scale_e(&self) -> f64;
    /// Read one frame exactly as [`Readout::read`] does (same draws, same output) and write into
    /// `sigma_e` the read-noise sigma (e-) of each of its pixels that a controller knowing this
    /// camera's noise map assigns to it: the map's window for map models, the frame's own
    /// sigmas for per-frame random ones, the constant otherwise.
    fn read_known(
        &self,
        input: &FrameInput,
        aux: &mut SimRng,
        out: &mut [f64],
        sigma_e: &mut [f64],
    ) {
        self.read(input, aux, out);
        sigma_e.fill(self.noise_scale_e());
    }
    /// Median per-pixel read noise (e-) of the camera: the reference of noise-map masking.
    fn median_sigma_e(&self) -> f64 {
        self.noise_scale_e()
    }
    /// Variance of the output per expected photo-electron (e-^2 per e-): 1 for Poisson light
    /// read directly, about 2 behind an EM register (its excess noise), q for light thinned
    /// to a fraction q. Inverse-variance centroiders weight with it.
    fn photon_variance_factor(&self) -> f64 {
        1.0
    }
    /// Whether the model's R describes a usable camera at `mean_e_per_px` (the sub-aperture's
    /// mean photo-electrons per pixel); None for a model that holds at every light level.
    fn in_range(&self, _mean_e_per_px: f64) -> Option<bool> {
        None
    }

    /// The photon noise the Cramer-Rao floor models, from [`Readout::photon_variance_factor`]:
    /// up to 1, thinned Poisson counts; above 1.5, an EM register (F^2 = 1.97 at gain 500 is
    /// taken as the Gamma register's 2); between, the excess noise in the Gaussian form.
    fn photon_noise(&self) -> PhotonNoise {
        match self.photon_variance_factor() {
            f if f <= 1.0 => PhotonNoise::Poisson { thinning: f },
            f if f > 1.5 => PhotonNoise::EmRegister,
            f2 => PhotonNoise::Excess { f2 },
        }
    }
}

/// Samplers shared by the readouts' exact tests.
#[cfg(test)]
pub(super) mod sampling {
    use super::{draw_normals, FrameInput, Readout};
    use crate::rng::stream;
    use crate::stats::poisson;

    /// `n` one-pixel frames of Poisson(`lambda`) photo-electrons read by `model` (seed 21).
    pub fn pixel_samples(model: &dyn Readout, lambda: f64, n: usize) -> Vec<f64> {
        let mut rng = stream(21, 0, 0);
        let mut noise = stream(21, 0, 1);
        let mut aux = stream(21, 0, 2);
        let expected = [lambda];
        let (mut out, mut z) = ([0.0], [0.0]);
        (0..n)
            .map(|_| {
                let k = [poisson(lambda, &mut rng)];
                draw_normals(&mut noise, &mut z);
                let input = FrameInput {
                    subap_px: 1,
                    expected_e: &expected,
                    mean_e: &expected,
                    photo_e: &k,
                    normals: &z,
                };
                model.read(&input, &mut aux, &mut out);
                out[0]
            })
            .collect()
    }

    /// `frames` dark frames of `subap_px` x `subap_px` pixels read by `model`, each frame with
    /// streams of its own (`stream(seed, frame, 0)` for the normals, `(seed, frame, 1)` for
    /// `aux`) as the engine gives them: two models that draw the same numbers first read the
    /// same frames even when one draws more. Row-major frames, one after the other.
    pub fn frames_own_streams(
        model: &dyn Readout,
        subap_px: usize,
        frames: usize,
        seed: u64,
    ) -> Vec<f64> {
        let npx = subap_px * subap_px;
        let (zeros, expected) = (vec![0u32; npx], vec![0.0; npx]);
        let mut z = vec![0.0; npx];
        let mut out = vec![0.0; npx * frames];
        for (f, image) in out.chunks_exact_mut(npx).enumerate() {
            draw_normals(&mut stream(seed, f as u64, 0), &mut z);
            let input = FrameInput {
                subap_px,
                expected_e: &expected,
                mean_e: &expected,
                photo_e: &zeros,
                normals: &z,
            };
            model.read(&input, &mut stream(seed, f as u64, 1), image);
        }
        out
    }

    /// `frames` dark frames of `subap_px` x `subap_px` pixels read by `model`, as one
    /// vector of samples per pixel.
    pub fn dark_samples(
        model: &dyn Readout,
        subap_px: usize,
        frames: usize,
        seed: u64,
    ) -> Vec<Vec<f64>> {
        let (mut noise, mut aux) = (stream(seed, 0, 0), stream(seed, 0, 1));
        let npx = subap_px * subap_px;
        let (zeros, expected) = (vec![0u32; npx], vec![0.0; npx]);
        let (mut out, mut z) = (vec![0.0; npx], vec![0.0; npx]);
        let mut per_px = vec![Vec::with_capacity(frames); npx];
        for _ in 0..frames {
            draw_normals(&mut noise, &mut z);
            let input = FrameInput {
                subap_px,
                expected_e: &expected,
                mean_e: &expected,
                photo_e: &zeros,
                normals: &z,
            };
            model.read(&input, &mut aux, &mut out);
            for (px, &o) in per_px.iter_mut().zip(&out) {
                px.push(o);
            }
        }
        per_px
    }
}
