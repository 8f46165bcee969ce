//! Fixtures written by astropy, tifffile and OpenEXR (scripts/make_interop_fixtures.py)
//! read to exactly the reference values stored beside them.

use std::path::{Path, PathBuf};

use detnoise::io::FrameStack;

const FRAMES: usize = 4;
const ROWS: usize = 5;
const COLS: usize = 7;

fn dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/fixtures/interop")
}

fn reference_u16() -> Vec<f64> {
    let b = std::fs::read(dir().join("reference-u16.bin")).unwrap();
    b.chunks_exact(2)
        .map(|c| u16::from_le_bytes([c[0], c[1]]) as f64)
        .collect()
}

fn reference_half() -> Vec<f64> {
    let b = std::fs::read(dir().join("reference-half.bin")).unwrap();
    b.chunks_exact(4)
        .map(|c| f32::from_le_bytes([c[0], c[1], c[2], c[3]]) as f64)
        .collect()
}

fn read_all(paths: &[PathBuf]) -> (FrameStack, Vec<f64>) {
    let stack = FrameStack::open(paths).unwrap_or_else(|e| panic!("{paths:?}: {e}"));
    let mut all = Vec::new();
    let mut buf = vec![0.0; stack.pixels()];
    let mut r = stack.reader();
    while r.next_frame(&mut buf).unwrap().is_some() {
        all.extend_from_slice(&buf);
    }
    (stack, all)
}

fn check(name: &str, expected: &[f64]) {
    let (stack, values) = read_all(&[dir().join(name)]);
    assert_eq!(stack.shape, (ROWS, COLS), "{name}: shape (rows, cols)");
    assert_eq!(stack.frames, FRAMES, "{name}: frame count");
    assert_eq!(values, expected, "{name}: values");
}

#[test]
fn astropy_fits_variants_read_identically() {
    let r = reference_u16();
    for name in [
        "astropy-u16-bzero.fits",
        "astropy-f32.fits",
        "astropy-mef.fits",
        "astropy-rice.fits",
        "astropy-u16-bzero.fits.gz",
    ] {
        check(name, &r);
    }
    let (stack, _) = read_all(&[dir().join("astropy-u16-bzero.fits")]);
    assert_eq!(stack.sample_type, detnoise::io::SampleType::U16);
}

#[test]
fn tifffile_variants_read_identically() {
    let r = reference_u16();
    for name in [
        "tifffile-multipage.tif",
        "tifffile-lzw.tif",
        "tifffile-deflate.tif",
        "tifffile-bigtiff.tif",
        "tifffile-imagej.tif",
        "tifffile-imagej-one-ifd.tif",
        "tifffile-f32.tif",
        "tifffile-bigendian.tif",
    ] {
        check(name, &r);
    }
}

#[test]
fn openexr_variants_read_identically() {
    check("openexr-f32-layers.exr", &reference_u16());
    check("openexr-u32-layers.exr", &reference_u16());
    check("openexr-half-layers.exr", &reference_half());
    // One file per frame, given as a directory and as a glob.
    let (s, v) = read_all(&[dir().join("openexr-files")]);
    assert_eq!((s.frames, s.shape), (FRAMES, (ROWS, COLS)));
    assert_eq!(v, reference_u16());
    let (_, v) = read_all(&[dir().join("openexr-files/frame*.exr")]);
    assert_eq!(v, reference_u16());
}

#[test]
fn a_map_of_several_frames_is_refused_naming_their_count() {
    // Row-major order of the frames is checked above; a map is one image, and which of four
    // frames would be meant cannot be told.
    let e = detnoise::calib::Map::read(dir().join("astropy-mef.fits"), detnoise::calib::Unit::Adu)
        .unwrap_err()
        .to_string();
    assert!(e.contains("astropy-mef.fits: holds 4 frames of 5x7"), "{e}");
}
