//! Seeds of the mutants: small stacks and maps cut from the bundled fixtures
//! (`data-synthetic/`, written with the crate's own FITS/TIFF/EXR writers, so the real work
//! per mutant is milliseconds) and the interoperability fixtures of `tests/fixtures/interop`
//! (astropy, tifffile and OpenEXR files) as they are.

use std::path::{Path, PathBuf};

use detnoise::io::FrameStack;

/// How a seed is used.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Role {
    /// A frame stack: `darks` and `emgain`.
    Stack,
    /// A read-noise map: `fit-pdf`.
    Map,
}

/// File format of a seed, which picks its mutator.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Kind {
    /// FITS.
    Fits,
    /// Gzip-compressed FITS.
    FitsGz,
    /// TIFF or BigTIFF.
    Tiff,
    /// OpenEXR.
    Exr,
}

/// One seed file.
pub struct Seed {
    /// Short name (used in mutant labels and file names).
    pub name: String,
    /// File extension.
    pub ext: &'static str,
    /// Format.
    pub kind: Kind,
    /// Entry points it goes through.
    pub role: Role,
    /// The bytes.
    pub bytes: Vec<u8>,
}

fn repo(rel: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join(rel)
}

/// The first `frames` frames of a bundled stack, cropped to `rows` x `cols`.
pub fn crop(rel: &str, frames: usize, (rows, cols): (usize, usize)) -> Vec<Vec<f64>> {
    let stack = FrameStack::open(&[repo(rel)]).expect("bundled stack opens");
    let mut buf = vec![0.0; stack.pixels()];
    let mut r = stack.reader();
    let mut out = Vec::new();
    while out.len() < frames
        && r.next_frame(&mut buf)
            .expect("bundled stack reads")
            .is_some()
    {
        out.push(
            (0..rows)
                .flat_map(|i| buf[i * stack.shape.1..i * stack.shape.1 + cols].to_vec())
                .collect(),
        );
    }
    out
}

/// Write `frames` with the crate's writer for `kind` (u16 or f32 samples); return the bytes.
pub fn write(
    dir: &Path,
    name: &str,
    kind: Kind,
    shape: (usize, usize),
    frames: &[Vec<f64>],
    u16: bool,
) -> Vec<u8> {
    let ext = match kind {
        Kind::Fits | Kind::FitsGz => "fits",
        Kind::Tiff => "tif",
        Kind::Exr => "exr",
    };
    let p = dir.join(format!("{name}.{ext}"));
    let mut it = frames.iter().cloned();
    let mut next = || it.next().expect("frame count");
    match kind {
        Kind::Fits | Kind::FitsGz => {
            detnoise::io::fits::write_cube(&p, shape, frames.len(), u16, &mut next, &[])
        }
        Kind::Tiff => detnoise::io::tiff::write_pages(&p, shape, frames.len(), u16, &mut next),
        Kind::Exr => detnoise::io::exr::write_layers(&p, shape, frames.len(), u16, &mut next),
    }
    .expect("fixture written");
    std::fs::read(&p).expect("fixture read back")
}

/// A one-layer uncompressed EXR map of f32 values (the crate writes compressed layers).
fn uncompressed_exr(dir: &Path, (rows, cols): (usize, usize), values: &[f64]) -> Vec<u8> {
    use exr::prelude::*;
    let p = dir.join("uncompressed.exr");
    let samples = FlatSamples::F32(values.iter().map(|v| *v as f32).collect());
    let channels = AnyChannels::sort(SmallVec::from_vec(vec![AnyChannel::new("Y", samples)]));
    let layer = Layer::new(
        Vec2(cols, rows),
        LayerAttributes::named("map"),
        Encoding::UNCOMPRESSED,
        channels,
    );
    Image::from_layer(layer)
        .write()
        .to_file(&p)
        .expect("EXR written");
    std::fs::read(&p).expect("EXR read back")
}

fn seed(name: &str, ext: &'static str, kind: Kind, role: Role, bytes: Vec<u8>) -> Seed {
    Seed {
        name: name.to_string(),
        ext,
        kind,
        role,
        bytes,
    }
}

fn interop(name: &str, ext: &'static str, kind: Kind) -> Seed {
    let bytes = std::fs::read(repo("tests/fixtures/interop").join(name)).expect("interop fixture");
    seed(name, ext, kind, Role::Stack, bytes)
}

/// Every seed, written into `dir` where needed.
pub fn seeds(dir: &Path) -> Vec<Seed> {
    // sCMOS darks: 8 frames of 16x16 (2048 samples, enough for the EM-gain start values
    // to run); EMCCD low light: 4 frames of 32x48; a 16x16 read-noise map (e-).
    let scmos = crop("data-synthetic/scmos-darks-64x64.fits", 8, (16, 16));
    let emccd = crop("data-synthetic/emccd-lowlight-32x48.fits", 4, (32, 48));
    let map = crop(
        "data-synthetic/scmos-darks-64x64.truth-rms_e.fits",
        1,
        (16, 16),
    );
    let (s, e) = ((16, 16), (32, 48));
    let mut out = vec![
        seed(
            "fits-u16",
            "fits",
            Kind::Fits,
            Role::Stack,
            write(dir, "a", Kind::Fits, s, &scmos, true),
        ),
        seed(
            "fits-f32",
            "fits",
            Kind::Fits,
            Role::Stack,
            write(dir, "b", Kind::Fits, s, &scmos, false),
        ),
        seed(
            "fits-emccd",
            "fits",
            Kind::Fits,
            Role::Stack,
            write(dir, "c", Kind::Fits, e, &emccd, true),
        ),
        seed(
            "tiff-u16",
            "tif",
            Kind::Tiff,
            Role::Stack,
            write(dir, "d", Kind::Tiff, s, &scmos, true),
        ),
        seed(
            "tiff-f32",
            "tif",
            Kind::Tiff,
            Role::Stack,
            write(dir, "e", Kind::Tiff, s, &scmos, false),
        ),
        seed(
            "exr-u32",
            "exr",
            Kind::Exr,
            Role::Stack,
            write(dir, "f", Kind::Exr, s, &scmos, true),
        ),
        seed(
            "exr-f32",
            "exr",
            Kind::Exr,
            Role::Stack,
            write(dir, "g", Kind::Exr, s, &scmos, false),
        ),
        seed(
            "fits-map",
            "fits",
            Kind::Fits,
            Role::Map,
            write(dir, "h", Kind::Fits, s, &map, false),
        ),
        seed(
            "tiff-map",
            "tif",
            Kind::Tiff,
            Role::Map,
            write(dir, "i", Kind::Tiff, s, &map, false),
        ),
        seed(
            "exr-map",
            "exr",
            Kind::Exr,
            Role::Map,
            write(dir, "j", Kind::Exr, s, &map, false),
        ),
        seed(
            "exr-map-raw",
            "exr",
            Kind::Exr,
            Role::Map,
            uncompressed_exr(dir, s, &map[0]),
        ),
    ];
    for (name, ext, kind) in [
        ("astropy-mef.fits", "fits", Kind::Fits),
        ("astropy-rice.fits", "fits", Kind::Fits),
        ("astropy-u16-bzero.fits.gz", "gz", Kind::FitsGz),
        ("tifffile-lzw.tif", "tif", Kind::Tiff),
        ("tifffile-deflate.tif", "tif", Kind::Tiff),
        ("tifffile-bigtiff.tif", "tif", Kind::Tiff),
        ("tifffile-bigendian.tif", "tif", Kind::Tiff),
        ("tifffile-imagej.tif", "tif", Kind::Tiff),
        ("tifffile-imagej-one-ifd.tif", "tif", Kind::Tiff),
        ("openexr-half-layers.exr", "exr", Kind::Exr),
        ("openexr-u32-layers.exr", "exr", Kind::Exr),
        ("openexr-files/frame0.exr", "exr", Kind::Exr),
    ] {
        out.push(interop(name, ext, kind));
    }
    out
}
