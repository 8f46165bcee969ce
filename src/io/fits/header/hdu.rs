//! The HDUs of a FITS file walked header by header: the mandatory keywords and the data size
//! they declare, the image each HDU holds, and its data passed over (checking a compressed
//! image's heap on the way) and compared with the bytes present.

use std::path::Path;

use super::cards::{bytes_per_sample, dims, mul, product, read_header, Header, BLOCK};
use super::compressed::{check_descriptors, compressed_image, descriptor_columns};
use super::source::Source;
use crate::error::{Error, Result};
use crate::io::checks::frame_error;

/// Largest NAXIS allowed by the FITS standard.
const MAX_NAXIS: i64 = 999;

/// One image HDU (plain or tile-compressed) with at least one 2-D frame.
#[derive(Clone, Debug, PartialEq, Eq)]
pub(crate) struct ImageHdu {
    /// 1-based HDU number.
    pub hdu: i32,
    /// Dimensions as CFITSIO reports them (NAXISn or ZNAXISn), NAXIS1 first.
    pub dims: Vec<usize>,
    /// Tile-compressed (a BINTABLE with ZIMAGE = T).
    pub compressed: bool,
    /// Its BUNIT (the unit of its values), if stated.
    pub bunit: Option<String>,
}

impl ImageHdu {
    /// Frame shape (rows, cols).
    pub fn shape(&self) -> (usize, usize) {
        (self.dims[1], self.dims[0])
    }

    /// Frames held (product of the dimensions beyond the second).
    pub fn frames(&self) -> usize {
        self.dims[2..].iter().product()
    }
}

/// What one header declares: its HDU number, the frames before it (for messages), the
/// sample width, NAXISn, PCOUNT and the data size in bytes.
struct Declared {
    hdu: i32,
    frame: usize,
    width: u64,
    axes: Vec<usize>,
    pcount: u64,
    data: u64,
}

impl Declared {
    /// The error `m` about this HDU.
    fn bad(&self, path: &Path, m: String) -> Error {
        Error::input(path, format!("frame {}: HDU {}: {m}", self.frame, self.hdu))
    }
}

/// The mandatory keywords of a header and the data size they give (checked arithmetic;
/// random groups count NAXIS2.. only, extensions PCOUNT and GCOUNT).
fn declared(path: &Path, h: &Header, hdu: i32, frame: usize) -> Result<(Declared, bool)> {
    let bad = |m: String| Error::input(path, format!("frame {frame}: HDU {hdu}: {m}"));
    if hdu == 1 && !h.logical("SIMPLE") {
        return Err(bad("SIMPLE = T missing: not a standard FITS file".into()));
    }
    let bitpix = h.required_int(path, hdu, "BITPIX")?;
    let width = bytes_per_sample(path, hdu, "BITPIX", bitpix)?;
    let naxis = h.required_int(path, hdu, "NAXIS")?;
    if !(0..=MAX_NAXIS).contains(&naxis) {
        return Err(bad(format!("NAXIS = {naxis} is outside 0..{MAX_NAXIS}")));
    }
    let axes = dims(path, h, hdu, "NAXIS", naxis)?;
    let primary = hdu == 1 && !h.logical("GROUPS");
    let (pcount, gcount) = if primary {
        (0, 1)
    } else {
        (
            h.int(path, hdu, "PCOUNT")?.unwrap_or(0),
            h.int(path, hdu, "GCOUNT")?.unwrap_or(1),
        )
    };
    let (Ok(pcount), Ok(gcount)) = (u64::try_from(pcount), u64::try_from(gcount)) else {
        return Err(bad(format!(
            "PCOUNT = {pcount}, GCOUNT = {gcount}: negative"
        )));
    };
    let groups = hdu == 1 && h.logical("GROUPS") && axes.first() == Some(&0);
    let counted = if groups { &axes[1..] } else { &axes[..] };
    let elements = if naxis == 0 {
        Some(0)
    } else {
        product(path, hdu, "NAXISn", counted)?
            .checked_add(pcount)
            .and_then(|e| mul(e, gcount))
    };
    let data = elements.and_then(|e| mul(e, width)).ok_or_else(|| {
        bad(format!(
            "NAXISn = {axes:?} with PCOUNT {pcount} overflow 64 bits"
        ))
    })?;
    let table = h.string("XTENSION").as_deref() == Some("BINTABLE");
    if table && h.logical("ZIMAGE") && bitpix != 8 {
        return Err(bad(format!(
            "BITPIX = {bitpix} in a binary table (must be 8)"
        )));
    }
    let d = Declared {
        hdu,
        frame,
        width,
        axes,
        pcount,
        data,
    };
    Ok((d, groups))
}

/// The image an HDU holds, if any: its dimensions, and for a tile-compressed image the
/// table's (row bytes, rows, heap bytes). Zero-sized images are no image; 1-D images and
/// frames too large to address are errors.
type Image = (Vec<usize>, Option<(u64, u64, u64)>);

fn image_of(path: &Path, h: &Header, d: &Declared, groups: bool) -> Result<Option<Image>> {
    let xtension = h.string("XTENSION").unwrap_or_default();
    let image = if xtension == "BINTABLE" && h.logical("ZIMAGE") {
        let (row_bytes, rows) = (
            d.axes.first().copied().unwrap_or(0) as u64,
            d.axes.get(1).copied().unwrap_or(0) as u64,
        );
        let zdims = compressed_image(path, h, d.hdu, rows, d.data)?;
        Some((zdims, Some((row_bytes, rows, d.pcount))))
    } else if (d.hdu == 1 || xtension == "IMAGE") && !groups && !d.axes.is_empty() {
        Some((d.axes.clone(), None))
    } else {
        None
    };
    let Some((dims, table)) = image.filter(|(dims, _)| !dims.contains(&0)) else {
        return Ok(None);
    };
    if dims.len() == 1 {
        return Err(Error::input(
            path,
            format!(
                "frame {}: HDU {} is a 1-D image, not a frame",
                d.frame, d.hdu
            ),
        ));
    }
    let pixels = product(path, d.hdu, "the frame shape", &dims[..2])?;
    if mul(pixels, 8).is_none_or(|b| b > isize::MAX as u64) {
        return Err(d.bad(
            path,
            format!("frame shape {}x{} is too large", dims[1], dims[0]),
        ));
    }
    Ok(Some((dims, table)))
}

/// Move past the data of an HDU (checking the heap descriptors of a compressed image on
/// the way); return how many of its bytes were present.
fn pass_data(
    path: &Path,
    src: &mut Source,
    h: &Header,
    d: &Declared,
    image: &Option<Image>,
) -> Result<u64> {
    let Some((row_bytes, rows, heap)) = image.as_ref().and_then(|(_, t)| *t) else {
        return src.skip(path, d.data);
    };
    let columns = descriptor_columns(path, h, d.hdu, row_bytes)?;
    let table = mul(row_bytes, rows).expect("within the data size");
    let theap = h.int(path, d.hdu, "THEAP")?.unwrap_or(table as i64);
    let heap_start = u64::try_from(theap)
        .ok()
        .filter(|t| *t >= table && *t <= table + heap)
        .ok_or_else(|| d.bad(path, format!("THEAP = {theap} is outside the data")))?;
    if src.remaining() < table {
        return src.skip(path, table);
    }
    let read = check_descriptors(
        path,
        src,
        d.hdu,
        &columns,
        (row_bytes, rows),
        (heap_start, table + heap),
    )?;
    if read < table {
        return Ok(read);
    }
    Ok(read + src.skip(path, d.data - table)?)
}

/// The error for data cut short: the first incomplete frame (of a plain image) and sizes.
fn truncated(path: &Path, d: &Declared, image: &Option<Image>, start: u64, present: u64) -> Error {
    let complete = match image {
        Some((dims, None)) => {
            let frame_bytes = (dims[0] as u64) * (dims[1] as u64) * d.width;
            (present / frame_bytes.max(1)) as usize
        }
        _ => 0,
    };
    frame_error(
        path,
        d.frame + complete,
        format!(
            "file truncated (HDU {} needs {} bytes, file has {})",
            d.hdu,
            start + d.data,
            start + present
        ),
    )
}

/// Parse and check every header of the FITS file at `path`; return its image HDUs.
pub(crate) fn check(path: &Path) -> Result<Vec<ImageHdu>> {
    let mut src = Source::open(path)?;
    let mut images = Vec::new();
    let mut frames_before = 0usize;
    for hdu in 1.. {
        let Some(h) = read_header(path, &mut src, hdu, frames_before)? else {
            break;
        };
        let (d, groups) = declared(path, &h, hdu, frames_before)?;
        let image = image_of(path, &h, &d, groups)?;
        let start = src.pos();
        let present = pass_data(path, &mut src, &h, &d, &image)?;
        if present < d.data {
            return Err(truncated(path, &d, &image, start, present));
        }
        // Padding to the next block (may be missing after the last HDU).
        src.skip(path, d.data.div_ceil(BLOCK) * BLOCK - d.data)?;
        if let Some((dims, table)) = image {
            let img = ImageHdu {
                hdu,
                dims,
                compressed: table.is_some(),
                bunit: h.string("BUNIT"),
            };
            frames_before = frames_before.saturating_add(img.frames());
            images.push(img);
        }
    }
    Ok(images)
}
