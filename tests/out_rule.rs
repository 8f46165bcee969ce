//! The `--out` rule (issue 9, section 1): detnoise replaces only what it wrote, refuses bad
//! output paths before any work, and an interrupted run leaves nothing behind.

use assert_cmd::Command;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

/// A small bundled sCMOS dark stack (100 frames of 64x64, 0.25 e-/adu).
fn fixture() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("data-synthetic/scmos-darks-64x64.fits")
}

fn dn() -> Command {
    let mut c = Command::cargo_bin("detnoise").unwrap();
    // A refused run must stop before the work: a hang here means it did not.
    c.timeout(Duration::from_secs(60));
    c
}

/// The issue's directory: `mydata/darks.fits` and `mydata/notes.txt`.
fn mydata(root: &Path) -> PathBuf {
    let d = root.join("mydata");
    std::fs::create_dir(&d).unwrap();
    std::fs::copy(fixture(), d.join("darks.fits")).unwrap();
    std::fs::write(d.join("notes.txt"), "notes\n").unwrap();
    d
}

/// Every file under `dir` (relative path -> bytes), to show nothing was touched.
fn snapshot(dir: &Path) -> BTreeMap<PathBuf, Vec<u8>> {
    fn go(root: &Path, rel: &Path, out: &mut BTreeMap<PathBuf, Vec<u8>>) {
        for e in std::fs::read_dir(root.join(rel)).unwrap() {
            let e = e.unwrap();
            let p = rel.join(e.file_name());
            if e.file_type().unwrap().is_dir() {
                go(root, &p, out);
            } else {
                out.insert(p.clone(), std::fs::read(root.join(&p)).unwrap());
            }
        }
    }
    let mut out = BTreeMap::new();
    go(dir, Path::new(""), &mut out);
    out
}

/// Names in `dir`, sorted.
fn names(dir: &Path) -> Vec<String> {
    let mut v: Vec<String> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    v.sort();
    v
}

/// Run `cmd`, require exit code 2 and no panic; return stderr.
fn refused(cmd: &mut Command) -> String {
    let out = cmd.output().unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr).into_owned();
    assert_eq!(out.status.code(), Some(2), "stderr: {stderr}");
    assert!(!stderr.contains("panicked"), "{stderr}");
    stderr
}

fn report_quick(darks: &Path, out: &Path) -> Command {
    let mut c = dn();
    c.args(["report", "--gain-e-per-adu", "0.25", "--quick", "--darks"])
        .arg(darks)
        .args([
            "--subap", "4", "--spot", "airy:2", "--signal", "50", "--iters", "200",
        ])
        .arg("--out")
        .arg(out);
    c
}

/// A full report long enough (1e8 iterations) that only a refusal before the work ends it.
fn report_long(darks: &Path, out: &Path) -> Command {
    let mut c = dn();
    c.args([
        "report",
        "--gain-e-per-adu",
        "0.25",
        "--iters",
        "100000000",
        "--darks",
    ])
    .arg(darks)
    .arg("--out")
    .arg(out);
    c
}

fn darks(input: &Path, out: &Path) -> Command {
    let mut c = dn();
    c.arg("darks").arg(input).arg("--out").arg(out);
    c
}

/// `effective` on one configuration with `iters` iterations.
fn effective(out: &Path, iters: &str) -> Command {
    let mut c = dn();
    c.args([
        "effective",
        "--subap",
        "4",
        "--spot",
        "airy:2",
        "--signal",
        "50",
    ])
    .args(["--iters", iters, "--out"])
    .arg(out);
    c
}

fn manifest_files(dir: &Path) -> Vec<String> {
    let text = std::fs::read_to_string(dir.join(".detnoise-manifest.json")).unwrap();
    let v: serde_json::Value = serde_json::from_str(&text).unwrap();
    assert_eq!(v["tool"], "detnoise");
    v["files"]
        .as_array()
        .unwrap()
        .iter()
        .map(|f| f.as_str().unwrap().to_string())
        .collect()
}

#[test]
fn the_issue_mydata_scenario_keeps_the_input_and_the_notes() {
    let root = tempfile::tempdir().unwrap();
    let data = mydata(root.path());
    let before = snapshot(&data);
    for force in [false, true] {
        let mut c = report_long(&data.join("darks.fits"), &data);
        if force {
            c.arg("--force");
        }
        let err = refused(&mut c);
        assert!(
            err.contains("mydata") && err.contains("contains the input"),
            "{err}"
        );
        // Refused before the stack was read.
        assert!(!err.contains("dark frames"), "{err}");
    }
    // The same for a directory input, a glob input and an input map of `effective`.
    refused(&mut darks(&data, &data));
    refused(
        dn().arg("darks")
            .arg(data.join("*.fits"))
            .arg("--out")
            .arg(&data),
    );
    refused(
        effective(&data, "100000000")
            .args(["--model", "scmos-map", "--map"])
            .arg(data.join("darks.fits")),
    );
    // An output directory that contains the input's directory.
    refused(&mut darks(&data.join("darks.fits"), root.path()));
    assert_eq!(snapshot(&data), before);
    assert_eq!(names(root.path()), ["mydata"]);
}

#[test]
fn out_dot_inside_mydata_is_refused_by_any_spelling() {
    let root = tempfile::tempdir().unwrap();
    let data = mydata(root.path());
    let before = snapshot(&data);
    let abs = data.canonicalize().unwrap();
    for spelling in [".", "./", "../mydata", abs.to_str().unwrap()] {
        for force in [false, true] {
            let mut c = report_long(Path::new("darks.fits"), Path::new(spelling));
            c.current_dir(&data);
            if force {
                c.arg("--force");
            }
            let err = refused(&mut c);
            assert!(err.contains("current directory"), "{spelling}: {err}");
        }
    }
    let err = refused(
        darks(Path::new("darks.fits"), Path::new("."))
            .arg("--force")
            .current_dir(&data),
    );
    assert!(err.contains("current directory"), "{err}");
    let err = refused(
        effective(Path::new("."), "100000000")
            .arg("--force")
            .current_dir(&data),
    );
    assert!(err.contains("current directory"), "{err}");
    assert_eq!(snapshot(&data), before);
}

#[test]
fn a_rerun_replaces_a_directory_detnoise_wrote() {
    let root = tempfile::tempdir().unwrap();
    let out = root.path().join("maps");
    darks(&fixture(), &out)
        .args(["--gain-e-per-adu", "0.25"])
        .assert()
        .success();
    assert!(out.join("rms_e.fits").exists());
    let listed = manifest_files(&out);
    assert!(listed.contains(&"rms_e.fits".to_string()), "{listed:?}");
    // Without a gain the run writes no rms_e.fits: the replaced directory has none either.
    darks(&fixture(), &out).assert().success();
    assert!(!out.join("rms_e.fits").exists());
    let listed = manifest_files(&out);
    let mut present = names(&out);
    present.retain(|n| n != ".detnoise-manifest.json");
    assert_eq!(listed, present);
    for n in [
        "flags.fits",
        "offset_adu.fits",
        "rms_adu.fits",
        "summary.json",
    ] {
        assert!(listed.contains(&n.to_string()), "{n} in {listed:?}");
    }
    // report and effective too, and nothing is left beside the output.
    let rep = root.path().join("rep");
    for _ in 0..2 {
        report_quick(&fixture(), &rep).assert().success();
        effective(&root.path().join("eff"), "200")
            .assert()
            .success();
    }
    assert!(manifest_files(&rep).contains(&"index.html".to_string()));
    assert!(manifest_files(&root.path().join("eff")).contains(&"effective_noise.csv".into()));
    assert_eq!(names(root.path()), ["eff", "maps", "rep"]);
}

#[test]
fn a_user_file_blocks_a_rerun_and_survives_force() {
    let root = tempfile::tempdir().unwrap();
    let out = root.path().join("maps");
    darks(&fixture(), &out).assert().success();
    std::fs::write(out.join("notes.txt"), "mine\n").unwrap();
    let err = refused(&mut darks(&fixture(), &out));
    assert!(
        err.contains("maps") && err.contains("notes.txt") && err.contains("--force"),
        "{err}"
    );
    darks(&fixture(), &out)
        .args(["--force", "--gain-e-per-adu", "0.25"])
        .assert()
        .success();
    assert_eq!(
        std::fs::read_to_string(out.join("notes.txt")).unwrap(),
        "mine\n"
    );
    assert!(out.join("rms_e.fits").exists());
    let listed = manifest_files(&out);
    assert!(!listed.contains(&"notes.txt".to_string()), "{listed:?}");
    // --force again without a gain: the stale rms_e.fits (detnoise's) goes, the notes stay.
    darks(&fixture(), &out).arg("--force").assert().success();
    assert!(!out.join("rms_e.fits").exists());
    assert_eq!(
        std::fs::read_to_string(out.join("notes.txt")).unwrap(),
        "mine\n"
    );
    // Still refused without --force, by report too.
    refused(&mut darks(&fixture(), &out));
    let err = refused(&mut report_long(&fixture(), &out));
    assert!(err.contains("notes.txt"), "{err}");
    // A directory the user filled is written into only with --force, beside the files.
    let eff = root.path().join("eff");
    std::fs::create_dir(&eff).unwrap();
    std::fs::write(eff.join("plan.md"), "plan\n").unwrap();
    refused(&mut effective(&eff, "100000000"));
    effective(&eff, "200").arg("--force").assert().success();
    assert_eq!(
        std::fs::read_to_string(eff.join("plan.md")).unwrap(),
        "plan\n"
    );
    assert!(eff.join("effective_noise.csv").exists());
}

#[test]
fn force_never_replaces_a_foreign_file_with_an_output_name() {
    let root = tempfile::tempdir().unwrap();
    let out = root.path().join("maps");
    std::fs::create_dir(&out).unwrap();
    std::fs::write(out.join("summary.json"), "{\"mine\": 1}").unwrap();
    let before = snapshot(&out);
    let err = refused(darks(&fixture(), &out).arg("--force"));
    assert!(
        err.contains("summary.json") && err.contains("did not write"),
        "{err}"
    );
    let eff = root.path().join("eff");
    std::fs::create_dir(&eff).unwrap();
    std::fs::write(eff.join("effective_noise_S50.png"), "mine").unwrap();
    let err = refused(effective(&eff, "100000000").arg("--force"));
    assert!(err.contains("effective_noise_S50.png"), "{err}");
    assert_eq!(snapshot(&out), before);
    assert_eq!(
        std::fs::read(eff.join("effective_noise_S50.png")).unwrap(),
        b"mine"
    );
}

#[test]
fn a_failed_rerun_keeps_the_earlier_output() {
    let root = tempfile::tempdir().unwrap();
    let out = root.path().join("maps");
    darks(&fixture(), &out).assert().success();
    let before = snapshot(&out);
    let bad = root.path().join("bad.fits");
    std::fs::write(&bad, b"SIMPLE  =                    T").unwrap();
    let o = darks(&bad, &out).output().unwrap();
    assert_ne!(o.status.code(), Some(0));
    assert_eq!(snapshot(&out), before);
    assert_eq!(names(root.path()), ["bad.fits", "maps"]);
}

#[test]
fn out_naming_an_existing_file_is_refused() {
    let root = tempfile::tempdir().unwrap();
    let data = mydata(root.path());
    let notes = data.join("notes.txt");
    for force in [false, true] {
        let mut cmds = [
            report_long(&fixture(), &notes),
            darks(&fixture(), &notes),
            effective(&notes, "100000000"),
        ];
        for c in cmds.iter_mut() {
            if force {
                c.arg("--force");
            }
            let err = refused(c);
            assert!(
                err.contains("notes.txt") && err.contains("existing file"),
                "{err}"
            );
        }
    }
    assert_eq!(std::fs::read_to_string(&notes).unwrap(), "notes\n");
}

#[test]
fn home_root_and_an_unexpanded_tilde_are_refused() {
    let root = tempfile::tempdir().unwrap();
    let home = root.path().join("home");
    std::fs::create_dir(&home).unwrap();
    std::fs::write(home.join(".profile"), "x").unwrap();
    for out in [home.clone(), home.join("."), PathBuf::from("/")] {
        for force in [false, true] {
            let mut c = darks(&fixture(), &out);
            c.env("HOME", &home);
            if force {
                c.arg("--force");
            }
            let err = refused(&mut c);
            assert!(
                err.contains("home directory") || err.contains("root"),
                "{err}"
            );
        }
        let err = refused(report_long(&fixture(), &out).env("HOME", &home));
        assert!(
            err.contains("home directory") || err.contains("root"),
            "{err}"
        );
    }
    let err = refused(effective(Path::new("~/eff"), "100000000").current_dir(root.path()));
    assert!(err.contains("not expanded"), "{err}");
    assert_eq!(names(&home), [".profile"]);
    assert_eq!(names(root.path()), ["home"]);
}

#[test]
fn simulate_checks_its_files_before_the_work() {
    let root = tempfile::tempdir().unwrap();
    let d = root.path();
    let long = [
        "simulate",
        "--subap",
        "16",
        "--iters",
        "100000000",
        "--format",
        "csv",
    ];
    let err = refused(
        dn().args(long)
            .arg("--out")
            .arg(d.join("r.csv"))
            .arg("--plot")
            .arg(d.join("r.jpg")),
    );
    assert!(
        err.contains("r.jpg") && err.contains(".png or .svg"),
        "{err}"
    );
    let err = refused(
        dn().args(["simulate", "--iters", "100000000", "--out"])
            .arg(d.join("r.csv")),
    );
    assert!(
        err.contains("--format table") && err.contains(".txt"),
        "{err}"
    );
    assert!(names(d).is_empty());
    // An existing result is replaced only with --force.
    std::fs::write(d.join("r.csv"), "old").unwrap();
    let err = refused(dn().args(long).arg("--out").arg(d.join("r.csv")));
    assert!(err.contains("r.csv") && err.contains("--force"), "{err}");
    assert_eq!(std::fs::read_to_string(d.join("r.csv")).unwrap(), "old");
    let short = [
        "simulate",
        "--subap",
        "4",
        "--iters",
        "200",
        "--model",
        "scmos-median",
    ];
    dn().args(short)
        .args(["--format", "csv", "--force", "--out"])
        .arg(d.join("r.csv"))
        .arg("--plot")
        .arg(d.join("r.svg"))
        .assert()
        .success();
    assert!(std::fs::read_to_string(d.join("r.csv"))
        .unwrap()
        .starts_with("model,"));
    // An input is never an output, --force or not; nor is a directory.
    std::fs::write(d.join("map.txt"), "1").unwrap();
    let err = refused(
        dn().args(short)
            .args(["--force", "--map"])
            .arg(d.join("map.txt"))
            .arg("--out")
            .arg(d.join("map.txt")),
    );
    assert!(err.contains("is the input"), "{err}");
    let err = refused(dn().args(short).arg("--force").arg("--plot").arg(d));
    assert!(err.contains(".png or .svg"), "{err}");
    assert_eq!(names(d), ["map.txt", "r.csv", "r.svg"]);
}

#[test]
fn synth_checks_its_files_before_the_work() {
    let root = tempfile::tempdir().unwrap();
    let d = root.path();
    let synth = |out: &Path| {
        let mut c = dn();
        c.args([
            "synth",
            "--detector",
            "scmos",
            "--shape",
            "16x16",
            "--frames",
            "4",
            "--out",
        ])
        .arg(out);
        c
    };
    synth(&d.join("s.fits")).assert().success();
    let before = snapshot(d);
    assert_eq!(before.len(), 6, "{:?}", before.keys());
    let err = refused(&mut synth(&d.join("s.fits")));
    assert!(err.contains("s.fits") && err.contains("--force"), "{err}");
    // A file beside the stack (here its manifest) counts as an output too.
    std::fs::remove_file(d.join("s.fits")).unwrap();
    let err = refused(&mut synth(&d.join("s.fits")));
    assert!(err.contains("s.truth-offset_adu.fits"), "{err}");
    synth(&d.join("s.fits")).arg("--force").assert().success();
    let err = refused(synth(&d.join("t.fits")).args(["--format", "tiff"]));
    assert!(err.contains(".tif or .tiff"), "{err}");
    std::fs::create_dir(d.join("dir.fits")).unwrap();
    let err = refused(synth(&d.join("dir.fits")).arg("--force"));
    assert!(err.contains("is a directory"), "{err}");
    std::fs::remove_dir(d.join("dir.fits")).unwrap();
    // The noise map read by --rms-pdf is never overwritten.
    let map = d.join("s.truth-rms_e.fits");
    let err = refused(synth(&map).args(["--force", "--rms-pdf"]).arg(&map));
    assert!(err.contains("is the input"), "{err}");
    assert_eq!(snapshot(d).len(), 6);
    assert_eq!(
        snapshot(d).get(Path::new("s.truth-rms_e.fits")),
        before.get(Path::new("s.truth-rms_e.fits"))
    );
}

#[test]
fn unwritable_places_are_refused_without_showing_temporary_paths() {
    let root = tempfile::tempdir().unwrap();
    let data = mydata(root.path());
    let notes = data.join("notes.txt");
    // /proc refuses new entries even to root; a regular file cannot hold a directory.
    for parent in [Path::new("/proc"), notes.as_path()] {
        let out = parent.join("detnoise-x");
        let results = [
            refused(&mut darks(&fixture(), &out)),
            refused(&mut report_long(&fixture(), &out)),
            refused(&mut effective(&out, "100000000")),
            refused(
                dn().args(["simulate", "--iters", "100000000", "--out"])
                    .arg(parent.join("r.txt")),
            ),
            refused(
                dn().args(["synth", "--detector", "scmos", "--shape", "512x512"])
                    .args(["--frames", "100000", "--out"])
                    .arg(parent.join("s.fits")),
            ),
        ];
        for err in results {
            assert!(err.contains(&*parent.to_string_lossy()), "{err}");
            assert!(!err.contains("partial") && !err.contains("probe"), "{err}");
        }
    }
    assert_eq!(names(&data), ["darks.fits", "notes.txt"]);
}

#[test]
fn other_directory_commands_follow_the_rule() {
    let root = tempfile::tempdir().unwrap();
    let data = mydata(root.path());
    let map = data.join("darks.fits");
    // ptc refuses one file as darks and flat: the flat is a copy.
    let flat = data.join("flat.fits");
    std::fs::copy(&map, &flat).unwrap();
    let before = snapshot(&data);
    let cmds: Vec<Vec<std::ffi::OsString>> = vec![
        vec!["fit-pdf".into(), map.clone().into()],
        vec!["emgain".into(), map.clone().into()],
        vec![
            "ptc".into(),
            "--darks".into(),
            map.clone().into(),
            "--flats".into(),
            flat.clone().into(),
        ],
        vec!["paper".into(), "--iters".into(), "100000000".into()],
    ];
    let other = root.path().join("other");
    std::fs::create_dir(&other).unwrap();
    std::fs::write(other.join("keep.txt"), "k").unwrap();
    for args in &cmds {
        let err = refused(dn().args(args).arg("--out").arg(&data));
        assert!(
            err.contains("contains the input") || err.contains("holds files"),
            "{args:?}: {err}"
        );
        if args[0] != "paper" {
            let err = refused(dn().args(args).arg("--out").arg(&data).arg("--force"));
            assert!(err.contains("contains the input"), "{args:?}: {err}");
        }
        let err = refused(dn().args(args).arg("--out").arg(&other));
        assert!(err.contains("keep.txt"), "{args:?}: {err}");
        let err = refused(dn().args(args).arg("--out").arg(data.join("notes.txt")));
        assert!(err.contains("existing file"), "{args:?}: {err}");
    }
    assert_eq!(snapshot(&data), before);
    assert_eq!(names(&other), ["keep.txt"]);
}

/// A `*partial*` temporary anywhere under `dir`.
fn holds_partial(dir: &Path) -> bool {
    std::fs::read_dir(dir)
        .into_iter()
        .flatten()
        .flatten()
        .any(|e| {
            e.file_name().to_string_lossy().contains("partial")
                || (e.file_type().is_ok_and(|t| t.is_dir()) && holds_partial(&e.path()))
        })
}

/// Start `args`, wait for a temporary beside the output, send `signal`, and require exit
/// code 130 with nothing left in `dir` but `keep`.
fn interrupt(args: &[&str], out: &Path, dir: &Path, signal: &str, keep: &[&str]) {
    let mut child = std::process::Command::new(env!("CARGO_BIN_EXE_detnoise"))
        .args(args)
        .arg("--out")
        .arg(out)
        .stdout(std::process::Stdio::null())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    let start = Instant::now();
    while !holds_partial(dir) {
        assert!(
            child.try_wait().unwrap().is_none(),
            "{args:?} ended before the signal"
        );
        assert!(
            start.elapsed() < Duration::from_secs(30),
            "no temporary appeared"
        );
        std::thread::sleep(Duration::from_millis(20));
    }
    // A moment of real work, so the signal lands mid-run.
    std::thread::sleep(Duration::from_millis(300));
    let pid = child.id().to_string();
    let killed = std::process::Command::new("kill")
        .args([signal, &pid])
        .status()
        .unwrap();
    assert!(killed.success());
    let start = Instant::now();
    let status = loop {
        if let Some(s) = child.try_wait().unwrap() {
            break s;
        }
        if start.elapsed() > Duration::from_secs(30) {
            let _ = child.kill();
            panic!("{args:?} did not stop after {signal}");
        }
        std::thread::sleep(Duration::from_millis(20));
    };
    let mut stderr = String::new();
    std::io::Read::read_to_string(child.stderr.as_mut().unwrap(), &mut stderr).unwrap();
    assert_eq!(status.code(), Some(130), "{args:?} {signal}: {stderr}");
    assert_eq!(names(dir), keep, "{args:?} {signal}: {stderr}");
}

#[test]
fn an_interrupted_run_leaves_nothing_behind() {
    let root = tempfile::tempdir().unwrap();
    let d = root.path();
    let fx = fixture();
    let fx = fx.to_str().unwrap();
    let eff = [
        "effective",
        "--subap",
        "16",
        "--spot",
        "airy:2",
        "--signal",
        "50",
        "--iters",
        "100000000",
    ];
    interrupt(&eff, &d.join("eff"), d, "-TERM", &[]);
    interrupt(&eff, &d.join("eff"), d, "-INT", &[]);
    // Parents created for the output go too.
    interrupt(&eff, &d.join("new/deeper/eff"), d, "-INT", &[]);
    let report = [
        "report",
        "--gain-e-per-adu",
        "0.25",
        "--iters",
        "100000000",
        "--darks",
        fx,
    ];
    interrupt(&report, &d.join("rep"), d, "-TERM", &[]);
    let synth = [
        "synth",
        "--detector",
        "scmos",
        "--shape",
        "512x512",
        "--frames",
        "100000",
    ];
    interrupt(&synth, &d.join("s.fits"), d, "-INT", &[]);
    // An interrupted rerun keeps the earlier output whole.
    effective(&d.join("eff"), "200").assert().success();
    let before = snapshot(&d.join("eff"));
    interrupt(&eff, &d.join("eff"), d, "-TERM", &["eff"]);
    assert_eq!(snapshot(&d.join("eff")), before);
}
