//! What a stack's files hold: their format (FITS, TIFF, OpenEXR) and the storage type of
//! their samples.

use std::path::Path;

use serde::Serialize;

use crate::error::{Error, Result};

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

/// File format of a stack as the reader detects it from a file's first bytes (what `synth`
/// writes is [`SynthFormat`](crate::synth::SynthFormat)).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum StackFormat {
    /// FITS: plain, gzip- or tile-compressed (CFITSIO).
    Fits,
    /// TIFF or BigTIFF, one page per frame.
    Tiff,
    /// OpenEXR, one layer per frame.
    Exr,
}

impl StackFormat {
    /// Detect the format of `path` from its first bytes.
    pub fn detect(path: &Path) -> Result<StackFormat> {
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
            Ok(StackFormat::Fits)
        } else if h.starts_with(b"II*\0")
            || h.starts_with(b"MM\0*")
            || h.starts_with(b"II+\0")
            || h.starts_with(b"MM\0+")
        {
            Ok(StackFormat::Tiff)
        } else if h.starts_with(&[0x76, 0x2f, 0x31, 0x01]) {
            Ok(StackFormat::Exr)
        } else {
            Err(Error::input(
                path,
                "not a FITS, TIFF or OpenEXR file (unrecognised header)",
            ))
        }
    }
}
