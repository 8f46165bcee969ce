//! RTS tables (`rts.csv`): mutants of the bundled truth table of `scmos-rts-64x64` (126
//! telegraph pixels of a 64x64 px camera), judged through `detector::params` (the table read
//! as `rts_table`) and the `scmos-rts` readout built on the camera's map (where pixels
//! outside the map are refused).
//!
//! What each mutant allows (an error naming the table is always allowed):
//! - spellings of the same table that CSV allows (a UTF-8 BOM, CRLF, blank lines, spaces
//!   around cells, quoted cells, rows or columns reordered, an extra column, a column the
//!   model does not read removed): `Kept`, it must be read, giving the seed's pixels.
//! - other spellings (`+3`, `003`, `3e0`, cells of unread columns changed, unread columns
//!   renamed): `Same`, an Ok must give the seed's pixels.
//! - values out of range (NaN, inf, huge levels and widths, negative widths and
//!   occupancies, 0 or 4 levels, coordinates outside the map, not numbers), a required
//!   column removed or renamed, a repeated pixel, a row of more or fewer cells, only a
//!   header, no `ok` row, another separator: `Refused`.
//! - edits that make another valid table (a digit flipped, a row dropped, a cut at a line,
//!   a level moved, a status changed): `Any`.

use std::path::Path;
use std::sync::Arc;

use detnoise::calib::Map;
use detnoise::detector::{ModelParams, ModelSpec, RtsTable};
use detnoise::progress::Silent;
use detnoise::settings::{Value, Values, MAP, RTS_TABLE};

use super::expect::{caught, verdict, Case, Expect, Seen};
use super::lines::{self, Op};
use super::{Mutant, Rng};

/// The seed table.
pub const SEED: &str = "data-synthetic/scmos-rts-64x64.truth-rts.csv";
/// The camera's map the table belongs to (64x64 px, e-).
pub const MAP_FILE: &str = "data-synthetic/scmos-rts-64x64.truth-rms_e.fits";
/// Rows of the table of many rows (loading must stay linear in them).
pub const MANY_ROWS: usize = 120_000;

/// What the model reads of a column of a row with `n` levels.
#[derive(Clone, Copy, PartialEq, Debug)]
enum Class {
    Coord,
    Levels,
    Status,
    Level,
    Occupancy,
    Width,
    Unread,
}

fn class(name: &str, n: usize) -> Class {
    let level = |prefix: &str, suffix: &str| {
        name.strip_prefix(prefix)
            .and_then(|r| r.strip_suffix(suffix))
            .and_then(|k| k.parse::<usize>().ok())
            .is_some_and(|k| k <= n)
    };
    match name {
        "x_px" | "y_px" => Class::Coord,
        "n_levels" => Class::Levels,
        "status" => Class::Status,
        _ if level("level_", "_e") => Class::Level,
        _ if level("occupancy_", "") => Class::Occupancy,
        _ if level("width_", "_e") => Class::Width,
        _ => Class::Unread,
    }
}

/// Columns the model cannot do without (level 2 too: every seed row has two levels).
const REQUIRED: [&str; 10] = [
    "x_px",
    "y_px",
    "n_levels",
    "status",
    "level_1_e",
    "occupancy_1",
    "width_1_e",
    "level_2_e",
    "occupancy_2",
    "width_2_e",
];

/// The seed's header and rows, as cells.
fn table(seed: &str) -> (Vec<String>, Vec<Vec<String>>) {
    let mut rows = seed
        .lines()
        .map(|l| l.split(',').map(str::to_string).collect());
    let header = rows.next().unwrap();
    (header, rows.collect())
}

fn text(header: &[String], rows: &[Vec<String>]) -> Vec<u8> {
    let mut t = header.join(",");
    for r in rows {
        t.push('\n');
        t.push_str(&r.join(","));
    }
    t.push('\n');
    t.into_bytes()
}

/// A new text for the cell `old` of a column of class `c`, with what it allows.
fn cell_value(c: Class, old: &str, rng: &mut Rng) -> (String, Expect) {
    use Expect::{Any, Kept, Refused as R, Same};
    let v: f64 = old.parse().unwrap_or(0.0);
    let same = [
        (format!(" {old} "), Kept),
        (format!("\"{old}\""), Kept),
        (
            format!("+{old}"),
            if v < 0.0 && c != Class::Unread {
                R
            } else {
                Same
            },
        ),
    ];
    let mut choices: Vec<(String, Expect)> = match c {
        Class::Coord => vec![
            ("-1".into(), R),
            ("64".into(), R),
            ("65535".into(), R),
            (u64::MAX.to_string(), R),
            ("18446744073709551616".into(), R),
            ("1.5".into(), R),
            ("nan".into(), R),
            (String::new(), R),
            ("x".into(), R),
            (format!("00{old}"), Same),
            (((v as usize + 1) % 64).to_string(), Any),
        ],
        Class::Levels => vec![
            ("0".into(), R),
            ("4".into(), R),
            ("-1".into(), R),
            ("99999999999999999999".into(), R),
            (String::new(), R),
            ("1".into(), Any),
            ("3".into(), Any),
        ],
        Class::Status => vec![
            ("imprecise".into(), Any),
            ("OK".into(), Any),
            (String::new(), Any),
            ("o,k".into(), R),
        ],
        Class::Level | Class::Occupancy | Class::Width => {
            let mut v2 = vec![
                ("nan".into(), R),
                ("NaN".into(), R),
                ("inf".into(), R),
                ("-inf".into(), R),
                ("1e308".into(), R),
                (String::new(), R),
                ("abc".into(), R),
                (format!("{v:e}"), Same),
                ("1,5".into(), R),
            ];
            v2.extend(match c {
                Class::Level => vec![
                    ("1e20".into(), R),
                    ("-1e20".into(), R),
                    ((v * 2.0).to_string(), Any),
                ],
                Class::Occupancy => vec![("-0.5".into(), R), ("1.5".into(), R), ("2".into(), R)],
                _ => vec![("-1".into(), R), ("1e20".into(), R), ("0".into(), Any)],
            });
            v2
        }
        Class::Unread => vec![
            ("nan".into(), Same),
            (String::new(), Same),
            ("abc".into(), Same),
            ("1e308".into(), Same),
            ("\"1,5\"".into(), Kept),
            ("1,5".into(), R),
        ],
    };
    if c != Class::Status {
        choices.extend(same);
    } else {
        choices.extend([(" ok ".into(), Kept), ("\"ok\"".into(), Kept)]);
    }
    let fresh: Vec<_> = choices.into_iter().filter(|(t, _)| t != old).collect();
    rng.pick(&fresh).clone()
}

fn cell_edit(seed: &str, rng: &mut Rng) -> Case {
    let (header, mut rows) = table(seed);
    let r = rng.below(rows.len());
    let j = rng.below(header.len());
    let n = rows[r][2].parse().unwrap_or(0);
    let c = class(&header[j], n);
    let old = rows[r][j].clone();
    let (new, expect) = cell_value(c, &old, rng);
    rows[r][j] = new.clone();
    let label = format!("row {} {} = {new:?} (was {old:?})", r + 2, header[j]);
    Case::new(Mutant::new(label, text(&header, &rows)), expect)
}

fn structural(seed: &str, rng: &mut Rng) -> Case {
    use Expect::{Kept, Refused as R, Same};
    let (mut header, mut rows) = table(seed);
    let cols = header.len();
    let (label, expect): (String, Expect) = match rng.below(14) {
        0 => {
            let j = rng.below(cols);
            let name = header.remove(j);
            rows.iter_mut().for_each(|r| {
                r.remove(j);
            });
            let e = if REQUIRED.contains(&name.as_str()) {
                R
            } else {
                Kept
            };
            (format!("column {name} removed"), e)
        }
        1 => {
            let j = rng.below(cols + 1);
            header.insert(j, "extra".into());
            rows.iter_mut().for_each(|r| r.insert(j, "1".into()));
            (format!("a column 'extra' inserted at {j}"), Kept)
        }
        2 => {
            let j = rng.below(cols);
            let old = header[j].clone();
            let new = rng
                .pick(&[
                    old.to_uppercase(),
                    old.replace('_', " "),
                    format!("{old}x"),
                    format!(" {old} "),
                ])
                .clone();
            let e = if new.trim() == old {
                Kept
            } else if !REQUIRED.contains(&old.as_str()) {
                Same
            } else {
                R
            };
            header[j] = new.clone();
            (format!("column {old} renamed {new:?}"), e)
        }
        3 => {
            let r = rng.below(rows.len());
            rows[r].push("1".into());
            (format!("row {} has an extra cell", r + 2), R)
        }
        4 => {
            let r = rng.below(rows.len());
            let j = rng.below(cols);
            rows[r].remove(j);
            (format!("row {} lacks cell {j}", r + 2), R)
        }
        5 => {
            rows = rng.sample(rows, usize::MAX);
            ("rows shuffled".into(), Kept)
        }
        6 => {
            let (a, b) = (rng.below(cols), rng.below(cols));
            header.swap(a, b);
            rows.iter_mut().for_each(|r| r.swap(a, b));
            (format!("columns {a} and {b} exchanged"), Kept)
        }
        7 => {
            rows.clear();
            ("only the header".into(), R)
        }
        8 => {
            rows.iter_mut().for_each(|r| r[3] = "imprecise".into());
            ("no row is ok".into(), R)
        }
        9 => {
            let q = |c: &mut String| *c = format!("\"{c}\"");
            header.iter_mut().for_each(q);
            rows.iter_mut().for_each(|r| r.iter_mut().for_each(q));
            ("every cell quoted".into(), Kept)
        }
        10 => {
            let sep = *rng.pick(&[";", "\t", " "]);
            let t = String::from_utf8(text(&header, &rows))
                .unwrap()
                .replace(',', sep);
            return Case::new(Mutant::new(format!("separator {sep:?}"), t.into_bytes()), R);
        }
        11 => {
            let t = String::from_utf8(text(&header, &rows))
                .unwrap()
                .replace(',', ", ");
            return Case::new(
                Mutant::new("a space after every comma", t.into_bytes()),
                Kept,
            );
        }
        12 => {
            let mut b = vec![0xff, 0xfe];
            let t = String::from_utf8(text(&header, &rows)).unwrap();
            b.extend(t.encode_utf16().flat_map(u16::to_le_bytes));
            return Case::new(Mutant::new("UTF-16LE with its BOM", b), R);
        }
        _ => {
            let r = rng.below(rows.len());
            let mut copy = rows[r].clone();
            copy[4] = "0".into();
            rows.insert(rng.below(rows.len()), copy);
            (format!("row {} repeated with another adu level", r + 2), R)
        }
    };
    Case::new(Mutant::new(label, text(&header, &rows)), expect)
}

/// What a line mutant of the table allows.
fn line_expect(op: Op, rows: usize) -> Expect {
    use Expect::{Any, Kept, Refused};
    match op {
        Op::FlipBit { .. } | Op::TruncateByte { .. } => Any,
        Op::TruncateLine { keep } => {
            if keep <= 1 {
                Refused
            } else {
                Any
            }
        }
        Op::Drop { header } => {
            if header {
                Refused
            } else if rows > 1 {
                Any
            } else {
                Refused
            }
        }
        // The header repeated as a row is a row whose status is not `ok`: skipped.
        Op::Duplicate { header } => {
            if header {
                Any
            } else {
                Refused
            }
        }
        Op::Swap { header } => {
            if header {
                Refused
            } else {
                Kept
            }
        }
        Op::Blank | Op::Crlf | Op::Bom | Op::NoFinalNewline => Kept,
        Op::Long | Op::Garbage => Any,
    }
}

/// `n` mutants of the seed table.
pub fn mutants(seed: &str, rng: &mut Rng, n: usize) -> Vec<Case> {
    let rows = seed.lines().count() - 1;
    let mut out: Vec<Case> = (0..n)
        .map(|_| match rng.below(20) {
            0..=5 => {
                let (op, m) = lines::mutant(seed.as_bytes(), rng);
                // A long line of blanks is a blank line; of anything else, a broken row.
                let e = match (
                    op,
                    m.label.contains("of ' '") || m.label.contains("of '\\t'"),
                ) {
                    (Op::Long, true) => Expect::Kept,
                    (Op::Long, false) => Expect::Refused,
                    _ => line_expect(op, rows),
                };
                Case::new(m, e)
            }
            6..=14 => cell_edit(seed, rng),
            _ => structural(seed, rng),
        })
        .collect();
    out.push(many_rows());
    out
}

/// A table of [`MANY_ROWS`] distinct `ok` pixels, most outside the map: refused, and read in
/// time linear in its rows (the watchdog and the slow-mutant check see it).
fn many_rows() -> Case {
    let (header, _) = table(&std::fs::read_to_string(repo(SEED)).unwrap());
    let mut t = header.join(",");
    for i in 0..MANY_ROWS {
        t.push_str(&format!(
            "\n{},{},2,ok,-10,,-2.5,0.5,,2.5,0.6,12,,20,,5,0.5,,2.5,0.6,6,,,,,,,,,,",
            i % 512,
            i / 512
        ));
    }
    t.push('\n');
    Case::new(
        Mutant::new(
            format!("{MANY_ROWS} rows, most outside the map"),
            t.into_bytes(),
        ),
        Expect::Refused,
    )
}

/// A path in the repository.
pub fn repo(rel: &str) -> std::path::PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join(rel)
}

/// A table's pixels in a form to compare: sorted, without their line numbers.
type Pixels = Vec<(usize, usize, Vec<f64>, Vec<f64>, Vec<f64>)>;

fn pixels(t: &RtsTable) -> Pixels {
    let mut p: Pixels = t
        .pixels
        .iter()
        .map(|p| {
            (
                p.y_px,
                p.x_px,
                p.levels_e.clone(),
                p.occupancy.clone(),
                p.widths_e.clone(),
            )
        })
        .collect();
    p.sort_by_key(|a| (a.0, a.1));
    p
}

/// The seed table's pixels (what `Same` mutants must give).
pub fn seed_pixels() -> Pixels {
    pixels(&RtsTable::read(&repo(SEED), &Silent).expect("the seed table reads"))
}

/// The failure, if any, of the table at `path` (allowing `expect`) with the camera's `map`.
pub fn judge(path: &Path, expect: Expect, map: &Arc<Map>, seed: &Pixels) -> Option<String> {
    let mut values = Values::default();
    values.set(&MAP, Value::Map(map.clone()));
    values.set(&RTS_TABLE, Value::Path(path.to_path_buf()));
    let r = caught(|| {
        let params = ModelParams::from_settings(&values, &Silent)?;
        ModelSpec::parse("scmos-rts")?.build(&params, 16)?;
        Ok(params.rts_table.expect("a table was given"))
    });
    verdict("rts_table", expect, path, r, |t| Seen {
        differs: (pixels(t) != *seed).then(|| format!("{} pixels read", t.pixels.len())),
        wrong: None,
    })
}
