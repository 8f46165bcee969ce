//! Coordinates and ticks: the linear coordinate every x-y chart uses (log axes are linear in
//! log10 of the value), tick positions and tick labels.

use std::ops::Range;

use plotters::coord::ranged1d::{DefaultFormatting, KeyPointHint, Ranged};
use plotters::prelude::*;

/// The coordinate system of every x-y chart.
pub type Coord2d = Cartesian2d<AxisCoord, AxisCoord>;

/// A linear f64 coordinate with fixed tick (bold) and grid (light) positions.
#[derive(Clone, Debug)]
pub struct AxisCoord {
    lo: f64,
    hi: f64,
    ticks: Vec<f64>,
    minor: Vec<f64>,
}

impl AxisCoord {
    /// Range [lo, hi] with labelled `ticks` and light grid lines at `minor`.
    pub fn new(lo: f64, hi: f64, ticks: Vec<f64>, minor: Vec<f64>) -> Self {
        AxisCoord {
            lo,
            hi,
            ticks,
            minor,
        }
    }
}

impl Ranged for AxisCoord {
    type ValueType = f64;
    type FormatOption = DefaultFormatting;

    fn map(&self, v: &f64, limit: (i32, i32)) -> i32 {
        let f = (v - self.lo) / (self.hi - self.lo);
        let len = (limit.1 - limit.0) as f64;
        if !f.is_finite() {
            return if f > 0.0 { limit.1 } else { limit.0 };
        }
        // Far outside values are clamped so the backend never sees absurd pixel positions.
        limit.0 + (len * f.clamp(-10.0, 11.0) + 1e-3).floor() as i32
    }

    fn key_points<H: KeyPointHint>(&self, hint: H) -> Vec<f64> {
        if hint.weight().allow_light_points() {
            self.minor.clone()
        } else {
            self.ticks.clone()
        }
    }

    fn range(&self) -> Range<f64> {
        self.lo..self.hi
    }
}

/// About `target` ticks at 1, 2, 2.5 or 5 times a power of ten covering [lo, hi]; returns the ticks and the step.
pub fn nice_ticks(lo: f64, hi: f64, target: usize) -> (Vec<f64>, f64) {
    let span = hi - lo;
    if !(span.is_finite() && span > 0.0) {
        return (vec![lo], 1.0);
    }
    let raw = span / target.max(2) as f64;
    let mag = 10f64.powf(raw.log10().floor());
    let step = [1.0, 2.0, 2.5, 5.0, 10.0]
        .iter()
        .map(|m| m * mag)
        .find(|s| *s >= raw)
        .unwrap_or(10.0 * mag);
    let first = (lo / step).ceil() as i64;
    let last = (hi / step).floor() as i64;
    let ticks = (first..=last)
        .map(|i| {
            let v = i as f64 * step;
            if v.abs() < step * 1e-9 {
                0.0
            } else {
                v
            }
        })
        .collect();
    (ticks, step)
}

/// Log-axis ticks between 10^lo and 10^hi (exponents given): decades, with 2 and 5 (or all
/// multiples) added when there are too few decades; minor lines at every integer multiple.
pub fn log_ticks(lo: f64, hi: f64) -> (Vec<f64>, Vec<f64>) {
    let (d0, d1) = (lo.floor() as i32, hi.ceil() as i32);
    let within = |v: f64| v >= lo - 1e-9 && v <= hi + 1e-9;
    let pick = |mults: &[f64]| -> Vec<f64> {
        (d0..=d1)
            .flat_map(|d| mults.iter().map(move |m| d as f64 + m.log10()))
            .filter(|v| within(*v))
            .collect()
    };
    let all: Vec<f64> = (1..10).map(|m| m as f64).collect();
    let mut ticks = pick(&[1.0]);
    // Many decades: label every second or third only, so the labels never collide.
    if ticks.len() > 8 {
        let every = ticks.len().div_ceil(8);
        ticks.retain(|v| (v.round() as i64).rem_euclid(every as i64) == 0);
    }
    if ticks.len() < 3 {
        ticks = pick(&[1.0, 2.0, 5.0]);
    }
    if ticks.len() < 3 {
        ticks = pick(&all);
    }
    let minor = if hi - lo > 12.0 {
        Vec::new()
    } else {
        pick(&all)
    };
    (ticks, minor)
}

/// Tick label of a value on a linear axis with tick spacing `step`.
pub fn fmt_tick(v: f64, step: f64) -> String {
    if v == 0.0 {
        return "0".into();
    }
    let a = v.abs();
    if !(1e-4..1e6).contains(&a) {
        return fmt_sci(v);
    }
    let decimals = if step > 0.0 {
        (-(step.log10().floor()) as i32).max(0) as usize + usize::from(is_quarter(step))
    } else {
        3
    };
    format!("{v:.decimals$}")
}

fn is_quarter(step: f64) -> bool {
    let m = step / 10f64.powf(step.log10().floor());
    (m - 2.5).abs() < 1e-9
}

/// Label for a value on a log axis: plain numbers between 1e-3 and 1e5, powers of ten outside.
pub fn fmt_log(v: f64) -> String {
    let a = v.abs();
    if (1e-3..1e5).contains(&a) {
        let s = format!("{v:.6}");
        let s = s.trim_end_matches('0').trim_end_matches('.');
        s.to_string()
    } else {
        fmt_sci(v)
    }
}

/// `m×10ⁿ` with superscript digits (`10ⁿ` when the mantissa is 1).
fn fmt_sci(v: f64) -> String {
    let e = v.abs().log10().floor() as i32;
    let m = v / 10f64.powi(e);
    let sup: String = e
        .to_string()
        .chars()
        .map(|c| match c {
            '-' => '⁻',
            d => ['⁰', '¹', '²', '³', '⁴', '⁵', '⁶', '⁷', '⁸', '⁹'][d as usize - '0' as usize],
        })
        .collect();
    let ms = format!("{m:.2}");
    let ms = ms.trim_end_matches('0').trim_end_matches('.');
    if ms == "1" {
        format!("10{sup}")
    } else if ms == "-1" {
        format!("−10{sup}")
    } else {
        format!("{ms}×10{sup}")
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ticks_and_labels() {
        let (t, s) = nice_ticks(0.0, 1.0, 7);
        assert_eq!(s, 0.2);
        assert_eq!(t.len(), 6);
        assert_eq!(fmt_tick(0.4, 0.2), "0.4");
        assert_eq!(fmt_tick(2.5, 2.5), "2.5");
        assert_eq!(fmt_tick(1500.0, 500.0), "1500");
        assert_eq!(fmt_log(200.0), "200");
        assert_eq!(fmt_log(0.02), "0.02");
        assert_eq!(fmt_log(1e6), "10⁶");
        assert_eq!(fmt_log(2e-5), "2×10⁻⁵");
        // 20..1000: decades 100, 1000 only, so 2 and 5 are added.
        let (t, _) = log_ticks(20f64.log10(), 1000f64.log10());
        let labels: Vec<String> = t.iter().map(|v| fmt_log(10f64.powf(*v))).collect();
        assert_eq!(labels, ["20", "50", "100", "200", "500", "1000"]);
    }
}
