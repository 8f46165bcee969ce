//! FITS writing: a stack as one cube, a map as one image (64-bit floats or 32-bit integer
//! flags), each with BUNIT, the creating tool and the caller's keywords. Every file is written
//! to a temporary file beside its destination and renamed into place, so a failure never
//! leaves a partial file.

use std::path::Path;

use fitsio::images::{ImageDescription, ImageType};
use fitsio::FitsFile;

use crate::error::{Error, Result};
use crate::io::frame::to_u16;
use crate::output::write_atomic_with;

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

/// Standard provenance keywords: creating tool and version.
pub fn provenance() -> Vec<Keyword> {
    vec![key(
        "CREATOR",
        KeyValue::Str(format!("detnoise {}", env!("CARGO_PKG_VERSION"))),
        "software that wrote this file",
    )]
}

fn fits_err(path: &Path, e: fitsio::errors::Error) -> Error {
    Error::io(path, std::io::Error::other(e.to_string()))
}

/// Write header keywords to the primary HDU of an open FITS file.
fn write_keys(f: &mut FitsFile, path: &Path, keys: &[Keyword]) -> Result<()> {
    let hdu = f.primary_hdu().map_err(|e| fits_err(path, e))?;
    for (name, value, comment) in keys {
        let r = match value {
            KeyValue::Str(s) => {
                let s: String = s.chars().take(68).collect();
                hdu.write_key(f, name, (s, comment.as_str()))
            }
            KeyValue::F64(v) if v.is_finite() => hdu.write_key(f, name, (*v, comment.as_str())),
            // FITS has no NaN or infinity among its values: say it in words, as a string.
            KeyValue::F64(v) => hdu.write_key(f, name, (format!("{v}"), comment.as_str())),
            KeyValue::I64(v) => hdu.write_key(f, name, (*v, comment.as_str())),
        };
        r.map_err(|e| fits_err(path, e))?;
    }
    Ok(())
}

/// The pixels of one image, row-major.
#[derive(Clone, Copy, Debug)]
pub enum ImageData<'a> {
    /// 64-bit floats (maps).
    F64(&'a [f64]),
    /// 32-bit integers (flag bit fields).
    I32(&'a [i32]),
}

/// Write one 2-D image of `shape` (rows, cols) as the primary HDU of a new FITS file, with
/// BUNIT `bunit` (none if empty), the provenance keywords and `keys`, atomically.
pub fn write_image(
    path: &Path,
    shape: (usize, usize),
    data: ImageData,
    bunit: &str,
    keys: &[Keyword],
) -> Result<()> {
    write_atomic_with(path, |tmp| {
        let data_type = match data {
            ImageData::F64(_) => ImageType::Double,
            ImageData::I32(_) => ImageType::Long,
        };
        let (mut f, hdu) = create_primary(tmp, data_type, &[shape.0, shape.1])?;
        match data {
            ImageData::F64(d) => hdu.write_image(&mut f, d),
            ImageData::I32(d) => hdu.write_image(&mut f, d),
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

/// A new FITS file at `tmp` whose primary HDU is an image of `data_type` and `dimensions`
/// (slowest axis first), with that HDU.
fn create_primary(
    tmp: &Path,
    data_type: ImageType,
    dimensions: &[usize],
) -> Result<(FitsFile, fitsio::hdu::FitsHdu)> {
    let desc = ImageDescription {
        data_type,
        dimensions,
    };
    let mut f = super::disk::create(tmp, Some(&desc))?;
    let hdu = f.primary_hdu().map_err(|e| fits_err(tmp, e))?;
    Ok((f, hdu))
}

/// Write frames as one FITS cube (NAXIS3 = frames), atomically. `u16` stores unsigned
/// 16-bit integers (int16 + BZERO 32768, values rounded and clamped), otherwise 32-bit floats.
pub fn write_cube(
    path: &Path,
    shape: (usize, usize),
    frames: usize,
    u16_samples: bool,
    next: &mut dyn FnMut() -> Vec<f64>,
    keys: &[Keyword],
) -> Result<()> {
    write_atomic_with(path, |tmp| {
        let data_type = if u16_samples {
            ImageType::UnsignedShort
        } else {
            ImageType::Float
        };
        let (mut f, hdu) = create_primary(tmp, data_type, &[frames, shape.0, shape.1])?;
        let npix = shape.0 * shape.1;
        for k in 0..frames {
            let frame = next();
            let r = if u16_samples {
                let v: Vec<u16> = frame.iter().map(|x| to_u16(*x)).collect();
                hdu.write_section(&mut f, k * npix, (k + 1) * npix, &v)
            } else {
                let v: Vec<f32> = frame.iter().map(|x| *x as f32).collect();
                hdu.write_section(&mut f, k * npix, (k + 1) * npix, &v)
            };
            r.map_err(|e| fits_err(tmp, e))?;
        }
        let mut all = provenance();
        all.extend_from_slice(keys);
        write_keys(&mut f, tmp, &all)
    })
}
