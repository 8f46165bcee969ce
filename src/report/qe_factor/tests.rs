use super::*;
use crate::charts::qe_factor::tests::{airy, records};

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
