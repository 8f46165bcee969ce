//! The manifest detnoise leaves in every output directory, and the survey of an existing
//! directory into the files detnoise wrote (listed in its manifest) and everything else.

use serde::{Deserialize, Serialize};
use std::collections::BTreeSet;
use std::path::{Component, Path, PathBuf};

/// File name of the manifest inside an output directory.
pub const MANIFEST_NAME: &str = ".detnoise-manifest.json";

/// Contents of `.detnoise-manifest.json`: who wrote the directory, and which files.
#[derive(Debug, Serialize, Deserialize)]
pub struct Manifest {
    /// Always `detnoise`.
    pub tool: String,
    /// Version of detnoise that wrote the directory.
    pub version: String,
    /// The subcommand that wrote it.
    pub command: String,
    /// When it was written, UTC, ISO 8601 (`2025-01-31T12:00:00Z`).
    pub created_utc: String,
    /// The files detnoise wrote, relative to the directory (`/`-separated).
    pub files: Vec<String>,
}

impl Manifest {
    /// The manifest of `command` listing `files` (relative paths), stamped now.
    pub fn new(command: &str, files: &[PathBuf]) -> Self {
        Manifest {
            tool: "detnoise".into(),
            version: env!("CARGO_PKG_VERSION").into(),
            command: command.into(),
            created_utc: utc_now(),
            files: files
                .iter()
                .map(|f| f.to_string_lossy().into_owned())
                .collect(),
        }
    }

    /// The manifest in `dir`, if it is one detnoise wrote.
    fn read(dir: &Path) -> Option<Manifest> {
        let text = std::fs::read_to_string(dir.join(MANIFEST_NAME)).ok()?;
        let m: Manifest = serde_json::from_str(&text).ok()?;
        (m.tool == "detnoise").then_some(m)
    }

    /// The listed files that are plain relative paths (nothing outside the directory).
    fn listed(&self) -> BTreeSet<PathBuf> {
        self.files
            .iter()
            .map(PathBuf::from)
            .filter(|p| {
                p.components().count() > 0
                    && p.components().all(|c| matches!(c, Component::Normal(_)))
            })
            .collect()
    }
}

/// What an existing directory holds.
#[derive(Debug, Default)]
pub(crate) struct Survey {
    /// Files present that the directory's detnoise manifest lists (relative).
    pub ours: BTreeSet<PathBuf>,
    /// Entries detnoise did not write (relative; a foreign directory is one entry).
    pub foreign: Vec<PathBuf>,
}

/// Sort the entries of `dir` into detnoise's (listed in its manifest) and foreign ones.
pub(crate) fn survey(dir: &Path) -> std::io::Result<Survey> {
    let manifest = Manifest::read(dir);
    let listed = manifest.as_ref().map(Manifest::listed).unwrap_or_default();
    let mut s = Survey::default();
    walk(dir, Path::new(""), &listed, manifest.is_some(), &mut s)?;
    Ok(s)
}

fn walk(
    root: &Path,
    rel: &Path,
    listed: &BTreeSet<PathBuf>,
    has_manifest: bool,
    s: &mut Survey,
) -> std::io::Result<()> {
    let mut entries: Vec<_> = std::fs::read_dir(root.join(rel))?
        .map(|e| e.map(|e| e.file_name()))
        .collect::<std::io::Result<_>>()?;
    entries.sort();
    for name in entries {
        let p = rel.join(&name);
        let is_dir = std::fs::symlink_metadata(root.join(&p))?.is_dir();
        if is_dir && listed.iter().any(|f| f.starts_with(&p)) {
            walk(root, &p, listed, has_manifest, s)?;
        } else if !is_dir && listed.contains(&p) {
            s.ours.insert(p);
        } else if !(has_manifest && p == Path::new(MANIFEST_NAME)) {
            s.foreign.push(p);
        }
    }
    Ok(())
}

/// Every file under `dir`, relative to it, sorted.
pub(crate) fn files_under(dir: &Path) -> std::io::Result<Vec<PathBuf>> {
    fn go(root: &Path, rel: &Path, out: &mut Vec<PathBuf>) -> std::io::Result<()> {
        for e in std::fs::read_dir(root.join(rel))? {
            let e = e?;
            let p = rel.join(e.file_name());
            if e.file_type()?.is_dir() {
                go(root, &p, out)?;
            } else {
                out.push(p);
            }
        }
        Ok(())
    }
    let mut out = Vec::new();
    go(dir, Path::new(""), &mut out)?;
    out.sort();
    Ok(out)
}

/// The current UTC time as `YYYY-MM-DDThh:mm:ssZ`.
fn utc_now() -> String {
    let secs = std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map_or(0, |d| d.as_secs());
    let (days, rem) = (secs / 86_400, secs % 86_400);
    let (y, m, d) = civil_from_days(days as i64);
    format!(
        "{y:04}-{m:02}-{d:02}T{:02}:{:02}:{:02}Z",
        rem / 3600,
        rem % 3600 / 60,
        rem % 60
    )
}

/// Proleptic Gregorian date of a day count since 1970-01-01 (H. Hinnant's algorithm).
fn civil_from_days(z: i64) -> (i64, u32, u32) {
    let z = z + 719_468;
    let era = z.div_euclid(146_097);
    let doe = z.rem_euclid(146_097);
    let yoe = (doe - doe / 1460 + doe / 36_524 - doe / 146_096) / 365;
    let doy = doe - (365 * yoe + yoe / 4 - yoe / 100);
    let mp = (5 * doy + 2) / 153;
    let d = (doy - (153 * mp + 2) / 5 + 1) as u32;
    let m = if mp < 10 { mp + 3 } else { mp - 9 } as u32;
    (yoe + era * 400 + i64::from(m <= 2), m, d)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn civil_dates_of_known_days() {
        assert_eq!(civil_from_days(0), (1970, 1, 1));
        assert_eq!(civil_from_days(11_016), (2000, 2, 29));
        assert_eq!(civil_from_days(19_782), (2024, 2, 29));
        assert_eq!(civil_from_days(-1), (1969, 12, 31));
    }

    #[test]
    fn survey_separates_listed_files_from_the_rest() {
        let dir = tempfile::tempdir().unwrap();
        let d = dir.path();
        std::fs::create_dir(d.join("sub")).unwrap();
        for f in ["a.csv", "sub/b.png", "notes.txt"] {
            std::fs::write(d.join(f), b"x").unwrap();
        }
        std::fs::create_dir(d.join("mine")).unwrap();
        let files = [
            PathBuf::from("a.csv"),
            PathBuf::from("sub/b.png"),
            "../x".into(),
        ];
        let m = Manifest::new("darks", &files);
        std::fs::write(d.join(MANIFEST_NAME), serde_json::to_string(&m).unwrap()).unwrap();
        let s = survey(d).unwrap();
        assert_eq!(s.ours.len(), 2);
        assert_eq!(s.foreign, [PathBuf::from("mine"), "notes.txt".into()]);
        // Without a manifest everything is foreign, a stray manifest-named file included.
        std::fs::write(d.join(MANIFEST_NAME), b"{}").unwrap();
        assert_eq!(survey(d).unwrap().foreign.len(), 5);
        assert_eq!(files_under(d).unwrap().len(), 4);
    }
}
