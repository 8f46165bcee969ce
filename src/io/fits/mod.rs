//! FITS: frames read through CFITSIO (`fitsio` crate, bundled library) after the headers are
//! checked in Rust (`header`), and cubes and images written with BUNIT and provenance keywords.

mod disk;
mod header;
mod read;
mod write;

pub(crate) use disk::create as create_file;
pub use read::{scan, FitsFrames};
pub use write::{key, provenance, write_cube, write_image, ImageData, KeyValue, Keyword};
