//! Option values are checked before any work (issue 9, sections 2, 4 and 6): every bad value
//! is refused with exit code 2 and a message naming the option as the user spells it, before
//! an input frame is read or an output appears; exit codes follow the documented rule.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};
use std::time::{Duration, Instant};

/// A refusal must not wait for the input: reading the 4 GiB stack below would take far longer.
const PROMPT: Duration = Duration::from_secs(5);

fn detnoise(args: &[&str]) -> (Output, Duration) {
    let t = Instant::now();
    let out = Command::new(env!("CARGO_BIN_EXE_detnoise"))
        .args(args)
        .output()
        .expect("run detnoise");
    (out, t.elapsed())
}

/// A scratch directory with a 4 GiB sparse file `big.fits` (zeros: not a valid stack, so a
/// run that read it would fail naming the file with exit code 1, after reading it).
struct Scratch {
    dir: tempfile::TempDir,
}

impl Scratch {
    fn new() -> Self {
        let dir = tempfile::tempdir().unwrap();
        let big = std::fs::File::create(dir.path().join("big.fits")).unwrap();
        big.set_len(4 << 30).unwrap();
        Scratch { dir }
    }

    fn path(&self, name: &str) -> String {
        self.dir.path().join(name).display().to_string()
    }

    /// Every entry of the directory besides the input.
    fn outputs(&self) -> Vec<PathBuf> {
        let mut found = Vec::new();
        collect(self.dir.path(), &mut found);
        found.retain(|p| !p.ends_with("big.fits"));
        found
    }
}

fn collect(dir: &Path, found: &mut Vec<PathBuf>) {
    for e in std::fs::read_dir(dir).unwrap() {
        let p = e.unwrap().path();
        if p.is_dir() {
            collect(&p, found);
        }
        found.push(p);
    }
}

/// Run `args` (`BIG` and `OUT` replaced by the scratch paths); assert a prompt refusal with
/// exit code 2 whose message contains every needle, no panic, and nothing written.
fn refused(args: &[&str], needles: &[&str]) {
    let s = Scratch::new();
    let (big, out, out_fits) = (s.path("big.fits"), s.path("out"), s.path("out.fits"));
    let args: Vec<&str> = args
        .iter()
        .map(|a| match *a {
            "BIG" => big.as_str(),
            "OUT" => out.as_str(),
            // synth writes one stack file, whose name must carry the format's extension.
            "OUT.fits" => out_fits.as_str(),
            a => a,
        })
        .collect();
    let (o, took) = detnoise(&args);
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(2), "{args:?}: {err}");
    for n in needles {
        assert!(err.contains(n), "{args:?}: {err:?} should contain {n:?}");
    }
    assert!(!err.contains("panicked"), "{args:?}: {err}");
    assert!(took < PROMPT, "{args:?} took {took:?}");
    assert!(s.outputs().is_empty(), "{args:?} wrote {:?}", s.outputs());
}

#[test]
fn simulate_and_effective_name_each_bad_option_and_its_range() {
    let cases: &[(&[&str], &[&str])] = &[
        (&["--iters", "0"], &["--iters", "from 2 to"]),
        (&["--iters", "-1"], &["--iters", "from 2 to"]),
        (&["--qe", "80"], &["--qe", "(0, 1]"]),
        (&["--qe", "0"], &["--qe", "(0, 1]"]),
        (&["--subap", "0"], &["--subap", "2 to 128"]),
        (&["--signal", "-5"], &["--signal", "> 0"]),
        (&["--signal", "0"], &["--signal", "> 0"]),
        (&["--max-empty-frac", "2"], &["--max-empty-frac", "[0, 1]"]),
        (
            &["--max-empty-frac", "-0.1"],
            &["--max-empty-frac", "[0, 1]"],
        ),
        (&["--threads", "0"], &["--threads", "from 1 to"]),
        (&["--sigma", "-1"], &["--sigma", "[0, 10000] e-"]),
        (&["--seed", "-1"], &["--seed", "whole number"]),
        (
            &["--pattern-seed", "x"],
            &["--pattern-seed", "whole number"],
        ),
        (
            &["--gaussian-switch", "-3"],
            &["--gaussian-switch", "whole number"],
        ),
        (&["--pp-lambda", "0"], &["--pp-lambda", "(0, 100000]"]),
        (&["--position-range", "-1"], &["--position-range", ">= 0"]),
        (&["--spot", "airy:0"], &["--spot", ">= 0.1 px"]),
        (&["--bg-grid", "5:1:1"], &["--bg-grid", "start <= stop"]),
        (&["--bg-grid", "-1:2:1"], &["--bg-grid", "0 <= start"]),
        (&["--model", "ccd-magic"], &["--model", "unknown model"]),
        (&["--model", "scmos-map"], &["--map"]),
        (
            &["--pdf-model", "empirical"],
            &["--pdf-model", "--pdf FILE"],
        ),
    ];
    for (args, needles) in cases {
        let mut a = vec!["simulate"];
        a.extend_from_slice(args);
        refused(&a, needles);
    }
    for (args, needles) in [
        (["--subap", "1"], ["--subap", "2 to 128"]),
        (["--iters", "0"], ["--iters", "from 2 to"]),
        (["--qe", "80"], ["--qe", "(0, 1]"]),
        (["--model", "nope"], ["--model", "unknown model"]),
        (["--stages", "8"], ["--stages", "at least 9 stages"]),
    ] {
        let mut a = vec!["effective", "--out", "OUT"];
        a.extend_from_slice(&args);
        refused(&a, &needles);
    }
}

#[test]
fn negative_values_reach_the_range_check_in_every_spelling() {
    // Not clap's "unexpected argument '-1' found": the option and its range.
    refused(
        &["simulate", "--emccd-read-noise=-1"],
        &["--emccd-read-noise", "[0, 10000] e-"],
    );
    refused(
        &["simulate", "--emccd-read-noise", "-1"],
        &["--emccd-read-noise", "[0, 10000] e-"],
    );
    let (o, _) = detnoise(&["simulate", "--emccd-read-noise=-1"]);
    assert!(!String::from_utf8_lossy(&o.stderr).contains("--sigma"));
    refused(
        &[
            "report",
            "--darks",
            "BIG",
            "--out",
            "OUT",
            "--gain-e-per-adu",
            "-1",
        ],
        &["--gain-e-per-adu", "(0, 10000] e- per adu"],
    );
    refused(
        &["darks", "BIG", "--out", "OUT", "--clip", "-3"],
        &["--clip", "from 0 to"],
    );
}

#[test]
fn report_checks_every_option_before_reading_the_darks() {
    let base = ["report", "--darks", "BIG", "--out", "OUT", "--quick"];
    let cases: &[(&[&str], &[&str])] = &[
        (
            &["--gain-e-per-adu", "0"],
            &["--gain-e-per-adu", "(0, 10000]"],
        ),
        (&["--gain-e-per-adu", "1", "--iters", "0"], &["--iters"]),
        (
            &["--gain-e-per-adu", "1", "--subap", "0"],
            &["--subap", "2 to 128"],
        ),
        (&["--gain-e-per-adu", "1", "--subap", "4,1"], &["--subap"]),
        (
            &["--gain-e-per-adu", "1", "--signal", "0"],
            &["--signal", "> 0"],
        ),
        (
            &["--gain-e-per-adu", "1", "--signal", "1e12"],
            &["--signal", "1e9"],
        ),
        (&["--gain-e-per-adu", "1", "--spot", "airy:0"], &["--spot"]),
        (
            &["--gain-e-per-adu", "1", "--qe", "80"],
            &["--qe", "(0, 1]"],
        ),
        (
            &["--gain-e-per-adu", "1", "--qe-emccd", "0"],
            &["--qe-emccd"],
        ),
        (
            &["--gain-e-per-adu", "1", "--stages", "8"],
            &["--stages", "--em-gain"],
        ),
        (&[], &["--gain-e-per-adu", "--flats"]),
        (
            &["--gain-e-per-adu", "1", "--flats", "BIG"],
            &["--gain-e-per-adu", "not both"],
        ),
        (&["--detector", "emccd"], &["--gain-e-per-adu"]),
        (
            &[
                "--detector",
                "emccd",
                "--gain-e-per-adu",
                "1",
                "--flats",
                "BIG",
            ],
            &["--flats"],
        ),
    ];
    for (args, needles) in cases {
        let mut a = base.to_vec();
        a.extend_from_slice(args);
        refused(&a, needles);
    }
    // `--subap 0` names --subap alone (it used to say --subap/--signal).
    let (o, _) = detnoise(&[
        "report",
        "--darks",
        "x.fits",
        "--out",
        "o",
        "--gain-e-per-adu",
        "1",
        "--subap",
        "0",
    ]);
    assert!(!String::from_utf8_lossy(&o.stderr).contains("--signal"));
}

#[test]
fn calibration_commands_check_their_options_before_reading() {
    let cases: &[(&[&str], &[&str])] = &[
        (
            &["darks", "BIG", "--out", "OUT", "--gain-e-per-adu", "0"],
            &["--gain-e-per-adu"],
        ),
        (
            &["darks", "BIG", "--out", "OUT", "--sigma-clip", "0"],
            &["--sigma-clip", "(0, 1000]"],
        ),
        (
            &["darks", "BIG", "--out", "OUT", "--hot-sigma", "-1"],
            &["--hot-sigma"],
        ),
        (
            &["darks", "BIG", "--out", "OUT", "--dead-fraction", "2"],
            &["--dead-fraction", "[0, 1]"],
        ),
        (
            &["darks", "BIG", "--out", "OUT", "--rts-sigma", "0"],
            &["--rts-sigma"],
        ),
        (
            &[
                "ptc",
                "--darks",
                "BIG",
                "--flats",
                "BIG",
                "--out",
                "OUT",
                "--em-gain",
                "0",
            ],
            &["--em-gain", "[1, 10000]"],
        ),
        (
            &[
                "ptc",
                "--darks",
                "BIG",
                "--flats",
                "BIG",
                "--out",
                "OUT",
                "--excess-noise-factor-sq",
                "3",
            ],
            &["--excess-noise-factor-sq", "[1, 2]"],
        ),
        (
            &[
                "ptc",
                "--darks",
                "BIG",
                "--flats",
                "BIG",
                "--out",
                "OUT",
                "--saturation-adu",
                "-5",
            ],
            &["--saturation-adu", "> 0"],
        ),
        (
            &["fit-pdf", "BIG", "--out", "OUT", "--unit", "adu"],
            &["--gain-e-per-adu"],
        ),
        (
            &["fit-pdf", "BIG", "--out", "OUT", "--gain-e-per-adu", "2"],
            &["--gain-e-per-adu", "--unit adu"],
        ),
        (
            &["fit-pdf", "BIG", "--out", "OUT", "--models", "nope"],
            &["--models", "unknown model"],
        ),
        (
            &["fit-pdf", "BIG", "--out", "OUT", "--upper-cut-e", "0"],
            &["--upper-cut-e", "> 0"],
        ),
        (
            &["emgain", "BIG", "--out", "OUT", "--gain-e-per-adu", "-1"],
            &["--gain-e-per-adu"],
        ),
        (
            &["emgain", "BIG", "--out", "OUT", "--stages", "0"],
            &["--stages", "from 1 to 2000"],
        ),
        (
            &["emgain", "BIG", "--out", "OUT", "--law", "register"],
            &["--gain-e-per-adu", "conversion gain"],
        ),
        (
            &["emgain", "BIG", "--out", "OUT", "--bin-width-adu", "0"],
            &["--bin-width-adu", "> 0"],
        ),
        (
            &["emgain", "BIG", "--out", "OUT", "--max-value-adu", "inf"],
            &["--max-value-adu"],
        ),
        (
            &["emgain", "BIG", "--out", "OUT", "--reference-stack", "BIG"],
            &["--reference-offset"],
        ),
        (
            &["paper", "--out", "OUT", "--iters", "1"],
            &["--iters", "from 2 to"],
        ),
        (&["paper", "--out", "OUT", "--seed", "-2"], &["--seed"]),
    ];
    for (args, needles) in cases {
        refused(args, needles);
    }
}

#[test]
fn synth_checks_its_options_before_writing() {
    let base = ["synth", "--detector", "emccd", "--out", "OUT.fits"];
    let cases: &[(&[&str], &[&str])] = &[
        (
            &["--shape", "8x8", "--frames", "0"],
            &["--frames", "from 1 to"],
        ),
        (&["--shape", "0x8", "--frames", "2"], &["--shape"]),
        (
            &["--shape", "100000x100000", "--frames", "2"],
            &["--shape", "16777216 pixels"],
        ),
        (
            &["--shape", "8x8", "--frames", "2", "--light-e", "-1"],
            &["--light-e"],
        ),
        (
            &["--shape", "8x8", "--frames", "2", "--light-e", "1e12"],
            &["--light-e"],
        ),
        (
            &["--shape", "8x8", "--frames", "2", "--em-gain", "0.5"],
            &["--em-gain", "[1, 10000]"],
        ),
        (
            &[
                "--shape",
                "8x8",
                "--frames",
                "2",
                "--em-gain",
                "500",
                "--stages",
                "8",
            ],
            &["--stages", "--em-gain", "at least 9 stages"],
        ),
        (
            &["--shape", "8x8", "--frames", "2", "--gain-spread", "2"],
            &["--gain-spread"],
        ),
        (
            &["--shape", "8x8", "--frames", "2", "--cic-e", "-1"],
            &["--cic-e"],
        ),
        (
            &["--shape", "8x8", "--frames", "2", "--read-noise-e", "-1"],
            &["--read-noise-e"],
        ),
    ];
    for (args, needles) in cases {
        let mut a = base.to_vec();
        a.extend_from_slice(args);
        refused(&a, needles);
    }
    refused(
        &[
            "synth",
            "--detector",
            "scmos",
            "--out",
            "OUT.fits",
            "--shape",
            "8x8",
            "--frames",
            "2",
            "--rms-pdf",
            "-1",
        ],
        &["--rms-pdf"],
    );
}

#[test]
fn engine_limits_are_refused_with_the_limit_and_its_reason() {
    // Stages against gain: p = g^(1/N) - 1 must be at most 1; 500 needs 9 stages.
    for args in [
        ["--register", "cascade", "--stages", "1"],
        ["--register", "exact", "--stages", "1"],
        ["--register", "exact", "--stages", "8"],
    ] {
        let mut a = vec!["simulate", "--model", "emccd-stochastic"];
        a.extend_from_slice(&args);
        refused(
            &a,
            &["--stages", "--em-gain", "at least 9 stages", "at most 1"],
        );
    }
    // Cost and memory grow with the gain: bounded, with the bound in the message.
    refused(
        &["simulate", "--em-gain", "1e9"],
        &["--em-gain", "[1, 10000]"],
    );
    refused(
        &["simulate", "--em-gain", "0.5"],
        &["--em-gain", "[1, 10000]"],
    );
    // The EM gain has one name in every command; the old `--gain` (which `report` took silently
    // as an EM gain beside `--gain-e-per-adu`) is refused, naming both options.
    for cmd in ["simulate", "effective", "report"] {
        refused(
            &[cmd, "--gain", "0.25"],
            &["--gain", "--em-gain", "--gain-e-per-adu"],
        );
    }
    // The spot stays mostly inside the sub-aperture: a quarter of the side.
    refused(
        &["simulate", "--position-range", "1e9"],
        &["--position-range", "0 to 4 px for 16x16"],
    );
    refused(
        &["simulate", "--subap", "4", "--position-range", "1.01"],
        &["--position-range", "0 to 1 px for 4x4"],
    );
    // Precision ends where a pixel's 32-bit count could overflow.
    refused(
        &["simulate", "--signal", "1e12"],
        &["--signal", "1e12 photo-electrons", "at most 1e9", "32-bit"],
    );
    refused(
        &["simulate", "--signal", "2e9", "--qe", "0.9"],
        &["--signal", "at most 1e9"],
    );
    // One pixel carries no centroid information: no R = 0 and no "ok" sigma_eff of 0.165 e-.
    refused(
        &["simulate", "--subap", "1"],
        &["--subap", "2 to 128", "one pixel"],
    );
    refused(
        &["effective", "--subap", "1", "--out", "OUT"],
        &["--subap", "2 to 128"],
    );
    // The real limit of a background grid is its number of levels.
    refused(
        &["simulate", "--bg-grid", "0:1000:0.001"],
        &["--bg-grid", "1000001 levels", "at most 100000"],
    );
}

#[test]
fn runs_at_the_engine_limits_succeed_promptly() {
    // At the limits the engine works and its cost does not grow with the value: the exact
    // register at its largest gain and at the fewest stages, and the largest signal with the
    // O(signal) sampler that bright pixels no longer use.
    for args in [
        vec![
            "--subap",
            "4",
            "--model",
            "emccd-stochastic",
            "--em-gain",
            "10000",
        ],
        vec![
            "--subap",
            "4",
            "--model",
            "emccd-stochastic",
            "--stages",
            "9",
        ],
        vec![
            "--subap",
            "4",
            "--model",
            "emccd-stochastic",
            "--register",
            "cascade",
            "--stages",
            "9",
        ],
        vec![
            "--subap",
            "4",
            "--model",
            "emccd-stochastic,emccd-simple,scmos-random",
            "--signal",
            "1e9",
        ],
        vec![
            "--subap",
            "2",
            "--model",
            "scmos-median",
            "--position-range",
            "0.5",
        ],
    ] {
        let mut a = vec!["simulate", "--iters", "16", "--format", "csv"];
        a.extend_from_slice(&args);
        let (o, took) = detnoise(&a);
        assert_eq!(
            o.status.code(),
            Some(0),
            "{a:?}: {}",
            String::from_utf8_lossy(&o.stderr)
        );
        assert!(took < Duration::from_secs(60), "{a:?} took {took:?}");
    }
}

#[test]
fn exit_codes_are_documented_in_every_help_and_followed() {
    let (o, _) = detnoise(&["--help"]);
    assert_eq!(o.status.code(), Some(0));
    let top = String::from_utf8_lossy(&o.stdout).to_string();
    for code in ["Exit status", "0 ", "1 ", "2 ", "130"] {
        assert!(top.contains(code), "{top}");
    }
    for sub in [
        "simulate",
        "effective",
        "paper",
        "report",
        "darks",
        "fit-pdf",
        "emgain",
        "ptc",
        "synth",
    ] {
        let (o, _) = detnoise(&[sub, "--help"]);
        assert_eq!(o.status.code(), Some(0), "{sub}");
        let help = String::from_utf8_lossy(&o.stdout);
        assert!(
            help.contains("Exit status") && help.contains("130"),
            "{sub}: {help}"
        );
    }
    // clap's own usage errors are 2 as well.
    for args in [
        vec!["simulate", "--no-such-option"],
        vec!["no-such-command"],
        vec!["darks"],
    ] {
        let (o, _) = detnoise(&args);
        assert_eq!(o.status.code(), Some(2), "{args:?}");
    }
    // Bad data and I/O failures are 1, naming the file.
    let s = Scratch::new();
    let garbage = s.path("garbage.fits");
    std::fs::write(&garbage, b"SIMPLE  =                    T").unwrap();
    let out = s.path("maps");
    let missing = s.path("missing.fits");
    for input in [&garbage, &missing] {
        let (o, _) = detnoise(&["darks", input, "--out", &out]);
        let err = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(1), "{err}");
        let name = Path::new(input).file_name().unwrap().to_string_lossy();
        assert!(err.contains(name.as_ref()), "{err}");
    }
    let (o, _) = detnoise(&["fit-pdf", &garbage, "--out", &out]);
    assert_eq!(o.status.code(), Some(1));
    // A usage error found with a bad input present is still 2: options come first.
    let (o, _) = detnoise(&["darks", &garbage, "--out", &out, "--hot-sigma", "0"]);
    assert_eq!(o.status.code(), Some(2));
}
