//! Tests of the value parsers and the sweep options.

use super::super::fields::to_cli;
use super::*;
use crate::calib::{Map, Unit};
use crate::detector::register::{MAX_EM_GAIN, MAX_STAGES};
use std::ops::Bound::Included;

#[test]
fn real_parser_states_the_range_and_refuses_non_finite_values() {
    let qe = real(Excluded(0.0), Included(1.0), "");
    assert_eq!(qe("0.7"), Ok(0.7));
    assert_eq!(qe("1"), Ok(1.0));
    for bad in ["0", "80", "-1", "nan", "inf", "x", ""] {
        assert_eq!(qe(bad), Err("must be a number in (0, 1]".into()), "{bad}");
    }
    let noise = real(Included(0.0), Unbounded, "e-");
    assert_eq!(noise("0"), Ok(0.0));
    assert_eq!(noise("-1"), Err("must be a number >= 0 e-".into()));
    let gain = real(Included(1.0), Included(MAX_EM_GAIN), "e-/e-");
    assert_eq!(
        gain("1e9"),
        Err("must be a number in [1, 10000] e-/e-".into())
    );
}

#[test]
fn whole_parser_accepts_exponent_notation_and_states_the_range() {
    let iters = whole::<u64>(2, SimConfig::MAX_ITERS, "frames");
    assert_eq!(iters("10000"), Ok(10_000));
    assert_eq!(iters("1e6"), Ok(1_000_000));
    for bad in ["0", "1", "-1", "2.5", "1e10", "many"] {
        assert_eq!(
            iters(bad),
            Err("must be a whole number from 2 to 1000000000 frames".into()),
            "{bad}"
        );
    }
    let stages = whole::<u32>(1, MAX_STAGES as u64, "stages");
    assert!(stages("4294967296").is_err());
    assert_eq!(
        whole::<u64>(0, u64::MAX, "")("18446744073709551615"),
        Ok(u64::MAX)
    );
}

#[test]
fn each_list_option_names_itself() {
    for (text, option) in [("4;8", "--subap"), ("x", "--signal")] {
        let e = parse_list::<usize>(text, option).unwrap_err().to_string();
        assert!(e.contains(option), "{e}");
    }
    let sweep = |subap: &str, signal: &str| {
        let mut args = SweepArgs::default();
        let v = &mut args.values;
        v.set(&settings::SUBAP_PX, settings::Value::Text(subap.into()));
        v.set(
            &settings::SIGNAL_PHOTONS,
            settings::Value::Text(signal.into()),
        );
        v.set(&settings::ITERS, settings::Value::Whole(100));
        args
    };
    // As the command line shows them: the library names fields, the CLI maps them to flags.
    let shown = |s: SweepArgs| to_cli(s.validate().unwrap_err()).to_string();
    let e = shown(sweep("0", "50"));
    assert!(e.contains("--subap") && !e.contains("--signal"), "{e}");
    let e = shown(sweep("8", "-5"));
    assert!(e.contains("--signal") && !e.contains("--subap"), "{e}");
    sweep("2,8", "20,1e9").validate().unwrap();
}

/// The detector options as parsed from `args`.
fn detector(args: &[&str]) -> DetectorArgs {
    use clap::Parser;
    #[derive(clap::Parser)]
    struct Cli {
        #[command(flatten)]
        d: DetectorArgs,
    }
    Cli::try_parse_from([&["x"], args].concat()).unwrap().d
}

#[test]
fn each_real_noise_model_names_the_options_it_needs() {
    let models = |m: &str| parse_models(m).unwrap();
    for (model, given, flag) in [
        ("scmos-rts", &["--rts-table", "rts.csv"][..], "--map"),
        ("scmos-rts", &["--map", "m.fits"][..], "--rts-table"),
        (
            "scmos-correlated",
            &["--map", "m.fits", "--column-noise-e", "0.2"][..],
            "--row-noise-e",
        ),
        (
            "scmos-correlated",
            &["--map", "m.fits", "--row-noise-e", "0.2"][..],
            "--column-noise-e",
        ),
        ("scmos-frames", &[][..], "--dark-frames"),
        (
            "scmos-frames",
            &["--dark-frames", "d.fits"][..],
            "--gain-e-per-adu",
        ),
    ] {
        let e = detector(given).validate(&models(model)).unwrap_err();
        let shown = to_cli(e).to_string();
        assert!(
            shown.starts_with(&format!("invalid option {flag}: ")),
            "{model}: {shown}"
        );
        assert!(shown.contains(flag), "{shown}");
    }
    let full = detector(&[
        "--map",
        "m.fits",
        "--rts-table",
        "rts.csv",
        "--row-noise-e",
        "0.3",
        "--column-noise-e",
        "0",
        "--dark-frames",
        "a.fits",
        "b.fits",
        "--gain-e-per-adu",
        "0.25",
    ]);
    full.validate(&models("scmos-rts,scmos-correlated,scmos-frames,scmos-map"))
        .unwrap();
    assert_eq!(full.values.paths(&settings::DARK_FRAMES).len(), 2);
    assert_eq!(
        full.values.real(&settings::DARK_FRAMES_MAX_MIB),
        Some(512.0)
    );
    let inputs = full.input_files();
    for f in ["m.fits", "rts.csv", "a.fits", "b.fits"] {
        assert!(
            inputs.contains(&std::path::PathBuf::from(f)),
            "{f}: {inputs:?}"
        );
    }
}

#[test]
fn the_models_parameters_are_read_from_their_files() {
    // A 2x3 map, an rts.csv with one ok and one imprecise row, and 4 dark frames.
    let dir = tempfile::tempdir().unwrap();
    let path = |n: &str| dir.path().join(n).display().to_string();
    Map::new(2, 3, vec![1.0; 6], Unit::Electrons)
        .write_fits(dir.path().join("m.fits").as_path(), &[])
        .unwrap();
    use crate::detector::rts_table::fixture::{row, table};
    let levels = [(-1.0, 0.5, 0.1), (1.0, 0.5, 0.1)];
    let rts = table(&[
        row(2, 1, "ok", &levels, true),
        row(0, 0, "imprecise", &levels, true),
    ]);
    std::fs::write(dir.path().join("rts.csv"), rts).unwrap();
    let mut k = 0.0;
    let mut next = || {
        k += 1.0;
        vec![50.0 + k; 6]
    };
    crate::io::fits::write_cube(&dir.path().join("d.fits"), (2, 3), 4, true, &mut next, &[])
        .unwrap();
    let (m, r, d) = (path("m.fits"), path("rts.csv"), path("d.fits"));
    let args = detector(&[
        "--map",
        &m,
        "--rts-table",
        &r,
        "--row-noise-e",
        "0.3",
        "--column-noise-e",
        "0.1",
        "--dark-frames",
        &d,
        "--gain-e-per-adu",
        "0.5",
    ]);
    let p = args.params().unwrap();
    let t = p.rts_table.as_ref().unwrap();
    assert_eq!((t.pixels.len(), t.skipped), (1, 1));
    assert_eq!((p.row_noise_e, p.column_noise_e), (Some(0.3), Some(0.1)));
    let frames = p.dark_frames.as_ref().unwrap();
    assert_eq!(
        (frames.kept(), frames.total, frames.gain_e_per_adu),
        (4, 4, 0.5)
    );
    for model in ["scmos-rts", "scmos-correlated", "scmos-frames"] {
        let built = ModelSpec::parse(model).unwrap().build(&p, 2).unwrap();
        assert_eq!(built.name(), model);
    }
    // A table without levels in e- is refused; the command line names the option to use.
    let adu = table(&[row(2, 1, "ok", &levels, false)]);
    std::fs::write(dir.path().join("adu.csv"), adu).unwrap();
    let a = path("adu.csv");
    let e = to_cli(detector(&["--rts-table", &a]).params().unwrap_err()).to_string();
    assert!(
        e.contains("adu.csv: line 2") && e.contains("--gain-e-per-adu"),
        "{e}"
    );
    // A table pixel outside the map names the table and its line.
    let far = table(&[row(3, 0, "ok", &levels, true)]);
    std::fs::write(dir.path().join("far.csv"), far).unwrap();
    let f = path("far.csv");
    let p = detector(&["--map", &m, "--rts-table", &f])
        .params()
        .unwrap();
    let Err(e) = ModelSpec::parse("scmos-rts").unwrap().build(&p, 2) else {
        panic!("built with a pixel outside the map")
    };
    assert!(
        e.to_string()
            .contains("far.csv: line 2: pixel (x_px 3, y_px 0) is outside"),
        "{e}"
    );
}

#[test]
fn the_model_list_in_the_help_names_the_new_models_options() {
    let mut cmd = super::super::command();
    let sub = cmd.find_subcommand_mut("simulate").expect("simulate");
    let help = sub.render_long_help().to_string();
    for (model, flags) in [
        ("scmos-rts", &["--map", "--rts-table"][..]),
        (
            "scmos-correlated",
            &["--map", "--row-noise-e", "--column-noise-e"][..],
        ),
        ("scmos-frames", &["--dark-frames"][..]),
    ] {
        // The list's line of the model (wrapped by clap): from its name to the end of its
        // `(uses ...)`.
        let flat = help.split_whitespace().collect::<Vec<_>>().join(" ");
        let list = &flat[flat.find("Models (NAME[:ARG]):").expect("model list")..];
        let start = list.find(&format!(" {model} ")).expect("model in the list");
        let uses = start + list[start..].find("(uses ").expect("(uses ...)");
        let line = &list[start..uses + list[uses..].find(')').expect("(uses ...)")];
        for flag in flags {
            assert!(line.contains(flag), "{line}");
        }
        assert!(!line.contains('`'), "{line}");
    }
    for flag in ["--dark-frames-max-mib", "--gain-e-per-adu", "--rts-table"] {
        assert!(help.contains(flag), "{flag}");
    }
}
