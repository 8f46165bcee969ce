//! Atomic files: written beside their final name, then renamed, so a failure never leaves a
//! partial or overwritten output.

use super::temps::{plain, Kind, Temp};
use crate::{Error, Result};
use serde::Serialize;
use std::path::Path;

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

pub(super) fn set_mode(path: &Path, mode: u32) -> Result<()> {
    use std::os::unix::fs::PermissionsExt;
    std::fs::set_permissions(path, std::fs::Permissions::from_mode(mode))
        .map_err(|e| Error::io(path, e))
}

#[cfg(test)]
mod tests {
    use super::*;

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
