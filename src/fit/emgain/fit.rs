//! The EM-gain fit: the data binned on the model's grid (`Layout`), the binned likelihood
//! (`Problem`), and Nelder-Mead from the best of several start values, with standard errors
//! from the Hessian.

use super::histogram::{ValueHistogram, MAX_HIST_BINS};
use super::model::{excess_noise_factor_sq, Model, MAX_FFT};
use super::options::{EmGainOptions, EmShape};
use super::result::{EmCrossChecks, EmGainFit};
use super::start::{far_limit, start_from_moments, start_values, MIN_SAMPLES};
use crate::error::{Error, Result};
use crate::fit::optim::{correlations, hessian, minimise, spd_inverse, INVALID_COST};
use rustfft::FftPlanner;

/// Work budget of one fit in model cells evaluated (2^26: a few seconds at most); the
/// limit on cost evaluations is derived from it, between 300 and 1200 (real fits need
/// 220 to 300).
const WORK_CELLS: u64 = 1 << 26;

/// The binned data and the model grid of one fit.
struct Problem {
    model: Model,
    /// Fine cells per data bin.
    per_bin: usize,
    /// Data counts per fitted bin, starting at fine cell 0.
    counts: Vec<f64>,
    n: f64,
    /// Samples outside the fitted range.
    excluded: f64,
    bias0: f64,
    s0: f64,
    guard_gain: f64,
    /// Internal coordinates of the parameters that are not free.
    base: [f64; 5],
    /// Indices (into bias, ln s, ln G, ln lambda) of the free parameters.
    free: Vec<usize>,
}

impl Problem {
    /// Natural parameters (b, s, G, lambda, serial CIC) from the free internal coordinates `u`.
    fn params(&self, u: &[f64]) -> [f64; 5] {
        let mut v = self.base;
        for (k, i) in self.free.iter().enumerate() {
            v[*i] = u[k];
        }
        [
            self.bias0 + v[0] * self.s0,
            v[1].exp(),
            v[2].exp(),
            v[3].exp(),
            v[4].exp(),
        ]
    }

    /// Internal coordinates of all natural parameters `p` (a zero CIC rate maps to -inf,
    /// which `params` maps back to 0 while the rate is not free).
    fn internal(&self, p: &[f64; 5]) -> [f64; 5] {
        [
            (p[0] - self.bias0) / self.s0,
            p[1].ln(),
            p[2].ln(),
            p[3].ln(),
            p[4].ln(),
        ]
    }

    /// Probabilities of the fitted bins, normalised over the fitted range.
    fn bin_probs(&self, p: &[f64; 5]) -> Option<Vec<f64>> {
        let [b, s, g, lambda, cic] = *p;
        // The model is valid while the fine cells resolve the Gaussian and the EM tail
        // does not wrap around the period.
        if s < 2.5 * self.model.h || g > self.guard_gain || lambda > 1e5 {
            return None;
        }
        let cells = self.model.cells(b, s, g, lambda, cic)?;
        let probs: Vec<f64> = cells
            .chunks(self.per_bin)
            .take(self.counts.len())
            .map(|c| c.iter().sum::<f64>().max(0.0))
            .collect();
        let total: f64 = probs.iter().sum();
        (total > 0.0).then(|| probs.into_iter().map(|q| q / total).collect())
    }

    /// Negative log-likelihood per sample.
    fn nll(&self, u: &[f64]) -> f64 {
        let Some(probs) = self.bin_probs(&self.params(u)) else {
            return INVALID_COST;
        };
        let mut s = 0.0;
        for (c, q) in self.counts.iter().zip(&probs) {
            if *c > 0.0 {
                s -= c * q.max(1e-300).ln();
            }
        }
        s / self.n
    }
}

/// Binning of one fit: fitted bins of width `w` (a multiple of the histogram's) from `lo`
/// to `cut` (adu), fine model cells of `h`.
struct Layout {
    lo: f64,
    cut: f64,
    w: f64,
    per_bin: usize,
    hfine: f64,
}

impl Layout {
    /// Bins at most `s_min`/2 wide; fine cells at most `s_min`/4.5 so that the Gaussian
    /// factor vanishes at the grid's Nyquist frequency; from 10 `sq` below `q4`.
    fn new(h: &ValueHistogram, s_min: f64, sq: f64, q4: f64, cut: f64) -> Self {
        let w0 = h.width();
        let data_lo = h.centre(0) - 0.5 * w0;
        let merge = ((0.5 * s_min / w0).floor() as usize).max(1);
        let w = merge as f64 * w0;
        let per_bin = ((4.5 * w / s_min).ceil() as usize).max(1);
        // From 10 read noises below the 1e-4 quantile (lower values are far outliers),
        // aligned with the histogram's bins.
        let lo = data_lo + ((q4 - 10.0 * sq - data_lo) / w).floor() * w;
        Layout {
            lo,
            cut,
            w,
            per_bin,
            hfine: w / per_bin as f64,
        }
    }

    /// The fit problem with a model period reaching `pad` adu beyond the cut.
    fn problem(&self, h: &ValueHistogram, shape: EmShape, conv: f64, pad: f64) -> Result<Problem> {
        // Sizes are checked before anything is allocated from them.
        let span = self.cut - self.lo + pad;
        let cells = (span / self.hfine).ceil();
        if cells.is_nan() || cells > MAX_FFT as f64 {
            return Err(Error::Numeric(format!(
                "the value range ({span:.0} adu) is too wide for model cells of {:.3} adu (set by the read noise): more than {MAX_FFT} cells, where real EMCCD histograms need at most 32768; if these are EMCCD frames, lower --max-value-adu or widen --bin-width-adu",
                self.hfine
            )));
        }
        let m = (cells as usize).max(2).next_power_of_two();
        let n_bins = ((self.cut - self.lo) / self.w).ceil().max(0.0) as usize;
        let mut counts = vec![0.0; n_bins];
        let mut excluded = 0.0;
        for (i, v) in h.counts().iter().enumerate() {
            let j = ((h.centre(i) - self.lo) / self.w).floor();
            if j >= 0.0 && (j as usize) < n_bins {
                counts[j as usize] += v;
            } else {
                excluded += v;
            }
        }
        let n: f64 = counts.iter().sum();
        Ok(Problem {
            model: Model {
                shape,
                conv,
                x0: self.lo,
                h: self.hfine,
                fft: FftPlanner::new().plan_fft_forward(m),
                m,
            },
            per_bin: self.per_bin,
            counts,
            n,
            excluded,
            bias0: 0.0,
            s0: 1.0,
            base: [0.0, 0.0, 0.0, 0.0, f64::NEG_INFINITY],
            free: vec![0, 1, 2, 3],
            guard_gain: (m as f64 * self.hfine - (self.cut - self.lo)) / 25.0,
        })
    }
}

/// [`fit_emgain`] of the histogram of `stack`'s values: a failure names its first file.
pub fn fit_emgain_of_stack(
    stack: &crate::io::FrameStack,
    h: &ValueHistogram,
    opts: &EmGainOptions,
) -> Result<EmGainFit> {
    fit_emgain(h, opts).map_err(|e| crate::io::name_file(&stack.sources[0].path, e))
}

/// Fit bias, read noise, gain and lambda to a histogram of EMCCD pixel values (adu).
pub fn fit_emgain(h: &ValueHistogram, opts: &EmGainOptions) -> Result<EmGainFit> {
    if let Some(c) = opts.gain_e_per_adu {
        if !(c > 0.0 && c.is_finite()) {
            return Err(Error::invalid(
                "gain_e_per_adu",
                "must be a positive number",
            ));
        }
    }
    let conv = match (opts.shape, opts.gain_e_per_adu) {
        (EmShape::Register { .. }, None) => {
            return Err(Error::invalid(
                "stages",
                "the exact register model needs the conversion gain (`gain_e_per_adu`)",
            ))
        }
        (_, c) => c.unwrap_or(1.0),
    };
    let n = h.total();
    let all = n + h.outside();
    if h.outside() > 0.01 * all {
        return Err(Error::Numeric(format!(
            "{} of {all} pixel values fall outside the histogram's window of {MAX_HIST_BINS} bins ({} adu) around the bulk of the values: spread far wider than the values of EMCCD frames (check the files, or widen --bin-width-adu)",
            h.outside(),
            MAX_HIST_BINS as f64 * h.width()
        )));
    }
    if (n as usize) < MIN_SAMPLES {
        return Err(Error::Numeric(format!(
            "only {n} pixel-samples: an EM-gain fit needs at least {MIN_SAMPLES} for stable start values and a meaningful histogram"
        )));
    }
    let w0 = h.width();
    let c = h.counts();
    let ((q4, sq), q50) = (h.low_tail(), h.quantile(0.5));
    let sq = sq.max(w0 / 12f64.sqrt());
    if opts.serial_cic && opts.shape == EmShape::Gamma {
        return Err(Error::invalid(
            "serial_cic",
            "serial CIC has partial gain, modelled only with the exact register (`stages`)",
        ));
    }
    let st =
        match (opts.fixed_bias_adu, opts.fixed_read_noise_adu) {
            (Some(b), Some(s)) if !(b.is_finite() && s.is_finite() && s > 0.0) => return Err(Error::invalid(
                "fixed_read_noise_adu",
                format!("the maps give a bias of {b} adu and a read noise of {s} adu: both must be finite, the read noise > 0"),
            )),
            (Some(b), Some(s)) => start_from_moments(h, b, s, opts.shape, conv)?,
            (None, None) => start_values(h)?,
            _ => return Err(Error::invalid(
                "fixed_bias_adu",
                "bias and read noise are fixed together (both from no-signal frames, `fixed_bias_adu` with `fixed_read_noise_adu`) or not at all",
            )),
        };
    let fixed = opts.fixed_bias_adu.is_some();
    let (l0, g0) = (st.lambda_e, st.gain_adu_per_e);
    // Far outliers (beyond the EM tail, or 10 read noises below the lowest quantile) are
    // left out of the moments and of the fitted range.
    let far = far_limit(h, st.bias_adu, st.read_noise_adu);
    let data_hi = (h.centre(c.len() - 1) + 0.5 * w0).min(far);
    let (_, mean, var) = h.moments_within(q4 - 10.0 * sq, far);
    let cut = opts
        .max_value_adu
        .unwrap_or(st.bias_adu + 40.0 * g0 * (1.0 + l0 + 5.0 * l0.sqrt()))
        .min(data_hi);
    // Candidate starts: the peak-based values, and a grid of biases between the lowest
    // values and the median with read noises from the spacing of the lowest quantiles
    // (where the bias peak drowns in the EM signal, e.g. low gain at high light), each
    // with gain and lambda from the moments: mean = b + lambda G,
    // var = s^2 + lambda G^2 F^2.
    let f2 = excess_noise_factor_sq(opts.shape, g0 * conv);
    let mut cands = vec![[st.bias_adu, st.read_noise_adu, g0, l0, 0.0]];
    for s in [st.read_noise_adu, 0.6 * sq, sq] {
        for k in 0..=24 {
            let b = q4 + (q50 - q4) * k as f64 / 24.0;
            let g = (var - s * s) / ((mean - b) * f2);
            let l = (mean - b) / g;
            if !fixed && g > 0.0 && l > 0.0 && g.is_finite() && l.is_finite() {
                cands.push([b, s, g, l, 0.0]);
            }
        }
    }
    let s_min = cands
        .iter()
        .map(|c| c[1])
        .fold(f64::INFINITY, f64::min)
        .min(sq);
    let g_max = cands.iter().map(|c| c[2]).fold(0.0, f64::max).min(4.0 * g0);
    let grid = Layout::new(h, s_min, sq, q4, cut);
    let mut problem = grid.problem(h, opts.shape, conv, (10.0 * sq).max(25.0 * g_max))?;
    let best = cands
        .iter()
        .map(|p| (problem.nll(&problem.internal(p)), *p))
        .min_by(|a, b| a.0.total_cmp(&b.0))
        .expect("at least one candidate");
    if best.0 >= INVALID_COST {
        return Err(Error::Numeric(
            "EM-gain fit: no start value gives a valid model (read noise below the bin resolution?)".into(),
        ));
    }
    // The period must hold the EM tail of any gain the optimiser may try (25 scale
    // lengths: wrapped mass < 1e-10): up to 3x the best start.
    problem = grid.problem(h, opts.shape, conv, (10.0 * sq).max(75.0 * best.1[2]))?;
    problem.bias0 = best.1[0];
    problem.s0 = best.1[1];
    problem.base = problem.internal(&best.1);
    if fixed {
        problem.free = vec![2, 3];
    }
    if opts.serial_cic {
        // Start the rate at a tenth of the light: the Nelder-Mead steps find the scale.
        problem.base[4] = (0.1 * best.1[3]).max(1e-4).ln();
        problem.free.push(4);
    }
    let (n, w, lo, cut, excluded) = (problem.n, grid.w, grid.lo, grid.cut, problem.excluded);
    let s0 = problem.s0;
    let u0: Vec<f64> = problem.free.iter().map(|i| problem.base[*i]).collect();
    let steps = [0.3, 0.1, 0.2, 0.2, 1.0];
    let step: Vec<f64> = problem.free.iter().map(|i| steps[*i]).collect();
    let cost = |u: &[f64]| problem.nll(u);
    // Stop when the simplex spans 1e-4 in total log-likelihood.
    let tol = 1e-4 / n;
    // Bounded work: at most WORK_CELLS model cells in all (one FFT of m cells per cost,
    // the exact register costing more per cell); past the budget every cost is invalid,
    // which ends Nelder-Mead at once, and the fit is refused.
    let m = problem.model.m;
    let weight = match opts.shape {
        EmShape::Gamma => 1,
        EmShape::Register { stages } => 1 + u64::from(stages) / 64,
    };
    let max_evals = (WORK_CELLS / (m as u64 * weight)).clamp(300, 1200);
    let evals = std::cell::Cell::new(0u64);
    let capped = |u: &[f64]| {
        evals.set(evals.get() + 1);
        if evals.get() > max_evals {
            INVALID_COST
        } else {
            problem.nll(u)
        }
    };
    let fit = minimise(capped, &u0, &step, tol, 20_000, "EM-gain fit");
    if evals.get() > max_evals {
        return Err(Error::Numeric(format!(
            "EM-gain fit: not converged after {max_evals} model evaluations on a grid of {m} cells (real EMCCD histograms, a Gaussian zero-electron peak and an exponential EM tail, converge in 220 to 300): these frames do not look like EMCCD darks or low-light frames (check the files, or give --max-value-adu to leave out what is not EM signal)"
        )));
    }
    let fit = fit?;
    let p = problem.params(&fit.x);
    let hm: Vec<Vec<f64>> = hessian(cost, &fit.x, &vec![1e-3; u0.len()])
        .into_iter()
        .map(|r| r.into_iter().map(|v| v * n).collect())
        .collect();
    let cov = spd_inverse(&hm).ok_or_else(|| {
        Error::Numeric(
            "EM-gain fit: the likelihood is flat in some direction at the optimum (Hessian not positive definite): the data do not constrain gain and light level separately".into(),
        )
    })?;
    // Fixed parameters have no standard error here (0): theirs is the no-signal frames'.
    let mut se = [0.0; 5];
    for (k, i) in problem.free.iter().enumerate() {
        let scale = if *i == 0 { s0 } else { p[*i] };
        se[*i] = cov[k][k].sqrt() * scale;
    }
    let f2 = excess_noise_factor_sq(opts.shape, p[2] * conv);
    let (mean, var) = fitted_moments(&problem, lo, w);
    let signal = mean - p[0];
    let (em_gain, em_gain_se, units) = match opts.gain_e_per_adu {
        Some(c) => (p[2] * c, se[2] * c, "e-/e-"),
        None => (p[2], se[2], "adu/e-"),
    };
    Ok(EmGainFit {
        em_gain,
        em_gain_se,
        em_gain_units: units.into(),
        gain_adu_per_e: p[2],
        gain_adu_per_e_se: se[2],
        bias_adu: p[0],
        bias_adu_se: se[0],
        read_noise_adu: p[1],
        read_noise_adu_se: se[1],
        read_noise_input_e: p[1] / p[2],
        lambda_e: p[3],
        lambda_e_se: se[3],
        serial_cic_e: opts.serial_cic.then_some(p[4]),
        serial_cic_e_se: opts.serial_cic.then_some(se[4]),
        gain_e_per_adu: opts.gain_e_per_adu,
        shape: opts.shape,
        converged: true,
        iterations: fit.iterations,
        log_likelihood: -fit.cost * n,
        n_samples: n,
        n_excluded: excluded + h.outside(),
        max_value_adu: cut,
        bin_width_adu: w,
        correlations: Some(correlations(&cov)),
        start: st,
        cross_checks: EmCrossChecks {
            excess_noise_factor_sq: f2,
            mean_variance_gain_adu_per_e: (var - p[1] * p[1]) / (signal * f2),
            mean_variance_gain_no_enf_adu_per_e: (var - p[1] * p[1]) / signal,
            mean_signal_adu: signal,
            variance_adu2: var,
        },
    })
}

/// Mean and variance (adu) of the fitted (not excluded) values, from their bins, with the
/// bin quantisation variance w^2/12 removed.
fn fitted_moments(p: &Problem, lo: f64, w: f64) -> (f64, f64) {
    let (mut s, mut s2) = (0.0, 0.0);
    for (i, c) in p.counts.iter().enumerate() {
        let x = lo + (i as f64 + 0.5) * w;
        s += c * x;
        s2 += c * x * x;
    }
    let m = s / p.n;
    (m, s2 / p.n - m * m - w * w / 12.0)
}
