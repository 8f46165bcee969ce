//! Per-pixel decomposition of a campaign's dark signal (issue 31, part 2): the mean dark of
//! every pixel fitted by weighted least squares as
//!
//! - EMCCD: `mean_adu = F + (G/K) (C + t D(T))`,
//! - no EM register (sCMOS, CCD): `mean_adu = F + t D(T) / K` (CIC cannot be told from the
//!   offset without a gain to vary, so no CIC map),
//!
//! with `D(T) = D_ref 2^((T - T_ref)/T_d)` when the temperature term is on (EMVA 1288). F is the
//! offset (adu), C the clock-induced charge (e-/frame), D the dark current (e-/s), G the EM gain
//! of each condition, K the conversion gain (e-/adu). The noise is checked against D through
//! the slope of the temporal variance with exposure time (EMVA 1288's second method), and the
//! fitted EM gains make a calibration curve. A pure library step: `Vec<ConditionStats>` in,
//! maps and a summary out ([`decompose`]); [`write_outputs`] writes them.

mod classes;
mod design;
mod gain_curve;
mod noise;
mod options;
mod outputs;
mod pixels;
mod result;
mod summary;
mod temperature;
#[cfg(test)]
mod tests;
pub(super) mod wls;

use super::ConditionStats;
use crate::error::Result;

pub use classes::{HotClass, HotPixels, HotRule};
pub use gain_curve::{EmGainCurve, EmGainRow};
pub use noise::{GainNoiseFactor, ShotNoiseCheck};
pub use options::{
    ConversionGain, DecomposeOptions, EmGainFit, FitThresholds, TemperatureTerm,
    DEFAULT_BAD_FIT_P_VALUE, MAX_CLASS_E_PER_S, MAX_CLASS_SIGMAS,
};
pub use outputs::{write_outputs, OUTPUT_NAMES};
pub use pixels::FitQuality;
pub use result::{ConditionRow, Decomposition, DecompositionSummary, MedianSe, TemperatureSummary};

/// Decompose the dark stacks of `stats` (flats are ignored) per pixel; every check of the
/// design and the options is made before the fit, and a design that cannot separate the
/// requested terms is refused naming what is missing.
pub fn decompose(stats: &[ConditionStats], opts: &DecomposeOptions) -> Result<Decomposition> {
    let mut design = design::Design::new(stats, opts)?;
    let k = pixels::PixelGain::new(&opts.conversion_gain);
    let ones = vec![1.0; design.conds.len()];
    pixels::set_signal_floor(&mut design, &k, &ones, 1);
    let temp = temperature::resolve(&design, &k, &opts.temperature)?;
    let fit = pixels::fit_all(&design, &k, &temp.factors);
    let quality = pixels::quality(&fit, design.dof(), opts.bad_fit_p_value);
    let hot = classes::classify(&fit.d, &opts.hot);
    let shot = noise::check(&design, &k, &temp.factors, &fit, opts.register_stages);
    let summary = summary::summarise(summary::Parts {
        design: &design,
        maps: &fit,
        k: &k,
        temp: &temp,
        quality,
        hot: hot.summary,
        shot,
        curve: gain_curve::fit(&opts.em_gains),
        opts,
    });
    Ok(Decomposition {
        rows: design.rows,
        cols: design.cols,
        offset_adu: fit.f,
        offset_se_adu: fit.f_se,
        dark_current_e_per_s: fit.d,
        dark_current_se_e_per_s: fit.d_se,
        cic_e_per_frame: fit.c,
        cic_se_e_per_frame: fit.c_se,
        reduced_chi2: fit.reduced_chi2,
        hot_class: hot.classes,
        summary,
    })
}
