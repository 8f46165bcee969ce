//! One EM-gain fit's problem: the data binned on the model's grid (`Layout`) and the binned
//! likelihood of the natural parameters in internal coordinates (`Problem`).

use super::histogram::ValueHistogram;
use super::mixture::LambdaMixture;
use super::model::{Model, MAX_FFT};
use super::options::EmShape;
use crate::error::{Error, Result};
use crate::fit::optim::INVALID_COST;
use rustfft::FftPlanner;

/// The binned data and the model grid of one fit.
pub(super) struct Problem {
    pub(super) model: Model,
    /// Fine cells per data bin.
    per_bin: usize,
    /// Data counts per fitted bin, starting at fine cell 0.
    counts: Vec<f64>,
    /// Samples in the fitted range.
    pub(super) n: f64,
    /// Samples outside the fitted range.
    pub(super) excluded: f64,
    /// The bias coordinate is (b - bias0) / s0: the start's bias and read noise (adu).
    bias0: f64,
    pub(super) s0: f64,
    guard_gain: f64,
    /// The serial-CIC coordinate is the rate over this scale (e- per pixel-sample): linear,
    /// so that a rate of 0 is an ordinary point (no drift towards -inf when there is none).
    pub(super) cic_scale: f64,
    /// Internal coordinates of the parameters that are not free.
    pub(super) base: [f64; 5],
    /// Indices (into bias, ln s, ln G, ln lambda) of the free parameters.
    pub(super) free: Vec<usize>,
}

impl Problem {
    /// Natural parameters (b, s, G, lambda, serial CIC) from the free internal coordinates `u`.
    pub(super) fn params(&self, u: &[f64]) -> [f64; 5] {
        let mut v = self.base;
        for (k, i) in self.free.iter().enumerate() {
            v[*i] = u[k];
        }
        [
            self.bias0 + v[0] * self.s0,
            v[1].exp(),
            v[2].exp(),
            v[3].exp(),
            v[4] * self.cic_scale,
        ]
    }

    /// Internal coordinates of all natural parameters `p`.
    pub(super) fn internal(&self, p: &[f64; 5]) -> [f64; 5] {
        [
            (p[0] - self.bias0) / self.s0,
            p[1].ln(),
            p[2].ln(),
            p[3].ln(),
            p[4] / self.cic_scale,
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
    pub(super) fn nll(&self, u: &[f64]) -> f64 {
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

    /// Centre the internal coordinates on the start `best` (natural parameters) and free
    /// the parameters to fit: gain and lambda, bias and read noise unless `fixed`, and the
    /// serial CIC rate when `serial_cic`.
    pub(super) fn start_at(&mut self, best: &[f64; 5], fixed: bool, serial_cic: bool) {
        self.bias0 = best[0];
        self.s0 = best[1];
        let mut best = *best;
        if serial_cic {
            // Serial-CIC events are counted as light by a model without them: the scale is
            // a third of the start's light, the start half of that (the Nelder-Mead steps
            // of one scale find the rate, 0 included).
            self.cic_scale = (best[3] / 3.0).max(1e-4);
            if best[4] == 0.0 {
                best[4] = 0.5 * self.cic_scale;
            }
        }
        self.base = self.internal(&best);
        if fixed {
            self.free = vec![2, 3];
        }
        if serial_cic {
            self.free.push(4);
        }
    }
}

/// Binning of one fit: fitted bins of width `w` (a multiple of the histogram's) from `lo`
/// to `cut` (adu), fine model cells of `h`.
pub(super) struct Layout {
    pub(super) lo: f64,
    pub(super) cut: f64,
    pub(super) w: f64,
    per_bin: usize,
    hfine: f64,
}

impl Layout {
    /// Bins at most `s_min`/2 wide; fine cells at most `s_min`/4.5 so that the Gaussian
    /// factor vanishes at the grid's Nyquist frequency; from 10 `sq` below `q4`.
    pub(super) fn new(h: &ValueHistogram, s_min: f64, sq: f64, q4: f64, cut: f64) -> Self {
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

    /// The fit problem with a model period reaching `pad` adu beyond the cut; `conv` the
    /// conversion gain (e-/adu) if known, `mix` the pixels' spread of mean charge.
    pub(super) fn problem(
        &self,
        h: &ValueHistogram,
        shape: EmShape,
        conv: Option<f64>,
        mix: Option<&LambdaMixture>,
        pad: f64,
    ) -> Result<Problem> {
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
                conv: conv.unwrap_or(1.0),
                conv_known: conv.is_some(),
                x0: self.lo,
                h: self.hfine,
                fft: FftPlanner::new().plan_fft_forward(m),
                m,
                mix: mix.cloned(),
            },
            per_bin: self.per_bin,
            counts,
            n,
            excluded,
            bias0: 0.0,
            s0: 1.0,
            base: [0.0; 5],
            cic_scale: 1.0,
            free: vec![0, 1, 2, 3],
            guard_gain: (m as f64 * self.hfine - (self.cut - self.lo)) / 25.0,
        })
    }
}

/// Mean and variance (adu) of the fitted (not excluded) values, from their bins, with the
/// bin quantisation variance w^2/12 removed.
pub(super) fn fitted_moments(p: &Problem, lo: f64, w: f64) -> (f64, f64) {
    let (mut s, mut s2) = (0.0, 0.0);
    for (i, c) in p.counts.iter().enumerate() {
        let x = lo + (i as f64 + 0.5) * w;
        s += c * x;
        s2 += c * x * x;
    }
    let m = s / p.n;
    (m, s2 / p.n - m * m - w * w / 12.0)
}
