//! Reading the inputs of a job from files: the noise map (refused when its FITS header says
//! it is not in electrons) and the mask of valid sub-apertures.

use crate::calib::{Map, Unit};
use crate::io::StackFormat;
use crate::{Error, Result};
use std::path::Path;

/// BUNIT values that mean electrons (compared without case).
const ELECTRON_UNITS: [&str; 4] = ["electron", "electrons", "e-", "e"];

/// Read a noise map in e- (FITS, TIFF or EXR; the first frame). A FITS map whose first image
/// states another BUNIT (e.g. `adu`, as `darks` writes rms_adu.fits) is refused, naming the
/// file; without BUNIT (and for TIFF/EXR, which carry no unit) the caller's word is taken.
pub fn read_map_e(path: &Path) -> Result<Map> {
    let map = Map::read(path, Unit::Electrons)?;
    if let Some(unit) = fits_bunit(path)? {
        if !ELECTRON_UNITS.contains(&unit.trim().to_lowercase().as_str()) {
            return Err(Error::input(
                path,
                format!(
                    "the map's BUNIT is {unit:?}, not electrons: give the read-noise map in e- \
                     (e.g. rms_e.fits from `detnoise darks --gain-e-per-adu`)"
                ),
            ));
        }
    }
    Ok(map)
}

/// The BUNIT of the first image of a FITS file (None: not FITS, or no BUNIT). The file has
/// been read (and its headers checked) before this is called.
fn fits_bunit(path: &Path) -> Result<Option<String>> {
    if StackFormat::detect(path)? != StackFormat::Fits {
        return Ok(None);
    }
    let io = |e: fitsio::errors::Error| Error::input(path, format!("FITS header: {e}"));
    let mut f = fitsio::FitsFile::open(path).map_err(io)?;
    for i in 0.. {
        let Ok(hdu) = f.hdu(i) else { break };
        if let fitsio::hdu::HduInfo::ImageInfo { shape, .. } = &hdu.info {
            if shape.len() >= 2 {
                return Ok(hdu.read_key::<String>(&mut f, "BUNIT").ok());
            }
        }
    }
    Ok(None)
}
