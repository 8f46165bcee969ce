//! `emccd-simple` (paper section 2.2): the EM register's excess noise as a reduced QE, by
//! default halved (`emccd-simple:Q` for another factor q).

use rand_distr::{Binomial, Distribution};

use super::readout::{FrameInput, Readout};
use super::spec::{ModelEntry, ModelSpec, Sensor};
use crate::rng::SimRng;
use crate::stats::binomial_half;
use crate::{Error, Result};

/// The registry entry of `emccd-simple[:QE_FACTOR]`.
pub const ENTRY: ModelEntry = ModelEntry {
    name: "emccd-simple",
    arg: Some("QE_FACTOR"),
    help: "EMCCD as QE_FACTOR (0.5) x the flux, Poisson, + read noise / gain (0.1 e-): the \
           paper's simple model",
    sensor: Sensor::Emccd,
    params: &["em_gain", "emccd_read_noise_e"],
    parse: |_, arg| match arg {
        None => Ok(ModelSpec::EmccdSimple(None)),
        Some(a) => match a.parse::<f64>() {
            Ok(q) if EmccdSimple::valid_factor(q) => Ok(ModelSpec::EmccdSimple(Some(q))),
            _ => Err("the QE factor must be a number in (0, 1]".into()),
        },
    },
    build: |spec, p, _| {
        let ModelSpec::EmccdSimple(q) = spec else {
            unreachable!("emccd-simple builds only its own spec")
        };
        Ok(Box::new(EmccdSimple::new(
            q.unwrap_or(EmccdSimple::PAPER_FACTOR),
            EmccdSimple::read_noise_of(p.em_gain, p.emccd_read_noise_e)?,
        )?))
    },
};

/// Photo-electrons above which `emccd-simple` thins the count with one Binomial(k, q) draw
/// (constant cost) instead of counting random bits (cost about 2 k/64 draws); both are exact.
const BINOMIAL_ABOVE_E: u32 = 1 << 16;

/// `emccd-simple`: the excess noise as a reduced QE (Poisson of q x the flux; the paper's q is
/// 1/2), plus Normal(0, sigma_r / g) read noise. The flux is reduced by binomial thinning of
/// the shared photon draws, which is exactly Poisson(q lambda) and keeps common random numbers.
#[derive(Debug, Clone)]
pub struct EmccdSimple {
    qe_factor: f64,
    read_noise_e: f64,
}

impl EmccdSimple {
    /// The paper's QE factor: the excess noise factor F^2 = 2 of a high-gain register halves
    /// the effective QE.
    pub const PAPER_FACTOR: f64 = 0.5;

    /// The paper's version: q = 1/2, read noise 0.1 e- (50 e- / gain 500).
    pub fn paper() -> Self {
        EmccdSimple {
            qe_factor: Self::PAPER_FACTOR,
            read_noise_e: 0.1,
        }
    }

    /// QE factor q in (0, 1] and read noise referred to the input (e- rms, >= 0).
    pub fn new(qe_factor: f64, read_noise_e: f64) -> Result<Self> {
        if !Self::valid_factor(qe_factor) {
            return Err(Error::invalid(
                "model",
                format!("emccd-simple: QE factor {qe_factor} must be in (0, 1]"),
            ));
        }
        if !(read_noise_e.is_finite() && read_noise_e >= 0.0) {
            return Err(Error::invalid(
                "emccd_read_noise_e",
                format!("emccd-simple: read noise {read_noise_e} must be >= 0 e-"),
            ));
        }
        Ok(EmccdSimple {
            qe_factor,
            read_noise_e,
        })
    }

    /// The simple model's read noise (e-, referred to the input) of a camera with EM gain
    /// `em_gain` (e-/e-) and read noise `read_noise_output_e` (output e- rms): their ratio
    /// (50 / 500 = 0.1 e- exactly, as the paper's).
    pub fn read_noise_of(em_gain: f64, read_noise_output_e: f64) -> Result<f64> {
        if !(em_gain.is_finite() && em_gain > 0.0) {
            return Err(Error::invalid(
                "em_gain",
                format!("{em_gain}: EM gain must be > 0 e-/e-"),
            ));
        }
        Ok(read_noise_output_e / em_gain)
    }

    /// Whether `q` is a QE factor the model takes: in (0, 1].
    pub fn valid_factor(q: f64) -> bool {
        q > 0.0 && q <= 1.0
    }

    /// The QE factor q.
    pub fn qe_factor(&self) -> f64 {
        self.qe_factor
    }

    /// Photo-electrons of `k` kept with probability q each: Binomial(k, q), drawn bit by bit
    /// of q's binary expansion. A uniform u per electron is compared with q one binary digit at
    /// a time; at digit j the electrons still undecided each draw one random bit: where q's
    /// digit is 1 those drawing a 1 are kept, where it is 0 those drawing a 0 are dropped, the
    /// rest stay undecided. The count drawing a 1 among n is `binomial_half(n)`, so q = 1/2
    /// (one digit) draws exactly what `binomial_half(k)` does, and every q shares the first
    /// digit's draws (common random numbers across factors).
    #[inline(always)]
    fn thin(&self, k: u32, aux: &mut SimRng) -> u32 {
        if k == 0 || self.qe_factor == 1.0 {
            return k;
        }
        if k > BINOMIAL_ABOVE_E {
            return Binomial::new(k as u64, self.qe_factor)
                .expect("q in (0, 1) is a probability")
                .sample(aux) as u32;
        }
        let (mut kept, mut undecided, mut rest) = (0, k, self.qe_factor);
        // Doubling and subtracting 1 are exact: `rest` runs through q's binary digits and
        // reaches 0 after the last one (at most 1074 digits; `undecided` halves per digit).
        while undecided > 0 && rest > 0.0 {
            rest *= 2.0;
            let ones = binomial_half(undecided, aux);
            if rest >= 1.0 {
                rest -= 1.0;
                kept += ones;
                undecided -= ones;
            } else {
                undecided = ones;
            }
        }
        kept
    }

    /// [`Readout::read`] compiled with POPCNT: the thinning counts a draw's bits once per
    /// binary digit of q, which the baseline x86-64 target does in a dozen instructions. The
    /// same draws and counts.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "popcnt")]
    unsafe fn read_popcnt(&self, input: &FrameInput, aux: &mut SimRng, out: &mut [f64]) {
        self.read_inline(input, aux, out)
    }

    #[inline(always)]
    fn read_inline(&self, input: &FrameInput, aux: &mut SimRng, out: &mut [f64]) {
        for ((o, &k), &z) in out.iter_mut().zip(input.photo_e).zip(input.normals) {
            *o = self.thin(k, aux) as f64 + self.read_noise_e * z;
        }
    }
}

impl Readout for EmccdSimple {
    fn name(&self) -> String {
        if self.qe_factor == Self::PAPER_FACTOR {
            "emccd-simple".into()
        } else {
            format!("emccd-simple:{}", self.qe_factor)
        }
    }

    fn read(&self, input: &FrameInput, aux: &mut SimRng, out: &mut [f64]) {
        #[cfg(target_arch = "x86_64")]
        if std::arch::is_x86_feature_detected!("popcnt") {
            // SAFETY: the CPU has POPCNT (checked just above).
            return unsafe { self.read_popcnt(input, aux, out) };
        }
        self.read_inline(input, aux, out)
    }

    fn noise_scale_e(&self) -> f64 {
        self.read_noise_e
    }

    fn photon_variance_factor(&self) -> f64 {
        // Poisson of q x the flux: variance q per expected photo-electron.
        self.qe_factor
    }
}

#[cfg(test)]
mod tests;
