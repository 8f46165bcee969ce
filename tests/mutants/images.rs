//! Masks of valid sub-apertures (`subaps --subap-mask`) and read-noise maps (`--map` of
//! `subaps` and of the readout models) as FITS, TIFF and EXR images: the image mutators of
//! the readers' test, plus mutants that keep the file valid and change what it means (a
//! second frame, a negative or all-zero map, a BUNIT that is not electrons), judged through
//! `ValidMask::read` and the layout on a map, `Map::read_noise` (the map reader of `subaps`), and `detector::params`
//! with the `scmos-map` readout built on the map.
//!
//! What each mutant allows (an error naming the file is always allowed):
//! - the image mutants: `Any` (a changed pixel is another valid image), but never a file of
//!   several frames used as one, nor a map with a negative or no non-zero pixel, nor a FITS
//!   map whose BUNIT is not electrons (`Seen::wrong`, checked on every Ok).
//! - BUNIT spelled as another word for electrons: `Kept`; any other unit: `Refused`.
//! - a second frame, a dark stack, a negative pixel, an all-zero map: `Refused`.

use std::path::Path;

use detnoise::calib::{Map, Unit};
use detnoise::detector::{ModelParams, ModelSpec};
use detnoise::io::FrameStack;
use detnoise::progress::Silent;
use detnoise::settings::{Value, Values, MAP};
use detnoise::subaps::{Geometry, GridSpec, ValidMask};

use super::expect::{caught, verdict, Case, Expect, Seen};
use super::fixtures::{self, Kind};
use super::{exr, fits, tiff, Mutant, Rng};

/// One image seed: its name, extension, format and bytes.
pub struct ImageSeed {
    /// Short name.
    pub name: String,
    /// Extension.
    pub ext: &'static str,
    /// Format (picks the mutator).
    pub kind: Kind,
    /// Bytes.
    pub bytes: Vec<u8>,
}

/// The 4x4 mask of the seeds (three cells invalid), row-major.
pub const MASK: [f64; 16] = [
    1.0, 1.0, 0.0, 1.0, 1.0, 1.0, 1.0, 1.0, 0.0, 1.0, 1.0, 1.0, 1.0, 1.0, 1.0, 0.0,
];

const FORMATS: [(Kind, &str); 3] = [
    (Kind::Fits, "fits"),
    (Kind::Tiff, "tif"),
    (Kind::Exr, "exr"),
];

/// Write `frames` of `shape` as `kind` (FITS maps through `Map::write_fits`, with BUNIT).
fn image(
    dir: &Path,
    name: &str,
    kind: Kind,
    shape: (usize, usize),
    frames: &[Vec<f64>],
    unit: Unit,
) -> Vec<u8> {
    if kind == Kind::Fits && frames.len() == 1 {
        let p = dir.join(format!("{name}.fits"));
        Map::new(shape.0, shape.1, frames[0].clone(), unit)
            .write_fits(&p, &[])
            .unwrap();
        return std::fs::read(p).unwrap();
    }
    fixtures::write(dir, name, kind, shape, frames, false)
}

/// The 16x16 px read-noise map (e-) of the seeds.
pub fn map_data() -> Vec<f64> {
    fixtures::crop(
        "data-synthetic/scmos-darks-64x64.truth-rms_e.fits",
        1,
        (16, 16),
    )
    .remove(0)
}

/// The mask seeds, one per format.
pub fn mask_seeds(dir: &Path) -> Vec<ImageSeed> {
    FORMATS
        .iter()
        .map(|&(kind, ext)| ImageSeed {
            name: format!("mask-{ext}"),
            ext,
            kind,
            bytes: image(
                dir,
                &format!("mask-{ext}"),
                kind,
                (4, 4),
                &[MASK.to_vec()],
                Unit::Flags,
            ),
        })
        .collect()
}

/// The map seeds, one per format.
pub fn map_seeds(dir: &Path) -> Vec<ImageSeed> {
    FORMATS
        .iter()
        .map(|&(kind, ext)| ImageSeed {
            name: format!("map-{ext}"),
            ext,
            kind,
            bytes: image(
                dir,
                &format!("map-{ext}"),
                kind,
                (16, 16),
                &[map_data()],
                Unit::Electrons,
            ),
        })
        .collect()
}

/// The pixels of the map seed as its format holds them (f32 in TIFF and EXR).
pub fn seed_data(dir: &Path, seed: &ImageSeed) -> Vec<f64> {
    let p = dir.join(format!("{}-seed.{}", seed.name, seed.ext));
    std::fs::write(&p, &seed.bytes).unwrap();
    Map::read(&p, Unit::Electrons).unwrap().data
}

/// `n` image mutants of `seed` (`Any`).
pub fn mutants(seed: &ImageSeed, rng: &mut Rng, n: usize) -> Vec<Case> {
    let list = match seed.kind {
        Kind::Fits | Kind::FitsGz => fits::mutants(&seed.bytes, rng, n),
        Kind::Tiff => tiff::mutants(&seed.bytes, rng, n),
        Kind::Exr => exr::mutants(&seed.bytes, rng, n),
    };
    list.into_iter()
        .map(|m| Case::new(m, Expect::Any))
        .collect()
}

/// Mutants of the mask in `seed`'s format that are valid images of another meaning.
pub fn mask_meanings(dir: &Path, seed: &ImageSeed) -> Vec<Case> {
    let two = [MASK.to_vec(), MASK.to_vec()];
    vec![Case::new(
        Mutant::new(
            "two frames",
            fixtures::write(dir, "mask2", seed.kind, (4, 4), &two, false),
        ),
        Expect::Refused,
    )]
}

/// Mutants of the map in `seed`'s format that are valid images of another meaning.
pub fn map_meanings(dir: &Path, seed: &ImageSeed) -> Vec<Case> {
    let map = map_data();
    let one = |name: &str, data: Vec<f64>| {
        image(dir, name, seed.kind, (16, 16), &[data], Unit::Electrons)
    };
    let mut negative = map.clone();
    negative[17] = -negative[17];
    let mut negated = map.clone();
    negated[..32].iter_mut().for_each(|v| *v = -*v);
    let dark = fixtures::crop("data-synthetic/scmos-darks-64x64.fits", 8, (16, 16));
    let mut out = vec![
        Case::new(
            Mutant::new("one pixel negated", one("neg", negative)),
            Expect::Refused,
        ),
        Case::new(
            Mutant::new("two rows negated", one("negrows", negated)),
            Expect::Refused,
        ),
        Case::new(
            Mutant::new("all pixels zero", one("zero", vec![0.0; 256])),
            Expect::Refused,
        ),
        Case::new(
            Mutant::new(
                "a second frame",
                fixtures::write(dir, "map2", seed.kind, (16, 16), &[map.clone(), map], false),
            ),
            Expect::Refused,
        ),
        Case::new(
            Mutant::new(
                "an 8-frame dark stack (adu)",
                fixtures::write(dir, "dark", seed.kind, (16, 16), &dark, true),
            ),
            Expect::Refused,
        ),
    ];
    if seed.kind == Kind::Fits {
        for (unit, e) in [
            ("adu", Expect::Refused),
            ("ADU", Expect::Refused),
            ("counts", Expect::Refused),
            ("DN", Expect::Refused),
            ("e-/adu", Expect::Refused),
            // A blank BUNIT states no unit: taken as the caller's word, or refused.
            ("", Expect::Same),
            ("electrons", Expect::Kept),
            ("e-", Expect::Kept),
            ("Electron", Expect::Kept),
        ] {
            out.push(Case::new(
                Mutant::new(format!("BUNIT = '{unit}'"), with_bunit(&seed.bytes, unit)),
                e,
            ));
        }
    }
    out
}

/// `fits` with its BUNIT card's value replaced by `unit`.
fn with_bunit(fits: &[u8], unit: &str) -> Vec<u8> {
    let mut b = fits.to_vec();
    let at = (0..b.len() / 80)
        .map(|i| i * 80)
        .find(|&i| b[i..i + 8] == *b"BUNIT   ")
        .expect("the map seed has BUNIT");
    let card = format!("{:<80}", format!("BUNIT   = '{unit:<8}'"));
    b[at..at + 80].copy_from_slice(card.as_bytes());
    b
}

/// Frames in the file at `path`, if it opens as a stack.
fn frames(path: &Path) -> Option<usize> {
    FrameStack::open(&[path.to_path_buf()])
        .ok()
        .map(|s| s.frames)
}

/// The BUNIT of the first image of a FITS file, if any.
fn bunit(path: &Path) -> Option<String> {
    let mut f = fitsio::FitsFile::open(path).ok()?;
    for i in 0..8 {
        let hdu = f.hdu(i).ok()?;
        if let fitsio::hdu::HduInfo::ImageInfo { shape, .. } = &hdu.info {
            if shape.len() >= 2 {
                return hdu.read_key::<String>(&mut f, "BUNIT").ok();
            }
        }
    }
    None
}

/// What no loader may accept as a map or a mask: several frames; for a map, a negative
/// pixel, no non-zero pixel, or a unit other than electrons.
fn wrong(path: &Path, kind: Kind, data: Option<&[f64]>) -> Option<String> {
    if let Some(n) = frames(path).filter(|&n| n > 1) {
        return Some(format!("a file of {n} frames used as one"));
    }
    let data = data?;
    if let Some(v) = data.iter().find(|v| **v < 0.0) {
        return Some(format!("a map with a negative pixel ({v})"));
    }
    if data.iter().all(|v| *v == 0.0 || !v.is_finite()) {
        return Some("a map with no non-zero pixel".into());
    }
    if kind == Kind::Fits {
        let unit = bunit(path)?;
        let u = unit.trim().to_lowercase();
        if !["", "electron", "electrons", "e-", "e"].contains(&u.as_str()) {
            return Some(format!("a map whose BUNIT is {unit:?}"));
        }
    }
    None
}

/// The failure, if any, of the mask at `path` (allowing `expect`): read, then laid out by a
/// 4 px grid on a 16x16 px map (an error of the layout naming `subap_grid` or `subap_mask`,
/// e.g. a mask of another shape than the grid: allowed).
pub fn judge_mask(path: &Path, expect: Expect, kind: Kind) -> Option<String> {
    let r = caught(|| ValidMask::read(path));
    let grid = GridSpec::parse("4").unwrap();
    verdict("mask", expect, path, r, |m| {
        let g = Geometry {
            grid,
            mask: Some(m.clone()),
        };
        let layout = caught(|| g.layout(16, 16));
        Seen {
            differs: (m.valid != MASK.map(|v| v != 0.0)).then(|| "other cells".into()),
            wrong: match layout {
                Err(p) => Some(format!("PANIC in the layout: {p}")),
                Ok(Err(detnoise::Error::Usage { field, .. }))
                    if field == "subap_grid" || field == "subap_mask" =>
                {
                    None
                }
                Ok(Err(e)) => Some(format!("layout: {e}")),
                Ok(Ok(_)) => None,
            }
            .or_else(|| wrong(path, kind, None)),
        }
    })
}

/// The failures of the map at `path` (allowing `expect`) through `subaps` and the readout
/// models' parameters.
pub fn judge_map(path: &Path, expect: Expect, kind: Kind, seed: &[f64]) -> Vec<String> {
    let seen = |m: &Map| Seen {
        differs: (m.data != seed).then(|| "other pixels".into()),
        wrong: wrong(path, kind, Some(&m.data)),
    };
    let mut bad = Vec::new();
    let r = caught(|| Map::read_noise(path, Unit::Electrons));
    bad.extend(verdict("subaps map", expect, path, r, seen));
    let r = caught(|| {
        let mut values = Values::default();
        values.set(&MAP, Value::Path(path.to_path_buf()));
        let params = ModelParams::from_settings(&values, &Silent)?;
        ModelSpec::parse("scmos-map")?.build(&params, 4)?;
        Ok(params.map.expect("a map was given"))
    });
    bad.extend(verdict("detector map", expect, path, r, |m| seen(m)));
    bad
}
