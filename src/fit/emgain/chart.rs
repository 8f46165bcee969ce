//! The chart of an EM-gain fit: the histogram (log y) with the fitted model and its
//! zero-electron and signal components.

use std::path::Path;

use super::histogram::ValueHistogram;
use super::model::{model_curve, CurveBin};
use super::result::EmGainFit;
use crate::error::Result;
use crate::plot::{LineChart, Series, SeriesStyle};

/// Most points of a curve on the chart (whole histogram bins are merged above that).
const MAX_POINTS: usize = 160;

/// Write the chart of `fit` to the histogram `h` it was fitted to at `path` (PNG or SVG by
/// extension), atomically.
pub fn chart(h: &ValueHistogram, fit: &EmGainFit, path: &Path) -> Result<()> {
    chart_of(h, fit).save(path)
}

/// The chart of `fit` on `h`. Counts are per bin of the fit (`bin_width_adu` of the result,
/// as the y label says): where the chart merges bins to at most [`MAX_POINTS`] points, a point
/// is the mean over the bins it merges.
fn chart_of(h: &ValueHistogram, fit: &EmGainFit) -> LineChart {
    let curve = model_curve(h, fit, MAX_POINTS);
    let mut c = LineChart::new(
        format!(
            "EM gain {:.2} ± {:.2} {}, read noise {:.2} adu, lambda {:.3} e-",
            fit.em_gain, fit.em_gain_se, fit.em_gain_units, fit.read_noise_adu, fit.lambda_e
        ),
        "pixel value (adu)",
        format!("pixel-samples per {} adu bin", fit.bin_width_adu),
    );
    c.log_y = true;
    let per_bin = |b: &CurveBin| fit.bin_width_adu / b.width_adu;
    // One count in the widest merged bin is the smallest data point: the floor is below it.
    let widest = curve.iter().map(|b| b.width_adu).fold(0.0, f64::max);
    let ymin = 0.3 * (fit.bin_width_adu / widest).min(1.0);
    let ymax = curve
        .iter()
        .map(|b| b.data.max(b.model) * per_bin(b))
        .fold(1.0, f64::max)
        * 2.0;
    // Model points below the floor are left out: the curves end there instead of running
    // along the axis.
    let pts = |f: fn(&CurveBin) -> f64, floor: f64| {
        curve
            .iter()
            .map(move |b| (b.x_adu, f(b) * per_bin(b)))
            .filter(|&(_, y)| y >= floor)
            .collect::<Vec<_>>()
    };
    c.series = vec![
        Series::new("data", pts(|b| b.data, f64::MIN_POSITIVE)).styled(SeriesStyle::Markers),
        Series::new("model", pts(|b| b.model, ymin)).styled(SeriesStyle::Line),
        Series::new("no input electron", pts(|b| b.zero_electron, ymin)).styled(SeriesStyle::Line),
        Series::new(
            ">= 1 input electron",
            pts(|b| b.model - b.zero_electron, ymin),
        )
        .styled(SeriesStyle::Line),
    ];
    c.y_range = Some((ymin, ymax));
    c
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::fit::emgain::{accumulate, fit_emgain, EmGainOptions, EmShape};
    use crate::io::FrameStack;

    /// The bundled low-light EMCCD stack's histogram and its exact-register fit.
    fn bundled_fit() -> (ValueHistogram, EmGainFit) {
        let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("data-synthetic/emccd-lowlight-32x48.fits");
        let stack = FrameStack::open(&[path]).unwrap();
        let (h, _) = accumulate(&stack, None, None).unwrap();
        let opts = EmGainOptions {
            shape: Some(EmShape::Register { stages: 520 }),
            gain_e_per_adu: Some(10.0),
            ..EmGainOptions::default()
        };
        let fit = fit_emgain(&h, &opts).unwrap();
        (h, fit)
    }

    #[test]
    fn the_chart_counts_per_bin_of_the_fit_as_its_label_and_the_json_say() {
        let (h, fit) = bundled_fit();
        let c = chart_of(&h, &fit);
        // The label states the JSON's bin width...
        let json = serde_json::to_value(&fit).unwrap();
        let width = json["bin_width_adu"].as_f64().unwrap();
        assert_eq!(c.y_label, format!("pixel-samples per {width} adu bin"));
        // ... and the points are counts per bin of that width: scaled back to their own
        // widths they add up to every pixel-sample the chart covers.
        let curve = model_curve(&h, &fit, MAX_POINTS);
        assert!(curve.len() < h.counts().len(), "bins were merged");
        let data = &c.series[0];
        let total: f64 = data
            .points
            .iter()
            .zip(curve.iter().filter(|b| b.data > 0.0))
            .map(|(p, b)| p.y * b.width_adu / width)
            .sum();
        let covered: f64 = curve.iter().map(|b| b.data).sum();
        assert!((total / covered - 1.0).abs() < 1e-12, "{total} {covered}");
        // Every data point is on the chart (above its floor).
        let floor = c.y_range.unwrap().0;
        assert!(data.points.iter().all(|p| p.y >= floor));
        assert!(
            c.title.contains(" ± ") && !c.title.contains("+-"),
            "{}",
            c.title
        );
    }
}
