//! Writing results: atomic files, and records as text tables, CSV or JSON.

use crate::{Error, Result};
use serde::Serialize;
use serde_json::Value;
use std::path::Path;

/// Write `bytes` to `path` atomically: a temporary file beside it, then a rename, so a
/// failure never leaves a partial or overwritten output.
pub fn write_atomic(path: &Path, bytes: &[u8]) -> Result<()> {
    write_atomic_with(path, |tmp| {
        std::fs::write(tmp, bytes).map_err(|e| Error::io(tmp, e))
    })
}

/// Run `write` on a temporary path beside `path`, then rename it to `path`.
pub fn write_atomic_with(path: &Path, write: impl FnOnce(&Path) -> Result<()>) -> Result<()> {
    let dir = match path.parent() {
        Some(d) if !d.as_os_str().is_empty() => d.to_path_buf(),
        _ => std::path::PathBuf::from("."),
    };
    let name = path
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_default();
    let tmp = tempfile::Builder::new()
        .prefix(&format!(".{name}."))
        .suffix(".tmp")
        .tempfile_in(&dir)
        .map_err(|e| Error::io(&dir, e))?;
    let tmp_path = tmp.path().to_path_buf();
    write(&tmp_path)?;
    // tempfile creates 0600 files; outputs are ordinary shared results.
    set_mode(&tmp_path, 0o644)?;
    tmp.persist(path).map_err(|e| Error::io(path, e.error))?;
    Ok(())
}

fn set_mode(path: &Path, mode: u32) -> Result<()> {
    use std::os::unix::fs::PermissionsExt;
    std::fs::set_permissions(path, std::fs::Permissions::from_mode(mode))
        .map_err(|e| Error::io(path, e))
}

/// Output format of a table of records.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
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

/// An output directory built in a temporary sibling and moved into place only on success,
/// so a failed run leaves neither a half-written directory nor a damaged earlier one.
pub struct OutputDir {
    target: std::path::PathBuf,
    tmp: tempfile::TempDir,
}

impl OutputDir {
    /// Start building the directory `target`.
    pub fn new(target: &Path) -> Result<Self> {
        let parent = match target.parent() {
            Some(p) if !p.as_os_str().is_empty() => p.to_path_buf(),
            _ => std::path::PathBuf::from("."),
        };
        std::fs::create_dir_all(&parent).map_err(|e| Error::io(&parent, e))?;
        let name = target
            .file_name()
            .map(|n| n.to_string_lossy().to_string())
            .unwrap_or_else(|| "out".into());
        let tmp = tempfile::Builder::new()
            .prefix(&format!(".{name}.partial-"))
            .tempdir_in(&parent)
            .map_err(|e| Error::io(&parent, e))?;
        Ok(OutputDir {
            target: target.to_path_buf(),
            tmp,
        })
    }

    /// Path of `file` inside the directory being built.
    pub fn path(&self, file: &str) -> std::path::PathBuf {
        self.tmp.path().join(file)
    }

    /// Move the finished directory into place, replacing an earlier one of the same name.
    pub fn commit(self) -> Result<std::path::PathBuf> {
        if self.target.is_dir() {
            std::fs::remove_dir_all(&self.target).map_err(|e| Error::io(&self.target, e))?;
        } else if self.target.exists() {
            return Err(Error::input(&self.target, "exists and is not a directory"));
        }
        let tmp = self.tmp.keep();
        set_mode(&tmp, 0o755)?;
        std::fs::rename(&tmp, &self.target).map_err(|e| Error::io(&self.target, e))?;
        Ok(self.target)
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
