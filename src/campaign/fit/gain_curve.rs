//! The EM gain calibration curve: fitted against commanded gain, `ln G_fit = a + b ln G_cmd`
//! (a register's gain is close to a power of the commanded value over a decade or two).

use serde::Serialize;

use super::options::EmGainFit;
use super::wls::Normal;

/// One row of em_gain_curve.csv.
#[derive(Clone, Debug, Serialize, PartialEq)]
pub struct EmGainRow {
    /// Commanded gain (e-/e-).
    pub commanded_gain: f64,
    /// Fitted gain (e-/e-).
    pub fitted_gain: f64,
    /// Its SE (e-/e-).
    pub fitted_gain_se: f64,
    /// Fitted / commanded.
    pub fitted_over_commanded: f64,
    /// The curve at the commanded gain (e-/e-; NaN with one gain).
    pub curve_gain: f64,
    /// (fitted - curve) / SE (NaN without an SE or a curve).
    pub pull: f64,
}

/// The curve and its table.
#[derive(Clone, Debug, Serialize, PartialEq)]
pub struct EmGainCurve {
    /// The curve's form.
    pub model: String,
    /// a (ln e-/e-; NaN with one gain).
    pub a: f64,
    /// SE of a.
    pub a_se: f64,
    /// b (exponent; NaN with one gain).
    pub b: f64,
    /// SE of b.
    pub b_se: f64,
    /// Degrees of freedom (gains - 2).
    pub dof: usize,
    /// Reduced chi2 (NaN with no degree of freedom or without SEs).
    pub reduced_chi2: f64,
    /// The table, by commanded gain.
    pub rows: Vec<EmGainRow>,
}

/// The curve of `fits` (`None` if empty). Weights (G/SE)^2 on ln G when every SE is > 0, the
/// SEs of a and b inflated by sqrt(reduced chi2) when above 1; equal weights and SEs from the
/// scatter otherwise.
pub(super) fn fit(fits: &[EmGainFit]) -> Option<EmGainCurve> {
    let mut fits = fits.to_vec();
    if fits.is_empty() {
        return None;
    }
    fits.sort_by(|a, b| a.commanded.total_cmp(&b.commanded));
    let weighted = fits.iter().all(|f| f.se > 0.0);
    let w = |f: &EmGainFit| {
        if weighted {
            (f.gain / f.se).powi(2)
        } else {
            1.0
        }
    };
    let mut n = Normal::<2>::new(2);
    for f in &fits {
        n.add(&[1.0, f.commanded.ln()], f.gain.ln(), w(f));
    }
    let (a, b, mut a_se, mut b_se) = match n.solve() {
        Some(s) => (s.x[0], s.x[1], s.se[0], s.se[1]),
        None => (f64::NAN, f64::NAN, f64::NAN, f64::NAN),
    };
    let dof = fits.len().saturating_sub(2);
    let chi2: f64 = fits
        .iter()
        .map(|f| w(f) * (f.gain.ln() - a - b * f.commanded.ln()).powi(2))
        .sum();
    let reduced = if dof > 0 { chi2 / dof as f64 } else { f64::NAN };
    let scale = if weighted { reduced.max(1.0) } else { reduced };
    if a.is_finite() {
        let s = if scale.is_finite() {
            scale.sqrt()
        } else if weighted {
            1.0
        } else {
            f64::NAN
        };
        a_se *= s;
        b_se *= s;
    }
    let rows = fits
        .iter()
        .map(|f| {
            let curve = (a + b * f.commanded.ln()).exp();
            EmGainRow {
                commanded_gain: f.commanded,
                fitted_gain: f.gain,
                fitted_gain_se: f.se,
                fitted_over_commanded: f.gain / f.commanded,
                curve_gain: curve,
                pull: if f.se > 0.0 {
                    (f.gain - curve) / f.se
                } else {
                    f64::NAN
                },
            }
        })
        .collect();
    Some(EmGainCurve {
        model: "ln G_fit = a + b ln G_commanded".into(),
        a,
        a_se,
        b,
        b_se,
        dof,
        reduced_chi2: if weighted { reduced } else { f64::NAN },
        rows,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_power_law_is_recovered_with_pulls_of_zero() {
        // G_fit = 1.1 G^0.95 exactly, SEs 1 %.
        let fits: Vec<EmGainFit> = [100.0, 300.0, 1000.0]
            .iter()
            .map(|&g| {
                let gain = 1.1 * f64::powf(g, 0.95);
                EmGainFit {
                    commanded: g,
                    gain,
                    se: 0.01 * gain,
                }
            })
            .collect();
        let c = fit(&fits).unwrap();
        assert!((c.b - 0.95).abs() < 1e-9 && (c.a - 1.1f64.ln()).abs() < 1e-9);
        // Exact points: the SEs are the unscaled ones, 1 % on ln G over ln 10 of range.
        assert!(c.b_se > 0.005 && c.b_se < 0.02, "{}", c.b_se);
        assert_eq!(c.dof, 1);
        assert!(c.rows.iter().all(|r| r.pull.abs() < 1e-6));
    }

    #[test]
    fn one_gain_gives_a_table_without_a_curve() {
        let c = fit(&[EmGainFit {
            commanded: 500.0,
            gain: 480.0,
            se: 5.0,
        }])
        .unwrap();
        assert!(c.b.is_nan());
        assert_eq!(c.rows[0].fitted_over_commanded, 0.96);
    }
}
