//! Frame stacks: sequences of 2-D frames of one shape read one frame at a time from FITS,
//! TIFF or OpenEXR files, given as files, directories or glob patterns.
//!
//! Memory is O(frame): a [`StackReader`] holds one open file and the caller's frame buffer.
//! Orientation is rows x columns as the file stores them (FITS NAXIS1 is the column count).

pub mod exr;
pub mod fits;
mod fits_header;
pub mod tiff;

use std::path::{Path, PathBuf};

use serde::Serialize;

use crate::error::{Error, Result};
use crate::maps::Map;

/// Largest factor by which compressed sample data may expand when decoded. Deflate's limit
/// is 1032:1 and LZW's about 1400:1 (on constant data); Rice, RLE, PackBits and B44 stay far
/// below. A header that claims more decoded bytes than this many times the bytes stored is
/// refused before anything is allocated (uncompressed data must be present in full).
pub const MAX_EXPANSION: u64 = 2048;

/// Largest magnitude of a sample value (adu): 2^53, beyond which f64 no longer holds every
/// integer. No camera delivers such values; they come from a corrupt header (BZERO, BSCALE)
/// or garbage data, and would overflow the sums of squares of the statistics.
pub const MAX_SAMPLE_ABS: f64 = 9_007_199_254_740_992.0;

/// The error for a header whose decoded size is impossible for the bytes stored
/// (`decoded` is None when the size does not even fit in 64 bits).
pub(crate) fn compressed_size_error(
    path: &Path,
    frame: usize,
    what: &str,
    decoded: Option<u64>,
    stored: u64,
) -> Error {
    let size = decoded.map_or("more than 2^64".to_string(), |d| d.to_string());
    frame_error(
        path,
        frame,
        format!(
            "{what} would decode to {size} bytes from {stored} stored bytes, more than compression allows ({MAX_EXPANSION}:1): the header is corrupt"
        ),
    )
}

/// Storage type of the samples in a file (values are always delivered as f64).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum SampleType {
    /// Unsigned 8-bit integer.
    U8,
    /// Signed 8-bit integer.
    I8,
    /// Unsigned 16-bit integer (FITS: int16 with BZERO 32768).
    U16,
    /// Signed 16-bit integer.
    I16,
    /// Unsigned 32-bit integer.
    U32,
    /// Signed 32-bit integer.
    I32,
    /// Signed 64-bit integer.
    I64,
    /// IEEE half-precision float.
    F16,
    /// IEEE single-precision float.
    F32,
    /// IEEE double-precision float.
    F64,
    /// Integers with a non-trivial FITS BSCALE/BZERO (values are scaled, so not integers).
    Scaled,
}

impl SampleType {
    /// True when the samples can hold NaN or Inf (floats and scaled integers are checked).
    pub fn is_float(self) -> bool {
        matches!(self, SampleType::F16 | SampleType::F32 | SampleType::F64)
    }

    /// Largest representable integer value, or None for floats; used to detect saturation.
    pub fn max_value(self) -> Option<f64> {
        match self {
            SampleType::U8 => Some(u8::MAX as f64),
            SampleType::I8 => Some(i8::MAX as f64),
            SampleType::U16 => Some(u16::MAX as f64),
            SampleType::I16 => Some(i16::MAX as f64),
            SampleType::U32 => Some(u32::MAX as f64),
            SampleType::I32 => Some(i32::MAX as f64),
            SampleType::I64 => Some(i64::MAX as f64),
            _ => None,
        }
    }
}

/// File formats recognised by their magic bytes.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Format {
    /// FITS (plain, gzip-compressed or tile-compressed), read with CFITSIO.
    Fits,
    /// TIFF or BigTIFF, read with the `tiff` crate.
    Tiff,
    /// OpenEXR, read with the `exr` crate.
    Exr,
}

impl Format {
    /// Detect the format of `path` from its first bytes.
    pub fn detect(path: &Path) -> Result<Format> {
        use std::io::Read;
        let mut f = std::fs::File::open(path).map_err(|e| Error::io(path, e))?;
        let mut head = [0u8; 9];
        let mut n = 0;
        while n < head.len() {
            match f.read(&mut head[n..]) {
                Ok(0) => break,
                Ok(k) => n += k,
                Err(e) => return Err(Error::io(path, e)),
            }
        }
        if n == 0 {
            return Err(Error::input(path, "frame 0: empty file"));
        }
        let h = &head[..n];
        if h.starts_with(b"SIMPLE  =") || h.starts_with(&[0x1f, 0x8b]) {
            Ok(Format::Fits)
        } else if h.starts_with(b"II*\0")
            || h.starts_with(b"MM\0*")
            || h.starts_with(b"II+\0")
            || h.starts_with(b"MM\0+")
        {
            Ok(Format::Tiff)
        } else if h.starts_with(&[0x76, 0x2f, 0x31, 0x01]) {
            Ok(Format::Exr)
        } else {
            Err(Error::input(
                path,
                "not a FITS, TIFF or OpenEXR file (unrecognised header)",
            ))
        }
    }
}

/// Header facts about one file of a stack.
#[derive(Clone, Debug, Serialize)]
pub struct SourceFile {
    /// Path of the file.
    pub path: PathBuf,
    /// Its format.
    pub format: Format,
    /// Number of frames it holds.
    pub frames: usize,
    /// Frame shape (rows, cols).
    pub shape: (usize, usize),
    /// Sample type as stored.
    pub sample_type: SampleType,
}

/// Reads the frames of one file in order; implemented per format.
pub(crate) trait FileFrames {
    /// Read frame `k` (0-based within the file) into `out` (row-major, rows*cols values).
    /// Frames are requested in increasing order.
    fn read_frame(&mut self, k: usize, out: &mut [f64]) -> Result<()>;

    /// Whether frame `k` can hold NaN/Inf or values beyond [`MAX_SAMPLE_ABS`] (false for
    /// plain integer storage, which skips the check).
    fn may_be_out_of_range(&self, _k: usize) -> bool {
        true
    }

    /// Layout of frame `k` when its stored bytes can be handed over undecoded (plain integers).
    fn raw_layout(&self, _k: usize) -> Option<RawLayout> {
        None
    }

    /// Read the stored bytes of frame `k` (only when `raw_layout(k)` is Some).
    fn read_raw(&mut self, k: usize, _bytes: &mut Vec<u8>) -> Result<()> {
        Err(Error::Numeric(format!(
            "frame {k}: no raw read for this format"
        )))
    }
}

/// Integer storage of raw frame bytes.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum RawKind {
    /// Unsigned 8-bit.
    U8,
    /// Signed 16-bit.
    I16,
    /// Signed 32-bit.
    I32,
    /// Signed 64-bit.
    I64,
}

/// How stored frame bytes map to values: value = stored x scale + zero.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RawLayout {
    /// Integer type of a sample.
    pub kind: RawKind,
    /// Big-endian byte order (FITS).
    pub big_endian: bool,
    /// Multiplier (FITS BSCALE).
    pub scale: f64,
    /// Offset (FITS BZERO).
    pub zero: f64,
}

impl RawLayout {
    /// Bytes per sample.
    pub fn width(&self) -> usize {
        match self.kind {
            RawKind::U8 => 1,
            RawKind::I16 => 2,
            RawKind::I32 => 4,
            RawKind::I64 => 8,
        }
    }

    /// Decode `bytes` (a whole number of samples) into `out`.
    pub fn decode(&self, bytes: &[u8], out: &mut [f64]) {
        let (scale, zero) = (self.scale, self.zero);
        macro_rules! dec {
            ($t:ty, $n:expr) => {
                for (o, c) in out.iter_mut().zip(bytes.chunks_exact($n)) {
                    let a: [u8; $n] = c.try_into().expect("chunk size");
                    let v = if self.big_endian {
                        <$t>::from_be_bytes(a)
                    } else {
                        <$t>::from_le_bytes(a)
                    };
                    *o = v as f64 * scale + zero;
                }
            };
        }
        match self.kind {
            RawKind::U8 => dec!(u8, 1),
            RawKind::I16 => dec!(i16, 2),
            RawKind::I32 => dec!(i32, 4),
            RawKind::I64 => dec!(i64, 8),
        }
    }
}

/// One frame as delivered by [`StackReader::next_frame_data`]: decoded values, or stored
/// integer bytes with their layout (decoded later, where the values are used).
#[derive(Clone, Debug)]
pub enum FrameData {
    /// Row-major values.
    Values(Vec<f64>),
    /// Row-major stored bytes and how to decode them.
    Raw(Vec<u8>, RawLayout),
}

impl FrameData {
    /// Turn a raw frame into values in place.
    pub fn decode_in_place(&mut self) {
        if let FrameData::Raw(bytes, layout) = self {
            let mut v = vec![0.0; bytes.len() / layout.width()];
            layout.decode(bytes, &mut v);
            *self = FrameData::Values(v);
        }
    }

    /// The values of a decoded frame (panics on a raw frame: call `decode_in_place` first).
    pub fn values(&self) -> &[f64] {
        match self {
            FrameData::Values(v) => v,
            FrameData::Raw(..) => panic!("frame not decoded"),
        }
    }

    /// Mutable values of a decoded frame (panics on a raw frame).
    pub fn values_mut(&mut self) -> &mut [f64] {
        match self {
            FrameData::Values(v) => v,
            FrameData::Raw(..) => panic!("frame not decoded"),
        }
    }
}

fn scan_file(path: &Path) -> Result<SourceFile> {
    let format = Format::detect(path)?;
    let (frames, shape, sample_type) = match format {
        Format::Fits => fits::scan(path)?,
        Format::Tiff => tiff::scan(path)?,
        Format::Exr => exr::scan(path)?,
    };
    if frames == 0 {
        return Err(Error::input(path, "file holds no image frame"));
    }
    if shape.0 == 0 || shape.1 == 0 {
        return Err(Error::input(
            path,
            format!("frame 0: empty frame shape {}x{}", shape.0, shape.1),
        ));
    }
    // The readers bound every shape by the file size; this keeps `rows * cols * 8` exact.
    if shape
        .0
        .checked_mul(shape.1)
        .and_then(|p| p.checked_mul(8))
        .is_none_or(|b| b > isize::MAX as usize)
    {
        return Err(Error::input(
            path,
            format!("frame 0: frame shape {}x{} is too large", shape.0, shape.1),
        ));
    }
    Ok(SourceFile {
        path: path.to_path_buf(),
        format,
        frames,
        shape,
        sample_type,
    })
}

fn open_file(src: &SourceFile) -> Result<Box<dyn FileFrames>> {
    match src.format {
        Format::Fits => Ok(Box::new(fits::FitsFrames::open(&src.path)?)),
        Format::Tiff => Ok(Box::new(tiff::TiffFrames::open(
            &src.path, src.shape, src.frames,
        )?)),
        Format::Exr => Ok(Box::new(exr::ExrFrames::open(&src.path, src.shape)?)),
    }
}

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

    /// Fail unless the stack has at least `n` frames (variances need 2).
    pub fn require_frames(&self, n: usize, what: &str) -> Result<()> {
        if self.frames < n {
            return Err(Error::input(
                &self.sources[0].path,
                format!(
                    "frame {}: stack has {} frame(s), {what} needs at least {n}",
                    self.frames, self.frames
                ),
            ));
        }
        Ok(())
    }

    /// A sequential reader over all frames.
    pub fn reader(&self) -> StackReader<'_> {
        StackReader {
            stack: self,
            file_index: 0,
            local: 0,
            global: 0,
            open: None,
        }
    }
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
    Err(Error::input(
        &sources[odd].path,
        format!(
            "frame 0 (stack frame {start}): differs from {}; the {} files of {} are not one stack: {}. A stack is frames of one camera in one format, shape and sample type (the same frames saved as .fits, .tif and .exr would be read three times): give one kind, e.g. DIR/*.fits",
            first.path.display(),
            sources.len(),
            shown(inputs),
            found.join("; ")
        ),
    ))
}

/// Sequential reader over the frames of a [`FrameStack`]; holds at most one open file.
pub struct StackReader<'a> {
    stack: &'a FrameStack,
    file_index: usize,
    local: usize,
    global: usize,
    open: Option<Box<dyn FileFrames>>,
}

impl StackReader<'_> {
    /// Read the next frame into `slot`, as stored integer bytes when the file allows it
    /// (reusing the slot's buffers), else as values. Returns the stack frame index, or None.
    pub fn next_frame_data(&mut self, slot: &mut FrameData) -> Result<Option<usize>> {
        self.skip_finished_files();
        let Some(src) = self.stack.sources.get(self.file_index) else {
            return Ok(None);
        };
        if self.open.is_none() {
            self.open = Some(open_file(src)?);
        }
        let reader = self.open.as_mut().expect("opened above");
        if let Some(layout) = reader.raw_layout(self.local) {
            let mut bytes = match std::mem::replace(slot, FrameData::Values(Vec::new())) {
                FrameData::Raw(b, _) => b,
                FrameData::Values(_) => Vec::new(),
            };
            bytes.resize(self.stack.pixels() * layout.width(), 0);
            reader
                .read_raw(self.local, &mut bytes)
                .map_err(|e| add_stack_frame(e, self.global))?;
            *slot = FrameData::Raw(bytes, layout);
            let k = self.global;
            self.local += 1;
            self.global += 1;
            return Ok(Some(k));
        }
        let mut values = match std::mem::replace(slot, FrameData::Values(Vec::new())) {
            FrameData::Values(v) => v,
            FrameData::Raw(..) => Vec::new(),
        };
        values.resize(self.stack.pixels(), 0.0);
        let r = self.next_frame(&mut values);
        *slot = FrameData::Values(values);
        r
    }

    fn skip_finished_files(&mut self) {
        while self.file_index < self.stack.sources.len()
            && self.local >= self.stack.sources[self.file_index].frames
        {
            self.file_index += 1;
            self.local = 0;
            self.open = None;
        }
    }

    /// Read the next frame into `out` (rows*cols f64, row-major). Returns the stack frame
    /// index, or None at the end. Non-finite samples are an error naming file and frame.
    pub fn next_frame(&mut self, out: &mut [f64]) -> Result<Option<usize>> {
        while self.file_index < self.stack.sources.len()
            && self.local >= self.stack.sources[self.file_index].frames
        {
            self.file_index += 1;
            self.local = 0;
            self.open = None;
        }
        let Some(src) = self.stack.sources.get(self.file_index) else {
            return Ok(None);
        };
        assert_eq!(
            out.len(),
            self.stack.pixels(),
            "frame buffer has the wrong length"
        );
        if self.open.is_none() {
            self.open = Some(open_file(src)?);
        }
        let reader = self.open.as_mut().expect("opened above");
        reader
            .read_frame(self.local, out)
            .map_err(|e| add_stack_frame(e, self.global))?;
        if reader.may_be_out_of_range(self.local) {
            check_samples(&src.path, src.shape.1, out, false)
                .map_err(|e| add_stack_frame(prefix_frame(e, self.local), self.global))?;
        }
        let k = self.global;
        self.local += 1;
        self.global += 1;
        Ok(Some(k))
    }
}

/// Fail on the first sample that is non-finite (NaN allowed when `nan_ok`, for masked map
/// pixels) or beyond [`MAX_SAMPLE_ABS`], naming its row and column.
fn check_samples(path: &Path, cols: usize, values: &[f64], nan_ok: bool) -> Result<()> {
    let bad = values
        .iter()
        .position(|v| !(v.abs() <= MAX_SAMPLE_ABS || (nan_ok && v.is_nan())));
    let Some(i) = bad else {
        return Ok(());
    };
    let v = values[i];
    let what = if v.is_finite() {
        format!(
            "sample {v:e} beyond +-2^53 (not camera data: check BZERO/BSCALE or the file's integrity)"
        )
    } else {
        format!("non-finite sample {v}")
    };
    Err(Error::input(
        path,
        format!("{what} at row {}, column {}", i / cols, i % cols),
    ))
}

/// Prefix the message of an input error with `frame k: `.
fn prefix_frame(e: Error, k: usize) -> Error {
    match e {
        Error::Input { path, message } => Error::Input {
            path,
            message: format!("frame {k}: {message}"),
        },
        other => other,
    }
}

fn add_stack_frame(e: Error, global: usize) -> Error {
    match e {
        Error::Input { path, message } => Error::Input {
            path,
            message: format!("{message} (stack frame {global})"),
        },
        other => other,
    }
}

/// Attribute a numerical failure to the file whose data caused it: `Error::Numeric` becomes
/// an input error naming `path`; other errors already name their file or option.
pub fn name_file(path: &Path, e: Error) -> Error {
    match e {
        Error::Numeric(message) => Error::Input {
            path: path.to_path_buf(),
            message,
        },
        other => other,
    }
}

/// Convert a decoding error of frame `k` of `path` into an input error.
pub(crate) fn frame_error(path: &Path, k: usize, what: impl std::fmt::Display) -> Error {
    Error::input(path, format!("frame {k}: {what}"))
}

/// Copy any numeric slice into an f64 buffer, checking the length.
pub(crate) fn widen<T: Copy + Into<f64>>(
    path: &Path,
    k: usize,
    src: &[T],
    out: &mut [f64],
) -> Result<()> {
    if src.len() != out.len() {
        return Err(frame_error(
            path,
            k,
            format!("{} samples decoded, {} expected", src.len(), out.len()),
        ));
    }
    for (o, s) in out.iter_mut().zip(src) {
        *o = (*s).into();
    }
    Ok(())
}

/// Read the first frame of a FITS, TIFF or EXR file (or stack argument) as a map.
/// NaN is allowed in maps (it marks masked pixels); infinities and values beyond
/// [`MAX_SAMPLE_ABS`] are not.
pub fn read_first_frame(path: &Path) -> Result<Map> {
    let src = scan_file(path)?;
    let mut data = vec![0.0; src.shape.0 * src.shape.1];
    open_file(&src)?.read_frame(0, &mut data)?;
    check_samples(path, src.shape.1, &data, true).map_err(|e| prefix_frame(e, 0))?;
    Ok(Map {
        rows: src.shape.0,
        cols: src.shape.1,
        data,
    })
}
