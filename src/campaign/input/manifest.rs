//! The CSV manifest of a campaign: a header `file,kind,exposure_s,em_gain,temperature_c,
//! light_level` (any order; every column present, `em_gain`, `temperature_c` and
//! `light_level` cells may be empty), one row per stack, file paths relative to the
//! manifest's folder. Cells are CSV cells as in the RTS tables (quotes, a UTF-8 byte-order
//! mark dropped).

use std::borrow::Cow;
use std::path::{Path, PathBuf};

use super::stack::{beside, check_condition, number, parse_kind, CampaignStack, Listed};
use crate::campaign::condition::Condition;
use crate::detector::rts_table::{cells, read_csv_text};
use crate::error::{Error, Result};

/// The columns of a campaign manifest, in the order the docs give them.
pub const MANIFEST_COLUMNS: [&str; 6] = [
    "file",
    "kind",
    "exposure_s",
    "em_gain",
    "temperature_c",
    "light_level",
];

/// Read the manifest at `path`: one [`CampaignStack`] per row, in order.
pub fn read_manifest(path: &Path) -> Result<Vec<CampaignStack>> {
    let text = read_csv_text(path, "a campaign manifest (CSV)")?;
    parse_manifest(&text, path)
}

/// Parse the text of a manifest; `source` names it in errors and places relative paths.
pub fn parse_manifest(text: &str, source: &Path) -> Result<Vec<CampaignStack>> {
    let bad = |line: usize, what: String| Error::input(source, format!("line {line}: {what}"));
    let text = text.strip_prefix('\u{feff}').unwrap_or(text);
    let mut lines = text
        .lines()
        .enumerate()
        .map(|(i, l)| (i + 1, l))
        .filter(|(_, l)| !l.trim().is_empty());
    let Some((first, header)) = lines.next() else {
        return Err(Error::input(
            source,
            format!(
                "empty file: a campaign manifest needs the header {}",
                MANIFEST_COLUMNS.join(",")
            ),
        ));
    };
    let names = cells(header).map_err(|why| bad(first, why))?;
    let at = columns(&names).map_err(|why| bad(first, why))?;
    let mut stacks = Vec::new();
    for (line, row) in lines {
        let cells = cells(row).map_err(|why| bad(line, why))?;
        if cells.len() != names.len() {
            return Err(bad(
                line,
                format!(
                    "{} cells, but the header has {} columns",
                    cells.len(),
                    names.len()
                ),
            ));
        }
        let cell = |c: usize| cells[at[c]].as_ref();
        let stack = row_stack(cell, source, line).map_err(|why| bad(line, why))?;
        stacks.push(stack);
    }
    if stacks.is_empty() {
        return Err(Error::input(
            source,
            "the manifest lists no stacks (a header and no rows)",
        ));
    }
    Ok(stacks)
}

/// The position of each of [`MANIFEST_COLUMNS`] in the header `names`, or why not.
fn columns(names: &[Cow<str>]) -> std::result::Result<[usize; 6], String> {
    if let Some(unknown) = names
        .iter()
        .find(|n| !MANIFEST_COLUMNS.contains(&n.as_ref()))
    {
        return Err(format!(
            "unknown column {unknown:?}: a campaign manifest has the columns {}",
            MANIFEST_COLUMNS.join(",")
        ));
    }
    let mut at = [0; 6];
    for (slot, want) in at.iter_mut().zip(MANIFEST_COLUMNS) {
        let found: Vec<usize> = (0..names.len()).filter(|i| names[*i] == want).collect();
        *slot = match found.as_slice() {
            [one] => *one,
            [] => {
                return Err(format!(
                    "no column '{want}' (the header needs {}; optional values may be empty cells)",
                    MANIFEST_COLUMNS.join(",")
                ))
            }
            _ => return Err(format!("column '{want}' given twice")),
        };
    }
    Ok(at)
}

/// The stack of one row: `cell(c)` is the cell of column `MANIFEST_COLUMNS[c]`.
fn row_stack<'a>(
    cell: impl Fn(usize) -> &'a str,
    source: &Path,
    line: usize,
) -> std::result::Result<CampaignStack, String> {
    let file = cell(0);
    if file.is_empty() {
        return Err("the 'file' cell is empty: every row names its stack file".into());
    }
    let kind = parse_kind(cell(1))?;
    let optional = |c: usize| -> std::result::Result<Option<f64>, String> {
        match cell(c) {
            "" => Ok(None),
            t => number(t, MANIFEST_COLUMNS[c]).map(Some),
        }
    };
    let exposure = cell(2);
    if exposure.is_empty() {
        return Err(
            "the 'exposure_s' cell is empty: every stack needs its exposure time (s)".into(),
        );
    }
    let condition = Condition {
        exposure_s: number(exposure, "exposure_s")?,
        em_gain: optional(3)?,
        temperature_c: optional(4)?,
        kind,
        light_level: optional(5)?,
    };
    check_condition(&condition)?;
    Ok(CampaignStack {
        files: vec![beside(source, &PathBuf::from(file))],
        condition,
        listed_in: Listed {
            source: source.to_path_buf(),
            line: Some(line),
        },
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::campaign::condition::StackKind;

    const HEADER: &str = "file,kind,exposure_s,em_gain,temperature_c,light_level\n";

    #[test]
    fn rows_read_with_bom_quotes_and_empty_optional_cells() {
        let text =
            format!("\u{feff}{HEADER}a.fits,dark,0.5,,,\n\"b, c.fits\",FLAT,1,100,-40,\"2.5\"\n");
        let s = parse_manifest(&text, Path::new("/data/m.csv")).unwrap();
        assert_eq!(s.len(), 2);
        assert_eq!(s[0].files, vec![PathBuf::from("/data/a.fits")]);
        assert_eq!(s[0].condition.kind, StackKind::Dark);
        assert_eq!(s[0].condition.em_gain, None);
        assert_eq!(s[1].files, vec![PathBuf::from("/data/b, c.fits")]);
        assert_eq!(s[1].condition.em_gain, Some(100.0));
        assert_eq!(s[1].condition.temperature_c, Some(-40.0));
        assert_eq!(s[1].condition.light_level, Some(2.5));
        assert_eq!(s[1].listed_in.line, Some(3));
    }

    #[test]
    fn columns_in_any_order() {
        let text = "kind,light_level,file,temperature_c,em_gain,exposure_s\ndark,,x.fits,,,2\n";
        let s = parse_manifest(text, Path::new("m.csv")).unwrap();
        assert_eq!(s[0].condition.exposure_s, 2.0);
        assert_eq!(s[0].files, vec![PathBuf::from("x.fits")]);
    }

    #[test]
    fn bad_manifests_refused_naming_line_and_what() {
        let cases = [
            ("file,kind,exposure_s\n", "no column 'em_gain'"),
            (
                "file,kind,exposure,em_gain,temperature_c,light_level\n",
                "unknown column \"exposure\"",
            ),
            (
                &format!("{HEADER}a.fits,dark,,,,\n"),
                "line 2: the 'exposure_s' cell is empty",
            ),
            (
                &format!("{HEADER}a.fits,bias,1,,,\n"),
                "line 2: kind \"bias\"",
            ),
            (
                &format!("{HEADER}a.fits,dark,1,,,3\n"),
                "line 2: a dark with light_level 3",
            ),
            (
                &format!("{HEADER}a.fits,dark,-1,,,\n"),
                "exposure_s -1 is negative",
            ),
            (
                &format!("{HEADER}a.fits,dark,1,0.5,,\n"),
                "em_gain 0.5 is below 1",
            ),
            (
                &format!("{HEADER}a.fits,dark,abc,,,\n"),
                "exposure_s \"abc\" is not a finite number",
            ),
            (
                &format!("{HEADER}a.fits,dark,1,,\n"),
                "line 2: 5 cells, but the header has 6",
            ),
            (&format!("{HEADER},dark,1,,,\n"), "the 'file' cell is empty"),
            (HEADER, "lists no stacks"),
        ];
        for (text, want) in cases {
            let e = parse_manifest(text, Path::new("m.csv"))
                .unwrap_err()
                .to_string();
            assert!(e.contains("m.csv") && e.contains(want), "{text:?}: {e}");
        }
    }
}
