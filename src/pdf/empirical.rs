//! The empirical distribution of a measured read-noise map.

use super::RmsPdf;
use crate::rng::SimRng;
use rand::RngExt;

/// The measured per-pixel rms values themselves (e-), sampled with replacement.
#[derive(Clone, Debug)]
pub struct EmpiricalPdf {
    sorted: Vec<f64>,
    mean: f64,
    rms: f64,
    label: String,
}

impl EmpiricalPdf {
    /// Build from measured rms values (e-); non-finite and negative values are dropped.
    pub fn new(values: &[f64], label: &str) -> Option<Self> {
        let mut sorted: Vec<f64> = values
            .iter()
            .copied()
            .filter(|v| v.is_finite() && *v >= 0.0)
            .collect();
        if sorted.is_empty() {
            return None;
        }
        sorted.sort_by(f64::total_cmp);
        let n = sorted.len() as f64;
        let mean = sorted.iter().sum::<f64>() / n;
        let rms = (sorted.iter().map(|v| v * v).sum::<f64>() / n).sqrt();
        Some(EmpiricalPdf {
            sorted,
            mean,
            rms,
            label: label.to_string(),
        })
    }

    /// The sorted values (e-).
    pub fn values(&self) -> &[f64] {
        &self.sorted
    }
}

impl RmsPdf for EmpiricalPdf {
    fn sample(&self, rng: &mut SimRng) -> f64 {
        self.sorted[rng.random_range(0..self.sorted.len())]
    }

    fn quantile(&self, p: f64) -> f64 {
        // Type-7 (linear) sample quantile, as numpy's default.
        let h = p.clamp(0.0, 1.0) * (self.sorted.len() - 1) as f64;
        let i = h.floor() as usize;
        let j = (i + 1).min(self.sorted.len() - 1);
        self.sorted[i] + (h - i as f64) * (self.sorted[j] - self.sorted[i])
    }

    fn cdf(&self, x: f64) -> f64 {
        self.sorted.partition_point(|v| *v <= x) as f64 / self.sorted.len() as f64
    }

    fn mean(&self) -> f64 {
        self.mean
    }

    fn rms(&self) -> f64 {
        self.rms
    }

    fn label(&self) -> String {
        self.label.clone()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn quantiles_and_moments_of_known_values() {
        let e = EmpiricalPdf::new(&[1.0, 2.0, 3.0, 4.0, f64::NAN], "t").unwrap();
        assert_eq!(e.median(), 2.5);
        assert_eq!(e.mean(), 2.5);
        assert!((e.rms() - 7.5f64.sqrt()).abs() < 1e-12);
        assert_eq!(e.cdf(2.0), 0.5);
        assert!(EmpiricalPdf::new(&[f64::NAN], "t").is_none());
    }
}
