//! The chart of an EM-gain fit: the histogram (log y) with the fitted model and its
//! zero-electron and signal components.

use std::path::Path;

use super::histogram::ValueHistogram;
use super::model::{model_curve, CurveBin};
use super::result::EmGainFit;
use crate::error::Result;
use crate::plot::{LineChart, Series, SeriesStyle};

/// Write the chart of `fit` to the histogram `h` it was fitted to at `path` (PNG or SVG by
/// extension), atomically.
pub fn chart(h: &ValueHistogram, fit: &EmGainFit, path: &Path) -> Result<()> {
    let curve = model_curve(h, fit, 160);
    let width = curve.get(1).map_or(h.width(), |c| c.x_adu - curve[0].x_adu);
    let mut c = LineChart::new(
        format!(
            "EM gain {:.2} +- {:.2} {}, read noise {:.2} adu, lambda {:.3} e-",
            fit.em_gain, fit.em_gain_se, fit.em_gain_units, fit.read_noise_adu, fit.lambda_e
        ),
        "pixel value (adu)",
        format!("pixel-samples per {width:.3} adu bin"),
    );
    c.log_y = true;
    let pts = |f: fn(&CurveBin) -> f64| {
        curve
            .iter()
            .map(move |c| (c.x_adu, f(c)))
            .collect::<Vec<_>>()
    };
    c.series = vec![
        Series::new("data", pts(|c| c.data)).styled(SeriesStyle::Markers),
        Series::new("model", pts(|c| c.model)).styled(SeriesStyle::Line),
        Series::new("no input electron", pts(|c| c.zero_electron)).styled(SeriesStyle::Line),
        Series::new(">= 1 input electron", pts(|c| c.model - c.zero_electron))
            .styled(SeriesStyle::Line),
    ];
    let ymin = 0.3;
    let ymax = curve
        .iter()
        .map(|c| c.data.max(c.model))
        .fold(1.0, f64::max)
        * 2.0;
    c.y_range = Some((ymin, ymax));
    c.save(path)
}
