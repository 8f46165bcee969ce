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
