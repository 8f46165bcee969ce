//! Tile-compressed images (binary tables with ZIMAGE = T): their compression keywords, the
//! sizes they give, and the heap descriptors of every tile, checked before CFITSIO decodes them
//! (a zero tile size or Rice block size divides by zero inside it).

use std::path::Path;

use super::cards::{bytes_per_sample, dims, mul, product, Header};
use super::source::Source;
use crate::error::{Error, Result};
use crate::io::checks::{compressed_size_error, MAX_EXPANSION};

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
pub(super) fn descriptor_columns(
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
pub(super) fn compressed_image(
    path: &Path,
    h: &Header,
    hdu: i32,
    rows: u64,
    stored: u64,
) -> Result<Vec<usize>> {
    let bad = |m: String| bad_hdu(path, hdu, m);
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
    let tile = tile_shape(path, h, hdu, &zdims, rows)?;
    check_parameters(path, h, hdu, &cmp)?;
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

/// An error about HDU `hdu` of the file at `path`.
fn bad_hdu(path: &Path, hdu: i32, message: String) -> Error {
    Error::input(path, format!("frame 0: HDU {hdu}: {message}"))
}

/// The tile shape (ZTILEn; by default rows of the image), checked against the table's
/// `rows`, one per tile of the image of dimensions `zdims`.
fn tile_shape(path: &Path, h: &Header, hdu: i32, zdims: &[usize], rows: u64) -> Result<Vec<usize>> {
    let mut tiles = 1u64;
    let mut tile = Vec::with_capacity(zdims.len());
    for (i, d) in zdims.iter().enumerate() {
        let key = format!("ZTILE{}", i + 1);
        let t = h
            .int(path, hdu, &key)?
            .unwrap_or(if i == 0 { *d as i64 } else { 1 });
        if t < 1 {
            return Err(bad_hdu(
                path,
                hdu,
                format!("{key} = {t}: a tile needs at least 1 pixel per axis"),
            ));
        }
        let t = t as u64;
        tiles = mul(tiles, (*d as u64).div_ceil(t)).unwrap_or(u64::MAX);
        tile.push(t.min(u64::from(u32::MAX)) as usize);
    }
    if tiles != rows {
        return Err(bad_hdu(
            path,
            hdu,
            format!("ZNAXISn and ZTILEn give {tiles} tiles, the table has {rows} rows"),
        ));
    }
    Ok(tile)
}

/// Check the compression parameters (ZVALn) of the compression `cmp`: Rice's block size
/// and bytes per pixel, HCOMPRESS's scale.
fn check_parameters(path: &Path, h: &Header, hdu: i32, cmp: &str) -> Result<()> {
    let bad = |m: String| bad_hdu(path, hdu, m);
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
    Ok(())
}

/// Check every heap descriptor of a binary table (read from `src`, which is at the start
/// of the table) against the heap; leaves `src` after the table rows.
pub(super) fn check_descriptors(
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
}
