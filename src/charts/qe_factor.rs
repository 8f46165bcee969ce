//! The simple EMCCD model's effective QE factor against signal: one line per sub-aperture size
//! at one spot, with error bars, the paper's 0.5 marked (`report --detector emccd` and
//! `effective --model emccd-...`).

use crate::detector::EmccdSimple;
use crate::effective::{QeRecord, QeStatus};
use crate::output::OutputDir;
use crate::plot::{LineChart, RefLine, Series};
use crate::spot::Spot;
use crate::Result;
use std::path::PathBuf;

/// The chart's file stem for `spot`: `effective_qe_airy-2` (`:` and `,` become `-`).
pub fn chart_stem(spot: &Spot) -> String {
    format!("effective_qe_{}", spot.label().replace([':', ','], "-"))
}

/// The `ok` factors of the records at `spot`, one line per sub-aperture size (ascending), as
/// (signal photons, q, SE) with error bars; None when no factor there is `ok`.
fn chart(records: &[QeRecord], spot: &Spot) -> Option<LineChart> {
    let at: Vec<&QeRecord> = records
        .iter()
        .filter(|r| r.config.spot == *spot && r.qe.status == QeStatus::Ok)
        .collect();
    let mut sizes: Vec<usize> = at.iter().map(|r| r.config.subap_px).collect();
    sizes.sort_unstable();
    sizes.dedup();
    if sizes.is_empty() {
        return None;
    }
    let model = &at[0].model;
    let mut chart = LineChart::new(
        format!(
            "Effective QE factor of emccd-simple for {model}, {}",
            spot.label()
        ),
        "signal (photons per sub-aperture)",
        "QE factor q of the simple model",
    );
    chart.log_x = true;
    chart.series = sizes
        .iter()
        .map(|&n| {
            let points = at
                .iter()
                .filter(|r| r.config.subap_px == n)
                .map(|r| (r.config.signal_photons, r.qe.qe_factor, r.qe.qe_factor_se));
            Series::with_errors(format!("{n}x{n} px"), points)
        })
        .collect();
    chart.reference.push(RefLine {
        y: EmccdSimple::PAPER_FACTOR,
        label: "the paper's 0.5".into(),
    });
    Some(chart)
}

/// Draw the chart of `spot` into `dir` as PNG and SVG ([`chart_stem`]); returns the paths, or
/// none when no factor at that spot is `ok`.
pub fn save_chart(records: &[QeRecord], spot: &Spot, dir: &OutputDir) -> Result<Vec<PathBuf>> {
    let Some(chart) = chart(records, spot) else {
        return Ok(Vec::new());
    };
    let stem = chart_stem(spot);
    let mut written = Vec::new();
    for ext in ["png", "svg"] {
        let path = dir.path(&format!("{stem}.{ext}"));
        chart.save(&path)?;
        written.push(path);
    }
    Ok(written)
}

/// One chart per spot of the records (in order of first appearance); returns the paths.
pub fn save_charts(records: &[QeRecord], dir: &OutputDir) -> Result<Vec<PathBuf>> {
    let mut spots: Vec<Spot> = Vec::new();
    for r in records {
        if !spots.contains(&r.config.spot) {
            spots.push(r.config.spot);
        }
    }
    let mut written = Vec::new();
    for spot in &spots {
        written.extend(save_chart(records, spot, dir)?);
    }
    Ok(written)
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;
    use crate::effective::QeFactor;
    use crate::montecarlo::SimConfig;
    use crate::output::DirPlan;

    pub(crate) fn airy(d: f64) -> Spot {
        Spot::Airy { diameter_px: d }
    }

    /// A record at (n px, spot, S photons) with factor q ± se and `status`.
    pub(crate) fn record(
        n: usize,
        spot: Spot,
        s: f64,
        (q, se): (f64, f64),
        status: QeStatus,
    ) -> QeRecord {
        QeRecord {
            model: "emccd-stochastic".into(),
            config: SimConfig {
                spot,
                signal_photons: s,
                ..SimConfig::paper(n)
            },
            em_gain: 300.0,
            emccd_read_noise_e: 50.0,
            qe: QeFactor {
                qe_factor: q,
                qe_factor_se: se,
                target_se: Some(0.0125),
                read_noise_e: 50.0 / 300.0,
                iters: 10_240,
                r_px: 0.2,
                r_se_px: 0.002,
                b_opt_e: 0.4,
                qe_grid: vec![],
                r_simple_px: vec![],
                status,
            },
        }
    }

    /// Three ok factors (one within 2 SE of 0.5, one below, one above), an imprecise one, one
    /// out of range and one at the second spot.
    pub(crate) fn records() -> Vec<QeRecord> {
        let d2 = airy(2.0);
        vec![
            record(8, d2, 20.0, (0.45, 0.01), QeStatus::Ok),
            record(8, d2, 50.0, (0.515, 0.01), QeStatus::Ok),
            record(8, d2, 500.0, (0.56, 0.02), QeStatus::Ok),
            record(16, d2, 20.0, (0.3, 0.2), QeStatus::Imprecise),
            record(16, d2, 50.0, (f64::NAN, f64::NAN), QeStatus::BelowRange),
            record(16, airy(6.0), 50.0, (1.0, 0.3), QeStatus::AboveRange),
        ]
    }

    #[test]
    fn the_chart_draws_the_ok_factors_per_sub_aperture_with_the_papers_line() {
        let recs = records();
        let drawn = chart(&recs, &airy(2.0)).unwrap();
        // Only 8x8 px has ok factors at airy:2.
        assert_eq!(drawn.series.len(), 1);
        assert_eq!(drawn.series[0].name, "8x8 px");
        let ys: Vec<f64> = drawn.series[0].points.iter().map(|p| p.y).collect();
        assert_eq!(ys, [0.45, 0.515, 0.56]);
        assert_eq!(drawn.series[0].points[2].y_se, Some(0.02));
        assert_eq!(drawn.reference[0].y, 0.5);
        assert!(chart(&recs, &airy(6.0)).is_none());
        assert_eq!(
            chart_stem(&Spot::Gauss {
                sigma_x_px: 1.0,
                sigma_y_px: 3.0
            }),
            "effective_qe_gauss-1-3"
        );
        let tmp = tempfile::tempdir().unwrap();
        let dir = OutputDir::prepare(
            &tmp.path().join("out"),
            DirPlan {
                command: "test",
                force: false,
                inputs: &[],
                names: &["effective_qe_*.png", "effective_qe_*.svg"],
            },
        )
        .unwrap();
        let written = save_charts(&recs, &dir).unwrap();
        let names: Vec<String> = written
            .iter()
            .map(|p| p.file_name().unwrap().to_string_lossy().into_owned())
            .collect();
        assert_eq!(
            names,
            ["effective_qe_airy-2.png", "effective_qe_airy-2.svg"]
        );
        assert!(written.iter().all(|p| p.is_file()));
    }
}
