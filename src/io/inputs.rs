//! Stack arguments expanded to files: plain files, directories (their FITS/TIFF/EXR files)
//! and glob patterns, in order.

use std::path::{Path, PathBuf};

use crate::error::{Error, Result};

const KNOWN_EXTENSIONS: [&str; 8] = ["fits", "fit", "fts", "fz", "gz", "tif", "tiff", "exr"];

fn has_known_extension(p: &Path) -> bool {
    p.extension()
        .and_then(|e| e.to_str())
        .map(|e| KNOWN_EXTENSIONS.contains(&e.to_ascii_lowercase().as_str()))
        .unwrap_or(false)
}

/// Expand stack arguments (files, directories, glob patterns) to a list of files, in order.
///
/// A directory contributes its files with a FITS/TIFF/EXR extension, sorted by name;
/// a glob contributes its matches sorted by name; a plain path must exist.
pub fn expand_inputs(inputs: &[PathBuf]) -> Result<Vec<PathBuf>> {
    let mut out = Vec::new();
    for input in inputs {
        let s = input.to_string_lossy();
        if input.is_dir() {
            let mut files: Vec<PathBuf> = std::fs::read_dir(input)
                .map_err(|e| Error::io(input, e))?
                .filter_map(|e| e.ok().map(|e| e.path()))
                .filter(|p| p.is_file() && has_known_extension(p))
                .collect();
            files.sort();
            if files.is_empty() {
                return Err(Error::input(
                    input,
                    "directory holds no FITS, TIFF or EXR file",
                ));
            }
            out.extend(files);
        } else if input.exists() {
            out.push(input.clone());
        } else if s.contains(['*', '?', '[']) {
            let paths = glob::glob(&s)
                .map_err(|e| Error::invalid("stacks", format!("bad glob pattern {s}: {e}")))?;
            let mut files: Vec<PathBuf> = paths
                .filter_map(|p| p.ok())
                .filter(|p| p.is_file())
                .collect();
            files.sort();
            if files.is_empty() {
                return Err(Error::input(input, "glob pattern matches no file"));
            }
            out.extend(files);
        } else {
            return Err(Error::io(
                input,
                std::io::Error::new(std::io::ErrorKind::NotFound, "no such file or directory"),
            ));
        }
    }
    if out.is_empty() {
        return Err(Error::invalid("stacks", "no input given"));
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn directories_and_globs_expand_in_name_order() {
        let d = tempfile::tempdir().unwrap();
        for n in ["b.fits", "a.FITS", "c.txt", "d.tif"] {
            std::fs::write(d.path().join(n), b"x").unwrap();
        }
        let names = |v: Vec<PathBuf>| -> Vec<String> {
            v.iter()
                .map(|p| p.file_name().unwrap().to_string_lossy().into_owned())
                .collect()
        };
        // A directory: its stack files (any case of the extension), sorted by name.
        let got = expand_inputs(&[d.path().to_path_buf()]).unwrap();
        assert_eq!(names(got), ["a.FITS", "b.fits", "d.tif"]);
        // A glob: its matches (case-sensitive), sorted; files keep the order given.
        let glob = d.path().join("*.fits");
        assert_eq!(names(expand_inputs(&[glob]).unwrap()), ["b.fits"]);
        let files = [d.path().join("d.tif"), d.path().join("b.fits")];
        assert_eq!(names(expand_inputs(&files).unwrap()), ["d.tif", "b.fits"]);
        assert!(matches!(expand_inputs(&[]), Err(Error::Usage { .. })));
        let none = d.path().join("none*.fits");
        assert!(matches!(expand_inputs(&[none]), Err(Error::Input { .. })));
        let missing = d.path().join("missing.fits");
        assert!(matches!(expand_inputs(&[missing]), Err(Error::Io { .. })));
    }
}
