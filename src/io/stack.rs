//! A stack of frames of one shape spread over one or more files of one format and sample
//! type: opened from files, directories or glob patterns, headers only.

use std::path::{Path, PathBuf};

use serde::Serialize;

use super::file::{scan_file, SourceFile};
use super::format::SampleType;
use super::inputs::expand_inputs;
use crate::error::{Error, Result};

/// A stack of frames of one shape spread over one or more files; frames are read on demand.
#[derive(Clone, Debug, Serialize)]
pub struct FrameStack {
    /// The files, in stack order.
    pub sources: Vec<SourceFile>,
    /// Frame shape (rows, cols).
    pub shape: (usize, usize),
    /// Total number of frames.
    pub frames: usize,
    /// Sample type (one per stack).
    pub sample_type: SampleType,
}

impl FrameStack {
    /// Open a stack from files, directories or glob patterns, reading headers only.
    /// Fails (naming file and frame) when a file is unreadable, and (listing what was
    /// found) when the files mix formats, frame shapes or sample types: the same frames
    /// saved as .fits, .tif and .exr in one directory are not a stack three times as long.
    pub fn open(inputs: &[PathBuf]) -> Result<FrameStack> {
        let files = expand_inputs(inputs)?;
        check_distinct(&files, "the stack's files")?;
        let sources = files
            .iter()
            .map(|p| scan_file(p))
            .collect::<Result<Vec<SourceFile>>>()?;
        check_uniform(inputs, &sources)?;
        let shape = sources[0].shape;
        let sample_type = sources[0].sample_type;
        Ok(FrameStack {
            frames: sources.iter().map(|s| s.frames).sum(),
            sources,
            shape,
            sample_type,
        })
    }

    /// Pixels per frame.
    pub fn pixels(&self) -> usize {
        self.shape.0 * self.shape.1
    }

    /// The file holding stack frame `k` (the last file if `k` is past the end).
    pub fn source_of(&self, k: usize) -> &Path {
        let mut start = 0;
        for s in &self.sources {
            if k < start + s.frames {
                return &s.path;
            }
            start += s.frames;
        }
        &self.sources[self.sources.len() - 1].path
    }

    /// Source file paths, in order.
    pub fn paths(&self) -> Vec<PathBuf> {
        self.sources.iter().map(|s| s.path.clone()).collect()
    }

    /// Total bytes of sample data as stored (used for throughput figures).
    pub fn stored_bytes(&self) -> u64 {
        self.sources
            .iter()
            .map(|s| {
                let b = match s.sample_type {
                    SampleType::U8 | SampleType::I8 => 1,
                    SampleType::U16 | SampleType::I16 | SampleType::F16 => 2,
                    SampleType::U32 | SampleType::I32 | SampleType::F32 | SampleType::Scaled => 4,
                    SampleType::I64 | SampleType::F64 => 8,
                };
                (b * s.frames * s.shape.0 * s.shape.1) as u64
            })
            .sum()
    }

    /// Largest integer sample value of the stored type (None for floats), for saturation checks.
    pub fn saturation_value(&self) -> Option<f64> {
        self.sources
            .iter()
            .map(|s| s.sample_type.max_value())
            .try_fold(f64::INFINITY, |m, v| v.map(|v| m.min(v)))
    }

    /// An error naming the first file unless `read` frames, all of the stack's, were read (a
    /// file that shrank or changed while it was read).
    pub fn require_all_read(&self, read: usize) -> Result<()> {
        if read == self.frames {
            return Ok(());
        }
        Err(Error::input(
            &self.sources[0].path,
            format!(
                "frame {read}: stack ended after {read} of {} frames",
                self.frames
            ),
        ))
    }

    /// Fail unless the stack has at least `n` frames (variances need 2).
    pub fn require_frames(&self, n: usize, what: &str) -> Result<()> {
        if self.frames < n {
            let message = format!(
                "frame {}: stack has {} frame(s), {what} needs at least {n}",
                self.frames, self.frames
            );
            return Err(match truth_map(&self.sources) {
                Some(map) => Error::input(map, format!("{message}; {}", truth_map_note(map))),
                None => Error::input(&self.sources[0].path, message),
            });
        }
        Ok(())
    }
}

/// An error naming the first file that `files` (described as `among`, e.g. "the stack's
/// files") give twice (the same file by another name, a link, or inside a directory also
/// given): its frames would be read twice, which doubles their weight and makes a noise stack
/// look non-Gaussian. Files are compared by device and inode, which sees through every
/// spelling of a path (a copy is another file).
pub fn check_distinct(files: &[PathBuf], among: &str) -> Result<()> {
    use std::collections::HashMap;
    use std::os::unix::fs::MetadataExt;
    let mut seen: HashMap<(u64, u64), &Path> = HashMap::new();
    for f in files {
        let m = std::fs::metadata(f).map_err(|e| Error::io(f, e))?;
        if let Some(first) = seen.insert((m.dev(), m.ino()), f) {
            let same = if first.as_os_str() == f.as_os_str() {
                String::new()
            } else {
                format!(" (also as {})", first.display())
            };
            return Err(Error::input(
                f,
                format!(
                    "given twice among {among}{same}: its frames would be read twice; give \
                     each file once"
                ),
            ));
        }
    }
    Ok(())
}

/// True when `path` is named as `synth` names the truth maps it writes beside a stack
/// (`<stem>.truth-<quantity>.fits`).
pub(crate) fn named_as_truth_map(path: &Path) -> bool {
    let name = path
        .file_name()
        .map(|n| n.to_string_lossy())
        .unwrap_or_default();
    name.ends_with(".fits") && name.contains(".truth-")
}

/// The first of `sources` that is one of `synth`'s truth maps (named as they are, one frame):
/// a glob such as `*e.fits` picks up `x.truth-rms_e.fits` beside the stack `x.fits`.
fn truth_map(sources: &[SourceFile]) -> Option<&Path> {
    sources
        .iter()
        .find(|s| s.frames == 1 && named_as_truth_map(&s.path))
        .map(|s| s.path.as_path())
}

/// What an error says about the truth map `path` found among a stack's files.
fn truth_map_note(path: &Path) -> String {
    format!(
        "{} is a truth map written by `detnoise synth` beside its stack, not a frame stack: leave it out of the inputs (a pattern such as *e.fits also matches the truth maps)",
        path.display()
    )
}

/// The stack arguments for a message: the first three, then how many more.
fn shown(inputs: &[PathBuf]) -> String {
    let mut s: Vec<String> = inputs
        .iter()
        .take(3)
        .map(|p| p.display().to_string())
        .collect();
    if inputs.len() > 3 {
        s.push(format!("and {} more", inputs.len() - 3));
    }
    s.join(" ")
}

/// Files of one kind (format, shape or sample type) in a stack: how many, and the first.
fn groups<K: PartialEq + std::fmt::Debug>(
    sources: &[SourceFile],
    key: impl Fn(&SourceFile) -> K,
) -> Vec<(K, usize, &Path)> {
    let mut out: Vec<(K, usize, &Path)> = Vec::new();
    for s in sources {
        let k = key(s);
        match out.iter_mut().find(|g| g.0 == k) {
            Some(g) => g.1 += 1,
            None => out.push((k, 1, &s.path)),
        }
    }
    out
}

/// One format, one frame shape and one sample type per stack, or an error listing each
/// kind found with its file count and first file.
fn check_uniform(inputs: &[PathBuf], sources: &[SourceFile]) -> Result<()> {
    fn list<K>(g: &[(K, usize, &Path)], name: impl Fn(&K) -> String) -> String {
        g.iter()
            .map(|(k, n, p)| {
                let files = if *n == 1 { "file" } else { "files" };
                format!("{} ({n} {files}, first {})", name(k), p.display())
            })
            .collect::<Vec<_>>()
            .join(", ")
    }
    let formats = groups(sources, |s| s.format);
    let shapes = groups(sources, |s| s.shape);
    let types = groups(sources, |s| s.sample_type);
    let mut found = Vec::new();
    if formats.len() > 1 {
        found.push(format!(
            "formats {}",
            list(&formats, |f| format!("{f:?}").to_uppercase())
        ));
    }
    if shapes.len() > 1 {
        found.push(format!(
            "frame shapes {}",
            list(&shapes, |s| format!("{}x{}", s.0, s.1))
        ));
    }
    if types.len() > 1 {
        found.push(format!(
            "sample types {}",
            list(&types, |t| format!("{t:?}").to_lowercase())
        ));
    }
    if found.is_empty() {
        return Ok(());
    }
    // Name the first file that differs from the first one, with its stack frame.
    let first = &sources[0];
    let odd = sources
        .iter()
        .position(|s| {
            (s.format, s.shape, s.sample_type) != (first.format, first.shape, first.sample_type)
        })
        .expect("some file differs");
    let start: usize = sources[..odd].iter().map(|s| s.frames).sum();
    let truth = truth_map(sources)
        .map(|map| format!(". {}", truth_map_note(map)))
        .unwrap_or_default();
    Err(Error::input(
        &sources[odd].path,
        format!(
            "frame 0 (stack frame {start}): differs from {}; the {} files of {} are not one stack: {}. A stack is frames of one camera in one format, shape and sample type (the same frames saved as .fits, .tif and .exr would be read three times): give one kind, e.g. DIR/*.fits{truth}",
            first.path.display(),
            sources.len(),
            shown(inputs),
            found.join("; ")
        ),
    ))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::io::fits::{write_cube, write_image, ImageData};

    /// A stack `x.fits` of 3 frames, its truth map `x.truth-rms_e.fits` and a one-frame
    /// `y.fits`, all 4x4, in `dir`.
    fn files(dir: &Path) -> [PathBuf; 3] {
        let [stack, truth, single] =
            ["x.fits", "x.truth-rms_e.fits", "y.fits"].map(|n| dir.join(n));
        let mut next = || vec![100.0; 16];
        write_cube(&stack, (4, 4), 3, true, &mut next, &[]).unwrap();
        for p in [&truth, &single] {
            write_image(p, (4, 4), ImageData::F64(&[1.5; 16]), "electron", &[]).unwrap();
        }
        [stack, truth, single]
    }

    fn message(e: Error) -> (PathBuf, String) {
        match e {
            Error::Input { path, message } => (path, message),
            other => panic!("not an input error: {other}"),
        }
    }

    #[test]
    fn a_file_given_twice_is_refused_naming_it() {
        let d = tempfile::tempdir().unwrap();
        let [stack, _, single] = files(d.path());
        let elsewhere = tempfile::tempdir().unwrap();
        let link = elsewhere.path().join("link.fits");
        std::os::unix::fs::symlink(&stack, &link).unwrap();
        let dotted = d.path().join(".").join("x.fits");
        let cases: [(Vec<PathBuf>, &Path, &str); 4] = [
            (vec![stack.clone(), stack.clone()], &stack, "given twice"),
            (
                vec![stack.clone(), single.clone(), dotted.clone()],
                &dotted,
                "also as",
            ),
            (vec![link.clone(), stack.clone()], &stack, "link.fits"),
            // A directory holds the file given beside it.
            (
                vec![d.path().to_path_buf(), single.clone()],
                &single,
                "given twice",
            ),
        ];
        for (inputs, named, says) in cases {
            let (path, m) = message(FrameStack::open(&inputs).unwrap_err());
            assert_eq!(path, named, "{inputs:?}");
            assert!(m.contains(says) && m.contains("read twice"), "{m}");
        }
        // The same frames in another file (a copy) are another file.
        let copy = d.path().join("copy.fits");
        std::fs::copy(&stack, &copy).unwrap();
        assert_eq!(FrameStack::open(&[stack, copy]).unwrap().frames, 6);
    }

    #[test]
    fn a_truth_map_among_the_inputs_is_named_as_one() {
        let d = tempfile::tempdir().unwrap();
        let [stack, truth, single] = files(d.path());
        let note = "is a truth map written by `detnoise synth`";
        // Alone (one --flats per file): too few frames, and why.
        let alone = FrameStack::open(std::slice::from_ref(&truth)).unwrap();
        let (path, m) = message(alone.require_frames(2, "a flat variance").unwrap_err());
        assert_eq!(path, truth);
        assert!(m.starts_with("frame 1: stack has 1 frame(s), a flat variance needs at least 2; "));
        assert!(m.contains(note), "{m}");
        // With its stack (a glob matching both): not one stack, and why.
        let mixed = FrameStack::open(&[stack.clone(), truth.clone()]).unwrap_err();
        let (path, m) = message(mixed);
        assert_eq!(path, truth);
        assert!(m.contains("sample types") && m.contains(note), "{m}");
        // A one-frame file named otherwise is not called a truth map.
        let other = FrameStack::open(std::slice::from_ref(&single)).unwrap();
        let (path, m) = message(other.require_frames(2, "a variance").unwrap_err());
        assert_eq!(path, single);
        assert!(!m.contains("truth map"), "{m}");
        let (_, m) = message(FrameStack::open(&[stack, single]).unwrap_err());
        assert!(!m.contains("truth map"), "{m}");
    }
}
