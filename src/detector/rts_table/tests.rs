//! Tests of the `rts.csv` reader: the shared format, skipped rows, and errors naming file,
//! line and column.

use super::fixture::{header, row, table};
use super::*;
use crate::progress::Recorder;
use crate::settings::MAX_NOISE_E;

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

#[test]
fn a_byte_order_mark_and_quoted_cells_are_read_as_csv() {
    // Issue 30: a spreadsheet's UTF-8 BOM gave "no column 'x_px'", and a quoted "ok" counted
    // as not ok. Both are CSV: the BOM is dropped, cells are unquoted ("" is a quote), header
    // and rows alike, with spaces around a quoted cell as around any.
    let two = [(-1.0, 0.5, 0.2), (1.0, 0.5, 0.2)];
    let plain = table(&[row(3, 4, "ok", &two, true), row(5, 6, "ok", &two, true)]);
    let want = RtsTable::parse(&plain, Path::new("r.csv")).unwrap();
    let bom = format!("\u{feff}{plain}");
    assert_eq!(RtsTable::parse(&bom, Path::new("r.csv")).unwrap(), want);
    let quoted = plain
        .replacen("x_px,y_px", "\"x_px\", \"y_px\"", 1)
        .replace(",ok,", ", \"ok\" ,")
        .replacen("3,4,", "\"3\",4,", 1);
    let t = RtsTable::parse(&quoted, Path::new("r.csv")).unwrap();
    assert_eq!((t.pixels, t.skipped), (want.pixels.clone(), 0));
    // A quoted cell may hold a comma or a doubled quote: the status "not, ""ok""" is skipped.
    let odd = plain.replacen(",ok,", ",\"not, \"\"ok\"\"\",", 1);
    let t = RtsTable::parse(&odd, Path::new("r.csv")).unwrap();
    assert_eq!((t.pixels.len(), t.skipped), (1, 1));
    // A quote left open, or text after a closing quote, is an error naming line and cell.
    for (text, expect) in [
        (
            plain.replacen(",ok,", ",\"ok,", 1),
            "r.csv: line 2: cell 4: a quote is opened and not closed on this line",
        ),
        (
            plain.replacen(",ok,", ",\"ok\"x,", 1),
            "r.csv: line 2: cell 4: text after its closing quote",
        ),
    ] {
        let msg = RtsTable::parse(&text, Path::new("r.csv"))
            .unwrap_err()
            .to_string();
        assert!(msg.starts_with(expect), "{msg}\nexpected: {expect}");
    }
}

#[test]
fn a_table_without_ok_rows_is_refused() {
    // Issue 30: a header-only table ran silently as scmos-map. A user who gave a table wants
    // it used: refused, saying what to run instead; the same when every row is skipped.
    let two = [(-1.0, 0.5, 0.2), (1.0, 0.5, 0.2)];
    for (rows, why) in [
        (vec![], "the table has no rows"),
        (
            vec![
                row(0, 0, "imprecise", &two, true),
                row(1, 0, "imprecise", &two, true),
            ],
            "all 2 rows have a status other than `ok`",
        ),
    ] {
        let (_dir, path) = file("rts.csv", &table(&rows));
        let err = RtsTable::read(&path, &Recorder::default()).unwrap_err();
        let msg = err.to_string();
        assert!(
            msg.contains("rts.csv: no RTS pixels in the table: ")
                && msg.contains(why)
                && msg.contains("`scmos-map`"),
            "{msg}"
        );
        assert_eq!(err.exit_code(), 1);
    }
}

#[test]
fn absurd_levels_and_widths_are_refused() {
    // Issue 30: a level of 1e20 e- ran and gave an empty R. A level is at most a full well
    // either side of the offset, a width at most the largest read noise of the settings.
    let path = Path::new("rts.csv");
    let ok = |l: f64, w: f64| table(&[row(0, 0, "ok", &[(l, 0.5, w), (1.0, 0.5, 0.2)], true)]);
    assert!(RtsTable::parse(&ok(-MAX_LEVEL_E, MAX_NOISE_E), path).is_ok());
    for (text, expect) in [
        (
            ok(1e20, 0.2),
            "line 2: 'level_1_e' is 100000000000000000000: at most 1e6 e-",
        ),
        (
            ok(-2e6, 0.2),
            "line 2: 'level_1_e' is -2000000: at most 1e6 e-",
        ),
        (
            ok(-1.0, 1e5),
            "line 2: 'width_1_e' is 100000: at most 1e4 e-",
        ),
    ] {
        let msg = RtsTable::parse(&text, path).unwrap_err().to_string();
        assert!(msg.contains(expect), "{msg}\nexpected: {expect}");
    }
}

#[test]
fn utf16_and_binary_files_are_refused_by_name() {
    let (_d, path) = file("rts.csv", "");
    let utf16: Vec<u8> = [0xff, 0xfe]
        .into_iter()
        .chain(header().encode_utf16().flat_map(u16::to_le_bytes))
        .collect();
    std::fs::write(&path, utf16).unwrap();
    let msg = RtsTable::read(&path, &Recorder::default())
        .unwrap_err()
        .to_string();
    assert!(
        msg.contains("rts.csv: UTF-16 text") && msg.contains("UTF-8"),
        "{msg}"
    );
    std::fs::write(&path, [b'x', b',', 0xc3, 0x28]).unwrap();
    let msg = RtsTable::read(&path, &Recorder::default())
        .unwrap_err()
        .to_string();
    assert!(
        msg.contains("rts.csv: not UTF-8 text (byte 2 is not)"),
        "{msg}"
    );
}

#[test]
fn a_large_table_keeps_its_order_and_finds_a_late_duplicate() {
    // 20,000 rows in a scrambled order read back in table order; a duplicate of the first
    // pixel at the end names both lines (the check is a hash map, linear in the rows).
    let two = [(-1.0, 0.5, 0.2), (1.0, 0.5, 0.2)];
    let place = |i: usize| {
        let p = i.wrapping_mul(2_654_435_761) % (256 * 256);
        (p % 256, p / 256)
    };
    let mut rows: Vec<String> = (0..20_000)
        .map(|i| {
            let (x, y) = place(i);
            row(x, y, "ok", &two, true)
        })
        .collect();
    let t = RtsTable::parse(&table(&rows), Path::new("r.csv")).unwrap();
    assert!(t
        .pixels
        .iter()
        .enumerate()
        .all(|(i, p)| (p.x_px, p.y_px, p.line) == (place(i).0, place(i).1, i + 2)));
    let (x, y) = place(0);
    rows.push(row(x, y, "ok", &two, true));
    let msg = RtsTable::parse(&table(&rows), Path::new("r.csv"))
        .unwrap_err()
        .to_string();
    assert!(
        msg.contains(&format!(
            "line 20002: pixel (x_px {x}, y_px {y}) is listed twice (also on line 2)"
        )),
        "{msg}"
    );
}
