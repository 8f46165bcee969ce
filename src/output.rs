//! Writing results: output directories and files under the `--out` rule, atomic files, and
//! records as text tables, CSV or JSON.

mod dir;
mod file;
pub mod manifest;
mod paths;
pub mod temps;

pub use dir::{DirPlan, OutputDir};
pub use file::{check_file, FileOut, StagedFiles};

use crate::{Error, Result};
use serde::Serialize;
use serde_json::Value;
use std::path::Path;
use temps::{plain, Kind, Temp};

/// Write `bytes` to `path` atomically: a temporary file beside it, then a rename, so a
/// failure never leaves a partial or overwritten output.
pub fn write_atomic(path: &Path, bytes: &[u8]) -> Result<()> {
    write_atomic_with(path, |tmp| {
        std::fs::write(tmp, bytes).map_err(|e| Error::io(tmp, e))
    })
}

/// Run `write` on a temporary path beside `path`, then rename it to `path`. The temporary is
/// registered: an interruption removes it, and errors that name it name `path` instead.
pub fn write_atomic_with(path: &Path, write: impl FnOnce(&Path) -> Result<()>) -> Result<()> {
    let dir = match path.parent() {
        Some(d) if !d.as_os_str().is_empty() => d.to_path_buf(),
        _ => std::path::PathBuf::from("."),
    };
    let name = path
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_default();
    let tmp = Temp::create(Kind::File, Some(path), || {
        tempfile::Builder::new()
            .prefix(&format!(".{name}."))
            .suffix(".tmp")
            .tempfile_in(&dir)?
            .into_temp_path()
            .keep()
            .map_err(|e| e.error)
    })
    .map_err(|e| Error::io(path, plain(e)))?;
    write(tmp.path())?;
    // tempfile creates 0600 files; outputs are ordinary shared results.
    set_mode(tmp.path(), 0o644)?;
    tmp.rename_to(path).map_err(|e| Error::io(path, e))
}

/// Write a serialisable value to `path` as pretty JSON with a final newline, atomically.
pub fn write_json(path: &Path, value: &impl Serialize) -> Result<()> {
    let text = serde_json::to_string_pretty(value)
        .map_err(|e| Error::Numeric(format!("{}: cannot encode as JSON: {e}", path.display())))?;
    write_atomic(path, format!("{text}\n").as_bytes())
}

/// Escape `&`, `<` and `>` for HTML text.
pub fn html_escape(s: &str) -> String {
    s.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
}

pub(crate) fn set_mode(path: &Path, mode: u32) -> Result<()> {
    use std::os::unix::fs::PermissionsExt;
    std::fs::set_permissions(path, std::fs::Permissions::from_mode(mode))
        .map_err(|e| Error::io(path, e))
}

/// Output format of a table of records.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "cli", derive(clap::ValueEnum))]
pub enum Format {
    /// Aligned text columns for reading in a terminal.
    Table,
    /// Comma-separated values with a header row (pandas-friendly).
    Csv,
    /// A JSON array of objects.
    Json,
}

/// Render records in `format`. CSV and table keep the scalar fields; JSON keeps everything.
pub fn render<T: Serialize>(records: &[T], format: Format) -> Result<String> {
    let values: Vec<Value> = records
        .iter()
        .map(serde_json::to_value)
        .collect::<std::result::Result<_, _>>()
        .map_err(|e| Error::Numeric(format!("cannot serialise results: {e}")))?;
    Ok(match format {
        Format::Json => serde_json::to_string_pretty(&values).expect("values serialise") + "\n",
        Format::Csv => {
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
        Format::Table => {
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
            render(&recs, Format::Csv).unwrap(),
            "spot,r_px,n\n\"gauss:1,2\",0.123457,3\n"
        );
        let json: Value = serde_json::from_str(&render(&recs, Format::Json).unwrap()).unwrap();
        assert_eq!(json[0]["levels"][0], 1.0);
        assert!(render(&recs, Format::Table)
            .unwrap()
            .starts_with("     spot"));
    }

    #[test]
    fn atomic_write_replaces_whole_file() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("a.txt");
        write_atomic(&p, b"one").unwrap();
        write_atomic(&p, b"two").unwrap();
        assert_eq!(std::fs::read(&p).unwrap(), b"two");
        assert!(write_atomic(&dir.path().join("missing/a.txt"), b"x").is_err());
    }
}
