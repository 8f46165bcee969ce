//! The run's temporary paths: an interruption (Ctrl-C, SIGTERM) removes every one of them
//! before exiting, and error messages show the output path a temporary stands for, never
//! the temporary itself.

use crate::Error;
use std::path::{Path, PathBuf};
use std::sync::{Mutex, MutexGuard};

/// How a registered path is removed.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Kind {
    /// A temporary file.
    File,
    /// A temporary directory with everything in it.
    Tree,
    /// A directory created to hold the output: removed only while it is empty.
    Created,
}

/// Registered temporaries (removed on interruption) and the user paths they stand for.
struct Registry {
    live: Vec<(PathBuf, Kind)>,
    aliases: Vec<(PathBuf, PathBuf)>,
}

static REGISTRY: Mutex<Registry> = Mutex::new(Registry {
    live: Vec::new(),
    aliases: Vec::new(),
});

/// The locked registry. While a guard lives the interrupt handler waits, so a sequence of
/// renames done under it is never cut in half by Ctrl-C.
pub(crate) struct Guard(MutexGuard<'static, Registry>);

/// Lock the registry (a panic elsewhere never makes it unusable).
pub(crate) fn lock() -> Guard {
    Guard(REGISTRY.lock().unwrap_or_else(|p| p.into_inner()))
}

impl Guard {
    /// Register `temp`, standing for `user` in messages if given.
    fn add(&mut self, temp: &Path, kind: Kind, user: Option<&Path>) {
        self.0.live.push((temp.to_path_buf(), kind));
        if let Some(user) = user {
            let user = if user.as_os_str().is_empty() {
                Path::new(".")
            } else {
                user
            };
            self.0
                .aliases
                .push((temp.to_path_buf(), user.to_path_buf()));
        }
    }

    /// Stop removing `temp` on interruption; `keep_alias` keeps mapping it in messages (for
    /// an error that is still on its way to the user).
    pub(crate) fn forget(&mut self, temp: &Path, keep_alias: bool) {
        self.0.live.retain(|(p, _)| p != temp);
        if !keep_alias {
            self.0.aliases.retain(|(p, _)| p != temp);
        }
    }

    /// Remove every registered path, newest first (files inside a temporary directory go
    /// before it, created parents after it).
    #[cfg(feature = "cli")]
    fn remove_all(&mut self) {
        for (path, kind) in self.0.live.drain(..).rev() {
            remove(&path, kind);
        }
    }
}

/// Remove `path` as its kind says; a path already gone is fine.
pub(crate) fn remove(path: &Path, kind: Kind) {
    let _ = match kind {
        Kind::File => std::fs::remove_file(path),
        Kind::Tree => std::fs::remove_dir_all(path),
        Kind::Created => std::fs::remove_dir(path),
    };
}

/// A registered temporary path: removed and unregistered when dropped, unless handed over
/// with [`Temp::rename_to`] or [`Temp::keep`].
pub(crate) struct Temp {
    path: PathBuf,
    kind: Kind,
}

impl Temp {
    /// Create a temporary with `make` and register it in one step (no interruption can fall
    /// between them); it stands for `user` in messages, if given.
    pub(crate) fn create(
        kind: Kind,
        user: Option<&Path>,
        make: impl FnOnce() -> std::io::Result<PathBuf>,
    ) -> std::io::Result<Temp> {
        let mut reg = lock();
        let path = make()?;
        reg.add(&path, kind, user);
        Ok(Temp { path, kind })
    }

    /// The temporary path.
    pub(crate) fn path(&self) -> &Path {
        &self.path
    }

    /// Move the temporary to `dest` (replacing a file there) and unregister it.
    pub(crate) fn rename_to(self, dest: &Path) -> std::io::Result<()> {
        let mut reg = lock();
        std::fs::rename(&self.path, dest)?;
        reg.forget(&self.path, false);
        std::mem::forget(self);
        Ok(())
    }

    /// Unregister the temporary and leave it on disk (it has become part of the output).
    pub(crate) fn keep(self) {
        lock().forget(&self.path, false);
        std::mem::forget(self);
    }
}

impl Drop for Temp {
    fn drop(&mut self) {
        let mut reg = lock();
        remove(&self.path, self.kind);
        reg.forget(&self.path, true);
    }
}

/// Install the handler of Ctrl-C and SIGTERM: remove every registered temporary, then exit
/// with [`crate::error::EXIT_INTERRUPTED`]. Call once, at the start of the program. Only with the
/// `cli` feature (the library alone installs no signal handler).
#[cfg(feature = "cli")]
pub fn install_interrupt_handler() -> Result<(), String> {
    ctrlc::set_handler(|| {
        // Keep the lock to the end: no new temporary can appear, and no commit is half done.
        let mut reg = lock();
        reg.remove_all();
        eprintln!("\ndetnoise: interrupted; temporary files removed");
        std::process::exit(crate::error::EXIT_INTERRUPTED);
    })
    .map_err(|e| format!("cannot install the Ctrl-C handler: {e}"))
}

/// Wait until an interruption being handled has exited the process (returns at once when
/// none is), so that a run stopped mid-way never reports success or a stray error instead.
pub fn settle() {
    drop(lock());
}

/// `e` with every registered temporary path replaced by the path it stands for.
pub fn hide_temporaries(e: Error) -> Error {
    let aliases = lock().0.aliases.clone();
    if aliases.is_empty() {
        return e;
    }
    let text = |s: String| {
        aliases.iter().rev().fold(s, |s, (tmp, user)| {
            s.replace(&*tmp.to_string_lossy(), &user.to_string_lossy())
        })
    };
    let path = |p: PathBuf| {
        aliases
            .iter()
            .rev()
            .fold(p, |p, (tmp, user)| match p.strip_prefix(tmp) {
                Ok(rest) if rest.as_os_str().is_empty() => user.clone(),
                Ok(rest) => user.join(rest),
                Err(_) => p,
            })
    };
    match e {
        Error::Usage { field, message } => Error::Usage {
            field,
            message: text(message),
        },
        Error::Input { path: p, message } => Error::Input {
            path: path(p),
            message: text(message),
        },
        Error::Io { path: p, source } => {
            let shown = source.to_string();
            let mapped = text(shown.clone());
            let source = if mapped == shown {
                source
            } else {
                std::io::Error::new(source.kind(), mapped)
            };
            Error::Io {
                path: path(p),
                source,
            }
        }
        Error::Numeric(m) => Error::Numeric(text(m)),
        Error::Interrupted => Error::Interrupted,
    }
}

/// An I/O error without the path text some libraries add (it may name a temporary): tempfile
/// words its errors `<os error> at path "<temporary>"`.
pub(crate) fn plain(e: std::io::Error) -> std::io::Error {
    if let Some(code) = e.raw_os_error() {
        return std::io::Error::from_raw_os_error(code);
    }
    let text = e.to_string();
    match text.find(" at path ") {
        Some(i) => std::io::Error::new(e.kind(), &text[..i]),
        None => std::io::Error::new(e.kind(), text),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn dropped_temporary_is_removed_and_messages_name_the_user_path() {
        let dir = tempfile::tempdir().unwrap();
        let user = dir.path().join("out");
        let t = Temp::create(Kind::Tree, Some(&user), || {
            let p = dir.path().join(".out.partial-x");
            std::fs::create_dir(&p)?;
            std::fs::write(p.join("a.csv"), b"1")?;
            Ok(p)
        })
        .unwrap();
        let inner = t.path().join("a.csv");
        let e = hide_temporaries(Error::io(&inner, std::io::Error::other("disk full")));
        assert_eq!(
            e.to_string(),
            format!("{}: disk full", user.join("a.csv").display())
        );
        let e = hide_temporaries(Error::Numeric(format!("cannot draw {}", inner.display())));
        assert!(!e.to_string().contains("partial"), "{e}");
        let tmp = t.path().to_path_buf();
        drop(t);
        assert!(!tmp.exists());
    }

    #[test]
    fn renamed_temporary_is_the_output() {
        let dir = tempfile::tempdir().unwrap();
        let dest = dir.path().join("r.csv");
        let t = Temp::create(Kind::File, Some(&dest), || {
            let p = dir.path().join(".r.csv.1.tmp");
            std::fs::write(&p, b"x")?;
            Ok(p)
        })
        .unwrap();
        t.rename_to(&dest).unwrap();
        assert_eq!(std::fs::read(&dest).unwrap(), b"x");
        assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 1);
    }
}
