//! The parametric families of per-pixel read-noise pdfs fitted by `fit-pdf`.
//!
//! Every family is a mixture of unnormalised components on [0, U] e-, normalised
//! numerically on the support (U is the upper cut, the largest value of the map unless
//! the user fixes it). Parameters are held in natural units; the optimiser works on
//! unbounded internal coordinates (log for positive, logit for fractions) so bounds hold.

use crate::error::{Error, Result};
use crate::pdf::{paper_shape, TabulatedPdf};

/// Median of the paper's pdf on [0, 10] e- (notes 3.1), used for start values.
pub(crate) const PAPER_MEDIAN_E: f64 = 0.7944;

/// How a parameter maps to the optimiser's unbounded coordinate.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) enum Transform {
    /// Positive parameter: u = ln(theta).
    Log,
    /// Fraction in (0, 1): u = ln(theta / (1 - theta)).
    Logit,
    /// Unbounded: u = theta.
    Free,
}

impl Transform {
    pub(crate) fn to_internal(self, t: f64) -> f64 {
        match self {
            Transform::Log => t.ln(),
            Transform::Logit => (t / (1.0 - t)).ln(),
            Transform::Free => t,
        }
    }

    pub(crate) fn to_natural(self, u: f64) -> f64 {
        match self {
            Transform::Log => u.exp(),
            Transform::Logit => 1.0 / (1.0 + (-u).exp()),
            Transform::Free => u,
        }
    }

    /// d theta / d u at natural value `t` (for propagating uncertainties).
    pub(crate) fn derivative(self, t: f64) -> f64 {
        match self {
            Transform::Log => t,
            Transform::Logit => t * (1.0 - t),
            Transform::Free => 1.0,
        }
    }
}

/// A model of the per-pixel read-noise pdf that `fit-pdf` can fit.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum PdfModel {
    /// The paper's pdf (Eq. 3) stretched by one scale factor s: f(x/s).
    PaperScaled,
    /// The paper's functional form with free tanh edge and steepness and free constants
    /// and weights of the three power-law terms (the paper's values are one point).
    PaperFamily,
    /// A log-normal core plus a power-law tail that switches on with the core.
    LognormalTail,
    /// The measured values themselves.
    Empirical,
}

impl PdfModel {
    /// Every model, in the order they are fitted.
    pub const ALL: [PdfModel; 4] = [
        PdfModel::PaperScaled,
        PdfModel::PaperFamily,
        PdfModel::LognormalTail,
        PdfModel::Empirical,
    ];

    /// The model's name in `pdf_fit.json` and on the command line.
    pub fn name(self) -> &'static str {
        match self {
            PdfModel::PaperScaled => "paper-scaled",
            PdfModel::PaperFamily => "paper-family",
            PdfModel::LognormalTail => "lognormal+tail",
            PdfModel::Empirical => "empirical",
        }
    }

    /// The model called `name`, if any.
    pub fn from_name(name: &str) -> Option<Self> {
        Self::ALL.into_iter().find(|m| m.name() == name)
    }

    /// The models named in `names` (surrounding spaces ignored); every model when empty. An
    /// unknown name is an error of the `models` setting listing the known ones.
    pub fn parse_list(names: &[String]) -> Result<Vec<PdfModel>> {
        if names.is_empty() {
            return Ok(Self::ALL.to_vec());
        }
        names
            .iter()
            .map(|m| {
                Self::from_name(m.trim()).ok_or_else(|| {
                    let known: Vec<&str> = Self::ALL.iter().map(|m| m.name()).collect();
                    Error::invalid(
                        "models",
                        format!("unknown model {m:?} ({})", known.join(", ")),
                    )
                })
            })
            .collect()
    }

    /// Free parameters (name with unit, transform) in the order of the parameter vector.
    pub(crate) fn params(self) -> &'static [(&'static str, Transform)] {
        use Transform::*;
        match self {
            PdfModel::PaperScaled => &[("scale", Log)],
            PdfModel::PaperFamily => &[
                ("edge_e", Log),
                ("steepness_per_e", Log),
                ("c10_e10", Log),
                ("c4_e4", Log),
                ("c2_e2", Log),
                ("w4_e6", Log),
                ("w2_e8", Log),
            ],
            PdfModel::LognormalTail => &[
                ("mu_ln_e", Free),
                ("sigma_ln", Log),
                ("tail_fraction", Logit),
                ("tail_alpha", Log),
            ],
            PdfModel::Empirical => &[],
        }
    }

    /// Formula of the unnormalised density, for reports.
    pub fn formula(self) -> &'static str {
        match self {
            PdfModel::PaperScaled => {
                "f(x/scale) on [0, upper_cut_e], f = paper Eq. 3: (tanh(10x-6.5)+1)(1/(x^10+0.1)+1/(2(x^4+0.1))+1/(2(x^2+0.1)))"
            }
            PdfModel::PaperFamily => {
                "(tanh(steepness (x-edge))+1)(1/(x^10+c10)+w4/(x^4+c4)+w2/(x^2+c2)) on [0, upper_cut_e]; paper: edge 0.65, steepness 10, c 0.1, w 0.5"
            }
            PdfModel::LognormalTail => {
                "(1-w) LogNormal(mu, sigma) + w Phi((ln x-mu)/sigma) x^-(1+alpha), each normalised on [0, upper_cut_e]"
            }
            PdfModel::Empirical => "the measured values (or their quantiles) sampled with replacement",
        }
    }

    /// Number of mixture components.
    pub(crate) fn n_components(self) -> usize {
        match self {
            PdfModel::LognormalTail => 2,
            _ => 1,
        }
    }

    /// Mixing weight of component `j`.
    pub(crate) fn weight(self, p: &[f64], j: usize) -> f64 {
        match (self, j) {
            (PdfModel::LognormalTail, 0) => 1.0 - p[2],
            (PdfModel::LognormalTail, _) => p[2],
            _ => 1.0,
        }
    }

    /// Unnormalised density of component `j` at rms `x` (e-).
    pub(crate) fn component(self, p: &[f64], j: usize, x: f64) -> f64 {
        match self {
            PdfModel::PaperScaled => paper_shape(x / p[0]),
            PdfModel::PaperFamily => {
                let x2 = x * x;
                let x4 = x2 * x2;
                let x10 = x4 * x4 * x2;
                ((p[1] * (x - p[0])).tanh() + 1.0)
                    * (1.0 / (x10 + p[2]) + p[5] / (x4 + p[3]) + p[6] / (x2 + p[4]))
            }
            PdfModel::LognormalTail => {
                if x <= 0.0 {
                    return 0.0;
                }
                let z = (x.ln() - p[0]) / p[1];
                if j == 0 {
                    (-0.5 * z * z).exp() / (x * p[1])
                } else {
                    // Scaled by e^mu so the tail stays O(1) near the core.
                    0.5 * libm::erfc(-z / std::f64::consts::SQRT_2)
                        * (x / p[0].exp()).powf(-1.0 - p[3])
                        / p[0].exp()
                }
            }
            PdfModel::Empirical => 0.0,
        }
    }

    /// Start values (natural units) for a map with median `median` and 10 % quantile `q10` (e-).
    pub(crate) fn start(self, median: f64, q10: f64) -> Vec<f64> {
        match self {
            PdfModel::PaperScaled => vec![median / PAPER_MEDIAN_E],
            PdfModel::PaperFamily => paper_family_from_scale(median / PAPER_MEDIAN_E),
            PdfModel::LognormalTail => {
                // The lower side of the map is free of the tail: sigma from median/q10.
                let sigma = ((median / q10).ln() / 1.2816).max(0.02);
                vec![median.ln(), sigma, 0.1, 1.0]
            }
            PdfModel::Empirical => vec![],
        }
    }
}

/// The paper-family parameters equal to the paper's pdf stretched by `s`: factoring
/// s^10 out of f(x/s) gives edge 0.65 s, steepness 10/s, c10 = 0.1 s^10, c4 = 0.1 s^4,
/// c2 = 0.1 s^2, w4 = 0.5 s^-6, w2 = 0.5 s^-8 (so paper-scaled is nested in paper-family).
pub(crate) fn paper_family_from_scale(s: f64) -> Vec<f64> {
    vec![
        0.65 * s,
        10.0 / s,
        0.1 * s.powi(10),
        0.1 * s.powi(4),
        0.1 * s.powi(2),
        0.5 * s.powi(-6),
        0.5 * s.powi(-8),
    ]
}

/// A grid of cells on [0, U] e-: 32 uniform cells up to U/1000, then cells growing by
/// 0.1 % each (a relative resolution far below any structure of the models: the paper's
/// edge is 15 % of x wide), so integrals and the binned likelihood are accurate to
/// O(1e-7) relative while a cost evaluation does not depend on the map size.
#[derive(Debug, Clone)]
pub(crate) struct Grid {
    pub lo_log: f64,
    pub ln_ratio: f64,
    pub n_lin: usize,
    pub mids: Vec<f64>,
    pub widths: Vec<f64>,
}

impl Grid {
    pub(crate) fn new(upper: f64) -> Self {
        let n_lin = 32;
        let lo_log = upper * 1e-3;
        let n_log = ((1e3f64).ln() / 1e-3).ceil() as usize;
        let ln_ratio = (1e3f64).ln() / n_log as f64;
        let mut mids = Vec::with_capacity(n_lin + n_log);
        let mut widths = Vec::with_capacity(n_lin + n_log);
        let w = lo_log / n_lin as f64;
        for i in 0..n_lin {
            mids.push((i as f64 + 0.5) * w);
            widths.push(w);
        }
        for i in 0..n_log {
            let a = lo_log * (ln_ratio * i as f64).exp();
            let b = lo_log * (ln_ratio * (i + 1) as f64).exp();
            mids.push(0.5 * (a + b));
            widths.push(b - a);
        }
        Grid {
            lo_log,
            ln_ratio,
            n_lin,
            mids,
            widths,
        }
    }

    /// Cell index of `x` in [0, U].
    pub(crate) fn index(&self, x: f64) -> usize {
        let i = if x < self.lo_log {
            (x / self.lo_log * self.n_lin as f64) as usize
        } else {
            self.n_lin + ((x / self.lo_log).ln() / self.ln_ratio) as usize
        };
        i.min(self.mids.len() - 1)
    }

    /// Normalisation constant of every component of `model` at `p`, or `None` if one is
    /// not positive and finite.
    pub(crate) fn norms(&self, model: PdfModel, p: &[f64]) -> Option<Vec<f64>> {
        (0..model.n_components())
            .map(|j| {
                let z: f64 = self
                    .mids
                    .iter()
                    .zip(&self.widths)
                    .map(|(x, w)| model.component(p, j, *x) * w)
                    .sum();
                (z > 0.0 && z.is_finite()).then_some(z)
            })
            .collect()
    }
}

/// Normalised density of `model` at `x` given the component normalisations `norms`.
pub(crate) fn density(model: PdfModel, p: &[f64], norms: &[f64], x: f64) -> f64 {
    norms
        .iter()
        .enumerate()
        .map(|(j, z)| model.weight(p, j) * model.component(p, j, x) / z)
        .sum()
}

/// The fitted pdf of a parametric `model` at natural parameters `p` on [0, `upper`] e-.
pub(crate) fn tabulate(model: PdfModel, p: &[f64], upper: f64) -> Option<TabulatedPdf> {
    let norms = Grid::new(upper).norms(model, p)?;
    let label = format!("{} fit [0, {upper:.3}] e-", model.name());
    TabulatedPdf::try_from_density(|x| density(model, p, &norms, x), 0.0, upper, &label)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::pdf::RmsPdf;

    #[test]
    fn model_lists_parse_by_name() {
        let names = |v: &[&str]| v.iter().map(|s| s.to_string()).collect::<Vec<_>>();
        assert_eq!(PdfModel::parse_list(&[]).unwrap(), PdfModel::ALL);
        assert_eq!(
            PdfModel::parse_list(&names(&[" empirical", "paper-scaled"])).unwrap(),
            [PdfModel::Empirical, PdfModel::PaperScaled]
        );
        match PdfModel::parse_list(&names(&["nope"])) {
            Err(Error::Usage { field, message }) => {
                assert_eq!(field, "models");
                assert!(message.contains("\"nope\"") && message.contains("lognormal+tail"));
            }
            other => panic!("{other:?}"),
        }
    }

    #[test]
    fn paper_family_contains_the_scaled_paper_pdf() {
        // Same shape up to a constant: the ratio must not depend on x.
        for s in [1.0, 1.7] {
            let p = paper_family_from_scale(s);
            let r0 = PdfModel::PaperFamily.component(&p, 0, 0.9 * s)
                / PdfModel::PaperScaled.component(&[s], 0, 0.9 * s);
            for x in [0.3, 0.7, 1.3, 4.0, 9.0] {
                let x = x * s;
                let r = PdfModel::PaperFamily.component(&p, 0, x)
                    / PdfModel::PaperScaled.component(&[s], 0, x);
                assert!((r / r0 - 1.0).abs() < 1e-12, "s {s} x {x}");
            }
        }
    }

    #[test]
    fn grid_normalisation_matches_the_paper_constant() {
        // N = 5.8409 on [0, 10] e- (notes 3.1, 5 digits).
        let g = Grid::new(10.0);
        let z = g.norms(PdfModel::PaperScaled, &[1.0]).unwrap()[0];
        assert!((z - 5.8409).abs() < 1e-4, "{z}");
        let t = tabulate(PdfModel::PaperScaled, &[1.0], 10.0).unwrap();
        assert!((t.median() - 0.7944).abs() < 1e-3);
        assert_eq!(g.index(10.0), g.mids.len() - 1);
        assert_eq!(g.index(0.0), 0);
        let i = g.index(0.8);
        assert!(g.mids[i] - 0.5 * g.widths[i] <= 0.8 && 0.8 <= g.mids[i] + 0.5 * g.widths[i]);
    }

    #[test]
    fn transforms_round_trip() {
        for (t, v) in [
            (Transform::Log, 3.5),
            (Transform::Logit, 0.2),
            (Transform::Free, -1.0),
        ] {
            assert!((t.to_natural(t.to_internal(v)) - v).abs() < 1e-12);
        }
    }
}
