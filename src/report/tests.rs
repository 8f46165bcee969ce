use super::charts::{comparison_chart, r_against_sweep};
use super::compare::{verdicts, SCMOS_LABELS};
use super::*;
use crate::detector::ModelSpec;
use crate::montecarlo::{SimConfig, SimResult};
use crate::spot::Spot;
use crate::Error;

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
    let cfg = SimConfig {
        signal_photons,
        ..SimConfig::paper(8)
    };
    let result = SimResult {
        model: format!("{spec:?}"),
        r_px,
        r_se_px,
        b_opt_e: 0.0,
        b_at_grid_edge: false,
        no_eligible_level: false,
        r0_px: r_px,
        r0_se_px: r_se_px,
        zero_frames: 0,
        levels: vec![],
    };
    Compared {
        spec,
        record: SimRecord::new(&cfg, Some(500.0), result),
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
    comparison_chart(&comparison, &path, &SCMOS_LABELS).unwrap();
    let svg = std::fs::read_to_string(&path).unwrap();
    let mapped = svg
        .find("this camera (measured map)")
        .expect("label of scmos-map");
    // A model without a label shows its model name.
    let unlabelled = svg.find("ScmosConstant(Some(1.5))").expect("model name");
    assert!(mapped < unlabelled);
    assert_eq!(svg.matches("this camera (measured map)").count(), 1);
    assert!(svg.contains("R against signal, 8x8 px, airy:2"));
    assert!(comparison_chart(&[], &path, &SCMOS_LABELS).is_err());
}

#[test]
fn r_against_sweep_takes_the_first_axis_that_varies() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("sweep.svg");
    let records: Vec<SimRecord> = [(20.0, 0.3), (50.0, 0.2)]
        .iter()
        .map(|&(s, r)| compared(ModelSpec::ScmosMean, s, r, 0.01).record)
        .collect();
    r_against_sweep(&records, &path).unwrap();
    let svg = std::fs::read_to_string(&path).unwrap();
    assert!(svg.contains("signal (photons per sub-aperture)"), "{svg}");
    assert!(svg.contains("ScmosMean"));
}
