//! The old home of the map type, kept only for the callers outside the data path that still
//! read a noise map here (`cli::args`); the map is [`crate::calib::Map`]. Remove with them.

use std::path::Path;

use crate::calib::{Map, Unit};
use crate::error::Result;

/// Read a read-noise map in electrons: [`Map::read`] with [`Unit::Electrons`].
pub fn read_map(path: impl AsRef<Path>) -> Result<Map> {
    Map::read(path, Unit::Electrons)
}
