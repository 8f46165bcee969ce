//! Single output files (`simulate --out r.csv --plot r.png`, `synth --out stack.fits`):
//! checked before any work, written atomically, never replacing an input, and replacing an
//! existing file only with `force`.

use super::paths::{refuse_input_file, refuse_unexpanded_tilde, resolve, resolve_inputs};
use super::temps::{self, plain, Kind, Temp};
use crate::{Error, Result};
use std::path::{Path, PathBuf};

/// One output file named by a setting.
#[derive(Debug, Clone, Copy)]
pub struct FileOut<'a> {
    /// The path as given.
    pub path: &'a Path,
    /// The setting that names it, in messages: a library field (`plot`), which the command
    /// line shows as its flag.
    pub option: &'a str,
    /// Extensions it may have (lower case, without the dot); empty: any.
    pub exts: &'a [&'a str],
    /// What is written there, for messages, e.g. `a chart (PNG or SVG)`.
    pub what: &'a str,
}

/// Check an output file before any work: the extension fits what is written, it is not an
/// input or a directory, it exists only with `force`, and its directory is writable.
pub fn check_file(f: &FileOut, force: bool, inputs: &[PathBuf]) -> Result<()> {
    check_resolved(f, force, &resolve_inputs(inputs)).map(drop)
}

/// [`check_file`] with resolved inputs; returns the resolved path.
fn check_resolved(f: &FileOut, force: bool, inputs: &[(PathBuf, PathBuf)]) -> Result<PathBuf> {
    let usage = |what: String| Error::invalid(f.option, format!("{}: {what}", f.path.display()));
    refuse_unexpanded_tilde(f.path, f.option)?;
    let ext = f
        .path
        .extension()
        .map(|e| e.to_string_lossy().to_ascii_lowercase());
    if !f.exts.is_empty() && !ext.as_ref().is_some_and(|e| f.exts.contains(&e.as_str())) {
        let names: Vec<String> = f.exts.iter().map(|e| format!(".{e}")).collect();
        return Err(usage(format!(
            "{} is written here: the name must end in {}",
            f.what,
            names.join(" or ")
        )));
    }
    let resolved = resolve(f.path);
    refuse_input_file(f.path, &resolved, f.option, inputs)?;
    if let Ok(meta) = std::fs::symlink_metadata(&resolved) {
        if meta.is_dir() {
            return Err(usage("is a directory: give a file name".into()));
        }
        if !meta.is_file() {
            return Err(usage(
                "exists and is not a regular file: choose another name".into(),
            ));
        }
        if !force {
            return Err(usage(
                "exists: add `force` to replace it, or choose another name".into(),
            ));
        }
    }
    let parent = resolved.parent().unwrap_or(Path::new("/"));
    if !parent.is_dir() {
        return Err(usage(format!(
            "the directory {} does not exist",
            parent.display()
        )));
    }
    // Proves the directory writable: the real file is written beside it the same way.
    Temp::create(Kind::File, None, || {
        tempfile::Builder::new()
            .prefix(".detnoise-probe-")
            .tempfile_in(parent)?
            .into_temp_path()
            .keep()
            .map_err(|e| e.error)
    })
    .map_err(|e| {
        usage(format!(
            "cannot write in {}: {}",
            parent.display(),
            plain(e)
        ))
    })?;
    Ok(resolved)
}

/// Output files of one directory written into a temporary directory beside them and moved
/// into place together at the end: a failed or interrupted run leaves none of them.
pub struct StagedFiles {
    /// (as given, resolved) of each file.
    files: Vec<(PathBuf, PathBuf)>,
    option: String,
    force: bool,
    tmp: Temp,
}

impl StagedFiles {
    /// Check every file (all in one directory) and create the staging directory.
    pub fn prepare(files: &[FileOut], force: bool, inputs: &[PathBuf]) -> Result<Self> {
        let inputs = resolve_inputs(inputs);
        let checked = files
            .iter()
            .map(|f| Ok((f.path.to_path_buf(), check_resolved(f, force, &inputs)?)))
            .collect::<Result<Vec<_>>>()?;
        let first = files.first().expect("at least one output file");
        let parent = checked[0]
            .1
            .parent()
            .unwrap_or(Path::new("/"))
            .to_path_buf();
        if checked
            .iter()
            .any(|(_, r)| r.parent() != Some(parent.as_path()))
        {
            return Err(Error::invalid(
                first.option,
                "the output files must share one directory",
            ));
        }
        let user_dir = first.path.parent().unwrap_or(Path::new(""));
        let tmp = Temp::create(Kind::Tree, Some(user_dir), || {
            Ok(tempfile::Builder::new()
                .prefix(".detnoise-partial-")
                .tempdir_in(&parent)?
                .keep())
        })
        .map_err(|e| {
            Error::invalid(
                first.option,
                format!(
                    "{}: cannot write in {}: {}",
                    first.path.display(),
                    parent.display(),
                    plain(e)
                ),
            )
        })?;
        Ok(StagedFiles {
            files: checked,
            option: first.option.into(),
            force,
            tmp,
        })
    }

    /// The staging directory: write each file there under its final file name.
    pub fn dir(&self) -> &Path {
        self.tmp.path()
    }

    /// Move every file into place (an interruption waits until all are there).
    pub fn commit(self) -> Result<()> {
        let _guard = temps::lock();
        if !self.force {
            if let Some((shown, _)) = self.files.iter().find(|(_, r)| r.exists()) {
                return Err(Error::invalid(
                    &self.option,
                    format!(
                        "{} appeared during the run: add `force` to replace it",
                        shown.display()
                    ),
                ));
            }
        }
        for (shown, resolved) in &self.files {
            let name = resolved.file_name().expect("a file name");
            std::fs::rename(self.tmp.path().join(name), resolved)
                .map_err(|e| Error::io(shown, e))?;
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn plot(path: &Path) -> FileOut<'_> {
        FileOut {
            path,
            option: "plot",
            exts: &["png", "svg"],
            what: "a chart (PNG or SVG)",
        }
    }

    #[test]
    fn file_checks_extension_existence_inputs_and_directory() {
        let dir = tempfile::tempdir().unwrap();
        let d = dir.path();
        let e = check_file(&plot(&d.join("r.jpg")), false, &[]).unwrap_err();
        assert!(e.to_string().contains(".png or .svg"), "{e}");
        assert!(check_file(&plot(&d.join("R.PNG")), false, &[]).is_ok());
        std::fs::write(d.join("r.png"), b"old").unwrap();
        let e = check_file(&plot(&d.join("r.png")), false, &[]).unwrap_err();
        assert!(e.to_string().contains("`force`"), "{e}");
        assert!(check_file(&plot(&d.join("r.png")), true, &[]).is_ok());
        let e = check_file(&plot(&d.join("r.png")), true, &[d.join("r.png")]).unwrap_err();
        assert!(e.to_string().contains("is the input"), "{e}");
        std::fs::create_dir(d.join("x.svg")).unwrap();
        assert!(check_file(&plot(&d.join("x.svg")), true, &[]).is_err());
        assert!(check_file(&plot(&d.join("no/r.png")), false, &[]).is_err());
        // The probe leaves nothing behind.
        assert_eq!(std::fs::read_dir(d).unwrap().count(), 2);
    }

    #[test]
    fn staged_files_arrive_together_and_vanish_on_failure() {
        let dir = tempfile::tempdir().unwrap();
        let (a, b) = (dir.path().join("s.fits"), dir.path().join("s.json"));
        let outs = [
            FileOut {
                path: &a,
                option: "out",
                exts: &["fits"],
                what: "a FITS stack",
            },
            FileOut {
                path: &b,
                option: "out",
                exts: &[],
                what: "",
            },
        ];
        let staged = StagedFiles::prepare(&outs, false, &[]).unwrap();
        std::fs::write(staged.dir().join("s.fits"), b"1").unwrap();
        std::fs::write(staged.dir().join("s.json"), b"2").unwrap();
        staged.commit().unwrap();
        assert_eq!(std::fs::read(&b).unwrap(), b"2");
        assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 2);
        assert!(StagedFiles::prepare(&outs, false, &[]).is_err());
        let staged = StagedFiles::prepare(&outs, true, &[]).unwrap();
        std::fs::write(staged.dir().join("s.fits"), b"3").unwrap();
        drop(staged);
        assert_eq!(std::fs::read(&a).unwrap(), b"1");
        assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 2);
    }
}
