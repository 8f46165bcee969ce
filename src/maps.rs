//! 2-D maps (per-pixel offset, noise, gain, flags): the `Map` type, reading a single map
//! from FITS/TIFF/EXR, and writing FITS maps with BUNIT and provenance keywords.
//!
//! Every output file is written to a temporary file in the destination directory and
//! renamed into place, so a failure never leaves a partial file.

use std::path::Path;

use fitsio::images::{ImageDescription, ImageType};
use fitsio::FitsFile;

use crate::error::{Error, Result};

/// A single 2-D map (rows x cols) of f64 values in row-major order.
#[derive(Clone, Debug, PartialEq)]
pub struct Map {
    /// Number of rows.
    pub rows: usize,
    /// Number of columns.
    pub cols: usize,
    /// Values, row-major (`data[r * cols + c]`).
    pub data: Vec<f64>,
}

impl Map {
    /// A map of `rows` x `cols` filled with `value`.
    pub fn filled(rows: usize, cols: usize, value: f64) -> Map {
        Map {
            rows,
            cols,
            data: vec![value; rows * cols],
        }
    }

    /// A map from row-major data; panics if the length is not rows*cols (a programming error).
    pub fn new(rows: usize, cols: usize, data: Vec<f64>) -> Map {
        assert_eq!(data.len(), rows * cols, "map data length");
        Map { rows, cols, data }
    }

    /// Value at (row, col).
    pub fn at(&self, r: usize, c: usize) -> f64 {
        self.data[r * self.cols + c]
    }
}

/// Read a single 2-D map (the first frame) from a FITS, TIFF or EXR file.
/// NaN values are kept (they mark masked pixels).
pub fn read_map(path: impl AsRef<Path>) -> Result<Map> {
    crate::io::read_first_frame(path.as_ref())
}

/// A FITS header value.
#[derive(Clone, Debug)]
pub enum KeyValue {
    /// A string (FITS limits it to 68 characters; longer strings are cut).
    Str(String),
    /// A real number.
    F64(f64),
    /// An integer.
    I64(i64),
}

/// One header keyword: name (<= 8 characters), value, comment.
pub type Keyword = (String, KeyValue, String);

/// Build a keyword entry.
pub fn key(name: &str, value: KeyValue, comment: &str) -> Keyword {
    (name.to_string(), value, comment.to_string())
}

use crate::output::write_atomic_with;
pub use crate::output::write_json;

fn fits_err(path: &Path, e: fitsio::errors::Error) -> Error {
    Error::io(path, std::io::Error::other(e.to_string()))
}

/// Write header keywords to the primary HDU of an open FITS file.
pub(crate) fn write_keys(f: &mut FitsFile, path: &Path, keys: &[Keyword]) -> Result<()> {
    let hdu = f.primary_hdu().map_err(|e| fits_err(path, e))?;
    for (name, value, comment) in keys {
        let r = match value {
            KeyValue::Str(s) => {
                let s: String = s.chars().take(68).collect();
                hdu.write_key(f, name, (s, comment.as_str()))
            }
            KeyValue::F64(v) => hdu.write_key(f, name, (*v, comment.as_str())),
            KeyValue::I64(v) => hdu.write_key(f, name, (*v, comment.as_str())),
        };
        r.map_err(|e| fits_err(path, e))?;
    }
    Ok(())
}

/// Standard provenance keywords: creating tool and version.
pub fn provenance() -> Vec<Keyword> {
    vec![key(
        "CREATOR",
        KeyValue::Str(format!("detnoise {}", env!("CARGO_PKG_VERSION"))),
        "software that wrote this file",
    )]
}

/// Write `map` as a 64-bit float FITS image with BUNIT `bunit` and extra keywords.
pub fn write_fits_map(path: &Path, map: &Map, bunit: &str, keys: &[Keyword]) -> Result<()> {
    write_fits_image(
        path,
        map.rows,
        map.cols,
        FitsData::F64(&map.data),
        bunit,
        keys,
    )
}

/// Write integer flags (bit field) as a 32-bit integer FITS image.
pub fn write_fits_flags(
    path: &Path,
    rows: usize,
    cols: usize,
    flags: &[i32],
    keys: &[Keyword],
) -> Result<()> {
    write_fits_image(path, rows, cols, FitsData::I32(flags), "", keys)
}

enum FitsData<'a> {
    F64(&'a [f64]),
    I32(&'a [i32]),
}

fn write_fits_image(
    path: &Path,
    rows: usize,
    cols: usize,
    data: FitsData,
    bunit: &str,
    keys: &[Keyword],
) -> Result<()> {
    write_atomic_with(path, |tmp| {
        let data_type = match data {
            FitsData::F64(_) => ImageType::Double,
            FitsData::I32(_) => ImageType::Long,
        };
        let desc = ImageDescription {
            data_type,
            dimensions: &[rows, cols],
        };
        let mut f = FitsFile::create(tmp)
            .with_custom_primary(&desc)
            .overwrite()
            .open()
            .map_err(|e| fits_err(tmp, e))?;
        let hdu = f.primary_hdu().map_err(|e| fits_err(tmp, e))?;
        match data {
            FitsData::F64(d) => hdu.write_image(&mut f, d),
            FitsData::I32(d) => hdu.write_image(&mut f, d),
        }
        .map_err(|e| fits_err(tmp, e))?;
        let mut all = Vec::new();
        if !bunit.is_empty() {
            all.push(key(
                "BUNIT",
                KeyValue::Str(bunit.to_string()),
                "unit of the pixel values",
            ));
        }
        all.extend(provenance());
        all.extend_from_slice(keys);
        write_keys(&mut f, tmp, &all)?;
        Ok(())
    })
}
