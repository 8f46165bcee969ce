//! The per-pixel weighted least-squares fits of the mean dark, over all pixels in parallel
//! (deterministic whatever the thread count), and what is summed over them.

use rayon::prelude::*;

use super::design::Design;
use super::options::ConversionGain;
use super::wls::{Normal, Solution};
use crate::stats::median;
use serde::Serialize;

/// Pixels per parallel work item; sums are made per chunk, then in chunk order, so a result
/// does not depend on the number of threads.
pub(super) const CHUNK: usize = 4096;

/// The inverse conversion gain 1/K (adu/e-) of each pixel.
pub(super) enum PixelGain {
    /// One for all.
    Global(f64),
    /// One per pixel.
    Map(Vec<f64>),
}

impl PixelGain {
    /// From the options (already checked).
    pub fn new(k: &ConversionGain) -> Self {
        match k {
            ConversionGain::Global { e_per_adu, .. } => PixelGain::Global(1.0 / e_per_adu),
            ConversionGain::Map(m) => PixelGain::Map(m.iter().map(|k| 1.0 / k).collect()),
        }
    }

    /// 1/K of pixel `p` (adu/e-).
    #[inline]
    pub fn at(&self, p: usize) -> f64 {
        match self {
            PixelGain::Global(k) => *k,
            PixelGain::Map(m) => m[p],
        }
    }

    /// The median 1/K (adu/e-).
    pub fn typical(&self) -> f64 {
        match self {
            PixelGain::Global(k) => *k,
            PixelGain::Map(m) => median(m),
        }
    }
}

/// One pixel's fit: parameters F, (C,) D with SEs, and its chi2 (compact: millions are
/// held at once).
#[derive(Clone, Copy)]
pub(super) struct PixelFit {
    /// Parameters.
    pub x: [f64; 3],
    /// Their SEs.
    pub se: [f64; 3],
    /// Weighted sum of squared residuals.
    pub chi2: f64,
}

/// Rounds of reweighting by the model's variance after the first fit.
const REWEIGHT_ROUNDS: usize = 2;

/// Fit pixel `p` at 1/K `k` with temperature factors `factors` (one per condition); `None`
/// where a condition's mean or variance is not finite or the variance is not > 0 (a dead or
/// saturated pixel: no weight can be given).
///
/// Why the weights are the model's variance, not each condition's sample variance: behind an
/// EM register most frames of a pixel hold no charge, so a pixel that drew few events has both
/// a low mean and a low variance, and weighting by its own variance pulls the fit down. On the
/// 3 gains x 3 exposures fixture (tests/fixtures/campaign/emccd) sample-variance weights gave
/// CIC pulls of mean -0.88 and SD 1.49; the model's variance, read noise plus the signal's
/// shot noise times the register's F^2, gives mean and SD near 0 and 1. The signal in that
/// shot noise is the pixel's fitted one but at least the condition's median
/// ([`set_signal_floor`]): a pixel's own fit is noisy, and a low fit with the low variance it
/// implies would again weight its own low draws up.
/// `var` is scratch space (one variance per condition), reused from pixel to pixel so that
/// millions of fits allocate nothing.
#[inline]
pub(super) fn fit_pixel(
    design: &Design,
    k: f64,
    factors: &[f64],
    p: usize,
    var: &mut Vec<f64>,
) -> Option<PixelFit> {
    let conds = &design.conds;
    if conds.iter().any(|c| {
        let (y, v) = (c.stats.mean_adu[p], c.stats.var_adu2[p]);
        !(y.is_finite() && v.is_finite() && v > 0.0)
    }) {
        return None;
    }
    var.clear();
    var.extend(conds.iter().map(|c| c.stats.var_adu2[p]));
    let mut sol = solve_weighted(design, k, factors, p, var)?;
    for _ in 0..REWEIGHT_ROUNDS {
        model_variance(design, k, factors, p, &sol.x, var);
        sol = solve_weighted(design, k, factors, p, var)?;
    }
    let mut chi2 = 0.0;
    for (i, c) in conds.iter().enumerate() {
        let r = c.stats.mean_adu[p] - predicted(design, i, k, factors[i], &sol.x);
        chi2 += r * r * c.stats.frames as f64 / var[i];
    }
    Some(PixelFit {
        x: [sol.x[0], sol.x[1], sol.x[2]],
        se: [sol.se[0], sol.se[1], sol.se[2]],
        chi2,
    })
}

/// The model's mean dark (adu) of condition `i` at parameters `x`.
#[inline]
fn predicted(design: &Design, i: usize, k: f64, factor: f64, x: &[f64]) -> f64 {
    let row = design.row(i, k, factor);
    (0..design.npar()).map(|j| row[j] * x[j]).sum()
}

/// The weighted least-squares solution with per-condition variances `var` (adu^2).
#[inline]
fn solve_weighted(
    design: &Design,
    k: f64,
    factors: &[f64],
    p: usize,
    var: &[f64],
) -> Option<Solution<3>> {
    let mut n = Normal::<3>::new(design.npar());
    for (i, c) in design.conds.iter().enumerate() {
        let w = c.stats.frames as f64 / var[i];
        n.add(&design.row(i, k, factors[i]), c.stats.mean_adu[p], w);
    }
    n.solve()
}

/// Each condition's variance (adu^2) as the model gives it at parameters `x`: a variance
/// common to all conditions (read, frame-common and quantisation noise) plus the signal's
/// shot noise, F^2 g k s for a signal s (adu) above the offset. The common part is the
/// inverse-variance mean of the sample variances less their shot noise (the variance of a
/// sample variance being 2 v^2 / (n - 1)), so the low-signal conditions set it.
fn model_variance(design: &Design, k: f64, factors: &[f64], p: usize, x: &[f64], var: &mut [f64]) {
    let conds = &design.conds;
    let shot = |i: usize| {
        let c = &conds[i];
        let s = (predicted(design, i, k, factors[i], x) - x[0]).max(design.signal_floor_adu[i]);
        c.enf2 * c.g * k * s
    };
    let (mut sw, mut swr) = (0.0, 0.0);
    for (i, c) in conds.iter().enumerate() {
        let w = (c.stats.frames as f64 - 1.0).max(1.0) / (var[i] * var[i]);
        sw += w;
        swr += w * (c.stats.var_adu2[p] - shot(i));
    }
    // The floor keeps a weight finite when shot noise explains every sample variance.
    let floor = 1e-3
        * conds
            .iter()
            .map(|c| c.stats.var_adu2[p])
            .fold(f64::INFINITY, f64::min);
    let common = (swr / sw).max(floor);
    for (i, v) in var.iter_mut().enumerate() {
        *v = common + shot(i);
    }
}

/// Set each condition's signal floor of the weights to the median over pixels (every
/// `stride`-th) of the signal above the offset of a fit without floor.
pub(super) fn set_signal_floor(design: &mut Design, k: &PixelGain, factors: &[f64], stride: usize) {
    design.signal_floor_adu.iter_mut().for_each(|f| *f = 0.0);
    let n = design.npix.div_ceil(stride);
    let fits: Vec<Option<PixelFit>> = (0..n)
        .into_par_iter()
        .with_min_len(CHUNK)
        .map_init(Vec::new, |var, j| {
            fit_pixel(design, k.at(j * stride), factors, j * stride, var)
        })
        .collect();
    let floors: Vec<f64> = (0..design.conds.len())
        .map(|i| {
            let s: Vec<f64> = fits
                .iter()
                .enumerate()
                .filter_map(|(j, f)| {
                    let f = f.as_ref()?;
                    Some(predicted(design, i, k.at(j * stride), factors[i], &f.x) - f.x[0])
                })
                .collect();
            if s.is_empty() {
                0.0
            } else {
                median(&s).max(0.0)
            }
        })
        .collect();
    design.signal_floor_adu = floors;
}

/// The maps of all pixels (NaN where not fitted).
pub(super) struct Maps {
    /// F (adu).
    pub f: Vec<f64>,
    /// SE of F (adu).
    pub f_se: Vec<f64>,
    /// C (e-/frame), if fitted.
    pub c: Option<Vec<f64>>,
    /// SE of C.
    pub c_se: Option<Vec<f64>>,
    /// D (e-/s).
    pub d: Vec<f64>,
    /// SE of D.
    pub d_se: Vec<f64>,
    /// Reduced chi2 (NaN with no degree of freedom).
    pub reduced_chi2: Vec<f64>,
}

impl Maps {
    /// Pixels fitted.
    pub fn fitted(&self) -> usize {
        self.d.iter().filter(|v| v.is_finite()).count()
    }
}

/// Fit every pixel.
pub(super) fn fit_all(design: &Design, k: &PixelGain, factors: &[f64]) -> Maps {
    let fits: Vec<Option<PixelFit>> = (0..design.npix)
        .into_par_iter()
        .with_min_len(CHUNK)
        .map_init(Vec::new, |var, p| {
            fit_pixel(design, k.at(p), factors, p, var)
        })
        .collect();
    let dof = design.dof() as f64;
    let get = |f: &(dyn Fn(&PixelFit) -> f64 + Sync)| -> Vec<f64> {
        fits.par_iter()
            .map(|o| o.as_ref().map_or(f64::NAN, f))
            .collect()
    };
    let di = design.d_index();
    let (c, c_se) = if design.cic {
        (Some(get(&|p| p.x[1])), Some(get(&|p| p.se[1])))
    } else {
        (None, None)
    };
    Maps {
        f: get(&|p| p.x[0]),
        f_se: get(&|p| p.se[0]),
        c,
        c_se,
        d: get(&|p| p.x[di]),
        d_se: get(&|p| p.se[di]),
        reduced_chi2: get(&|p| if dof > 0.0 { p.chi2 / dof } else { f64::NAN }),
    }
}

/// The sum of chi2 over the fitted pixels among every `stride`-th one and their count, at
/// temperature factors `factors` (the profile cost of the doubling temperature).
pub(super) fn total_chi2(
    design: &Design,
    k: &PixelGain,
    factors: &[f64],
    stride: usize,
) -> (f64, usize) {
    let n = design.npix.div_ceil(stride);
    let parts: Vec<(f64, usize)> = (0..n.div_ceil(CHUNK))
        .into_par_iter()
        .map(|c| {
            let (mut s, mut var) = ((0.0, 0), Vec::new());
            for j in c * CHUNK..((c + 1) * CHUNK).min(n) {
                let p = j * stride;
                if let Some(f) = fit_pixel(design, k.at(p), factors, p, &mut var) {
                    s.0 += f.chi2;
                    s.1 += 1;
                }
            }
            s
        })
        .collect();
    parts.iter().fold((0.0, 0), |a, b| (a.0 + b.0, a.1 + b.1))
}

/// The fit quality of the maps: the flag threshold for p-value `p_flag` at `dof` degrees of
/// freedom, and how many pixels pass it.
pub(super) fn quality(maps: &Maps, dof: usize, p_flag: f64) -> FitQuality {
    use statrs::distribution::{ChiSquared, ContinuousCDF};
    let above = if dof == 0 {
        f64::INFINITY
    } else {
        ChiSquared::new(dof as f64)
            .map(|d| d.inverse_cdf(1.0 - p_flag) / dof as f64)
            .unwrap_or(f64::INFINITY)
    };
    FitQuality {
        dof,
        median_reduced_chi2: median(&maps.reduced_chi2),
        flag_p_value: p_flag,
        flag_reduced_chi2_above: above,
        pixels_flagged: maps.reduced_chi2.iter().filter(|&&r| r > above).count(),
    }
}

/// The change of the parameters of a typical pixel (each condition's median mean and
/// variance over pixels, the median 1/K) when each condition's EM gain moves by its SE,
/// added in quadrature: the systematic error the gains' SEs put on every pixel alike.
pub(super) fn gain_systematic(design: &Design, k: &PixelGain, factors: &[f64]) -> [f64; 3] {
    let y: Vec<f64> = design
        .conds
        .iter()
        .map(|c| median(&c.stats.mean_adu))
        .collect();
    let w: Vec<f64> = design
        .conds
        .iter()
        .map(|c| c.stats.frames as f64 / median(&c.stats.var_adu2))
        .collect();
    let kt = k.typical();
    let solve = |gains: &[f64]| -> Option<[f64; 3]> {
        let mut n = Normal::<3>::new(design.npar());
        for (i, c) in design.conds.iter().enumerate() {
            n.add(&design.row_at(gains[i], c.t, kt, factors[i]), y[i], w[i]);
        }
        let s = n.solve()?;
        Some([s.x[0], s.x[1], s.x[2]])
    };
    let gains: Vec<f64> = design.conds.iter().map(|c| c.g).collect();
    let Some(base) = solve(&gains) else {
        return [f64::NAN; 3];
    };
    let mut var = [0.0; 3];
    // Conditions at one commanded gain share its fitted value: move them together.
    let mut done = vec![false; gains.len()];
    for i in 0..gains.len() {
        if done[i] || design.conds[i].g_se == 0.0 {
            continue;
        }
        let mut moved = gains.clone();
        for j in 0..gains.len() {
            if gains[j] == gains[i] {
                moved[j] += design.conds[i].g_se;
                done[j] = true;
            }
        }
        if let Some(x) = solve(&moved) {
            for (v, (a, b)) in var.iter_mut().zip(x.iter().zip(&base)) {
                *v += (a - b).powi(2);
            }
        }
    }
    var.map(f64::sqrt)
}

/// Fit quality over the pixels.
#[derive(Clone, Debug, Serialize, PartialEq)]
pub struct FitQuality {
    /// Degrees of freedom of each pixel's fit (conditions minus parameters).
    pub dof: usize,
    /// Median reduced chi2 over the fitted pixels (1 when the model and the weights hold).
    pub median_reduced_chi2: f64,
    /// The p-value below which a fit is flagged.
    pub flag_p_value: f64,
    /// The reduced chi2 above which a fit is flagged (that p-value at `dof`).
    pub flag_reduced_chi2_above: f64,
    /// Pixels flagged.
    pub pixels_flagged: usize,
}
