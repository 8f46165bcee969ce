//! The EMCCD histogram model: exact bin probabilities from the characteristic function
//! (one FFT per evaluation), the excess noise factor of the single-electron law, and the
//! model curve of a fit for its chart.

use std::sync::Arc;

use rustfft::{num_complex::Complex64, Fft, FftPlanner};

use super::histogram::ValueHistogram;
use super::mixture::LambdaMixture;
use super::options::EmShape;
use super::result::EmGainFit;

/// Largest FFT used for the model (2^18 points: an 8-fold margin over the grids of real
/// EMCCD histograms, 4096 to 32768 cells).
pub(super) const MAX_FFT: usize = 1 << 18;

/// The exact bin probabilities of the model on a fine periodic grid.
pub(super) struct Model {
    pub(super) shape: EmShape,
    /// Conversion gain (e-/adu), 1 when not known.
    pub(super) conv: f64,
    /// Whether the conversion gain is known (else the Gamma law's F^2 is taken at
    /// [`law_gain`]).
    pub(super) conv_known: bool,
    /// Lower edge of the grid (adu).
    pub(super) x0: f64,
    /// Fine cell width (adu).
    pub(super) h: f64,
    pub(super) fft: Arc<dyn Fft<f64>>,
    pub(super) m: usize,
    /// The pixels' spread of mean charge (None: one lambda for all).
    pub(super) mix: Option<LambdaMixture>,
}

impl Model {
    /// Fine cell probabilities for (b, s, G, lambda) and a rate `cic` of serial CIC
    /// electrons (born at a uniformly random stage), or `None` outside the domain.
    pub(super) fn cells(&self, b: f64, s: f64, g: f64, lambda: f64, cic: f64) -> Option<Vec<f64>> {
        let m = self.m;
        let period = m as f64 * self.h;
        let dt = 2.0 * std::f64::consts::PI / period;
        // Frequencies beyond 9/s carry < e^-40 of the Gaussian factor: left at zero.
        let kmax = ((9.0 / s) / dt).ceil() as usize;
        let kmax = kmax.min(m / 2 - 1);
        let laws = self.laws(g, kmax + 1, dt, cic != 0.0)?;
        let mut a = vec![Complex64::new(0.0, 0.0); m];
        for k in 0..=kmax {
            let t = dt * k as f64;
            let x = t * (self.h * 0.5);
            let sinc = if x == 0.0 { 1.0 } else { x.sin() / x };
            let mut log_phi =
                Complex64::new(-0.5 * s * s * t * t, t * (b - self.x0 - 0.5 * self.h));
            let light = lambda * (laws.one[k] - 1.0);
            if self.mix.is_none() {
                log_phi += light;
            }
            if let Some(serial) = &laws.serial {
                log_phi += cic * (serial[k] - 1.0);
            }
            let mut v = log_phi.exp() * sinc;
            if let Some(mix) = &self.mix {
                v *= mix
                    .weights
                    .iter()
                    .zip(&mix.relative)
                    .map(|(w, r)| w * (light * r).exp())
                    .sum::<Complex64>();
            }
            a[k] = v;
            if k > 0 {
                a[m - k] = v.conj();
            }
        }
        self.fft.process(&mut a);
        Some(a.iter().map(|v| v.re / m as f64).collect())
    }

    /// Characteristic functions at t = k dt, k < `n`, of the register output (adu) for one
    /// input electron and, if `serial`, for one electron born at a uniformly random stage
    /// (which passes the stages after it: N - 1 down to 0); `None` for a register gain
    /// below 1.
    fn laws(&self, g: f64, n: usize, dt: f64, serial: bool) -> Option<Laws> {
        match self.shape {
            EmShape::Gamma => Some(Laws {
                one: (0..n)
                    .map(|k| 1.0 / Complex64::new(1.0, -dt * k as f64 * g))
                    .collect(),
                serial: serial.then(|| vec![Complex64::new(1.0, 0.0); n]),
            }),
            EmShape::RegisterGamma { stages } => {
                let ge = law_gain(g, self.conv_known.then_some(self.conv));
                (ge >= 1.0).then(|| register_gamma_laws(g, ge, stages, n, dt, serial))
            }
            EmShape::Register { stages } => {
                let ge = g * self.conv;
                (ge >= 1.0).then(|| register_laws(ge, self.conv, stages, n, dt, serial))
            }
        }
    }
}

/// Characteristic functions of the single-electron laws on the model's frequencies.
struct Laws {
    /// One input electron through the whole register.
    one: Vec<Complex64>,
    /// One serial-CIC electron (uniform birth stage), when asked for.
    serial: Option<Vec<Complex64>>,
}

/// The exact register of `stages` stages at gain `ge` (e-/e-), conversion `conv` (e-/adu):
/// the pgf iterated once per stage on e^{i t / conv}, all frequencies at a time (the inner
/// loop over frequencies on split real and imaginary parts vectorises), with the running
/// sum of the iterates for the serial-CIC electron.
fn register_laws(ge: f64, conv: f64, stages: u32, n: usize, dt: f64, serial: bool) -> Laws {
    let p = ge.powf(1.0 / f64::from(stages)) - 1.0;
    let (mut vr, mut vi): (Vec<f64>, Vec<f64>) = (0..n)
        .map(|k| {
            let x = dt * k as f64 / conv;
            (x.cos(), x.sin())
        })
        .unzip();
    let (mut sr, mut si) = (vec![0.0; n], vec![0.0; n]);
    for _ in 0..stages {
        if serial {
            sr.iter_mut().zip(&vr).for_each(|(s, v)| *s += v);
            si.iter_mut().zip(&vi).for_each(|(s, v)| *s += v);
        }
        for (r, i) in vr.iter_mut().zip(vi.iter_mut()) {
            // v <- v ((1 - p) + p v)
            let (ar, ai) = (1.0 - p + p * *r, p * *i);
            let nr = *r * ar - *i * ai;
            *i = *r * ai + *i * ar;
            *r = nr;
        }
    }
    let nst = f64::from(stages);
    Laws {
        one: vr
            .iter()
            .zip(&vi)
            .map(|(r, i)| Complex64::new(*r, *i))
            .collect(),
        serial: serial.then(|| {
            sr.iter()
                .zip(&si)
                .map(|(r, i)| Complex64::new(r / nst, i / nst))
                .collect()
        }),
    }
}

/// Nodes of the average over birth stages of a serial-CIC electron in the Gamma law (the
/// law varies smoothly with the stages passed; the midpoint rule on 32 groups of stages).
const SERIAL_NODES: u32 = 32;

/// The Gamma law with the register's F^2: one input electron passes all `stages`, a serial
/// CIC electron a uniform number of them (N - 1 down to 0), each a Gamma law of the partial
/// register's mean and F^2; `g` is the whole register's mean (adu), `ge` its gain (e-/e-)
/// that sets the per-stage probability and F^2.
fn register_gamma_laws(g: f64, ge: f64, stages: u32, n: usize, dt: f64, serial: bool) -> Laws {
    let p = ge.powf(1.0 / f64::from(stages)) - 1.0;
    let one = (0..n).map(|k| gamma_cf(dt * k as f64, g, ge, p)).collect();
    let serial = serial.then(|| {
        let groups = SERIAL_NODES.min(stages);
        let width = f64::from(stages) / f64::from(groups);
        let gains: Vec<f64> = (0..groups)
            .map(|j| (1.0 + p).powf((f64::from(j) + 0.5) * width - 0.5))
            .collect();
        (0..n)
            .map(|k| {
                let t = dt * k as f64;
                gains
                    .iter()
                    .map(|gm| gamma_cf(t, g * gm / ge, *gm, p))
                    .sum::<Complex64>()
                    / f64::from(groups)
            })
            .collect()
    });
    Laws { one, serial }
}

/// Characteristic function at `t` (1/adu) of a Gamma law of mean `mean` (adu) with the F^2
/// of a register of per-stage probability `p` and gain `gm` (e-/e-):
/// F^2 - 1 = (1 - p)(gm - 1) / (gm (1 + p)), shape k = 1 / (F^2 - 1), so
/// phi = (1 - i t mean / k)^(-k); a single unmultiplied electron (F^2 = 1) is e^{i t mean}.
fn gamma_cf(t: f64, mean: f64, gm: f64, p: f64) -> Complex64 {
    let f2m1 = (1.0 - p) * (gm - 1.0) / (gm * (1.0 + p));
    if f2m1 < 1e-9 {
        return Complex64::new(0.0, t * mean).exp();
    }
    let k = 1.0 / f2m1;
    (-k * Complex64::new(1.0, -t * mean / k).ln()).exp()
}

/// Lowest register gain (e-/e-) at which the Gamma law takes the register's F^2 when the
/// conversion gain is not known: F^2 varies by < 0.3 % over gains 100 to 5000 (604 stages),
/// and a gain in adu/e- is below the gain in e-/e- wherever a count is more than an electron.
pub const UNKNOWN_CONVERSION_MIN_GAIN: f64 = 100.0;

/// The register gain (e-/e-) a law takes its F^2 at, for gain `g` (adu per input e-): g
/// times the conversion gain (e-/adu), or without it g read as e-/e- but at least
/// [`UNKNOWN_CONVERSION_MIN_GAIN`].
pub fn law_gain(g: f64, conv: Option<f64>) -> f64 {
    match conv {
        Some(c) => g * c,
        None => g.max(UNKNOWN_CONVERSION_MIN_GAIN),
    }
}

/// Excess noise factor squared of the single-electron law at gain `g_e` (e-/e-).
///
/// For the register (and the Gamma law with its F^2) this is
/// [`crate::detector::register::excess_noise_factor_sq`], the formula, not a tabulated
/// register: the fit needs the factor at every trial gain (a gain below 1 has p = 0 and
/// F^2 = 1).
pub fn excess_noise_factor_sq(shape: EmShape, g_e: f64) -> f64 {
    match shape {
        EmShape::Gamma => 2.0,
        EmShape::Register { stages } | EmShape::RegisterGamma { stages } => {
            crate::detector::register::excess_noise_factor_sq(g_e, stages)
        }
    }
}

/// One bin of the chart of a fit: data and model counts (pixel-samples).
#[derive(Debug, Clone, Copy)]
pub struct CurveBin {
    /// Bin centre (adu).
    pub x_adu: f64,
    /// Bin width (adu): whole histogram bins merged, fewer in the last bin.
    pub width_adu: f64,
    /// Observed pixel-samples.
    pub data: f64,
    /// Expected pixel-samples of the fitted model.
    pub model: f64,
    /// Expected pixel-samples with no input electron (bias + read noise only).
    pub zero_electron: f64,
}

/// The data and the fitted model on at most `max_bins` bins (whole histogram bins merged)
/// up to the fit's upper limit, with the zero-electron component.
pub fn model_curve(h: &ValueHistogram, fit: &EmGainFit, max_bins: usize) -> Vec<CurveBin> {
    let (b, s, g, l) = (
        fit.bias_adu,
        fit.read_noise_adu,
        fit.gain_adu_per_e,
        fit.lambda_e,
    );
    let w = h.width();
    // From 10 read noises below the bias (lower values are far outliers) to the cut.
    let first = h
        .counts()
        .iter()
        .enumerate()
        .position(|(i, _)| h.centre(i) >= b - 10.0 * s)
        .unwrap_or(0);
    let counts = &h.counts()[first..];
    let used = (0..counts.len())
        .take_while(|i| h.centre(first + i) <= fit.max_value_adu)
        .count()
        .max(1)
        .min(counts.len());
    let group = used.div_ceil(max_bins.max(1));
    let lo = h.centre(first) - 0.5 * w;
    let per_bin = ((4.5 * w / s).ceil() as usize).clamp(1, 1024);
    let hfine = w / per_bin as f64;
    let span = used as f64 * w + (10.0 * s).max(100.0 * g);
    let m = ((span / hfine).ceil().min(MAX_FFT as f64) as usize)
        .max(2)
        .next_power_of_two();
    let model = Model {
        shape: fit.shape,
        conv: fit.gain_e_per_adu.unwrap_or(1.0),
        conv_known: fit.gain_e_per_adu.is_some(),
        x0: lo,
        h: hfine,
        fft: FftPlanner::new().plan_fft_forward(m),
        m,
        mix: fit.lambda_mixture.clone(),
    };
    let zeros = vec![0.0; m];
    let cic = fit.serial_cic_e.unwrap_or(0.0);
    let total = model
        .cells(b, s, g, l, cic)
        .unwrap_or_else(|| zeros.clone());
    // No input and no serial-CIC electron: the bias peak alone.
    let gauss = model.cells(b, s, g, 0.0, 0.0).unwrap_or(zeros);
    let n = fit.n_samples;
    // Probability of no input and no serial-CIC electron.
    let none = match &fit.lambda_mixture {
        None => (-l - cic).exp(),
        Some(mix) => mix.p_zero(l) * (-cic).exp(),
    };
    let sum = |v: &[f64], i0: usize, i1: usize| -> f64 {
        v.get(i0 * per_bin..(i1 * per_bin).min(v.len()))
            .map_or(0.0, |c| c.iter().sum())
    };
    (0..used)
        .step_by(group)
        .map(|i0| {
            let i1 = (i0 + group).min(used);
            CurveBin {
                x_adu: lo + 0.5 * (i0 + i1) as f64 * w,
                width_adu: (i1 - i0) as f64 * w,
                data: counts[i0..i1].iter().sum(),
                model: n * sum(&total, i0, i1),
                zero_electron: n * none * sum(&gauss, i0, i1),
            }
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::detector::EmRegister;

    #[test]
    fn register_excess_noise_is_the_registers_own() {
        for (gain, stages) in [(1.0, 1), (2.0, 1), (5.0, 512), (300.0, 520), (1000.0, 512)] {
            let reg = EmRegister::new(gain, stages).unwrap();
            let ours = excess_noise_factor_sq(EmShape::Register { stages }, gain);
            let theirs = reg.excess_noise_factor_sq();
            assert!(
                (ours / theirs - 1.0).abs() < 1e-12,
                "{gain} {stages}: {ours} {theirs}"
            );
        }
        // (1 + p)^N = g gives F^2 = 1 + (1 - p)(g - 1) / (g (1 + p)): 2 - O(p) at high gain,
        // the Gamma model's 2 in the limit of many stages.
        let (g, n) = (5000.0f64, 2000u32);
        let p = g.powf(1.0 / n as f64) - 1.0;
        let f2 = excess_noise_factor_sq(EmShape::Register { stages: n }, g);
        assert!(
            (f2 - (1.0 + (1.0 - p) * (g - 1.0) / (g * (1.0 + p)))).abs() < 1e-9,
            "{f2}"
        );
        assert!((f2 - 2.0).abs() < 0.01);
        assert_eq!(
            excess_noise_factor_sq(EmShape::Register { stages: 10 }, 0.5),
            1.0
        );
        assert_eq!(excess_noise_factor_sq(EmShape::Gamma, 300.0), 2.0);
    }
}
