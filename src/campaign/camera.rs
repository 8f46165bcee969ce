//! The measured camera of a campaign as a [`CameraModel`]: the decomposition's offset, dark
//! current and CIC maps, the per-pixel read noise of the darks with the least signal, the
//! line and frame noise pooled over the darks, and the EM register's gain curve.

use super::checks::CampaignPlan;
use super::fit::{Decomposition, HotClass};
use super::measure::StackMeasurement;
use super::StackKind;
use crate::calib::{Map, Unit};
use crate::camera::{CameraModel, DarkCurrent, EmRegisterModel, OperatingRange};
use crate::detector::register::excess_noise_factor_sq;
use crate::error::Result;

/// Stages of the EM register the campaign assumes (the `emgain` default).
pub const REGISTER_STAGES: u32 = 604;

/// The camera model of a measured campaign at conversion gain `k_e_per_adu` (e-/adu).
pub fn camera_model(
    plan: &CampaignPlan,
    stacks: &[StackMeasurement],
    d: &Decomposition,
    k_e_per_adu: f64,
) -> Result<CameraModel> {
    let (rows, cols) = (d.rows, d.cols);
    let map = |data: Vec<f64>, unit| Map::new(rows, cols, data, unit);
    let darks: Vec<&StackMeasurement> = stacks
        .iter()
        .filter(|m| m.stats.condition.kind == StackKind::Dark)
        .collect();
    let lines = pooled_line_noise_e(&darks);
    let read = read_noise_e(&darks, d, k_e_per_adu, &lines);
    let bits = plan
        .opened
        .first()
        .and_then(|s| s.saturation_value())
        .map_or(16, |max| (max + 1.0).log2().round() as u32);
    let mut model = CameraModel::new(
        map(d.offset_adu.clone(), Unit::Adu),
        k_e_per_adu,
        map(read, Unit::Electrons),
        bits,
    )?
    .with_common_noise(lines[0], lines[1], lines[2])?
    .with_campaign(operating_range(plan))?;
    let temperature = &d.summary.temperature;
    model = model.with_dark_current(DarkCurrent {
        map_e_per_s: map(non_negative(&d.dark_current_e_per_s), Unit::Electrons),
        reference_temperature_c: temperature.as_ref().map(|t| t.reference_c),
        doubling_temperature_c: temperature.as_ref().map(|t| t.doubling_c),
    })?;
    if let Some(c) = &d.cic_e_per_frame {
        model = model.with_cic(map(non_negative(c), Unit::Electrons))?;
    }
    if !plan.design.dark_em_gains.is_empty() {
        let gain_curve = match &d.summary.em_gain_curve {
            Some(c) => c
                .rows
                .iter()
                .map(|r| (r.commanded_gain, r.fitted_gain))
                .collect(),
            None => Vec::new(),
        };
        model = model.with_register(EmRegisterModel {
            stages: REGISTER_STAGES,
            gain_curve,
        })?;
    }
    Ok(model)
}

/// The dark conditions of the campaign, for a run's default operating point and its
/// extrapolation warnings.
fn operating_range(plan: &CampaignPlan) -> OperatingRange {
    let d = &plan.design;
    OperatingRange {
        exposures_s: d.dark_exposures_s.clone(),
        em_gains: d.dark_em_gains.clone(),
        temperatures_c: d.dark_temperatures_c.clone(),
    }
}

/// Fitted values clipped at 0 (a pixel's dark current or CIC fitted below 0 within its SE);
/// NaN where not fitted stays NaN.
fn non_negative(values: &[f64]) -> Vec<f64> {
    values
        .iter()
        .map(|&v| if v < 0.0 { 0.0 } else { v })
        .collect()
}

/// A stack's measured value and its SE, if measured.
type ValueAndSe = dyn Fn(&StackMeasurement) -> (Option<f64>, Option<f64>);

/// Row, column and frame noise (e- rms, output-referred): the inverse-variance means over the
/// darks of each stack's measured term (0 where no stack measured it).
fn pooled_line_noise_e(darks: &[&StackMeasurement]) -> [f64; 3] {
    let pool = |get: &ValueAndSe| {
        let (mut sw, mut swx) = (0.0, 0.0);
        for m in darks {
            if let (Some(v), Some(se)) = get(m) {
                if v.is_finite() && se.is_finite() && se > 0.0 {
                    sw += se.powi(-2);
                    swx += v * se.powi(-2);
                }
            }
        }
        if sw > 0.0 {
            (swx / sw).max(0.0)
        } else {
            0.0
        }
    };
    [
        pool(&|m| (m.stats.temporal.row_rms_e, m.stats.temporal.row_rms_se_e)),
        pool(&|m| {
            (
                m.stats.temporal.column_rms_e,
                m.stats.temporal.column_rms_se_e,
            )
        }),
        pool(&|m| {
            (
                m.stats.temporal.frame_rms_e,
                m.stats.temporal.frame_rms_se_e,
            )
        }),
    ]
}

/// Each pixel's read noise (e- rms, output-referred) from the dark stack with the least
/// signal: its temporal variance less the signal's shot noise (x F^2 behind a register) and
/// the row, column and frame terms `lines` (e-), which the model holds apart. A pixel the
/// decomposition did not fit, or whose remainder is not positive, gets the median.
fn read_noise_e(
    darks: &[&StackMeasurement],
    d: &Decomposition,
    k_e_per_adu: f64,
    lines: &[f64; 3],
) -> Vec<f64> {
    let quietest = darks
        .iter()
        .min_by(|a, b| {
            let signal = |m: &StackMeasurement| {
                let c = &m.stats.condition;
                c.em_gain.unwrap_or(1.0) * c.exposure_s
            };
            signal(a).total_cmp(&signal(b))
        })
        .expect("a campaign has darks");
    let c = &quietest.stats.condition;
    let g = c.em_gain.unwrap_or(1.0);
    let enf2 = if c.em_gain.is_some() {
        excess_noise_factor_sq(g, REGISTER_STAGES)
    } else {
        1.0
    };
    let common_e2: f64 = lines.iter().map(|x| x * x).sum();
    let mut read: Vec<f64> = (0..d.offset_adu.len())
        .map(|p| {
            if d.hot_class[p] == HotClass::NotFitted {
                return f64::NAN;
            }
            let charge_e = d.cic_e_per_frame.as_ref().map_or(0.0, |c| c[p].max(0.0))
                + d.dark_current_e_per_s[p].max(0.0) * c.exposure_s;
            let var_e2 = quietest.stats.var_adu2[p] * k_e_per_adu * k_e_per_adu
                - enf2 * g * g * charge_e
                - common_e2;
            if var_e2 > 0.0 {
                var_e2.sqrt()
            } else {
                f64::NAN
            }
        })
        .collect();
    let finite: Vec<f64> = read.iter().copied().filter(|v| v.is_finite()).collect();
    let fill = if finite.is_empty() {
        0.0
    } else {
        crate::stats::median(&finite)
    };
    read.iter_mut()
        .filter(|v| !v.is_finite())
        .for_each(|v| *v = fill);
    read
}
