//! Aligned text tables for the terminal (`simulate`, `effective`, `effective --simple-qe`):
//! each column declared once (header, alignment, width, the gap before it and its cell),
//! every table's lines written by [`render`].

/// How a column's cells line up.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Align {
    /// Text reads left to right.
    Left,
    /// Numbers align on their last digit.
    Right,
}

/// How wide a column is, in characters.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Width {
    /// At least this wide; a wider cell pushes the rest of its line to the right.
    AtLeast(usize),
    /// As wide as its widest cell or its header.
    Fit,
}

/// A column of a table of records `R`.
pub struct Column<R> {
    /// Header (the unit in the name, as in the CSV).
    pub head: &'static str,
    /// Alignment of the header and the cells.
    pub align: Align,
    /// Width.
    pub width: Width,
    /// Spaces before the column (ignored for the first).
    pub gap: usize,
    /// The cell of a record.
    pub cell: fn(&R) -> String,
}

// Not derived: a derive would ask `R: Clone`, and a column holds no `R`.
impl<R> Clone for Column<R> {
    fn clone(&self) -> Self {
        *self
    }
}

impl<R> Copy for Column<R> {}

impl<R> Column<R> {
    /// A column as wide as its widest cell, two spaces after the previous one.
    pub fn fit(head: &'static str, align: Align, cell: fn(&R) -> String) -> Self {
        Column {
            head,
            align,
            width: Width::Fit,
            gap: 2,
            cell,
        }
    }
}

/// The header line and one line per record, each without trailing spaces; `heading(k)` is a
/// line written before record `k` (a group's heading), if any.
pub fn render<R>(
    columns: &[Column<R>],
    records: &[R],
    heading: impl Fn(usize) -> Option<String>,
) -> String {
    let rows: Vec<Vec<String>> = records
        .iter()
        .map(|r| columns.iter().map(|c| (c.cell)(r)).collect())
        .collect();
    let widths: Vec<usize> = columns
        .iter()
        .enumerate()
        .map(|(k, c)| match c.width {
            Width::AtLeast(w) => w,
            Width::Fit => rows
                .iter()
                .map(|r| r[k].chars().count())
                .chain([c.head.chars().count()])
                .max()
                .unwrap_or(0),
        })
        .collect();
    let line = |cells: &mut dyn Iterator<Item = &str>| {
        let mut s = String::new();
        for (k, (cell, (c, &w))) in cells.zip(columns.iter().zip(&widths)).enumerate() {
            if k > 0 {
                s += &" ".repeat(c.gap);
            }
            match c.align {
                Align::Left => s += &format!("{cell:<w$}"),
                Align::Right => s += &format!("{cell:>w$}"),
            }
        }
        s.trim_end().to_string() + "\n"
    };
    let mut out = line(&mut columns.iter().map(|c| c.head));
    for (k, row) in rows.iter().enumerate() {
        if let Some(h) = heading(k) {
            out += &h;
            out.push('\n');
        }
        out += &line(&mut row.iter().map(String::as_str));
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fixed_columns_overflow_fitted_ones_align_and_headings_go_before_their_row() {
        let columns = [
            Column {
                head: "n",
                align: Align::Right,
                width: Width::AtLeast(3),
                gap: 0,
                cell: |r: &(u32, &str)| r.0.to_string(),
            },
            Column::fit("name", Align::Left, |r| r.1.to_string()),
            Column {
                head: "tail",
                align: Align::Left,
                width: Width::AtLeast(0),
                gap: 1,
                cell: |_| String::new(),
            },
        ];
        let records = [(7, "a"), (12345, "longer")];
        let text = render(&columns, &records, |k| (k == 1).then(|| "group:".into()));
        assert_eq!(
            text, "  n  name   tail\n  7  a\ngroup:\n12345  longer\n",
            "{text}"
        );
    }
}
