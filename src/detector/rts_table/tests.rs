//! Tests of the `rts.csv` reader: the shared format, skipped rows, and errors naming file,
//! line and column.

use super::fixture::{header, row, table};
use super::*;
use crate::progress::Recorder;

/// `text` written to `name` in a fresh directory; returns the directory (kept alive) and path.
fn file(name: &str, text: &str) -> (tempfile::TempDir, PathBuf) {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join(name);
    std::fs::write(&path, text).unwrap();
    (dir, path)
}

#[test]
fn reads_the_shared_format_and_skips_rows_that_are_not_ok() {
    let three = [(-3.0, 0.2, 0.5), (0.0, 0.5, 0.3), (2.0, 0.3, 0.8)];
    let two = [(-1.5, 0.6, 0.4), (2.25, 0.4, 0.4)];
    let text = table(&[
        row(5, 7, "ok", &three, true),
        row(1, 0, "imprecise", &two, true),
        row(0, 3, "ok", &two, true),
        row(2, 2, "imprecise", &two, false),
    ]);
    assert_eq!(header().split(',').count(), 4 + 3 * 9);
    let (_dir, path) = file("rts.csv", &text);
    let seen = Recorder::default();
    let t = RtsTable::read(&path, &seen).unwrap();
    assert_eq!(t.skipped, 2);
    assert_eq!(t.source, path);
    assert_eq!(t.pixels.len(), 2);
    let p = &t.pixels[0];
    assert_eq!((p.x_px, p.y_px, p.line), (5, 7, 2));
    assert_eq!(p.levels_e, [-3.0, 0.0, 2.0]);
    assert_eq!(p.widths_e, [0.5, 0.3, 0.8]);
    assert_eq!(p.occupancy, [0.2, 0.5, 0.3]);
    let q = &t.pixels[1];
    assert_eq!((q.x_px, q.y_px, q.line), (0, 3, 4));
    assert_eq!((q.levels_e.len(), q.occupancy.len()), (2, 2));
    // The skipped rows are counted in one warning naming the file and the option.
    let warnings = seen.warnings.lock().unwrap();
    assert_eq!(warnings.len(), 1);
    let w = &warnings[0];
    assert!(
        w.contains("rts.csv") && w.contains("2 of 4") && w.contains("`rts_table`"),
        "{w}"
    );
    // Without skipped rows there is no warning; CRLF line ends and blank lines are fine.
    let crlf = table(&[row(0, 3, "ok", &two, true)]).replace('\n', "\r\n") + "\r\n";
    let (_d, path) = file("crlf.csv", &crlf);
    let quiet = Recorder::default();
    assert_eq!(RtsTable::read(&path, &quiet).unwrap().pixels.len(), 1);
    assert!(quiet.warnings.lock().unwrap().is_empty());
}

#[test]
fn occupancies_are_renormalised_within_round_off() {
    // Written with 4 decimals the occupancies may sum to 0.9999: accepted, rescaled to 1.
    let text = table(&[row(
        0,
        0,
        "ok",
        &[(-1.0, 0.3333, 0.1), (0.5, 0.6666, 0.1)],
        true,
    )]);
    let t = RtsTable::parse(&text, Path::new("r.csv")).unwrap();
    let sum: f64 = t.pixels[0].occupancy.iter().sum();
    assert!((sum - 1.0).abs() < 1e-15, "{sum}");
    assert!((t.pixels[0].occupancy[0] - 0.3333 / 0.9999).abs() < 1e-15);
}

#[test]
fn a_table_without_electrons_asks_for_the_gain() {
    // `darks` without a gain leaves the e- cells empty: refused, saying what to run.
    let text = table(&[row(3, 4, "ok", &[(-1.0, 0.5, 0.2), (1.0, 0.5, 0.2)], false)]);
    let err = RtsTable::parse(&text, Path::new("dir/rts.csv")).unwrap_err();
    let msg = err.to_string();
    assert!(
        msg.starts_with("dir/rts.csv: line 2: no level in e-"),
        "{msg}"
    );
    assert!(
        msg.contains("`gain_e_per_adu`") && msg.contains("darks"),
        "{msg}"
    );
    assert_eq!(err.exit_code(), 1);
    // A header without the e- columns at all: the same advice, on line 1.
    let adu_only =
        "x_px,y_px,n_levels,status,level_1_adu,occupancy_1,width_1_adu\n0,0,1,ok,1,1,1\n";
    let msg = RtsTable::parse(adu_only, Path::new("rts.csv"))
        .unwrap_err()
        .to_string();
    assert!(
        msg.contains("no level in e-") && msg.contains("`gain_e_per_adu`"),
        "{msg}"
    );
}

#[test]
fn bad_rows_and_files_are_errors_naming_file_line_and_column() {
    let two = [(-1.0, 0.5, 0.2), (1.0, 0.5, 0.2)];
    let path = Path::new("cam/rts.csv");
    let parse = |text: &str| RtsTable::parse(text, path).unwrap_err().to_string();
    let cases: Vec<(String, &str)> = vec![
        (
            table(&[row(0, 0, "ok", &[(-1.0, 0.5, 0.2), (1.0, 0.4, 0.2)], true)]),
            "line 2: the occupancies of the 2 levels sum to 0.9",
        ),
        (
            table(&[row(0, 0, "ok", &[(-1.0, 1.5, 0.2), (1.0, -0.5, 0.2)], true)]),
            "line 2: 'occupancy_1' is 1.5: must be in [0, 1]",
        ),
        (
            table(&[row(0, 0, "ok", &[(-1.0, 0.5, -0.2), (1.0, 0.5, 0.2)], true)]),
            "line 2: 'width_1_e' is -0.2: must be >= 0 e-",
        ),
        (
            table(&[row(0, 0, "ok", &two, true), row(0, 0, "ok", &two, true)]),
            "line 3: pixel (x_px 0, y_px 0) is listed twice (also on line 2)",
        ),
        (
            table(&[row(0, 0, "ok", &two, true).replacen("0,0,", "-1,0,", 1)]),
            "line 2: 'x_px' is '-1', not a whole number >= 0",
        ),
        (
            table(&[row(0, 0, "ok", &two, true).replacen(",2,ok", ",4,ok", 1)]),
            "line 2: 'n_levels' is 4: a telegraph pixel has 1 to 3 levels",
        ),
        (
            table(&[row(0, 0, "ok", &two, true).replace(",-1,", ",NaN,")]),
            "line 2: 'level_1_e' is 'NaN', not a finite number",
        ),
        (
            "x,y,levels\n1,2,3\n".to_string(),
            "line 1: no column 'x_px': not an rts.csv table written by darks",
        ),
        (String::new(), "empty file"),
        (
            table(&[row(0, 0, "ok", &two, true) + ",1"]),
            "line 2: 32 cells, but the header has 31 columns",
        ),
        (
            table(&["1,2,3".to_string()]),
            "line 2: 3 cells, but the header has 31 columns",
        ),
    ];
    for (text, expect) in cases {
        let msg = parse(&text);
        assert!(msg.starts_with("cam/rts.csv: "), "{msg}");
        assert!(msg.contains(expect), "{msg}\nexpected: {expect}");
    }
    let missing = RtsTable::read(Path::new("no/such/rts.csv"), &Recorder::default()).unwrap_err();
    assert!(missing.to_string().contains("no/such/rts.csv"), "{missing}");
}
