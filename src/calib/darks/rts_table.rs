//! The RTS table: one row per telegraph pixel (levels relative to the pixel's offset,
//! occupancies, widths, dwell times), written as `rts.csv` and as a FITS binary table with
//! the same columns and their units; the same columns hold the truth of synthetic stacks.

use std::fmt::Write as _;
use std::path::Path;

use fitsio::tables::{ColumnDataType, ColumnDescription};

use super::telegraph::TelegraphFit;
use crate::error::{Error, Result};
use crate::output::{write_atomic, write_atomic_with};

/// Most levels a row holds.
pub const MAX_LEVELS: usize = 3;

/// The columns of one level (k = 1, 2, 3) with their units ('' for dimensionless).
const LEVEL_COLUMNS: [(&str, &str); 9] = [
    ("level_{k}_adu", "adu"),
    ("level_{k}_se_adu", "adu"),
    ("level_{k}_e", "electron"),
    ("occupancy_{k}", ""),
    ("occupancy_{k}_se", ""),
    ("width_{k}_adu", "adu"),
    ("width_{k}_e", "electron"),
    ("dwell_{k}_frames", "frame"),
    ("dwell_{k}_se_frames", "frame"),
];

/// Every column name of the table, in order.
pub fn rts_columns() -> Vec<String> {
    let mut c: Vec<String> = ["x_px", "y_px", "n_levels", "status"]
        .map(String::from)
        .to_vec();
    for k in 1..=MAX_LEVELS {
        c.extend(
            LEVEL_COLUMNS
                .iter()
                .map(|(n, _)| n.replace("{k}", &k.to_string())),
        );
    }
    c
}

/// One level of a row: values in adu (and e- with a gain), standard errors where known.
#[derive(Clone, Debug, PartialEq)]
pub struct RtsLevelRow {
    /// Level relative to the pixel's offset (adu).
    pub level_adu: f64,
    /// Its standard error (adu).
    pub level_se_adu: Option<f64>,
    /// Fraction of frames in the level.
    pub occupancy: f64,
    /// Its standard error.
    pub occupancy_se: Option<f64>,
    /// Gaussian standard deviation around the level (adu).
    pub width_adu: f64,
    /// Mean run length in the level (frames).
    pub dwell_frames: f64,
    /// Its standard error (frames).
    pub dwell_se_frames: Option<f64>,
}

/// One row of the RTS table.
#[derive(Clone, Debug, PartialEq)]
pub struct RtsRow {
    /// Column (0-based, full frame).
    pub x_px: usize,
    /// Row (0-based, full frame).
    pub y_px: usize,
    /// `ok` or `imprecise`.
    pub status: &'static str,
    /// Levels, ascending (two or three).
    pub levels: Vec<RtsLevelRow>,
    /// Conversion gain for the e- columns (e- per adu), if known.
    pub gain_e_per_adu: Option<f64>,
}

impl RtsRow {
    /// The row of the telegraph fit `fit` of pixel (x, y).
    pub fn of_fit(x_px: usize, y_px: usize, fit: &TelegraphFit, gain: Option<f64>) -> RtsRow {
        RtsRow {
            x_px,
            y_px,
            status: fit.status.label(),
            levels: fit
                .levels
                .iter()
                .map(|l| RtsLevelRow {
                    level_adu: l.mean,
                    level_se_adu: Some(l.mean_se),
                    occupancy: l.occupancy,
                    occupancy_se: Some(l.occupancy_se),
                    width_adu: l.width,
                    dwell_frames: l.dwell_frames,
                    dwell_se_frames: Some(l.dwell_se_frames),
                })
                .collect(),
            gain_e_per_adu: gain,
        }
    }

    /// The values of the level columns of level `k` (0-based; None when absent or unknown).
    fn level_cells(&self, k: usize) -> [Option<f64>; 9] {
        let Some(l) = self.levels.get(k) else {
            return [None; 9];
        };
        let e = |v: f64| self.gain_e_per_adu.map(|g| v * g);
        [
            Some(l.level_adu),
            l.level_se_adu,
            e(l.level_adu),
            Some(l.occupancy),
            l.occupancy_se,
            Some(l.width_adu),
            e(l.width_adu),
            Some(l.dwell_frames),
            l.dwell_se_frames,
        ]
        .map(|v| v.filter(|x| x.is_finite()))
    }
}

/// The table as CSV: a header row of [`rts_columns`], empty cells for absent values.
pub fn rts_csv(rows: &[RtsRow]) -> String {
    let mut s = rts_columns().join(",");
    s.push('\n');
    for r in rows {
        let _ = write!(s, "{},{},{},{}", r.x_px, r.y_px, r.levels.len(), r.status);
        for k in 0..MAX_LEVELS {
            for v in r.level_cells(k) {
                s.push(',');
                if let Some(v) = v {
                    let _ = write!(s, "{v}");
                }
            }
        }
        s.push('\n');
    }
    s
}

/// Write the table as CSV to `path`, atomically.
pub fn write_rts_csv(path: &Path, rows: &[RtsRow]) -> Result<()> {
    write_atomic(path, rts_csv(rows).as_bytes())
}

fn fits_err(path: &Path, e: fitsio::errors::Error) -> Error {
    Error::io(path, std::io::Error::other(e.to_string()))
}

/// Write the table as a FITS binary table (extension `RTS`, TUNITn units; absent values
/// NaN, the FITS convention for undefined reals) to `path`, atomically.
pub fn write_rts_fits(path: &Path, rows: &[RtsRow]) -> Result<()> {
    write_atomic_with(path, |tmp| {
        let mut f = crate::io::fits::create_file(tmp, None)?;
        let names = rts_columns();
        let mut units: Vec<&str> = vec!["pixel", "pixel", "", ""];
        for _ in 0..MAX_LEVELS {
            units.extend(LEVEL_COLUMNS.iter().map(|(_, u)| *u));
        }
        let descriptions = names
            .iter()
            .enumerate()
            .map(|(i, n)| {
                let mut d = ColumnDescription::new(n);
                match i {
                    0..=2 => d.with_type(ColumnDataType::Long),
                    3 => d.with_type(ColumnDataType::String).that_repeats(9),
                    _ => d.with_type(ColumnDataType::Double),
                };
                d.create()
            })
            .collect::<std::result::Result<Vec<_>, _>>()
            .map_err(|e| fits_err(tmp, e))?;
        let hdu = f
            .create_table("RTS", &descriptions)
            .map_err(|e| fits_err(tmp, e))?;
        let ints = |g: &dyn Fn(&RtsRow) -> usize| -> Vec<i64> {
            rows.iter().map(|r| g(r) as i64).collect()
        };
        let err = |e| fits_err(tmp, e);
        hdu.write_col(&mut f, "x_px", &ints(&|r| r.x_px))
            .map_err(err)?;
        hdu.write_col(&mut f, "y_px", &ints(&|r| r.y_px))
            .map_err(err)?;
        hdu.write_col(&mut f, "n_levels", &ints(&|r| r.levels.len()))
            .map_err(err)?;
        let status: Vec<String> = rows.iter().map(|r| r.status.to_string()).collect();
        hdu.write_col(&mut f, "status", &status).map_err(err)?;
        for (c, name) in names.iter().enumerate().skip(4) {
            let (k, j) = ((c - 4) / 9, (c - 4) % 9);
            let v: Vec<f64> = rows
                .iter()
                .map(|r| r.level_cells(k)[j].unwrap_or(f64::NAN))
                .collect();
            hdu.write_col(&mut f, name.as_str(), &v).map_err(err)?;
        }
        for (i, u) in units.iter().enumerate() {
            if !u.is_empty() {
                hdu.write_key(&mut f, &format!("TUNIT{}", i + 1), *u)
                    .map_err(|e| fits_err(tmp, e))?;
            }
        }
        let creator = format!("detnoise {}", env!("CARGO_PKG_VERSION"));
        hdu.write_key(
            &mut f,
            "CREATOR",
            (creator, "software that wrote this file"),
        )
        .map_err(|e| fits_err(tmp, e))?;
        hdu.write_key(
            &mut f,
            "COMMENT",
            "telegraph (RTS) pixels: levels relative to the pixel offset; NaN = no value",
        )
        .map_err(|e| fits_err(tmp, e))?;
        Ok(())
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn row(levels: usize, gain: Option<f64>) -> RtsRow {
        RtsRow {
            x_px: 3,
            y_px: 7,
            status: "ok",
            levels: (0..levels)
                .map(|k| RtsLevelRow {
                    level_adu: k as f64 - 0.5,
                    level_se_adu: Some(0.01),
                    occupancy: 0.5,
                    occupancy_se: None,
                    width_adu: 2.0,
                    dwell_frames: 10.0,
                    dwell_se_frames: Some(f64::NAN),
                })
                .collect(),
            gain_e_per_adu: gain,
        }
    }

    #[test]
    fn csv_has_the_shared_columns_and_empty_cells_for_absent_values() {
        let csv = rts_csv(&[row(2, Some(0.5)), row(3, None)]);
        let lines: Vec<&str> = csv.lines().collect();
        assert!(lines[0].starts_with(
            "x_px,y_px,n_levels,status,level_1_adu,level_1_se_adu,level_1_e,occupancy_1,occupancy_1_se,width_1_adu,width_1_e,dwell_1_frames,dwell_1_se_frames,level_2_adu,"
        ));
        assert!(lines[0].ends_with(",dwell_3_frames,dwell_3_se_frames"));
        assert_eq!(lines[0].split(',').count(), 4 + 27);
        let cells: Vec<&str> = lines[1].split(',').collect();
        assert_eq!(cells.len(), 31);
        assert_eq!(
            &cells[..8],
            ["3", "7", "2", "ok", "-0.5", "0.01", "-0.25", "0.5"]
        );
        // Unknown SE, NaN SE and level 3 of a two-level pixel: empty cells.
        assert_eq!((cells[8], cells[12]), ("", ""));
        assert!(cells[22..].iter().all(|c| c.is_empty()));
        // Without a gain the e- cells are empty.
        let cells: Vec<&str> = lines[2].split(',').collect();
        assert_eq!((cells[2], cells[6], cells[10]), ("3", "", ""));
        assert!(!csv.contains("NaN"));
    }

    #[test]
    fn the_fits_table_reads_back_with_its_units() {
        let d = tempfile::tempdir().unwrap();
        let p = d.path().join("rts.fits");
        write_rts_fits(&p, &[row(2, Some(0.5)), row(3, None)]).unwrap();
        let mut f = fitsio::FitsFile::open(&p).unwrap();
        let hdu = f.hdu("RTS").unwrap();
        let x: Vec<i64> = hdu.read_col(&mut f, "x_px").unwrap();
        assert_eq!(x, [3, 3]);
        let l: Vec<f64> = hdu.read_col(&mut f, "level_2_e").unwrap();
        assert_eq!(l[0], 0.25);
        assert!(l[1].is_nan());
        let s: Vec<String> = hdu.read_col(&mut f, "status").unwrap();
        assert_eq!(s[0].trim(), "ok");
        let unit: String = hdu.read_key(&mut f, "TUNIT5").unwrap();
        assert_eq!(unit, "adu");
    }
}
