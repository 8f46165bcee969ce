//! The terminal table of `simulate` (`--format table`): only the columns that say something
//! about this run, at most [`MAX_WIDTH`] characters wide. Settings shared by every row are
//! stated once above the table; a sweep too wide for one table is split into one table per
//! configuration. CSV and JSON keep every column.

use super::super::table::{render, Align, Column};
use crate::montecarlo::SimRecord;

/// Widest line of the table, characters (a terminal of 100 columns shows it unwrapped).
pub const MAX_WIDTH: usize = 100;

/// The text of `--format table` for `records` (configuration order, then model order).
pub fn terminal_table(records: &[SimRecord]) -> String {
    if records.is_empty() {
        return String::new();
    }
    let settings: Vec<(&Setting, bool)> = SETTINGS
        .iter()
        .map(|s| (s, varies(records, s.value)))
        .collect();
    let shared: Vec<String> = settings
        .iter()
        .filter(|(_, varies)| !varies)
        .map(|(s, _)| (s.phrase)(&(s.value)(&records[0])))
        .collect();
    let swept: Vec<&Setting> = settings
        .iter()
        .filter(|(_, varies)| *varies)
        .map(|(s, _)| *s)
        .collect();
    let results = result_columns(records);
    let mut out = wrap(&shared.join(", "));
    let flat = table(records, &swept, &results);
    if flat.lines().all(|l| l.chars().count() <= MAX_WIDTH) {
        out += &flat;
    } else {
        // One table per configuration, headed by its swept settings.
        let mut start = 0;
        while start < records.len() {
            let key = |r: &SimRecord| swept.iter().map(|s| (s.value)(r)).collect::<Vec<_>>();
            let len = records[start..]
                .iter()
                .take_while(|r| key(r) == key(&records[start]))
                .count();
            let head: Vec<String> = swept
                .iter()
                .map(|s| (s.phrase)(&(s.value)(&records[start])))
                .collect();
            out += &format!("\n{}", wrap(&head.join(", ")));
            out += &table(&records[start..start + len], &[], &results);
            start += len;
        }
    }
    out + &legend(&results)
}

/// A configuration setting: its column name (unit in the name, as in the CSV), its cell, and
/// how a value shared by every row is stated above the table.
struct Setting {
    name: &'static str,
    value: fn(&SimRecord) -> String,
    phrase: fn(&str) -> String,
}

/// The configuration settings, in CSV column order.
const SETTINGS: [Setting; 7] = [
    Setting {
        name: "subap_px",
        value: |r| r.config.subap_px.to_string(),
        phrase: |v| format!("sub-aperture {v}x{v} px"),
    },
    Setting {
        name: "spot",
        value: |r| r.config.spot.label(),
        phrase: |v| format!("spot {v}"),
    },
    Setting {
        name: "sampling",
        value: |r| r.config.sampling.label().to_string(),
        phrase: |v| format!("{v} sampling"),
    },
    Setting {
        name: "signal_photons",
        value: |r| plain(r.config.signal_photons),
        phrase: |v| format!("{v} photons"),
    },
    Setting {
        name: "qe",
        value: |r| plain(r.config.qe),
        phrase: |v| format!("QE {v}"),
    },
    Setting {
        name: "iters",
        value: |r| r.config.iters.to_string(),
        phrase: |v| format!("{v} iterations"),
    },
    Setting {
        name: "seed",
        value: |r| r.config.seed.to_string(),
        phrase: |v| format!("seed {v}"),
    },
];

/// The result columns that apply to `records`: the EM gain only with a model that has a
/// register, empty frames and notes only when some row has them. The model (a name, read
/// left to right) leads; the others are numbers but the note, last.
fn result_columns(records: &[SimRecord]) -> Vec<Column<SimRecord>> {
    fn number(head: &'static str, cell: fn(&SimRecord) -> String) -> Column<SimRecord> {
        Column::fit(head, Align::Right, cell)
    }
    let mut cols = vec![Column::fit("model", Align::Left, |r: &SimRecord| {
        r.result.model.clone()
    })];
    if records.iter().any(|r| r.result.centroider != "cog") {
        cols.push(number("centroider", |r| r.result.centroider.clone()));
    }
    if records.iter().any(|r| r.em_gain.is_some()) {
        cols.push(number("em_gain", |r| {
            r.em_gain.map(plain).unwrap_or_default()
        }));
    }
    cols.extend([
        number("r_px", |r| sig(r.result.r_px, 4)),
        number("r_se_px", |r| sig(r.result.r_se_px, 2)),
        number("b_opt_e", |r| plain(trimmed(r.result.b_opt_e, 3))),
        number("r0_px", |r| sig(r.result.r0_px, 4)),
    ]);
    if records.iter().any(|r| r.result.param_opt.is_some()) {
        cols.push(number("param_opt", |r| {
            match (r.result.param_name, r.result.param_opt) {
                (Some(name), Some(v)) => format!("{name}={}", plain(trimmed(v, 3))),
                _ => String::new(),
            }
        }));
    }
    if records.iter().any(|r| r.result.zero_frames > 0) {
        cols.push(number("zero_frames", |r| r.result.zero_frames.to_string()));
    }
    if records.iter().any(|r| !note(r).is_empty()) {
        cols.push(Column::fit("note", Align::Left, note));
    }
    cols
}

/// Flags of a result, in words.
fn note(r: &SimRecord) -> String {
    let mut words = Vec::new();
    if r.result.b_at_grid_edge {
        words.push(GRID_TOP);
    }
    if r.result.no_eligible_level {
        words.push(NO_ELIGIBLE);
    }
    if r.below_crlb() == Some(true) {
        words.push(BELOW_CRLB);
    }
    words.join(", ")
}

const GRID_TOP: &str = "grid top";
const NO_ELIGIBLE: &str = "no eligible level";
const BELOW_CRLB: &str = "below R_crlb";

/// True when `value` differs between records.
fn varies(records: &[SimRecord], value: fn(&SimRecord) -> String) -> bool {
    let first = value(&records[0]);
    records.iter().any(|r| value(r) != first)
}

/// An aligned table: the model, the `swept` settings, then the other `results` columns.
fn table(records: &[SimRecord], swept: &[&Setting], results: &[Column<SimRecord>]) -> String {
    let settings = swept
        .iter()
        .map(|s| Column::fit(s.name, Align::Right, s.value));
    let columns: Vec<Column<SimRecord>> = results[..1]
        .iter()
        .copied()
        .chain(settings)
        .chain(results[1..].iter().copied())
        .collect();
    render(&columns, records, |_| None)
}

/// What the result columns mean, for those shown.
fn legend(results: &[Column<SimRecord>]) -> String {
    let shown = |name: &str| results.iter().any(|c| c.head == name);
    let mut items = vec![
        "r_px ± r_se_px: mean radial centroid error (px) after subtracting the background \
         level b_opt_e (e-) that minimises it"
            .to_string(),
        "r0_px: without subtraction".to_string(),
    ];
    if shown("em_gain") {
        items.push("em_gain (e-/e-): models with an EM register only".into());
    }
    if shown("zero_frames") {
        items.push("zero_frames: frames with nothing above b_opt_e".into());
    }
    if shown("note") {
        items.push(format!(
            "{GRID_TOP}: b_opt_e is the highest level tried (widen --bg-grid)"
        ));
        items.push(format!(
            "{NO_ELIGIBLE}: every level leaves more than --max-empty-frac of the frames \
             empty (the least empty is shown)"
        ));
        items.push(format!(
            "{BELOW_CRLB}: R lies more than 3 SE under the Cramer-Rao floor r_crlb_px (in \
             --format csv): the centroid is biased"
        ));
    }
    wrap(&(items.join("; ") + "."))
}

/// `text` broken at spaces into lines of at most [`MAX_WIDTH`] characters.
fn wrap(text: &str) -> String {
    let mut out = String::new();
    let mut line = String::new();
    for word in text.split_whitespace() {
        if !line.is_empty() && line.chars().count() + 1 + word.chars().count() > MAX_WIDTH {
            out += &line;
            out.push('\n');
            line.clear();
        }
        if !line.is_empty() {
            line.push(' ');
        }
        line += word;
    }
    if !line.is_empty() {
        out += &line;
        out.push('\n');
    }
    out
}

/// `x` rounded to `n` significant digits.
fn trimmed(x: f64, n: i32) -> f64 {
    if x == 0.0 || !x.is_finite() {
        return x;
    }
    let scale = 10f64.powi(n - 1 - x.abs().log10().floor() as i32);
    (x * scale).round() / scale
}

/// A number as written by hand: at most 6 decimals, no trailing zeros; empty if not finite.
fn plain(x: f64) -> String {
    if !x.is_finite() {
        return String::new();
    }
    let s = format!("{:.6}", x);
    let s = s.trim_end_matches('0').trim_end_matches('.');
    if s == "-0" {
        "0".into()
    } else {
        s.into()
    }
}

/// `x` with `n` significant digits (an exponent below 1e-4 and from 1e6); empty if not finite.
fn sig(x: f64, n: usize) -> String {
    if !x.is_finite() {
        return String::new();
    }
    if x == 0.0 {
        return "0".into();
    }
    let mag = x.abs().log10().floor() as i32;
    if !(-4..6).contains(&mag) {
        return format!("{:.*e}", n - 1, x);
    }
    let decimals = (n as i32 - 1 - mag).max(0) as usize;
    let s = format!("{x:.decimals$}");
    // Rounding up may add a digit (0.99996 -> 1.0000): keep n significant digits.
    if s.trim_start_matches(['-', '0', '.']).replace('.', "").len() > n && decimals > 0 {
        format!("{x:.0$}", decimals - 1)
    } else {
        s
    }
}

#[cfg(test)]
mod tests;
