//! Charts of Monte-Carlo results: R against a swept axis, effective-noise heatmaps, and the
//! report's comparison of models.

use super::heatmaps::{save_heatmaps, NoiseScale};
use super::result::Compared;
use crate::detector::ModelSpec;
use crate::effective::EffectiveRecord;
use crate::montecarlo::SimRecord;
use crate::output::OutputDir;
use crate::plot::{LineChart, Series};
use crate::{Error, Result};
use std::path::{Path, PathBuf};

/// R against the swept axis (signal, sub-aperture size or spot), one line per model and fixed setting.
pub fn r_against_sweep(records: &[SimRecord], path: &Path) -> Result<()> {
    let distinct = |f: &dyn Fn(&SimRecord) -> String| {
        let mut v: Vec<String> = records.iter().map(f).collect();
        v.sort();
        v.dedup();
        v.len()
    };
    // The axis is the first of signal, sub-aperture, spot that takes several values.
    type Axis = (&'static str, fn(&SimRecord) -> f64, bool);
    let axes: [Axis; 3] = [
        (
            "signal (photons per sub-aperture)",
            |r| r.config.signal_photons,
            true,
        ),
        (
            "sub-aperture size (px per side)",
            |r| r.config.subap_px as f64,
            false,
        ),
        (
            "spot size (px)",
            |r| spot_size(&r.config.spot.label()),
            false,
        ),
    ];
    let counts = [
        distinct(&|r| r.config.signal_photons.to_string()),
        distinct(&|r| r.config.subap_px.to_string()),
        distinct(&|r| r.config.spot.label()),
    ];
    let k = counts.iter().position(|&c| c > 1).unwrap_or(0);
    let (x_label, x_of, log_x) = axes[k];
    let series_key = |r: &SimRecord| {
        let mut parts = vec![r.result.model.clone()];
        if r.result.centroider != "cog" {
            parts.push(r.result.centroider.clone());
        }
        if k != 0 && counts[0] > 1 {
            parts.push(format!("S = {}", r.config.signal_photons));
        }
        if k != 1 && counts[1] > 1 {
            parts.push(format!("{}x{}", r.config.subap_px, r.config.subap_px));
        }
        if k != 2 && counts[2] > 1 {
            parts.push(r.config.spot.label());
        }
        parts.join(", ")
    };
    let mut keys: Vec<String> = Vec::new();
    for r in records {
        let key = series_key(r);
        if !keys.contains(&key) {
            keys.push(key);
        }
    }
    let mut chart = LineChart::new(
        "Mean radial centroid error",
        x_label,
        "R, mean radial error (px)",
    );
    chart.log_x = log_x;
    chart.log_y = true;
    chart.series = keys
        .iter()
        .map(|key| {
            let pts = records
                .iter()
                .filter(|r| &series_key(r) == key)
                .map(|r| (x_of(r), r.result.r_px, r.result.r_se_px));
            Series::with_errors(key.clone(), pts)
        })
        .collect();
    chart.save(path)
}

/// Diameter of an Airy spot or the larger sigma of a Gaussian (px).
fn spot_size(spot: &str) -> f64 {
    let nums: Vec<f64> = spot
        .split([':', ','])
        .filter_map(|s| s.parse().ok())
        .collect();
    nums.into_iter().fold(0.0, f64::max)
}

/// One heatmap per signal level (PNG and SVG, `effective_noise_S<signal>`): sub-aperture size x
/// spot, colour = sigma_eff_e on one scale for every signal ([`NoiseScale::from_ok`]), cells that
/// are not `ok` grey with their status. The records must be of one model.
pub fn effective_heatmaps(records: &[EffectiveRecord], dir: &OutputDir) -> Result<Vec<PathBuf>> {
    let model = records.first().map_or("", |r| r.model.as_str());
    let scale = NoiseScale::from_ok(records);
    let mut centroiders: Vec<&str> = Vec::new();
    for r in records {
        if !centroiders.contains(&r.centroider.as_str()) {
            centroiders.push(&r.centroider);
        }
    }
    let mut paths = Vec::new();
    for c in centroiders {
        // The paper's centroider keeps the plain names; the others are named in the file.
        let (suffix, named) = match c {
            "cog" => (String::new(), String::new()),
            c => (format!("_{}", c.replace(':', "_")), format!(", {c}")),
        };
        let mine: Vec<EffectiveRecord> = records
            .iter()
            .filter(|r| r.centroider == c)
            .cloned()
            .collect();
        paths.extend(save_heatmaps(
            &mine,
            &scale,
            &|s| {
                format!(
                    "Effective read noise (e-), {model}{named}, S = {s} photons per sub-aperture"
                )
            },
            &|s, ext| dir.path(&format!("effective_noise_S{s}{suffix}.{ext}")),
        )?);
    }
    Ok(paths)
}

/// R against signal at one sub-aperture and spot, one line per model (in order of first
/// appearance) with error bars of one standard error; `labels` names the models in the legend
/// (others show their model name). Written to `path` (PNG or SVG).
pub fn comparison_chart(
    comparison: &[Compared],
    path: &Path,
    labels: &[(ModelSpec, String)],
) -> Result<()> {
    comparison_line_chart(comparison, labels)?.save(path)
}

/// The chart of [`comparison_chart`].
pub(crate) fn comparison_line_chart(
    comparison: &[Compared],
    labels: &[(ModelSpec, String)],
) -> Result<LineChart> {
    let first = &comparison
        .first()
        .ok_or_else(|| Error::Numeric("no comparison records to draw".into()))?
        .record;
    let mut chart = LineChart::new(
        format!(
            "R against signal, {}x{} px, {}",
            first.config.subap_px,
            first.config.subap_px,
            first.config.spot.label()
        ),
        "signal (photons per sub-aperture)",
        "R, mean radial error (px)",
    );
    chart.log_x = true;
    chart.log_y = true;
    let mut models: Vec<&Compared> = Vec::new();
    for c in comparison {
        if !models.iter().any(|m| m.spec == c.spec) {
            models.push(c);
        }
    }
    chart.series = models
        .iter()
        .map(|m| {
            let label = labels
                .iter()
                .find(|(spec, _)| *spec == m.spec)
                .map_or(m.record.result.model.as_str(), |(_, l)| l.as_str());
            Series::with_errors(
                label,
                comparison.iter().filter(|c| c.spec == m.spec).map(|c| {
                    let (cfg, r) = (&c.record.config, &c.record.result);
                    (cfg.signal_photons, r.r_px, r.r_se_px)
                }),
            )
        })
        .collect();
    Ok(chart)
}

/// What a caption says of a chart's error bars (one standard error): that they are drawn, or
/// that they hide behind the markers, with the largest standard error (px) and the largest
/// relative one. `extent` is [`LineChart::error_bar_extent`]; `records` the points drawn.
pub fn error_bar_note(extent: Option<(f64, f64)>, records: &[&SimRecord]) -> String {
    match extent {
        None => String::new(),
        Some((arm_px, _)) if arm_px > LineChart::MARKER_HALF_PX => {
            "Error bars are one standard error.".into()
        }
        Some((_, largest_se)) => {
            let rel = records
                .iter()
                .map(|r| r.result.r_se_px / r.result.r_px)
                .filter(|v| v.is_finite())
                .fold(0.0, f64::max);
            format!(
                "Error bars (one standard error) are smaller than the markers: standard errors \
                 are at most {} px, {:.1} % of R.",
                super::heatmaps::round_up_2_digits(largest_se).1,
                100.0 * rel
            )
        }
    }
}
