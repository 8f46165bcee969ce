//! Issue 30's hostile RTS tables and absurd amplitudes through the command line: a table with
//! a byte-order mark or quoted cells reads as the plain one, a table without an `ok` row or
//! with a level beyond a full well is refused, and amplitudes beyond any camera's are refused
//! by their option (or, where no option bounds them, by the Monte-Carlo) instead of giving
//! an empty R. No output is written by a refused run.

mod common;

use std::path::Path;

use common::{data, detnoise};

/// The header of `rts.csv` as `darks` writes it.
fn header() -> String {
    let mut cols = vec!["x_px,y_px,n_levels,status".to_string()];
    for k in 1..=3 {
        cols.push(format!(
            "level_{k}_adu,level_{k}_se_adu,level_{k}_e,occupancy_{k},occupancy_{k}_se,\
             width_{k}_adu,width_{k}_e,dwell_{k}_frames,dwell_{k}_se_frames"
        ));
    }
    cols.join(",")
}

/// A two-level row at (x, y) with `status`, level 1 at `level_e` e-.
fn row(x: usize, y: usize, status: &str, level_e: f64) -> String {
    format!(
        "{x},{y},2,{status},-24,0.02,{level_e},0.25,0.01,1.2,0.3,8,0.5,8,0.02,2,0.75,0.01,1.2,0.3,8,\
         0.5,,,,,,,,,"
    )
}

/// `simulate` of `model` at 4x4 px, 300 frames, its table into `out` (CSV).
fn simulate(model: &str, out: &Path) -> assert_cmd::Command {
    let mut c = detnoise();
    c.args([
        "simulate", "--model", model, "--subap", "4", "--iters", "300",
    ]);
    c.args(["--format", "csv", "--out"]).arg(out);
    c
}

/// `simulate` of scmos-rts on the bundled 64x64 map with the table `rts`.
fn with_table(rts: &Path, out: &Path) -> assert_cmd::Command {
    let mut c = simulate("scmos-rts", out);
    c.arg("--map")
        .arg(data("scmos-darks-64x64.truth-rms_e.fits"))
        .arg("--rts-table")
        .arg(rts);
    c
}

/// Run `c`: it exits with `code`, its stderr holds every needle, and `out` was not written.
fn refused(mut c: assert_cmd::Command, code: i32, needles: &[&str], out: &Path) {
    let got = c.assert().code(code);
    let stderr = String::from_utf8_lossy(&got.get_output().stderr).to_string();
    for n in needles {
        assert!(stderr.contains(n), "{n:?} not in: {stderr}");
    }
    assert!(!out.exists(), "{} written by a refused run", out.display());
}

#[test]
fn a_bom_and_quoted_cells_give_the_plain_tables_results() {
    let dir = tempfile::tempdir().unwrap();
    let body = [row(3, 5, "ok", -6.0), row(10, 20, "ok", -4.0)].join("\n");
    let plain = format!("{}\n{body}\n", header());
    let quoted = format!(
        "\u{feff}{}\r\n{}\r\n",
        header().replacen("status", "\"status\"", 1),
        body.replace(",ok,", ",\"ok\",").replace('\n', "\r\n")
    );
    let mut results = Vec::new();
    for (name, text) in [("plain", &plain), ("quoted", &quoted)] {
        let rts = dir.path().join(format!("{name}.csv"));
        std::fs::write(&rts, text).unwrap();
        let out = dir.path().join(format!("{name}-out.csv"));
        let got = with_table(&rts, &out).assert().success();
        let stderr = String::from_utf8_lossy(&got.get_output().stderr).to_string();
        assert!(!stderr.contains("skipped"), "{name}: {stderr}");
        results.push(std::fs::read(&out).unwrap());
    }
    assert!(results[0] == results[1], "the quoted table reads otherwise");
}

#[test]
fn tables_without_pixels_or_with_absurd_levels_are_refused() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("out.csv");
    let cases = [
        (
            "header.csv",
            format!("{}\n", header()),
            "no RTS pixels in the table",
        ),
        (
            "skipped.csv",
            format!("{}\n{}\n", header(), row(3, 5, "imprecise", -6.0)),
            "all 1 rows have a status other than `ok`",
        ),
        (
            "absurd.csv",
            format!("{}\n{}\n", header(), row(3, 5, "ok", 1e20)),
            "line 2: 'level_1_e' is 100000000000000000000: at most 1e6 e-",
        ),
    ];
    for (name, text, why) in cases {
        let rts = dir.path().join(name);
        std::fs::write(&rts, text).unwrap();
        refused(with_table(&rts, &out), 1, &[name, why], &out);
    }
}

#[test]
fn absurd_amplitudes_are_refused_not_an_empty_r() {
    // Issue 30: each of these exited 0 with R empty and SE 0.
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("out.csv");
    let map = data("scmos-darks-64x64.truth-rms_e.fits");
    let mut c = simulate("scmos-constant", &out);
    c.args(["--sigma", "1e20"]);
    refused(c, 2, &["--sigma", "1e20", "[0, 10000] e-"], &out);
    let mut c = simulate("scmos-correlated", &out);
    c.arg("--map").arg(&map);
    c.args(["--row-noise-e", "1e20", "--column-noise-e", "0"]);
    refused(c, 2, &["--row-noise-e", "[0, 10000] e-"], &out);
    let mut c = simulate("scmos-frames", &out);
    c.arg("--dark-frames")
        .arg(data("scmos-darks-64x64.fits"))
        .args(["--gain-e-per-adu", "1e300"]);
    refused(c, 2, &["--gain-e-per-adu", "(0, 10000] e- per adu"], &out);
    let mut c = simulate("emccd-stochastic", &out);
    c.args(["--emccd-read-noise", "1e20"]);
    refused(c, 2, &["--emccd-read-noise"], &out);
    // The model's own argument takes --sigma's range, in simulate and in effective (the
    // Monte-Carlo's refusal of overflowing sums, the net under every readout, is tested in
    // montecarlo::engine's tests).
    refused(
        simulate("scmos-constant:1e20", &out),
        2,
        &["'scmos-constant:1e20': sigma must be a number in [0, 10000] e-"],
        &out,
    );
    let eff = dir.path().join("eff");
    let mut c = detnoise();
    c.args([
        "effective",
        "--model",
        "scmos-constant:1e20",
        "--subap",
        "4",
    ]);
    c.args(["--spot", "airy:2", "--signal", "50", "--iters", "600"]);
    c.arg("--out").arg(&eff);
    refused(c, 2, &["[0, 10000] e-"], &eff);
}
