//! FITS frames through CFITSIO (`fitsio` crate, bundled library): a cube in one HDU,
//! one 2-D image HDU per frame, tile-compressed (RICE/GZIP) and `.fits.gz` files.
//!
//! CFITSIO applies BSCALE/BZERO and BLANK when reading as f64. Uncompressed HDUs without
//! BLANK take a raw-read fast path (big-endian decode in Rust), several times faster than
//! CFITSIO's per-pixel conversion; it gives the same values (tested).

use std::ffi::{c_int, CString};
use std::os::unix::fs::FileExt;
use std::path::{Path, PathBuf};

use fitsio::sys;
use fitsio::FitsFile;

use super::disk::{self, status_text};
use super::header;
use crate::error::{Error, Result};
use crate::io::checks::{frame_error, prefix_frame, MAX_SAMPLE_ABS};
use crate::io::format::SampleType;
use crate::io::frame::{FileFrames, RawKind, RawLayout};

const IMAGE_HDU: c_int = 0;
const KEY_NO_EXIST: c_int = 202;

fn check(path: &Path, status: c_int, what: &str) -> Result<()> {
    if status == 0 {
        Ok(())
    } else {
        Err(Error::input(
            path,
            format!("{what}: {}", status_text(status)),
        ))
    }
}

/// Where and how the samples of an uncompressed HDU are stored.
#[derive(Clone, Copy, Debug)]
struct HduData {
    datastart: u64,
    bitpix: i32,
    bscale: f64,
    bzero: f64,
}

impl HduData {
    /// Whether every stored integer maps to a finite value within the sample range, so
    /// frames need no per-sample check.
    fn within_sample_range(&self) -> bool {
        let max_stored = match self.bitpix {
            8 => 255.0,
            16 => 32768.0,
            32 => 2_147_483_648.0,
            _ => return false,
        };
        (max_stored * self.bscale.abs() + self.bzero.abs()) <= MAX_SAMPLE_ABS
    }

    /// The integer layout of the samples (None for floats): the one big-endian integer
    /// decoder serves the raw frames and this reader.
    fn integer_layout(&self) -> Option<RawLayout> {
        let kind = match self.bitpix {
            8 => RawKind::U8,
            16 => RawKind::I16,
            32 => RawKind::I32,
            64 => RawKind::I64,
            _ => return None,
        };
        Some(RawLayout {
            kind,
            big_endian: true,
            scale: self.bscale,
            zero: self.bzero,
        })
    }

    /// Decode the stored bytes of one frame into `out`.
    fn decode(&self, bytes: &[u8], out: &mut [f64]) {
        if let Some(layout) = self.integer_layout() {
            return layout.decode(bytes, out);
        }
        let (scale, zero) = (self.bscale, self.bzero);
        macro_rules! dec {
            ($t:ty, $n:expr) => {
                for (o, c) in out.iter_mut().zip(bytes.chunks_exact($n)) {
                    *o = <$t>::from_be_bytes(c.try_into().expect("chunk size")) as f64 * scale
                        + zero;
                }
            };
        }
        match self.bitpix {
            -32 => dec!(f32, 4),
            -64 => dec!(f64, 8),
            _ => unreachable!("bitpix checked at open"),
        }
    }
}

#[derive(Clone, Debug)]
struct HduFrames {
    /// 1-based HDU number.
    hdu: c_int,
    /// Index within the file of this HDU's first frame.
    first: usize,
    frames: usize,
    raw: Option<HduData>,
}

/// The frames of one FITS file.
pub struct FitsFrames {
    path: PathBuf,
    file: FitsFile,
    raw_file: Option<std::fs::File>,
    hdus: Vec<HduFrames>,
    shape: (usize, usize),
    sample_type: SampleType,
    bytes: Vec<u8>,
    bunit: Option<String>,
}

fn sample_type_of(path: &Path, hdu: c_int, stored: c_int, equiv: c_int) -> Result<SampleType> {
    let t = match (stored, equiv) {
        (_, 8) => SampleType::U8,
        (_, 10) => SampleType::I8,
        (_, 16) => SampleType::I16,
        (_, 20) => SampleType::U16,
        (_, 32) => SampleType::I32,
        (_, 40) => SampleType::U32,
        (_, 64) => SampleType::I64,
        (s, -32 | -64) if s > 0 => SampleType::Scaled,
        (_, -32) => SampleType::F32,
        (_, -64) => SampleType::F64,
        (_, 80) => SampleType::Scaled,
        (s, e) => {
            return Err(Error::input(
                path,
                format!("HDU {hdu}: unsupported BITPIX {s} (equivalent type {e})"),
            ))
        }
    };
    Ok(t)
}

fn read_key_f64(
    fptr: *mut sys::fitsfile,
    key: &str,
    default: f64,
) -> std::result::Result<f64, c_int> {
    let name = CString::new(key).expect("key has no NUL");
    let mut value = 0.0;
    let mut status = 0;
    // SAFETY: fptr is a valid open fitsfile; a NULL comment pointer is allowed by CFITSIO.
    unsafe {
        sys::ffgkyd(
            fptr,
            name.as_ptr(),
            &mut value,
            std::ptr::null_mut(),
            &mut status,
        )
    };
    match status {
        0 => Ok(value),
        KEY_NO_EXIST => Ok(default),
        s => Err(s),
    }
}

fn has_key(fptr: *mut sys::fitsfile, key: &str) -> bool {
    read_key_f64(fptr, key, f64::NAN)
        .map(|v| !v.is_nan())
        .unwrap_or(true)
}

fn is_plain_fits(path: &Path) -> bool {
    use std::io::Read;
    let mut head = [0u8; 6];
    std::fs::File::open(path)
        .and_then(|mut f| f.read_exact(&mut head))
        .map(|_| &head == b"SIMPLE")
        .unwrap_or(false)
}

impl FitsFrames {
    /// Open `path` and list its image HDUs; all must have one frame shape. The headers are
    /// checked first (module `header`), so CFITSIO never sees an unchecked size.
    pub fn open(path: &Path) -> Result<FitsFrames> {
        disk::c_name(path)?;
        let images = header::check(path)?;
        let mut file = disk::open(path).map_err(|e| prefix_frame(e, 0))?;
        // SAFETY: the pointer stays owned by `file`, which outlives every use below.
        let fptr = unsafe { file.as_raw() };
        let plain = is_plain_fits(path);
        let mut hdus = Vec::new();
        let mut shape = None;
        let mut sample_type = SampleType::F64;
        let mut first = 0usize;
        for img in &images {
            let hdu = img.hdu;
            let (stored, t) = move_to_image(path, fptr, hdu, &img.dims, first)?;
            let ((rows, cols), frames) = (img.shape(), img.frames());
            match shape {
                None => {
                    shape = Some((rows, cols));
                    sample_type = t;
                }
                Some((r, c)) if (r, c) != (rows, cols) => {
                    return Err(Error::input(
                        path,
                        format!("frame {first}: HDU {hdu} has shape {rows}x{cols}, earlier frames {r}x{c}"),
                    ));
                }
                _ => {}
            }
            let raw = if plain && !img.compressed {
                direct_read(path, fptr, hdu, stored)?
            } else {
                None
            };
            hdus.push(HduFrames {
                hdu,
                first,
                frames,
                raw,
            });
            first += frames;
        }
        let Some(shape) = shape else {
            return Err(Error::input(path, "frame 0: no image data in any HDU"));
        };
        let raw_file = if hdus.iter().any(|h| h.raw.is_some()) {
            Some(std::fs::File::open(path).map_err(|e| Error::io(path, e))?)
        } else {
            None
        };
        Ok(FitsFrames {
            path: path.to_path_buf(),
            file,
            raw_file,
            hdus,
            shape,
            sample_type,
            bytes: Vec::new(),
            bunit: images.first().and_then(|i| i.bunit.clone()),
        })
    }

    /// Total frames in the file.
    pub fn frames(&self) -> usize {
        self.hdus.iter().map(|h| h.frames).sum()
    }

    /// The BUNIT (unit of the values) of the HDU holding the first frame, if stated.
    pub fn bunit(&self) -> Option<&str> {
        self.bunit.as_deref()
    }
}

/// Make the image HDU `hdu` current, check that CFITSIO reads the dimensions `header_dims`
/// the header check found (naming the file's frame `first`), and return its stored BITPIX
/// and sample type.
fn move_to_image(
    path: &Path,
    fptr: *mut sys::fitsfile,
    hdu: c_int,
    header_dims: &[usize],
    first: usize,
) -> Result<(c_int, SampleType)> {
    let mut exttype = 0;
    let mut status = 0;
    unsafe { sys::ffmahd(fptr, hdu, &mut exttype, &mut status) };
    check(path, status, &format!("HDU {hdu}"))?;
    let dims = cfitsio_dims(path, fptr, hdu)?;
    if exttype != IMAGE_HDU || dims != header_dims {
        return Err(Error::input(
            path,
            format!(
                "frame {first}: HDU {hdu}: CFITSIO reads dimensions {dims:?}, the header says {header_dims:?}"
            ),
        ));
    }
    let (mut stored, mut equiv) = (0, 0);
    unsafe { sys::ffgidt(fptr, &mut stored, &mut status) };
    unsafe { sys::ffgiet(fptr, &mut equiv, &mut status) };
    check(path, status, &format!("HDU {hdu}"))?;
    Ok((stored, sample_type_of(path, hdu, stored, equiv)?))
}

/// Where the current HDU's data (stored BITPIX `stored`) can be read straight from the file,
/// bypassing CFITSIO; None where CFITSIO must read it.
fn direct_read(
    path: &Path,
    fptr: *mut sys::fitsfile,
    hdu: c_int,
    stored: c_int,
) -> Result<Option<HduData>> {
    let layout = raw_layout(path, fptr, hdu, stored)?;
    // BLANK marks undefined integer pixels: leave those HDUs to CFITSIO, which turns them
    // into NaN. Scaled values that can exceed the sample range take the checked path too.
    Ok((stored < 0 || !has_key(fptr, "BLANK"))
        .then_some(layout)
        .filter(|l| stored < 0 || l.within_sample_range()))
}

/// The image dimensions CFITSIO reads for the current HDU (NAXIS1 first).
fn cfitsio_dims(path: &Path, fptr: *mut sys::fitsfile, hdu: c_int) -> Result<Vec<usize>> {
    let (mut naxis, mut status) = (0, 0);
    unsafe { sys::ffgidm(fptr, &mut naxis, &mut status) };
    check(path, status, &format!("HDU {hdu}"))?;
    let mut dims = vec![0i64; naxis.clamp(0, 999) as usize];
    if !dims.is_empty() {
        unsafe { sys::ffgiszll(fptr, naxis, dims.as_mut_ptr(), &mut status) };
        check(path, status, &format!("HDU {hdu}"))?;
    }
    Ok(dims
        .iter()
        .map(|d| usize::try_from(*d).unwrap_or(usize::MAX))
        .collect())
}

fn raw_layout(path: &Path, fptr: *mut sys::fitsfile, hdu: c_int, bitpix: c_int) -> Result<HduData> {
    let (mut head, mut data, mut end) = (0i64, 0i64, 0i64);
    let mut status = 0;
    unsafe { sys::ffghadll(fptr, &mut head, &mut data, &mut end, &mut status) };
    check(path, status, &format!("HDU {hdu}"))?;
    let bad = |s| Error::input(path, format!("HDU {hdu}: {}", status_text(s)));
    let bscale = read_key_f64(fptr, "BSCALE", 1.0).map_err(bad)?;
    let bzero = read_key_f64(fptr, "BZERO", 0.0).map_err(bad)?;
    Ok(HduData {
        datastart: data as u64,
        bitpix,
        bscale,
        bzero,
    })
}

/// Frame count, shape and sample type of a FITS file (headers only).
pub fn scan(path: &Path) -> Result<(usize, (usize, usize), SampleType)> {
    let f = FitsFrames::open(path)?;
    Ok((f.frames(), f.shape, f.sample_type))
}

impl FitsFrames {
    fn hdu_of(&self, k: usize) -> Option<&HduFrames> {
        self.hdus
            .iter()
            .find(|h| k >= h.first && k < h.first + h.frames)
    }
}

impl FileFrames for FitsFrames {
    fn raw_layout(&self, k: usize) -> Option<RawLayout> {
        let raw = self.hdu_of(k)?.raw?;
        raw.integer_layout()
            .filter(|_| raw.bscale.is_finite() && raw.bzero.is_finite())
    }

    fn read_raw(&mut self, k: usize, bytes: &mut Vec<u8>) -> Result<u64> {
        let h = self
            .hdu_of(k)
            .cloned()
            .ok_or_else(|| frame_error(&self.path, k, "no such frame"))?;
        let (Some(raw), Some(file)) = (h.raw, self.raw_file.as_ref()) else {
            return Err(frame_error(&self.path, k, "no raw layout"));
        };
        let offset = raw.datastart + ((k - h.first) * bytes.len()) as u64;
        file.read_exact_at(bytes, offset)
            .map_err(|e| frame_error(&self.path, k, format!("cannot read data: {e}")))?;
        Ok(offset)
    }

    fn may_be_out_of_range(&self, k: usize) -> bool {
        // Raw integer HDUs have no BLANK and map into the sample range (checked at open).
        self.hdu_of(k)
            .is_none_or(|h| h.raw.is_none_or(|r| r.bitpix < 0))
    }

    fn read_frame(&mut self, k: usize, out: &mut [f64]) -> Result<()> {
        let h = self
            .hdus
            .iter()
            .find(|h| k >= h.first && k < h.first + h.frames)
            .ok_or_else(|| frame_error(&self.path, k, "no such frame"))?
            .clone();
        let npix = self.shape.0 * self.shape.1;
        let local = (k - h.first) as u64;
        if let (Some(raw), Some(file)) = (h.raw, self.raw_file.as_ref()) {
            let width = raw.bitpix.unsigned_abs() as usize / 8;
            self.bytes.resize(npix * width, 0);
            let offset = raw.datastart + local * (npix * width) as u64;
            file.read_exact_at(&mut self.bytes, offset)
                .map_err(|e| frame_error(&self.path, k, format!("cannot read data: {e}")))?;
            raw.decode(&self.bytes, out);
            return Ok(());
        }
        // SAFETY: fptr is owned by self.file; `out` has npix elements (checked by the caller).
        let fptr = unsafe { self.file.as_raw() };
        let mut status = 0;
        let mut exttype = 0;
        let mut anynul = 0;
        unsafe {
            sys::ffmahd(fptr, h.hdu, &mut exttype, &mut status);
            sys::ffgpvd(
                fptr,
                1,
                1 + (local * npix as u64) as i64,
                npix as i64,
                f64::NAN,
                out.as_mut_ptr(),
                &mut anynul,
                &mut status,
            );
        }
        if status != 0 {
            return Err(frame_error(
                &self.path,
                k,
                format!("HDU {}: {}", h.hdu, status_text(status)),
            ));
        }
        Ok(())
    }
}
