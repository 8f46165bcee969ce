//! The mean charge of an EMCCD histogram from its zero-electron peak alone, beside the
//! fit's lambda (which the EM tail's shape also sets): an independent route to the CIC.
//!
//! Values below the bias are almost all zero-electron read noise, which puts exactly half of
//! its mass there: P(no electron) = 2 (F(b) - E(b)), F(b) the fraction of the values below
//! the fitted bias b and E(b) the fraction the fitted model puts there from one or more
//! electrons (EM events below the bias, a large share at low gain). Only E(b) depends on the
//! register law, and at high gain it is small.

use super::histogram::ValueHistogram;
use super::model::{Model, MAX_FFT};
use super::result::{EmGainFit, ZeroPeak};
use crate::error::{Error, Result};
use rustfft::FftPlanner;

/// Cells per read noise on the model's grid.
const CELLS_PER_SIGMA: f64 = 8.0;

/// Read noises of the zero-electron peak below the bias counted (beyond: < 1e-32 of it).
const BELOW_SIGMAS: f64 = 12.0;

/// The mean input charge (e- per pixel-sample) of histogram `h` from its zero-electron peak,
/// with the fitted model `fit` of the same histogram for the EM events below the bias.
pub fn zero_peak_lambda(h: &ValueHistogram, fit: &EmGainFit) -> Result<ZeroPeak> {
    let (b, s, g, l) = (
        fit.bias_adu,
        fit.read_noise_adu,
        fit.gain_adu_per_e,
        fit.lambda_e,
    );
    let cic = fit.serial_cic_e.unwrap_or(0.0);
    // The period holds 30 gains of EM tail beyond the peak (wrapped mass < 1e-13).
    let span = (BELOW_SIGMAS + 10.0) * s + 30.0 * g;
    let cell = (s / CELLS_PER_SIGMA).max(span / MAX_FFT as f64);
    if !(cell > 0.0 && s >= 2.5 * cell) {
        return Err(Error::Numeric(format!(
            "zero-peak lambda: a read noise of {s:.3} adu is too narrow for an EM tail of {g:.1} adu per electron on {MAX_FFT} cells"
        )));
    }
    let below = (BELOW_SIGMAS * s / cell).ceil() as usize;
    let m = ((span / cell).ceil() as usize).max(2).next_power_of_two();
    let model = Model {
        shape: fit.shape,
        conv: fit.gain_e_per_adu.unwrap_or(1.0),
        conv_known: fit.gain_e_per_adu.is_some(),
        x0: b - below as f64 * cell,
        h: cell,
        fft: FftPlanner::new().plan_fft_forward(m),
        m,
        mix: fit.lambda_mixture.clone(),
    };
    let invalid = || Error::Numeric("zero-peak lambda: the fitted model is not valid".into());
    let total = model.cells(b, s, g, l, cic).ok_or_else(invalid)?;
    let peak = model.cells(b, s, g, 0.0, 0.0).ok_or_else(invalid)?;
    let none = match &fit.lambda_mixture {
        Some(mix) => mix.p_zero(l),
        None => (-l).exp(),
    } * (-cic).exp();
    let events: f64 = (0..below).map(|i| total[i] - none * peak[i]).sum();
    let n = h.total();
    let fraction = h.cdf(b);
    let p0 = 2.0 * (fraction - events);
    let p0_se = 2.0 * (fraction * (1.0 - fraction) / n).sqrt();
    // The probability of no input electron.
    let p_in = p0 * cic.exp();
    let solved = match &fit.lambda_mixture {
        Some(mix) => mix.lambda_of_p_zero(p_in),
        None => (p_in > 0.0 && p_in < 1.0).then(|| (-p_in.ln(), -1.0 / p_in)),
    };
    let (lambda, slope) = solved.ok_or_else(|| {
        Error::Numeric(format!(
            "zero-peak lambda: P(no electron) = 2 ({fraction:.5} - {events:.5}) = {p0:.5} leaves no mean charge"
        ))
    })?;
    Ok(ZeroPeak {
        fraction_below_bias: fraction,
        events_below_bias: events,
        p_zero: p0,
        p_zero_se: p0_se,
        lambda_e: lambda,
        lambda_e_se: slope.abs() * p0_se * cic.exp(),
    })
}
