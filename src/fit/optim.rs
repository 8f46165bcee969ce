//! Shared numerical machinery of the fits: Nelder-Mead through argmin with a strict
//! convergence check, and parameter uncertainties from a finite-difference Hessian.

use crate::error::{Error, Result};
use argmin::core::{CostFunction, Executor, State, TerminationReason, TerminationStatus};
use argmin::solver::neldermead::NelderMead;

/// Cost returned for parameters outside the model's domain: large but finite, because
/// argmin's Nelder-Mead unwraps the initial costs and sorts by them.
pub(crate) const INVALID_COST: f64 = 1e30;

/// A cost closure as an argmin problem.
struct Closure<F>(F);

impl<F: Fn(&[f64]) -> f64> CostFunction for Closure<F> {
    type Param = Vec<f64>;
    type Output = f64;
    fn cost(&self, p: &Self::Param) -> std::result::Result<f64, argmin::core::Error> {
        let c = (self.0)(p);
        Ok(if c.is_finite() { c } else { INVALID_COST })
    }
}

/// The minimum found by [`minimise`].
#[derive(Debug, Clone)]
pub(crate) struct Minimum {
    /// Parameters at the minimum (internal, unbounded coordinates).
    pub x: Vec<f64>,
    /// Cost at the minimum.
    pub cost: f64,
    /// Nelder-Mead iterations over all restarts.
    pub iterations: u64,
}

/// Minimise `cost` from `start` with Nelder-Mead (initial simplex steps `step`), restarting
/// from the best vertex until a restart no longer improves the cost by more than `tol`;
/// anything but argmin's `SolverConverged` is an `Error::Numeric` naming `what`.
pub(crate) fn minimise(
    cost: impl Fn(&[f64]) -> f64,
    start: &[f64],
    step: &[f64],
    tol: f64,
    max_iters: u64,
    what: &str,
) -> Result<Minimum> {
    let problem = Closure(cost);
    let mut best = Minimum {
        x: start.to_vec(),
        cost: (problem.0)(start),
        iterations: 0,
    };
    if !best.cost.is_finite() || best.cost >= INVALID_COST {
        return Err(Error::Numeric(format!(
            "{what}: the start values are outside the model's domain"
        )));
    }
    // Nelder-Mead can collapse its simplex early on ill-conditioned problems; a few
    // restarts from the best point are the standard remedy.
    for restart in 0..6 {
        let scale = if restart == 0 { 1.0 } else { 0.3 };
        let mut simplex = vec![best.x.clone()];
        for (i, s) in step.iter().enumerate() {
            let mut v = best.x.clone();
            v[i] += s * scale;
            simplex.push(v);
        }
        let solver = NelderMead::new(simplex)
            .with_sd_tolerance(tol)
            .map_err(|e| Error::Numeric(format!("{what}: {e}")))?;
        let res = Executor::new(Closure(&problem.0), solver)
            .configure(|s| s.max_iters(max_iters))
            .run()
            .map_err(|e| Error::Numeric(format!("{what}: optimiser failed: {e}")))?;
        let state = res.state();
        match state.get_termination_status() {
            TerminationStatus::Terminated(TerminationReason::SolverConverged) => {}
            TerminationStatus::Terminated(r) => {
                return Err(Error::Numeric(format!(
                    "{what}: the fit did not converge ({})",
                    r.text()
                )))
            }
            TerminationStatus::NotTerminated => {
                return Err(Error::Numeric(format!(
                    "{what}: the optimiser stopped early"
                )))
            }
        }
        let x = state
            .get_best_param()
            .cloned()
            .ok_or_else(|| Error::Numeric(format!("{what}: no best parameters")))?;
        let c = state.get_best_cost();
        best.iterations += state.get_iter();
        if !c.is_finite() || c >= INVALID_COST {
            return Err(Error::Numeric(format!(
                "{what}: the fit ended outside the model's domain"
            )));
        }
        let improved = best.cost - c;
        if c < best.cost {
            best.x = x;
            best.cost = c;
        }
        if improved <= 10.0 * tol {
            return Ok(best);
        }
    }
    Err(Error::Numeric(format!(
        "{what}: the fit kept improving after 6 Nelder-Mead restarts (not converged)"
    )))
}

/// Hessian of `f` at `x` by central differences with steps `h` (per coordinate).
pub(crate) fn hessian(f: impl Fn(&[f64]) -> f64, x: &[f64], h: &[f64]) -> Vec<Vec<f64>> {
    let n = x.len();
    let f0 = f(x);
    let at = |d: &[(usize, f64)]| {
        let mut y = x.to_vec();
        for &(i, s) in d {
            y[i] += s;
        }
        f(&y)
    };
    let mut hm = vec![vec![0.0; n]; n];
    for i in 0..n {
        hm[i][i] = (at(&[(i, h[i])]) - 2.0 * f0 + at(&[(i, -h[i])])) / (h[i] * h[i]);
        for j in 0..i {
            let v = (at(&[(i, h[i]), (j, h[j])])
                - at(&[(i, h[i]), (j, -h[j])])
                - at(&[(i, -h[i]), (j, h[j])])
                + at(&[(i, -h[i]), (j, -h[j])]))
                / (4.0 * h[i] * h[j]);
            hm[i][j] = v;
            hm[j][i] = v;
        }
    }
    hm
}

/// Inverse of a symmetric positive-definite matrix by Cholesky; `None` if it is not
/// positive definite (the likelihood is flat or saddle-shaped in some direction).
pub(crate) fn spd_inverse(a: &[Vec<f64>]) -> Option<Vec<Vec<f64>>> {
    let n = a.len();
    let mut l = vec![vec![0.0; n]; n];
    for i in 0..n {
        for j in 0..=i {
            let s: f64 = a[i][j] - (0..j).map(|k| l[i][k] * l[j][k]).sum::<f64>();
            if i == j {
                if s.is_nan() || s <= 0.0 || !s.is_finite() {
                    return None;
                }
                l[i][i] = s.sqrt();
            } else {
                l[i][j] = s / l[j][j];
            }
        }
    }
    // Columns of L^-1 by forward substitution, then A^-1 = L^-T L^-1.
    let mut linv = vec![vec![0.0; n]; n];
    #[allow(clippy::needless_range_loop)] // triangular index arithmetic reads best as indices
    for c in 0..n {
        for i in c..n {
            let s: f64 = (c..i).map(|k| l[i][k] * linv[k][c]).sum::<f64>();
            linv[i][c] = (if i == c { 1.0 } else { 0.0 } - s) / l[i][i];
        }
    }
    let mut inv = vec![vec![0.0; n]; n];
    for i in 0..n {
        for j in 0..n {
            inv[i][j] = (i.max(j)..n).map(|k| linv[k][i] * linv[k][j]).sum();
        }
    }
    Some(inv)
}

/// Correlation matrix of a covariance matrix.
pub(crate) fn correlations(cov: &[Vec<f64>]) -> Vec<Vec<f64>> {
    let n = cov.len();
    (0..n)
        .map(|i| {
            (0..n)
                .map(|j| cov[i][j] / (cov[i][i] * cov[j][j]).sqrt())
                .collect()
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn minimises_a_quadratic_and_inverts_its_hessian() {
        // f = (x-1)^2 + 10 (y+2)^2 + x y: minimum and Hessian are exact.
        let f = |p: &[f64]| (p[0] - 1.0).powi(2) + 10.0 * (p[1] + 2.0).powi(2) + p[0] * p[1];
        let m = minimise(f, &[0.0, 0.0], &[0.5, 0.5], 1e-14, 5000, "quadratic").unwrap();
        // Gradient zero: 2(x-1) + y = 0, 20(y+2) + x = 0 => x = 80/39, y = -82/39.
        assert!((m.x[0] - 80.0 / 39.0).abs() < 1e-5, "{:?}", m.x);
        assert!((m.x[1] + 82.0 / 39.0).abs() < 1e-5, "{:?}", m.x);
        let h = hessian(f, &m.x, &[1e-3, 1e-3]);
        assert!((h[0][0] - 2.0).abs() < 1e-6 && (h[1][1] - 20.0).abs() < 1e-6);
        assert!((h[0][1] - 1.0).abs() < 1e-6);
        let inv = spd_inverse(&h).unwrap();
        // [[2,1],[1,20]]^-1 = [[20,-1],[-1,2]]/39.
        assert!((inv[0][0] - 20.0 / 39.0).abs() < 1e-6 && (inv[0][1] + 1.0 / 39.0).abs() < 1e-6);
        assert!(spd_inverse(&[vec![1.0, 2.0], vec![2.0, 1.0]]).is_none());
    }

    #[test]
    fn non_convergence_is_an_error() {
        let f = |p: &[f64]| -p[0].abs() - p[1].abs();
        assert!(minimise(f, &[0.0, 0.0], &[1.0, 1.0], 1e-14, 50, "unbounded").is_err());
    }
}
