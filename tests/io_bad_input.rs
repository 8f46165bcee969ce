//! Bad input gives an error naming the file and frame, exit code 2, no panic and no output.

use std::path::{Path, PathBuf};

use assert_cmd::Command;
use detnoise::io::FrameStack;

fn fixture(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/fixtures/interop")
        .join(name)
}

/// Write `frames` (each rows*cols) as a float32 FITS cube.
fn write_fits(path: &Path, shape: (usize, usize), frames: &[Vec<f64>]) {
    let mut it = frames.iter().cloned();
    detnoise::io::fits::write_cube(
        path,
        shape,
        frames.len(),
        false,
        &mut || it.next().unwrap(),
        &[],
    )
    .unwrap();
}

fn frames(n: usize, shape: (usize, usize)) -> Vec<Vec<f64>> {
    (0..n)
        .map(|k| {
            (0..shape.0 * shape.1)
                .map(|i| (i * 7 + k * 13) as f64 % 17.0)
                .collect()
        })
        .collect()
}

/// Run `detnoise darks` on `inputs`; assert exit code 1 (bad data), that stderr names `needle`s, and
/// that the output directory holds no file.
fn darks_fails(inputs: &[PathBuf], needles: &[&str]) {
    let out = tempfile::tempdir().unwrap();
    let out_dir = out.path().join("maps");
    let assert = Command::cargo_bin("detnoise")
        .unwrap()
        .arg("darks")
        .args(inputs)
        .arg("--out")
        .arg(&out_dir)
        .assert()
        .code(1);
    let stderr = String::from_utf8_lossy(&assert.get_output().stderr).to_string();
    for n in needles {
        assert!(stderr.contains(n), "stderr {stderr:?} should contain {n:?}");
    }
    assert!(!stderr.contains("panicked"), "{stderr}");
    let left: Vec<_> = std::fs::read_dir(&out_dir)
        .map(|d| d.collect())
        .unwrap_or_default();
    assert!(left.is_empty(), "output left behind: {left:?}");
}

#[test]
fn truncated_fits_names_file_and_frame() {
    let d = tempfile::tempdir().unwrap();
    let p = d.path().join("cube.fits");
    write_fits(&p, (6, 9), &frames(5, (6, 9)));
    let bytes = std::fs::read(&p).unwrap();
    // Header (2880) + 2 whole frames (6*9*4 bytes each) + part of the third.
    std::fs::write(&p, &bytes[..2880 + 2 * 216 + 100]).unwrap();
    darks_fails(&[p], &["cube.fits", "frame 2", "truncated"]);
}

#[test]
fn corrupt_fits_header_is_an_input_error() {
    let d = tempfile::tempdir().unwrap();
    let p = d.path().join("bad.fits");
    let mut h = b"SIMPLE  = T".to_vec();
    h.resize(2880, b'#');
    std::fs::write(&p, h).unwrap();
    darks_fails(&[p], &["bad.fits", "frame 0"]);
}

#[test]
fn empty_and_unknown_files_are_input_errors() {
    let d = tempfile::tempdir().unwrap();
    let e = d.path().join("empty.fits");
    std::fs::write(&e, b"").unwrap();
    darks_fails(&[e], &["empty.fits", "empty file"]);
    let u = d.path().join("text.fits");
    std::fs::write(&u, b"hello world, not an image").unwrap();
    darks_fails(&[u], &["text.fits", "not a FITS, TIFF or OpenEXR"]);
}

#[test]
fn differing_shapes_name_the_second_file() {
    let d = tempfile::tempdir().unwrap();
    let a = d.path().join("a.fits");
    let b = d.path().join("b.fits");
    write_fits(&a, (6, 9), &frames(3, (6, 9)));
    write_fits(&b, (9, 6), &frames(3, (9, 6)));
    darks_fails(&[a, b], &["b.fits", "frame 0 (stack frame 3)", "differs"]);
}

#[test]
fn nan_sample_names_file_frame_and_pixel() {
    let d = tempfile::tempdir().unwrap();
    let p = d.path().join("nan.fits");
    let mut f = frames(4, (3, 5));
    f[2][5 + 4] = f64::NAN;
    write_fits(&p, (3, 5), &f);
    darks_fails(
        &[p],
        &["nan.fits", "frame 2", "non-finite", "row 1, column 4"],
    );
}

#[test]
fn inf_in_tiff_is_rejected() {
    let d = tempfile::tempdir().unwrap();
    let p = d.path().join("inf.tif");
    let mut f = frames(3, (4, 4));
    f[1][0] = f64::INFINITY;
    let mut it = f.into_iter();
    detnoise::io::tiff::write_pages(&p, (4, 4), 3, false, &mut || it.next().unwrap()).unwrap();
    darks_fails(&[p], &["inf.tif", "frame 1", "non-finite"]);
}

#[test]
fn single_frame_cannot_give_a_variance() {
    let d = tempfile::tempdir().unwrap();
    let p = d.path().join("one.fits");
    write_fits(&p, (4, 4), &frames(1, (4, 4)));
    darks_fails(&[p], &["one.fits", "1 frame", "at least 2"]);
}

#[test]
fn rgb_tiff_is_an_unsupported_type() {
    use tiff::encoder::{colortype, TiffEncoder};
    let d = tempfile::tempdir().unwrap();
    let p = d.path().join("rgb.tif");
    let mut enc = TiffEncoder::new(std::fs::File::create(&p).unwrap()).unwrap();
    enc.write_image::<colortype::RGB8>(4, 3, &[7u8; 36])
        .unwrap();
    enc.write_image::<colortype::RGB8>(4, 3, &[9u8; 36])
        .unwrap();
    darks_fails(&[p], &["rgb.tif", "frame 0", "single-channel"]);
}

#[test]
fn tiff_page_of_another_shape_is_caught_at_open() {
    use tiff::encoder::{colortype, TiffEncoder};
    let d = tempfile::tempdir().unwrap();
    let p = d.path().join("mixed.tif");
    let mut enc = TiffEncoder::new(std::fs::File::create(&p).unwrap()).unwrap();
    enc.write_image::<colortype::Gray16>(4, 3, &[1u16; 12])
        .unwrap();
    enc.write_image::<colortype::Gray16>(4, 3, &[2u16; 12])
        .unwrap();
    enc.write_image::<colortype::Gray16>(3, 4, &[3u16; 12])
        .unwrap();
    let e = FrameStack::open(&[p]).unwrap_err().to_string();
    assert!(
        e.contains("mixed.tif") && e.contains("frame 2") && e.contains("differs"),
        "{e}"
    );
}

#[test]
fn truncated_tiff_fails_on_a_named_frame() {
    let src = std::fs::read(fixture("tifffile-imagej-one-ifd.tif")).unwrap();
    let d = tempfile::tempdir().unwrap();
    let p = d.path().join("short.tif");
    std::fs::write(&p, &src[..src.len() - 100]).unwrap();
    darks_fails(&[p], &["short.tif", "frame 2", "truncated"]);
}

#[test]
fn missing_file_and_empty_glob_are_errors() {
    let d = tempfile::tempdir().unwrap();
    let out = d.path().join("o");
    Command::cargo_bin("detnoise")
        .unwrap()
        .args(["darks", "/nonexistent/x.fits", "--out"])
        .arg(&out)
        .assert()
        .code(1);
    darks_fails(&[d.path().join("nothing-*.fits")], &["matches no file"]);
}

#[test]
fn ptc_with_a_one_frame_flat_fails_without_output() {
    let d = tempfile::tempdir().unwrap();
    let (dark, flat) = (d.path().join("dark.fits"), d.path().join("flat.fits"));
    write_fits(&dark, (4, 6), &frames(5, (4, 6)));
    write_fits(&flat, (4, 6), &frames(1, (4, 6)));
    let out = d.path().join("ptc");
    let a = Command::cargo_bin("detnoise")
        .unwrap()
        .arg("ptc")
        .arg("--darks")
        .arg(&dark)
        .arg("--flats")
        .arg(&flat)
        .arg("--out")
        .arg(&out)
        .assert()
        .code(1);
    let stderr = String::from_utf8_lossy(&a.get_output().stderr).to_string();
    assert!(
        stderr.contains("flat.fits") && stderr.contains("frame 1") && stderr.contains("at least 2"),
        "{stderr}"
    );
    assert!(!out.exists(), "no output directory on failure");
}
