//! The temperature term of the dark current, D(T) = D_ref 2^((T - T_ref)/T_d) (EMVA 1288):
//! given, or with T_d fitted globally by profiling the total chi2 of all pixels' fits.

use super::design::{Design, CAMPAIGN};
use super::options::TemperatureTerm;
use super::pixels::{total_chi2, PixelGain};
use super::result::TemperatureSummary;
use crate::error::{Error, Result};
use crate::stats::median;

/// The doubling temperatures searched (deg C): sensors double their dark current every
/// 3-15 deg C; the range is wide so a value at its edge means the data do not constrain it.
const SEARCH_C: (f64, f64) = (0.3, 300.0);

/// The temperature term resolved for a design.
pub(super) struct Temperature {
    /// Factor 2^((T - T_ref)/T_d) of each condition (1 without the term).
    pub factors: Vec<f64>,
    /// The term as fitted or given.
    pub summary: Option<TemperatureSummary>,
    /// Notes for the summary.
    pub notes: Vec<String>,
}

fn factors(temps: &[f64], reference: f64, doubling: f64) -> Vec<f64> {
    temps
        .iter()
        .map(|t| ((t - reference) / doubling).exp2())
        .collect()
}

/// Resolve `term` for `design`: checks that every dark has a temperature (and, to fit T_d,
/// that there are two or more and a degree of freedom left), then fits T_d if asked.
pub(super) fn resolve(
    design: &Design,
    k: &PixelGain,
    term: &TemperatureTerm,
) -> Result<Temperature> {
    let given: Vec<f64> = design.conds.iter().filter_map(|c| c.temp).collect();
    let mut distinct = given.clone();
    distinct.sort_by(f64::total_cmp);
    distinct.dedup();
    let (reference, doubling) = match *term {
        TemperatureTerm::Off => {
            let notes = if distinct.len() > 1 {
                vec![format!(
                    "the darks are at {} temperatures ({} to {} deg C) but the temperature term \
                     is off: D is an average over them",
                    distinct.len(),
                    distinct[0],
                    distinct[distinct.len() - 1]
                )]
            } else {
                Vec::new()
            };
            return Ok(Temperature {
                factors: vec![1.0; design.conds.len()],
                summary: None,
                notes,
            });
        }
        TemperatureTerm::Fit { reference_c } => (reference_c, None),
        TemperatureTerm::Given {
            doubling_c,
            reference_c,
        } => {
            if !(doubling_c.is_finite() && doubling_c > 0.0) {
                return Err(Error::invalid(
                    "temperature",
                    format!("doubling temperature {doubling_c} deg C must be finite and > 0"),
                ));
            }
            (reference_c, Some(doubling_c))
        }
    };
    if let Some(c) = design.conds.iter().find(|c| c.temp.is_none()) {
        return Err(Error::input(
            &c.stats.file,
            "no temperature: the temperature term of the dark current needs every dark's \
             temperature_c",
        ));
    }
    if let Some(r) = reference {
        if !r.is_finite() {
            return Err(Error::invalid(
                "temperature",
                format!("reference temperature {r} deg C must be finite"),
            ));
        }
    }
    let reference = reference.unwrap_or_else(|| median(&given));
    let (doubling, se, fitted) = match doubling {
        Some(d) => (d, 0.0, false),
        None => {
            let exposed: Vec<f64> = design
                .conds
                .iter()
                .filter(|c| c.t > 0.0)
                .filter_map(|c| c.temp)
                .collect();
            if exposed.iter().all(|t| *t == exposed[0]) {
                return Err(Error::invalid(
                    CAMPAIGN,
                    format!(
                        "the doubling temperature needs darks (with t > 0) at two or more \
                         temperatures; all are at {} deg C",
                        exposed[0]
                    ),
                ));
            }
            if design.dof() == 0 {
                return Err(Error::invalid(
                    CAMPAIGN,
                    "the doubling temperature needs more dark conditions than parameters per \
                     pixel (every pixel is fitted exactly at any doubling temperature)",
                ));
            }
            let (d, se) = fit_doubling(design, k, &given, reference)?;
            (d, se, true)
        }
    };
    Ok(Temperature {
        factors: factors(&given, reference, doubling),
        summary: Some(TemperatureSummary {
            reference_c: reference,
            doubling_c: doubling,
            doubling_se_c: se,
            fitted,
            temperatures_c: distinct,
        }),
        notes: Vec::new(),
    })
}

/// Pixels the search for T_d looks at, at most (every n-th pixel): the search is then cheap,
/// and its result is refined on all pixels.
const SEARCH_PIXELS: usize = 1 << 16;

/// T_d minimising the total chi2 of all pixels, and its SE from the curvature of the total
/// chi2 (Delta chi2 = 1), inflated by sqrt(total chi2 / dof) when that is above 1. A
/// log-spaced scan and a golden-section search in ln T_d on a subsample of the pixels find
/// the minimum within a few SEs; two Newton steps on all pixels, from parabolas through
/// T_d and T_d +- h, put it at the minimum of all of them.
fn fit_doubling(
    design: &Design,
    k: &PixelGain,
    temps: &[f64],
    reference: f64,
) -> Result<(f64, f64)> {
    let stride = design.npix.div_ceil(SEARCH_PIXELS).max(1);
    let cost =
        |ln_td: f64| total_chi2(design, k, &factors(temps, reference, ln_td.exp()), stride).0;
    let (lo, hi) = (SEARCH_C.0.ln(), SEARCH_C.1.ln());
    const SCAN: usize = 16;
    let grid: Vec<f64> = (0..=SCAN)
        .map(|i| lo + (hi - lo) * i as f64 / SCAN as f64)
        .collect();
    let costs: Vec<f64> = grid.iter().map(|&x| cost(x)).collect();
    let best = (0..=SCAN)
        .min_by(|&a, &b| costs[a].total_cmp(&costs[b]))
        .unwrap_or(0);
    if best == 0 || best == SCAN {
        return Err(Error::Numeric(format!(
            "the doubling temperature is not bracketed in {} to {} deg C: the dark current does \
             not vary with temperature as 2^(T/T_d) in these darks",
            SEARCH_C.0, SEARCH_C.1
        )));
    }
    let (mut a, mut b) = (grid[best - 1], grid[best + 1]);
    let r = 0.5 * (5f64.sqrt() - 1.0);
    let (mut x1, mut x2) = (b - r * (b - a), a + r * (b - a));
    let (mut f1, mut f2) = (cost(x1), cost(x2));
    while b - a > 1e-4 {
        if f1 < f2 {
            b = x2;
            x2 = x1;
            f2 = f1;
            x1 = b - r * (b - a);
            f1 = cost(x1);
        } else {
            a = x1;
            x1 = x2;
            f1 = f2;
            x2 = a + r * (b - a);
            f2 = cost(x2);
        }
    }
    let at = |d: f64| total_chi2(design, k, &factors(temps, reference, d), 1);
    let parabola = |td: f64, h: f64| {
        let ((c0, n), cp, cm) = (at(td), at(td + h).0, at(td - h).0);
        let curvature = (cp - 2.0 * c0 + cm) / (h * h);
        (c0, n, curvature, -(cp - cm) / (2.0 * h * curvature))
    };
    // The first parabola (T_d +- 1 %) finds the scale of the SE; the second, over +- 3 of
    // those SEs where the profile is a parabola, the minimum and the curvature reported.
    let td0 = (0.5 * (a + b)).exp();
    let (_, _, curvature, step) = parabola(td0, 0.01 * td0);
    let td1 = td0 + step;
    let h = (3.0 * (2.0 / curvature).sqrt()).clamp(1e-6 * td1, 0.01 * td1);
    let (c0, n, curvature2, step) = parabola(td1, h);
    let td = td1 + step;
    if [curvature, curvature2]
        .iter()
        .any(|c| c.is_nan() || *c <= 0.0)
        || !td.is_finite()
    {
        return Err(Error::Numeric(format!(
            "the total chi2 has no minimum near doubling temperature {td} deg C: T_d is not \
             constrained by these darks"
        )));
    }
    let dof = (n * design.dof()).saturating_sub(1).max(1) as f64;
    let inflate = (c0 / dof).max(1.0).sqrt();
    Ok((td, (2.0 / curvature2).sqrt() * inflate))
}
