//! The EMVA 1288 (release 4.0) datasheet of a camera: a photon-transfer series of frame pairs
//! (bright and dark at each exposure or irradiance) and the spatial stacks, read from an EMVA
//! descriptor or a campaign's manifest, reduced to the standard's numbers with their standard
//! errors, and per-pixel maps the standard does not give.

pub mod beyond;
pub mod dataset;
pub mod datasheet;
pub mod page;
pub mod pairs;
pub mod pixel_maps;
pub mod quantity;
pub mod run;
pub mod sheet;
pub mod spatial;
pub mod temporal;
pub mod xml;

pub use dataset::{EmvaDataset, PairPoint, SpatialStack};
pub use quantity::{Quantity, QuantityStatus};
pub use sheet::{Curve, Figure, Row, Section, Sheet};
