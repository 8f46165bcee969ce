//! The expected sub-aperture image at the positions the bound is averaged over: photo-electrons
//! per pixel, their derivatives in the spot position, and the truth's Jacobian.

use super::radial::GL6;
use crate::montecarlo::SimConfig;
use crate::spot::SpotRenderer;

/// Central-difference step (px): truncation error ~1e-6 relative, round-off of the f32 pixel
/// tables ~1e-4 relative.
const STEP_PX: f64 = 1e-3;

/// The expected image at one spot position.
#[derive(Debug, Clone)]
pub struct Position {
    /// Quadrature weight (the weights sum to 1).
    pub weight: f64,
    /// The truth: the noiseless image's centre of gravity (px from the centre; x, y).
    pub truth_px: [f64; 2],
    /// Expected photo-electrons per pixel (row-major), scaled to S x QE in the sub-aperture.
    pub mu_e: Vec<f64>,
    /// d mu / d x0 (e- per px), x along columns.
    pub dmu_dx: Vec<f64>,
    /// d mu / d y0 (e- per px), y along rows.
    pub dmu_dy: Vec<f64>,
    /// d(truth) / d(position): the truth is the noiseless image's centre of gravity, which
    /// a spot cut by the sub-aperture's edge moves less than the spot itself.
    pub truth_jacobian: [[f64; 2]; 2],
}

/// The expected images of a configuration at the Gauss-Legendre positions (6 x 6 over
/// [-h, h]^2, or the centre alone when h = 0), as the Monte-Carlo draws them.
#[derive(Debug, Clone)]
pub struct SpotImages {
    /// Sub-aperture side (px).
    pub subap_px: usize,
    /// The positions.
    pub positions: Vec<Position>,
}

impl SpotImages {
    /// The images of `cfg` (its spot, sampling, signal, QE and position range).
    pub fn new(cfg: &SimConfig) -> Self {
        let n = cfg.subap_px;
        let h = cfg.position_half_range_px;
        let renderer = SpotRenderer::new(cfg.spot, cfg.sampling, n, h + 2.0 * STEP_PX);
        let nodes: Vec<(f64, f64)> = if h > 0.0 {
            GL6.iter().map(|&(t, w)| (h * t, 0.5 * w)).collect()
        } else {
            vec![(0.0, 1.0)]
        };
        let flux = cfg.signal_photons * cfg.qe;
        let mut positions = Vec::with_capacity(nodes.len() * nodes.len());
        for &(y0, wy) in &nodes {
            for &(x0, wx) in &nodes {
                positions.push(Position::at(&renderer, flux, (x0, y0), wx * wy));
            }
        }
        SpotImages {
            subap_px: n,
            positions,
        }
    }
}

/// An image at offset `at` scaled to `flux` e- in total, and its centre of gravity (px).
fn image(renderer: &SpotRenderer, flux: f64, at: (f64, f64)) -> (Vec<f64>, [f64; 2]) {
    let n = renderer.subap_px();
    let mut img = vec![0.0; n * n];
    renderer.render(at.0, at.1, &mut img);
    let total: f64 = img.iter().sum();
    if total <= 0.0 {
        return (vec![0.0; n * n], [0.0, 0.0]);
    }
    let c = (n as f64 - 1.0) / 2.0;
    let (mut sx, mut sy) = (0.0, 0.0);
    for (k, v) in img.iter_mut().enumerate() {
        sx += *v * ((k % n) as f64 - c);
        sy += *v * ((k / n) as f64 - c);
        *v *= flux / total;
    }
    (img, [sx / total, sy / total])
}

impl Position {
    /// The expected image of `cfg` with the spot at offset (`x0`, `y0`) px, weight 1.
    pub fn new(cfg: &SimConfig, (x0, y0): (f64, f64)) -> Self {
        let reach = x0.abs().max(y0.abs()) + 2.0 * STEP_PX;
        let renderer = SpotRenderer::new(cfg.spot, cfg.sampling, cfg.subap_px, reach);
        Position::at(&renderer, cfg.signal_photons * cfg.qe, (x0, y0), 1.0)
    }

    fn at(renderer: &SpotRenderer, flux: f64, (x0, y0): (f64, f64), weight: f64) -> Self {
        let (mu_e, truth_px) = image(renderer, flux, (x0, y0));
        let diff = |plus: (f64, f64), minus: (f64, f64)| {
            let (a, ta) = image(renderer, flux, plus);
            let (b, tb) = image(renderer, flux, minus);
            let d: Vec<f64> = a
                .iter()
                .zip(&b)
                .map(|(p, m)| (p - m) / (2.0 * STEP_PX))
                .collect();
            (
                d,
                [
                    (ta[0] - tb[0]) / (2.0 * STEP_PX),
                    (ta[1] - tb[1]) / (2.0 * STEP_PX),
                ],
            )
        };
        let (dmu_dx, tx) = diff((x0 + STEP_PX, y0), (x0 - STEP_PX, y0));
        let (dmu_dy, ty) = diff((x0, y0 + STEP_PX), (x0, y0 - STEP_PX));
        Position {
            weight,
            truth_px,
            mu_e,
            dmu_dx,
            dmu_dy,
            truth_jacobian: [[tx[0], ty[0]], [tx[1], ty[1]]],
        }
    }

    /// The Fisher matrix [[xx, xy], [xy, yy]] (px^-2) of the position when pixel i carries
    /// `info(i, mu_i)` per e-^2 of its mean.
    pub fn fisher(&self, mut info: impl FnMut(usize, f64) -> f64) -> [[f64; 2]; 2] {
        let (mut xx, mut xy, mut yy) = (0.0, 0.0, 0.0);
        for (i, ((&mu, &gx), &gy)) in self
            .mu_e
            .iter()
            .zip(&self.dmu_dx)
            .zip(&self.dmu_dy)
            .enumerate()
        {
            if gx == 0.0 && gy == 0.0 {
                continue;
            }
            let j = info(i, mu);
            xx += j * gx * gx;
            xy += j * gx * gy;
            yy += j * gy * gy;
        }
        [[xx, xy], [xy, yy]]
    }

    /// The least covariance (px^2) of an unbiased estimate of the truth given Fisher matrix
    /// `f`: T F^-1 T' with T the truth's Jacobian; None when F is singular.
    pub fn truth_covariance(&self, f: [[f64; 2]; 2]) -> Option<[[f64; 2]; 2]> {
        let det = f[0][0] * f[1][1] - f[0][1] * f[1][0];
        if det.is_nan() || det <= 0.0 || det.is_infinite() {
            return None;
        }
        let inv = [
            [f[1][1] / det, -f[0][1] / det],
            [-f[1][0] / det, f[0][0] / det],
        ];
        let t = self.truth_jacobian;
        let mut ti = [[0.0; 2]; 2];
        for r in 0..2 {
            for c in 0..2 {
                ti[r][c] = t[r][0] * inv[0][c] + t[r][1] * inv[1][c];
            }
        }
        let mut cov = [[0.0; 2]; 2];
        for r in 0..2 {
            for c in 0..2 {
                cov[r][c] = ti[r][0] * t[c][0] + ti[r][1] * t[c][1];
            }
        }
        Some(cov)
    }
}
