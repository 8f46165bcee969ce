//! The random part's effective read noise: the constant sigma whose rms error sqrt(E|e|^2)
//! equals the rms of a detector's error about its mean (its frame-to-frame slope noise).
//!
//! A uniform camera has no static part (by symmetry its mean error is 0), so its whole rms
//! error is random: the constant sigma that reproduces the detector's random rms is the noise
//! a simulator should put on the slopes when the static part is removed by reference slopes
//! taken with the camera at the operating flux. It is solved from the final run of the
//! effective-noise solver (detector and constant-sigma references on common random numbers),
//! by interpolating the references' mean squared error linearly in sigma^2 (for a Gaussian
//! camera the centroid's variance is a photon term plus a read term in sigma^2) between the
//! two references that bracket the detector's random mean square, or extrapolating from the
//! nearest two when none does (flagged). Its standard error is that of the paired difference
//! D = random_ms_det - [(1 - t) ms_lo + t ms_hi] over the slope, from the experiment's block
//! sums: D's per-frame influence is |e|^2 - 2 mean(e) . e for the detector and |e|^2 for the
//! references.

use crate::montecarlo::{Experiment, Moment, MomentTerm, SimResult};

/// The constant sigma that reproduces a detector's random error.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RandomSigma {
    /// Constant sigma whose rms error equals the detector's random rms (e-); NaN when the
    /// references' errors do not grow with sigma.
    pub sigma_e: f64,
    /// Its standard error (e-), paired over common random numbers.
    pub se_e: f64,
    /// True when no two references bracket the detector's random mean square: the value is
    /// extrapolated from the nearest two.
    pub extrapolated: bool,
}

/// The static and random parts of a detector's error in an [`super::Effective`] (its last
/// field, serialised flat): the static offset at the detector's optimum and the constant sigma
/// that reproduces its random part. NaN (false) where no run gave them.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct EffectiveParts {
    /// Constant sigma whose rms error equals the detector's random rms (e-).
    pub sigma_random_e: f64,
    /// Standard error of `sigma_random_e` (e-), paired over common random numbers.
    pub sigma_random_se_e: f64,
    /// True when `sigma_random_e` is extrapolated (no two references of the final grid bracket
    /// the detector's random mean square).
    pub sigma_random_extrapolated: bool,
    /// The detector's random rms, the rms of its error about its mean (px).
    pub random_rms_px: f64,
    /// Static part: the detector's mean error along x (px).
    pub static_x_px: f64,
    /// Static part along y (px).
    pub static_y_px: f64,
    /// Length of the static offset (px).
    pub static_px: f64,
    /// Standard error of `static_px` (px).
    pub static_se_px: f64,
    /// True when `static_px` is at least 3 times its SE (a static part is resolved).
    pub static_resolved: bool,
}

impl Default for EffectiveParts {
    fn default() -> Self {
        EffectiveParts {
            sigma_random_e: f64::NAN,
            sigma_random_se_e: f64::NAN,
            sigma_random_extrapolated: false,
            random_rms_px: f64::NAN,
            static_x_px: f64::NAN,
            static_y_px: f64::NAN,
            static_px: f64::NAN,
            static_se_px: f64::NAN,
            static_resolved: false,
        }
    }
}

impl EffectiveParts {
    /// The parts of the detector's result `det` with its random sigma `random`.
    pub fn new(det: &SimResult, random: RandomSigma) -> Self {
        let p = &det.parts;
        EffectiveParts {
            sigma_random_e: random.sigma_e,
            sigma_random_se_e: random.se_e,
            sigma_random_extrapolated: random.extrapolated,
            random_rms_px: p.random_rms_px,
            static_x_px: p.static_x_px,
            static_y_px: p.static_y_px,
            static_px: p.static_px,
            static_se_px: p.static_se_px,
            static_resolved: p.static_resolved,
        }
    }
}

/// Where a detector's random mean square falls on the references' mean squared errors.
struct Bracket {
    /// The bracketing references (indices into the grid).
    lo: usize,
    hi: usize,
    /// The detector's position between them (0 at `lo`, 1 at `hi`; outside when extrapolated).
    t: f64,
    /// d(mean squared error)/d(sigma^2) between them (px^2 per e-^2).
    slope: f64,
    /// sigma^2 at the detector's random mean square (e-^2).
    var: f64,
    /// True when no two references bracket it.
    extrapolated: bool,
}

/// The bracket of `det`'s random mean square on `refs` (at the ascending sigmas `grid_e`),
/// None when the references' errors do not grow with sigma or the input is short.
fn bracket(det: &SimResult, refs: &[SimResult], grid_e: &[f64]) -> Option<Bracket> {
    if refs.len() < 2 || refs.len() != grid_e.len() {
        return None;
    }
    let target = det.parts.random_rms_px.powi(2);
    let ms: Vec<f64> = refs.iter().map(|r| r.parts.rms_px.powi(2)).collect();
    // The first reference at or above the target and the one before it, else the nearest two
    // at either end.
    let hi = (1..ms.len())
        .find(|&k| ms[k] >= target)
        .unwrap_or(ms.len() - 1);
    let lo = hi - 1;
    let (s0, s1) = (grid_e[lo].powi(2), grid_e[hi].powi(2));
    let slope = (ms[hi] - ms[lo]) / (s1 - s0);
    if !(slope > 0.0 && target.is_finite()) {
        return None;
    }
    let t = (target - ms[lo]) / (ms[hi] - ms[lo]);
    Some(Bracket {
        lo,
        hi,
        t,
        slope,
        var: (s0 + t * (s1 - s0)).max(0.0),
        extrapolated: !(ms[lo] <= target && target <= ms[hi]),
    })
}

/// The random sigma of bracket `b` with `se_ms`, the SE of the mean-square difference (px^2).
fn from_bracket(b: &Bracket, se_ms: f64) -> RandomSigma {
    let sigma = b.var.sqrt();
    RandomSigma {
        sigma_e: sigma,
        se_e: se_ms / b.slope / (2.0 * sigma),
        extrapolated: b.extrapolated,
    }
}

const NO_RANDOM_SIGMA: RandomSigma = RandomSigma {
    sigma_e: f64::NAN,
    se_e: f64::NAN,
    extrapolated: false,
};

/// The random sigma of `det` (arm 0 of `exp`) against the constant-sigma references `refs`
/// (arms 1.., at the ascending sigmas `grid_e`, e-), each at its own optimum setting.
pub fn random_sigma(
    exp: &Experiment,
    det: &SimResult,
    refs: &[SimResult],
    grid_e: &[f64],
) -> RandomSigma {
    let Some(b) = bracket(det, refs, grid_e) else {
        return NO_RANDOM_SIGMA;
    };
    let p = &det.parts;
    let term = |moment, arm, r: &SimResult, coef| MomentTerm {
        moment,
        arm,
        setting: r.best,
        coef,
    };
    let terms = [
        term(Moment::SquaredError, 0, det, 1.0),
        term(Moment::ErrorX, 0, det, -2.0 * p.static_x_px),
        term(Moment::ErrorY, 0, det, -2.0 * p.static_y_px),
        term(Moment::SquaredError, b.lo + 1, &refs[b.lo], -(1.0 - b.t)),
        term(Moment::SquaredError, b.hi + 1, &refs[b.hi], -b.t),
    ];
    from_bracket(&b, exp.paired_se_moments(&terms))
}

/// [`random_sigma`] for a detector run apart from its references (a sub-aperture beside the
/// `subaps` ladder, whose per-frame moments are not kept): the SE is the quadrature sum of the
/// detector's and the bracketing references' own SEs. They share frames, so their errors are
/// positively correlated and this SE overstates the paired one: conservative.
pub fn random_sigma_unpaired(det: &SimResult, refs: &[SimResult], grid_e: &[f64]) -> RandomSigma {
    let Some(b) = bracket(det, refs, grid_e) else {
        return NO_RANDOM_SIGMA;
    };
    // SE of a mean square m = rms^2 from the rms's SE: 2 rms SE(rms).
    let ms_se = |rms: f64, se: f64| 2.0 * rms * se;
    let p = &det.parts;
    let (lo, hi) = (&refs[b.lo].parts, &refs[b.hi].parts);
    let se = ms_se(p.random_rms_px, p.random_rms_se_px)
        .hypot((1.0 - b.t) * ms_se(lo.rms_px, lo.rms_se_px))
        .hypot(b.t * ms_se(hi.rms_px, hi.rms_se_px));
    from_bracket(&b, se)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::detector::{Readout, ScmosConstant};
    use crate::montecarlo::SimConfig;
    use crate::progress::Silent;

    #[test]
    fn a_uniform_camera_s_random_sigma_is_its_sigma() {
        // A uniform 1 e- camera beside references at 0.85-1.18 e- on common random numbers:
        // no static part, so its random rms is its rms, and the random sigma is 1 e- within
        // 3 SE (fixed seed). A noiseless "detector" lies below the grid: extrapolated, small.
        let mut cfg = SimConfig::paper(8);
        cfg.iters = 4000;
        let grid = [0.85, 0.95, 1.05, 1.18];
        let det = ScmosConstant::new(1.0, "uniform".into());
        let quiet = ScmosConstant::new(0.0, "noiseless".into());
        let refs: Vec<ScmosConstant> = grid
            .iter()
            .map(|&s| ScmosConstant::new(s, format!("{s}")))
            .collect();
        for (d, want) in [(&det, Some(1.0)), (&quiet, None)] {
            let models: Vec<&dyn Readout> = std::iter::once(d as &dyn Readout)
                .chain(refs.iter().map(|r| r as &dyn Readout))
                .collect();
            let mut exp = Experiment::new(&cfg, &models).unwrap().with_blocks();
            exp.extend_to(cfg.iters, &Silent, 1).unwrap();
            let mut results = exp.results().unwrap();
            let det = results.remove(0);
            let r = random_sigma(&exp, &det, &results, &grid);
            match want {
                Some(w) => {
                    assert!(!r.extrapolated && r.se_e > 0.0 && r.se_e < 0.1, "{r:?}");
                    assert!((r.sigma_e - w).abs() < 3.0 * r.se_e, "{r:?}");
                }
                None => assert!(r.extrapolated && r.sigma_e < 0.85, "{r:?}"),
            }
        }
    }
}

#[cfg(test)]
mod window_tests {
    use crate::calib::{Map, Unit};
    use crate::detector::PerPixelSigma;
    use crate::effective::{effective_sigma, Precision};
    use crate::montecarlo::SimConfig;
    use crate::progress::Silent;

    #[test]
    fn a_real_map_window_has_a_resolved_static_part_and_a_random_sigma() {
        // The bundled synthetic camera's 8x8 window at the origin (airy:2, 50 photons, cog,
        // 20,000 frames, fixed seed): a fixed window's noisy pixels give a static offset (0.038
        // +- 0.001 px here, against a random rms of 0.20 px), and the random part has a
        // bracketed sigma (2.13 e-; sigma_eff of R 2.00 e-: R, a mean distance, weighs the
        // window's occasional large errors less than the rms does).
        let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("data-synthetic/scmos-darks-64x64.truth-rms_e.fits");
        let map = Map::read(&path, Unit::Electrons).unwrap();
        let n = 8;
        let sigma: Vec<f64> = (0..n * n).map(|i| map.at(i / n, i % n)).collect();
        let detector = PerPixelSigma::new(sigma, "window 0,0".into());
        let mut cfg = SimConfig::paper(n);
        cfg.iters = 20_000;
        let e = effective_sigma(&cfg, &detector, &Precision::default(), &Silent).unwrap();
        let p = &e.parts;
        assert!(
            p.static_resolved && p.static_px > 10.0 * p.static_se_px,
            "{p:?}"
        );
        assert!(
            !p.sigma_random_extrapolated && p.sigma_random_se_e < 0.05,
            "{p:?}"
        );
        assert!((p.sigma_random_e - e.sigma_eff_e).abs() < 0.5, "{p:?}");
    }
}
