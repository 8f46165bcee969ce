//! FITS headers parsed and checked in Rust before CFITSIO sees the file.
//!
//! CFITSIO trusts header values: a ZTILEn or Rice block size (ZVAL1) of 0 divides by zero
//! inside it (SIGFPE), and sizes such as NAXISn = 2^63-1 wrap around. So every HDU's header
//! is read here first, its mandatory keywords and the tile-compression keywords are
//! validated, every size is computed with checked arithmetic and compared with the bytes
//! the file holds (for `.fits.gz`, the decompressed bytes), and the heap descriptors of
//! tile-compressed images must point inside their heap. Only then is CFITSIO given the file,
//! and the shapes it reports are checked against these.

use std::fs::File;
use std::io::{BufReader, Read, Seek, SeekFrom};
use std::path::Path;

use super::{compressed_size_error, frame_error, MAX_EXPANSION};
use crate::error::{Error, Result};

const BLOCK: u64 = 2880;
const CARD: usize = 80;
/// Largest NAXIS allowed by the FITS standard.
const MAX_NAXIS: i64 = 999;
/// Largest ZNAXIS CFITSIO handles (`MAX_COMPRESS_DIM`).
const MAX_ZNAXIS: i64 = 6;
/// Compression algorithms CFITSIO decodes.
const ZCMPTYPES: [&str; 7] = [
    "RICE_1",
    "RICE_ONE",
    "GZIP_1",
    "GZIP_2",
    "PLIO_1",
    "HCOMPRESS_1",
    "NOCOMPRESS",
];

/// One image HDU (plain or tile-compressed) with at least one 2-D frame.
#[derive(Clone, Debug, PartialEq, Eq)]
pub(crate) struct ImageHdu {
    /// 1-based HDU number.
    pub hdu: i32,
    /// Dimensions as CFITSIO reports them (NAXISn or ZNAXISn), NAXIS1 first.
    pub dims: Vec<usize>,
    /// Tile-compressed (a BINTABLE with ZIMAGE = T).
    pub compressed: bool,
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

/// The logical bytes of a FITS file: the file itself, or the stream of a `.fits.gz`.
enum Source {
    Plain {
        file: BufReader<File>,
        pos: u64,
        len: u64,
    },
    /// `bound` caps the decompressed length: deflate expands at most 1032-fold.
    Gzip {
        dec: Box<flate2::read::MultiGzDecoder<BufReader<File>>>,
        pos: u64,
        bound: u64,
    },
}

impl Source {
    fn open(path: &Path) -> Result<Source> {
        let file = File::open(path).map_err(|e| Error::io(path, e))?;
        let len = file.metadata().map_err(|e| Error::io(path, e))?.len();
        let mut file = BufReader::new(file);
        let mut magic = [0u8; 2];
        let n = file.read(&mut magic).map_err(|e| Error::io(path, e))?;
        file.seek(SeekFrom::Start(0))
            .map_err(|e| Error::io(path, e))?;
        Ok(if n == 2 && magic == [0x1f, 0x8b] {
            Source::Gzip {
                dec: Box::new(flate2::read::MultiGzDecoder::new(file)),
                pos: 0,
                bound: len.saturating_mul(MAX_EXPANSION),
            }
        } else {
            Source::Plain { file, pos: 0, len }
        })
    }

    fn pos(&self) -> u64 {
        match self {
            Source::Plain { pos, .. } | Source::Gzip { pos, .. } => *pos,
        }
    }

    /// Read up to `buf.len()` bytes; returns how many (fewer only at the end of the data).
    fn fill(&mut self, path: &Path, buf: &mut [u8]) -> Result<usize> {
        let mut n = 0;
        while n < buf.len() {
            let r = match self {
                Source::Plain { file, .. } => file.read(&mut buf[n..]),
                Source::Gzip { dec, .. } => dec.read(&mut buf[n..]),
            };
            match r {
                Ok(0) => break,
                Ok(k) => n += k,
                Err(e) if e.kind() == std::io::ErrorKind::Interrupted => {}
                Err(e) if matches!(self, Source::Gzip { .. }) => {
                    return Err(Error::input(
                        path,
                        format!("frame 0: cannot decompress the gzip stream: {e}"),
                    ))
                }
                Err(e) => return Err(Error::io(path, e)),
            }
        }
        match self {
            Source::Plain { pos, .. } | Source::Gzip { pos, .. } => *pos += n as u64,
        }
        Ok(n)
    }

    /// Skip `n` bytes; returns how many were there (fewer only at the end of the data).
    fn skip(&mut self, path: &Path, n: u64) -> Result<u64> {
        match self {
            Source::Plain { file, pos, len } => {
                let k = n.min(len.saturating_sub(*pos));
                file.seek_relative(k as i64)
                    .map_err(|e| Error::io(path, e))?;
                *pos += k;
                Ok(k)
            }
            Source::Gzip { .. } => {
                let mut buf = [0u8; 8192];
                let mut done = 0;
                while done < n {
                    let want = (n - done).min(buf.len() as u64) as usize;
                    let k = self.fill(path, &mut buf[..want])?;
                    if k == 0 {
                        break;
                    }
                    done += k as u64;
                }
                Ok(done)
            }
        }
    }

    /// Bytes left in a plain file; for a gzip stream, an upper bound.
    fn remaining(&self) -> u64 {
        match self {
            Source::Plain { pos, len, .. } => len.saturating_sub(*pos),
            Source::Gzip { pos, bound, .. } => bound.saturating_sub(*pos),
        }
    }
}

/// The keywords of one header, first occurrence of each, values as written.
struct Header {
    cards: Vec<(String, String)>,
}

impl Header {
    fn raw(&self, key: &str) -> Option<&str> {
        self.cards
            .iter()
            .find(|(k, _)| k == key)
            .map(|(_, v)| v.as_str())
    }

    fn int(&self, path: &Path, hdu: i32, key: &str) -> Result<Option<i64>> {
        let Some(v) = self.raw(key) else {
            return Ok(None);
        };
        let t = v.trim();
        let t = t.strip_prefix('+').unwrap_or(t);
        t.parse::<i64>().map(Some).map_err(|_| {
            Error::input(
                path,
                format!("frame 0: HDU {hdu}: {key} = {t:?} is not an integer"),
            )
        })
    }

    fn required_int(&self, path: &Path, hdu: i32, key: &str) -> Result<i64> {
        self.int(path, hdu, key)?.ok_or_else(|| {
            Error::input(
                path,
                format!("frame 0: HDU {hdu}: keyword {key} is missing"),
            )
        })
    }

    fn real(&self, path: &Path, hdu: i32, key: &str) -> Result<Option<f64>> {
        let Some(v) = self.raw(key) else {
            return Ok(None);
        };
        let t = v.trim().replace(['D', 'd'], "E");
        match t.parse::<f64>() {
            Ok(x) if x.is_finite() => Ok(Some(x)),
            _ => Err(Error::input(
                path,
                format!(
                    "frame 0: HDU {hdu}: {key} = {:?} is not a finite number",
                    v.trim()
                ),
            )),
        }
    }

    fn string(&self, key: &str) -> Option<String> {
        let v = self.raw(key)?.trim();
        let s = v.strip_prefix('\'')?;
        let end = s.rfind('\'').unwrap_or(s.len());
        Some(s[..end].replace("''", "'").trim_end().to_string())
    }

    fn logical(&self, key: &str) -> bool {
        self.raw(key).map(str::trim) == Some("T")
    }
}

/// The value part of a card: a quoted string up to its closing quote, else up to `/`.
fn card_value(text: &str) -> String {
    let t = text.trim_start();
    if let Some(s) = t.strip_prefix('\'') {
        let mut out = String::from("'");
        let mut chars = s.chars().peekable();
        while let Some(c) = chars.next() {
            out.push(c);
            if c == '\'' {
                if chars.peek() == Some(&'\'') {
                    out.push(chars.next().expect("peeked"));
                } else {
                    break;
                }
            }
        }
        out
    } else {
        t.split('/').next().unwrap_or("").trim().to_string()
    }
}

/// Read one header (blocks up to the END card). None at the end of the data: no bytes,
/// less than a block, or a block of only NULs or spaces after the last HDU (CFITSIO
/// ignores these too). Any other block after the last HDU must be an extension header.
fn read_header(path: &Path, src: &mut Source, hdu: i32, frame: usize) -> Result<Option<Header>> {
    let mut cards = Vec::new();
    let mut block = [0u8; BLOCK as usize];
    let mut first_block = true;
    loop {
        let n = src.fill(path, &mut block)?;
        if first_block && hdu > 1 {
            if n < block.len() || block.iter().all(|b| *b == 0 || *b == b' ') {
                return Ok(None);
            }
            if !block.starts_with(b"XTENSION= ") {
                return Err(frame_error(
                    path,
                    frame,
                    format!(
                        "the bytes after HDU {} are not an extension header (no XTENSION card)",
                        hdu - 1
                    ),
                ));
            }
        }
        if n < block.len() {
            return Err(frame_error(
                path,
                frame,
                format!("file truncated in the header of HDU {hdu} (no END card)"),
            ));
        }
        for card in block.chunks_exact(CARD) {
            let key = String::from_utf8_lossy(&card[..8]).trim_end().to_string();
            if key == "END" {
                return Ok(Some(Header { cards }));
            }
            if &card[8..10] == b"= " {
                let value = card_value(&String::from_utf8_lossy(&card[10..]));
                cards.push((key, value));
            }
        }
        first_block = false;
    }
}

fn mul(a: u64, b: u64) -> Option<u64> {
    a.checked_mul(b)
}

/// Product of sizes with overflow reported as an error naming `what`.
fn product(path: &Path, hdu: i32, what: &str, dims: &[usize]) -> Result<u64> {
    dims.iter()
        .try_fold(1u64, |p, d| mul(p, *d as u64))
        .ok_or_else(|| {
            Error::input(
                path,
                format!("frame 0: HDU {hdu}: {what} {dims:?} overflow 64 bits"),
            )
        })
}

/// Dimensions NAXIS1..NAXISn (or ZNAXIS1..) as non-negative sizes.
fn dims(path: &Path, h: &Header, hdu: i32, prefix: &str, n: i64) -> Result<Vec<usize>> {
    (1..=n)
        .map(|i| {
            let key = format!("{prefix}{i}");
            let v = h.required_int(path, hdu, &key)?;
            usize::try_from(v).map_err(|_| {
                Error::input(path, format!("frame 0: HDU {hdu}: {key} = {v} is negative"))
            })
        })
        .collect()
}

fn bytes_per_sample(path: &Path, hdu: i32, key: &str, bitpix: i64) -> Result<u64> {
    match bitpix {
        8 | 16 | 32 | 64 | -32 | -64 => Ok(bitpix.unsigned_abs() / 8),
        b => Err(Error::input(
            path,
            format!("frame 0: HDU {hdu}: {key} = {b} is not one of 8, 16, 32, 64, -32, -64"),
        )),
    }
}

/// Size in bytes of one binary-table field of TFORM `form`, and for heap descriptors
/// (P, Q) the descriptor width and the size of one heap element.
fn tform(form: &str) -> Option<(u64, Option<(u64, u64)>)> {
    let form = form.trim();
    let digits = form.chars().take_while(|c| c.is_ascii_digit()).count();
    let repeat: u64 = if digits == 0 {
        1
    } else {
        form[..digits].parse().ok()?
    };
    let mut rest = form[digits..].chars();
    let t = rest.next()?.to_ascii_uppercase();
    let elem = |c: char| -> Option<u64> {
        Some(match c.to_ascii_uppercase() {
            'L' | 'B' | 'A' | 'X' => 1,
            'I' => 2,
            'J' | 'E' => 4,
            'K' | 'D' | 'C' => 8,
            'M' => 16,
            _ => return None,
        })
    };
    match t {
        'P' | 'Q' => {
            let width = if t == 'P' { 8 } else { 16 };
            let e = elem(rest.next()?)?;
            Some((repeat.min(1) * width, Some((width, e))))
        }
        'X' => Some((repeat.div_ceil(8), None)),
        c => Some((mul(repeat, elem(c)?)?, None)),
    }
}

/// The heap descriptor columns of a binary table: (byte offset in a row, width, element size).
fn descriptor_columns(
    path: &Path,
    h: &Header,
    hdu: i32,
    row_bytes: u64,
) -> Result<Vec<(u64, u64, u64)>> {
    let fields = h.required_int(path, hdu, "TFIELDS")?;
    if !(0..=999).contains(&fields) {
        return Err(Error::input(
            path,
            format!("frame 0: HDU {hdu}: TFIELDS = {fields} is outside 0..999"),
        ));
    }
    let mut offset = 0u64;
    let mut out = Vec::new();
    for i in 1..=fields {
        let key = format!("TFORM{i}");
        let form = h.string(&key).unwrap_or_default();
        let Some((size, desc)) = tform(&form) else {
            return Err(Error::input(
                path,
                format!("frame 0: HDU {hdu}: {key} = {form:?} is not a binary-table format"),
            ));
        };
        if let Some((width, elem)) = desc {
            if size > 0 {
                out.push((offset, width, elem));
            }
        }
        offset = offset.saturating_add(size);
    }
    if offset != row_bytes {
        return Err(Error::input(
            path,
            format!("frame 0: HDU {hdu}: the TFORMn fields add up to {offset} bytes per row, NAXIS1 says {row_bytes}"),
        ));
    }
    Ok(out)
}

/// Check the keywords of a tile-compressed image and return its dimensions (ZNAXISn).
fn compressed_image(
    path: &Path,
    h: &Header,
    hdu: i32,
    rows: u64,
    stored: u64,
) -> Result<Vec<usize>> {
    let bad = |m: String| Error::input(path, format!("frame 0: HDU {hdu}: {m}"));
    let cmp = h
        .string("ZCMPTYPE")
        .ok_or_else(|| bad("keyword ZCMPTYPE is missing".into()))?;
    if !ZCMPTYPES.contains(&cmp.as_str()) {
        return Err(bad(format!(
            "ZCMPTYPE = {cmp:?} is not a supported compression ({})",
            ZCMPTYPES.join(", ")
        )));
    }
    let zbitpix = h.required_int(path, hdu, "ZBITPIX")?;
    let width = bytes_per_sample(path, hdu, "ZBITPIX", zbitpix)?;
    let zn = h.required_int(path, hdu, "ZNAXIS")?;
    if !(1..=MAX_ZNAXIS).contains(&zn) {
        return Err(bad(format!("ZNAXIS = {zn} is outside 1..{MAX_ZNAXIS}")));
    }
    let zdims = dims(path, h, hdu, "ZNAXIS", zn)?;
    if let Some(i) = zdims.iter().position(|d| *d == 0) {
        return Err(bad(format!(
            "ZNAXIS{} = 0: an empty compressed image",
            i + 1
        )));
    }
    let mut tiles = 1u64;
    let mut tile = Vec::with_capacity(zdims.len());
    for (i, d) in zdims.iter().enumerate() {
        let key = format!("ZTILE{}", i + 1);
        let t = h
            .int(path, hdu, &key)?
            .unwrap_or(if i == 0 { *d as i64 } else { 1 });
        if t < 1 {
            return Err(bad(format!(
                "{key} = {t}: a tile needs at least 1 pixel per axis"
            )));
        }
        let t = t as u64;
        tiles = mul(tiles, (*d as u64).div_ceil(t)).unwrap_or(u64::MAX);
        tile.push(t.min(u64::from(u32::MAX)) as usize);
    }
    if tiles != rows {
        return Err(bad(format!(
            "ZNAXISn and ZTILEn give {tiles} tiles, the table has {rows} rows"
        )));
    }
    if cmp.starts_with("RICE") {
        let block = h.int(path, hdu, "ZVAL1")?;
        if !matches!(block, Some(16 | 32)) {
            return Err(bad(format!(
                "Rice block size ZVAL1 = {} (must be 16 or 32)",
                block.map_or("missing".into(), |b| b.to_string())
            )));
        }
        if let Some(b) = h.int(path, hdu, "ZVAL2")? {
            if !matches!(b, 1 | 2 | 4 | 8) {
                return Err(bad(format!(
                    "Rice bytes per pixel ZVAL2 = {b} (must be 1, 2, 4 or 8)"
                )));
            }
        }
    }
    if cmp == "HCOMPRESS_1" {
        if let Some(s) = h.real(path, hdu, "ZVAL1")? {
            if s < 0.0 {
                return Err(bad(format!("HCOMPRESS scale ZVAL1 = {s} is negative")));
            }
        }
    }
    let image = mul(product(path, hdu, "ZNAXISn", &zdims)?, width);
    let tile_bytes = mul(product(path, hdu, "ZTILEn", &tile)?, width);
    let limit = mul(stored, MAX_EXPANSION).unwrap_or(u64::MAX);
    for (what, bytes) in [("image", image), ("tile", tile_bytes)] {
        match bytes {
            Some(b) if b <= limit => {}
            _ => {
                return Err(compressed_size_error(
                    path,
                    0,
                    &format!("HDU {hdu}: the compressed {what}"),
                    bytes,
                    stored,
                ))
            }
        }
    }
    Ok(zdims)
}

/// Check every heap descriptor of a binary table (read from `src`, which is at the start
/// of the table) against the heap; leaves `src` after the table rows.
fn check_descriptors(
    path: &Path,
    src: &mut Source,
    hdu: i32,
    columns: &[(u64, u64, u64)],
    (row_bytes, rows): (u64, u64),
    heap: (u64, u64),
) -> Result<u64> {
    let mut row = vec![0u8; row_bytes as usize];
    let (heap_start, heap_end) = heap;
    for r in 0..rows {
        let n = src.fill(path, &mut row)?;
        if n < row.len() {
            return Ok(r * row_bytes + n as u64);
        }
        for &(off, width, elem) in columns {
            let d = &row[off as usize..(off + width) as usize];
            let (count, start) = if width == 8 {
                let c = i32::from_be_bytes(d[..4].try_into().expect("4 bytes"));
                let o = i32::from_be_bytes(d[4..].try_into().expect("4 bytes"));
                (i64::from(c), i64::from(o))
            } else {
                let c = i64::from_be_bytes(d[..8].try_into().expect("8 bytes"));
                let o = i64::from_be_bytes(d[8..].try_into().expect("8 bytes"));
                (c, o)
            };
            let end = u64::try_from(count)
                .ok()
                .zip(u64::try_from(start).ok())
                .and_then(|(c, s)| heap_start.checked_add(s)?.checked_add(c.checked_mul(elem)?));
            if end.is_none_or(|e| e > heap_end) {
                return Err(Error::input(
                    path,
                    format!("frame 0: HDU {hdu}: tile {} points outside the heap ({count} elements at heap offset {start})", r + 1),
                ));
            }
        }
    }
    Ok(rows * row_bytes)
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
            };
            frames_before = frames_before.saturating_add(img.frames());
            images.push(img);
        }
    }
    Ok(images)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn tform_sizes() {
        assert_eq!(tform("1PB(120)"), Some((8, Some((8, 1)))));
        assert_eq!(tform("1QI"), Some((16, Some((16, 2)))));
        assert_eq!(tform("2E"), Some((8, None)));
        assert_eq!(tform("9X"), Some((2, None)));
        assert_eq!(tform("Z"), None);
    }

    #[test]
    fn card_values() {
        assert_eq!(card_value(" 'RICE_1  '  / comment"), "'RICE_1  '");
        assert_eq!(card_value("   16 / blocksize"), "16");
        assert_eq!(card_value(" 'it''s' / q"), "'it''s'");
    }
}
