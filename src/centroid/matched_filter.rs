//! `matched-filter`: the noise-weighted linearised matched filter of MAOS (`mtch`).
//!
//! The frame I is modelled about the mean spot I0 as I = I0 + gx tx + gy ty + I0 f (a shift
//! (tx, ty) px and a relative flux change f), with per-pixel variance
//! C_i = F mean_i + sigma_i^2 (F the readout's photon variance factor). The estimate is the
//! generalised least-squares solution theta = (G^T C^-1 G)^-1 G^T C^-1 (I - I0), G = [gx gy I0],
//! of which the filter keeps the two shift rows: a 2 x n^2 filter applied to each frame. The
//! third column is MAOS's intensity constraint: the flux of a frame (Poisson) does not leak into
//! the shift. The position is then the mean spot's centroid plus the shift.
//!
//! The gradient images are not central differences of the mean image (a point-sampled spot of
//! 1-2 px FWHM is far too coarse for them): they are the sub-pixel derivative of the spot itself,
//! rendered at +-[`GRADIENT_STEP_PX`] in each axis, each rendering normalised to unit total (the
//! engine scales every frame to the same total), and taken per unit of the engine's truth (the
//! noiseless image's centroid, which for a narrow point-sampled spot moves less than the spot),
//! as `wcog`'s response slope is. They are scaled by the mean spot's total in each frame.
//!
//! The filter depends only on the mean spot, the noise map and F: a worker keeps it and
//! recomputes it (a few passes over the pixels) only when one of them differs from the last
//! frame's. Being linear, the estimate needs no background sweep and takes no parameter; its
//! response is linear only near the centre (about a quarter of the spot's FWHM), beyond which it
//! underestimates the shift.

use super::centroider::{CentroidFrame, CentroidWorker, Centroider, SettingSums};
use super::image::ImageSums;
use super::spec::{CentroidContext, CentroiderEntry};
use crate::spot::SpotRenderer;
use crate::{Error, Result};

/// `matched-filter`'s registry entry.
pub const ENTRY: CentroiderEntry = CentroiderEntry {
    name: "matched-filter",
    help: "noise-weighted linearised matched filter (MAOS mtch): spot gradients, variance F x mean_i + sigma_i^2, flux constrained",
    param: None,
    mask_above: false,
    build: |_, _, ctx| Ok(Box::new(MatchedFilter::new(ctx)?)),
};

/// Offset (px) of the renderings whose difference is the gradient.
pub(super) const GRADIENT_STEP_PX: f64 = 0.01;
/// Least per-pixel variance (e-^2): a pixel without read noise or light would get an unbounded
/// weight.
pub(super) const VARIANCE_FLOOR_E2: f64 = 1e-12;

/// The matched filter of a run's spot.
#[derive(Debug, Clone)]
pub(super) struct MatchedFilter {
    n: usize,
    /// d(image)/d(truth x) and d(image)/d(truth y) of the unit-total spot (per px).
    gx: Vec<f64>,
    gy: Vec<f64>,
}

impl MatchedFilter {
    /// The filter for the run's spot, sampling and sub-aperture.
    pub(super) fn new(ctx: &CentroidContext) -> Result<Self> {
        let n = ctx.subap_px;
        let renderer = SpotRenderer::new(ctx.spot, ctx.sampling, n, GRADIENT_STEP_PX);
        let mut img = vec![0.0; n * n];
        let mut unit = |x0: f64, y0: f64| {
            renderer.render(x0, y0, &mut img);
            let sums = ImageSums::of(&img, n);
            let truth = sums.centroid(n)?;
            Some((img.iter().map(|v| v / sums.total).collect::<Vec<f64>>(), truth))
        };
        let d = GRADIENT_STEP_PX;
        let mut gradient = |y: bool| {
            let (dx, dy) = if y { (0.0, d) } else { (d, 0.0) };
            let ((a, ta), (b, tb)) = (unit(dx, dy)?, unit(-dx, -dy)?);
            let moved = if y { ta.1 - tb.1 } else { ta.0 - tb.0 };
            (moved > 0.0).then(|| a.iter().zip(&b).map(|(a, b)| (a - b) / moved).collect())
        };
        match (gradient(false), gradient(true)) {
            (Some(gx), Some(gy)) => Ok(MatchedFilter { n, gx, gy }),
            _ => Err(Error::invalid(
                "centroider",
                "matched-filter: the spot does not move in the sub-aperture (no gradient)",
            )),
        }
    }

    /// The unit-total spot's gradient images (per px of truth), x then y.
    #[cfg(test)]
    pub(super) fn gradients(&self) -> (&[f64], &[f64]) {
        (&self.gx, &self.gy)
    }
}

impl Centroider for MatchedFilter {
    fn name(&self) -> String {
        ENTRY.name.into()
    }

    fn needs_noise_map(&self) -> bool {
        true
    }

    fn worker(&self) -> Box<dyn CentroidWorker + '_> {
        Box::new(FilterWorker {
            c: self,
            key: None,
            filter: None,
        })
    }
}

/// The inputs a filter was made from: mean spot (e-), noise map (e-), photon variance factor.
#[derive(Debug, Clone, PartialEq)]
struct FilterKey {
    mean_e: Vec<f64>,
    sigma_e: Vec<f64>,
    factor: f64,
}

/// The two shift rows of the filter and the mean spot's centroid (px from the centre).
#[derive(Debug, Clone)]
struct Filter {
    fx: Vec<f64>,
    fy: Vec<f64>,
    origin: (f64, f64),
}

/// A thread's filter, kept while its inputs do not change.
struct FilterWorker<'c> {
    c: &'c MatchedFilter,
    key: Option<FilterKey>,
    /// None when the weighted normal matrix is singular (no light): the estimate is the centre.
    filter: Option<Filter>,
}

impl FilterWorker<'_> {
    /// Make the filter of frame `f`'s inputs unless it is the one kept.
    fn refresh(&mut self, f: &CentroidFrame) {
        let same = self.key.as_ref().is_some_and(|k| {
            k.factor == f.photon_variance_factor && k.mean_e == f.mean_e && k.sigma_e == f.sigma_e
        });
        if !same {
            self.filter = make_filter(self.c, f.mean_e, f.sigma_e, f.photon_variance_factor);
            self.key = Some(FilterKey {
                mean_e: f.mean_e.to_vec(),
                sigma_e: f.sigma_e.to_vec(),
                factor: f.photon_variance_factor,
            });
        }
    }
}

/// The filter's shift rows: the first two rows of (G^T W G)^-1 G^T W, G = [F gx, F gy, I0],
/// W = diag(1 / max(F_v mean_i + sigma_i^2, floor)), F the mean spot's total; None when
/// G^T W G is singular to rounding.
fn make_filter(c: &MatchedFilter, mean: &[f64], sigma: &[f64], factor: f64) -> Option<Filter> {
    let npix = c.n * c.n;
    let sums = ImageSums::of(mean, c.n);
    let origin = sums.centroid(c.n)?;
    let flux = sums.total;
    let column = |k: usize, i: usize| match k {
        0 => flux * c.gx[i],
        1 => flux * c.gy[i],
        _ => mean[i],
    };
    let weight: Vec<f64> = (0..npix)
        .map(|i| 1.0 / (factor * mean[i] + sigma[i] * sigma[i]).max(VARIANCE_FLOOR_E2))
        .collect();
    let mut m = [[0.0; 3]; 3];
    for (i, &w) in weight.iter().enumerate() {
        let g = [column(0, i), column(1, i), column(2, i)];
        for a in 0..3 {
            for b in 0..3 {
                m[a][b] += g[a] * w * g[b];
            }
        }
    }
    let inv = inverse3(&m)?;
    let (mut fx, mut fy) = (vec![0.0; npix], vec![0.0; npix]);
    for (i, &w) in weight.iter().enumerate() {
        let g = [column(0, i), column(1, i), column(2, i)];
        fx[i] = w * (inv[0][0] * g[0] + inv[0][1] * g[1] + inv[0][2] * g[2]);
        fy[i] = w * (inv[1][0] * g[0] + inv[1][1] * g[1] + inv[1][2] * g[2]);
    }
    Some(Filter { fx, fy, origin })
}

/// Inverse of a symmetric positive 3 x 3 matrix by its adjugate; None when its determinant is
/// below 1e-12 of the product of its diagonal (singular to rounding, or not positive).
fn inverse3(m: &[[f64; 3]; 3]) -> Option<[[f64; 3]; 3]> {
    let cof = |r: usize, c: usize| {
        let (r1, r2) = ((r + 1) % 3, (r + 2) % 3);
        let (c1, c2) = ((c + 1) % 3, (c + 2) % 3);
        m[r1][c1] * m[r2][c2] - m[r1][c2] * m[r2][c1]
    };
    let det = m[0][0] * cof(0, 0) + m[0][1] * cof(0, 1) + m[0][2] * cof(0, 2);
    let scale = m[0][0] * m[1][1] * m[2][2];
    if !(det > 1e-12 * scale && scale > 0.0 && det.is_finite()) {
        return None;
    }
    let mut inv = [[0.0; 3]; 3];
    for (r, row) in inv.iter_mut().enumerate() {
        for (c, v) in row.iter_mut().enumerate() {
            // The inverse is the transposed cofactor matrix over the determinant.
            *v = cof(c, r) / det;
        }
    }
    Some(inv)
}

impl CentroidWorker for FilterWorker<'_> {
    fn accumulate(&mut self, f: &CentroidFrame, acc: &mut SettingSums) {
        self.refresh(f);
        let sums = acc.part_mut(0);
        let (ex, ey) = match &self.filter {
            Some(filter) => {
                let (mut tx, mut ty) = (0.0, 0.0);
                for ((&x, &m), (&wx, &wy)) in f
                    .image_e
                    .iter()
                    .zip(f.mean_e)
                    .zip(filter.fx.iter().zip(&filter.fy))
                {
                    tx += wx * (x - m);
                    ty += wy * (x - m);
                }
                (
                    filter.origin.0 + tx - f.truth_px.0,
                    filter.origin.1 + ty - f.truth_px.1,
                )
            }
            None => return sums.add_empty(0, f.truth_px),
        };
        sums.add_error(0, ex.hypot(ey), (ex, ey));
    }
}

#[cfg(test)]
mod tests {
    use super::inverse3;

    #[test]
    #[allow(clippy::needless_range_loop)] // a matrix product reads best as indices
    fn inverse3_inverts_and_refuses_singular_matrices() {
        let m = [[4.0, 1.0, 0.5], [1.0, 3.0, 0.2], [0.5, 0.2, 2.0]];
        let inv = inverse3(&m).unwrap();
        for r in 0..3 {
            for c in 0..3 {
                let v: f64 = (0..3).map(|k| m[r][k] * inv[k][c]).sum();
                assert!((v - f64::from(u8::from(r == c))).abs() < 1e-14, "{r} {c}: {v}");
            }
        }
        let singular = [[1.0, 2.0, 0.0], [2.0, 4.0, 0.0], [0.0, 0.0, 1.0]];
        assert!(inverse3(&singular).is_none());
        assert!(inverse3(&[[0.0; 3]; 3]).is_none());
    }
}
