//! decomposition.json: the medians of the maps with their statistical and systematic SEs,
//! the conditions with their read noise, and the checks.

use super::classes::HotPixels;
use super::design::Design;
use super::gain_curve::EmGainCurve;
use super::noise::ShotNoiseCheck;
use super::options::{ConversionGain, DecomposeOptions};
use super::pixels::FitQuality;
use super::pixels::{gain_systematic, Maps, PixelGain};
use super::result::{ConditionRow, DecompositionSummary, MedianSe};
use super::temperature::Temperature;
use rayon::prelude::*;

use crate::stats::median_and_robust_sigma;

/// The SE of a median of `n` values of robust sigma `s`: sqrt(pi/2) s / sqrt(n).
fn median_se(values: &[f64]) -> (f64, f64) {
    let (m, s) = median_and_robust_sigma(values);
    let n = values.iter().filter(|v| v.is_finite()).count().max(1) as f64;
    (m, (std::f64::consts::FRAC_PI_2).sqrt() * s / n.sqrt())
}

fn median_of(map: &[f64], se_map: &[f64], systematic: f64) -> MedianSe {
    let (median, se) = median_se(map);
    MedianSe {
        median,
        se,
        systematic_se: systematic,
        median_pixel_se: crate::stats::median(se_map),
    }
}

/// Everything the summary is made from.
pub(super) struct Parts<'a> {
    pub design: &'a Design<'a>,
    pub maps: &'a Maps,
    pub k: &'a PixelGain,
    pub temp: &'a Temperature,
    pub quality: FitQuality,
    pub hot: HotPixels,
    pub shot: std::result::Result<ShotNoiseCheck, String>,
    pub curve: Option<EmGainCurve>,
    pub opts: &'a DecomposeOptions,
}

/// The summary of a decomposition.
pub(super) fn summarise(p: Parts) -> DecompositionSummary {
    let d = p.design;
    let sys = gain_systematic(d, p.k, &p.temp.factors);
    // C and D scale as K: its relative SE adds in quadrature to theirs.
    let (k_global, k_se) = match &p.opts.conversion_gain {
        ConversionGain::Global {
            e_per_adu,
            se_e_per_adu,
        } => (Some(*e_per_adu), Some(*se_e_per_adu)),
        ConversionGain::Map(_) => (None, None),
    };
    let k_rel = k_se.zip(k_global).map_or(0.0, |(s, k)| s / k);
    let with_k = |m: MedianSe| MedianSe {
        systematic_se: m.systematic_se.hypot(m.median * k_rel),
        ..m
    };
    let di = d.d_index();
    let model = match (d.register, d.cic) {
        (true, true) => "mean_adu = F + (G/K) (C + t D(T))",
        (true, false) => "mean_adu = F + (G/K) t D(T) (CIC part of F)",
        _ => "mean_adu = F + t D(T) / K (CIC part of F)",
    };
    let temperature_words = match &p.temp.summary {
        Some(_) => ", D(T) = D_ref 2^((T - T_ref)/T_d)",
        None => ", D(T) = D",
    };
    let mut notes = d.notes.clone();
    notes.extend(p.temp.notes.iter().cloned());
    let shot_noise = match p.shot {
        Ok(s) => Some(s),
        Err(why) => {
            notes.push(why);
            None
        }
    };
    notes.push(
        "per-pixel SE maps are statistical (weights frames / var_adu2); errors common to every \
         pixel (EM gains, conversion gain) are in the medians' systematic_se"
            .into(),
    );
    let fitted = p.maps.fitted();
    let mut maps = vec![
        (&p.maps.f, &p.maps.f_se, sys[0]),
        (&p.maps.d, &p.maps.d_se, sys[di]),
    ];
    if let (Some(c), Some(se)) = (&p.maps.c, &p.maps.c_se) {
        maps.push((c, se, sys[1]));
    }
    let medians: Vec<MedianSe> = maps
        .par_iter()
        .map(|(m, se, sys)| median_of(m, se, *sys))
        .collect();
    DecompositionSummary {
        tool: format!("detnoise {}", env!("CARGO_PKG_VERSION")),
        model: format!("{model}{temperature_words}, weighted least squares per pixel"),
        em_register: d.register,
        shape: [d.rows, d.cols],
        pixels_fitted: fitted,
        pixels_not_fitted: d.npix - fitted,
        conversion_gain_e_per_adu: k_global,
        conversion_gain_se_e_per_adu: k_se,
        conditions: d
            .conds
            .iter()
            .enumerate()
            .map(|(i, c)| {
                let cond = &c.stats.condition;
                ConditionRow {
                    file: c.stats.file.display().to_string(),
                    exposure_s: c.t,
                    em_gain_commanded: cond.em_gain,
                    em_gain_used: d.register.then_some(c.g),
                    em_gain_used_se: d.register.then_some(c.g_se),
                    temperature_c: c.temp,
                    frames: c.stats.frames,
                    median_mean_adu: d.typical[i][0],
                    read_noise: c.stats.temporal.clone(),
                }
            })
            .collect(),
        offset_adu: medians[0],
        dark_current_e_per_s: with_k(medians[1]),
        cic_e_per_frame: medians.get(2).copied().map(with_k),
        temperature: p.temp.summary.clone(),
        fit_quality: p.quality,
        hot_pixels: p.hot,
        shot_noise,
        em_gain_curve: p.curve,
        notes,
    }
}
