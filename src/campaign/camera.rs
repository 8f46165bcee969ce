//! The measured camera of a campaign as a [`CameraModel`]: the decomposition's offset, dark
//! current and CIC maps, the per-pixel read noise of the darks with the least signal, the
//! line and frame noise pooled over the darks, and the EM register's gain curve.

use super::checks::CampaignPlan;
use super::fit::wls::Normal;
use super::fit::{Decomposition, HotClass};
use super::measure::StackMeasurement;
use super::StackKind;
use crate::calib::{Map, Unit};
use crate::camera::{CameraModel, DarkCurrent, EmRegisterModel, OperatingRange};
use crate::detector::register::{excess_noise_factor_sq, serial_cic_moments};
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
    let serial = serial_cic_e(&darks);
    let without_serial;
    let d = match serial {
        Some(c) => {
            without_serial = without_serial_cic(d, c, k_e_per_adu);
            &without_serial
        }
        None => d,
    };
    let lines = pooled_line_noise_e(&darks);
    let quantised = plan.opened.iter().all(|s| s.saturation_value().is_some());
    let read = read_noise_e(&darks, d, k_e_per_adu, &lines, serial, quantised);
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
            serial_cic_e: serial,
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

/// The serial CIC of the darks' EM fits, events per pixel: the inverse-variance mean of the
/// rates of the stacks whose fit kept it (the model comparison said present); None when none
/// did.
fn serial_cic_e(darks: &[&StackMeasurement]) -> Option<f64> {
    let (mut sw, mut swx) = (0.0, 0.0);
    for m in darks {
        let Some(Ok(fit)) = &m.em_fit else { continue };
        let kept = fit.serial_cic_test.as_ref().is_none_or(|t| t.present);
        if let (true, Some(c), Some(se)) = (kept, fit.serial_cic_e, fit.serial_cic_e_se) {
            if c.is_finite() && se.is_finite() && se > 0.0 {
                sw += se.powi(-2);
                swx += c * se.powi(-2);
            }
        }
    }
    (sw > 0.0).then(|| (swx / sw).max(0.0))
}

/// The decomposition with the serial CIC `c` (events per pixel) taken back out. Its mean
/// output, c (G - 1) / (N p) e- at gain G, grows almost as G, so the per-pixel fit of
/// F + G C + G t D put it into C (and a little into F and D); the model simulates serial CIC
/// apart, so the least-squares line of its mean over the darks' conditions (unweighted, the
/// temperature term left aside) comes off each pixel's F, C and D.
fn without_serial_cic(d: &Decomposition, c: f64, k_e_per_adu: f64) -> Decomposition {
    let cic = d.cic_e_per_frame.is_some();
    let rows: Vec<([f64; 3], f64)> = d
        .summary
        .conditions
        .iter()
        .filter_map(|r| {
            let g = r.em_gain_used?;
            let s = c * serial_cic_moments(g, REGISTER_STAGES).0;
            Some(match cic {
                true => ([1.0, g, g * r.exposure_s], s),
                false => ([1.0, g * r.exposure_s, 0.0], s),
            })
        })
        .collect();
    let Some(x) = least_squares(&rows, if cic { 3 } else { 2 }) else {
        return d.clone();
    };
    let (f, c_e, d_e) = if cic {
        (x[0], x[1], x[2])
    } else {
        (x[0], 0.0, x[1])
    };
    let mut out = d.clone();
    out.offset_adu
        .iter_mut()
        .for_each(|v| *v -= f / k_e_per_adu);
    out.dark_current_e_per_s.iter_mut().for_each(|v| *v -= d_e);
    if let Some(m) = &mut out.cic_e_per_frame {
        m.iter_mut().for_each(|v| *v -= c_e);
    }
    out
}

/// Unweighted least squares of `rows` ((design row, observation)) in its first `p` (<= 3)
/// parameters (the decomposition's solver, unit weights); None when the normal equations are
/// singular (too few conditions).
fn least_squares(rows: &[([f64; 3], f64)], p: usize) -> Option<[f64; 3]> {
    let mut normal = Normal::<3>::new(p);
    for (x, y) in rows {
        normal.add(x, *y, 1.0);
    }
    normal.solve().map(|s| s.x)
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
/// the row, column and frame terms `lines` (e-), which the model holds apart, and less the
/// serial CIC's variance (`serial` events per pixel) and, for `quantised` (integer) data, the
/// rounding's 1/12 adu^2, which the model simulates apart too. A pixel the decomposition did
/// not fit, or whose remainder is not positive, gets the median.
fn read_noise_e(
    darks: &[&StackMeasurement],
    d: &Decomposition,
    k_e_per_adu: f64,
    lines: &[f64; 3],
    serial: Option<f64>,
    quantised: bool,
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
    let serial_e2 = match (serial, c.em_gain) {
        (Some(rate), Some(_)) => rate * serial_cic_moments(g, REGISTER_STAGES).1,
        _ => 0.0,
    };
    let rounding_e2 = if quantised {
        k_e_per_adu * k_e_per_adu / 12.0
    } else {
        0.0
    };
    let mut read: Vec<f64> = (0..d.offset_adu.len())
        .map(|p| {
            if d.hot_class[p] == HotClass::NotFitted {
                return f64::NAN;
            }
            let charge_e = d.cic_e_per_frame.as_ref().map_or(0.0, |c| c[p].max(0.0))
                + d.dark_current_e_per_s[p].max(0.0) * c.exposure_s;
            let var_e2 = quietest.stats.var_adu2[p] * k_e_per_adu * k_e_per_adu
                - enf2 * g * g * charge_e
                - common_e2
                - serial_e2
                - rounding_e2;
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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn least_squares_recovers_an_exact_design() {
        // y = 2 + 3 g + 0.5 g t over a 3 x 3 design of gains and exposures: exact.
        let mut rows = vec![];
        for g in [50.0, 200.0, 800.0] {
            for t in [0.01, 0.1, 0.5] {
                rows.push(([1.0, g, g * t], 2.0 + 3.0 * g + 0.5 * g * t));
            }
        }
        let x = least_squares(&rows, 3).unwrap();
        for (got, want) in x.iter().zip([2.0, 3.0, 0.5]) {
            assert!((got - want).abs() < 1e-9 * want, "{x:?}");
        }
        // One gain cannot separate F from G C.
        let one: Vec<_> = rows.iter().filter(|r| r.0[1] == 50.0).copied().collect();
        assert!(least_squares(&one, 3).is_none());
    }

    #[test]
    fn the_serial_cic_mean_is_almost_linear_in_the_gain() {
        // Why taking its least-squares line out of F + G C + G t D is enough: over the
        // campaign fixture's gains 50, 200, 800 the line predicts the serial CIC's mean output
        // at G 400 within 7 % (0.07 x 0.02 events x 66 e- = 0.09 e- output, 2e-4 e- input).
        let s = |g: f64| serial_cic_moments(g, REGISTER_STAGES).0;
        let rows: Vec<_> = [50.0, 200.0, 800.0]
            .iter()
            .map(|&g| ([1.0, g, 0.0], s(g)))
            .collect();
        let x = least_squares(&rows, 2).unwrap();
        let line = x[0] + x[1] * 400.0;
        assert!(
            (line / s(400.0) - 1.0).abs() < 0.07,
            "{line} vs {}",
            s(400.0)
        );
    }
}
