//! FITS files opened and created by their plain disk names: the one place a path reaches
//! CFITSIO. CFITSIO's extended filename syntax would read another HDU than the header check
//! did (`x.fits[1]`) or fail on a directory such as `d(1)` ("file open failed (parser)"), so
//! names are taken literally; the `fitsio` crate panics on a name that is not UTF-8, so such a
//! name is refused here, naming it.

use std::ffi::{c_char, c_int, CString};
use std::path::Path;

use fitsio::images::ImageDescription;
use fitsio::sys;
use fitsio::{FileOpenMode, FitsFile};

use crate::error::{Error, Result};

/// The name of `path` as CFITSIO takes it (UTF-8 without NUL), or an error naming the path.
pub(crate) fn c_name(path: &Path) -> Result<CString> {
    let name = crate::io::checks::utf8_path(path)?;
    CString::new(name).map_err(|_| Error::input(path, "the path holds a NUL byte"))
}

/// CFITSIO's message for `status`.
pub(super) fn status_text(status: c_int) -> String {
    let mut buf = [0 as c_char; 32];
    // SAFETY: ffgerr writes at most 31 characters and a NUL into the 32-byte buffer.
    unsafe { sys::ffgerr(status, buf.as_mut_ptr()) };
    let bytes: Vec<u8> = buf
        .iter()
        .take_while(|c| **c != 0)
        .map(|c| *c as u8)
        .collect();
    format!(
        "CFITSIO error {status}: {}",
        String::from_utf8_lossy(&bytes)
    )
}

/// A `FitsFile` in `mode` over the pointer CFITSIO returned with `status`, or an error
/// naming `path`.
fn wrap(
    path: &Path,
    (fptr, status): (*mut sys::fitsfile, c_int),
    mode: FileOpenMode,
    what: &str,
) -> Result<FitsFile> {
    if status != 0 || fptr.is_null() {
        return Err(Error::input(
            path,
            format!("{what}: {}", status_text(status)),
        ));
    }
    // SAFETY: fptr is a file CFITSIO has just opened; the FitsFile owns and closes it.
    unsafe { FitsFile::from_raw(fptr, mode) }
        .map_err(|e| Error::input(path, format!("{what}: {e}")))
}

/// Open the existing FITS file at `path` read-only, its name taken literally.
pub(crate) fn open(path: &Path) -> Result<FitsFile> {
    let name = c_name(path)?;
    let (mut fptr, mut status) = (std::ptr::null_mut(), 0);
    // SAFETY: name is NUL-terminated; CFITSIO writes the new file pointer and the status.
    unsafe { sys::ffdkopn(&mut fptr, name.as_ptr(), 0, &mut status) };
    wrap(
        path,
        (fptr, status),
        FileOpenMode::READONLY,
        "cannot open as FITS",
    )
}

/// Create a new FITS file at `path` (a temporary of the caller's, replaced if it exists), its
/// name taken literally, with `primary` as its primary image, or an empty primary HDU.
pub(crate) fn create(path: &Path, primary: Option<&ImageDescription>) -> Result<FitsFile> {
    let name = c_name(path)?;
    if path.is_file() {
        std::fs::remove_file(path).map_err(|e| Error::io(path, e))?;
    }
    let (mut fptr, mut status) = (std::ptr::null_mut(), 0);
    // SAFETY: name is NUL-terminated; CFITSIO writes the new file pointer and the status.
    unsafe { sys::ffdkinit(&mut fptr, name.as_ptr(), &mut status) };
    let mut f = wrap(
        path,
        (fptr, status),
        FileOpenMode::READWRITE,
        "cannot create as FITS",
    )?;
    let fail = |e: fitsio::errors::Error| Error::io(path, std::io::Error::other(e.to_string()));
    match primary {
        // `_PRIMARY` is the fitsio crate's name for a primary image, written as EXTNAME as
        // files have always had it.
        Some(desc) => f.create_image("_PRIMARY", desc).map(|_| ()).map_err(fail)?,
        None => {
            // SAFETY: the file is open read-write; an 8-bit image of no axis is an empty HDU.
            unsafe { sys::ffphps(f.as_raw(), 8, 0, std::ptr::null_mut(), &mut status) };
            if status != 0 {
                return Err(Error::input(path, status_text(status)));
            }
        }
    }
    Ok(f)
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::os::unix::ffi::OsStrExt;

    #[test]
    fn names_are_literal_and_utf8_only() {
        let d = tempfile::tempdir().unwrap();
        // Extended-syntax characters are part of the name.
        let sub = d.path().join("d(1)");
        std::fs::create_dir(&sub).unwrap();
        for name in ["x[1].fits", "!y.fits", "z.fits+1"] {
            let p = sub.join(name);
            drop(create(&p, None).unwrap());
            assert!(p.is_file(), "{name}");
        }
        // A name that is not UTF-8 is refused, shown lossily; nothing is created.
        let bad = d.path().join(std::ffi::OsStr::from_bytes(b"dk\xff.fits"));
        for e in [create(&bad, None).err(), open(&bad).err()].map(Option::unwrap) {
            let m = e.to_string();
            assert!(
                m.contains("dk\u{fffd}.fits: the path is not valid UTF-8"),
                "{m}"
            );
        }
        assert!(!bad.exists());
    }
}
