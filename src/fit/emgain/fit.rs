//! The EM-gain fit: the options and histogram checked, start values, the fit problem set
//! up from the best of several candidate starts (`problem`), Nelder-Mead within a work
//! budget, and standard errors from the Hessian.

use super::histogram::{ValueHistogram, MAX_HIST_BINS};
use super::model::{excess_noise_factor_sq, law_gain};
use super::options::{EmGainOptions, EmShape, SerialCic};
use super::problem::{fitted_moments, Layout, Problem};
use super::result::{EmCrossChecks, EmGainFit, EmStart, SerialCicTest};
use super::start::{far_limit, start_from_moments, start_values, MIN_SAMPLES};
use crate::error::{Error, Result};
use crate::fit::optim::{correlations, hessian, minimise, spd_inverse, INVALID_COST};

/// Work budget of one fit in model cells evaluated (2^26: a few seconds at most); the
/// limit on cost evaluations is derived from it, between 300 and 1200 (real fits need
/// 220 to 300).
const WORK_CELLS: u64 = 1 << 26;

/// Widest model grid (cells) on which serial CIC is tried on auto: twice the widest grid of
/// real EMCCD histograms (32768); wider grids come from frames that are not EMCCD frames,
/// where the serial-CIC law (up to 33 characteristic functions per frequency with the
/// Gamma law) would cost a minute.
const MAX_AUTO_SERIAL_CELLS: usize = 1 << 16;

/// [`fit_emgain`] of the histogram of `stack`'s values: a failure names its first file.
pub fn fit_emgain_of_stack(
    stack: &crate::io::FrameStack,
    h: &ValueHistogram,
    opts: &EmGainOptions,
) -> Result<EmGainFit> {
    fit_emgain(h, opts).map_err(|e| crate::io::name_file(&stack.sources[0].path, e))
}

/// Fit bias, read noise, gain and lambda (and serial CIC, see [`SerialCic`]) to a histogram
/// of EMCCD pixel values (adu).
///
/// The library entry for one EMCCD dark or low-light stack: fill a [`ValueHistogram`] while
/// streaming the frames (or use [`super::accumulate`]) and call this. With serial CIC on
/// auto (the default) both models are fitted on the same bins and the one with the lower
/// BIC is returned; `serial_cic_test` of the result holds the comparison.
pub fn fit_emgain(h: &ValueHistogram, opts: &EmGainOptions) -> Result<EmGainFit> {
    let conv = conversion_gain(opts)?;
    let shape = opts
        .shape
        .unwrap_or_else(|| EmShape::default_for(opts.gain_e_per_adu));
    check_histogram(h)?;
    let spread = Spread::of(h);
    let mode = match (opts.serial_cic, shape) {
        (SerialCic::On, EmShape::Gamma) => {
            return Err(Error::invalid(
                "serial_cic",
                "serial CIC has partial gain, modelled only with a register law (`stages`), not the exponential law",
            ))
        }
        (SerialCic::Auto, EmShape::Gamma) => SerialCic::Off,
        (m, _) => m,
    };
    let st = start(h, opts, shape)?;
    let (grid, problem) = set_up(h, opts, shape, conv, &st, &spread)?;
    let without = solve(&problem, shape);
    if mode == SerialCic::Off {
        return Ok(result(h, opts, shape, st, &grid, &problem, without?, None));
    }
    // On auto a failed fit without serial CIC is the answer: frames that are not EMCCD
    // frames fail it within its budget, and a second fit would double that time.
    let without = match (mode, without) {
        (SerialCic::Auto, Err(e)) => return Err(e),
        (_, w) => w,
    };
    let with = with_serial_cic(
        h, opts, shape, conv, &grid, &problem, &without, &spread, mode,
    );
    let (problem, solution, test) = choose(mode, problem, without, with, h.total())?;
    Ok(result(
        h,
        opts,
        shape,
        st,
        &grid,
        &problem,
        solution,
        Some(test),
    ))
}

/// The fit with serial CIC free, on the same bins as the fit without, started at that fit's
/// optimum (or at its start if it failed), on a model period that holds the EM tail of up to
/// 3 times that gain; on auto not tried on grids wider than [`MAX_AUTO_SERIAL_CELLS`].
#[allow(clippy::too_many_arguments)]
fn with_serial_cic(
    h: &ValueHistogram,
    opts: &EmGainOptions,
    shape: EmShape,
    conv: Option<f64>,
    grid: &Layout,
    without_problem: &Problem,
    without: &Result<Solution>,
    q: &Spread,
    mode: SerialCic,
) -> Result<(Problem, Solution)> {
    let from = match without {
        Ok(s) => s.p,
        Err(_) => without_problem.params(
            &without_problem
                .free
                .iter()
                .map(|i| without_problem.base[*i])
                .collect::<Vec<_>>(),
        ),
    };
    let mix = opts.lambda_mixture.as_ref();
    let mut problem = grid.problem(h, shape, conv, mix, (10.0 * q.sq).max(75.0 * from[2]))?;
    if mode == SerialCic::Auto && problem.model.m > MAX_AUTO_SERIAL_CELLS {
        return Err(Error::Numeric(format!(
            "not tried on auto: the model grid of {} cells is wider than real EMCCD histograms need (at most {MAX_AUTO_SERIAL_CELLS}); `serial_cic` on fits it anyway",
            problem.model.m
        )));
    }
    problem.start_at(&from, opts.fixed_bias_adu.is_some(), true);
    let solution = solve(&problem, shape)?;
    Ok((problem, solution))
}

/// The model kept (its problem and solution) and the comparison of the fits without and with
/// serial CIC: with `On` the one with, with `Auto` the one with the lower BIC (the one
/// with serial CIC only if its rate is positive); a fit that failed loses (on auto the one
/// without has succeeded), both failing is the error of the one asked for.
fn choose(
    mode: SerialCic,
    without_problem: Problem,
    without: Result<Solution>,
    with: Result<(Problem, Solution)>,
    n: f64,
) -> Result<(Problem, Solution, SerialCicTest)> {
    let ll = |s: &Solution, p: &Problem| -s.cost * p.n;
    let ll0 = without.as_ref().ok().map(|s| ll(s, &without_problem));
    let ll1 = with.as_ref().ok().map(|(p, s)| ll(s, p));
    let lr = ll0.zip(ll1).map(|(a, b)| 2.0 * (b - a));
    let delta_bic = lr.map(|lr| lr - n.ln());
    let (rate, rate_se) = match &with {
        Ok((_, s)) => (Some(s.p[4]), Some(s.se[4])),
        Err(_) => (None, None),
    };
    let note = match (&without, &with) {
        (Err(e), _) => Some(format!("no fit without serial CIC: {e}")),
        (_, Err(e)) => Some(format!("no fit with serial CIC: {e}")),
        _ => None,
    };
    let present = match (mode, &without, &with) {
        (_, _, Err(_)) => false,
        (SerialCic::On, _, _) | (_, Err(_), _) => true,
        _ => delta_bic.is_some_and(|d| d > 0.0) && rate.is_some_and(|r| r > 0.0),
    };
    let test = SerialCicTest {
        mode,
        present,
        log_likelihood_without: ll0,
        log_likelihood_with: ll1,
        likelihood_ratio: lr,
        p_value: lr.map(|lr| 0.5 * statrs::function::erf::erfc((lr.max(0.0) / 2.0).sqrt())),
        delta_bic,
        serial_cic_e: rate,
        serial_cic_e_se: rate_se,
        note,
    };
    match (mode, present, without, with) {
        (SerialCic::On, _, _, Err(e)) => Err(e),
        (_, true, _, Ok((p, s))) => Ok((p, s, test)),
        (_, false, Ok(s), _) => Ok((without_problem, s, test)),
        (_, _, Err(e), _) | (_, _, _, Err(e)) => Err(e),
    }
}

/// The conversion gain (e- per adu) if given (the gain is then in e-/e-, else in adu per
/// e-), refused when not positive or when the exact register lacks it.
fn conversion_gain(opts: &EmGainOptions) -> Result<Option<f64>> {
    let shape = opts
        .shape
        .unwrap_or_else(|| EmShape::default_for(opts.gain_e_per_adu));
    if let Some(c) = opts.gain_e_per_adu {
        if !(c > 0.0 && c.is_finite()) {
            return Err(Error::invalid(
                "gain_e_per_adu",
                "must be a positive number",
            ));
        }
    }
    match (shape, opts.gain_e_per_adu) {
        (EmShape::Register { .. }, None) => Err(Error::invalid(
            "gain_e_per_adu",
            "the exact register law needs the conversion gain (`gain_e_per_adu`) to place the electron lattice",
        )),
        (_, c) => Ok(c),
    }
}

/// Fail unless the histogram holds the bulk of the values and enough of them to fit.
fn check_histogram(h: &ValueHistogram) -> Result<()> {
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
    Ok(())
}

/// Where a histogram's values lie (adu).
struct Spread {
    /// The 1e-4 quantile.
    q4: f64,
    /// A read-noise scale from the spacing of the lowest quantiles, at least the bins'
    /// quantisation noise.
    sq: f64,
    /// The median.
    q50: f64,
}

impl Spread {
    fn of(h: &ValueHistogram) -> Self {
        let ((q4, sq), q50) = (h.low_tail(), h.quantile(0.5));
        Spread {
            q4,
            sq: sq.max(h.width() / 12f64.sqrt()),
            q50,
        }
    }
}

/// Start values: from the histogram's peak, or from its moments when bias and read noise
/// are fixed (both or neither).
fn start(h: &ValueHistogram, opts: &EmGainOptions, shape: EmShape) -> Result<EmStart> {
    match (opts.fixed_bias_adu, opts.fixed_read_noise_adu) {
        (Some(b), Some(s)) if !(b.is_finite() && s.is_finite() && s > 0.0) => Err(Error::invalid(
            "fixed_read_noise_adu",
            format!("the maps give a bias of {b} adu and a read noise of {s} adu: both must be finite, the read noise > 0"),
        )),
        (Some(b), Some(s)) => start_from_moments(h, b, s, shape, opts.gain_e_per_adu),
        (None, None) => start_values(h),
        _ => Err(Error::invalid(
            "fixed_bias_adu",
            "bias and read noise are fixed together (both from no-signal frames, `fixed_bias_adu` with `fixed_read_noise_adu`) or not at all",
        )),
    }
}

/// The binning and the fit problem, started at the candidate of lowest cost on a model
/// period that holds the EM tail of any gain the optimiser may try.
fn set_up(
    h: &ValueHistogram,
    opts: &EmGainOptions,
    shape: EmShape,
    conv: Option<f64>,
    st: &EmStart,
    q: &Spread,
) -> Result<(Layout, Problem)> {
    let fixed = opts.fixed_bias_adu.is_some();
    // Far outliers (beyond the EM tail, or 10 read noises below the lowest quantile) are
    // left out of the moments and of the fitted range.
    let far = far_limit(h, st.bias_adu, st.read_noise_adu);
    let cands = candidates(h, opts, shape, st, q, far);
    let s_min = cands
        .iter()
        .map(|c| c[1])
        .fold(f64::INFINITY, f64::min)
        .min(q.sq);
    let g0 = st.gain_adu_per_e;
    let g_max = cands.iter().map(|c| c[2]).fold(0.0, f64::max).min(4.0 * g0);
    let grid = Layout::new(h, s_min, q.sq, q.q4, fit_top(h, opts, st, far));
    let mix = opts.lambda_mixture.as_ref();
    let trial = grid.problem(h, shape, conv, mix, (10.0 * q.sq).max(25.0 * g_max))?;
    let best = cands
        .iter()
        .map(|p| (trial.nll(&trial.internal(p)), *p))
        .min_by(|a, b| a.0.total_cmp(&b.0))
        .expect("at least one candidate");
    if best.0 >= INVALID_COST {
        return Err(Error::Numeric(
            "EM-gain fit: no start value gives a valid model (read noise below the bin resolution?)".into(),
        ));
    }
    // The period must hold the EM tail of any gain the optimiser may try (25 scale
    // lengths: wrapped mass < 1e-10): up to 3x the best start.
    let mut problem = grid.problem(h, shape, conv, mix, (10.0 * q.sq).max(75.0 * best.1[2]))?;
    problem.start_at(&best.1, fixed, false);
    Ok((grid, problem))
}

/// The top of the fitted range (adu): `max_value_adu`, or by default the start's bias plus
/// 40 gains for each of 1 + lambda + 5 sqrt(lambda) electrons; at most the highest value
/// short of the far outliers (from `far`).
fn fit_top(h: &ValueHistogram, opts: &EmGainOptions, st: &EmStart, far: f64) -> f64 {
    let (l0, g0) = (st.lambda_e, st.gain_adu_per_e);
    let data_hi = (h.centre(h.counts().len() - 1) + 0.5 * h.width()).min(far);
    opts.max_value_adu
        .unwrap_or(st.bias_adu + 40.0 * g0 * (1.0 + l0 + 5.0 * l0.sqrt()))
        .min(data_hi)
}

/// Candidate starts (b, s, G, lambda, serial CIC): the peak-based values, and a grid of
/// biases between the lowest values and the median with read noises from the spacing of
/// the lowest quantiles (where the bias peak drowns in the EM signal, e.g. low gain at high
/// light), each with gain and lambda from the moments of the values below `far`:
/// mean = b + lambda G, var = s^2 + lambda G^2 F^2. With bias and read noise fixed, the
/// start values only.
fn candidates(
    h: &ValueHistogram,
    opts: &EmGainOptions,
    shape: EmShape,
    st: &EmStart,
    q: &Spread,
    far: f64,
) -> Vec<[f64; 5]> {
    let fixed = opts.fixed_bias_adu.is_some();
    let (l0, g0) = (st.lambda_e, st.gain_adu_per_e);
    let (_, mean, var) = h.moments_within(q.q4 - 10.0 * q.sq, far);
    let f2 = excess_noise_factor_sq(shape, law_gain(g0, opts.gain_e_per_adu));
    let mut cands = vec![[st.bias_adu, st.read_noise_adu, g0, l0, 0.0]];
    for s in [st.read_noise_adu, 0.6 * q.sq, q.sq] {
        for k in 0..=24 {
            let b = q.q4 + (q.q50 - q.q4) * k as f64 / 24.0;
            let g = (var - s * s) / ((mean - b) * f2);
            let l = (mean - b) / g;
            if !fixed && g > 0.0 && l > 0.0 && g.is_finite() && l.is_finite() {
                cands.push([b, s, g, l, 0.0]);
            }
        }
    }
    cands
}

/// The optimum of one fit.
struct Solution {
    /// Natural parameters (b, s, G, lambda, serial CIC).
    p: [f64; 5],
    /// Their standard errors (0 for those not fitted).
    se: [f64; 5],
    /// Covariance of the fitted ones (internal coordinates).
    cov: Vec<Vec<f64>>,
    /// Nelder-Mead iterations.
    iterations: u64,
    /// Negative log-likelihood per sample at the optimum.
    cost: f64,
}

/// Minimise the problem's likelihood within the work budget; standard errors from the
/// Hessian.
fn solve(problem: &Problem, shape: EmShape) -> Result<Solution> {
    let n = problem.n;
    let u0: Vec<f64> = problem.free.iter().map(|i| problem.base[*i]).collect();
    let steps = [0.3, 0.1, 0.2, 0.2, 0.5];
    let step: Vec<f64> = problem.free.iter().map(|i| steps[*i]).collect();
    // Stop when the simplex spans 1e-4 in total log-likelihood.
    let tol = 1e-4 / n;
    // Bounded work: at most WORK_CELLS model cells in all (one FFT of m cells per cost,
    // the exact register costing more per cell); past the budget every cost is invalid,
    // which ends Nelder-Mead at once, and the fit is refused.
    let m = problem.model.m;
    let weight = match shape {
        EmShape::Gamma => 1,
        EmShape::Register { stages } => 1 + u64::from(stages) / 256,
        EmShape::RegisterGamma { .. } => 2,
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
    let hm: Vec<Vec<f64>> = hessian(|u| problem.nll(u), &fit.x, &vec![1e-3; u0.len()])
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
        let scale = match *i {
            0 => problem.s0,
            4 => problem.cic_scale,
            _ => p[*i],
        };
        se[*i] = cov[k][k].sqrt() * scale;
    }
    Ok(Solution {
        p,
        se,
        cov,
        iterations: fit.iterations,
        cost: fit.cost,
    })
}

/// The fit's record: the solution in the options' units, the fitted range and the
/// cross-checks from the fitted values' moments.
#[allow(clippy::too_many_arguments)]
fn result(
    h: &ValueHistogram,
    opts: &EmGainOptions,
    shape: EmShape,
    st: EmStart,
    grid: &Layout,
    problem: &Problem,
    s: Solution,
    serial_cic_test: Option<SerialCicTest>,
) -> EmGainFit {
    let (p, se, n) = (s.p, s.se, problem.n);
    let f2 = excess_noise_factor_sq(shape, law_gain(p[2], opts.gain_e_per_adu));
    let serial = problem.free.contains(&4);
    let (mean, var) = fitted_moments(problem, grid.lo, grid.w);
    let signal = mean - p[0];
    let (em_gain, em_gain_se, units) = match opts.gain_e_per_adu {
        Some(c) => (p[2] * c, se[2] * c, "e-/e-"),
        None => (p[2], se[2], "adu/e-"),
    };
    EmGainFit {
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
        serial_cic_e: serial.then_some(p[4]),
        serial_cic_e_se: serial.then_some(se[4]),
        serial_cic_test,
        gain_e_per_adu: opts.gain_e_per_adu,
        shape,
        law: shape.describe(),
        converged: true,
        iterations: s.iterations,
        log_likelihood: -s.cost * n,
        n_samples: n,
        n_excluded: problem.excluded + h.outside(),
        max_value_adu: grid.cut,
        bin_width_adu: grid.w,
        correlations: Some(correlations(&s.cov)),
        lambda_mixture: opts.lambda_mixture.clone(),
        zero_peak: None,
        start: st,
        cross_checks: EmCrossChecks {
            excess_noise_factor_sq: f2,
            mean_variance_gain_adu_per_e: (var - p[1] * p[1]) / (signal * f2),
            mean_variance_gain_no_enf_adu_per_e: (var - p[1] * p[1]) / signal,
            mean_signal_adu: signal,
            variance_adu2: var,
        },
    }
}
