//! The calibration map: per-pixel values of one quantity (offset, read noise, gain, flags)
//! on a rows x cols grid, with the unit they are in and where they came from.

use std::path::Path;

use crate::error::Result;
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

    /// Read the first frame of a FITS, TIFF or EXR file as a map whose values are in `unit`
    /// (the caller's knowledge: files rarely state it). NaN values are kept (masked pixels).
    pub fn read(path: impl AsRef<Path>, unit: Unit) -> Result<Map> {
        let path = path.as_ref();
        let ((rows, cols), data) = crate::io::read_first_frame(path)?;
        Ok(Map::new(rows, cols, data, unit).with_source(path.display().to_string()))
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
}
