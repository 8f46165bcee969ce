//! Inverting R along a reference family's grid at the detector's R: the interpolated abscissa
//! x (a constant sigma, or minus a QE factor: see `family`), the slope of R there, and the
//! weight of each reference's R in the answer (for the paired standard error).
//!
//! Inside the bracket, a quadratic through the bracket's two points and the nearer neighbour
//! removes most of the bias that linear interpolation has where R curves (0.3 % of sigma over
//! a 10 % bracket); where that quadratic is not monotone over the bracket, or no neighbour is
//! usable, the interpolation is linear. Either way x solves sum_i w_i(x) R_i = R_det with
//! weights w_i summing to 1, so a change dR_det - sum_i w_i dR_i moves it by that over the
//! slope.

use crate::special::bisect;

/// Why a grid does not bracket the detector's R.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Outside {
    /// The detector's R is below R at the smallest abscissa.
    Below,
    /// The detector's R is above R at the largest abscissa.
    Above,
}

/// The abscissa whose reference has the detector's R.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct Inversion {
    /// The interpolated abscissa (e- for a constant sigma).
    pub x: f64,
    /// Slope of the interpolated R in x there (px per unit of x; 0 where R is flat).
    pub slope: f64,
    /// `(reference index, weight)`: the interpolated R at x is sum weight x R_reference.
    pub weights: Vec<(usize, f64)>,
}

/// Invert R of the references (`r_const`, px, at the ascending abscissae `grid`) at the
/// detector's `r_det` (px).
pub(crate) fn invert(r_det: f64, r_const: &[f64], grid: &[f64]) -> Result<Inversion, Outside> {
    // Monte-Carlo noise can make neighbouring R values cross; a running maximum keeps the
    // curve monotone (as it is in expectation) before inversion, each point remembering which
    // constant gave it.
    let mut r = r_const.to_vec();
    let mut source: Vec<usize> = (0..r.len()).collect();
    for k in 1..r.len() {
        if r[k] < r[k - 1] {
            r[k] = r[k - 1];
            source[k] = source[k - 1];
        }
    }
    if r_det < r[0] {
        return Err(Outside::Below);
    }
    if r_det > r[r.len() - 1] {
        return Err(Outside::Above);
    }
    let k = (1..r.len()).find(|&k| r[k] >= r_det).expect("bracketed");
    let (g0, g1) = (grid[k - 1], grid[k]);
    if r[k] <= r[k - 1] {
        // Flat: any x of the bracket fits; the midpoint, with an infinite SE.
        return Ok(Inversion {
            x: 0.5 * (g0 + g1),
            slope: 0.0,
            weights: vec![(source[k - 1], 0.5), (source[k], 0.5)],
        });
    }
    let t = (r_det - r[k - 1]) / (r[k] - r[k - 1]);
    let linear = Inversion {
        x: g0 + t * (g1 - g0),
        slope: (r[k] - r[k - 1]) / (g1 - g0),
        weights: vec![(source[k - 1], 1.0 - t), (source[k], t)],
    };
    // The neighbour nearer to the linear answer, among those that are their own constant.
    let own = |i: usize| source[i] == i;
    let below = (k >= 2 && own(k - 2) && own(k - 1)).then(|| k - 2);
    let above = (k + 1 < r.len() && own(k + 1) && own(k - 1)).then_some(k + 1);
    let third = match (below, above) {
        (Some(b), Some(a)) if grid[a] - linear.x < linear.x - grid[b] => Some(a),
        (Some(b), _) => Some(b),
        (None, a) => a,
    };
    let Some(third) = third.filter(|_| own(k)) else {
        return Ok(linear);
    };
    let mut idx = [k - 1, k, third];
    idx.sort_unstable();
    let q = Quadratic::through(idx.map(|i| (grid[i], r[i])));
    if !(q.derivative(g0) > 0.0 && q.derivative(g1) > 0.0) {
        return Ok(linear);
    }
    let x = bisect(|x| r_det - q.value(x), g0, g1);
    Ok(Inversion {
        x,
        slope: q.derivative(x),
        weights: idx.iter().zip(q.basis(x)).map(|(&i, w)| (i, w)).collect(),
    })
}

/// The Lagrange quadratic through three points with distinct abscissae.
struct Quadratic {
    x: [f64; 3],
    y: [f64; 3],
}

impl Quadratic {
    fn through(points: [(f64, f64); 3]) -> Self {
        Quadratic {
            x: points.map(|p| p.0),
            y: points.map(|p| p.1),
        }
    }

    /// The Lagrange basis L_i(t): the weights of the three ordinates at t (summing to 1).
    fn basis(&self, t: f64) -> [f64; 3] {
        let x = &self.x;
        std::array::from_fn(|i| {
            let (j, k) = ((i + 1) % 3, (i + 2) % 3);
            (t - x[j]) * (t - x[k]) / ((x[i] - x[j]) * (x[i] - x[k]))
        })
    }

    fn value(&self, t: f64) -> f64 {
        self.basis(t).iter().zip(&self.y).map(|(l, y)| l * y).sum()
    }

    fn derivative(&self, t: f64) -> f64 {
        let x = &self.x;
        (0..3)
            .map(|i| {
                let (j, k) = ((i + 1) % 3, (i + 2) % 3);
                self.y[i] * (2.0 * t - x[j] - x[k]) / ((x[i] - x[j]) * (x[i] - x[k]))
            })
            .sum()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_quadratic_curve_is_inverted_exactly() {
        // R = 0.1 + 0.02 s + 0.01 s^2 on a grid: the quadratic interpolant is exact, so the
        // inversion returns the sigma whose R was asked for, with the true slope; the weights
        // sum to 1 and reproduce R.
        let grid = [0.85, 0.95, 1.05, 1.18];
        let f = |s: f64| 0.1 + 0.02 * s + 0.01 * s * s;
        let r: Vec<f64> = grid.iter().map(|&s| f(s)).collect();
        for want in [0.86, 0.9, 1.0, 1.1, 1.17] {
            let inv = invert(f(want), &r, &grid).unwrap();
            assert!((inv.x - want).abs() < 1e-12, "{inv:?}");
            assert!((inv.slope - (0.02 + 0.02 * want)).abs() < 1e-12);
            let sum: f64 = inv.weights.iter().map(|w| w.1).sum();
            let at: f64 = inv.weights.iter().map(|&(i, w)| w * r[i]).sum();
            assert!((sum - 1.0).abs() < 1e-12 && (at - f(want)).abs() < 1e-14);
        }
        // A linear interpolation would have been off by about 1e-3 e- in the middle bracket.
        let lin = 0.95 + (f(1.0) - f(0.95)) / (f(1.05) - f(0.95)) * 0.1;
        assert!((lin - 1.0).abs() > 1e-4);
    }

    #[test]
    fn outside_flat_and_crossing_points() {
        let grid = [0.0, 1.0, 2.0, 3.0];
        assert_eq!(
            invert(0.05, &[0.1, 0.2, 0.3, 0.4], &grid),
            Err(Outside::Below)
        );
        assert_eq!(
            invert(0.5, &[0.1, 0.2, 0.3, 0.4], &grid),
            Err(Outside::Above)
        );
        // Noise made point 2 fall below point 1: the running maximum takes point 1's value
        // there, and the answer between points 2 and 3 weighs constants 1 and 3, linearly.
        let inv = invert(0.35, &[0.1, 0.3, 0.25, 0.4], &grid).unwrap();
        assert_eq!(inv.weights.iter().map(|w| w.0).collect::<Vec<_>>(), [1, 3]);
        assert!((inv.x - 2.5).abs() < 1e-12);
        // Flat bracket: midpoint, zero slope.
        let inv = invert(0.1, &[0.1, 0.1, 0.3, 0.4], &grid).unwrap();
        assert_eq!((inv.x, inv.slope), (0.5, 0.0));
    }
}
