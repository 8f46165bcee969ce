//! Output paths compared as the file system sees them, and the places detnoise never writes:
//! the current directory, the home directory, the root, and anything holding an input.

use crate::{Error, Result};
use std::path::{Component, Path, PathBuf};

/// `path` made absolute, with symbolic links, `.` and `..` resolved: its nearest existing
/// ancestor is canonicalised and the rest (which does not exist yet) appended lexically.
pub(crate) fn resolve(path: &Path) -> PathBuf {
    let abs = match std::env::current_dir() {
        Ok(cwd) if path.is_relative() => cwd.join(path),
        _ => path.to_path_buf(),
    };
    let mut tail = Vec::new();
    let mut base = abs.as_path();
    loop {
        if let Ok(c) = base.canonicalize() {
            return append_lexically(c, tail.iter().rev());
        }
        match (base.parent(), base.file_name()) {
            (Some(parent), Some(name)) => {
                tail.push(Component::Normal(name));
                base = parent;
            }
            // `..` or `.` at the end of a path that does not exist: keep it for the lexical pass.
            (Some(parent), None) => {
                tail.push(base.components().next_back().unwrap_or(Component::CurDir));
                base = parent;
            }
            _ => return append_lexically(PathBuf::from("/"), tail.iter().rev()),
        }
    }
}

fn append_lexically<'a>(
    mut base: PathBuf,
    tail: impl Iterator<Item = &'a Component<'a>>,
) -> PathBuf {
    for c in tail {
        match c {
            Component::ParentDir => {
                base.pop();
            }
            Component::Normal(n) => base.push(n),
            _ => {}
        }
    }
    base
}

/// A path whose first component is a literal `~`: the shell did not expand it.
/// `field` names the setting (a library field, or a flag given by command-line code).
pub(crate) fn refuse_unexpanded_tilde(path: &Path, field: &str) -> Result<()> {
    let first = path.components().next();
    if matches!(first, Some(Component::Normal(n)) if n == "~") {
        let shown = mention(field);
        return Err(Error::invalid(
            field,
            format!(
                "{}: `~` was not expanded by the shell (it is only at the start of a separate \
                 word, e.g. {shown} ~/results, not {shown}=~/results); give the full path",
                path.display()
            ),
        ));
    }
    Ok(())
}

/// A setting as a message mentions it: a library field in backticks (the command line shows
/// its flag instead), a flag as it is.
fn mention(field: &str) -> String {
    if field.starts_with('-') {
        field.to_string()
    } else {
        format!("`{field}`")
    }
}

/// Refuse, whatever `force` says, an output directory that is the current directory, the
/// home directory or the root, or that is or contains one of `inputs` (resolved).
pub(crate) fn refuse_protected_dir(
    out: &Path,
    resolved: &Path,
    field: &str,
    inputs: &[(PathBuf, PathBuf)],
) -> Result<()> {
    let refuse = |what: String| {
        Err(Error::invalid(
            field,
            format!(
                "{}: {what}; detnoise writes its results into a directory of their own: choose a \
                 new directory (e.g. {} {})",
                out.display(),
                mention(field),
                suggestion(resolved).display()
            ),
        ))
    };
    if resolved.parent().is_none() {
        return refuse("is the root directory".into());
    }
    if std::env::current_dir().is_ok_and(|cwd| resolve(&cwd) == resolved) {
        return refuse("is the current directory".into());
    }
    if std::env::var_os("HOME").is_some_and(|h| !h.is_empty() && resolve(Path::new(&h)) == resolved)
    {
        return refuse("is your home directory ($HOME)".into());
    }
    for (shown, input) in inputs {
        if input == resolved {
            return refuse(format!("is the input {}", shown.display()));
        }
        if input.starts_with(resolved) {
            return refuse(format!(
                "contains the input {} (writing there could replace it)",
                shown.display()
            ));
        }
    }
    Ok(())
}

/// Refuse an output file that is one of `inputs` (resolved), whatever `force` says.
pub(crate) fn refuse_input_file(
    out: &Path,
    resolved: &Path,
    field: &str,
    inputs: &[(PathBuf, PathBuf)],
) -> Result<()> {
    match inputs.iter().find(|(_, input)| input == resolved) {
        Some((shown, _)) => Err(Error::invalid(
            field,
            format!(
                "{} is the input {}: choose another name for the output",
                out.display(),
                shown.display()
            ),
        )),
        None => Ok(()),
    }
}

/// A name for a new results directory beside `resolved` (for messages).
fn suggestion(resolved: &Path) -> PathBuf {
    let name = resolved
        .file_name()
        .map(|n| format!("{}-detnoise", n.to_string_lossy()))
        .unwrap_or_else(|| "detnoise-results".into());
    match resolved.parent() {
        Some(p) if p.parent().is_some() => p.join(name),
        _ => PathBuf::from(name),
    }
}

/// Every input as (as given, resolved): existing files and directories, and the files a glob
/// pattern matches. Inputs that do not exist are left to the readers to report.
pub(crate) fn resolve_inputs(inputs: &[PathBuf]) -> Vec<(PathBuf, PathBuf)> {
    let mut out = Vec::new();
    for input in inputs {
        if std::fs::symlink_metadata(input).is_ok() {
            out.push((input.clone(), resolve(input)));
            continue;
        }
        let pattern = input.to_string_lossy();
        if !pattern.contains(['*', '?', '[']) {
            continue;
        }
        if let Ok(paths) = glob::glob(&pattern) {
            out.extend(paths.flatten().map(|p| (p.clone(), resolve(&p))));
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn resolve_follows_links_and_dots_in_paths_that_do_not_exist_yet() {
        let dir = tempfile::tempdir().unwrap();
        let real = dir.path().canonicalize().unwrap();
        std::fs::create_dir(real.join("a")).unwrap();
        std::os::unix::fs::symlink(real.join("a"), real.join("link")).unwrap();
        assert_eq!(resolve(&real.join("link/new/x")), real.join("a/new/x"));
        assert_eq!(resolve(&real.join("a/./new/../y")), real.join("a/y"));
        assert_eq!(resolve(&real.join("a/..")), real);
        assert_eq!(resolve(Path::new("/")), PathBuf::from("/"));
    }

    #[test]
    fn an_output_holding_an_input_is_refused() {
        let dir = tempfile::tempdir().unwrap();
        let real = dir.path().canonicalize().unwrap();
        std::fs::create_dir(real.join("data")).unwrap();
        std::fs::write(real.join("data/d.fits"), b"").unwrap();
        let inputs = resolve_inputs(&[real.join("data/*.fits")]);
        assert_eq!(inputs.len(), 1);
        let e = refuse_protected_dir(&real, &real, "out", &inputs).unwrap_err();
        assert!(e.to_string().contains("contains the input"), "{e}");
        assert!(refuse_protected_dir(&real.join("o"), &real.join("o"), "out", &inputs).is_ok());
        let e = refuse_protected_dir(Path::new("/"), Path::new("/"), "out", &[]).unwrap_err();
        assert!(e.to_string().contains("root"), "{e}");
        let e = refuse_unexpanded_tilde(Path::new("~/x"), "out").unwrap_err();
        assert!(
            e.to_string()
                .contains("e.g. `out` ~/results, not `out`=~/results"),
            "{e}"
        );
        let e = refuse_unexpanded_tilde(Path::new("~/x"), "--out").unwrap_err();
        assert!(
            e.to_string()
                .contains("e.g. --out ~/results, not --out=~/results"),
            "{e}"
        );
        assert!(refuse_unexpanded_tilde(Path::new("a/~"), "out").is_ok());
    }
}
