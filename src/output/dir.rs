//! Output directories: checked before any work, built in a temporary sibling, and moved into
//! place at the end without ever touching a file detnoise did not write.

use super::atomic::{set_mode, write_json};
use super::manifest::{files_under, survey, Manifest, Survey, MANIFEST_NAME};
use super::paths::{refuse_protected_dir, refuse_unexpanded_tilde, resolve, resolve_inputs};
use super::temps::{self, plain, Kind, Temp};
use crate::{Error, Result};
use std::path::{Path, PathBuf};

/// What a command writes into its `out` directory and what it reads, for the checks done
/// before any work.
#[derive(Debug, Clone, Copy)]
pub struct DirPlan<'a> {
    /// The subcommand, recorded in the manifest.
    pub command: &'a str,
    /// `force`: write into a directory that holds other files (never replacing them).
    pub force: bool,
    /// Every input file, directory or glob pattern of the run.
    pub inputs: &'a [PathBuf],
    /// Names (glob patterns) of the files the command may write.
    pub names: &'a [&'a str],
}

/// An output directory built in a temporary sibling and moved into place only on success,
/// so a failed or interrupted run leaves neither a half-written directory nor a damaged
/// earlier one. It replaces only a directory that detnoise wrote (it carries a manifest and
/// nothing else); with `force` it writes beside foreign files without touching them.
pub struct OutputDir {
    /// The path as the user gave it (for messages).
    shown: PathBuf,
    /// The path resolved (symbolic links followed) where the output goes.
    target: PathBuf,
    command: String,
    force: bool,
    tmp: Temp,
    /// Parent directories created for the output, innermost first (the order they are removed
    /// in when the run fails; the temporary directory goes before them).
    created: Vec<Temp>,
}

/// Field of output directories in messages.
const FIELD: &str = "out";

impl OutputDir {
    /// Check `out` against the rule and create the temporary sibling, before any work: a
    /// refused or unwritable `out` is a usage error naming it.
    pub fn prepare(out: &Path, plan: DirPlan) -> Result<Self> {
        refuse_unexpanded_tilde(out, FIELD)?;
        let target = resolve(out);
        let inputs = resolve_inputs(plan.inputs);
        refuse_protected_dir(out, &target, FIELD, &inputs)?;
        if let Ok(meta) = std::fs::symlink_metadata(&target) {
            if !meta.is_dir() {
                return Err(usage(
                    out,
                    "is an existing file, not a directory: choose another `out` for the results",
                ));
            }
            check_existing(out, &target, plan)?;
        }
        let parent = target.parent().expect("the root is refused").to_path_buf();
        let created = create_parents(out, &parent)?;
        let name = target
            .file_name()
            .map_or_else(|| "out".into(), |n| n.to_string_lossy().into_owned());
        let tmp = Temp::create(Kind::Tree, Some(out), || {
            Ok(tempfile::Builder::new()
                .prefix(&format!(".{name}.partial-"))
                .tempdir_in(&parent)?
                .keep())
        })
        .map_err(|e| {
            usage(
                out,
                format!(
                    "cannot create the output directory in {}: {}",
                    parent.display(),
                    plain(e)
                ),
            )
        })?;
        Ok(OutputDir {
            shown: out.to_path_buf(),
            target,
            command: plan.command.into(),
            force: plan.force,
            tmp,
            created,
        })
    }

    /// Path of `file` inside the directory being built.
    pub fn path(&self, file: &str) -> PathBuf {
        self.tmp.path().join(file)
    }

    /// Write the manifest and move the finished directory into place: a new directory, an
    /// earlier detnoise directory replaced whole, or (`force`) the new files placed beside
    /// foreign ones. Returns the path as the user gave it.
    pub fn commit(self) -> Result<PathBuf> {
        let tmp = self.tmp.path().to_path_buf();
        let files = files_under(&tmp).map_err(|e| Error::io(&tmp, e))?;
        let files: Vec<PathBuf> = files
            .into_iter()
            .filter(|f| f != Path::new(MANIFEST_NAME))
            .collect();
        write_json(
            &tmp.join(MANIFEST_NAME),
            &Manifest::new(&self.command, &files),
        )?;
        set_mode(&tmp, 0o755)?;
        // Under the lock, an interruption waits until the directory is complete in place.
        let guard = temps::lock();
        let existing = match std::fs::symlink_metadata(&self.target) {
            Ok(_) => Some(survey(&self.target).map_err(|e| Error::io(&self.shown, e))?),
            Err(_) => None,
        };
        match existing {
            None => std::fs::rename(&tmp, &self.target).map_err(|e| Error::io(&self.shown, e))?,
            Some(s) if s.foreign.is_empty() => {
                if !self.replace_whole()? {
                    self.merge(&s, &files)?;
                }
            }
            Some(s) if self.force => self.merge(&s, &files)?,
            Some(s) => return Err(foreign_error(&self.shown, &s)),
        }
        drop(guard);
        let OutputDir {
            shown,
            tmp,
            created,
            ..
        } = self;
        // Placed (or emptied by the merge, whose leftovers it removes): no longer a temporary.
        if tmp.path().exists() {
            drop(tmp);
        } else {
            tmp.keep();
        }
        created.into_iter().for_each(Temp::keep);
        Ok(shown)
    }

    /// Swap an earlier detnoise directory (nothing foreign in it) for the new one; if the
    /// swap fails the earlier one is put back. False when the earlier one cannot be moved
    /// (e.g. a mount point): nothing has changed then.
    fn replace_whole(&self) -> Result<bool> {
        let parent = self.target.parent().expect("the root is refused");
        let io = |e| Error::io(&self.shown, e);
        // An empty placeholder the old directory is renamed over (rename replaces an empty dir).
        let old = tempfile::Builder::new()
            .prefix(".detnoise-replaced-")
            .tempdir_in(parent)
            .map_err(|e| io(plain(e)))?
            .keep();
        if std::fs::rename(&self.target, &old).is_err() {
            let _ = std::fs::remove_dir(&old);
            return Ok(false);
        }
        if let Err(e) = std::fs::rename(self.tmp.path(), &self.target) {
            let _ = std::fs::rename(&old, &self.target);
            let _ = std::fs::remove_dir(&old);
            return Err(io(e));
        }
        // Only detnoise's files are in it (the survey found nothing else).
        if let Err(e) = std::fs::remove_dir_all(&old) {
            eprintln!(
                "warning: cannot remove the replaced output {}: {e}",
                old.display()
            );
        }
        Ok(true)
    }

    /// `force` into a directory with foreign entries: move each new file in (replacing only
    /// files the old manifest lists), remove the old run's files this run did not write again.
    fn merge(&self, s: &Survey, files: &[PathBuf]) -> Result<()> {
        if let Some(p) = files.iter().find(|p| collides(&self.target, s, p)) {
            return Err(collision_error(&self.shown, p));
        }
        let io = |p: &Path, e| Error::io(self.shown.join(p), e);
        // The manifest goes last: until then the old one still describes the directory.
        let manifest = PathBuf::from(MANIFEST_NAME);
        for p in files.iter().chain([&manifest]) {
            let dest = self.target.join(p);
            if let Some(d) = dest.parent() {
                std::fs::create_dir_all(d).map_err(|e| io(p, e))?;
            }
            std::fs::rename(self.tmp.path().join(p), &dest).map_err(|e| io(p, e))?;
        }
        for stale in s.ours.iter().filter(|p| !files.contains(p)) {
            std::fs::remove_file(self.target.join(stale)).map_err(|e| io(stale, e))?;
        }
        let _ = std::fs::remove_dir_all(self.tmp.path());
        Ok(())
    }
}

/// A new file `p` would replace or sit under an entry detnoise did not write.
fn collides(target: &Path, s: &Survey, p: &Path) -> bool {
    if s.ours.contains(p) {
        return false;
    }
    let mut cur = PathBuf::new();
    for c in p.components() {
        cur.push(c);
        let exists = std::fs::symlink_metadata(target.join(&cur));
        let is_last = cur.as_path() == p;
        match exists {
            Ok(m) if is_last || !m.is_dir() => return true,
            Ok(_) => {}
            Err(_) => return false,
        }
    }
    false
}

/// Refuse an existing directory that holds files detnoise did not write (unless `force`,
/// and then only if none of them has the name of an output).
fn check_existing(out: &Path, target: &Path, plan: DirPlan) -> Result<()> {
    let s = survey(target).map_err(|e| usage(out, format!("cannot list it: {}", plain(e))))?;
    if s.foreign.is_empty() {
        return Ok(());
    }
    if !plan.force {
        return Err(foreign_error(out, &s));
    }
    let patterns: Vec<glob::Pattern> = plan
        .names
        .iter()
        .filter_map(|n| glob::Pattern::new(n).ok())
        .collect();
    if let Some(p) = s.foreign.iter().find(|p| {
        let name = p.to_string_lossy();
        patterns.iter().any(|pat| pat.matches(&name))
    }) {
        return Err(collision_error(out, p));
    }
    // Writability of the directory itself: the new files are moved into it.
    tempfile::tempfile_in(target)
        .map(drop)
        .map_err(|e| usage(out, format!("cannot write in it: {}", plain(e))))
}

/// Create the missing directories up to `parent`, each registered so that a failed or
/// interrupted run removes them again (while empty).
fn create_parents(out: &Path, parent: &Path) -> Result<Vec<Temp>> {
    let missing: Vec<&Path> = parent
        .ancestors()
        .take_while(|a| std::fs::symlink_metadata(a).is_err())
        .collect();
    let mut created = Vec::new();
    for dir in missing.into_iter().rev() {
        let t = Temp::create(Kind::Created, None, || {
            std::fs::create_dir(dir)?;
            Ok(dir.to_path_buf())
        })
        .map_err(|e| {
            usage(
                out,
                format!(
                    "cannot create the directory {}: {}",
                    dir.display(),
                    plain(e)
                ),
            )
        })?;
        created.push(t);
    }
    created.reverse();
    Ok(created)
}

fn usage(out: &Path, what: impl std::fmt::Display) -> Error {
    Error::invalid(FIELD, format!("{}: {what}", out.display()))
}

fn foreign_error(out: &Path, s: &Survey) -> Error {
    const SHOWN: usize = 5;
    let mut list: Vec<String> = s
        .foreign
        .iter()
        .take(SHOWN)
        .map(|p| p.display().to_string())
        .collect();
    if s.foreign.len() > SHOWN {
        list.push(format!("and {} more", s.foreign.len() - SHOWN));
    }
    usage(
        out,
        format!(
            "exists and holds files detnoise did not write ({}): choose another `out` (a new or \
             empty directory, or one detnoise wrote), or add `force` to write beside them \
             (detnoise never replaces or deletes files it did not write)",
            list.join(", ")
        ),
    )
}

fn collision_error(out: &Path, p: &Path) -> Error {
    usage(
        out,
        format!(
            "holds {} which detnoise did not write and this run would write: move it away or \
             choose another `out` (`force` never replaces files detnoise did not write)",
            p.display()
        ),
    )
}
