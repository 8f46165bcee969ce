//! The logical bytes of a FITS file for the header checks: the file itself, or the
//! decompressed stream of a `.fits.gz` (bounded by the largest expansion deflate allows).

use std::fs::File;
use std::io::{BufReader, Read, Seek, SeekFrom};
use std::path::Path;

use crate::error::{Error, Result};
use crate::io::checks::MAX_EXPANSION;

/// The logical bytes of a FITS file: the file itself, or the stream of a `.fits.gz`.
pub(super) enum Source {
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
    pub(super) fn open(path: &Path) -> Result<Source> {
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

    pub(super) fn pos(&self) -> u64 {
        match self {
            Source::Plain { pos, .. } | Source::Gzip { pos, .. } => *pos,
        }
    }

    /// Read up to `buf.len()` bytes; returns how many (fewer only at the end of the data).
    pub(super) fn fill(&mut self, path: &Path, buf: &mut [u8]) -> Result<usize> {
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
    pub(super) fn skip(&mut self, path: &Path, n: u64) -> Result<u64> {
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
    pub(super) fn remaining(&self) -> u64 {
        match self {
            Source::Plain { pos, len, .. } => len.saturating_sub(*pos),
            Source::Gzip { pos, bound, .. } => bound.saturating_sub(*pos),
        }
    }
}
