//! Records as text: an aligned table for the terminal, CSV, or JSON.

use crate::{Error, Result};
use serde::Serialize;
use serde_json::Value;

/// Output format of a table of records.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "cli", derive(clap::ValueEnum))]
pub enum TableFormat {
    /// Aligned text columns for reading in a terminal.
    Table,
    /// Comma-separated values with a header row (pandas-friendly).
    Csv,
    /// A JSON array of objects.
    Json,
}

/// Write `records` into `dir` as CSV under `names[0]` and JSON under `names[1]`, each
/// atomically; returns the two paths.
pub fn write_csv_json<T: Serialize>(
    records: &[T],
    dir: &std::path::Path,
    names: [&str; 2],
) -> Result<Vec<std::path::PathBuf>> {
    let mut written = Vec::new();
    for (name, format) in names.iter().zip([TableFormat::Csv, TableFormat::Json]) {
        let path = dir.join(name);
        super::write_atomic(&path, render(records, format)?.as_bytes())?;
        written.push(path);
    }
    Ok(written)
}

/// Render records in `format`. CSV and table keep the scalar fields; JSON keeps everything.
pub fn render<T: Serialize>(records: &[T], format: TableFormat) -> Result<String> {
    let values: Vec<Value> = records
        .iter()
        .map(serde_json::to_value)
        .collect::<std::result::Result<_, _>>()
        .map_err(|e| Error::Numeric(format!("cannot serialise results: {e}")))?;
    Ok(match format {
        TableFormat::Json => {
            serde_json::to_string_pretty(&values).expect("values serialise") + "\n"
        }
        TableFormat::Csv => {
            let (head, rows) = scalar_columns(&values);
            let mut s = head
                .iter()
                .map(|h| csv_field(h))
                .collect::<Vec<_>>()
                .join(",")
                + "\n";
            for row in rows {
                s += &(row
                    .iter()
                    .map(|c| csv_field(c))
                    .collect::<Vec<_>>()
                    .join(",")
                    + "\n");
            }
            s
        }
        TableFormat::Table => {
            let (head, rows) = scalar_columns(&values);
            let widths: Vec<usize> = (0..head.len())
                .map(|k| {
                    rows.iter()
                        .map(|r| r[k].len())
                        .chain([head[k].len()])
                        .max()
                        .unwrap_or(0)
                })
                .collect();
            let line = |cells: &[String]| {
                cells
                    .iter()
                    .zip(&widths)
                    .map(|(c, w)| format!("{c:>w$}"))
                    .collect::<Vec<_>>()
                    .join("  ")
                    .trim_end()
                    .to_string()
                    + "\n"
            };
            let mut s = line(&head);
            for row in &rows {
                s += &line(row);
            }
            s
        }
    })
}

/// Header and rows of the scalar (non-array, non-object) fields, in field order.
fn scalar_columns(values: &[Value]) -> (Vec<String>, Vec<Vec<String>>) {
    let head: Vec<String> = match values.first() {
        Some(Value::Object(m)) => m
            .iter()
            .filter(|(_, v)| !v.is_array() && !v.is_object())
            .map(|(k, _)| k.clone())
            .collect(),
        _ => Vec::new(),
    };
    let rows = values
        .iter()
        .map(|v| {
            head.iter()
                .map(|k| match v.get(k) {
                    Some(Value::String(s)) => s.clone(),
                    Some(Value::Number(x)) => format_number(x),
                    Some(Value::Null) | None => String::new(),
                    Some(other) => other.to_string(),
                })
                .collect()
        })
        .collect();
    (head, rows)
}

fn format_number(x: &serde_json::Number) -> String {
    match x.as_f64() {
        Some(f) if x.is_f64() => format!("{}", (f * 1e6).round() / 1e6),
        _ => x.to_string(),
    }
}

fn csv_field(s: &str) -> String {
    if s.contains([',', '"', '\n']) {
        format!("\"{}\"", s.replace('"', "\"\""))
    } else {
        s.to_string()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[derive(Serialize)]
    struct Rec {
        spot: String,
        r_px: f64,
        n: u32,
        levels: Vec<f64>,
    }

    #[test]
    fn csv_quotes_commas_and_drops_arrays() {
        let recs = [Rec {
            spot: "gauss:1,2".into(),
            r_px: 0.1234567891,
            n: 3,
            levels: vec![1.0],
        }];
        assert_eq!(
            render(&recs, TableFormat::Csv).unwrap(),
            "spot,r_px,n\n\"gauss:1,2\",0.123457,3\n"
        );
        let json: Value = serde_json::from_str(&render(&recs, TableFormat::Json).unwrap()).unwrap();
        assert_eq!(json[0]["levels"][0], 1.0);
        assert!(render(&recs, TableFormat::Table)
            .unwrap()
            .starts_with("     spot"));
    }
}
