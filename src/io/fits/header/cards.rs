//! The cards of one FITS header: read block by block up to END, values parsed as integers,
//! reals, strings and logicals, and sizes computed from them with checked arithmetic.

use std::path::Path;

use super::source::Source;
use crate::error::{Error, Result};
use crate::io::checks::frame_error;

/// Bytes of a FITS block (headers and data are padded to whole blocks).
pub(super) const BLOCK: u64 = 2880;
/// Bytes of a header card.
const CARD: usize = 80;

/// The keywords of one header, first occurrence of each, values as written.
pub(super) struct Header {
    cards: Vec<(String, String)>,
}

impl Header {
    pub(super) fn raw(&self, key: &str) -> Option<&str> {
        self.cards
            .iter()
            .find(|(k, _)| k == key)
            .map(|(_, v)| v.as_str())
    }

    pub(super) fn int(&self, path: &Path, hdu: i32, key: &str) -> Result<Option<i64>> {
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

    pub(super) fn required_int(&self, path: &Path, hdu: i32, key: &str) -> Result<i64> {
        self.int(path, hdu, key)?.ok_or_else(|| {
            Error::input(
                path,
                format!("frame 0: HDU {hdu}: keyword {key} is missing"),
            )
        })
    }

    pub(super) fn real(&self, path: &Path, hdu: i32, key: &str) -> Result<Option<f64>> {
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

    pub(super) fn string(&self, key: &str) -> Option<String> {
        let v = self.raw(key)?.trim();
        let s = v.strip_prefix('\'')?;
        let end = s.rfind('\'').unwrap_or(s.len());
        Some(s[..end].replace("''", "'").trim_end().to_string())
    }

    pub(super) fn logical(&self, key: &str) -> bool {
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
pub(super) fn read_header(
    path: &Path,
    src: &mut Source,
    hdu: i32,
    frame: usize,
) -> Result<Option<Header>> {
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

pub(super) fn mul(a: u64, b: u64) -> Option<u64> {
    a.checked_mul(b)
}

/// Product of sizes with overflow reported as an error naming `what`.
pub(super) fn product(path: &Path, hdu: i32, what: &str, dims: &[usize]) -> Result<u64> {
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
pub(super) fn dims(path: &Path, h: &Header, hdu: i32, prefix: &str, n: i64) -> Result<Vec<usize>> {
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

pub(super) fn bytes_per_sample(path: &Path, hdu: i32, key: &str, bitpix: i64) -> Result<u64> {
    match bitpix {
        8 | 16 | 32 | 64 | -32 | -64 => Ok(bitpix.unsigned_abs() / 8),
        b => Err(Error::input(
            path,
            format!("frame 0: HDU {hdu}: {key} = {b} is not one of 8, 16, 32, 64, -32, -64"),
        )),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn card_values() {
        assert_eq!(card_value(" 'RICE_1  '  / comment"), "'RICE_1  '");
        assert_eq!(card_value("   16 / blocksize"), "16");
        assert_eq!(card_value(" 'it''s' / q"), "'it''s'");
    }
}
