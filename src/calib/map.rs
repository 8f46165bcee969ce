//! The calibration map: per-pixel values of one quantity (offset, read noise, gain, flags)
//! on a rows x cols grid, with the unit they are in and where they came from.

use std::path::Path;

use crate::error::{Error, Result};
use crate::io::fits::{write_image, ImageData, Keyword};

/// The unit of a map's values; written as the FITS `BUNIT` keyword.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Unit {
    /// Analog-to-digital units (camera counts).
    Adu,
    /// Electrons (e-).
    Electrons,
    /// Conversion gain, electrons per adu.
    EPerAdu,
    /// Flag bits or other dimensionless values (no BUNIT).
    Flags,
}

impl Unit {
    /// The FITS `BUNIT` string (empty: no BUNIT keyword).
    pub fn bunit(self) -> &'static str {
        match self {
            Unit::Adu => "adu",
            Unit::Electrons => "electron",
            Unit::EPerAdu => "electron/adu",
            Unit::Flags => "",
        }
    }

    /// The BUNIT values that state this unit, compared without case (a blank BUNIT states
    /// none).
    fn spellings(self) -> &'static [&'static str] {
        match self {
            Unit::Adu => &["adu", "adus", "dn", "count", "counts"],
            Unit::Electrons => &["electron", "electrons", "e-", "e"],
            Unit::EPerAdu => &["electron/adu", "electrons/adu", "e-/adu", "e/adu"],
            Unit::Flags => &["dimensionless", "1"],
        }
    }

    /// The unit in words, for messages.
    fn words(self) -> &'static str {
        match self {
            Unit::Adu => "adu",
            Unit::Electrons => "electrons (e-)",
            Unit::EPerAdu => "e- per adu",
            Unit::Flags => "flags (no unit)",
        }
    }

    /// An error naming `path` unless its FITS `bunit` agrees with this unit. No BUNIT, or a
    /// blank one, states nothing: the caller's word is taken.
    fn check_bunit(self, path: &Path, bunit: Option<&str>) -> Result<()> {
        let Some(found) = bunit.map(str::trim).filter(|b| !b.is_empty()) else {
            return Ok(());
        };
        if self.spellings().contains(&found.to_lowercase().as_str()) {
            return Ok(());
        }
        let hint = match self {
            Unit::Electrons => {
                ": give the map in e- (e.g. rms_e.fits from `detnoise darks --gain-e-per-adu`)"
            }
            _ => "",
        };
        Err(Error::input(
            path,
            format!(
                "the map's BUNIT is {found:?}, expected {} (BUNIT {}){hint}",
                self.words(),
                self.spellings().join(", ")
            ),
        ))
    }
}

/// A 2-D map (rows x cols) of f64 values in row-major order, in `unit`. Non-finite values
/// mark pixels without a value (flagged, or read as NaN from a file). Two maps are equal when
/// they hold the same values in the same unit, wherever they came from.
#[derive(Clone, Debug)]
pub struct Map {
    /// Number of rows.
    pub rows: usize,
    /// Number of columns.
    pub cols: usize,
    /// Values, row-major (`data[r * cols + c]`), in `unit`.
    pub data: Vec<f64>,
    /// Unit of the values.
    pub unit: Unit,
    /// Where the map came from (the file read, or the input it was computed from), for
    /// messages; empty when unknown.
    pub source: String,
}

impl PartialEq for Map {
    fn eq(&self, other: &Map) -> bool {
        (self.rows, self.cols, self.unit) == (other.rows, other.cols, other.unit)
            && self.data == other.data
    }
}

impl Map {
    /// A map from row-major data in `unit`; panics if the length is not rows*cols (a
    /// programming error).
    pub fn new(rows: usize, cols: usize, data: Vec<f64>, unit: Unit) -> Map {
        assert_eq!(data.len(), rows * cols, "map data length");
        Map {
            rows,
            cols,
            data,
            unit,
            source: String::new(),
        }
    }

    /// A map of `rows` x `cols` filled with `value` (in `unit`).
    pub fn filled(rows: usize, cols: usize, value: f64, unit: Unit) -> Map {
        Map::new(rows, cols, vec![value; rows * cols], unit)
    }

    /// The same map, naming `source` as its origin in messages.
    pub fn with_source(mut self, source: impl Into<String>) -> Map {
        self.source = source.into();
        self
    }

    /// Read a FITS, TIFF or EXR file of one image as a map whose values are in `unit` (the
    /// caller's knowledge where the file states none). Refused, naming the file: several
    /// frames (a stack is not a map), a FITS BUNIT that states another unit. NaN values are
    /// kept (masked pixels).
    pub fn read(path: impl AsRef<Path>, unit: Unit) -> Result<Map> {
        let path = path.as_ref();
        let image = crate::io::read_image(path)?;
        unit.check_bunit(path, image.bunit.as_deref())?;
        let (rows, cols) = image.shape;
        Ok(Map::new(rows, cols, image.data, unit).with_source(path.display().to_string()))
    }

    /// Read a read-noise (rms) map in `unit` as [`Map::read`] does, refused (naming the file)
    /// when it cannot be one ([`Map::noise_problem`]): the one reader of noise maps.
    pub fn read_noise(path: impl AsRef<Path>, unit: Unit) -> Result<Map> {
        let path = path.as_ref();
        let map = Map::read(path, unit)?;
        match map.noise_problem() {
            Some(problem) => Err(Error::input(path, problem)),
            None => Ok(map),
        }
    }

    /// Why these values cannot be a read-noise map, or None: an rms is never negative (an
    /// offset map or a difference of maps is not a noise map), and a map of zeros only would
    /// give an effective noise of 0 without an error. Non-finite pixels (no value) are
    /// skipped.
    pub fn noise_problem(&self) -> Option<String> {
        let negative = self.data.iter().filter(|v| **v < 0.0).count();
        if let Some(i) = self.data.iter().position(|v| *v < 0.0) {
            return Some(format!(
                "{negative} negative pixel(s), the first at row {}, column {} ({} {}): a \
                 read-noise map holds rms values >= 0 (an offset map or a difference of maps is \
                 not one)",
                i / self.cols,
                i % self.cols,
                self.data[i],
                self.unit.bunit()
            ));
        }
        let finite = self.data.iter().filter(|v| v.is_finite());
        if finite.clone().count() > 0 && finite.clone().all(|v| *v == 0.0) {
            return Some(
                "every pixel is 0: not a measured read-noise map; for a noise-free camera use \
                 the model `scmos-constant:0` (or `--sigma 0`)"
                    .into(),
            );
        }
        None
    }

    /// Value at (row, col).
    pub fn at(&self, r: usize, c: usize) -> f64 {
        self.data[r * self.cols + c]
    }

    /// Frame shape (rows, cols).
    pub fn shape(&self) -> (usize, usize) {
        (self.rows, self.cols)
    }

    /// This map of adu values in electrons, at a conversion gain of `gain_e_per_adu` (e- per
    /// adu). Panics unless the map is in adu (a programming error).
    pub fn to_electrons(&self, gain_e_per_adu: f64) -> Map {
        assert_eq!(
            self.unit,
            Unit::Adu,
            "only a map in adu converts to electrons"
        );
        Map {
            data: self.data.iter().map(|v| v * gain_e_per_adu).collect(),
            unit: Unit::Electrons,
            ..self.clone()
        }
    }

    /// This map with the pixels whose `flags` are non-zero set to NaN (no value).
    pub fn masked(&self, flags: &[i32]) -> Map {
        assert_eq!(flags.len(), self.data.len(), "one flag per pixel");
        Map {
            data: self
                .data
                .iter()
                .zip(flags)
                .map(|(v, f)| if *f == 0 { *v } else { f64::NAN })
                .collect(),
            ..self.clone()
        }
    }

    /// Mean of the finite values (NaN if none), in the map's unit.
    pub fn finite_mean(&self) -> f64 {
        crate::stats::finite_mean(&self.data)
    }

    /// Write as a 64-bit float FITS image with the unit as BUNIT, the provenance keywords and
    /// `keys`, atomically.
    pub fn write_fits(&self, path: &Path, keys: &[Keyword]) -> Result<()> {
        write_image(
            path,
            self.shape(),
            ImageData::F64(&self.data),
            self.unit.bunit(),
            keys,
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn conversion_to_electrons_scales_values_and_unit() {
        let m = Map::new(1, 3, vec![1.0, 2.0, f64::NAN], Unit::Adu).with_source("d.fits");
        let e = m.to_electrons(0.25);
        assert_eq!(e.unit, Unit::Electrons);
        assert_eq!((e.rows, e.cols, e.source.as_str()), (1, 3, "d.fits"));
        assert_eq!(&e.data[..2], &[0.25, 0.5]);
        assert!(e.data[2].is_nan());
    }

    #[test]
    #[should_panic(expected = "only a map in adu")]
    fn electrons_do_not_convert_again() {
        Map::filled(2, 2, 1.0, Unit::Electrons).to_electrons(2.0);
    }

    #[test]
    fn masking_and_mean_skip_flagged_pixels() {
        let m = Map::new(2, 2, vec![1.0, 2.0, 3.0, 10.0], Unit::Adu).masked(&[0, 0, 0, 4]);
        assert!(m.data[3].is_nan());
        assert_eq!(m.at(1, 0), 3.0);
        assert_eq!(m.finite_mean(), 2.0);
    }

    #[test]
    fn units_name_their_bunit() {
        let names: Vec<&str> = [Unit::Adu, Unit::Electrons, Unit::EPerAdu, Unit::Flags]
            .iter()
            .map(|u| u.bunit())
            .collect();
        assert_eq!(names, ["adu", "electron", "electron/adu", ""]);
    }

    #[test]
    fn fits_round_trip_keeps_values() {
        let d = tempfile::tempdir().unwrap();
        let p = d.path().join("m.fits");
        let m = Map::new(2, 3, vec![0.5, 1.0, f64::NAN, -2.0, 3.25, 4.0], Unit::Adu);
        m.write_fits(&p, &[]).unwrap();
        let r = Map::read(&p, Unit::Adu).unwrap();
        assert_eq!(r.shape(), (2, 3));
        // Equal values from another source are the same map; another unit is not.
        let finite = |m: &Map| Map::new(2, 3, m.data.iter().map(|v| v.max(0.0)).collect(), m.unit);
        assert_eq!(finite(&r).with_source("x"), finite(&m));
        assert_ne!(
            Map {
                unit: Unit::Electrons,
                ..finite(&m)
            },
            finite(&m)
        );
        assert_eq!(r.source, p.display().to_string());
        for (a, b) in m.data.iter().zip(&r.data) {
            assert!(a == b || (a.is_nan() && b.is_nan()));
        }
    }

    /// `m` written as a FITS image with BUNIT `bunit` (none if empty) to `dir`/`name`.
    fn written(dir: &Path, name: &str, m: &Map, bunit: &str) -> std::path::PathBuf {
        let p = dir.join(name);
        write_image(&p, m.shape(), ImageData::F64(&m.data), bunit, &[]).unwrap();
        p
    }

    fn refusal(r: Result<Map>) -> String {
        match r {
            Err(Error::Input { path, message }) => format!("{}: {message}", path.display()),
            other => panic!("not an input error: {other:?}"),
        }
    }

    #[test]
    fn a_bunit_that_states_another_unit_is_refused() {
        let d = tempfile::tempdir().unwrap();
        let m = Map::filled(2, 2, 1.5, Unit::Adu);
        let units = [Unit::Adu, Unit::Electrons, Unit::EPerAdu, Unit::Flags];
        // As detnoise writes each unit (flags: BUNIT '' as `darks` writes flags.fits), and as
        // other tools spell it.
        for (bunit, reads_as) in [
            ("adu", Unit::Adu),
            ("ADU", Unit::Adu),
            ("electron", Unit::Electrons),
            ("e-", Unit::Electrons),
            ("electron/adu", Unit::EPerAdu),
            ("dimensionless", Unit::Flags),
        ] {
            let p = written(d.path(), "m.fits", &m, bunit);
            for unit in units {
                let r = Map::read(&p, unit);
                if unit == reads_as {
                    assert_eq!(r.unwrap().unit, unit);
                } else {
                    let e = refusal(r);
                    assert!(
                        e.contains(&format!(
                            "m.fits: the map's BUNIT is {bunit:?}, expected {}",
                            unit.words()
                        )),
                        "{e}"
                    );
                }
            }
        }
        // No BUNIT, or a blank one, states nothing: every unit is taken as the caller says.
        let blank = d.path().join("blank.fits");
        let empty = crate::io::fits::KeyValue::Str(String::new());
        let keys = [crate::io::fits::key("BUNIT", empty, "")];
        write_image(&blank, (2, 2), ImageData::F64(&m.data), "", &keys).unwrap();
        for p in [written(d.path(), "none.fits", &m, ""), blank] {
            for unit in units {
                assert_eq!(Map::read(&p, unit).unwrap().unit, unit);
            }
        }
        let e = refusal(Map::read(
            written(d.path(), "jy.fits", &m, "Jy"),
            Unit::Electrons,
        ));
        assert!(
            e.contains("BUNIT is \"Jy\"") && e.contains("rms_e.fits"),
            "{e}"
        );
    }

    #[test]
    fn a_stack_is_not_a_map() {
        let d = tempfile::tempdir().unwrap();
        let p = d.path().join("stack.fits");
        let mut next = || vec![100.0; 6];
        crate::io::fits::write_cube(&p, (2, 3), 5, true, &mut next, &[]).unwrap();
        for unit in [Unit::Electrons, Unit::Flags] {
            let e = refusal(Map::read(&p, unit));
            assert!(e.contains("stack.fits: holds 5 frames of 2x3"), "{e}");
        }
    }

    #[test]
    fn a_noise_map_has_no_negative_pixel_and_not_only_zeros() {
        let d = tempfile::tempdir().unwrap();
        let mut m = Map::new(
            2,
            3,
            vec![1.0, f64::NAN, 2.0, 0.5, -1.0, -2.0],
            Unit::Electrons,
        );
        let p = written(d.path(), "neg.fits", &m, "electron");
        let e = refusal(Map::read_noise(&p, Unit::Electrons));
        assert!(
            e.contains("neg.fits: 2 negative pixel(s), the first at row 1, column 1 (-1 electron)"),
            "{e}"
        );
        // An offset map may be negative: only noise maps are checked.
        assert!(Map::read(&p, Unit::Electrons).is_ok());
        m.data = vec![0.0, f64::NAN, 0.0, 0.0, 0.0, 0.0];
        let p = written(d.path(), "zero.fits", &m, "electron");
        let e = refusal(Map::read_noise(&p, Unit::Electrons));
        assert!(
            e.contains("zero.fits: every pixel is 0") && e.contains("scmos-constant:0"),
            "{e}"
        );
        // One pixel above 0 is a map (a nearly noise-free camera), as is one without a value.
        m.data[5] = 0.25;
        assert_eq!(m.noise_problem(), None);
        assert_eq!(
            Map::filled(1, 1, f64::NAN, Unit::Electrons).noise_problem(),
            None
        );
    }
}
