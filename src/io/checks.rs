//! Limits on what a file may claim (decoded size, sample magnitude) and the errors that name
//! the file and frame at fault.

use std::path::Path;

use crate::error::{Error, Result};

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

/// Fail on the first sample that is non-finite (NaN allowed when `nan_ok`, for masked map
/// pixels) or beyond [`MAX_SAMPLE_ABS`], naming its row and column.
pub(crate) fn check_samples(path: &Path, cols: usize, values: &[f64], nan_ok: bool) -> Result<()> {
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

/// The path as UTF-8, or an error naming it (lossily): the FITS library opens files by UTF-8
/// names only, and the JSON summaries record every input's path.
pub(crate) fn utf8_path(path: &Path) -> Result<&str> {
    path.to_str().ok_or_else(|| {
        Error::input(
            path,
            "the path is not valid UTF-8 (shown with U+FFFD for the bytes that are not): detnoise \
             takes UTF-8 file names only (the FITS library and the JSON summaries need them); \
             rename the file or directory",
        )
    })
}

/// Prefix the message of an input error with `frame k: `.
pub(crate) fn prefix_frame(e: Error, k: usize) -> Error {
    match e {
        Error::Input { path, message } => Error::Input {
            path,
            message: format!("frame {k}: {message}"),
        },
        other => other,
    }
}

/// Append ` (stack frame k)` to the message of an input error about a file of a stack.
pub(crate) fn add_stack_frame(e: Error, global: usize) -> Error {
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
