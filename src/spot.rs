//! Noiseless sub-aperture spot images: Airy disc and elongated Gaussian.
//!
//! Pixel (row i, column j) has its centre at (x, y) = (j, i); positions are offsets from the
//! sub-aperture centre (n-1)/2, so x follows columns and y follows rows.

use crate::{Error, Result};
use rayon::prelude::*;

/// First zero of J1: the Airy intensity (2 J1(v)/v)^2 vanishes first at v = 3.8317.
pub const J1_FIRST_ZERO: f64 = 3.831_705_970_207_512;

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
        let bad = |why: &str| {
            Error::invalid(
                "spot",
                format!("'{text}': {why} (use airy:D or gauss:SX,SY, in px)"),
            )
        };
        let positive = |s: &str| -> Result<f64> {
            match s.trim().parse::<f64>() {
                Ok(v) if Self::size_ok(v) => Ok(v),
                _ => Err(bad(SIZE_RULE)),
            }
        };
        match text.split_once(':') {
            Some(("airy", d)) => Ok(Spot::Airy {
                diameter_px: positive(d)?,
            }),
            Some(("gauss", s)) => {
                let (sx, sy) = s
                    .split_once(',')
                    .ok_or_else(|| bad("gauss needs two sigmas"))?;
                Ok(Spot::Gauss {
                    sigma_x_px: positive(sx)?,
                    sigma_y_px: positive(sy)?,
                })
            }
            _ => Err(bad("unknown spot")),
        }
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
            Err(Error::invalid(
                "spot",
                format!(
                    "'{}': {SIZE_RULE} (use airy:D or gauss:SX,SY, in px)",
                    self.label()
                ),
            ))
        }
    }

    fn size_ok(v: f64) -> bool {
        v.is_finite() && v >= MIN_SIZE_PX
    }

    /// Parse spot lists: each item is `airy:D1,D2,...` (one Airy spot per diameter) or
    /// `gauss:SX,SY` (one Gaussian); spots in the order given.
    pub fn parse_list(items: &[String]) -> Result<Vec<Self>> {
        let mut spots = Vec::new();
        for item in items {
            match item.strip_prefix("airy:") {
                Some(ds) => {
                    for d in ds.split(',') {
                        spots.push(Spot::parse(&format!("airy:{}", d.trim()))?);
                    }
                }
                None => spots.push(Spot::parse(item)?),
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
    /// Lower-case name.
    pub fn label(&self) -> &'static str {
        match self {
            Sampling::Integrated => "integrated",
            Sampling::Point => "point",
        }
    }
}

/// Normalised Airy intensity (2 J1(v)/v)^2, 1 at v = 0.
pub fn airy_intensity(v: f64) -> f64 {
    if v.abs() < 1e-8 {
        return 1.0;
    }
    let a = 2.0 * libm::j1(v) / v;
    a * a
}

/// Renders spot images of one shape and sampling for one sub-aperture size.
#[derive(Debug, Clone)]
pub struct SpotRenderer {
    n: usize,
    kind: Kind,
}

#[derive(Debug, Clone)]
enum Kind {
    AiryPoint { radial: RadialTable },
    AiryIntegrated { table: PixelTable },
    Gauss { sx: f64, sy: f64, integrated: bool },
}

impl SpotRenderer {
    /// Renderer for `n` x `n` pixels and spot offsets up to `max_offset_px` in each axis.
    pub fn new(spot: Spot, sampling: Sampling, n: usize, max_offset_px: f64) -> Self {
        let reach = (n as f64 - 1.0) / 2.0 + max_offset_px.abs() + 1.0;
        let kind = match (spot, sampling) {
            (Spot::Airy { diameter_px }, Sampling::Point) => Kind::AiryPoint {
                radial: RadialTable::new(diameter_px, reach * std::f64::consts::SQRT_2),
            },
            (Spot::Airy { diameter_px }, Sampling::Integrated) => Kind::AiryIntegrated {
                table: PixelTable::new(diameter_px, reach),
            },
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

    /// Unnormalised image of the spot centred at offset (x0, y0) px, row-major into `out`.
    pub fn render(&self, x0: f64, y0: f64, out: &mut [f64]) {
        let n = self.n;
        let c = (n as f64 - 1.0) / 2.0;
        match &self.kind {
            Kind::AiryPoint { radial } => {
                for (i, row) in out.chunks_exact_mut(n).enumerate() {
                    let dy = i as f64 - c - y0;
                    for (j, o) in row.iter_mut().enumerate() {
                        let dx = j as f64 - c - x0;
                        *o = radial.at((dx * dx + dy * dy).sqrt());
                    }
                }
            }
            Kind::AiryIntegrated { table } => {
                for (i, row) in out.chunks_exact_mut(n).enumerate() {
                    let dy = i as f64 - c - y0;
                    for (j, o) in row.iter_mut().enumerate() {
                        *o = table.at(j as f64 - c - x0, dy);
                    }
                }
            }
            Kind::Gauss { sx, sy, integrated } => {
                let profile = |d: f64, s: f64| {
                    if *integrated {
                        let k = 1.0 / (s * std::f64::consts::SQRT_2);
                        0.5 * (libm::erf((d + 0.5) * k) - libm::erf((d - 0.5) * k))
                    } else {
                        (-0.5 * (d / s).powi(2)).exp()
                    }
                };
                let px: Vec<f64> = (0..n).map(|j| profile(j as f64 - c - x0, *sx)).collect();
                for (i, row) in out.chunks_exact_mut(n).enumerate() {
                    let py = profile(i as f64 - c - y0, *sy);
                    for (o, p) in row.iter_mut().zip(&px) {
                        *o = p * py;
                    }
                }
            }
        }
    }
}

/// Airy intensity against radius (px), linearly interpolated on a fine grid.
#[derive(Debug, Clone)]
struct RadialTable {
    inv_step: f64,
    values: Vec<f64>,
}

impl RadialTable {
    /// 1/400 of the first-zero radius per step: interpolation error below 1e-6 of the peak.
    fn new(diameter_px: f64, max_r_px: f64) -> Self {
        let step = diameter_px / 2.0 / 400.0;
        let count = (max_r_px / step).ceil() as usize + 2;
        let scale = J1_FIRST_ZERO / (diameter_px / 2.0);
        let values = (0..count)
            .map(|k| airy_intensity(k as f64 * step * scale))
            .collect();
        RadialTable {
            inv_step: 1.0 / step,
            values,
        }
    }

    fn at(&self, r: f64) -> f64 {
        let t = r * self.inv_step;
        let k = t as usize;
        if k + 1 >= self.values.len() {
            return 0.0;
        }
        let f = t - k as f64;
        self.values[k] * (1.0 - f) + self.values[k + 1] * f
    }
}

/// Table resolution of the pixel-integrated Airy: 1/64 px steps in the pixel-to-spot offset.
const PIXEL_TABLE_STEPS_PER_PX: f64 = 64.0;
/// Gauss-Legendre nodes (per axis, per half pixel) for the pixel integral.
const GL_NODES: [f64; 6] = [
    -0.932_469_514_203_152,
    -0.661_209_386_466_265,
    -0.238_619_186_083_197,
    0.238_619_186_083_197,
    0.661_209_386_466_265,
    0.932_469_514_203_152,
];
const GL_WEIGHTS: [f64; 6] = [
    0.171_324_492_379_170,
    0.360_761_573_048_139,
    0.467_913_934_572_691,
    0.467_913_934_572_691,
    0.360_761_573_048_139,
    0.171_324_492_379_170,
];

/// Integral of the Airy intensity over a unit pixel against its offset (|dx|, |dy|) from the
/// spot centre, bilinearly interpolated: evaluating the integral per pixel per frame would
/// cost hundreds of Bessel evaluations.
#[derive(Debug, Clone)]
struct PixelTable {
    side: usize,
    values: Vec<f64>,
}

impl PixelTable {
    fn new(diameter_px: f64, reach_px: f64) -> Self {
        let side = (reach_px * PIXEL_TABLE_STEPS_PER_PX).ceil() as usize + 2;
        let radial = RadialTable::new(diameter_px, (reach_px + 1.0) * std::f64::consts::SQRT_2);
        // 1-D quadrature over a unit pixel: two halves, six Gauss-Legendre nodes each.
        let nodes: Vec<(f64, f64)> = [-0.25, 0.25]
            .iter()
            .flat_map(|&mid| {
                GL_NODES
                    .iter()
                    .zip(GL_WEIGHTS)
                    .map(move |(t, w)| (mid + 0.25 * t, 0.25 * w))
            })
            .collect();
        let values: Vec<f64> = (0..side * side)
            .into_par_iter()
            .map(|idx| {
                let dx = (idx % side) as f64 / PIXEL_TABLE_STEPS_PER_PX;
                let dy = (idx / side) as f64 / PIXEL_TABLE_STEPS_PER_PX;
                let mut acc = 0.0;
                for &(u, wu) in &nodes {
                    for &(v, wv) in &nodes {
                        acc += wu * wv * radial.at(((dx + u).powi(2) + (dy + v).powi(2)).sqrt());
                    }
                }
                acc
            })
            .collect();
        PixelTable { side, values }
    }

    fn at(&self, dx: f64, dy: f64) -> f64 {
        let tx = dx.abs() * PIXEL_TABLE_STEPS_PER_PX;
        let ty = dy.abs() * PIXEL_TABLE_STEPS_PER_PX;
        let (ix, iy) = (tx as usize, ty as usize);
        if ix + 1 >= self.side || iy + 1 >= self.side {
            return 0.0;
        }
        let (fx, fy) = (tx - ix as f64, ty - iy as f64);
        let v = |x: usize, y: usize| self.values[y * self.side + x];
        (v(ix, iy) * (1.0 - fx) + v(ix + 1, iy) * fx) * (1.0 - fy)
            + (v(ix, iy + 1) * (1.0 - fx) + v(ix + 1, iy + 1) * fx) * fy
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::centroid::cog;

    #[test]
    fn spot_lists_expand_airy_diameters_and_keep_the_order() {
        let items = [
            "airy:1, 2.5".to_string(),
            "gauss:1,3".into(),
            "airy:4".into(),
        ];
        let labels: Vec<String> = Spot::parse_list(&items)
            .unwrap()
            .iter()
            .map(Spot::label)
            .collect();
        assert_eq!(labels, ["airy:1", "airy:2.5", "gauss:1,3", "airy:4"]);
        let e = Spot::parse_list(&["airy:2,0.01".into()]).unwrap_err();
        assert!(
            e.to_string().starts_with("invalid `spot`: 'airy:0.01'"),
            "{e}"
        );
        assert!(Spot::parse_list(&["disc:2".into()]).is_err());
    }

    fn normalised(spot: Spot, sampling: Sampling, n: usize, x0: f64, y0: f64) -> Vec<f64> {
        let r = SpotRenderer::new(spot, sampling, n, 0.6);
        let mut img = vec![0.0; n * n];
        r.render(x0, y0, &mut img);
        let s: f64 = img.iter().sum();
        img.iter().map(|v| v / s).collect()
    }

    #[test]
    fn airy_first_zero_is_at_half_diameter() {
        let d = 2.0;
        let v = J1_FIRST_ZERO / (d / 2.0) * (d / 2.0);
        assert!(airy_intensity(v) < 1e-20);
        assert!(airy_intensity(0.99 * v) > 0.0 && airy_intensity(1.01 * v) > 0.0);
        let r = RadialTable::new(d, 5.0);
        assert!(r.at(1.0) < 1e-8, "{}", r.at(1.0));
        assert!((r.at(0.0) - 1.0).abs() < 1e-12);
    }

    #[test]
    fn matches_reference_values_of_the_research_notes() {
        // 8x8 px, D = 2, offset (0.25, -0.10) px: notes 1.3 table (max pixel, CoG).
        let airy = Spot::Airy { diameter_px: 2.0 };
        for (sampling, max, cx, cy) in [
            (Sampling::Point, 0.592, 0.476, -0.235),
            (Sampling::Integrated, 0.416, 0.275, -0.116),
        ] {
            let img = normalised(airy, sampling, 8, 0.25, -0.10);
            let m = img.iter().cloned().fold(0.0, f64::max);
            let (x, y) = cog(&img, 8).unwrap();
            assert!((m - max).abs() < 1.5e-3, "{sampling:?} max {m}");
            assert!(
                (x - cx).abs() < 1.5e-3 && (y - cy).abs() < 1.5e-3,
                "{sampling:?} cog {x} {y}"
            );
        }
    }

    #[test]
    fn centred_symmetric_spots_have_centred_cog() {
        for spot in [
            Spot::Airy { diameter_px: 3.0 },
            Spot::Gauss {
                sigma_x_px: 1.0,
                sigma_y_px: 2.0,
            },
        ] {
            for sampling in [Sampling::Point, Sampling::Integrated] {
                for n in [4, 7, 16] {
                    let (x, y) = cog(&normalised(spot, sampling, n, 0.0, 0.0), n).unwrap();
                    assert!(
                        x.abs() < 1e-9 && y.abs() < 1e-9,
                        "{spot:?} {sampling:?} {n}: {x} {y}"
                    );
                }
            }
        }
    }

    #[test]
    fn integrated_gaussian_is_exact_and_point_differs_from_integrated_at_d2() {
        // A wide Gaussian fully inside the frame integrates to 1 over the whole plane.
        let r = SpotRenderer::new(
            Spot::Gauss {
                sigma_x_px: 1.0,
                sigma_y_px: 1.5,
            },
            Sampling::Integrated,
            16,
            0.5,
        );
        let mut img = vec![0.0; 256];
        r.render(0.3, -0.2, &mut img);
        assert!((img.iter().sum::<f64>() - 1.0).abs() < 1e-6);
        let p = normalised(
            Spot::Airy { diameter_px: 2.0 },
            Sampling::Point,
            8,
            0.0,
            0.0,
        );
        let q = normalised(
            Spot::Airy { diameter_px: 2.0 },
            Sampling::Integrated,
            8,
            0.0,
            0.0,
        );
        let diff: f64 = p.iter().zip(&q).map(|(a, b)| (a - b).abs()).sum();
        assert!(
            diff > 0.05,
            "point and integrated should differ at D = 2: {diff}"
        );
    }

    #[test]
    fn integrated_airy_conserves_energy_inside_large_frame() {
        // Encircled energy of an Airy disc within radius 8 first-zero radii is ~0.99;
        // a 32x32 frame around a D = 2 spot holds at least that.
        let r = SpotRenderer::new(
            Spot::Airy { diameter_px: 2.0 },
            Sampling::Integrated,
            32,
            0.5,
        );
        let mut img = vec![0.0; 32 * 32];
        r.render(0.0, 0.0, &mut img);
        // Total intensity of (2J1(v)/v)^2 over the plane is 4 pi / k^2, k = 3.8317 / (D/2).
        let k = J1_FIRST_ZERO;
        let total = 4.0 * std::f64::consts::PI / (k * k);
        let got: f64 = img.iter().sum();
        assert!(
            got / total > 0.985 && got / total < 1.0 + 1e-4,
            "{}",
            got / total
        );
    }

    #[test]
    fn parses_spots_and_rejects_malformed() {
        assert_eq!(
            Spot::parse("airy:2").unwrap(),
            Spot::Airy { diameter_px: 2.0 }
        );
        assert_eq!(
            Spot::parse("gauss:1,3.5").unwrap(),
            Spot::Gauss {
                sigma_x_px: 1.0,
                sigma_y_px: 3.5
            }
        );
        for bad in [
            "airy",
            "airy:-1",
            "airy:x",
            "gauss:1",
            "disc:2",
            "gauss:1,0",
            "airy:0.05",
            "airy:1e-9",
            "gauss:1,0.01",
        ] {
            assert_eq!(Spot::parse(bad).unwrap_err().exit_code(), 2, "{bad}");
        }
        assert!(Spot::parse("airy:0.1").is_ok());
    }

    #[test]
    fn spots_made_in_code_meet_the_same_size_rule() {
        // A library caller can build a spot without parsing it: `validate` (and with it
        // `SimConfig::validate`) applies the parser's rule, naming `spot`.
        let small = [
            Spot::Airy { diameter_px: 0.05 },
            Spot::Gauss {
                sigma_x_px: 1.0,
                sigma_y_px: 0.0,
            },
            Spot::Airy {
                diameter_px: f64::NAN,
            },
        ];
        for spot in small {
            let msg = spot.validate().unwrap_err().to_string();
            assert!(msg.contains("`spot`") && msg.contains(">= 0.1 px"), "{msg}");
            let cfg = crate::montecarlo::SimConfig {
                spot,
                ..crate::montecarlo::SimConfig::paper(8)
            };
            assert!(cfg.validate().unwrap_err().to_string().contains("`spot`"));
        }
        assert!(Spot::Airy { diameter_px: 0.1 }.validate().is_ok());
        assert!(SIZE_RULE.contains(&format!(">= {MIN_SIZE_PX} px")));
    }
}
