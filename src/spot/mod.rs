//! Noiseless sub-aperture spot images: Airy disc and elongated Gaussian.
//!
//! Pixel (row i, column j) has its centre at (x, y) = (j, i); positions are offsets from the
//! sub-aperture centre (n-1)/2, so x follows columns and y follows rows.
//!
//! Airy spots render from tables built once per process and shared by every renderer: point
//! sampling from the intensity against radius, integrated sampling from the pixel integral
//! against the sub-pixel offset (`pixel_table`, within 5e-6 of the peak pixel of the exact
//! integral). Memory: at most 256 MiB of pixel tables and 32 MiB of radial tables are kept (least
//! recently used dropped first, while renderers still holding them keep them alive), and a build
//! takes at most 128 MiB while it runs; the report's default grid keeps about 6 MB.

mod airy;
mod cache;
mod gauss;
mod kernel;
mod pixel_table;
mod radial;
#[cfg(test)]
mod tests;

use crate::{Error, Result};
pub use airy::{airy_intensity, J1_FIRST_ZERO};
use cache::Cache;
use pixel_table::PixelTable;
use radial::RadialTable;
use std::sync::{Arc, LazyLock};

/// Smallest spot size accepted (Airy diameter or Gaussian sigma, px).
pub const MIN_SIZE_PX: f64 = 0.1;

/// Why a spot size is refused.
const SIZE_RULE: &str = "sizes must be numbers >= 0.1 px (a smaller spot puts all its light in \
                         one pixel, and its tables would grow as 1/size)";

/// A spot shape.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Spot {
    /// Airy disc whose first dark ring has diameter `diameter_px` (pixels).
    Airy {
        /// Diameter of the first dark ring (px).
        diameter_px: f64,
    },
    /// 2-D Gaussian (laser guide star elongation) with standard deviations in px.
    Gauss {
        /// Standard deviation along x / columns (px).
        sigma_x_px: f64,
        /// Standard deviation along y / rows (px).
        sigma_y_px: f64,
    },
}

impl Spot {
    /// Parse `airy:D` or `gauss:SX,SY` (pixels).
    pub fn parse(text: &str) -> Result<Self> {
        let bad = |why: &str| spot_error(text, why);
        let size = |s: &str| Self::size(s).ok_or_else(|| bad(SIZE_RULE));
        match text.split_once(':') {
            Some(("airy", d)) => Ok(Spot::Airy {
                diameter_px: size(d)?,
            }),
            Some(("gauss", s)) => {
                let (sx, sy) = s
                    .split_once(',')
                    .ok_or_else(|| bad("gauss needs two sigmas"))?;
                Ok(Spot::Gauss {
                    sigma_x_px: size(sx)?,
                    sigma_y_px: size(sy)?,
                })
            }
            _ => Err(bad("unknown spot")),
        }
    }

    /// A spot size (px) from its text, None unless a number of at least [`MIN_SIZE_PX`].
    fn size(text: &str) -> Option<f64> {
        text.trim().parse().ok().filter(|&v| Self::size_ok(v))
    }

    /// Check the sizes of a spot made in code (parsing checks them already): each at least
    /// [`MIN_SIZE_PX`]; the error names `spot`.
    pub fn validate(&self) -> Result<()> {
        let sizes = match *self {
            Spot::Airy { diameter_px } => [diameter_px, diameter_px],
            Spot::Gauss {
                sigma_x_px,
                sigma_y_px,
            } => [sigma_x_px, sigma_y_px],
        };
        if sizes.iter().all(|&v| Self::size_ok(v)) {
            Ok(())
        } else {
            Err(spot_error(&self.label(), SIZE_RULE))
        }
    }

    fn size_ok(v: f64) -> bool {
        v.is_finite() && v >= MIN_SIZE_PX
    }

    /// Parse spot lists: each item is `airy:D1,D2,...` (one Airy spot per diameter) or
    /// `gauss:SX,SY` (one Gaussian); spots in the order given. Errors quote the item as typed.
    pub fn parse_list(items: &[String]) -> Result<Vec<Self>> {
        let mut spots = Vec::new();
        for item in items {
            match item.strip_prefix("airy:") {
                Some(ds) if ds.contains(',') => {
                    for d in ds.split(',') {
                        let diameter_px =
                            Self::size(d).ok_or_else(|| diameter_error(item, d.trim()))?;
                        spots.push(Spot::Airy { diameter_px });
                    }
                }
                _ => spots.push(Spot::parse(item)?),
            }
        }
        Ok(spots)
    }

    /// Canonical text form, as accepted by [`Spot::parse`].
    pub fn label(&self) -> String {
        match self {
            Spot::Airy { diameter_px } => format!("airy:{diameter_px}"),
            Spot::Gauss {
                sigma_x_px,
                sigma_y_px,
            } => format!("gauss:{sigma_x_px},{sigma_y_px}"),
        }
    }

    /// Full width at half maximum of the intensity (px; the geometric mean of the two axes
    /// for an elongated Gaussian). The Airy FWHM is 1.029 lambda/D and its first dark ring
    /// has diameter 2.44 lambda/D, so FWHM = 0.4217 x the ring diameter.
    pub fn fwhm_px(&self) -> f64 {
        match *self {
            Spot::Airy { diameter_px } => 1.029 / 2.44 * diameter_px,
            Spot::Gauss {
                sigma_x_px,
                sigma_y_px,
            } => (8.0 * std::f64::consts::LN_2).sqrt() * (sigma_x_px * sigma_y_px).sqrt(),
        }
    }
}

/// The error of spot text `text` (quoted as typed), refused because `why`.
fn spot_error(text: &str, why: &str) -> Error {
    Error::invalid(
        "spot",
        format!("'{text}': {why} (use airy:D or gauss:SX,SY, in px)"),
    )
}

/// The error of diameter `d` in the Airy list `item` (both quoted as typed).
fn diameter_error(item: &str, d: &str) -> Error {
    let why = if d.contains(':') {
        // `airy:2,airy:3`: a second prefix, or another shape in the same list.
        format!(
            "'{d}' is not a diameter: list several Airy spots after one prefix, as airy:2,3, \
             and give another shape as its own spot"
        )
    } else {
        format!("diameter '{d}': {SIZE_RULE}")
    };
    Error::invalid(
        "spot",
        format!("'{item}': {why} (use airy:D1,D2,... in px)"),
    )
}

/// How the intensity is turned into pixel values.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize)]
#[cfg_attr(feature = "cli", derive(clap::ValueEnum))]
#[serde(rename_all = "lowercase")]
pub enum Sampling {
    /// Intensity integrated over each pixel's area (physical).
    Integrated,
    /// Intensity evaluated at pixel centres (the Durham simulation platform; the paper's figures).
    Point,
}

impl Sampling {
    /// Both samplings, in the order of the `--sampling` values.
    pub const ALL: [Sampling; 2] = [Sampling::Integrated, Sampling::Point];

    /// The sampling named `label` (see [`Sampling::label`]).
    pub fn parse(label: &str) -> Option<Sampling> {
        Self::ALL.into_iter().find(|s| s.label() == label)
    }

    /// Lower-case name.
    pub fn label(&self) -> &'static str {
        match self {
            Sampling::Integrated => "integrated",
            Sampling::Point => "point",
        }
    }
}

/// Bytes of pixel-integrated tables kept for reuse (least recently used dropped first); a build
/// takes at most [`pixel_table::BUILD_BUDGET_BYTES`] while it lasts.
const PIXEL_CACHE_BYTES: usize = 256 << 20;
/// Bytes of radial tables (point sampling) kept for reuse.
const RADIAL_CACHE_BYTES: usize = 32 << 20;

/// Pixel-integrated Airy tables by (diameter bits, extent px): one per spot and extent per
/// process, shared by every renderer (and thread) that needs it.
static PIXEL_TABLES: LazyLock<Cache<(u64, usize), PixelTable>> =
    LazyLock::new(|| Cache::new(PIXEL_CACHE_BYTES));
/// Radial Airy tables by (diameter bits, largest radius bits).
static RADIAL_TABLES: LazyLock<Cache<(u64, u64), RadialTable>> =
    LazyLock::new(|| Cache::new(RADIAL_CACHE_BYTES));

/// Renders spot images of one shape and sampling for one sub-aperture size.
#[derive(Debug, Clone)]
pub struct SpotRenderer {
    n: usize,
    kind: Kind,
}

#[derive(Debug, Clone)]
enum Kind {
    AiryPoint { radial: Arc<RadialTable> },
    AiryIntegrated { table: Arc<PixelTable> },
    Gauss { sx: f64, sy: f64, integrated: bool },
}

impl SpotRenderer {
    /// Renderer for `n` x `n` pixels and spot offsets up to `max_offset_px` in each axis
    /// (pixels further out render as 0).
    ///
    /// Airy tables are built once per process per spot and extent and shared (a cache hit costs
    /// a lock and a hash look-up); a table depends only on its key, so no image depends on which
    /// renderer was built first. Panics unless the spot's sizes are valid ([`Spot::validate`])
    /// and `max_offset_px` is finite: tables grow as their inverse.
    pub fn new(spot: Spot, sampling: Sampling, n: usize, max_offset_px: f64) -> Self {
        assert!(
            spot.validate().is_ok() && max_offset_px.is_finite(),
            "SpotRenderer::new: invalid spot {spot:?} or offset {max_offset_px}"
        );
        let kind = match (spot, sampling) {
            (Spot::Airy { diameter_px }, Sampling::Point) => {
                let reach = (n as f64 - 1.0) / 2.0 + max_offset_px.abs() + 1.0;
                let max_r = reach * std::f64::consts::SQRT_2;
                let key = (diameter_px.to_bits(), max_r.to_bits());
                Kind::AiryPoint {
                    radial: RADIAL_TABLES.get(&key, || RadialTable::new(diameter_px, max_r)),
                }
            }
            (Spot::Airy { diameter_px }, Sampling::Integrated) => {
                let extent = pixel_table::extent(n, max_offset_px);
                let key = (diameter_px.to_bits(), extent);
                let threads = rayon::current_num_threads();
                Kind::AiryIntegrated {
                    table: PIXEL_TABLES
                        .get(&key, || PixelTable::build(diameter_px, extent, threads)),
                }
            }
            (
                Spot::Gauss {
                    sigma_x_px,
                    sigma_y_px,
                },
                s,
            ) => Kind::Gauss {
                sx: sigma_x_px,
                sy: sigma_y_px,
                integrated: s == Sampling::Integrated,
            },
        };
        SpotRenderer { n, kind }
    }

    /// Sub-aperture side (px).
    pub fn subap_px(&self) -> usize {
        self.n
    }

    /// Unnormalised image of the spot centred at offset (x0, y0) px, row-major into the first
    /// n x n values of `out` (panics if it holds fewer): point-sampled Airy peaks at 1, a
    /// pixel-integrated one holds the integral of that intensity over each pixel, a point-sampled
    /// Gaussian peaks at 1 and an integrated one has unit volume.
    pub fn render(&self, x0: f64, y0: f64, out: &mut [f64]) {
        let n = self.n;
        let out = &mut out[..n * n];
        match &self.kind {
            Kind::AiryPoint { radial } => {
                let c = (n as f64 - 1.0) / 2.0;
                // Radii first (loops the compiler vectorises), then the look-ups.
                for (i, row) in out.chunks_exact_mut(n).enumerate() {
                    let dy = i as f64 - c - y0;
                    for (j, o) in row.iter_mut().enumerate() {
                        let dx = j as f64 - c - x0;
                        *o = (dx * dx + dy * dy).sqrt();
                    }
                }
                for o in out.iter_mut() {
                    *o = radial.at(*o);
                }
            }
            Kind::AiryIntegrated { table } => table.render(n, x0, y0, out),
            Kind::Gauss { sx, sy, integrated } => {
                gauss::render((*sx, *sy), *integrated, n, (x0, y0), out)
            }
        }
    }
}
