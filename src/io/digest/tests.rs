//! The digests of the checksum thread are the files' BLAKE3 / SHA-256, whichever bytes came
//! from the reader's batches and whichever the thread read itself.

use std::path::PathBuf;

use super::*;
use crate::io::{read_batches, FrameOrigin};

#[test]
fn prefetched_updates_hash_like_one_update() {
    // Lengths around the piece size and the SHA-256 block, odd offsets included.
    let data: Vec<u8> = (0..10_000u32).map(|i| (i * 31 % 251) as u8).collect();
    for cut in [0, 1, 63, 64, 1023, 1024, 2049, 9999, 10_000] {
        let mut a = Sha256::new();
        a.update(&data);
        let mut b = Sha256::new();
        update_prefetched(&mut b, &data[..cut]);
        update_prefetched(&mut b, &data[cut..]);
        assert_eq!(a.finalize(), b.finalize(), "cut at {cut}");
    }
}

#[test]
fn file_hashes_take_supplied_bytes_and_read_the_gaps() {
    let d = tempfile::tempdir().unwrap();
    let p = d.path().join("f.bin");
    let data: Vec<u8> = (0..700_000u32).map(|i| (i * 7 % 253) as u8).collect();
    std::fs::write(&p, &data).unwrap();
    // The known digest of these bytes, computed independently of this module.
    let whole = format!("{:x}", Sha256::digest(&data));
    assert_eq!(checksum_file(&p, Checksum::Sha256).unwrap(), whole);
    let no = AtomicBool::new(false);
    let mut buf = vec![0u8; 1000];
    let mut h = FileHash::new(&p, Checksum::Sha256);
    // Pieces with gaps before, between and after them; a piece already hashed is skipped.
    h.add(2880, &data[2880..300_000], &mut buf, &no).unwrap();
    h.add(300_000, &data[300_000..400_000], &mut buf, &no)
        .unwrap();
    h.add(450_000, &data[450_000..600_000], &mut buf, &no)
        .unwrap();
    h.add(100, &data[100..200], &mut buf, &no).unwrap();
    h.finish(&mut buf, &no).unwrap();
    assert_eq!(h.hex(), whole);
    // A file finished from disk ignores later pieces.
    let mut h = FileHash::new(&p, Checksum::Sha256);
    h.finish(&mut buf, &no).unwrap();
    h.add(699_000, &data[699_000..], &mut buf, &no).unwrap();
    assert_eq!(h.hex(), whole);
}

#[test]
fn a_missing_file_is_an_error_naming_it() {
    let p = Path::new("/nonexistent/detnoise-digest.fits");
    let e = checksum_file(p, Checksum::Sha256).unwrap_err().to_string();
    assert!(e.contains("detnoise-digest.fits"), "{e}");
}

fn fixture(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/fixtures/interop")
        .join(name)
}

/// One 80-character header card.
fn card(text: &str) -> String {
    format!("{text:<80}")
}

/// Header cards padded to whole 2880-byte blocks.
fn header(cards: &[&str]) -> Vec<u8> {
    let mut h: String = cards.iter().map(|c| card(c)).collect();
    h.push_str(&card("END"));
    let mut b = h.into_bytes();
    b.resize(b.len().div_ceil(2880) * 2880, b' ');
    b
}

/// A FITS file of three 2 x 3 int16 image extensions (frames), the second with a BLANK
/// value, so that its frame is decoded by CFITSIO and the others are read raw.
fn fits_with_blank(path: &Path) {
    let mut b = header(&[
        "SIMPLE  =                    T",
        "BITPIX  =                   16",
        "NAXIS   =                    0",
        "EXTEND  =                    T",
    ]);
    for k in 0..3i16 {
        let mut cards = vec![
            "XTENSION= 'IMAGE   '",
            "BITPIX  =                   16",
            "NAXIS   =                    2",
            "NAXIS1  =                    3",
            "NAXIS2  =                    2",
            "PCOUNT  =                    0",
            "GCOUNT  =                    1",
        ];
        if k == 1 {
            cards.push("BLANK   =               -32768");
        }
        b.extend(header(&cards));
        let mut data: Vec<u8> = (0..6i16)
            .flat_map(|i| (100 * k + i).to_be_bytes())
            .collect();
        data.resize(2880, 0);
        b.extend(data);
    }
    std::fs::write(path, b).unwrap();
}

/// Read `paths` as a stack through the batch reader with a tap; returns the origins of the
/// frames read and the digests.
fn tapped(paths: &[PathBuf], algorithm: Checksum) -> (Vec<FrameOrigin>, Vec<String>) {
    let stack = FrameStack::open(paths).unwrap_or_else(|e| panic!("{paths:?}: {e}"));
    let (origins, hashes) = hash_stack_while(&stack, algorithm, |tap| {
        let mut origins = Vec::new();
        read_batches(&stack, Some(tap), |b| {
            origins.extend_from_slice(b.origins());
            Ok(())
        })?;
        Ok(origins)
    })
    .unwrap();
    assert_eq!(origins.len(), stack.frames);
    (origins, hashes)
}

#[test]
fn blake3_of_an_empty_file_is_the_reference_digest() {
    // The BLAKE3 test vector for empty input (BLAKE3 specification, test_vectors.json).
    let d = tempfile::tempdir().unwrap();
    let p = d.path().join("empty");
    std::fs::write(&p, b"").unwrap();
    assert_eq!(
        checksum_file(&p, Checksum::Blake3).unwrap(),
        "af1349b9f5f9a1a6a0404dea36dcc9499bcb25c9adc112b7cc9a93cae41f3262"
    );
}

#[test]
fn tapped_digests_are_the_files_digests_in_every_format() {
    let d = tempfile::tempdir().unwrap();
    let blank = d.path().join("blank.fits");
    fits_with_blank(&blank);
    let cube = fixture("astropy-u16-bzero.fits");
    let copy = d.path().join("copy.fits");
    std::fs::copy(&cube, &copy).unwrap();
    let stacks: Vec<Vec<PathBuf>> = vec![
        vec![cube.clone()],
        vec![fixture("astropy-mef.fits")],
        vec![fixture("astropy-rice.fits")],
        vec![fixture("astropy-u16-bzero.fits.gz")],
        vec![fixture("tifffile-multipage.tif")],
        vec![fixture("openexr-f32-layers.exr")],
        vec![blank.clone()],
        // One file, another, and a copy of the first (a file is given once): each entry is
        // hashed on its own.
        vec![cube.clone(), fixture("astropy-mef.fits"), copy],
    ];
    for algorithm in [Checksum::Blake3, Checksum::Sha256] {
        for paths in &stacks {
            let (_, hashes) = tapped(paths, algorithm);
            let want: Vec<String> = paths
                .iter()
                .map(|p| one_shot_digest(p, algorithm))
                .collect();
            assert_eq!(hashes, want, "{paths:?} {algorithm:?}");
            let alone: Vec<String> = paths
                .iter()
                .map(|p| checksum_file(p, algorithm).unwrap())
                .collect();
            assert_eq!(alone, want, "{paths:?} {algorithm:?}");
        }
    }
    // The raw paths were taken: cube frames 2880 bytes in, one after another; extension
    // frames after their headers; the BLANK frame decoded by CFITSIO.
    let (o, _) = tapped(&[cube], Checksum::Blake3);
    let offsets: Vec<Option<u64>> = o.iter().map(|o| o.offset).collect();
    assert_eq!(
        offsets,
        (0..4).map(|k| Some(2880 + 70 * k)).collect::<Vec<_>>()
    );
    let (o, _) = tapped(&[blank], Checksum::Blake3);
    let offsets: Vec<Option<u64>> = o.iter().map(|o| o.offset).collect();
    assert_eq!(offsets, [Some(2 * 2880), None, Some(6 * 2880)]);
    let (o, _) = tapped(&[fixture("astropy-rice.fits")], Checksum::Blake3);
    assert!(o.iter().all(|o| o.offset.is_none()));
}

#[test]
fn the_works_error_comes_first_and_a_vanished_file_is_named() {
    let d = tempfile::tempdir().unwrap();
    let p = d.path().join("gone.fits");
    std::fs::copy(fixture("astropy-u16-bzero.fits"), &p).unwrap();
    let stack = FrameStack::open(std::slice::from_ref(&p)).unwrap();
    let e = hash_stack_while(&stack, Checksum::Blake3, |_| -> Result<()> {
        Err(Error::Numeric("work failed".into()))
    })
    .unwrap_err();
    assert_eq!(
        e.to_string(),
        Error::Numeric("work failed".into()).to_string()
    );
    std::fs::remove_file(&p).unwrap();
    let e = hash_stack_while(&stack, Checksum::Blake3, |_| Ok(()))
        .unwrap_err()
        .to_string();
    assert!(e.contains("gone.fits"), "{e}");
}

#[test]
fn the_reader_hashes_stored_frames_inline_and_leaves_the_rest_to_the_thread() {
    let cube = fixture("astropy-u16-bzero.fits");
    let stack = FrameStack::open(std::slice::from_ref(&cube)).unwrap();
    let mut state = StackHash::new(&stack, Checksum::Blake3);
    let abort = AtomicBool::new(false);
    let mut reader = stack.reader();
    let mut frame = FrameData::Values(Vec::new());
    let origin = reader.next_frame_data(&mut frame).unwrap().unwrap();
    let FrameData::Raw(bytes, _) = &frame else {
        panic!("the cube's frames are stored bytes");
    };
    let end = origin.offset.unwrap() + bytes.len() as u64;
    // A decoded frame is not hashed inline: the file stays where it was.
    let decoded = FrameData::Values(vec![0.0; 35]);
    state.inline(&origin, &decoded, &abort);
    assert_eq!(state.files[0].pos, 0);
    // A stored frame is, with the header before it (2880 bytes, within the gap allowed).
    state.inline(&origin, &frame, &abort);
    assert_eq!(state.files[0].pos, end);
    // The thread's turn for the same frame skips it.
    state.add(&origin, &frame, &abort).unwrap();
    assert_eq!(state.files[0].pos, end);
    // A frame further on than INLINE_GAP is left to the thread.
    let far = FrameOrigin {
        offset: Some(end + INLINE_GAP + 1),
        ..origin
    };
    state.inline(&far, &frame, &abort);
    assert_eq!(state.files[0].pos, end);
    // The rest of the file is read at the end, and the digest is the file's.
    let digests = state.finish(&abort).unwrap();
    assert_eq!(digests, [one_shot_digest(&cube, Checksum::Blake3)]);
}

#[test]
fn the_reader_finishes_a_previous_file_only_when_little_of_it_is_left() {
    // Two files of 8 frames of 64 x 64 uint16 (64 KiB + header, more than INLINE_GAP): the
    // second's first frame is hashed inline once the first file has been hashed up to its
    // padding, not while most of it is left.
    let d = tempfile::tempdir().unwrap();
    let cube = d.path().join("cube.fits");
    let mut k = 0.0;
    let mut next = || {
        k += 1.0;
        (0..64 * 64).map(|i| 100.0 + k + (i % 7) as f64).collect()
    };
    crate::io::fits::write_cube(&cube, (64, 64), 8, true, &mut next, &[]).unwrap();
    assert!(std::fs::metadata(&cube).unwrap().len() > INLINE_GAP);
    let copy = d.path().join("copy.fits");
    std::fs::copy(&cube, &copy).unwrap();
    let paths = [cube.clone(), copy];
    let stack = FrameStack::open(&paths).unwrap();
    let abort = AtomicBool::new(false);
    let frames: Vec<(FrameOrigin, FrameData)> = {
        let mut reader = stack.reader();
        let mut out = Vec::new();
        loop {
            let mut f = FrameData::Values(Vec::new());
            match reader.next_frame_data(&mut f).unwrap() {
                Some(o) => out.push((o, f)),
                None => break out,
            }
        }
    };
    let second = frames.iter().position(|(o, _)| o.source == 1).unwrap();
    let mut state = StackHash::new(&stack, Checksum::Blake3);
    state.inline(&frames[second].0, &frames[second].1, &abort);
    assert_eq!(state.files[1].pos, 0, "the first file is all left");
    for (o, f) in &frames {
        state.inline(o, f, &abort);
    }
    assert_eq!(state.next, 1, "the first file finished inline");
    let offset = frames.last().unwrap().0.offset.unwrap();
    assert!(state.files[1].pos > offset);
    let digests = state.finish(&abort).unwrap();
    let want = one_shot_digest(&cube, Checksum::Blake3);
    assert_eq!(digests, [want.clone(), want]);
}
