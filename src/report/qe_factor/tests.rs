use super::*;
use crate::effective::QeFactor;
use crate::montecarlo::SimConfig;
use crate::output::DirPlan;

fn airy(d: f64) -> Spot {
    Spot::Airy { diameter_px: d }
}

/// A record at (n px, spot, S photons) with factor q ± se and `status`.
fn record(n: usize, spot: Spot, s: f64, (q, se): (f64, f64), status: QeStatus) -> QeRecord {
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
fn records() -> Vec<QeRecord> {
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
fn the_summary_counts_where_the_papers_factor_holds_within_two_se() {
    // 0.515 ± 0.01 is 1.5 SE from 0.5 (holds); 0.45 ± 0.01 is 5 SE below, 0.56 ± 0.02 3 SE
    // above (both fail); the rest are not ok and are not counted.
    let recs = records();
    let s = QeSummary::new(&recs, (8, airy(2.0), 50.0));
    assert_eq!((s.configurations, s.ok), (6, 3));
    assert_eq!(
        (s.paper_holds, s.paper_fails, s.paper_fails_below),
        (1, 2, 1)
    );
    assert_eq!(s.lowest.as_ref().unwrap().qe_factor, Some(0.45));
    assert_eq!(s.highest.as_ref().unwrap().signal_photons, 500.0);
    let at = s.at_operating_point.as_ref().unwrap();
    assert_eq!((at.qe_factor, at.status), (Some(0.515), QeStatus::Ok));
    assert_eq!(s.simple_read_noise_e, 50.0 / 300.0);
    let signals: Vec<(f64, usize, usize)> = s
        .by_signal
        .iter()
        .map(|b| (b.signal_photons, b.ok, b.paper_holds))
        .collect();
    assert_eq!(signals, [(20.0, 1, 0), (50.0, 1, 1), (500.0, 1, 0)]);
    let text = s.sentence();
    for part in [
        "holds (within 2 SE) in 1 of the 3 configurations",
        "and not in 2: in 1 of them the factor is below 0.5",
        "from 0.450 ± 0.010 (8×8 px, airy:2, S = 20) to 0.560 ± 0.020 (8×8 px, airy:2, S = 500)",
        "3 configurations have no ok factor",
        "Where it holds, by signal: S = 20: 0 of 1 (mean q 0.450); S = 50: 1 of 1 (mean q \
         0.515); S = 500: 0 of 1 (mean q 0.560).",
    ] {
        assert!(text.contains(part), "{part}: {text}");
    }
    // A configuration without a value is null in summary.json, never NaN.
    let none = QeSummary::new(&recs, (16, airy(2.0), 50.0));
    let json = serde_json::to_value(&none).unwrap();
    assert!(json["at_operating_point"]["qe_factor"].is_null());
    assert_eq!(json["at_operating_point"]["status"], "below_range");
    let holds_all = QeSummary::new(&recs[1..2], (8, airy(2.0), 50.0));
    assert!(holds_all
        .sentence()
        .contains("right everywhere it was tested"));
    let no_ok = QeSummary::new(&recs[3..5], (8, airy(2.0), 50.0));
    assert!(no_ok
        .sentence()
        .starts_with("No configuration's factor reached"));
}

#[test]
fn the_section_shows_values_bounds_and_status_words_never_nan() {
    let recs = records();
    let s = QeSummary::new(&recs, (8, airy(2.0), 50.0));
    let h = html_section(&recs, &s, Some("effective_qe_airy-2.png"));
    assert!(
        !h.contains("NaN") && !h.contains(">inf") && !h.contains("∞"),
        "{h}"
    );
    assert!(
        h.contains("<td>0.450 ± 0.010</td><td>-5.0</td><td>no</td>"),
        "{h}"
    );
    assert!(
        h.contains("<td>0.515 ± 0.010</td><td>1.5</td><td>yes</td>"),
        "{h}"
    );
    assert!(h.contains("0.300 ± 0.200 <span class=\"status\">imprecise</span>"));
    assert!(h.contains("≥ 1 <span class=\"status\">above_range</span>"));
    assert!(h.contains("<img src=\"effective_qe_airy-2.png\""));
    for st in QeStatus::ALL {
        assert!(h.contains(st.meaning()), "{}", st.label());
    }
}

#[test]
fn the_chart_draws_the_ok_factors_per_sub_aperture_with_the_papers_line() {
    let recs = records();
    let chart = chart(&recs, &airy(2.0)).unwrap();
    // Only 8x8 px has ok factors at airy:2.
    assert_eq!(chart.series.len(), 1);
    assert_eq!(chart.series[0].name, "8x8 px");
    let ys: Vec<f64> = chart.series[0].points.iter().map(|p| p.y).collect();
    assert_eq!(ys, [0.45, 0.515, 0.56]);
    assert_eq!(chart.series[0].points[2].y_se, Some(0.02));
    assert_eq!(chart.reference[0].y, 0.5);
    assert!(super::chart(&recs, &airy(6.0)).is_none());
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
