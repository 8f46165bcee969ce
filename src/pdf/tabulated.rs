//! A density tabulated on a fine grid, sampled exactly from its piecewise-linear CDF.

use super::RmsPdf;
use crate::rng::SimRng;
use rand::RngExt;

/// Grid cells over the support: 1e-4 e- on [0, 10], fine enough for the paper's steep edge
/// at 0.6-0.75 e- (density rises from 1.4 to 11.6 over 0.15 e-).
const CELLS: usize = 100_000;
/// Size of the guide table that turns inverse-CDF search into O(1) expected steps.
const GUIDE: usize = 1 << 16;

/// A probability density on [lo, hi] (e-) held as a CDF on a uniform grid.
///
/// Within a cell the density is taken as constant (the CDF is linear), so sampling,
/// quantiles and moments all describe the same distribution exactly.
#[derive(Clone, Debug)]
pub struct TabulatedPdf {
    lo: f64,
    step: f64,
    cdf: Vec<f64>,
    guide: Vec<u32>,
    mean: f64,
    rms: f64,
    label: String,
    /// Alias table over the cells for sampling, built on the first draw.
    alias: std::sync::OnceLock<Vec<u64>>,
}

impl TabulatedPdf {
    /// Tabulate the (unnormalised, non-negative) density `f` on [lo, hi] e-; panics if it
    /// cannot be tabulated (for densities fixed in the code, such as the paper's).
    pub fn from_density(f: impl Fn(f64) -> f64, lo: f64, hi: f64, label: &str) -> Self {
        Self::try_from_density(f, lo, hi, label).expect("density has mass on a finite support")
    }

    /// Tabulate the density `f` on [lo, hi] e-, or None when the support is empty or not
    /// finite, or the density has no finite positive mass on the grid (e.g. a fitted density
    /// concentrated inside one cell of a support stretched by extreme map values).
    pub fn try_from_density(f: impl Fn(f64) -> f64, lo: f64, hi: f64, label: &str) -> Option<Self> {
        let step = (hi - lo) / CELLS as f64;
        if !(lo.is_finite() && hi.is_finite() && step > 0.0 && step.is_finite()) {
            return None;
        }
        // Cell masses by 3-point Gauss-Legendre: exact to O(step^6) for smooth densities.
        let nodes = [-0.774_596_669_241_483_4, 0.0, 0.774_596_669_241_483_4];
        let weights = [5.0 / 18.0, 8.0 / 18.0, 5.0 / 18.0];
        let mut cdf = Vec::with_capacity(CELLS + 1);
        cdf.push(0.0);
        let mut acc = 0.0;
        for i in 0..CELLS {
            let mid = lo + (i as f64 + 0.5) * step;
            let mass: f64 = nodes
                .iter()
                .zip(weights)
                .map(|(t, w)| w * f(mid + 0.5 * step * t).max(0.0))
                .sum::<f64>()
                * step;
            acc += mass;
            cdf.push(acc);
        }
        if !(acc > 0.0 && acc.is_finite()) {
            return None;
        }
        cdf.iter_mut().for_each(|c| *c /= acc);
        Some(Self::from_cdf(lo, step, cdf, label))
    }

    fn from_cdf(lo: f64, step: f64, cdf: Vec<f64>, label: &str) -> Self {
        let cells = cdf.len() - 1;
        let mut guide = Vec::with_capacity(GUIDE);
        let mut i = 0usize;
        for j in 0..GUIDE {
            let u = j as f64 / GUIDE as f64;
            while i < cells - 1 && cdf[i + 1] <= u {
                i += 1;
            }
            guide.push(i as u32);
        }
        let (mut m1, mut m2) = (0.0, 0.0);
        for i in 0..cells {
            let (a, b) = (lo + i as f64 * step, lo + (i + 1) as f64 * step);
            let w = cdf[i + 1] - cdf[i];
            m1 += w * 0.5 * (a + b);
            m2 += w * (a * a + a * b + b * b) / 3.0;
        }
        TabulatedPdf {
            lo,
            step,
            cdf,
            guide,
            mean: m1,
            rms: m2.sqrt(),
            label: label.to_string(),
            alias: std::sync::OnceLock::new(),
        }
    }

    /// Lower end of the support (e-).
    pub fn lo(&self) -> f64 {
        self.lo
    }

    /// Upper end of the support (e-).
    pub fn hi(&self) -> f64 {
        self.lo + self.step * (self.cdf.len() - 1) as f64
    }

    /// Probability density at `x` (per e-), piecewise constant per cell.
    pub fn density(&self, x: f64) -> f64 {
        let t = (x - self.lo) / self.step;
        if t < 0.0 || t >= (self.cdf.len() - 1) as f64 {
            return 0.0;
        }
        let i = t as usize;
        (self.cdf[i + 1] - self.cdf[i]) / self.step
    }

    /// A copy with every rms multiplied by `scale` (support and moments scale with it).
    pub fn scaled(&self, scale: f64, label: &str) -> Self {
        Self::from_cdf(self.lo * scale, self.step * scale, self.cdf.clone(), label)
    }

    fn invert(&self, u: f64) -> f64 {
        let cells = self.cdf.len() - 1;
        let mut i = self.guide[((u * GUIDE as f64) as usize).min(GUIDE - 1)] as usize;
        while i < cells - 1 && self.cdf[i + 1] <= u {
            i += 1;
        }
        let w = self.cdf[i + 1] - self.cdf[i];
        let frac = if w > 0.0 { (u - self.cdf[i]) / w } else { 0.0 };
        self.lo + (i as f64 + frac.clamp(0.0, 1.0)) * self.step
    }
}

impl TabulatedPdf {
    /// The alias table, built on first use.
    fn alias_table(&self) -> &[u64] {
        self.alias.get_or_init(|| alias_table(&self.cdf))
    }

    /// The rms (e-) that the deviates of [`alias_deviates`] pick: the cell kept or its alias,
    /// and the position `within` it.
    #[inline]
    fn alias_value(&self, table: &[u64], product: u128, within: f64) -> f64 {
        let i = (product >> 64) as usize;
        let entry = table[i];
        let cell = if ((product as u64) >> 32) < (entry >> 32) {
            i
        } else {
            (entry & 0xffff_ffff) as usize
        };
        self.lo + (cell as f64 + within) * self.step
    }
}

/// One draw's deviates, in draw order: bits x cells / 2^64 (the integer part picks the cell,
/// each with probability 1/cells to 2^-64; the fractional part, uniform and independent of it,
/// decides keep or alias), then the position within the cell.
#[inline]
fn alias_deviates(table: &[u64], rng: &mut SimRng) -> (u128, f64) {
    let product = u128::from(rng.random::<u64>()) * table.len() as u128;
    (product, rng.random::<f64>())
}

/// Walker's alias table over cells of masses `cdf[i + 1] - cdf[i]` (Vose's construction):
/// entry i packs the probability of keeping cell i (high 32 bits, in units of 2^-32) and the
/// cell taken otherwise (low 32 bits). One draw reads one entry, wherever the mass lies, so a
/// sample costs one cache access instead of a guide lookup and a search.
fn alias_table(cdf: &[f64]) -> Vec<u64> {
    let cells = cdf.len() - 1;
    let mut scaled: Vec<f64> = cdf
        .windows(2)
        .map(|w| (w[1] - w[0]) * cells as f64)
        .collect();
    let (mut small, mut large): (Vec<usize>, Vec<usize>) =
        (0..cells).partition(|&i| scaled[i] < 1.0);
    let mut table = vec![0u64; cells];
    let keep = |p: f64| ((p.clamp(0.0, 1.0) * 4_294_967_296.0) as u64).min(u32::MAX as u64);
    while let (Some(&s), Some(&l)) = (small.last(), large.last()) {
        small.pop();
        table[s] = (keep(scaled[s]) << 32) | l as u64;
        scaled[l] -= 1.0 - scaled[s];
        if scaled[l] < 1.0 {
            large.pop();
            small.push(l);
        }
    }
    // Left over (round-off): cells kept with certainty.
    for i in small.into_iter().chain(large) {
        table[i] = (u64::from(u32::MAX) << 32) | i as u64;
    }
    table
}

impl RmsPdf for TabulatedPdf {
    fn sample(&self, rng: &mut SimRng) -> f64 {
        let table = self.alias_table();
        let (product, within) = alias_deviates(table, rng);
        self.alias_value(table, product, within)
    }

    fn sample_into(&self, rng: &mut SimRng, out: &mut [f64]) {
        const BATCH: usize = 64;
        let table = self.alias_table();
        // The deviates of a batch first (in draw order), then its table entries: the look-ups
        // (800 KB of table, mostly outside the L1 cache) are then independent and overlap.
        let mut deviates = [(0u128, 0.0); BATCH];
        for chunk in out.chunks_mut(BATCH) {
            for d in deviates.iter_mut().take(chunk.len()) {
                *d = alias_deviates(table, rng);
            }
            for (o, &(product, within)) in chunk.iter_mut().zip(&deviates) {
                *o = self.alias_value(table, product, within);
            }
        }
    }

    fn quantile(&self, p: f64) -> f64 {
        self.invert(p.clamp(0.0, 1.0 - f64::EPSILON))
    }

    fn cdf(&self, x: f64) -> f64 {
        let t = (x - self.lo) / self.step;
        if t <= 0.0 {
            return 0.0;
        }
        let cells = self.cdf.len() - 1;
        if t >= cells as f64 {
            return 1.0;
        }
        let i = t as usize;
        self.cdf[i] + (t - i as f64) * (self.cdf[i + 1] - self.cdf[i])
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
    use crate::pdf::paper;
    use crate::rng::stream;

    #[test]
    fn batched_draws_are_the_single_draws() {
        // sample_into must consume the stream exactly as sample does, element by element
        // (common random numbers): lengths across the batch size, and the stream after.
        let pdf = paper();
        for n in [0, 1, 63, 64, 65, 200] {
            let (mut a, mut b) = (stream(12, n, 0), stream(12, n, 0));
            let mut batch = vec![0.0; n as usize];
            pdf.sample_into(&mut a, &mut batch);
            let single: Vec<f64> = (0..n).map(|_| pdf.sample(&mut b)).collect();
            assert_eq!(batch, single, "{n}");
            assert_eq!(a.random::<u64>(), b.random::<u64>(), "{n}");
        }
    }

    #[test]
    fn paper_pdf_moments_match_spec() {
        // Reference values from numerical quadrature (notes 3.1), quoted to 4 digits.
        let p = paper();
        assert!((p.median() - 0.7944).abs() < 1e-3, "median {}", p.median());
        assert!((p.mean() - 1.078).abs() < 1e-3, "mean {}", p.mean());
        assert!((p.rms() - 1.470).abs() < 2e-3, "rms {}", p.rms());
        assert!((1.0 - p.cdf(1.0) - 0.2398).abs() < 5e-4);
        assert!((1.0 - p.cdf(5.0) - 0.0175).abs() < 5e-4);
    }

    #[test]
    fn paper_pdf_analytic_quantiles() {
        let p = paper();
        for (q, x) in [
            (0.05, 0.5769),
            (0.25, 0.6933),
            (0.75, 0.9843),
            (0.95, 2.6573),
            (0.99, 6.3478),
        ] {
            assert!(
                (p.quantile(q) - x).abs() < 2e-3 * x,
                "q{q}: {}",
                p.quantile(q)
            );
        }
    }

    #[test]
    fn paper_sampler_quantiles_within_standard_error() {
        // Sample quantile SE = sqrt(q(1-q)/N) / f(x_q); allow 4 SE (plus the 4-digit rounding).
        let p = paper();
        let n = 400_000;
        let mut rng = stream(7, 0, 0);
        let mut xs: Vec<f64> = (0..n).map(|_| p.sample(&mut rng)).collect();
        xs.sort_by(f64::total_cmp);
        for (q, x) in [
            (0.05, 0.577),
            (0.25, 0.693),
            (0.75, 0.984),
            (0.95, 2.657),
            (0.99, 6.348),
        ] {
            let got = xs[(q * n as f64) as usize];
            let se = (q * (1.0 - q) / n as f64).sqrt() / p.density(x);
            assert!(
                (got - x).abs() < 4.0 * se + 1e-3,
                "q{q}: {got} vs {x} (se {se})"
            );
        }
        // Mean: SE = sd / sqrt(N), sd = sqrt(E[x^2] - mean^2).
        let mean = xs.iter().sum::<f64>() / n as f64;
        let sd = (p.rms().powi(2) - p.mean().powi(2)).sqrt();
        assert!((mean - 1.078).abs() < 4.0 * sd / (n as f64).sqrt() + 1e-3);
    }

    #[test]
    fn untabulable_densities_are_none_not_a_panic() {
        // All mass inside the first cell, missed by every quadrature node.
        let spike = |x: f64| if x < 1e-3 { 1.0 } else { 0.0 };
        assert!(TabulatedPdf::try_from_density(spike, 0.0, 1e12, "t").is_none());
        assert!(TabulatedPdf::try_from_density(|_| 1.0, 1.0, 1.0, "t").is_none());
        assert!(TabulatedPdf::try_from_density(|_| 1.0, 0.0, f64::NAN, "t").is_none());
        assert!(TabulatedPdf::try_from_density(|_| f64::INFINITY, 0.0, 1.0, "t").is_none());
        assert!(TabulatedPdf::try_from_density(|_| 1.0, 0.0, 1.0, "t").is_some());
    }

    #[test]
    fn scaling_scales_quantiles() {
        let p = paper();
        let s = p.scaled(2.0, "x2");
        assert!((s.median() - 2.0 * p.median()).abs() < 1e-9);
        assert!((s.mean() - 2.0 * p.mean()).abs() < 1e-9);
    }
}
