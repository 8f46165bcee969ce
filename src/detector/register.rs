//! The EMCCD multiplication register: exact sampling of its output (used by `emccd-stochastic`
//! and `emccd-pp`, and by `synth` for EMCCD frames).

use crate::rng::SimRng;
use rand::RngExt;
use rand_distr::{Binomial, Distribution};
use rustfft::{num_complex::Complex64, FftPlanner};

/// An EM register of `stages` stages with mean gain `gain` (output e- per input e-).
///
/// Each stage, each electron creates one more with probability p = gain^(1/stages) - 1.
/// Descendants of different input electrons are independent, so the output for k input
/// electrons is a sum of k draws from the single-electron output distribution, which is
/// tabulated exactly once (pgf iteration on roots of unity + inverse FFT) and sampled
/// with an alias table. `sample_cascade` is the per-stage binomial reference.
#[derive(Debug, Clone)]
pub struct EmRegister {
    gain: f64,
    stages: u32,
    p: f64,
    alias: AliasTable,
}

/// Largest mean EM gain accepted (output e- per input e-). EMCCD cameras run at gains of at most
/// a few thousand; the tabulated single-electron output holds about 40 x gain entries, so its
/// memory and set-up time grow linearly with the gain (0.03 GB and 1 s at this bound).
pub const MAX_EM_GAIN: f64 = 10_000.0;

/// Largest number of register stages accepted. Real registers have 400 to 1100 stages; the
/// table's set-up and the per-stage cascade cost time proportional to the stage count.
pub const MAX_STAGES: u32 = 2000;

/// Input electrons above which [`EmRegister::sample`] switches from summing k table draws
/// (cost O(k)) to the per-stage binomial cascade (cost O(stages), independent of k). Both are
/// exact; the cost is equal near 7,000 electrons (about 40 us each), and the switch keeps
/// bright pixels from making a frame cost O(signal).
const CASCADE_ABOVE_E: u64 = 8192;

/// Per-stage multiplication probability p of a register of mean gain `gain` (e-/e-) over
/// `stages` stages: g^(1/N) - 1, in [0, 1] (a gain below 1 gives 0; p can exceed 1 by round-off
/// when the gain is exactly 2^N).
pub fn stage_probability(gain: f64, stages: u32) -> f64 {
    (gain.max(1.0).powf(1.0 / stages as f64) - 1.0).clamp(0.0, 1.0)
}

/// Exact variance of the register's output for one input electron (e-^2), at per-stage
/// probability `p`: (1-p)(1+p)^(N-1)((1+p)^N - 1).
pub fn single_electron_variance(p: f64, stages: u32) -> f64 {
    let m = 1.0 + p;
    let n = stages as i32;
    (1.0 - p) * m.powi(n - 1) * (m.powi(n) - 1.0)
}

/// Excess noise factor squared of a register of mean gain `gain` (e-/e-) for Poisson input:
/// 1 + var1 / g^2. A formula, cheap at any gain: the fits call it at every trial gain without
/// building (tabulating) a register.
pub fn excess_noise_factor_sq(gain: f64, stages: u32) -> f64 {
    1.0 + single_electron_variance(stage_probability(gain, stages), stages) / (gain * gain)
}

impl EmRegister {
    /// Register with mean gain `gain` (1 ..= [`MAX_EM_GAIN`]) and `stages` stages
    /// (1 ..= [`MAX_STAGES`], and enough that p <= 1: see [`EmRegister::check`]).
    pub fn new(gain: f64, stages: u32) -> crate::Result<Self> {
        Self::check(gain, stages, "em_gain")?;
        let p = stage_probability(gain, stages);
        let pmf = single_electron_pmf(p, stages, gain);
        Ok(EmRegister {
            gain,
            stages,
            p,
            alias: AliasTable::new(&pmf),
        })
    }

    /// Fewest stages that reach mean gain `gain` with a per-stage probability p <= 1
    /// (each stage at most doubles the electrons): ceil(log2 gain), at least 1.
    pub fn min_stages(gain: f64) -> u32 {
        let mut n = (gain.log2().ceil().max(1.0)) as u32;
        // log2 is exact for powers of two; step back if round-off overshot.
        while n > 1 && gain.powf(1.0 / (n - 1) as f64) - 1.0 <= 1.0 + P_ROUND_OFF {
            n -= 1;
        }
        n
    }

    /// Check a register's gain and stage count; errors name the field `gain_field` (the
    /// caller's name of the gain, e.g. `gain` or `em_gain`) and `stages`.
    pub fn check(gain: f64, stages: u32, gain_field: &str) -> crate::Result<()> {
        use crate::Error;
        if !(gain.is_finite() && (1.0..=MAX_EM_GAIN).contains(&gain)) {
            return Err(Error::invalid(
                gain_field,
                format!(
                    "EM gain {gain} must be in [1, {MAX_EM_GAIN}] e-/e-: cameras run at most at a few thousand, \
                     and the exact register table grows with the gain (40 x gain entries)"
                ),
            ));
        }
        if !(1..=MAX_STAGES).contains(&stages) {
            return Err(Error::invalid(
                "stages",
                format!(
                    "{stages} stages: must be 1 to {MAX_STAGES} (real registers have 400 to 1100)"
                ),
            ));
        }
        let p = gain.powf(1.0 / stages as f64) - 1.0;
        if p > 1.0 + P_ROUND_OFF {
            let n = Self::min_stages(gain);
            let g_max = 2f64.powi(stages as i32);
            return Err(Error::invalid(
                "stages",
                format!(
                    "`stages` {stages} cannot give `{gain_field}` {gain}: each stage multiplies an \
                     electron with probability p = gain^(1/stages) - 1, here {p:.3}, but p is at \
                     most 1 (a stage at most doubles the charge). Gain {gain} needs at least {n} \
                     stages; {stages} stages reach a gain of at most {g_max}"
                ),
            ));
        }
        Ok(())
    }

    /// Mean gain (output e- per input e-).
    pub fn gain(&self) -> f64 {
        self.gain
    }

    /// Number of multiplication stages.
    pub fn stages(&self) -> u32 {
        self.stages
    }

    /// Per-stage multiplication probability p.
    pub fn p(&self) -> f64 {
        self.p
    }

    /// Exact variance of the output for one input electron (e-^2): see [`single_electron_variance`].
    pub fn single_electron_variance(&self) -> f64 {
        single_electron_variance(self.p, self.stages)
    }

    /// Excess noise factor squared for Poisson input: see [`excess_noise_factor_sq`].
    pub fn excess_noise_factor_sq(&self) -> f64 {
        excess_noise_factor_sq(self.gain, self.stages)
    }

    /// Output electrons for `k` input electrons (exact, fast): a sum of k table draws, or the
    /// per-stage cascade above `CASCADE_ABOVE_E` (8192) input electrons, where it is cheaper.
    pub fn sample(&self, k: u64, rng: &mut SimRng) -> f64 {
        if k > CASCADE_ABOVE_E {
            return self.sample_cascade(k, rng);
        }
        (0..k).map(|_| self.alias.sample(rng) as f64).sum()
    }

    /// Output electrons for `k` input electrons by the per-stage binomial cascade (reference).
    pub fn sample_cascade(&self, k: u64, rng: &mut SimRng) -> f64 {
        let mut m = k;
        for _ in 0..self.stages {
            if m > 0 {
                m += Binomial::new(m, self.p).expect("valid p").sample(rng);
            }
        }
        m as f64
    }
}

/// Serial (in-register) clock-induced charge: electrons born inside the register, a Poisson
/// number per pixel (`rate`, events per pixel over the whole register, the unit `emgain`
/// fits), each at a uniformly random stage, so that it passes j = 0 to N-1 of the N stages
/// with equal probability (as `emgain`'s model of it). Sampled exactly from the tabulated
/// mixture of the j-stage single-electron laws.
#[derive(Debug, Clone)]
pub struct SerialCic {
    rate: f64,
    alias: AliasTable,
}

impl SerialCic {
    /// Serial CIC at `rate` events per pixel (> 0) in the register of mean gain `gain` and
    /// `stages` stages (checked as [`EmRegister::check`]).
    pub fn new(rate: f64, gain: f64, stages: u32) -> crate::Result<Self> {
        EmRegister::check(gain, stages, "em_gain")?;
        let p = stage_probability(gain, stages);
        Ok(SerialCic {
            rate,
            alias: AliasTable::new(&output_pmf(gain, |z| serial_mixture(z, p, stages))),
        })
    }

    /// Output electrons of one pixel's serial CIC: a Poisson number of events, each through
    /// the stages left after its birth.
    pub fn sample(&self, rng: &mut SimRng) -> f64 {
        let k = crate::stats::poisson(self.rate, rng);
        (0..k).map(|_| self.alias.sample(rng) as f64).sum()
    }
}

/// Mean and second moment of the output (e-, e-^2) of one serial-CIC electron of a register of
/// mean gain `gain` and `stages` stages: the averages over j = 0..N-1 stages passed of
/// (1+p)^j and of var_j + (1+p)^(2j).
pub fn serial_cic_moments(gain: f64, stages: u32) -> (f64, f64) {
    let p = stage_probability(gain, stages);
    let (mut m1, mut m2) = (0.0, 0.0);
    for j in 0..stages {
        let mean = (1.0 + p).powi(j as i32);
        m1 += mean;
        m2 += single_electron_variance(p, j) + mean * mean;
    }
    let n = f64::from(stages);
    (m1 / n, m2 / n)
}

/// The mixture over j = 0..N-1 stages of the pgf after j stages, at each point of `z` (in
/// place), in blocks as [`compose_stages`].
fn serial_mixture(z: &mut [Complex64], p: f64, stages: u32) {
    let n = f64::from(stages);
    for block in z.chunks_mut(64) {
        let mut sum = [Complex64::new(0.0, 0.0); 64];
        for _ in 0..stages {
            for (v, s) in block.iter_mut().zip(sum.iter_mut()) {
                *s += *v;
                *v = *v * ((1.0 - p) + p * *v);
            }
        }
        for (v, s) in block.iter_mut().zip(sum) {
            *v = s / n;
        }
    }
}

/// Round-off allowed in p = gain^(1/stages) - 1 <= 1 (gain exactly 2^stages).
const P_ROUND_OFF: f64 = 1e-12;

/// Single-electron output pmf, index = output electrons (index 0 has probability 0).
fn single_electron_pmf(p: f64, stages: u32, gain: f64) -> Vec<f64> {
    output_pmf(gain, |z| compose_stages(z, p, stages))
}

/// The pmf of an output of at least one electron (index = output electrons, index 0 has
/// probability 0) whose pgf `pgf` evaluates in place on the roots of unity, for a register of
/// mean gain `gain`.
fn output_pmf(gain: f64, pgf: impl FnOnce(&mut [Complex64])) -> Vec<f64> {
    // The tail falls as exp(-x/g): 40 g leaves < 1e-17 of the mass outside.
    let size = ((40.0 * gain) as usize + 64).next_power_of_two().max(1024);
    let mut z: Vec<Complex64> = (0..size)
        .map(|j| Complex64::from_polar(1.0, 2.0 * std::f64::consts::PI * j as f64 / size as f64))
        .collect();
    pgf(&mut z);
    FftPlanner::new().plan_fft_forward(size).process(&mut z);
    // z_j = sum_k p_k e^{2 pi i jk/M}, so the forward FFT gives M p_m at index m.
    let mut pmf: Vec<f64> = z.iter().map(|v| (v.re / size as f64).max(0.0)).collect();
    pmf[0] = 0.0;
    let total: f64 = pmf.iter().sum();
    pmf.iter_mut().for_each(|v| *v /= total);
    while pmf.last() == Some(&0.0) {
        pmf.pop();
    }
    pmf
}

/// The pgf after `stages` stages at each point of `z` (in place): F_N = f o ... o f (s), with
/// f(s) = (1-p) s + p s^2. Each point's stages form a chain of dependent multiplications; a
/// block of points takes each stage in turn, so that the chains of the block overlap: the same
/// operations per point, so the same values, several times faster than one point's stages
/// after another.
fn compose_stages(z: &mut [Complex64], p: f64, stages: u32) {
    for block in z.chunks_mut(64) {
        for _ in 0..stages {
            for v in block.iter_mut() {
                *v = *v * ((1.0 - p) + p * *v);
            }
        }
    }
}

/// Walker/Vose alias table for O(1) sampling of a discrete distribution.
#[derive(Debug, Clone)]
struct AliasTable {
    prob: Vec<f64>,
    alias: Vec<u32>,
}

impl AliasTable {
    fn new(pmf: &[f64]) -> Self {
        let n = pmf.len();
        let mut prob: Vec<f64> = pmf.iter().map(|p| p * n as f64).collect();
        let mut alias = vec![0u32; n];
        let (mut small, mut large): (Vec<usize>, Vec<usize>) = (0..n).partition(|&i| prob[i] < 1.0);
        while let (Some(s), Some(&l)) = (small.pop(), large.last()) {
            alias[s] = l as u32;
            prob[l] -= 1.0 - prob[s];
            if prob[l] < 1.0 {
                large.pop();
                small.push(l);
            }
        }
        for i in small.into_iter().chain(large) {
            prob[i] = 1.0;
        }
        AliasTable { prob, alias }
    }

    fn sample(&self, rng: &mut SimRng) -> usize {
        let i = rng.random_range(0..self.prob.len());
        if rng.random::<f64>() < self.prob[i] {
            i
        } else {
            self.alias[i] as usize
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rng::stream;
    use crate::stats::mean_var;

    #[test]
    fn serial_cic_has_the_moments_of_uniform_birth_stages() {
        // Mean per event (1/N) sum_j (1+p)^j = (G - 1) / (N p); a pixel's output is compound
        // Poisson: mean rate m1, variance rate m2, both within 4 SE over 200k pixels.
        let (g, stages, rate) = (100.0, 200, 0.5);
        let (m1, m2) = serial_cic_moments(g, stages);
        let p = stage_probability(g, stages);
        assert!(
            (m1 - (g - 1.0) / (f64::from(stages) * p)).abs() < 1e-9 * m1,
            "{m1}"
        );
        let serial = SerialCic::new(rate, g, stages).unwrap();
        let mut rng = stream(11, 0, 0);
        let n = 200_000;
        let xs: Vec<f64> = (0..n).map(|_| serial.sample(&mut rng)).collect();
        let (m, v) = mean_var(&xs);
        let var = rate * m2;
        assert!(
            (m - rate * m1).abs() < 4.0 * (var / n as f64).sqrt(),
            "mean {m}"
        );
        // The variance's SE from the sample's own fourth moment.
        let m4 = xs.iter().map(|x| (x - m).powi(4)).sum::<f64>() / n as f64;
        let se = ((m4 - v * v) / n as f64).sqrt();
        assert!(
            (v - var).abs() < 4.0 * se,
            "variance {v} vs {var} (se {se})"
        );
    }

    #[test]
    fn stages_composed_in_blocks_are_composed_point_by_point() {
        // 1000 points (whole blocks and a remainder) on the unit circle and inside it: the
        // blocked iteration gives each point's values bit for bit.
        let (p, stages) = (stage_probability(500.0, 520), 520);
        let start: Vec<Complex64> = (0..1000)
            .map(|j| Complex64::from_polar(1.0 - (j % 3) as f64 * 0.1, j as f64 * 0.0063))
            .collect();
        let mut blocked = start.clone();
        compose_stages(&mut blocked, p, stages);
        for (v0, b) in start.iter().zip(&blocked) {
            let mut v = *v0;
            for _ in 0..stages {
                v = v * ((1.0 - p) + p * v);
            }
            assert_eq!(
                (v.re.to_bits(), v.im.to_bits()),
                (b.re.to_bits(), b.im.to_bits())
            );
        }
    }

    #[test]
    fn analytic_moments_for_paper_register() {
        let r = EmRegister::new(500.0, 520).unwrap();
        assert!((r.p() - 0.012_022_9).abs() < 1e-7);
        let v = r.single_electron_variance() / (500.0 * 500.0);
        assert!((v - 0.974_287).abs() < 1e-6, "var1/g^2 = {v}");
        assert!((r.excess_noise_factor_sq() - 1.974_29).abs() < 1e-5);
    }

    /// Mean and variance of a pmf indexed by output electrons.
    fn pmf_moments(pmf: &[f64]) -> (f64, f64) {
        let mean: f64 = pmf.iter().enumerate().map(|(k, p)| k as f64 * p).sum();
        let var = pmf
            .iter()
            .enumerate()
            .map(|(k, p)| (k as f64 - mean).powi(2) * p)
            .sum();
        (mean, var)
    }

    #[test]
    fn tabulated_pmf_has_exact_moments() {
        // The table itself (no sampling error): mean g, variance var1, to FFT round-off.
        let r = EmRegister::new(500.0, 520).unwrap();
        let pmf = single_electron_pmf(r.p(), 520, 500.0);
        let (mean, var) = pmf_moments(&pmf);
        assert!((mean / 500.0 - 1.0).abs() < 1e-9, "mean {mean}");
        assert!(
            (var / r.single_electron_variance() - 1.0).abs() < 1e-8,
            "var {var}"
        );
    }

    #[test]
    fn fast_sampler_matches_moments_within_standard_error() {
        // k = 3 input electrons: mean 3g, variance 3 var1. SE(mean) = sd/sqrt(N);
        // SE(var) ~ var * sqrt((kurt - 1)/N), kurtosis of this sum ~ 5, so sqrt(4/N).
        let r = EmRegister::new(500.0, 520).unwrap();
        let n = 200_000;
        let mut rng = stream(3, 0, 0);
        let xs: Vec<f64> = (0..n).map(|_| r.sample(3, &mut rng)).collect();
        let (mean, var) = mean_var(&xs);
        let true_var = 3.0 * r.single_electron_variance();
        assert!((mean - 1500.0).abs() < 4.0 * (true_var / n as f64).sqrt());
        assert!((var - true_var).abs() < 4.0 * true_var * (4.0 / n as f64).sqrt());
    }

    #[test]
    fn fast_sampler_matches_per_stage_cascade() {
        // Two-sample Kolmogorov-Smirnov: critical distance at alpha = 0.001 is
        // 1.95 * sqrt(2/N). Also means and variances against the analytic values.
        let r = EmRegister::new(500.0, 520).unwrap();
        let n = 20_000;
        let mut ra = stream(11, 0, 0);
        let mut rb = stream(11, 0, 1);
        let mut a: Vec<f64> = (0..n).map(|_| r.sample(1, &mut ra)).collect();
        let mut b: Vec<f64> = (0..n).map(|_| r.sample_cascade(1, &mut rb)).collect();
        let v1 = r.single_electron_variance();
        for xs in [&a, &b] {
            let (m, v) = mean_var(xs);
            assert!((m - 500.0).abs() < 4.0 * (v1 / n as f64).sqrt(), "mean {m}");
            assert!(
                (v - v1).abs() < 4.0 * v1 * (8.0 / n as f64).sqrt(),
                "var {v}"
            );
            assert!(xs.iter().all(|x| *x >= 1.0));
        }
        let d = ks_distance(&mut a, &mut b);
        assert!(d < 1.95 * (2.0 / n as f64).sqrt(), "KS distance {d}");
    }

    #[test]
    fn stage_count_must_let_each_stage_at_most_double_the_charge() {
        // p = g^(1/N) - 1 <= 1 needs N >= log2 g: 500 needs 9 stages, 512 exactly 9, 513 ten.
        assert_eq!(EmRegister::min_stages(500.0), 9);
        assert_eq!(EmRegister::min_stages(512.0), 9);
        assert_eq!(EmRegister::min_stages(513.0), 10);
        assert_eq!(EmRegister::min_stages(1.0), 1);
        assert_eq!(EmRegister::min_stages(2.0), 1);
        for (gain, stages) in [(500.0, 1), (500.0, 8), (3.0, 1)] {
            let err = EmRegister::new(gain, stages).unwrap_err();
            assert_eq!(err.exit_code(), 2);
            let msg = err.to_string();
            let n = EmRegister::min_stages(gain);
            assert!(
                msg.contains("`stages`")
                    && msg.contains("`em_gain`")
                    && msg.contains(&format!("at least {n} stages")),
                "{msg}"
            );
        }
        for (gain, stages) in [
            (1e9, 520),
            (0.5, 520),
            (f64::NAN, 520),
            (500.0, 0),
            (500.0, MAX_STAGES + 1),
        ] {
            assert_eq!(
                EmRegister::new(gain, stages).unwrap_err().exit_code(),
                2,
                "{gain} {stages}"
            );
        }
    }

    #[test]
    fn register_at_the_stage_limit_is_exact() {
        // Gain 2^9 with 9 stages: p = 1, every stage doubles, so one electron gives exactly 512.
        let r = EmRegister::new(512.0, 9).unwrap();
        assert_eq!(r.p(), 1.0);
        let mut rng = stream(5, 0, 0);
        for k in [1, 3] {
            assert_eq!(r.sample(k, &mut rng), 512.0 * k as f64);
            assert_eq!(r.sample_cascade(k, &mut rng), 512.0 * k as f64);
        }
        // Gain 500 with 9 stages (p = 0.995): the table keeps the exact mean and variance (to
        // 1e-6: FFT round-off clipped at 0 on the many near-empty outputs of a near-doubling
        // register; the exact variance, 658.34186, agrees with a direct branching sum).
        let r = EmRegister::new(500.0, 9).unwrap();
        let pmf = single_electron_pmf(r.p(), 9, 500.0);
        let (mean, var) = pmf_moments(&pmf);
        assert!((mean / 500.0 - 1.0).abs() < 1e-9, "mean {mean}");
        assert!(
            (var / r.single_electron_variance() - 1.0).abs() < 1e-6,
            "var {var}"
        );
        assert!((r.single_electron_variance() - 658.341_861_5).abs() < 1e-6);
    }

    #[test]
    fn bright_pixels_use_the_cascade_with_the_same_moments() {
        // Above CASCADE_ABOVE_E input electrons the sampler switches to the cascade, whose cost
        // does not grow with k. Mean k g and variance k var1 within 4 SE (kurtosis ~ 3 for a
        // sum of this many electrons: SE(var) ~ var sqrt(2/N)).
        let r = EmRegister::new(500.0, 520).unwrap();
        let k = 4 * CASCADE_ABOVE_E;
        let n = 4000;
        let mut rng = stream(8, 0, 0);
        let xs: Vec<f64> = (0..n).map(|_| r.sample(k, &mut rng)).collect();
        let (m, v) = mean_var(&xs);
        let var = k as f64 * r.single_electron_variance();
        assert!(
            (m - k as f64 * 500.0).abs() < 4.0 * (var / n as f64).sqrt(),
            "mean {m}"
        );
        assert!(
            (v - var).abs() < 4.0 * var * (2.5 / n as f64).sqrt(),
            "var {v} vs {var}"
        );
    }

    fn ks_distance(a: &mut [f64], b: &mut [f64]) -> f64 {
        a.sort_by(f64::total_cmp);
        b.sort_by(f64::total_cmp);
        let (mut i, mut j, mut d) = (0, 0, 0.0f64);
        while i < a.len() && j < b.len() {
            let x = a[i].min(b[j]);
            while i < a.len() && a[i] <= x {
                i += 1;
            }
            while j < b.len() && b[j] <= x {
                j += 1;
            }
            d = d.max((i as f64 / a.len() as f64 - j as f64 / b.len() as f64).abs());
        }
        d
    }
}
