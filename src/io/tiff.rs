//! TIFF and BigTIFF frames through the `tiff` crate: one frame per page (IFD), any
//! compression the crate decodes (LZW, Deflate, PackBits), and ImageJ stacks whose frames
//! follow the first page contiguously (`images=N` in ImageDescription, one IFD).
//!
//! The crate decodes pages of other shapes or RGB pages without complaint, so every page's
//! shape and channel count is checked here when the file is opened.

use std::fs::File;
use std::io::BufReader;
use std::os::unix::fs::FileExt;
use std::path::{Path, PathBuf};

use tiff::decoder::{Decoder, DecodingResult, Limits};
use tiff::tags::{ByteOrder, CompressionMethod, Tag};
use tiff::ColorType;

use super::checks::{compressed_size_error, frame_error, MAX_EXPANSION};
use super::format::SampleType;
use super::frame::{to_u16, widen, FileFrames};
use crate::error::{Error, Result};

type Dec = Decoder<BufReader<File>>;

/// Bytes of one value of TIFF field type `t` (1 for unknown types, which are skipped).
fn type_bytes(t: u16) -> u64 {
    match t {
        3 | 8 => 2,
        4 | 9 | 11 | 13 => 4,
        5 | 10 | 12 | 16 | 17 | 18 => 8,
        _ => 1,
    }
}

/// Walk the IFD chain before the decoder does: every IFD and every entry's values must lie
/// inside the file. The decoder sizes its tag value lists from the entries' counts, before
/// any of our checks could run, so a count of 2^32 would otherwise allocate 128 GiB.
fn check_ifds(path: &Path, f: &File, len: u64) -> Result<()> {
    let read = |at: u64, n: usize| -> Result<Vec<u8>> {
        let mut b = vec![0u8; n];
        f.read_exact_at(&mut b, at)
            .map_err(|_| frame_error(path, 0, format!("file truncated or corrupt: {n} bytes at offset {at} are beyond its {len} bytes")))?;
        Ok(b)
    };
    let head = read(0, 16.min(len as usize))?;
    let big = head.starts_with(b"MM");
    let num = |b: &[u8]| -> u64 {
        let push = |v: u64, x: &u8| (v << 8) | u64::from(*x);
        if big {
            b.iter().fold(0, push)
        } else {
            b.iter().rev().fold(0, push)
        }
    };
    let bigtiff = head.len() >= 4 && num(&head[2..4]) == 43;
    let (count_w, entry_w, off_w) = if bigtiff {
        (8u64, 20u64, 8u64)
    } else {
        (2, 12, 4)
    };
    let first_at = if bigtiff { 8 } else { 4 };
    let mut ifd = num(read(first_at, off_w as usize)?.as_slice());
    let mut seen = std::collections::HashSet::new();
    let mut page = 0;
    while ifd != 0 {
        if !seen.insert(ifd) {
            return Err(frame_error(
                path,
                page,
                format!("IFD chain loops back to offset {ifd}"),
            ));
        }
        let n = num(&read(ifd, count_w as usize)?);
        let bytes = n
            .checked_mul(entry_w)
            .and_then(|b| b.checked_add(count_w + off_w))
            .filter(|b| ifd.checked_add(*b).is_some_and(|end| end <= len))
            .ok_or_else(|| {
                frame_error(
                    path,
                    page,
                    format!(
                        "IFD at offset {ifd} claims {n} entries, beyond the file's {len} bytes"
                    ),
                )
            })?;
        let table = read(ifd + count_w, bytes as usize - count_w as usize)?;
        for e in table[..(n * entry_w) as usize].chunks_exact(entry_w as usize) {
            let (tag, typ) = (num(&e[..2]), num(&e[2..4]) as u16);
            let count = num(&e[4..4 + off_w as usize]);
            let value_bytes = count.checked_mul(type_bytes(typ));
            let fits = match value_bytes {
                Some(b) if b <= off_w => true,
                Some(b) => {
                    let at = num(&e[4 + off_w as usize..]);
                    at.checked_add(b).is_some_and(|end| end <= len)
                }
                None => false,
            };
            if !fits {
                return Err(frame_error(
                    path,
                    page,
                    format!("IFD entry of tag {tag}: {count} values of type {typ} lie beyond the file's {len} bytes"),
                ));
            }
        }
        ifd = num(&table[(n * entry_w) as usize..]);
        page += 1;
    }
    Ok(())
}

fn open_decoder(path: &Path) -> Result<Dec> {
    let f = File::open(path).map_err(|e| Error::io(path, e))?;
    let len = f.metadata().map_err(|e| Error::io(path, e))?.len();
    check_ifds(path, &f, len)?;
    let len = len as usize;
    // The decoder sizes its buffers (and tag value lists) from header fields: cap them by
    // what the file can hold, at most MAX_EXPANSION times its bytes when decoded.
    let mut limits = Limits::default();
    limits.decoding_buffer_size = len.saturating_mul(MAX_EXPANSION as usize).max(1 << 20);
    limits.intermediate_buffer_size = len.max(1 << 20);
    limits.ifd_value_size = len.max(1 << 10);
    Decoder::new(BufReader::new(f))
        .map(|d| d.with_limits(limits))
        .map_err(|e| frame_error(path, 0, format!("cannot decode TIFF header: {e}")))
}

/// Shape, channel check and sample type of the decoder's current page.
fn page_info(path: &Path, k: usize, dec: &mut Dec) -> Result<((usize, usize), SampleType)> {
    let (w, h) = dec.dimensions().map_err(|e| frame_error(path, k, e))?;
    let ct = dec.colortype().map_err(|e| frame_error(path, k, e))?;
    let ColorType::Gray(bits) = ct else {
        return Err(frame_error(
            path,
            k,
            format!("colour type {ct:?}: only single-channel frames are supported"),
        ));
    };
    let format = dec
        .find_tag_unsigned::<u16>(Tag::SampleFormat)
        .map_err(|e| frame_error(path, k, e))?
        .unwrap_or(1);
    let t = match (format, bits) {
        (1, 8) => SampleType::U8,
        (2, 8) => SampleType::I8,
        (1, 16) => SampleType::U16,
        (2, 16) => SampleType::I16,
        (1, 32) => SampleType::U32,
        (2, 32) => SampleType::I32,
        (2, 64) => SampleType::I64,
        (3, 16) => SampleType::F16,
        (3, 32) => SampleType::F32,
        (3, 64) => SampleType::F64,
        (f, b) => {
            return Err(frame_error(
                path,
                k,
                format!("unsupported sample type ({b} bits, SampleFormat {f})"),
            ))
        }
    };
    let shape = (h as usize, w as usize);
    check_page_bytes(path, k, dec, shape, t)?;
    Ok((shape, t))
}

/// A tag's values, or an error naming the page.
fn tag_vec(path: &Path, k: usize, dec: &mut Dec, tag: Tag) -> Result<Option<Vec<u64>>> {
    dec.find_tag_unsigned_vec::<u64>(tag)
        .map_err(|e| frame_error(path, k, format!("tag {tag:?}: {e}")))
}

/// The page's strips (or tiles) must lie inside the file and hold the decoded frame: all of
/// it when uncompressed, at most [`MAX_EXPANSION`] times their size when compressed. Checked
/// before anything is decoded or allocated from the header's dimensions.
fn check_page_bytes(
    path: &Path,
    k: usize,
    dec: &mut Dec,
    (rows, cols): (usize, usize),
    t: SampleType,
) -> Result<()> {
    let len = std::fs::metadata(path)
        .map_err(|e| Error::io(path, e))?
        .len();
    let tiled = tag_vec(path, k, dec, Tag::TileOffsets)?.is_some();
    let (offsets_tag, counts_tag) = if tiled {
        (Tag::TileOffsets, Tag::TileByteCounts)
    } else {
        (Tag::StripOffsets, Tag::StripByteCounts)
    };
    let offsets = tag_vec(path, k, dec, offsets_tag)?.unwrap_or_default();
    let counts = tag_vec(path, k, dec, counts_tag)?.unwrap_or_default();
    if offsets.is_empty() || offsets.len() != counts.len() {
        return Err(frame_error(
            path,
            k,
            format!(
                "{} {offsets_tag:?} and {} {counts_tag:?}: the page's data cannot be located",
                offsets.len(),
                counts.len()
            ),
        ));
    }
    let mut stored = 0u64;
    for (i, (o, c)) in offsets.iter().zip(&counts).enumerate() {
        if o.checked_add(*c).is_none_or(|end| end > len) {
            return Err(frame_error(
                path,
                k,
                format!("file truncated or corrupt: {offsets_tag:?}[{i}] = {o} with {c} bytes ends beyond the file's {len} bytes"),
            ));
        }
        stored = stored.saturating_add(*c);
    }
    let decoded = (rows as u64)
        .checked_mul(cols as u64)
        .and_then(|p| p.checked_mul(bytes_of(t) as u64));
    let compression = dec
        .find_tag_unsigned::<u16>(Tag::Compression)
        .map_err(|e| frame_error(path, k, format!("tag Compression: {e}")))?
        .unwrap_or(1);
    if compression == CompressionMethod::None.to_u16() {
        // Tiles are padded to whole tiles, strips hold whole rows: at least the frame.
        if decoded.is_none_or(|d| d > stored) {
            return Err(frame_error(
                path,
                k,
                format!(
                    "file truncated or corrupt: the page's {} bytes of uncompressed data cannot hold a frame of {rows}x{cols} {t:?} samples",
                    stored
                ),
            ));
        }
    } else if decoded.is_none_or(|d| d > stored.saturating_mul(MAX_EXPANSION)) {
        return Err(compressed_size_error(
            path,
            k,
            &format!("the {rows}x{cols} page"),
            decoded,
            stored,
        ));
    }
    Ok(())
}

/// ImageJ frame count from the first page's ImageDescription (`images=N`), if any.
fn imagej_images(dec: &mut Dec) -> Option<usize> {
    let desc = dec.get_tag_ascii_string(Tag::ImageDescription).ok()?;
    if !desc.starts_with("ImageJ=") {
        return None;
    }
    desc.lines()
        .find_map(|l| l.strip_prefix("images="))
        .and_then(|v| v.trim().parse().ok())
}

/// Contiguous frames after the first page of an ImageJ stack with a single IFD.
#[derive(Clone, Copy, Debug)]
struct Contiguous {
    offset: u64,
    big_endian: bool,
}

fn bytes_of(t: SampleType) -> usize {
    match t {
        SampleType::U8 | SampleType::I8 => 1,
        SampleType::U16 | SampleType::I16 | SampleType::F16 => 2,
        SampleType::U32 | SampleType::I32 | SampleType::F32 | SampleType::Scaled => 4,
        SampleType::I64 | SampleType::F64 => 8,
    }
}

struct Scan {
    frames: usize,
    shape: (usize, usize),
    sample_type: SampleType,
    contiguous: Option<Contiguous>,
}

/// Frames, shape and sample type of a TIFF file: one frame per page (each page's header
/// checked), or the frames of an ImageJ stack stored contiguously after its single page.
fn scan_pages(path: &Path) -> Result<Scan> {
    let mut dec = open_decoder(path)?;
    let (shape, sample_type) = page_info(path, 0, &mut dec)?;
    let imagej = imagej_images(&mut dec);
    let pages = count_pages(path, &mut dec, shape, sample_type)?;
    let mut contiguous = None;
    let mut frames = pages;
    if let Some(n) = imagej.filter(|&n| n > pages) {
        if pages != 1 {
            return Err(frame_error(
                path,
                pages,
                format!("ImageJ description says {n} images but file has {pages} pages"),
            ));
        }
        contiguous = Some(imagej_frames(path, n, shape, sample_type)?);
        frames = n;
    }
    Ok(Scan {
        frames,
        shape,
        sample_type,
        contiguous,
    })
}

/// The pages of the file `dec` reads (at its first page), each of page 0's `shape` and
/// `sample_type`.
fn count_pages(
    path: &Path,
    dec: &mut Dec,
    shape: (usize, usize),
    sample_type: SampleType,
) -> Result<usize> {
    let mut pages = 1;
    while dec.more_images() {
        dec.next_image()
            .map_err(|e| frame_error(path, pages, format!("cannot read page header: {e}")))?;
        let (s, t) = page_info(path, pages, dec)?;
        if s != shape {
            return Err(frame_error(
                path,
                pages,
                format!(
                    "page shape {}x{} differs from {}x{} of page 0",
                    s.0, s.1, shape.0, shape.1
                ),
            ));
        }
        if t != sample_type {
            return Err(frame_error(
                path,
                pages,
                format!("sample type {t:?} differs from {sample_type:?} of page 0"),
            ));
        }
        pages += 1;
    }
    Ok(pages)
}

/// Where the `n` frames of an ImageJ stack with one page lie: uncompressed, one after the
/// other from the page's first strip, all within the file.
fn imagej_frames(
    path: &Path,
    n: usize,
    shape: (usize, usize),
    sample_type: SampleType,
) -> Result<Contiguous> {
    let mut dec = open_decoder(path)?;
    let compression = dec
        .find_tag_unsigned::<u16>(Tag::Compression)
        .ok()
        .flatten()
        .unwrap_or(1);
    if compression != CompressionMethod::None.to_u16() {
        return Err(frame_error(
            path,
            1,
            "compressed ImageJ stack with one IFD is not supported",
        ));
    }
    let offsets = dec
        .find_tag_unsigned_vec::<u64>(Tag::StripOffsets)
        .map_err(|e| frame_error(path, 0, e))?
        .ok_or_else(|| frame_error(path, 0, "no StripOffsets"))?;
    let offset = offsets[0];
    let frame_bytes = (shape.0 * shape.1 * bytes_of(sample_type)) as u64;
    let len = std::fs::metadata(path)
        .map_err(|e| Error::io(path, e))?
        .len();
    let needed = frame_bytes
        .checked_mul(n as u64)
        .and_then(|b| b.checked_add(offset));
    if needed.is_none_or(|b| b > len) {
        let complete = len.saturating_sub(offset) / frame_bytes.max(1);
        return Err(frame_error(
            path,
            complete as usize,
            format!(
                "file truncated: ImageJ stack of {n} frames needs {} bytes, file has {len}",
                needed.map_or("more than 2^64".to_string(), |b| b.to_string())
            ),
        ));
    }
    Ok(Contiguous {
        offset,
        big_endian: dec.byte_order() == ByteOrder::BigEndian,
    })
}

/// Frame count, shape and sample type of a TIFF file (walks every page header).
pub fn scan(path: &Path) -> Result<(usize, (usize, usize), SampleType)> {
    let s = scan_pages(path)?;
    Ok((s.frames, s.shape, s.sample_type))
}

/// The frames of one TIFF file, decoded page by page in order.
pub struct TiffFrames {
    path: PathBuf,
    dec: Dec,
    page: usize,
    sample_type: SampleType,
    contiguous: Option<(Contiguous, File)>,
    result: DecodingResult,
    bytes: Vec<u8>,
}

impl TiffFrames {
    /// Open `path`, whose shape and frame count were found by [`scan`].
    pub fn open(path: &Path, _shape: (usize, usize), _frames: usize) -> Result<TiffFrames> {
        let s = scan_pages(path)?;
        let contiguous = match s.contiguous {
            Some(c) => Some((c, File::open(path).map_err(|e| Error::io(path, e))?)),
            None => None,
        };
        Ok(TiffFrames {
            path: path.to_path_buf(),
            dec: open_decoder(path)?,
            page: 0,
            sample_type: s.sample_type,
            contiguous,
            result: DecodingResult::U8(Vec::new()),
            bytes: Vec::new(),
        })
    }

    fn read_contiguous(&mut self, k: usize, out: &mut [f64]) -> Result<()> {
        let (c, file) = self.contiguous.as_ref().expect("checked by caller");
        let width = bytes_of(self.sample_type);
        self.bytes.resize(out.len() * width, 0);
        file.read_exact_at(&mut self.bytes, c.offset + (k * out.len() * width) as u64)
            .map_err(|e| frame_error(&self.path, k, format!("cannot read data: {e}")))?;
        macro_rules! dec {
            ($t:ty, $n:expr) => {
                for (o, b) in out.iter_mut().zip(self.bytes.chunks_exact($n)) {
                    let a: [u8; $n] = b.try_into().expect("chunk size");
                    *o = if c.big_endian {
                        <$t>::from_be_bytes(a)
                    } else {
                        <$t>::from_le_bytes(a)
                    } as f64;
                }
            };
        }
        match self.sample_type {
            SampleType::U8 => dec!(u8, 1),
            SampleType::I8 => dec!(i8, 1),
            SampleType::U16 => dec!(u16, 2),
            SampleType::I16 => dec!(i16, 2),
            SampleType::U32 => dec!(u32, 4),
            SampleType::I32 => dec!(i32, 4),
            SampleType::I64 => dec!(i64, 8),
            SampleType::F32 => dec!(f32, 4),
            SampleType::F64 => dec!(f64, 8),
            t => {
                return Err(frame_error(
                    &self.path,
                    k,
                    format!("sample type {t:?} in a contiguous ImageJ stack"),
                ))
            }
        }
        Ok(())
    }
}

impl FileFrames for TiffFrames {
    fn may_be_out_of_range(&self, _k: usize) -> bool {
        matches!(
            self.sample_type,
            SampleType::F32 | SampleType::F64 | SampleType::I64
        )
    }

    fn read_frame(&mut self, k: usize, out: &mut [f64]) -> Result<()> {
        if self.contiguous.is_some() {
            return self.read_contiguous(k, out);
        }
        while self.page < k {
            self.dec
                .next_image()
                .map_err(|e| frame_error(&self.path, self.page + 1, e))?;
            self.page += 1;
        }
        let path = self.path.clone();
        self.dec
            .read_image_to_buffer(&mut self.result)
            .map_err(|e| frame_error(&path, k, format!("cannot decode page: {e}")))?;
        match &self.result {
            DecodingResult::U8(v) => widen(&path, k, v, out),
            DecodingResult::I8(v) => widen(&path, k, v, out),
            DecodingResult::U16(v) => widen(&path, k, v, out),
            DecodingResult::I16(v) => widen(&path, k, v, out),
            DecodingResult::U32(v) => widen(&path, k, v, out),
            DecodingResult::I32(v) => widen(&path, k, v, out),
            DecodingResult::F32(v) => widen(&path, k, v, out),
            DecodingResult::F64(v) => widen(&path, k, v, out),
            DecodingResult::F16(v) => widen(&path, k, v, out),
            DecodingResult::I64(v) => {
                let w: Vec<f64> = v.iter().map(|x| *x as f64).collect();
                widen(&path, k, &w, out)
            }
            DecodingResult::U64(v) => {
                let w: Vec<f64> = v.iter().map(|x| *x as f64).collect();
                widen(&path, k, &w, out)
            }
        }
    }
}

/// Write frames as a multi-page TIFF (one page per frame), atomically; `u16` stores
/// unsigned 16-bit integers (rounded, clamped), otherwise 32-bit floats.
pub fn write_pages(
    path: &Path,
    shape: (usize, usize),
    frames: usize,
    u16_samples: bool,
    next: &mut dyn FnMut() -> Vec<f64>,
) -> Result<()> {
    use tiff::encoder::{colortype, TiffEncoder};
    crate::output::write_atomic_with(path, |tmp| {
        let file = File::create(tmp).map_err(|e| Error::io(tmp, e))?;
        let mut enc = TiffEncoder::new(std::io::BufWriter::new(file))
            .map_err(|e| Error::io(tmp, std::io::Error::other(e)))?;
        let (w, h) = (shape.1 as u32, shape.0 as u32);
        for _ in 0..frames {
            let frame = next();
            let r = if u16_samples {
                let v: Vec<u16> = frame.iter().map(|x| to_u16(*x)).collect();
                enc.write_image::<colortype::Gray16>(w, h, &v)
            } else {
                let v: Vec<f32> = frame.iter().map(|x| *x as f32).collect();
                enc.write_image::<colortype::Gray32Float>(w, h, &v)
            };
            r.map_err(|e| Error::io(tmp, std::io::Error::other(e)))?;
        }
        Ok(())
    })
}
