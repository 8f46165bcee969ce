use super::compare::{comparison_chart, emccd_labels, scmos_labels, verdicts};
use super::*;
use crate::charts::heatmaps::tests::every_status;
use crate::charts::sweep::tests::sim_record;
use crate::detector::{ModelParams, ModelSpec};
use crate::effective::Status;
use crate::spot::Spot;
use crate::Error;
use std::path::{Path, PathBuf};

fn valid() -> ReportOptions {
    ReportOptions {
        darks_paths: vec!["darks.fits".into()],
        gain_e_per_adu: Some(0.25),
        quick: true,
        out_dir: "out".into(),
        ..ReportOptions::default()
    }
}

/// The field a usage error names.
fn field_of(options: &ReportOptions) -> String {
    match options.validate() {
        Err(Error::Usage { field, .. }) => field,
        other => panic!("expected a usage error, got {other:?}"),
    }
}

#[test]
fn validate_accepts_the_defaults_with_darks_a_gain_and_an_out_dir() {
    valid().validate().unwrap();
    let emccd = ReportOptions {
        detector: DetectorKind::Emccd,
        gain_e_per_adu: Some(10.0),
        ..valid()
    };
    emccd.validate().unwrap();
    let ptc = ReportOptions {
        gain_e_per_adu: None,
        flats_paths: vec!["flat.fits".into()],
        ..valid()
    };
    ptc.validate().unwrap();
}

#[test]
fn validate_names_the_field_at_fault() {
    let cases: Vec<(ReportOptions, &str)> = vec![
        (
            ReportOptions {
                darks_paths: vec![],
                ..valid()
            },
            "darks_paths",
        ),
        (
            ReportOptions {
                out_dir: "".into(),
                ..valid()
            },
            "out",
        ),
        (
            ReportOptions {
                gain_e_per_adu: None,
                ..valid()
            },
            "gain_e_per_adu",
        ),
        (
            ReportOptions {
                gain_e_per_adu: Some(-1.0),
                ..valid()
            },
            "gain_e_per_adu",
        ),
        (
            ReportOptions {
                flats_paths: vec!["flat.fits".into()],
                ..valid()
            },
            "gain_e_per_adu",
        ),
        (
            ReportOptions {
                detector: DetectorKind::Emccd,
                flats_paths: vec!["flat.fits".into()],
                ..valid()
            },
            "flats_paths",
        ),
        (
            ReportOptions {
                qe_emccd: 0.0,
                ..valid()
            },
            "qe_emccd",
        ),
        (
            ReportOptions {
                subaps_px: Some(vec![]),
                ..valid()
            },
            "subaps_px",
        ),
        (
            ReportOptions {
                spots: Some(vec![]),
                ..valid()
            },
            "spots",
        ),
        (
            ReportOptions {
                signals_photons: Some(vec![]),
                ..valid()
            },
            "signals_photons",
        ),
    ];
    for (options, field) in cases {
        assert_eq!(field_of(&options), field, "{options:?}");
    }
    // Fields checked by the configuration and the spot keep their own names.
    let tiny_spot = ReportOptions {
        spots: Some(vec![Spot::Airy { diameter_px: 0.01 }]),
        ..valid()
    };
    assert!(field_of(&tiny_spot).contains("spot"));
    let bright = ReportOptions {
        signals_photons: Some(vec![2e9]),
        ..valid()
    };
    assert!(field_of(&bright).contains("signal"));
}

#[test]
fn messages_name_other_settings_as_fields() {
    let both = ReportOptions {
        flats_paths: vec!["flat.fits".into()],
        ..valid()
    };
    let e = both.validate().unwrap_err().to_string();
    assert!(
        e.contains("`flats_paths`") && e.contains("`gain_e_per_adu`") && !e.contains("--"),
        "{e}"
    );
}

/// A comparison record of `spec` at `signal_photons` with R = `r_px` +- `r_se_px`.
fn compared(spec: ModelSpec, signal_photons: f64, r_px: f64, r_se_px: f64) -> Compared {
    Compared {
        record: sim_record(&format!("{spec:?}"), signal_photons, r_px, r_se_px),
        spec,
    }
}

#[test]
fn verdicts_compare_r_against_twice_the_ratios_standard_error() {
    let map = ModelSpec::ScmosMap;
    let em = ModelSpec::EmccdStochastic;
    let comparison = vec![
        // Ratio 0.5 with relative errors 1 % each: se = 0.5 x sqrt(2) x 0.01 = 0.0071.
        compared(map.clone(), 20.0, 0.1, 0.001),
        compared(em.clone(), 20.0, 0.2, 0.002),
        // Ratio 1.02, se = 1.02 x sqrt(2) x 0.01 = 0.0144: 0.02 < 2 se, no difference.
        compared(map.clone(), 50.0, 0.102, 0.00102),
        compared(em.clone(), 50.0, 0.1, 0.001),
        // Ratio 1.25: the other wins, R lower by 1 - 1/1.25 = 20 %.
        compared(map.clone(), 500.0, 0.125, 0.0001),
        compared(em.clone(), 500.0, 0.1, 0.0001),
        // A signal where one model is missing gives no verdict.
        compared(map.clone(), 1000.0, 0.1, 0.001),
    ];
    let v = verdicts(&comparison, (&map, "this camera"), (&em, "the EMCCD"));
    assert_eq!(
        v,
        vec![
            (20.0, "this camera wins (R 50.0 % lower)".to_string()),
            (50.0, "no significant difference".to_string()),
            (500.0, "the EMCCD wins (R 20.0 % lower)".to_string()),
        ]
    );
}

#[test]
fn comparison_chart_labels_each_model_once_in_order_of_appearance() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("r.svg");
    let comparison = vec![
        compared(ModelSpec::ScmosMap, 20.0, 0.3, 0.01),
        compared(ModelSpec::ScmosConstant(Some(1.5)), 20.0, 0.25, 0.01),
        compared(ModelSpec::ScmosMap, 50.0, 0.2, 0.01),
        compared(ModelSpec::ScmosConstant(Some(1.5)), 50.0, 0.15, 0.01),
    ];
    let labels = scmos_labels(&ModelParams::default());
    comparison_chart(&comparison, &labels)
        .unwrap()
        .save(&path)
        .unwrap();
    let svg = std::fs::read_to_string(&path).unwrap();
    let mapped = svg
        .find("this camera (measured map)")
        .expect("label of scmos-map");
    // A model without a label shows its model name.
    let unlabelled = svg.find("ScmosConstant(Some(1.5))").expect("model name");
    assert!(mapped < unlabelled);
    assert_eq!(svg.matches("this camera (measured map)").count(), 1);
    assert!(svg.contains("R against signal, 8x8 px, airy:2"));
    assert!(comparison_chart(&[], &labels).is_err());
}

/// The sCMOS page of `effective` with the headline's map value `map` (sigma, se, status).
fn scmos_page(effective: &[EffectiveRecord], map: (f64, f64, Status)) -> String {
    scmos_page_with(effective, map, |_| {})
}

/// [`scmos_page`] with the summary changed by `change` first.
fn scmos_page_with(
    effective: &[EffectiveRecord],
    map: (f64, f64, Status),
    change: impl Fn(&mut ReportSummary),
) -> String {
    use super::page::{index_html, ScmosPage};
    use crate::charts::heatmaps::NoiseScale;
    // A smooth spread of per-pixel noise (e-) to fit: the page only prints the fit's numbers.
    let values: Vec<f64> = (1..=300)
        .map(|k| 0.6 + 1.5 * (k as f64 * 0.618_034).fract())
        .collect();
    let fit = crate::fit::pdf_fit::fit_pdf(&values, &Default::default()).unwrap();
    let at = ChosenPoint::new(&OperatingPoint::default(), false, true);
    let mut summary = ReportSummary {
        tool: "detnoise test".into(),
        inputs: vec![],
        frames: 100,
        shape: [64, 64],
        gain_e_per_adu: 0.25,
        gain_source: "given".into(),
        gain_se_e_per_adu: None,
        pixels_used: 300,
        pixels_flagged: 0,
        median_rms_e: 1.3,
        mean_rms_e: 1.35,
        rms_rms_e: 1.4,
        frac_above_3x_median: 0.0,
        pdf_best_model: "lognormal <b>".into(),
        split_half_correlation: f64::NAN,
        operating_point: Headline {
            at,
            sigma_eff_fitted_pdf_e: 3.47,
            sigma_eff_fitted_pdf_se_e: 0.09,
            sigma_eff_fitted_pdf_status: Status::Ok,
            sigma_eff_map_e: map.0,
            sigma_eff_map_se_e: map.1,
            sigma_eff_map_status: map.2,
        },
        iters: 2000,
        seed: 1,
        sampling: "integrated".into(),
        quick: true,
        real_noise: super::RealNoise {
            temporal_noise: Default::default(),
            rts: Default::default(),
            dark_frames: None,
            rows: vec![],
        },
        subaps: None,
        centroiders: super::centroiders::Centroiders {
            median_rms_e: 1.0,
            best_for_map: None,
            rows: vec![],
            versus_emccd: vec![],
        },
        camera: None,
    };
    change(&mut summary);
    let heatmaps = vec![
        PathBuf::from("out/effective_noise_S20.png"),
        PathBuf::from("out/effective_noise_S20.svg"),
    ];
    index_html(&ScmosPage {
        summary: &summary,
        fit: &fit,
        effective,
        comparison: &[],
        heatmaps: &heatmaps,
        scale: &NoiseScale::from_ok(effective),
        error_bars: "Error bars are one standard error.",
        has_ptc: true,
        out_dir: Path::new("my-report"),
    })
}

#[test]
fn the_page_shows_each_status_by_its_word_with_a_legend_and_no_nan() {
    let records = every_status();
    let h = scmos_page(&records, (f64::NAN, f64::NAN, Status::Unreachable));
    for bad in ["NaN", ">inf", " inf ", "-inf"] {
        assert!(!h.contains(bad), "{bad:?} is printed");
    }
    // The legend: every status word with its meaning.
    for s in Status::ALL {
        let entry = format!(
            "<dt><span class=\"status\">{}</span></dt><dd>{}</dd>",
            s.label(),
            crate::output::html_escape(s.meaning())
        );
        assert!(h.contains(&entry), "legend lacks {}", s.label());
    }
    // ok: value +- SE; imprecise: greyed value +- SE with its word; others: the word alone.
    assert!(h.contains("<td>1.00 ± 0.05 e⁻</td>"));
    assert!(h.contains(
        "<td><span class=\"muted\">67.31 ± 120.65 e⁻ <span class=\"status\">imprecise</span></span></td>"
    ));
    for word in ["lower_bound", "unreachable", "no_eligible_level"] {
        assert!(
            h.contains(&format!("<td><span class=\"status\">{word}</span></td>")),
            "{word}"
        );
    }
    // The headline is unreachable: its word, not a number.
    assert!(
        h.contains("(this camera's measured map)<b><span class=\"status\">unreachable</span></b>")
    );
    // Where a cell is unreachable, the page says what to simulate instead, with this report's
    // files.
    assert!(h.contains("detnoise simulate --model scmos-map --map my-report/rms_e.fits"));
    assert!(h.contains("detnoise simulate --model scmos-random --pdf my-report/pdf_fit.json"));
    // The heatmap's caption states the shared scale.
    assert!(
        h.contains("colour scale 0-8.6 e-, 95th percentile of ok cells, the same for every signal")
    );
    assert!(h.contains(
        "Operating point of the headline numbers: 8x8 px, airy:2, 50 photons (default)."
    ));
    assert!(h.contains("an 8×8 px sub-aperture") && !h.contains("a 8×8"));
    // Alt texts are plain words: no markup, escaped or not.
    for alt in h.split("alt=\"").skip(1) {
        let alt = &alt[..alt.find('"').unwrap()];
        assert!(!alt.contains('<') && !alt.contains("&lt;"), "{alt}");
    }
    assert!(h.contains("ptc_points.csv"));
}

#[test]
fn without_unreachable_cells_the_page_gives_no_advice() {
    let ok: Vec<EffectiveRecord> = every_status()
        .into_iter()
        .filter(|r| r.effective.status == Status::Ok)
        .collect();
    let h = scmos_page(&ok, (3.55, 0.1, Status::Ok));
    assert!(!h.contains("class=\"advice\""));
    assert!(h.contains("(this camera's measured map)<b>3.55 ± 0.10 e⁻</b>"));
}

#[test]
fn articles_before_numbers_follow_how_they_are_read() {
    use super::html::article;
    for n in [8, 11, 18, 80, 86, 800, 8000, 11_000, 18_000, 11_000_000] {
        assert_eq!(article(n), "an", "{n}");
    }
    for n in [1, 2, 4, 10, 12, 16, 100, 110, 180, 1100, 1800, 110_000] {
        assert_eq!(article(n), "a", "{n}");
    }
}

#[test]
fn comparison_labels_state_the_parameters_simulated() {
    // The compared EMCCD is labelled with the gain and read noise it runs with, and the
    // sCMOS models of an EMCCD report with the pdf they draw from.
    let params = ModelParams {
        em_gain: 300.0,
        emccd_read_noise_e: 40.0,
        ..ModelParams::default()
    };
    let label = |labels: Vec<(ModelSpec, String)>, spec: ModelSpec| {
        labels.into_iter().find(|(s, _)| *s == spec).unwrap().1
    };
    assert_eq!(
        label(scmos_labels(&params), ModelSpec::EmccdStochastic),
        "EMCCD (g = 300, 40 e- read noise)"
    );
    assert_eq!(
        label(emccd_labels(&params), ModelSpec::ScmosRandom),
        "sCMOS, pdf paper [0, 10] e-"
    );
}

#[test]
fn the_page_explains_its_terms_folds_the_long_table_and_shows_each_chart_once() {
    let records = every_status();
    let h = scmos_page(&records, (3.55, 0.1, Status::Ok));
    // The terms of the fit table, every fitted model, and the spot notation.
    for term in ["ln L", "ΔAIC", "max CDF distance"] {
        assert!(h.contains(&format!("<dt>{term}</dt><dd>")), "{term}");
    }
    for m in crate::fit::PdfModel::ALL {
        let term = crate::output::html_escape(m.name());
        assert!(h.contains(&format!("<dt>{term}</dt><dd>")), "{term}");
    }
    assert!(h.contains("<code>airy:D</code> is an Airy spot"));
    // The effective-noise table folds, saying how long it is; the status legend stays open.
    let details = h
        .find("<details><summary>Every configuration: 24 rows")
        .unwrap();
    let table_end = h[details..].find("</table></details>").unwrap() + details;
    assert!(h[details..table_end].matches("<tr>").count() == 25);
    assert!(h[table_end..].contains("<h3>Status words</h3>"));
    // The heatmaps' model is named beside the headline's, with both values.
    assert!(h.contains(
        "the fitted distribution gives 3.47 ± 0.09 e⁻ and the measured map 3.55 ± 0.10 e⁻"
    ));
    // One histogram of the per-pixel noise on the page (the fit's); rms_hist.png is a file.
    assert!(h.contains("<img src=\"pdf_fit.png\""));
    assert!(!h.contains("<img src=\"rms_hist.png\"") && h.contains("rms_hist.png ("));
}

#[test]
fn the_noise_split_and_the_telegraph_pixels_say_what_there_is() {
    // No telegraph pixel, no line noise: no dashes for the missing medians, no note.
    let none = scmos_page(&every_status(), (3.55, 0.1, Status::Ok));
    assert!(none.contains("Random-telegraph (RTS) pixels: none was flagged"));
    assert!(!none.contains("median span") && !none.contains("above the total"));
    // Negative line variances (rms 0) put the pixel part above the total: the page says why.
    let split = scmos_page_with(&every_status(), (3.55, 0.1, Status::Ok), |s| {
        let t = &mut s.real_noise.temporal_noise;
        (t.pixel_rms_e, t.pixel_rms_se_e) = (Some(1.5737), Some(0.0061));
        (t.total_rms_e, t.total_rms_se_e) = (Some(1.5730), Some(0.0061));
        let rts = &mut s.real_noise.rts;
        (rts.flagged, rts.fitted, rts.ok, rts.two_level) = (12, 10, 9, 9);
        (rts.median_span_e, rts.median_dwell_frames) = (Some(8.04), Some(31.5));
    });
    assert!(split.contains("The pixel part is above the total by 0.0007 e⁻"));
    assert!(split.contains("within the pixel part's SE (0.0061 e⁻)"));
    assert!(split.contains(
        "12 flagged, 10 fitted, 9 fitted <span class=\"status\">ok</span> (9 two-level, \
         0 three-level); median span between a pixel's outer levels 8.04 e⁻, median dwell \
         time 31.5 frames"
    ));
    // Flagged but none ok: no medians to give, said in words.
    let flagged = scmos_page_with(&every_status(), (3.55, 0.1, Status::Ok), |s| {
        s.real_noise.rts.flagged = 3;
    });
    assert!(flagged.contains("none fitted ok, so no span or dwell time to give"));
    assert!(!flagged.contains("median span"));
}
