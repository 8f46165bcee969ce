//! FITS headers parsed and checked in Rust before CFITSIO sees the file.
//!
//! CFITSIO trusts header values: a ZTILEn or Rice block size (ZVAL1) of 0 divides by zero
//! inside it (SIGFPE), and sizes such as NAXISn = 2^63-1 wrap around. So every HDU's header
//! is read here first, its mandatory keywords and the tile-compression keywords are
//! validated, every size is computed with checked arithmetic and compared with the bytes
//! the file holds (for `.fits.gz`, the decompressed bytes), and the heap descriptors of
//! tile-compressed images must point inside their heap. Only then is CFITSIO given the file,
//! and the shapes it reports are checked against these.

mod cards;
mod compressed;
mod hdu;
mod source;

pub(crate) use hdu::check;
