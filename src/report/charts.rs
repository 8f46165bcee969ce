//! Charts of Monte-Carlo results: R against a swept axis, effective-noise heatmaps, and the
//! report's comparison of models.

use super::result::Compared;
use crate::detector::ModelSpec;
use crate::effective::EffectiveRecord;
use crate::montecarlo::SimRecord;
use crate::output::OutputDir;
use crate::plot::{Heatmap, LineChart, Series};
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

/// One heatmap per signal level (PNG and SVG): sub-aperture size x spot, colour = sigma_eff_e.
pub fn effective_heatmaps(records: &[EffectiveRecord], dir: &OutputDir) -> Result<Vec<PathBuf>> {
    let mut signals: Vec<f64> = records.iter().map(|r| r.config.signal_photons).collect();
    signals.sort_by(f64::total_cmp);
    signals.dedup();
    let mut subaps: Vec<usize> = records.iter().map(|r| r.config.subap_px).collect();
    subaps.sort();
    subaps.dedup();
    let mut spots: Vec<String> = Vec::new();
    for r in records {
        if !spots.contains(&r.config.spot.label()) {
            spots.push(r.config.spot.label());
        }
    }
    let mut written = Vec::new();
    for s in signals {
        let mut values = vec![vec![f64::NAN; subaps.len()]; spots.len()];
        for r in records.iter().filter(|r| r.config.signal_photons == s) {
            let i = subaps
                .iter()
                .position(|&n| n == r.config.subap_px)
                .ok_or_else(|| Error::Numeric("subap".into()))?;
            let j = spots
                .iter()
                .position(|p| p == &r.config.spot.label())
                .ok_or_else(|| Error::Numeric("spot".into()))?;
            values[j][i] = r.effective.sigma_eff_e;
        }
        let mut h = Heatmap::new(
            format!("Effective read noise (e-), S = {s} photons per sub-aperture"),
            "sub-aperture size (px per side)",
            "spot",
            subaps.iter().map(|n| n.to_string()).collect(),
            spots.clone(),
            values,
            "effective rms read noise (e-)",
        );
        h.decimals = 2;
        for ext in ["png", "svg"] {
            let p = dir.path(&format!("effective_noise_S{s}.{ext}"));
            h.save(&p)?;
            written.push(p);
        }
    }
    Ok(written)
}

/// R against signal at one sub-aperture and spot, one line per model (in order of first
/// appearance) with error bars of one standard error; `labels` names the models in the legend
/// (others show their model name).
pub fn comparison_chart(
    comparison: &[Compared],
    path: &Path,
    labels: &[(ModelSpec, &str)],
) -> Result<()> {
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
                .map_or(m.record.result.model.as_str(), |(_, l)| l);
            Series::with_errors(
                label,
                comparison.iter().filter(|c| c.spec == m.spec).map(|c| {
                    let (cfg, r) = (&c.record.config, &c.record.result);
                    (cfg.signal_photons, r.r_px, r.r_se_px)
                }),
            )
        })
        .collect();
    chart.save(path)
}
