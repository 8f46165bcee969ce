//! EMCCD gain from the histogram of dark or low-light frames (SPEC 2.4, notes 6).
//!
//! Model of one pixel value x (adu): x = b + Z/c + N(0, s^2), with Z the EM register
//! output (e-) for Poisson(lambda) input electrons and c the conversion (e- per adu).
//! Fitted by binned maximum likelihood (multinomial, i.e. Poisson with the total fixed)
//! in (b, ln s, ln G, ln lambda), G = g/c the gain in adu per input electron.
//!
//! The bin probabilities are computed exactly from the characteristic function
//!   phi(t) = exp(i t b - s^2 t^2 / 2 + lambda (phi1(t) - 1))
//! (compound Poisson register output, Gaussian read noise), multiplied by the box of a
//! bin and inverted with one FFT. This is the numerical convolution of the Poisson-Gamma
//! (Bessel closed form) with the Gaussian, done in Fourier space where it is a product:
//! no series in n, no Bessel function, and any single-electron law phi1 fits in:
//! `Gamma` (paper Eq. 2: exponential of mean G, phi1 = 1/(1 - i t G)) or the exact
//! `Register` of N stages (pgf iterated N times on e^{i t / c}).
//!
//! Layout: `histogram` bins the values, `stack` fills it from a stack, `signature` checks in
//! seconds that frames show an EM register at all, `start` finds start values, `model`
//! computes the bin probabilities, `problem` bins the data on the model's grid and gives the
//! likelihood, `fit` maximises it, `chart` draws the result,
//! and `run` is the whole `emgain` command as one call. `mixture` describes pixels of
//! different mean charge pooled in one histogram (the light term a mixture of Poisson laws),
//! and `zero_peak` estimates the mean charge from the zero-electron peak alone.

mod chart;
mod fit;
mod histogram;
mod mixture;
mod model;
mod options;
mod problem;
mod result;
mod run;
mod signature;
mod stack;
mod start;
#[cfg(test)]
mod tests;
mod zero_peak;

pub use chart::chart;
pub use fit::{fit_emgain, fit_emgain_of_stack};
pub use histogram::ValueHistogram;
pub use mixture::{LambdaMixture, DEFAULT_MIXTURE_GROUPS};
pub use model::{
    excess_noise_factor_sq, law_gain, model_curve, CurveBin, UNKNOWN_CONVERSION_MIN_GAIN,
};
pub use options::{EmGainOptions, EmLaw, EmShape, SerialCic, DEFAULT_STAGES};
pub use result::{
    gain_from_mean_ratio, EmCrossChecks, EmGainFit, EmStart, SerialCicTest, ZeroPeak,
};
pub use run::{fit_report, run, EmgainReport, EmgainRun, EmgainRunResult, RatioCheck};
pub use signature::{require_em_signature, EmSignature, Verdict};
pub use stack::{accumulate, accumulate_kept};
pub use start::{start_values, MIN_SAMPLES, MIN_SIGNAL_SAMPLES};
pub use zero_peak::zero_peak_lambda;
