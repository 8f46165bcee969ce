//! R against a swept axis (signal, sub-aperture size or spot): the chart of `simulate`.

use crate::montecarlo::SimRecord;
use crate::plot::{LineChart, Series};
use crate::Result;
use std::path::Path;

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

#[cfg(test)]
pub(crate) mod tests {
    use super::*;
    use crate::montecarlo::{SimConfig, SimResult};

    /// A record of `model` (plain cog) at `signal_photons` on 8x8 px, airy:2, with
    /// R = `r_px` +- `r_se_px`.
    pub(crate) fn sim_record(
        model: &str,
        signal_photons: f64,
        r_px: f64,
        r_se_px: f64,
    ) -> SimRecord {
        let cfg = SimConfig {
            signal_photons,
            ..SimConfig::paper(8)
        };
        let result = SimResult {
            model: model.into(),
            centroider: "cog".into(),
            param_name: None,
            param_opt: None,
            best: 0,
            r_px,
            r_se_px,
            b_opt_e: 0.0,
            b_at_grid_edge: false,
            no_eligible_level: false,
            r0_px: r_px,
            r0_se_px: r_se_px,
            zero_frames: 0,
            parts: Default::default(),
            levels: vec![],
        };
        SimRecord::new(&cfg, Some(500.0), result)
    }

    #[test]
    fn r_against_sweep_takes_the_first_axis_that_varies() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("sweep.svg");
        let records: Vec<SimRecord> = [(20.0, 0.3), (50.0, 0.2)]
            .iter()
            .map(|&(s, r)| sim_record("ScmosMean", s, r, 0.01))
            .collect();
        r_against_sweep(&records, &path).unwrap();
        let svg = std::fs::read_to_string(&path).unwrap();
        assert!(svg.contains("signal (photons per sub-aperture)"), "{svg}");
        assert!(svg.contains("ScmosMean"));
    }
}
