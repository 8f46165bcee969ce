//! Telegraph (RTS) fit of one pixel's dark time series: a hidden Markov chain of two or three
//! levels with Gaussian noise around each, fitted by Baum-Welch (expectation maximisation
//! over the hidden levels), the number of levels chosen by BIC.
//!
//! Per level: the mean (adu, relative to the series' mean, so sum_k occupancy_k x level_k = 0
//! up to round-off), the Gaussian width, the occupancy (expected fraction of frames in it) and
//! the mean dwell time (expected frames in it / expected transitions out of it = 1 / (1 -
//! a_kk)). Standard errors: a level's mean sigma_k / sqrt(frames in it); the occupancy from
//! the chain's asymptotic variance of the fraction of time in a level, (pi_k (1 - pi_k) + 2
//! pi_k (Z_kk - 1)) / T with Z = (I - A + 1 pi)^-1 the fundamental matrix (time in a level is
//! correlated over a dwell time); the dwell time from its geometric run lengths, D sqrt((1 -
//! 1/D) / runs). BIC = -2 ln L + p ln T with p = 2 (one Gaussian), 2K + K (K - 1) (K levels:
//! means, widths, transition probabilities).

/// Fewest expected transitions out of every level for a fit to be `ok` (a dwell time from
/// fewer runs is a guess).
pub const MIN_RUNS: f64 = 3.0;
/// Most Baum-Welch iterations per fit.
const MAX_ITERS: usize = 100;
/// Convergence: change of ln L per sample between iterations (BIC weighs ln L in units of
/// ln T / 2 per parameter, far above this times T).
const TOL_PER_SAMPLE: f64 = 1e-5;

/// One level of a telegraph fit.
#[derive(Clone, Debug, PartialEq)]
pub struct Level {
    /// Mean relative to the series' mean (adu).
    pub mean: f64,
    /// Standard error of the mean (adu).
    pub mean_se: f64,
    /// Fraction of frames in the level.
    pub occupancy: f64,
    /// Standard error of the occupancy.
    pub occupancy_se: f64,
    /// Gaussian standard deviation around the level (adu).
    pub width: f64,
    /// Mean run length in the level (frames).
    pub dwell_frames: f64,
    /// Standard error of the mean run length (frames).
    pub dwell_se_frames: f64,
}

/// How a telegraph fit came out.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum FitStatus {
    /// Two or three levels beat one Gaussian (BIC) and every level was left at least
    /// [`MIN_RUNS`] times: usable.
    Ok,
    /// One Gaussian fits as well (BIC), a level was seldom left, or the fit did not converge:
    /// shown, not to be used.
    Imprecise,
}

impl FitStatus {
    /// The status word of tables (`ok`, `imprecise`).
    pub fn label(self) -> &'static str {
        match self {
            FitStatus::Ok => "ok",
            FitStatus::Imprecise => "imprecise",
        }
    }
}

/// The telegraph fit of one time series.
#[derive(Clone, Debug, PartialEq)]
pub struct TelegraphFit {
    /// Levels, ascending (two or three).
    pub levels: Vec<Level>,
    /// BIC of one Gaussian and of the two- and three-level chains.
    pub bic: [f64; 3],
    /// Whether the fit can be used.
    pub status: FitStatus,
}

/// A fitted hidden Markov chain of K levels.
#[derive(Clone, Debug)]
struct Chain {
    mean: Vec<f64>,
    var: Vec<f64>,
    /// Transition probabilities, row-major K x K (from row to column).
    a: Vec<f64>,
    /// Expected frames in each level.
    time: Vec<f64>,
    /// Expected transitions out of each level.
    exits: Vec<f64>,
    log_l: f64,
    converged: bool,
}

/// Fit `y` (one pixel's samples over frames, adu) with two and three levels and keep the one
/// BIC prefers; None with fewer than 8 samples or no spread.
pub fn fit_telegraph(y: &[f64]) -> Option<TelegraphFit> {
    let t = y.len();
    if t < 8 {
        return None;
    }
    let mean = y.iter().sum::<f64>() / t as f64;
    let y: Vec<f64> = y.iter().map(|v| v - mean).collect();
    let var = y.iter().map(|v| v * v).sum::<f64>() / t as f64;
    if !(var > 0.0 && var.is_finite()) {
        return None;
    }
    let ln_t = (t as f64).ln();
    let one = -0.5 * t as f64 * ((2.0 * std::f64::consts::PI * var).ln() + 1.0);
    let two = baum_welch::<2>(&y, var);
    let three = baum_welch::<3>(&y, var);
    let bic = [
        -2.0 * one + 2.0 * ln_t,
        -2.0 * two.log_l + 6.0 * ln_t,
        -2.0 * three.log_l + 12.0 * ln_t,
    ];
    let (chain, k) = if bic[2] < bic[1] {
        (three, 3)
    } else {
        (two, 2)
    };
    let levels = levels_of(&chain, t);
    let ok = bic[k - 1] < bic[0]
        && chain.converged
        && chain.exits.iter().all(|e| *e >= MIN_RUNS)
        && levels.iter().all(|l| l.occupancy_se.is_finite());
    Some(TelegraphFit {
        levels,
        bic,
        status: if ok {
            FitStatus::Ok
        } else {
            FitStatus::Imprecise
        },
    })
}

/// The levels of a fitted chain over `t` frames, ascending, with standard errors.
fn levels_of(c: &Chain, t: usize) -> Vec<Level> {
    let k = c.mean.len();
    let pi = stationary(&c.a, k);
    let z = fundamental(&c.a, &pi, k);
    let mut levels: Vec<Level> = (0..k)
        .map(|i| {
            let sd = c.var[i].sqrt();
            let occ_var = pi[i] * (1.0 - pi[i]) + 2.0 * pi[i] * (z[i * k + i] - 1.0);
            let dwell = 1.0 / (1.0 - c.a[i * k + i]).max(f64::MIN_POSITIVE);
            Level {
                mean: c.mean[i],
                mean_se: sd / c.time[i].max(1.0).sqrt(),
                occupancy: c.time[i] / t as f64,
                occupancy_se: (occ_var.max(0.0) / t as f64).sqrt(),
                width: sd,
                dwell_frames: dwell,
                dwell_se_frames: dwell
                    * ((1.0 - 1.0 / dwell).max(0.0) / c.exits[i].max(1.0)).sqrt(),
            }
        })
        .collect();
    levels.sort_by(|a, b| a.mean.total_cmp(&b.mean));
    levels
}

/// Baum-Welch fit of `K` levels to `y` (mean 0, variance `var`), from k-means levels (`K`
/// a constant, so that the loops over levels unroll).
fn baum_welch<const K: usize>(y: &[f64], var: f64) -> Chain {
    let k = K;
    let t = y.len();
    let floor = (1e-6 * var).max(1e-12);
    let (mean, v) = kmeans(y, k, floor);
    let mut a = vec![0.0; k * k];
    for i in 0..k {
        for j in 0..k {
            a[i * k + j] = if i == j { 0.9 } else { 0.1 / (k - 1) as f64 };
        }
    }
    let mut model = Model {
        mean,
        var: v,
        a,
        start: vec![1.0 / k as f64; k],
    };
    let mut post = Posteriors::new(t, k);
    let mut prev = f64::NEG_INFINITY;
    let mut chain = None;
    for _ in 0..MAX_ITERS {
        let log_l = post.e_step::<K>(y, &model);
        let e = Expectations::of::<K>(y, &model.a, &post);
        let exits: Vec<f64> = (0..k).map(|i| e.from[i] - e.trans[i * k + i]).collect();
        model.m_step::<K>(y, &post, &e, floor);
        let converged = (log_l - prev).abs() < TOL_PER_SAMPLE * t as f64;
        chain = Some(Chain {
            mean: model.mean.clone(),
            var: model.var.clone(),
            a: model.a.clone(),
            time: e.time,
            exits,
            log_l,
            converged,
        });
        if converged {
            break;
        }
        prev = log_l;
    }
    chain.expect("at least one iteration")
}

/// The parameters Baum-Welch updates: the levels' means and variances, the transition
/// probabilities (row-major K x K, from row to column) and the start probabilities.
struct Model {
    mean: Vec<f64>,
    var: Vec<f64>,
    a: Vec<f64>,
    start: Vec<f64>,
}

/// The E step's arrays over the frames (row-major, frame by level): emission densities
/// (each frame's scaled by its largest), scaled forward and backward probabilities, and the
/// forward scales.
struct Posteriors {
    b: Vec<f64>,
    alpha: Vec<f64>,
    beta: Vec<f64>,
    scale: Vec<f64>,
}

impl Posteriors {
    fn new(t: usize, k: usize) -> Self {
        Posteriors {
            b: vec![0.0; t * k],
            alpha: vec![0.0; t * k],
            beta: vec![0.0; t * k],
            scale: vec![0.0; t],
        }
    }

    /// Emission densities, forward and backward passes of `y` under `m`; returns ln L.
    fn e_step<const K: usize>(&mut self, y: &[f64], m: &Model) -> f64 {
        let mut log_l = self.emissions::<K>(y, m);
        self.forward::<K>(m, &mut log_l);
        self.backward::<K>(&m.a);
        log_l
    }

    /// The emission densities of every frame, each scaled by its largest; returns the sum
    /// of the scales' logarithms.
    fn emissions<const K: usize>(&mut self, y: &[f64], m: &Model) -> f64 {
        let k = K;
        let mut log_l = 0.0;
        let norm: Vec<f64> = m
            .var
            .iter()
            .map(|v| -0.5 * (2.0 * std::f64::consts::PI * v).ln())
            .collect();
        let half_inv: Vec<f64> = m.var.iter().map(|v| -0.5 / v).collect();
        for (s, ys) in y.iter().enumerate() {
            let row = &mut self.b[s * k..(s + 1) * k];
            let mut top = f64::NEG_INFINITY;
            for i in 0..k {
                let d = ys - m.mean[i];
                row[i] = d * d * half_inv[i] + norm[i];
                top = top.max(row[i]);
            }
            row.iter_mut().for_each(|x| *x = (*x - top).exp());
            log_l += top;
        }
        log_l
    }

    /// The scaled forward pass; adds the ln of the scales to `log_l`.
    fn forward<const K: usize>(&mut self, m: &Model, log_l: &mut f64) {
        let k = K;
        let (alpha, b, a) = (&mut self.alpha, &self.b, &m.a);
        // ln L adds ln of the scales; their product is taken 16 at a time (each scale is in
        // (0, k], the largest emission being 1) to save logarithms.
        let mut product = 1.0;
        for s in 0..self.scale.len() {
            let mut c = 0.0;
            for j in 0..k {
                let p = if s == 0 {
                    m.start[j]
                } else {
                    (0..k).map(|i| alpha[(s - 1) * k + i] * a[i * k + j]).sum()
                };
                alpha[s * k + j] = p * b[s * k + j];
                c += alpha[s * k + j];
            }
            let c = c.max(f64::MIN_POSITIVE);
            self.scale[s] = c;
            product *= c;
            if s % 16 == 15 || product < 1e-250 {
                *log_l += product.ln();
                product = 1.0;
            }
            let inv = 1.0 / c;
            alpha[s * k..(s + 1) * k].iter_mut().for_each(|x| *x *= inv);
        }
        *log_l += product.ln();
    }

    /// The scaled backward pass through the transitions `a`.
    fn backward<const K: usize>(&mut self, a: &[f64]) {
        let k = K;
        let t = self.scale.len();
        let (beta, b) = (&mut self.beta, &self.b);
        beta[(t - 1) * k..].fill(1.0);
        for s in (0..t - 1).rev() {
            for i in 0..k {
                let v: f64 = (0..k)
                    .map(|j| a[i * k + j] * b[(s + 1) * k + j] * beta[(s + 1) * k + j])
                    .sum();
                beta[s * k + i] = v / self.scale[s + 1];
            }
        }
    }

    /// The posterior weight of level `i` in frame `s` (unnormalised: alpha x beta).
    fn weight(&self, s: usize, i: usize, k: usize) -> f64 {
        self.alpha[s * k + i] * self.beta[s * k + i]
    }
}

/// What the E step expects of the hidden levels: frames in each level, frames in it with a
/// successor, transitions between levels (row-major, from row to column), and the sum of
/// the samples in each.
struct Expectations {
    time: Vec<f64>,
    from: Vec<f64>,
    trans: Vec<f64>,
    s1: Vec<f64>,
}

impl Expectations {
    fn of<const K: usize>(y: &[f64], a: &[f64], p: &Posteriors) -> Self {
        let k = K;
        let t = y.len();
        let (alpha, beta, b, scale) = (&p.alpha, &p.beta, &p.b, &p.scale);
        let mut e = Expectations {
            time: vec![0.0; k],
            from: vec![0.0; k],
            trans: vec![0.0; k * k],
            s1: vec![0.0; k],
        };
        for s in 0..t {
            for i in 0..k {
                let g = p.weight(s, i, k);
                e.time[i] += g;
                e.s1[i] += g * y[s];
                if s + 1 < t {
                    e.from[i] += g;
                    for j in 0..k {
                        e.trans[i * k + j] += alpha[s * k + i]
                            * a[i * k + j]
                            * b[(s + 1) * k + j]
                            * beta[(s + 1) * k + j]
                            / scale[s + 1];
                    }
                }
            }
        }
        e
    }
}

impl Model {
    /// The M step: the levels, widths (at least `floor`) and transitions the expectations
    /// `e` imply.
    fn m_step<const K: usize>(&mut self, y: &[f64], p: &Posteriors, e: &Expectations, floor: f64) {
        let k = K;
        let t = y.len();
        for i in 0..k {
            self.mean[i] = e.s1[i] / e.time[i].max(f64::MIN_POSITIVE);
        }
        let mut s2 = vec![0.0; k];
        for (s, ys) in y.iter().enumerate() {
            for (i, s2) in s2.iter_mut().enumerate() {
                let d = ys - self.mean[i];
                *s2 += p.weight(s, i, k) * d * d;
            }
        }
        for (i, s2) in s2.iter().enumerate() {
            self.var[i] = (s2 / e.time[i].max(f64::MIN_POSITIVE)).max(floor);
            let f = e.from[i].max(f64::MIN_POSITIVE);
            for j in 0..k {
                self.a[i * k + j] = e.trans[i * k + j] / f;
            }
            self.start[i] = e.time[i] / t as f64;
        }
    }
}

/// One-dimensional k-means of `y` into `k` groups from its quantiles: their means and
/// variances (at least `floor`).
fn kmeans(y: &[f64], k: usize, floor: f64) -> (Vec<f64>, Vec<f64>) {
    let mut sorted = y.to_vec();
    sorted.sort_by(f64::total_cmp);
    let t = sorted.len();
    let mut mean: Vec<f64> = (0..k)
        .map(|i| sorted[((2 * i + 1) * t / (2 * k)).min(t - 1)])
        .collect();
    let mut var = vec![floor; k];
    for _ in 0..50 {
        let (mut n, mut s1, mut s2) = (vec![0.0; k], vec![0.0; k], vec![0.0; k]);
        for x in &sorted {
            let i = (0..k)
                .min_by(|a, b| (x - mean[*a]).abs().total_cmp(&(x - mean[*b]).abs()))
                .expect("k > 0");
            n[i] += 1.0;
            s1[i] += x;
            s2[i] += x * x;
        }
        let old = mean.clone();
        for i in 0..k {
            if n[i] > 0.0 {
                mean[i] = s1[i] / n[i];
                var[i] = (s2[i] / n[i] - mean[i] * mean[i]).max(floor);
            }
        }
        if old == mean {
            break;
        }
    }
    (mean, var)
}

/// Stationary distribution of the K x K transition matrix `a` (pi A = pi, sum 1).
fn stationary(a: &[f64], k: usize) -> Vec<f64> {
    // (A^T - I) pi = 0 with its last equation replaced by sum pi = 1.
    let mut m = vec![0.0; k * k];
    for i in 0..k {
        for j in 0..k {
            m[i * k + j] = if i + 1 == k {
                1.0
            } else {
                a[j * k + i] - if i == j { 1.0 } else { 0.0 }
            };
        }
    }
    let mut rhs = vec![0.0; k];
    rhs[k - 1] = 1.0;
    solve(&mut m, &mut rhs, k);
    rhs
}

/// Fundamental matrix Z = (I - A + 1 pi)^-1 of a chain with transitions `a` and stationary
/// distribution `pi`, row-major.
fn fundamental(a: &[f64], pi: &[f64], k: usize) -> Vec<f64> {
    let mut z = vec![0.0; k * k];
    for col in 0..k {
        let mut m: Vec<f64> = (0..k * k)
            .map(|idx| {
                let (i, j) = (idx / k, idx % k);
                (i == j) as u8 as f64 - a[idx] + pi[j]
            })
            .collect();
        let mut e = vec![0.0; k];
        e[col] = 1.0;
        solve(&mut m, &mut e, k);
        for i in 0..k {
            z[i * k + col] = e[i];
        }
    }
    z
}

/// Solve m x = b in place (b becomes x) by Gaussian elimination with partial pivoting; a
/// singular system leaves NaN.
fn solve(m: &mut [f64], b: &mut [f64], k: usize) {
    for c in 0..k {
        let p = (c..k)
            .max_by(|x, y| m[x * k + c].abs().total_cmp(&m[y * k + c].abs()))
            .expect("a row");
        if m[p * k + c] == 0.0 {
            b.fill(f64::NAN);
            return;
        }
        for j in 0..k {
            m.swap(c * k + j, p * k + j);
        }
        b.swap(c, p);
        for r in c + 1..k {
            let f = m[r * k + c] / m[c * k + c];
            for j in c..k {
                m[r * k + j] -= f * m[c * k + j];
            }
            b[r] -= f * b[c];
        }
    }
    for c in (0..k).rev() {
        let s: f64 = (c + 1..k).map(|j| m[c * k + j] * b[j]).sum();
        b[c] = (b[c] - s) / m[c * k + c];
    }
}

#[cfg(test)]
mod tests;
