//! The thresholded centres of gravity: `cog`, `tcog`, `masked-cog`, `ivw-cog` and `wcog`, all
//! one background sweep ([`BackgroundSweep::accumulate_terms`]) with per-pixel weights or
//! threshold scales, once per value of an outer parameter; their registry entries and
//! parameter grids.

use super::centroider::{CentroidFrame, CentroidWorker, Centroider, Setting, SettingSums};
use super::spec::{CentroidContext, CentroiderEntry, CentroiderParam, ParamRange};
use super::sweep::{BackgroundSweep, Scaled, Weighted};
use crate::spot::SpotRenderer;
use crate::{Error, Result};

/// `cog`: the paper's centre of gravity, background level b swept.
pub const COG: CentroiderEntry = CentroiderEntry {
    name: "cog",
    help: "centre of gravity after subtracting a background level b (swept; the paper's)",
    param: None,
    mask_above: false,
    build: |entry, _, ctx| Ok(swept_levels(entry, Weighting::None, ctx)),
};

/// `tcog`: per-pixel threshold k sigma_i from the known noise map, k swept.
pub const TCOG: CentroiderEntry = CentroiderEntry {
    name: "tcog",
    help: "per-pixel threshold K x sigma_i from the known noise map (K swept, or given)",
    param: Some(CentroiderParam {
        name: "k_sigma",
        symbol: "K",
        unit: "sigmas",
        meaning: "threshold of each pixel, in its own read-noise sigmas",
        range: ParamRange {
            least: 0.0,
            inclusive: true,
            whole: false,
        },
        grid: |ctx| {
            let peak = ctx.mean_e.iter().copied().fold(0.0, f64::max);
            k_grid(peak / ctx.median_sigma_e.max(SIGMA_FLOOR_E))
        },
    }),
    mask_above: false,
    build: |entry, k, ctx| {
        let t = Thresholded::new(entry, Weighting::NoiseScaled, k.to_vec(), ctx.subap_px);
        Ok(Box::new(t))
    },
};

/// `masked-cog`: pixels noisier than m x the median sigma get zero weight; m and b swept.
pub const MASKED_COG: CentroiderEntry = CentroiderEntry {
    name: "masked-cog",
    help: "pixels with sigma_i above M x the median sigma get zero weight (M swept, or given), b swept",
    param: Some(CentroiderParam {
        name: "mask_above_median",
        symbol: "M",
        unit: "times the median sigma",
        meaning: "read noise above which a pixel is left out",
        range: ParamRange {
            least: 0.0,
            inclusive: false,
            whole: false,
        },
        grid: |_| MASK_GRID.to_vec(),
    }),
    mask_above: true,
    build: |entry, m, ctx| {
        let weighting = Weighting::Mask {
            above_e: m.iter().map(|m| m * ctx.median_sigma_e).collect(),
            m: m.to_vec(),
        };
        Ok(swept_levels(entry, weighting, ctx))
    },
};

/// `ivw-cog`: inverse-variance weights from the noise map and the mean spot; b swept.
pub const IVW_COG: CentroiderEntry = CentroiderEntry {
    name: "ivw-cog",
    help: "weights 1 / (sigma_i^2 + F x mean_i): noise map, mean spot, excess factor F; b swept",
    param: None,
    mask_above: false,
    build: |entry, _, ctx| Ok(swept_levels(entry, Weighting::InverseVariance, ctx)),
};

/// `wcog`: a Gaussian weight on the sub-aperture centre, bias-corrected; its FWHM and b swept.
pub const WCOG: CentroiderEntry = CentroiderEntry {
    name: "wcog",
    help: "Gaussian weight of FWHM W px on the sub-aperture centre (W swept, or given), b swept; divided by its noiseless response slope",
    param: Some(CentroiderParam {
        name: "weight_fwhm_px",
        symbol: "W",
        unit: "px",
        meaning: "full width at half maximum of the Gaussian weight",
        range: ParamRange {
            least: 0.0,
            inclusive: false,
            whole: false,
        },
        grid: |ctx| {
            let fwhm = ctx.spot.fwhm_px();
            WCOG_FWHM_FACTORS
                .iter()
                .map(|f| (f * fwhm).max(MIN_WEIGHT_FWHM_PX))
                .collect()
        },
    }),
    mask_above: false,
    build: |entry, widths, ctx| {
        let renderer = SpotRenderer::new(ctx.spot, ctx.sampling, ctx.subap_px, SLOPE_OFFSET_PX);
        let weighting = Weighting::gaussian(widths, &renderer)?;
        Ok(swept_levels(entry, weighting, ctx))
    },
};

/// `entry` weighted by `weighting`, swept over the run's background levels.
fn swept_levels(
    entry: &'static CentroiderEntry,
    weighting: Weighting,
    ctx: &CentroidContext,
) -> Box<dyn Centroider> {
    Box::new(Thresholded::new(
        entry,
        weighting,
        ctx.levels_e.to_vec(),
        ctx.subap_px,
    ))
}

/// Read-noise sigmas below this (e-) are raised to it where one divides by them.
const SIGMA_FLOOR_E: f64 = 1e-6;
/// Masking thresholds swept (times the median sigma).
const MASK_GRID: [f64; 8] = [1.25, 1.5, 2.0, 2.5, 3.0, 4.0, 6.0, 10.0];
/// Weight widths swept (times the spot's FWHM).
const WCOG_FWHM_FACTORS: [f64; 7] = [0.5, 0.75, 1.0, 1.5, 2.0, 3.0, 4.0];
/// Narrowest weight (FWHM, px): narrower weights see one pixel.
const MIN_WEIGHT_FWHM_PX: f64 = 0.5;

/// Thresholds k (sigmas): 0 to 8 by 0.25, then 10 % steps up to `top` (the brightest mean
/// pixel in sigmas), beyond which every pixel is cut.
fn k_grid(top: f64) -> Vec<f64> {
    let mut k: Vec<f64> = (0..=32).map(|i| i as f64 * 0.25).collect();
    let mut v = 8.0 * 1.1;
    while v < top.min(1e6) {
        k.push(v);
        v *= 1.1;
    }
    k
}

/// How the pixels are weighted or thresholded.
#[derive(Debug, Clone)]
pub(super) enum Weighting {
    /// The plain sweep over background levels.
    None,
    /// Levels are k, in units of each pixel's own sigma: the threshold is k sigma_i.
    NoiseScaled,
    /// Per value m: pixels whose sigma exceeds `above_e` (= m x median, e-) get weight 0.
    Mask {
        /// The masking factors (times the median sigma).
        m: Vec<f64>,
        /// The sigma above which a pixel is masked, per factor (e-).
        above_e: Vec<f64>,
    },
    /// Weight 1 / (sigma_i^2 + F x mean_i).
    InverseVariance,
    /// Per weight FWHM: a Gaussian weight centred on the sub-aperture, and the gains that undo
    /// its pull towards the centre.
    Gaussian {
        /// Weight FWHM (px).
        fwhm_px: Vec<f64>,
        /// Weight per pixel, per width.
        weights: Vec<Vec<f64>>,
        /// (x, y) gain per width: 1 / the noiseless spot's response slope at the centre.
        gains: Vec<(f64, f64)>,
    },
}

/// Weights below this fraction of the largest are set to 0 (the pixel is left out): beyond
/// 5.3 sigma of a Gaussian weight. It bounds the weights' dynamic range, which the sweep's
/// single-precision distances need (a frame lit only by weight-1e-22 pixels would underflow).
pub(super) const MIN_RELATIVE_WEIGHT: f64 = 1e-6;

/// `w` (relative to a largest weight of 1), or 0 below [`MIN_RELATIVE_WEIGHT`].
pub(super) fn cut(w: f64) -> f64 {
    if w < MIN_RELATIVE_WEIGHT {
        0.0
    } else {
        w
    }
}

/// Offset (px) at which the weighted centroid's response slope is measured.
pub(super) const SLOPE_OFFSET_PX: f64 = 0.02;
/// Least response slope of a usable weight (its gain is at most the inverse).
const MIN_SLOPE: f64 = 0.05;

impl Weighting {
    /// Gaussian weights of the given FWHMs (px) for the renderer's sub-aperture, each with its
    /// bias correction: the inverse slope of the weighted centroid of the noiseless spot against
    /// its unweighted centroid (the engine's truth) at the centre, measured per axis from spots
    /// rendered at +-[`SLOPE_OFFSET_PX`] (the standard correction; for a well-sampled Gaussian
    /// spot of sigma s and weight sigma w the slope is w^2 / (s^2 + w^2)). `renderer` must
    /// render offsets up to that far.
    pub(super) fn gaussian(fwhm_px: &[f64], renderer: &SpotRenderer) -> Result<Self> {
        let n = renderer.subap_px();
        let c = (n as f64 - 1.0) / 2.0;
        let weights: Vec<Vec<f64>> = fwhm_px
            .iter()
            .map(|f| {
                let s = f / (8.0 * std::f64::consts::LN_2).sqrt();
                (0..n * n)
                    .map(|p| {
                        let (x, y) = ((p % n) as f64 - c, (p / n) as f64 - c);
                        cut((-(x * x + y * y) / (2.0 * s * s)).exp())
                    })
                    .collect()
            })
            .collect();
        let d = SLOPE_OFFSET_PX;
        let mut img = vec![0.0; n * n];
        let mut centroid = |w: &[f64], x0: f64, y0: f64| {
            renderer.render(x0, y0, &mut img);
            let wimg: Vec<f64> = img.iter().zip(w).map(|(v, w)| v * w).collect();
            super::image::cog(&wimg, n)
        };
        // The response is taken against the centroid of the unweighted noiseless image, the
        // engine's truth (for a narrow point-sampled spot that differs from the spot's offset).
        let ones = vec![1.0; n * n];
        let mut slope = |w: &[f64], y: bool| {
            let (dx, dy) = if y { (0.0, d) } else { (d, 0.0) };
            let (a, b) = (centroid(w, dx, dy)?, centroid(w, -dx, -dy)?);
            let (ta, tb) = (centroid(&ones, dx, dy)?, centroid(&ones, -dx, -dy)?);
            let pick = |p: (f64, f64)| if y { p.1 } else { p.0 };
            let moved = pick(ta) - pick(tb);
            Some((pick(a) - pick(b)) / moved).filter(|s| moved > 0.0 && *s >= MIN_SLOPE)
        };
        // Weights too narrow to follow the spot (slope below MIN_SLOPE: the estimate barely
        // moves and its correction would amplify noise without bound) are left out.
        let (mut kept, mut gains, mut kept_weights) = (Vec::new(), Vec::new(), Vec::new());
        for (w, &f) in weights.into_iter().zip(fwhm_px) {
            if let (Some(sx), Some(sy)) = (slope(&w, false), slope(&w, true)) {
                kept.push(f);
                gains.push((1.0 / sx, 1.0 / sy));
                kept_weights.push(w);
            }
        }
        if kept.is_empty() {
            return Err(Error::invalid(
                "centroider",
                format!(
                    "wcog: no weight of FWHM {fwhm_px:?} px follows the spot's motion (response \
                     slope below {MIN_SLOPE}); give a wider one"
                ),
            ));
        }
        Ok(Weighting::Gaussian {
            fwhm_px: kept,
            weights: kept_weights,
            gains,
        })
    }

    /// The outer parameter values (None: a single part without one).
    fn outer(&self) -> Vec<Option<f64>> {
        match self {
            Weighting::Mask { m, .. } => m.iter().map(|&m| Some(m)).collect(),
            Weighting::Gaussian { fwhm_px, .. } => fwhm_px.iter().map(|&f| Some(f)).collect(),
            _ => vec![None],
        }
    }
}

/// A thresholded centre of gravity: a weighting and the levels its sweep runs over (e-, or
/// sigmas for `tcog`).
#[derive(Debug, Clone)]
pub(super) struct Thresholded {
    entry: &'static CentroiderEntry,
    weighting: Weighting,
    levels: Vec<f64>,
    n: usize,
}

impl Thresholded {
    /// `entry` weighted by `weighting`, swept over `levels` (sorted and deduplicated here), for
    /// n x n sub-apertures.
    pub(super) fn new(
        entry: &'static CentroiderEntry,
        weighting: Weighting,
        mut levels: Vec<f64>,
        n: usize,
    ) -> Self {
        levels.sort_by(f64::total_cmp);
        levels.dedup();
        Thresholded {
            entry,
            weighting,
            levels,
            n,
        }
    }
}

impl Centroider for Thresholded {
    fn name(&self) -> String {
        self.entry.name.to_string()
    }

    fn param_name(&self) -> Option<&'static str> {
        self.entry.param.map(|p| p.name)
    }

    fn settings(&self) -> Vec<Setting> {
        let tcog = matches!(self.weighting, Weighting::NoiseScaled);
        self.weighting
            .outer()
            .into_iter()
            .enumerate()
            .flat_map(|(part, param)| {
                self.levels.iter().map(move |&l| match tcog {
                    true => Setting {
                        param: Some(l),
                        b_e: 0.0,
                        part,
                    },
                    false => Setting {
                        param,
                        b_e: l,
                        part,
                    },
                })
            })
            .collect()
    }

    fn sums(&self) -> SettingSums {
        SettingSums::new(&vec![self.levels.len(); self.weighting.outer().len()])
    }

    fn needs_noise_map(&self) -> bool {
        matches!(
            self.weighting,
            Weighting::NoiseScaled | Weighting::Mask { .. } | Weighting::InverseVariance
        )
    }

    fn worker(&self) -> Box<dyn CentroidWorker + '_> {
        Box::new(ThresholdedWorker {
            c: self,
            sweep: BackgroundSweep::new(self.levels.clone(), self.n),
            scratch: vec![0.0; self.n * self.n],
        })
    }
}

/// A thread's sweep and per-pixel scratch.
struct ThresholdedWorker<'c> {
    c: &'c Thresholded,
    sweep: BackgroundSweep,
    scratch: Vec<f64>,
}

impl CentroidWorker for ThresholdedWorker<'_> {
    fn accumulate_batch(&mut self, frames: &[CentroidFrame], acc: &mut SettingSums) {
        if let Weighting::None = self.c.weighting {
            self.sweep.accumulate_batch(frames, acc.part_mut(0));
        } else {
            for f in frames {
                self.accumulate(f, acc);
            }
        }
    }

    fn accumulate(&mut self, f: &CentroidFrame, acc: &mut SettingSums) {
        let (img, truth) = (f.image_e, f.truth_px);
        let plain = (1.0, 1.0);
        match &self.c.weighting {
            Weighting::None => self.sweep.accumulate(img, truth, acc.part_mut(0)),
            Weighting::NoiseScaled => {
                for (s, &sigma) in self.scratch.iter_mut().zip(f.sigma_e) {
                    *s = sigma.max(SIGMA_FLOOR_E);
                }
                let terms = Scaled {
                    scale: &self.scratch,
                };
                self.sweep
                    .accumulate_terms(img, &terms, truth, acc.part_mut(0));
            }
            Weighting::Mask { above_e, .. } => {
                for (k, &above) in above_e.iter().enumerate() {
                    for (w, &sigma) in self.scratch.iter_mut().zip(f.sigma_e) {
                        *w = f64::from(u8::from(sigma <= above));
                    }
                    let terms = Weighted {
                        weight: &self.scratch,
                        gain: plain,
                    };
                    self.sweep
                        .accumulate_terms(img, &terms, truth, acc.part_mut(k));
                }
            }
            Weighting::InverseVariance => {
                // A pixel with neither read noise nor expected light would get an unbounded
                // weight: the variance is floored at that of the floor sigma. Weights are
                // relative to the largest, and cut below MIN_RELATIVE_WEIGHT.
                let floor = SIGMA_FLOOR_E * SIGMA_FLOOR_E;
                for ((w, &sigma), &mean) in self.scratch.iter_mut().zip(f.sigma_e).zip(f.mean_e) {
                    *w = (sigma * sigma + f.photon_variance_factor * mean).max(floor);
                }
                let least = self.scratch.iter().copied().fold(f64::INFINITY, f64::min);
                self.scratch.iter_mut().for_each(|w| *w = cut(least / *w));
                let terms = Weighted {
                    weight: &self.scratch,
                    gain: plain,
                };
                self.sweep
                    .accumulate_terms(img, &terms, truth, acc.part_mut(0));
            }
            Weighting::Gaussian { weights, gains, .. } => {
                for (k, (w, &gain)) in weights.iter().zip(gains).enumerate() {
                    let terms = Weighted { weight: w, gain };
                    self.sweep
                        .accumulate_terms(img, &terms, truth, acc.part_mut(k));
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn k_grid_is_ascending_and_bounded() {
        let k = k_grid(40.0);
        assert!(k.windows(2).all(|w| w[0] < w[1]) && k[0] == 0.0 && *k.last().unwrap() < 40.0);
    }
}
