//! Tests of the registry: every entry parses, builds and names itself; the names, the help and
//! the parser agree with the table.

use super::*;
use crate::calib::{Map, Unit};

/// `name` plus an argument where the entry takes one.
fn examples(entry: &ModelEntry) -> Vec<String> {
    let mut names = vec![entry.name.to_string()];
    match entry.arg {
        Some("SIGMA_E") => names.push(format!("{}:1.5", entry.name)),
        Some("PATTERN") => names.push(format!("{}:4", entry.name)),
        Some("QE_FACTOR") => names.push(format!("{}:0.4", entry.name)),
        Some(other) => panic!("add an example argument for {other}"),
        None => {}
    }
    names
}

/// Two 8x8 dark frames, read from a FITS cube.
fn two_dark_frames() -> DarkFrames {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("darks.fits");
    let mut k = 0.0;
    let mut next = || {
        k += 1.0;
        vec![100.0 + k; 64]
    };
    crate::io::fits::write_cube(&path, (8, 8), 2, true, &mut next, &[]).unwrap();
    DarkFrames::read(&[path], 1.0, 1.0).unwrap()
}

/// An 8x8 camera model at an exposure of 1 s.
fn eight_px_camera() -> crate::camera::CameraAt {
    let offset = Map::filled(8, 8, 100.0, Unit::Adu);
    let camera =
        crate::camera::CameraModel::new(offset, 1.0, Map::filled(8, 8, 1.5, Unit::Electrons), 16);
    let op = crate::camera::OperatingPoint {
        exposure_s: 1.0,
        em_gain: None,
        temperature_c: None,
    };
    camera.unwrap().at(op).unwrap()
}

#[test]
fn every_entry_parses_builds_and_names_itself() {
    let map = Map::new(8, 8, vec![1.5; 64], Unit::Electrons).with_source("map.fits");
    let params = ModelParams {
        map: Some(std::sync::Arc::new(map)),
        rts_table: Some(std::sync::Arc::new(RtsTable {
            source: "rts.csv".into(),
            pixels: vec![],
            skipped: 0,
        })),
        row_noise_e: Some(0.2),
        column_noise_e: Some(0.1),
        dark_frames: Some(std::sync::Arc::new(two_dark_frames())),
        camera: Some(std::sync::Arc::new(eight_px_camera())),
        ..ModelParams::default()
    };
    let fields = format!("{params:?}");
    for entry in MODELS {
        for text in examples(entry) {
            let spec = ModelSpec::parse(&text).unwrap();
            assert_eq!(spec.name(), entry.name, "{text}");
            assert_eq!(spec.entry().syntax(), entry.syntax(), "{text}");
            assert_eq!(spec.is_emccd(), entry.name.starts_with("emccd-"), "{text}");
            assert_eq!(spec.is_scmos(), !spec.is_emccd(), "{text}");
            let built = spec.build(&params, 4).unwrap();
            assert!(
                built.name().starts_with(entry.name),
                "{text}: {}",
                built.name()
            );
            if text.contains(':') {
                assert_eq!(built.name(), text);
            }
            assert!(built.noise_scale_e() > 0.0, "{text}");
        }
        assert_eq!(MODELS.iter().filter(|m| m.name == entry.name).count(), 1);
        for field in entry.params {
            assert!(
                fields.contains(&format!(" {field}: ")),
                "{}: {field}",
                entry.name
            );
        }
        assert!(!entry.help.is_empty() && !entry.help.contains('\n'));
    }
}

#[test]
fn names_and_help_list_every_entry() {
    let help = models_help();
    assert_eq!(help.lines().count(), MODELS.len());
    let syntaxes: Vec<String> = MODELS.iter().map(ModelEntry::syntax).collect();
    assert_eq!(MODEL_NAMES, syntaxes.join(", "));
    for (line, entry) in help.lines().zip(MODELS) {
        assert!(line.starts_with(&format!("{} ", entry.syntax())), "{line}");
        assert!(line.contains(entry.help));
        for field in entry.params {
            assert!(line.contains(&format!("`{field}`")), "{line}");
        }
    }
    // The names as they were written by hand before the registry.
    assert_eq!(
        MODEL_NAMES,
        "emccd-simple[:QE_FACTOR], emccd-stochastic, emccd-distribution, emccd-pp, emccd-pp-uncorrected, \
scmos-constant[:SIGMA_E], scmos-median, scmos-mean, scmos-fixed[:PATTERN], scmos-random, scmos-map, \
scmos-rts, scmos-correlated, scmos-frames, camera"
    );
}

#[test]
fn properties_come_from_the_entry() {
    let spec = |t: &str| ModelSpec::parse(t).unwrap();
    assert!(spec("emccd-pp").is_emccd() && spec("emccd-simple").is_emccd());
    assert!(spec("scmos-map").is_scmos() && spec("scmos-map").uses("map"));
    for t in [
        "scmos-random",
        "scmos-median",
        "scmos-mean",
        "scmos-fixed:2",
    ] {
        assert!(spec(t).uses_pdf(), "{t}");
    }
    for t in ["scmos-constant", "scmos-map", "emccd-stochastic"] {
        assert!(!spec(t).uses_pdf(), "{t}");
    }
    assert_eq!(spec("scmos-fixed"), ModelSpec::ScmosFixed(0));
    assert_eq!(
        spec("scmos-constant:2"),
        ModelSpec::ScmosConstant(Some(2.0))
    );
    assert_eq!(spec("emccd-pp-uncorrected"), ModelSpec::EmccdPp(false));
    assert_eq!(spec(" scmos-mean"), ModelSpec::ScmosMean);
}

#[test]
fn parses_every_model_and_rejects_unknown() {
    for name in [
        "emccd-simple",
        "emccd-stochastic",
        "emccd-distribution",
        "emccd-pp",
        "emccd-pp-uncorrected",
        "scmos-constant",
        "scmos-constant:1.5",
        "scmos-median",
        "scmos-mean",
        "scmos-fixed",
        "scmos-fixed:4",
        "scmos-random",
    ] {
        let spec = ModelSpec::parse(name).unwrap();
        let built = spec.build(&ModelParams::default(), 4).unwrap();
        assert!(built.name().starts_with(name.split(':').next().unwrap()));
    }
    for bad in [
        "emccd",
        "scmos-constant:-1",
        "scmos-fixed:x",
        "emccd-simple:2",
        "",
    ] {
        let err = ModelSpec::parse(bad).unwrap_err();
        assert_eq!(err.exit_code(), 2, "{bad}");
    }
}

#[test]
fn errors_name_the_model_and_map_fields() {
    let unknown = ModelSpec::parse("ccd-magic").unwrap_err().to_string();
    assert_eq!(
        unknown,
        format!("invalid `model`: unknown model 'ccd-magic' (known: {MODEL_NAMES})")
    );
    // A typo near one name is told which it was (as clap does for option values).
    for (typo, near) in [
        ("scmos-randm", "scmos-random"),
        ("emccd-stochastc", "emccd-stochastic"),
    ] {
        let e = ModelSpec::parse(typo).unwrap_err().to_string();
        assert!(e.contains(&format!("; did you mean '{near}'?")), "{e}");
    }
    let e = ModelSpec::parse("scmos-median:1").unwrap_err().to_string();
    assert!(e.contains("scmos-median takes no :ARG"), "{e}");
    let bad = ModelSpec::parse("scmos-constant:-1")
        .unwrap_err()
        .to_string();
    assert_eq!(
        bad,
        "invalid `model`: 'scmos-constant:-1': sigma must be a number in [0, 10000] e-"
    );
    let huge = ModelSpec::parse("scmos-constant:1e20").unwrap_err();
    assert!(huge.to_string().contains("[0, 10000] e-"), "{huge}");
    let bad = ModelSpec::parse("scmos-fixed:x").unwrap_err().to_string();
    assert_eq!(
        bad,
        "invalid `model`: 'scmos-fixed:x': pattern must be a whole number"
    );
    let Err(no_map) = ModelSpec::ScmosMap.build(&ModelParams::default(), 4) else {
        panic!("scmos-map built without a map")
    };
    assert_eq!(no_map.exit_code(), 2);
    assert!(
        no_map.to_string().starts_with("invalid `map`: "),
        "{no_map}"
    );
}
