//! The datasheet's temporal numbers (EMVA 1288 release 4.0, linear camera) from the reduced
//! photon-transfer series: system gain, quantum efficiency, temporal dark noise, saturation
//! capacity, SNR, dynamic range, absolute sensitivity threshold, linearity error and dark
//! current, each a [`Quantity`] with its standard error and status.
//!
//! Standard errors are propagated from each point's own (pair) errors through the fits, then
//! scaled up by sqrt(chi^2 / dof) when the points scatter more than those errors (the Birge
//! ratio: a camera that is not linear in the fit range, a drifting light source). Derived
//! numbers propagate their inputs' errors as if independent.
//!
//! Where detnoise differs from the reference implementation (emva1288 1.x) on purpose:
//! saturation is the point of maximum variance over the whole series (emva1288 walks down from
//! the brightest point and stops at the first local maximum: past saturation the variance is a
//! noisy plateau of read noise, where that walk can stop at once; on the bundled camera it
//! takes the last point, 11,324 e- for a 9,000 e- well, detnoise 8,672 e-); the absolute sensitivity threshold is the exact root of SNR = 1,
//! (1/2 + sqrt(1/4 + sigma_y.dark^2 / K^2)) e-, where emva1288 uses the approximation
//! sigma_y.dark / K + 1/2; with a single exposure time the dark variance is the mean of every
//! point's dark pair (emva1288 takes the first point's); a negative dark-current slope is
//! reported with its SE (emva1288 gives NaN for the variance one), as a dark current consistent
//! with zero is a result.

use serde::Serialize;

use super::pairs::PointStats;
use super::quantity::{Quantity, QuantityStatus};

/// The standard's minimum number of photon-transfer points (irradiation steps).
pub const MIN_POINTS: usize = 50;
/// Top of the sensitivity fit range (K, R): signals up to this fraction of saturation's.
pub const SENSITIVITY_FIT_TOP: f64 = 0.7;
/// The linearity fit range: signals between these fractions of saturation's.
pub const LINEARITY_FIT_RANGE: (f64, f64) = (0.05, 0.95);
/// The standard's floor of the temporal dark variance (DN^2): below it quantisation dominates.
pub const DARK_VARIANCE_FLOOR_DN2: f64 = 0.24;
/// Quantisation noise variance (DN^2).
pub const QUANTISATION_VARIANCE_DN2: f64 = 1.0 / 12.0;
/// A number is `imprecise` when its SE exceeds this fraction of its magnitude.
pub const IMPRECISE_RELATIVE_SE: f64 = 0.1;
/// A linearity error is `imprecise` when its SE exceeds this (percentage points).
pub const IMPRECISE_LINEARITY_SE_PERCENT: f64 = 0.1;
/// Dark current needs dark pairs at at least this many distinct exposure times.
pub const MIN_DARK_EXPOSURES: usize = 3;

/// One point of the photon-transfer, SNR and linearity curves.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct CurvePoint {
    /// Exposure time (s).
    pub exposure_s: f64,
    /// Mean photons per pixel, when given.
    pub photons_per_px: Option<f64>,
    /// Signal: bright mean less dark mean (DN).
    pub signal_dn: f64,
    /// Its standard error (DN).
    pub signal_se_dn: f64,
    /// Temporal variance of the bright pair, drift corrected (DN^2).
    pub bright_variance_dn2: f64,
    /// Photon-transfer variance: bright less dark temporal variance (DN^2).
    pub variance_dn2: f64,
    /// Its standard error (DN^2).
    pub variance_se_dn2: f64,
    /// Mean of the dark pair (DN).
    pub dark_mean_dn: f64,
    /// Temporal variance of the dark pair, drift corrected (DN^2).
    pub dark_variance_dn2: f64,
    /// Drift of the mean between the bright pair's frames, A - B (DN).
    pub bright_drift_dn: f64,
    /// Measured SNR: signal over the bright temporal standard deviation.
    pub snr: f64,
    /// The linear model's SNR at this signal (from K and the temporal dark noise).
    pub snr_model: f64,
    /// Deviation from the linearity fit (%; NaN when linearity is not computed).
    pub linearity_deviation_percent: f64,
}

/// The datasheet's temporal numbers, each with its SE and status.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct TemporalResult {
    /// The curves, one entry per point in the dataset's order.
    pub points: Vec<CurvePoint>,
    /// Index of the saturation point (maximum temporal variance).
    pub saturation_index: usize,
    /// First and last index (inclusive) of the sensitivity fit (K, R).
    pub sensitivity_fit: [usize; 2],
    /// First and last index (inclusive) of the linearity fit (None: not computed).
    pub linearity_fit: Option<[usize; 2]>,
    /// The rules of the standard this dataset breaks (empty: none).
    pub rules_broken: Vec<String>,
    /// System gain K (DN/e-).
    pub system_gain_dn_per_e: Quantity,
    /// Responsivity R = QE * K (DN/photon).
    pub responsivity_dn_per_photon: Quantity,
    /// Quantum efficiency (%).
    pub quantum_efficiency_percent: Quantity,
    /// Temporal dark noise sigma_y.dark (DN), the standard's floor applied.
    pub dark_noise_dn: Quantity,
    /// Whether the floor (sqrt(0.24) DN) replaced the measured dark noise.
    pub dark_noise_floored: bool,
    /// Temporal dark noise sigma_d (e-), quantisation noise removed.
    pub dark_noise_e: Quantity,
    /// Saturation capacity mu_e.sat (e-).
    pub saturation_capacity_e: Quantity,
    /// Saturation irradiation mu_p.sat (photons per pixel).
    pub saturation_photons_per_px: Quantity,
    /// Maximum SNR, sqrt(mu_e.sat) (ratio).
    pub snr_max: Quantity,
    /// Maximum SNR (dB, 20 log10).
    pub snr_max_db: Quantity,
    /// Dynamic range mu_e.sat / mu_e.min (ratio).
    pub dynamic_range: Quantity,
    /// Dynamic range (dB, 20 log10).
    pub dynamic_range_db: Quantity,
    /// Absolute sensitivity threshold mu_e.min (e-).
    pub sensitivity_threshold_e: Quantity,
    /// Absolute sensitivity threshold mu_p.min (photons per pixel).
    pub sensitivity_threshold_photons_per_px: Quantity,
    /// Minimum linearity error LE_min (%).
    pub linearity_error_min_percent: Quantity,
    /// Maximum linearity error LE_max (%).
    pub linearity_error_max_percent: Quantity,
    /// Dark current from the slope of the dark mean with exposure time (e-/s).
    pub dark_current_mean_e_per_s: Quantity,
    /// Dark current from the slope of the dark variance with exposure time (e-/s).
    pub dark_current_variance_e_per_s: Quantity,
}

/// A number derived from a vector of base estimates.
type Derived = fn(&[f64]) -> f64;

/// A straight-line fit with its parameters' standard errors.
#[derive(Clone, Copy, Debug)]
struct Line {
    slope: f64,
    slope_se: f64,
    intercept: f64,
    intercept_se: f64,
}

/// Least squares of `y` = slope * x + intercept (or through the origin when `origin`), each y
/// with its variance `var` (used only for the SEs, not as weights: the standard's fits are
/// unweighted). SEs are propagated, then scaled by the Birge ratio when above 1.
fn fit_line(x: &[f64], y: &[f64], var: &[f64], origin: bool) -> Line {
    let n = x.len() as f64;
    // The fit as weights c (slope) and d (intercept) on y: both are linear in y.
    let (c, d): (Vec<f64>, Vec<f64>) = if origin {
        let sxx: f64 = x.iter().map(|v| v * v).sum();
        (x.iter().map(|v| v / sxx).collect(), vec![0.0; x.len()])
    } else {
        let xm = x.iter().sum::<f64>() / n;
        let sxx: f64 = x.iter().map(|v| (v - xm) * (v - xm)).sum();
        let c: Vec<f64> = x.iter().map(|v| (v - xm) / sxx).collect();
        let d = c.iter().map(|ci| 1.0 / n - xm * ci).collect();
        (c, d)
    };
    let dot = |w: &[f64], v: &[f64]| w.iter().zip(v).map(|(a, b)| a * b).sum::<f64>();
    let slope = dot(&c, y);
    let intercept = dot(&d, y);
    let chi2: f64 = (0..x.len())
        .map(|i| (y[i] - slope * x[i] - intercept).powi(2) / var[i])
        .sum();
    let dof = n - if origin { 1.0 } else { 2.0 };
    let birge = if dof > 0.0 && chi2.is_finite() {
        (chi2 / dof).max(1.0).sqrt()
    } else {
        1.0
    };
    let se = |w: &[f64]| {
        birge
            * w.iter()
                .zip(var)
                .map(|(a, v)| a * a * v)
                .sum::<f64>()
                .sqrt()
    };
    Line {
        slope,
        slope_se: se(&c),
        intercept,
        intercept_se: se(&d),
    }
}

/// f at `base` values and its SE, propagating the (independent) SEs of `base` by central
/// differences.
fn propagate(base: &[(f64, f64)], f: impl Fn(&[f64]) -> f64) -> (f64, f64) {
    let values: Vec<f64> = base.iter().map(|b| b.0).collect();
    let value = f(&values);
    let mut var = 0.0;
    for (i, &(v, se)) in base.iter().enumerate() {
        if se == 0.0 || !se.is_finite() {
            continue;
        }
        let h = 1e-4 * se.max(1e-12 * v.abs());
        let mut p = values.clone();
        p[i] = v + h;
        let up = f(&p);
        p[i] = v - h;
        let down = f(&p);
        var += ((up - down) / (2.0 * h) * se).powi(2);
    }
    (value, var.sqrt())
}

/// A computed number judged: unavailable when not finite, imprecise when its SE exceeds
/// `max_se` (given its value), out of rules when `rules` is not empty.
fn judged((value, se): (f64, f64), max_se: impl Fn(f64) -> f64, rules: &[String]) -> Quantity {
    if !value.is_finite() {
        return Quantity::unavailable("not finite for this dataset (a negative variance?)");
    }
    let mut q = Quantity::ok(value, se);
    if se > max_se(value) {
        q.status = QuantityStatus::Imprecise;
    }
    if rules.is_empty() {
        q
    } else {
        q.out_of_rules(rules.join("; "))
    }
}

fn relative(v: f64) -> f64 {
    IMPRECISE_RELATIVE_SE * v.abs()
}

/// The temporal datasheet numbers of the reduced series `points` (in the dataset's order, by
/// increasing irradiation; at least one point).
pub fn temporal(points: &[PointStats]) -> TemporalResult {
    assert!(!points.is_empty(), "temporal needs at least one point");
    let n = points.len();
    let signal: Vec<f64> = points
        .iter()
        .map(|p| p.bright.mean_dn - p.dark.mean_dn)
        .collect();
    let signal_var: Vec<f64> = points
        .iter()
        .map(|p| p.bright.mean_se_dn.powi(2) + p.dark.mean_se_dn.powi(2))
        .collect();
    let ptc: Vec<f64> = points
        .iter()
        .map(|p| p.bright.variance_dn2 - p.dark.variance_dn2)
        .collect();
    let ptc_var: Vec<f64> = points
        .iter()
        .map(|p| p.bright.variance_se_dn2.powi(2) + p.dark.variance_se_dn2.powi(2))
        .collect();

    let mut rules = Vec::new();
    if n < MIN_POINTS {
        rules.push(format!(
            "{n} photon-transfer points, the standard asks for at least {MIN_POINTS}"
        ));
    }
    let sat = saturation_index(points);
    let mut sat_rules = rules.clone();
    if sat + 1 == n {
        let rule = "variance still rising at the brightest point: no point beyond saturation";
        sat_rules.push(rule.to_string());
        rules_push_unique(&mut rules, rule);
    }
    let x_sat = signal[sat];
    let top = (0..n)
        .filter(|&i| signal[i] <= SENSITIVITY_FIT_TOP * x_sat)
        .max()
        .unwrap_or(0);
    let fit = 0..top + 1;

    // System gain: the photon transfer through the origin over the sensitivity range.
    let k_line = fit_line(
        &signal[fit.clone()],
        &ptc[fit.clone()],
        &ptc_var[fit.clone()],
        true,
    );
    let k = (k_line.slope, k_line.slope_se);
    let system_gain = if fit.len() < 2 {
        Quantity::unavailable("fewer than 2 points below 70 % of saturation")
    } else {
        judged(k, relative, &rules)
    };

    let photons: Option<Vec<f64>> = points.iter().map(|p| p.photons_per_px).collect();
    let r = photons.as_ref().map(|p| {
        let line = fit_line(
            &p[fit.clone()],
            &signal[fit.clone()],
            &signal_var[fit.clone()],
            true,
        );
        (line.slope, line.slope_se)
    });
    let no_photons = "the dataset gives no photons per pixel";
    let (responsivity, qe) = match r {
        Some(r) if fit.len() >= 2 => (
            judged(r, relative, &rules),
            judged(
                propagate(&[r, k], |v| 100.0 * v[0] / v[1]),
                relative,
                &rules,
            ),
        ),
        _ => (
            Quantity::unavailable(no_photons),
            Quantity::unavailable(no_photons),
        ),
    };

    let (s2_dark, s2_dark_se) = dark_variance_at_zero(points);
    let floored = s2_dark < DARK_VARIANCE_FLOOR_DN2;
    let s2d = if floored {
        (DARK_VARIANCE_FLOOR_DN2, 0.0)
    } else {
        (s2_dark, s2_dark_se)
    };
    let dark_noise_dn = judged(propagate(&[s2d], |v| v[0].sqrt()), relative, &[]);
    let dark_noise_e = judged(
        propagate(&[s2d, k], |v| {
            (v[0] - QUANTISATION_VARIANCE_DN2).sqrt() / v[1]
        }),
        relative,
        &rules,
    );
    // mu_e.min: the exact root of SNR = 1 for sigma_y.dark (with quantisation) and K.
    let e_min = |v: &[f64]| 0.5 + (0.25 + v[0] / (v[1] * v[1])).sqrt();
    let threshold_e = judged(propagate(&[s2d, k], e_min), relative, &rules);

    let p_sat = photons.as_ref().map(|p| (p[sat], 0.0));
    // mu_e.sat = QE mu_p.sat when photons are given (the standard's), else signal / K.
    let (sat_base, e_sat): (Vec<(f64, f64)>, Derived) = match (p_sat, r) {
        (Some(ps), Some(r)) => (vec![r, k, ps, s2d], |v| v[0] / v[1] * v[2]),
        _ => (
            vec![(x_sat, signal_var[sat].sqrt()), k, (f64::NAN, 0.0), s2d],
            |v| v[0] / v[1],
        ),
    };
    let saturation_capacity_e = judged(propagate(&sat_base, e_sat), relative, &sat_rules);
    let saturation_photons_per_px = match p_sat {
        Some(ps) => judged(ps, relative, &sat_rules),
        None => Quantity::unavailable(no_photons),
    };
    let snr_max = judged(
        propagate(&sat_base, |v| e_sat(v).sqrt()),
        relative,
        &sat_rules,
    );
    let snr_max_db = judged(
        propagate(&sat_base, |v| 10.0 * e_sat(v).log10()),
        |_| f64::INFINITY,
        &sat_rules,
    );
    let dr = |v: &[f64]| e_sat(v) / e_min(&[v[3], v[1]]);
    let dynamic_range = judged(propagate(&sat_base, dr), relative, &sat_rules);
    let dynamic_range_db = judged(
        propagate(&sat_base, |v| 20.0 * dr(v).log10()),
        |_| f64::INFINITY,
        &sat_rules,
    );
    let sensitivity_threshold_photons_per_px = match r {
        Some(r) => judged(
            propagate(&[s2d, k, r], |v| e_min(v) * v[1] / v[2]),
            relative,
            &rules,
        ),
        None => Quantity::unavailable(no_photons),
    };

    let lin = linearity(points, &signal, &signal_var, x_sat, photons.as_deref());
    let (linearity_fit, deviation, le_min, le_max) = match lin {
        Some(l) => {
            let max_se = |_| IMPRECISE_LINEARITY_SE_PERCENT;
            (
                Some(l.range),
                l.deviation,
                judged(l.min, max_se, &sat_rules),
                judged(l.max, max_se, &sat_rules),
            )
        }
        None => {
            let why = "no photons per pixel and a single exposure time: nothing to fit the \
                       signal against";
            (
                None,
                vec![f64::NAN; n],
                Quantity::unavailable(why),
                Quantity::unavailable(why),
            )
        }
    };

    let (dark_current_mean_e_per_s, dark_current_variance_e_per_s) =
        dark_current(points, k, &rules);

    let sigma_dark2 = s2d.0;
    let curve = (0..n)
        .map(|i| {
            let p = &points[i];
            let mu_e = signal[i] / k.0;
            CurvePoint {
                exposure_s: p.exposure_s,
                photons_per_px: p.photons_per_px,
                signal_dn: signal[i],
                signal_se_dn: signal_var[i].sqrt(),
                bright_variance_dn2: p.bright.variance_dn2,
                variance_dn2: ptc[i],
                variance_se_dn2: ptc_var[i].sqrt(),
                dark_mean_dn: p.dark.mean_dn,
                dark_variance_dn2: p.dark.variance_dn2,
                bright_drift_dn: p.bright.drift_dn,
                snr: signal[i] / p.bright.variance_dn2.sqrt(),
                snr_model: mu_e / (sigma_dark2 / (k.0 * k.0) + mu_e).sqrt(),
                linearity_deviation_percent: deviation[i],
            }
        })
        .collect();

    TemporalResult {
        points: curve,
        saturation_index: sat,
        sensitivity_fit: [0, top],
        linearity_fit,
        rules_broken: rules,
        system_gain_dn_per_e: system_gain,
        responsivity_dn_per_photon: responsivity,
        quantum_efficiency_percent: qe,
        dark_noise_dn,
        dark_noise_floored: floored,
        dark_noise_e,
        saturation_capacity_e,
        saturation_photons_per_px,
        snr_max,
        snr_max_db,
        dynamic_range,
        dynamic_range_db,
        sensitivity_threshold_e: threshold_e,
        sensitivity_threshold_photons_per_px,
        linearity_error_min_percent: le_min,
        linearity_error_max_percent: le_max,
        dark_current_mean_e_per_s,
        dark_current_variance_e_per_s,
    }
}

fn rules_push_unique(rules: &mut Vec<String>, rule: &str) {
    if !rules.iter().any(|r| r == rule) {
        rules.push(rule.to_string());
    }
}

/// The saturation point: the maximum of the bright pairs' temporal variance (the first one on
/// a tie).
pub fn saturation_index(points: &[PointStats]) -> usize {
    let mut best = 0;
    for (i, p) in points.iter().enumerate() {
        if p.bright.variance_dn2 > points[best].bright.variance_dn2 {
            best = i;
        }
    }
    best
}

fn distinct_exposures(points: &[PointStats]) -> usize {
    let mut t: Vec<f64> = points.iter().map(|p| p.exposure_s).collect();
    t.sort_by(f64::total_cmp);
    t.dedup();
    t.len()
}

/// The temporal dark variance at zero exposure (DN^2) and its SE: the intercept of the dark
/// variances against exposure time when there are enough exposure times (dark current's shot
/// noise removed), else the mean of every dark pair's.
fn dark_variance_at_zero(points: &[PointStats]) -> (f64, f64) {
    let t: Vec<f64> = points.iter().map(|p| p.exposure_s).collect();
    let v: Vec<f64> = points.iter().map(|p| p.dark.variance_dn2).collect();
    let var: Vec<f64> = points
        .iter()
        .map(|p| p.dark.variance_se_dn2.powi(2))
        .collect();
    if distinct_exposures(points) >= MIN_DARK_EXPOSURES {
        let line = fit_line(&t, &v, &var, false);
        return (line.intercept, line.intercept_se);
    }
    let n = v.len() as f64;
    let mean = v.iter().sum::<f64>() / n;
    // The spread of the points when larger than their own errors (a drifting dark level).
    let scatter = v.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / (n - 1.0).max(1.0);
    let own = var.iter().sum::<f64>() / n;
    (mean, (own.max(scatter) / n).sqrt())
}

/// Dark current from the mean and from the variance (e-/s), each with its SE.
fn dark_current(points: &[PointStats], k: (f64, f64), rules: &[String]) -> (Quantity, Quantity) {
    let exposures = distinct_exposures(points);
    if exposures < MIN_DARK_EXPOSURES {
        let why = format!(
            "dark pairs at {exposures} exposure time(s), the fit needs at least \
             {MIN_DARK_EXPOSURES}"
        );
        return (Quantity::unavailable(&why), Quantity::unavailable(why));
    }
    let t: Vec<f64> = points.iter().map(|p| p.exposure_s).collect();
    let mean: Vec<f64> = points.iter().map(|p| p.dark.mean_dn).collect();
    let mean_var: Vec<f64> = points.iter().map(|p| p.dark.mean_se_dn.powi(2)).collect();
    let v: Vec<f64> = points.iter().map(|p| p.dark.variance_dn2).collect();
    let v_var: Vec<f64> = points
        .iter()
        .map(|p| p.dark.variance_se_dn2.powi(2))
        .collect();
    let by_mean = fit_line(&t, &mean, &mean_var, false);
    let by_var = fit_line(&t, &v, &v_var, false);
    // Dark current's e- are read with gain K: its mean grows by K, its variance by K^2.
    let abs_se = |x: f64| IMPRECISE_RELATIVE_SE * x.abs();
    (
        judged(
            propagate(&[(by_mean.slope, by_mean.slope_se), k], |v| v[0] / v[1]),
            abs_se,
            rules,
        ),
        judged(
            propagate(&[(by_var.slope, by_var.slope_se), k], |v| {
                v[0] / (v[1] * v[1])
            }),
            abs_se,
            rules,
        ),
    )
}

struct Linearity {
    range: [usize; 2],
    deviation: Vec<f64>,
    min: (f64, f64),
    max: (f64, f64),
}

/// The standard's linearity fit: signal against photons (or exposure time when photons are not
/// given), minimising relative deviations, over signals between 5 % and 95 % of saturation's;
/// the deviation of every point from it (%). None when there is nothing to fit against or
/// fewer than 2 points in range.
fn linearity(
    points: &[PointStats],
    signal: &[f64],
    signal_var: &[f64],
    x_sat: f64,
    photons: Option<&[f64]>,
) -> Option<Linearity> {
    let x: Vec<f64> = match photons {
        Some(p) => p.to_vec(),
        None if distinct_exposures(points) >= 2 => points.iter().map(|p| p.exposure_s).collect(),
        None => return None,
    };
    let (lo, hi) = LINEARITY_FIT_RANGE;
    let first = (0..signal.len()).find(|&i| signal[i] >= lo * x_sat)?;
    let last = (0..signal.len())
        .filter(|&i| signal[i] <= hi * x_sat)
        .max()?;
    if last <= first {
        return None;
    }
    // Weighted least squares with weights 1 / signal^2: relative deviations minimised.
    let (mut sw, mut swx, mut swy, mut swxx, mut swxy) = (0.0, 0.0, 0.0, 0.0, 0.0);
    for i in first..=last {
        let w = 1.0 / (signal[i] * signal[i]);
        sw += w;
        swx += w * x[i];
        swy += w * signal[i];
        swxx += w * x[i] * x[i];
        swxy += w * x[i] * signal[i];
    }
    let det = sw * swxx - swx * swx;
    let a = (sw * swxy - swx * swy) / det;
    let b = (swxx * swy - swx * swxy) / det;
    let deviation: Vec<f64> = (0..x.len())
        .map(|i| {
            let model = a * x[i] + b;
            100.0 * (signal[i] - model) / model
        })
        .collect();
    let se = |i: usize| 100.0 * signal_var[i].sqrt() / (a * x[i] + b);
    let pick = |better: fn(f64, f64) -> bool| {
        let mut j = first;
        for i in first..=last {
            if better(deviation[i], deviation[j]) {
                j = i;
            }
        }
        (deviation[j], se(j))
    };
    Some(Linearity {
        range: [first, last],
        min: pick(|a, b| a < b),
        max: pick(|a, b| a > b),
        deviation,
    })
}

#[cfg(test)]
mod tests;
