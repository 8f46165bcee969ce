//! Issue 30's findings on noise maps, file names and dark-frame inputs, from the command line:
//! each refused before any work, naming the file and what is wrong, without a panic and
//! without output.
#![cfg(feature = "cli")]

mod common;

use common::{detnoise, FAST};
use detnoise::calib::{Map, Unit};
use detnoise::io::fits::write_cube;
use std::ffi::OsStr;
use std::os::unix::ffi::OsStrExt;
use std::path::{Path, PathBuf};

/// A 16x16 px read-noise map in `unit` (values 0.5 to 2.0, `edit` applied) written as `name`.
fn map(dir: &Path, name: &[u8], unit: Unit, edit: impl Fn(&mut [f64])) -> PathBuf {
    let mut data: Vec<f64> = (0..256).map(|i| 0.5 + (i % 16) as f64 * 0.1).collect();
    edit(&mut data);
    let p = dir.join(OsStr::from_bytes(name));
    Map::new(16, 16, data, unit).write_fits(&p, &[]).unwrap();
    p
}

/// A dark stack of `frames` frames of `rows` x `cols` (u16, noisy) written as `name`.
fn stack(dir: &Path, name: &[u8], (rows, cols): (usize, usize), frames: usize) -> PathBuf {
    let p = dir.join(OsStr::from_bytes(name));
    let mut k = 0usize;
    let mut next = || {
        k += 1;
        (0..rows * cols)
            .map(|i| 100.0 + ((i * 7 + k * 13) % 5) as f64)
            .collect()
    };
    write_cube(&p, (rows, cols), frames, true, &mut next, &[]).unwrap();
    p
}

/// Run `args` (in `dir`); assert it fails with `code`, its stderr holds every one of `says`,
/// and `out` was not written. Returns stderr.
fn refused(dir: &Path, args: &[&OsStr], code: i32, says: &[&str], out: &Path) -> String {
    let o = detnoise().current_dir(dir).args(args).output().unwrap();
    let err = String::from_utf8_lossy(&o.stderr).into_owned();
    assert_eq!(o.status.code(), Some(code), "{args:?}: {err}");
    for s in says {
        assert!(err.contains(s), "{args:?}: {s:?} not in {err}");
    }
    assert!(!out.exists(), "{args:?} wrote {}", out.display());
    err
}

fn os(s: &str) -> &OsStr {
    OsStr::new(s)
}

#[test]
fn a_path_that_is_not_utf8_is_refused_naming_it() {
    let d = tempfile::tempdir().unwrap();
    let dk = stack(d.path(), b"dk\xff.fits", (16, 16), 4);
    let bad_map = map(d.path(), b"m\xff.fits", Unit::Electrons, |_| ());
    let good_map = map(d.path(), b"m.fits", Unit::Electrons, |_| ());
    let mask = map(d.path(), b"mask\xff.fits", Unit::Flags, |v| v.fill(1.0));
    let out = d.path().join("out");
    let said = ["\u{fffd}.fits: the path is not valid UTF-8"];
    refused(
        d.path(),
        &[os("darks"), dk.as_os_str(), os("--out"), out.as_os_str()],
        1,
        &said,
        &out,
    );
    // A TIFF stack too: its path would fail to go into summary.json after the work.
    let tif = d.path().join(OsStr::from_bytes(b"t\xff.tif"));
    std::fs::copy(common::data("scmos-darks-64x64.tif"), &tif).unwrap();
    let args = [os("darks"), tif.as_os_str(), os("--out"), out.as_os_str()];
    refused(
        d.path(),
        &args,
        1,
        &["t\u{fffd}.tif: the path is not valid UTF-8"],
        &out,
    );
    let subaps = [
        os("subaps"),
        os("--subap-grid"),
        os("4"),
        os("--out"),
        out.as_os_str(),
    ];
    let fast: Vec<&OsStr> = FAST.iter().map(|s| os(s)).collect();
    let with_map = [&subaps[..], &[os("--map"), bad_map.as_os_str()], &fast].concat();
    refused(d.path(), &with_map, 1, &said, &out);
    let with_mask = [
        &subaps[..],
        &[
            os("--map"),
            good_map.as_os_str(),
            os("--subap-mask"),
            mask.as_os_str(),
        ],
        &fast,
    ]
    .concat();
    refused(d.path(), &with_mask, 1, &said, &out);
}

#[test]
fn a_map_that_is_not_a_noise_map_in_electrons_is_refused_naming_the_file() {
    let d = tempfile::tempdir().unwrap();
    let out = d.path().join("out");
    let adu = map(d.path(), b"rms_adu.fits", Unit::Adu, |_| ());
    let darks = stack(d.path(), b"darks.fits", (16, 16), 100);
    let negated = map(d.path(), b"neg.fits", Unit::Electrons, |v| {
        for x in &mut v[20..23] {
            *x = -*x;
        }
    });
    let zero = map(d.path(), b"zero.fits", Unit::Electrons, |v| v.fill(0.0));
    let synth_out = d.path().join("s.fits");
    let sim_out = d.path().join("r.txt");
    let cases: [(&Path, &[&str]); 4] = [
        (
            &adu,
            &["rms_adu.fits", "BUNIT is \"adu\"", "expected electrons"],
        ),
        (&darks, &["darks.fits", "holds 100 frames of 16x16"]),
        (
            &negated,
            &[
                "neg.fits",
                "3 negative pixel(s), the first at row 1, column 4",
            ],
        ),
        (
            &zero,
            &["zero.fits", "every pixel is 0", "scmos-constant:0"],
        ),
    ];
    for (file, says) in cases {
        // Every reader of a noise map: effective and simulate (the readout settings), subaps,
        // and synth's empirical read-noise pdf.
        let f = file.as_os_str();
        let runs: [Vec<&OsStr>; 4] = [
            [
                os("effective"),
                os("--model"),
                os("scmos-map"),
                os("--map"),
                f,
            ]
            .to_vec(),
            [
                os("simulate"),
                os("--model"),
                os("scmos-map"),
                os("--map"),
                f,
            ]
            .to_vec(),
            [os("subaps"), os("--subap-grid"), os("4"), os("--map"), f].to_vec(),
            [
                os("synth"),
                os("--detector"),
                os("scmos"),
                os("--shape"),
                os("8x8"),
            ]
            .to_vec(),
        ];
        for mut args in runs {
            // synth writes a stack file and simulate a table; the others a directory.
            let written = match args[0].to_str() {
                Some("synth") => synth_out.as_path(),
                Some("simulate") => sim_out.as_path(),
                _ => out.as_path(),
            };
            if args[0] == "synth" {
                args.extend([os("--frames"), os("2"), os("--rms-pdf"), f]);
            } else {
                // simulate has no precision target: its iterations only.
                let fast = if args[0] == "simulate" {
                    &FAST[..2]
                } else {
                    &FAST
                };
                args.extend(fast.iter().map(|s| os(s)));
            }
            args.extend([os("--out"), written.as_os_str()]);
            refused(d.path(), &args, 1, says, written);
        }
    }
    // A mask of several frames, and a mask whose BUNIT states a unit, are not masks.
    let good = map(d.path(), b"rms_e.fits", Unit::Electrons, |_| ());
    let masks = [
        (
            stack(d.path(), b"masks.fits", (4, 4), 3),
            "holds 3 frames of 4x4",
        ),
        (
            map(d.path(), b"m_e.fits", Unit::Electrons, |_| ()),
            "BUNIT is \"electron\"",
        ),
    ];
    for (mask, says) in masks {
        let mut args = [os("subaps"), os("--subap-grid"), os("4"), os("--map")].to_vec();
        args.extend([good.as_os_str(), os("--subap-mask"), mask.as_os_str()]);
        args.extend([os("--out"), out.as_os_str()]);
        args.extend(FAST.iter().map(|s| os(s)));
        refused(d.path(), &args, 1, &[says], &out);
    }
}

#[test]
fn a_file_given_twice_is_refused_naming_it() {
    let d = tempfile::tempdir().unwrap();
    let out = d.path().join("out");
    let darks = stack(d.path(), b"darks.fits", (16, 16), 20);
    let f = darks.as_os_str();
    let said = ["darks.fits: given twice among the stack's files"];
    refused(
        d.path(),
        &[os("darks"), f, f, os("--out"), out.as_os_str()],
        1,
        &said,
        &out,
    );
    // A directory and a file inside it.
    let args = [
        os("darks"),
        d.path().as_os_str(),
        f,
        os("--out"),
        out.as_os_str(),
    ];
    refused(d.path(), &args, 1, &said, &out);
    let mut args = [os("report"), os("--gain-e-per-adu"), os("1"), os("--quick")].to_vec();
    args.extend([
        os("--darks"),
        f,
        os("--dark-frames"),
        f,
        os("--dark-frames"),
        f,
    ]);
    args.extend([os("--out"), out.as_os_str()]);
    refused(d.path(), &args, 1, &said, &out);
    // One flat given as two light levels (report and ptc), or the darks given as a flat
    // (ptc): refused before the darks are calibrated.
    let flat = stack(d.path(), b"flat.fits", (16, 16), 20);
    let g = flat.as_os_str();
    let cases: [(&[&OsStr], &[&OsStr], &str); 3] = [
        (
            &[os("report"), os("--darks"), f, os("--quick")],
            &[g, g],
            "flat.fits",
        ),
        (&[os("ptc"), os("--darks"), f], &[g, g], "flat.fits"),
        (&[os("ptc"), os("--darks"), f], &[g, f], "darks.fits"),
    ];
    for (command, flats, twice) in cases {
        let mut args = command.to_vec();
        for flat in flats {
            args.extend([os("--flats"), flat]);
        }
        args.extend([os("--out"), out.as_os_str()]);
        let said = [format!(
            "{twice}: given twice among the darks' and flats' files"
        )];
        let said: Vec<&str> = said.iter().map(String::as_str).collect();
        refused(d.path(), &args, 1, &said, &out);
    }
}

#[test]
fn report_refuses_dark_frames_of_another_shape_naming_both() {
    let d = tempfile::tempdir().unwrap();
    let out = d.path().join("out");
    let darks = stack(d.path(), b"darks.fits", (64, 64), 20);
    let other = stack(d.path(), b"other.fits", (32, 48), 20);
    let mut args = [os("report"), os("--gain-e-per-adu"), os("1"), os("--quick")].to_vec();
    args.extend([os("--darks"), darks.as_os_str(), os("--dark-frames")]);
    args.extend([other.as_os_str(), os("--out"), out.as_os_str()]);
    let says = [
        "--dark-frames",
        "other.fits holds frames of 32x48 px, the darks 64x64 px",
    ];
    refused(d.path(), &args, 2, &says, &out);
}
