//! The telegraph (RTS) pixels measured by `darks`: its `rts.csv` table read for `scmos-rts`.
//!
//! One row per fitted RTS pixel: `x_px` (column) and `y_px` (row) of the full frame, 0-based,
//! `n_levels` (1 to 3), `status`, and per level k the level relative to the pixel's offset,
//! its occupancy (fraction of frames) and the Gaussian width around it. The model needs the
//! levels and widths in e- (`level_k_e`, `width_k_e`): `darks` writes them only when it was
//! given the conversion gain. Rows whose status is not `ok` are skipped (and counted).

use std::borrow::Cow;
use std::collections::HashMap;
use std::path::{Path, PathBuf};

use crate::progress::Observer;
use crate::settings::MAX_NOISE_E;
use crate::{Error, Result};

/// Most levels of a telegraph pixel in the table (the writer's, `darks`').
pub use crate::calib::darks::MAX_LEVELS;

/// Largest distance of a row's occupancies' sum from 1 accepted: the table's round-off
/// (the occupancies are renormalised to sum to 1 exactly).
const OCCUPANCY_SUM_TOLERANCE: f64 = 1e-3;

/// Largest level either side of the pixel's offset, e-: a pixel's full well (~1e6 e-; the
/// same bound as `synth`'s light). Beyond it the table is not of a camera, and the
/// Monte-Carlo's centroid sums would leave single precision's range.
pub const MAX_LEVEL_E: f64 = 1e6;

/// One telegraph pixel: its place and its levels (ascending, in e-).
#[derive(Debug, Clone, PartialEq)]
pub struct RtsPixel {
    /// Column in the full frame (0-based).
    pub x_px: usize,
    /// Row in the full frame (0-based).
    pub y_px: usize,
    /// Level means relative to the pixel's offset (e-), one per level.
    pub levels_e: Vec<f64>,
    /// Fraction of frames in each level (unitless, sums to 1).
    pub occupancy: Vec<f64>,
    /// Gaussian standard deviation around each level (e-).
    pub widths_e: Vec<f64>,
    /// Line of the table the pixel was read from (1-based; the header is line 1), for messages.
    pub line: usize,
}

/// The `ok` rows of an `rts.csv`, with how many rows were skipped.
#[derive(Debug, Clone, PartialEq)]
pub struct RtsTable {
    /// The file read.
    pub source: PathBuf,
    /// The telegraph pixels of the `ok` rows, in table order.
    pub pixels: Vec<RtsPixel>,
    /// Rows skipped because their status was not `ok` (fits too poor to use).
    pub skipped: usize,
}

/// Columns of `rts.csv` that the model reads.
struct Columns {
    /// Number of columns of the header.
    count: usize,
    x: usize,
    y: usize,
    n_levels: usize,
    status: usize,
    /// `level_k_e`, `occupancy_k`, `width_k_e` for k = 1, 2, 3 (None: the column is absent).
    levels: [[Option<usize>; 3]; MAX_LEVELS],
}

impl RtsTable {
    /// Read `path` (an `rts.csv` written by `darks`); the rows skipped for their status are
    /// reported to `observer` as a warning.
    pub fn read(path: &Path, observer: &dyn Observer) -> Result<RtsTable> {
        let text = read_csv_text(path, "an rts.csv table")?;
        let table = RtsTable::parse(&text, path)?;
        if table.skipped > 0 {
            let all = table.skipped + table.pixels.len();
            observer.warn(&format!(
                "{}: {} of {all} RTS pixels skipped (status not `ok`: their telegraph fit is too \
                 poor to use); `rts_table` simulates the other {} and reads the skipped ones \
                 with the map's sigma",
                path.display(),
                table.skipped,
                table.pixels.len()
            ));
        }
        Ok(table)
    }

    /// Parse the text of an `rts.csv`; `source` names it in errors. Cells are CSV cells: a
    /// cell in double quotes is unquoted (`""` inside it is one quote), and a UTF-8 byte-order
    /// mark before the header (spreadsheets write one) is dropped. A table with no `ok` row is
    /// refused: `scmos-rts` would then be `scmos-map` under another name.
    pub fn parse(text: &str, source: &Path) -> Result<RtsTable> {
        let bad = |line: usize, what: String| Error::input(source, format!("line {line}: {what}"));
        let text = text.strip_prefix('\u{feff}').unwrap_or(text);
        let mut lines = text.lines().enumerate().map(|(i, l)| (i + 1, l));
        let Some((first, header)) = lines.find(|(_, l)| !l.trim().is_empty()) else {
            return Err(Error::input(source, "empty file: not an rts.csv table"));
        };
        let names = cells(header).map_err(|why| bad(first, why))?;
        let cols = Columns::find(&names, header, source)?;
        let mut table = RtsTable {
            source: source.to_path_buf(),
            pixels: Vec::new(),
            skipped: 0,
        };
        // First line of each pixel: a hash map keeps the duplicate check linear in the rows.
        let mut seen: HashMap<(usize, usize), usize> = HashMap::new();
        for (line, text) in lines.filter(|(_, l)| !l.trim().is_empty()) {
            let cells = cells(text).map_err(|why| bad(line, why))?;
            if cells.len() != cols.count {
                let n = cols.count;
                return Err(bad(
                    line,
                    format!("{} cells, but the header has {n} columns", cells.len()),
                ));
            }
            if cells[cols.status] != "ok" {
                table.skipped += 1;
                continue;
            }
            let pixel = cols.pixel(&cells, line).map_err(|why| bad(line, why))?;
            if let Some(first) = seen.insert((pixel.x_px, pixel.y_px), line) {
                return Err(bad(
                    line,
                    format!(
                        "pixel (x_px {}, y_px {}) is listed twice (also on line {first})",
                        pixel.x_px, pixel.y_px
                    ),
                ));
            }
            table.pixels.push(pixel);
        }
        if table.pixels.is_empty() {
            return Err(Error::input(source, no_pixels(table.skipped)));
        }
        Ok(table)
    }
}

/// The text of the CSV file at `path` (`what` it should be, for messages): UTF-16 and
/// non-UTF-8 bytes refused (spreadsheets write either), a UTF-8 byte-order mark kept (the
/// parser drops it).
pub(crate) fn read_csv_text(path: &Path, what: &str) -> Result<String> {
    let bytes = std::fs::read(path).map_err(|source| Error::Io {
        path: path.to_path_buf(),
        source,
    })?;
    if bytes.starts_with(&[0xff, 0xfe]) || bytes.starts_with(&[0xfe, 0xff]) {
        return Err(Error::input(
            path,
            "UTF-16 text (its byte-order mark says so): save the table as UTF-8",
        ));
    }
    String::from_utf8(bytes).map_err(|e| {
        Error::input(
            path,
            format!(
                "not UTF-8 text (byte {} is not): not {what}",
                e.utf8_error().valid_up_to()
            ),
        )
    })
}

/// Why a table without a usable telegraph pixel is refused (`skipped` rows not `ok`).
fn no_pixels(skipped: usize) -> String {
    let what = if skipped == 0 {
        "the table has no rows".to_string()
    } else {
        format!("all {skipped} rows have a status other than `ok` (fits too poor to use)")
    };
    format!(
        "no RTS pixels in the table: {what}, so `scmos-rts` would simulate nothing but the \
         map; use `scmos-map` for a camera without telegraph pixels"
    )
}

/// The cells of one CSV line, trimmed; a cell in double quotes is unquoted (`""` is a quote
/// inside it). Err for a quote left open or text after a closing quote.
pub(crate) fn cells(line: &str) -> std::result::Result<Vec<Cow<'_, str>>, String> {
    let mut out = Vec::new();
    let mut rest = line;
    loop {
        let trimmed = rest.trim_start();
        let Some(quoted) = trimmed.strip_prefix('"') else {
            let end = rest.find(',').unwrap_or(rest.len());
            out.push(Cow::Borrowed(rest[..end].trim()));
            match rest.get(end + 1..) {
                Some(next) => rest = next,
                None => return Ok(out),
            }
            continue;
        };
        let cell = out.len() + 1;
        let mut value = String::new();
        let mut inside = quoted;
        loop {
            let Some(q) = inside.find('"') else {
                return Err(format!(
                    "cell {cell}: a quote is opened and not closed on this line"
                ));
            };
            value.push_str(&inside[..q]);
            inside = &inside[q + 1..];
            match inside.strip_prefix('"') {
                Some(after) => {
                    value.push('"');
                    inside = after;
                }
                None => break,
            }
        }
        let after = inside.trim_start();
        out.push(Cow::Owned(value.trim().to_string()));
        match after.strip_prefix(',') {
            Some(next) => rest = next,
            None if after.is_empty() => return Ok(out),
            None => {
                return Err(format!(
                    "cell {cell}: text after its closing quote (a quote inside a quoted cell \
                     is written twice)"
                ))
            }
        }
    }
}

impl Columns {
    /// The columns of the header `names` (the line `header` as written, for messages); an
    /// error names the first required column that is missing.
    fn find(names: &[Cow<str>], header: &str, source: &Path) -> Result<Columns> {
        let at = |name: &str| names.iter().position(|n| *n == name);
        let need = |name: &str| {
            at(name).ok_or_else(|| {
                Error::input(
                    source,
                    format!(
                        "line 1: no column '{name}': not an rts.csv table written by darks \
                         (header: {header})"
                    ),
                )
            })
        };
        let mut levels = [[None; 3]; MAX_LEVELS];
        for (k, cells) in levels.iter_mut().enumerate() {
            let k = k + 1;
            *cells = [
                at(&format!("level_{k}_e")),
                at(&format!("occupancy_{k}")),
                at(&format!("width_{k}_e")),
            ];
        }
        let cols = Columns {
            count: names.len(),
            x: need("x_px")?,
            y: need("y_px")?,
            n_levels: need("n_levels")?,
            status: need("status")?,
            levels,
        };
        if cols.levels[0][0].is_none() || cols.levels[0][2].is_none() {
            return Err(Error::input(source, no_electrons(1)));
        }
        need("occupancy_1")?;
        Ok(cols)
    }

    /// The telegraph pixel of one `ok` row; Err says what is wrong with the row.
    fn pixel(&self, cells: &[Cow<str>], line: usize) -> std::result::Result<RtsPixel, String> {
        let cell = |c: Option<usize>| c.and_then(|c| cells.get(c)).map_or("", |c| c.as_ref());
        let whole = |c: usize, name: &str| {
            let text = cell(Some(c));
            text.parse::<usize>()
                .map_err(|_| format!("'{name}' is '{text}', not a whole number >= 0"))
        };
        let n = whole(self.n_levels, "n_levels")?;
        if !(1..=MAX_LEVELS).contains(&n) {
            return Err(format!(
                "'n_levels' is {n}: a telegraph pixel has 1 to {MAX_LEVELS} levels"
            ));
        }
        let mut pixel = RtsPixel {
            x_px: whole(self.x, "x_px")?,
            y_px: whole(self.y, "y_px")?,
            levels_e: Vec::with_capacity(n),
            occupancy: Vec::with_capacity(n),
            widths_e: Vec::with_capacity(n),
            line,
        };
        for (k, [level, occupancy, width]) in self.levels.iter().take(n).enumerate() {
            let k = k + 1;
            let (level, width) = (cell(*level), cell(*width));
            if level.is_empty() || width.is_empty() {
                return Err(no_electrons(k));
            }
            // The column's name is formatted only for a message (a million rows are read).
            let number = |text: &str, name: &dyn Fn() -> String| {
                text.parse::<f64>()
                    .ok()
                    .filter(|v| v.is_finite())
                    .ok_or_else(|| format!("'{}' is '{text}', not a finite number", name()))
            };
            let occ = number(cell(*occupancy), &|| format!("occupancy_{k}"))?;
            let w = number(width, &|| format!("width_{k}_e"))?;
            if !(0.0..=1.0).contains(&occ) {
                return Err(format!("'occupancy_{k}' is {occ}: must be in [0, 1]"));
            }
            if w < 0.0 {
                return Err(format!("'width_{k}_e' is {w}: must be >= 0 e-"));
            }
            let l = number(level, &|| format!("level_{k}_e"))?;
            if w > MAX_NOISE_E {
                return Err(format!(
                    "'width_{k}_e' is {w}: at most {MAX_NOISE_E:e} e- (a read noise above that \
                     is no camera's)"
                ));
            }
            if l.abs() > MAX_LEVEL_E {
                return Err(format!(
                    "'level_{k}_e' is {l}: at most {MAX_LEVEL_E:e} e- either side of the \
                     offset (a pixel's full well; a telegraph step is a few to a few hundred e-)"
                ));
            }
            pixel.levels_e.push(l);
            pixel.occupancy.push(occ);
            pixel.widths_e.push(w);
        }
        let sum: f64 = pixel.occupancy.iter().sum();
        if (sum - 1.0).abs() > OCCUPANCY_SUM_TOLERANCE {
            return Err(format!(
                "the occupancies of the {n} levels sum to {sum}, not 1 (within {OCCUPANCY_SUM_TOLERANCE})"
            ));
        }
        pixel.occupancy.iter_mut().for_each(|o| *o /= sum);
        Ok(pixel)
    }
}

/// Why a table without levels in e- is refused, for level `k`.
fn no_electrons(k: usize) -> String {
    format!(
        "no level in e- ('level_{k}_e' and 'width_{k}_e' are empty or absent): this table was \
         written without the conversion gain; run darks again with `gain_e_per_adu` to write \
         the levels in e-"
    )
}

#[cfg(test)]
mod tests;

/// `rts.csv` text as `darks` writes it, for the tests of the table and of `scmos-rts`.
#[cfg(test)]
pub(crate) mod fixture {
    /// The header row of the shared format (without a line end).
    pub fn header() -> String {
        let mut cols = vec!["x_px,y_px,n_levels,status".to_string()];
        for k in 1..=super::MAX_LEVELS {
            cols.push(format!(
                "level_{k}_adu,level_{k}_se_adu,level_{k}_e,occupancy_{k},occupancy_{k}_se,\
                 width_{k}_adu,width_{k}_e,dwell_{k}_frames,dwell_{k}_se_frames"
            ));
        }
        cols.join(",")
    }

    /// One row: pixel (x, y), `status`, and per level (level e-, occupancy, width e-); the adu
    /// cells at a gain of 0.5 e-/adu, standard errors and dwell times filled with plausible
    /// values; the e- cells left empty when `electrons` is false.
    pub fn row(
        x: usize,
        y: usize,
        status: &str,
        levels: &[(f64, f64, f64)],
        electrons: bool,
    ) -> String {
        let mut cells = vec![format!("{x},{y},{},{status}", levels.len())];
        for k in 0..super::MAX_LEVELS {
            cells.push(match levels.get(k) {
                Some(&(l, o, w)) => {
                    let e = |v: f64| {
                        if electrons {
                            v.to_string()
                        } else {
                            String::new()
                        }
                    };
                    format!(
                        "{},0.01,{},{o},0.003,{},{},12.5,0.4",
                        l / 0.5,
                        e(l),
                        w / 0.5,
                        e(w)
                    )
                }
                None => ",,,,,,,,".to_string(),
            });
        }
        cells.join(",")
    }

    /// A table of `rows` under the header, one per line.
    pub fn table(rows: &[String]) -> String {
        let mut t = header();
        for r in rows {
            t.push('\n');
            t.push_str(r);
        }
        t.push('\n');
        t
    }
}
