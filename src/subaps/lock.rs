//! One writer per part file: a run holds an OS lock on `subaps-K-of-N.part.lock` beside the
//! part (its pid written inside) from before it reads the part until it ends, so a second run
//! on the same `--out` and shard is refused at once, naming the first's pid, and never touches
//! the part. The OS drops the lock with its process: a lock file left by a killed run does not
//! block the resume.

use crate::{Error, Result};
use std::fs::{File, OpenOptions, TryLockError};
use std::io::Write as _;
use std::os::unix::fs::MetadataExt as _;
use std::path::{Path, PathBuf};

/// Suffix of a part's lock file (`subaps-K-of-N.part.lock`).
pub(crate) const SUFFIX: &str = ".lock";

/// The held lock of one part file; dropping it removes the lock file and releases the lock.
#[derive(Debug)]
pub(crate) struct PartLock {
    file: File,
    path: PathBuf,
}

impl PartLock {
    /// Take the lock of the part file `part` without waiting: an error naming the holder's
    /// pid (field `out`) when another process holds it.
    pub(crate) fn take(part: &Path) -> Result<PartLock> {
        let path = lock_path(part);
        loop {
            let file = OpenOptions::new()
                .read(true)
                .write(true)
                .create(true)
                .truncate(false)
                .open(&path)
                .map_err(|e| Error::io(&path, e))?;
            match file.try_lock() {
                Ok(()) => {}
                Err(TryLockError::WouldBlock) => return Err(held(part, &path)),
                Err(TryLockError::Error(e)) => return Err(Error::io(&path, e)),
            }
            // A holder that ended removed the file after it was opened here: that lock guards
            // nothing, take the one at the path.
            if !is_at(&file, &path) {
                continue;
            }
            let mut lock = PartLock { file, path };
            lock.write_pid()?;
            return Ok(lock);
        }
    }

    fn write_pid(&mut self) -> Result<()> {
        let io = |e| Error::io(&self.path, e);
        self.file.set_len(0).map_err(io)?;
        (&self.file)
            .write_all(format!("{}\n", std::process::id()).as_bytes())
            .map_err(io)
    }
}

impl Drop for PartLock {
    fn drop(&mut self) {
        // Removed while still locked (the file closes after this): a run that opened it
        // meanwhile sees that it is no longer at the path and takes a new one.
        let _ = std::fs::remove_file(&self.path);
    }
}

/// The lock file of the part file `part`.
fn lock_path(part: &Path) -> PathBuf {
    let mut name = part.as_os_str().to_owned();
    name.push(SUFFIX);
    PathBuf::from(name)
}

/// Whether the open `file` is the file now at `path`.
fn is_at(file: &File, path: &Path) -> bool {
    match (file.metadata(), std::fs::metadata(path)) {
        (Ok(a), Ok(b)) => (a.dev(), a.ino()) == (b.dev(), b.ino()),
        _ => false,
    }
}

/// The refusal of a second writer: the holder's pid as its lock file states it.
fn held(part: &Path, lock: &Path) -> Error {
    let pid = std::fs::read_to_string(lock)
        .ok()
        .and_then(|t| t.trim().parse::<u32>().ok())
        .map_or("pid not yet written".to_string(), |p| format!("pid {p}"));
    Error::invalid(
        "out",
        format!(
            "{} is being written by another detnoise run ({pid}, holding {}): wait for it to \
             end, or stop it and rerun to resume; give another `out` to run apart",
            part.display(),
            lock.display()
        ),
    )
}
