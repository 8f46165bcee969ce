//! One work item's frame buffers: a batch of [`LANES`] iterations simulated and read by every
//! model, then handed to the centroiders a batch at a time.

use super::{BuiltArm, AUX, NOISE, PHOTONS, POSITION};
use crate::centroid::{CentroidFrame, CentroidWorker, ImageSums, SettingSums, LANES};
use crate::detector::{draw_normals, FrameInput, Readout};
use crate::montecarlo::config::SimConfig;
use crate::montecarlo::photons::ShotNoise;
use crate::rng::ItemStreams;
use crate::spot::SpotRenderer;
use rand::RngExt;

/// What a batch's frames are made from: the run's configuration, spot and models.
pub(super) struct Scene<'a> {
    pub(super) cfg: &'a SimConfig,
    pub(super) renderer: &'a SpotRenderer,
    pub(super) models: &'a [&'a dyn Readout],
    /// The centred spot's expected photo-electrons per pixel.
    pub(super) mean_e: &'a [f64],
}

/// Buffers of one work item, reused for each batch of frames.
pub(super) struct BatchFrames {
    npix: usize,
    /// Per model: its arms.
    arms_of: Vec<Vec<usize>>,
    /// Per model: whether any of its arms uses the known noise map.
    needs_map: Vec<bool>,
    /// Per model, the frames of a batch (e-, one after the other) and their known sigmas (e-).
    images: Vec<Vec<f64>>,
    sigmas: Vec<Vec<f64>>,
    /// Per frame of the batch: the noiseless image's centre of gravity (px from the centre).
    truths: [(f64, f64); LANES],
    /// Scratch of one frame: expected photo-electrons, photo-electrons, normal deviates.
    expected: Vec<f64>,
    photons: Vec<u32>,
    shot: ShotNoise,
    normals: Vec<f64>,
}

impl BatchFrames {
    /// Buffers for the models of `scene` read through `arms`.
    pub(super) fn new(scene: &Scene, arms: &[BuiltArm]) -> Self {
        let n = scene.cfg.subap_px;
        let npix = n * n;
        let models = scene.models.len();
        let arms_of: Vec<Vec<usize>> = (0..models)
            .map(|m| (0..arms.len()).filter(|&a| arms[a].model == m).collect())
            .collect();
        let needs_map: Vec<bool> = arms_of
            .iter()
            .map(|of| of.iter().any(|&a| arms[a].centroider.needs_noise_map()))
            .collect();
        BatchFrames {
            npix,
            images: vec![vec![0.0; LANES * npix]; models],
            sigmas: needs_map
                .iter()
                .map(|&needs| vec![0.0; if needs { LANES * npix } else { 0 }])
                .collect(),
            arms_of,
            needs_map,
            truths: [(0.0, 0.0); LANES],
            expected: vec![0.0; npix],
            photons: vec![0; npix],
            shot: ShotNoise::new(npix),
            normals: vec![0.0; npix],
        }
    }

    /// Simulate iteration `it` into frame `lane` of the batch: its spot position, noiseless
    /// image and truth, photo-electrons, and every model's readout.
    pub(super) fn simulate(&mut self, scene: &Scene, it: u64, lane: usize) {
        let (cfg, n) = (scene.cfg, scene.cfg.subap_px);
        let streams = ItemStreams::new(cfg.seed, it);
        let mut pos = streams.stream(POSITION);
        let h = cfg.position_half_range_px;
        let (x0, y0) = (pos.random_range(-h..=h), pos.random_range(-h..=h));
        let expected = &mut self.expected;
        scene.renderer.render(x0, y0, expected);
        // The truth is the noiseless image's centre of gravity, which scaling leaves alone:
        // taken from the rendered image's sums, whose total also sets the scale.
        let rendered = ImageSums::of(expected, n);
        self.truths[lane] = rendered.centroid(n).unwrap_or((0.0, 0.0));
        // A spot entirely outside the sub-aperture leaves nothing to measure.
        let (mean_photo_e, scale) = if rendered.total > 0.0 {
            let mean = cfg.signal_photons * cfg.qe;
            (mean, mean / rendered.total)
        } else {
            (0.0, 0.0)
        };
        expected.iter_mut().for_each(|v| *v *= scale);
        let mut ph = streams.stream(PHOTONS);
        self.shot
            .draw(expected, mean_photo_e, &mut ph, &mut self.photons);
        // Every model reads with the same normal deviates and starts from the same auxiliary
        // stream (common random numbers): drawn once, the stream's state copied.
        draw_normals(&mut streams.stream(NOISE), &mut self.normals);
        let input = FrameInput {
            subap_px: n,
            expected_e: expected,
            mean_e: scene.mean_e,
            photo_e: &self.photons,
            normals: &self.normals,
        };
        let aux0 = streams.stream(AUX);
        let frame = lane * self.npix..(lane + 1) * self.npix;
        for (m, model) in scene.models.iter().enumerate() {
            let image = &mut self.images[m][frame.clone()];
            if self.needs_map[m] {
                let sigma = &mut self.sigmas[m][frame.clone()];
                model.read_known(&input, &mut aux0.clone(), image, sigma);
            } else {
                model.read(&input, &mut aux0.clone(), image);
            }
        }
    }

    /// Add the first `count` frames of the batch, as each model read them, to the sums `accs`
    /// of its arms (`workers`, one per arm).
    pub(super) fn centroid(
        &self,
        scene: &Scene,
        count: usize,
        workers: &mut [Box<dyn CentroidWorker + '_>],
        accs: &mut [SettingSums],
    ) {
        let npix = self.npix;
        for (m, model) in scene.models.iter().enumerate() {
            let frames: [CentroidFrame; LANES] = std::array::from_fn(|lane| {
                let frame = lane * npix..(lane + 1) * npix;
                CentroidFrame {
                    image_e: &self.images[m][frame.clone()],
                    truth_px: self.truths[lane],
                    sigma_e: if self.needs_map[m] {
                        &self.sigmas[m][frame]
                    } else {
                        &[]
                    },
                    mean_e: scene.mean_e,
                    photon_variance_factor: model.photon_variance_factor(),
                }
            });
            for &a in &self.arms_of[m] {
                workers[a].accumulate_batch(&frames[..count], &mut accs[a]);
            }
        }
    }
}
