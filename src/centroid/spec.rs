//! Which centroider: the names `--centroider` takes, their parameters, and building one for a
//! run (its parameter grid depends on the spot, the sub-aperture and the camera).

use super::brightest::BrightestN;
use super::centroider::Centroider;
use super::thresholded::SLOPE_OFFSET_PX;
use super::thresholded::{Thresholded, Weighting};
use crate::spot::{Sampling, Spot, SpotRenderer};
use crate::{Error, Result};

/// The centroiding methods.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, serde::Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum CentroiderKind {
    /// Centre of gravity after subtracting a background level b (swept): the paper's.
    Cog,
    /// Per-pixel threshold k x sigma_i from the known noise map (k swept).
    Tcog,
    /// Pixels noisier than m x the median sigma get zero weight (m and b swept).
    MaskedCog,
    /// Inverse-variance weights 1 / (sigma_i^2 + F x mean_i) from the noise map and the mean
    /// spot (b swept).
    IvwCog,
    /// Gaussian weight centred on the sub-aperture (its FWHM and b swept), bias-corrected.
    Wcog,
    /// Centre of gravity of the N brightest pixels above the (N+1)-th (N swept).
    BrightestN,
}

/// Every kind, in the order tables list them.
pub const ALL_KINDS: [CentroiderKind; 6] = [
    CentroiderKind::Cog,
    CentroiderKind::Tcog,
    CentroiderKind::MaskedCog,
    CentroiderKind::IvwCog,
    CentroiderKind::Wcog,
    CentroiderKind::BrightestN,
];

impl CentroiderKind {
    /// Name on the command line and in tables.
    pub fn name(&self) -> &'static str {
        match self {
            CentroiderKind::Cog => "cog",
            CentroiderKind::Tcog => "tcog",
            CentroiderKind::MaskedCog => "masked-cog",
            CentroiderKind::IvwCog => "ivw-cog",
            CentroiderKind::Wcog => "wcog",
            CentroiderKind::BrightestN => "brightest-n",
        }
    }

    /// Name of its own parameter, with its unit.
    pub fn param_name(&self) -> Option<&'static str> {
        match self {
            CentroiderKind::Cog | CentroiderKind::IvwCog => None,
            CentroiderKind::Tcog => Some("k_sigma"),
            CentroiderKind::MaskedCog => Some("mask_above_median"),
            CentroiderKind::Wcog => Some("weight_fwhm_px"),
            CentroiderKind::BrightestN => Some("n_pixels"),
        }
    }

    /// One line of help.
    pub fn help(&self) -> &'static str {
        match self {
            CentroiderKind::Cog => "centre of gravity after subtracting a background level b (swept; the paper's)",
            CentroiderKind::Tcog => "per-pixel threshold K x sigma_i from the known noise map (K swept, or given)",
            CentroiderKind::MaskedCog => "pixels with sigma_i above M x the median sigma get zero weight (M swept, or given), b swept",
            CentroiderKind::IvwCog => "weights 1 / (sigma_i^2 + F x mean_i): noise map, mean spot, excess factor F; b swept",
            CentroiderKind::Wcog => "Gaussian weight of FWHM W px on the sub-aperture centre (W swept, or given), b swept; divided by its noiseless response slope",
            CentroiderKind::BrightestN => "centre of gravity of the N brightest pixels above the (N+1)-th (N swept, or given)",
        }
    }
}

/// A centroider as chosen: its kind and, optionally, its parameter fixed instead of swept.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct CentroiderSpec {
    /// The method.
    pub kind: CentroiderKind,
    /// Its parameter (unit of [`CentroiderKind::param_name`]) when given; swept when None.
    pub param: Option<f64>,
}

impl Default for CentroiderSpec {
    fn default() -> Self {
        CentroiderSpec::of(CentroiderKind::Cog)
    }
}

/// What building a centroider for a run needs to know.
#[derive(Clone, Copy)]
pub struct CentroidContext<'a> {
    /// Sub-aperture side (px).
    pub subap_px: usize,
    /// The run's background levels (e-), ascending.
    pub levels_e: &'a [f64],
    /// The centred spot's expected photo-electrons per pixel (row-major).
    pub mean_e: &'a [f64],
    /// The spot.
    pub spot: Spot,
    /// How the spot is sampled (the weighted centroid's response is calibrated with it).
    pub sampling: Sampling,
    /// The camera's median per-pixel read noise (e-).
    pub median_sigma_e: f64,
}

impl CentroiderSpec {
    /// `kind` with its parameter swept.
    pub fn of(kind: CentroiderKind) -> Self {
        CentroiderSpec { kind, param: None }
    }

    /// Parse `NAME[:PARAM]` (e.g. `masked-cog:3`); errors name the `centroider` field.
    pub fn parse(text: &str) -> Result<Self> {
        let (name, arg) = match text.split_once(':') {
            Some((n, a)) => (n, Some(a)),
            None => (text, None),
        };
        let known = || {
            ALL_KINDS
                .iter()
                .map(|k| k.name())
                .collect::<Vec<_>>()
                .join(", ")
        };
        let kind = *ALL_KINDS.iter().find(|k| k.name() == name).ok_or_else(|| {
            Error::invalid(
                "centroider",
                format!("'{text}': unknown; known: {}", known()),
            )
        })?;
        let param = match (arg, kind.param_name()) {
            (None, _) => None,
            (Some(_), None) => {
                return Err(Error::invalid(
                    "centroider",
                    format!("'{text}': {name} takes no parameter"),
                ))
            }
            (Some(a), Some(_)) => Some(
                a.parse::<f64>()
                    .ok()
                    .filter(|v| v.is_finite())
                    .ok_or_else(|| {
                        Error::invalid(
                            "centroider",
                            format!("'{text}': parameter must be a number"),
                        )
                    })?,
            ),
        };
        let spec = CentroiderSpec { kind, param };
        spec.validate()?;
        Ok(spec)
    }

    /// Check a given parameter's range.
    pub fn validate(&self) -> Result<()> {
        let Some(p) = self.param else { return Ok(()) };
        let ok = match self.kind {
            CentroiderKind::Tcog => p >= 0.0,
            CentroiderKind::MaskedCog => p > 0.0,
            CentroiderKind::Wcog => p > 0.0,
            CentroiderKind::BrightestN => p >= 1.0 && p.fract() == 0.0,
            CentroiderKind::Cog | CentroiderKind::IvwCog => false,
        };
        if ok {
            Ok(())
        } else {
            let rule = match self.kind {
                CentroiderKind::Tcog => "K must be >= 0 (sigmas)",
                CentroiderKind::MaskedCog => "M must be > 0 (times the median sigma)",
                CentroiderKind::Wcog => "W must be > 0 (px)",
                CentroiderKind::BrightestN => "N must be a whole number >= 1",
                _ => "no parameter is taken",
            };
            Err(Error::invalid(
                "centroider",
                format!("{}:{p}: {rule}", self.kind.name()),
            ))
        }
    }

    /// Text form, as [`CentroiderSpec::parse`] takes it.
    pub fn label(&self) -> String {
        match self.param {
            Some(p) => format!("{}:{p}", self.kind.name()),
            None => self.kind.name().to_string(),
        }
    }

    /// The centroider for a run described by `ctx`.
    pub fn build(&self, ctx: &CentroidContext) -> Result<Box<dyn Centroider>> {
        let n = ctx.subap_px;
        let fixed = |grid: Vec<f64>| self.param.map_or(grid, |p| vec![p]);
        Ok(match self.kind {
            CentroiderKind::Cog => Box::new(Thresholded::new(
                self.kind,
                Weighting::None,
                ctx.levels_e.to_vec(),
                n,
            )),
            CentroiderKind::Tcog => {
                let peak = ctx.mean_e.iter().copied().fold(0.0, f64::max);
                let grid = fixed(k_grid(peak / ctx.median_sigma_e.max(SIGMA_FLOOR_E)));
                Box::new(Thresholded::new(self.kind, Weighting::NoiseScaled, grid, n))
            }
            CentroiderKind::MaskedCog => {
                let m = fixed(MASK_GRID.to_vec());
                let weighting = Weighting::Mask {
                    above_e: m.iter().map(|m| m * ctx.median_sigma_e).collect(),
                    m,
                };
                Box::new(Thresholded::new(
                    self.kind,
                    weighting,
                    ctx.levels_e.to_vec(),
                    n,
                ))
            }
            CentroiderKind::IvwCog => Box::new(Thresholded::new(
                self.kind,
                Weighting::InverseVariance,
                ctx.levels_e.to_vec(),
                n,
            )),
            CentroiderKind::Wcog => {
                let fwhm = ctx.spot.fwhm_px();
                let widths = fixed(
                    WCOG_FWHM_FACTORS
                        .iter()
                        .map(|f| (f * fwhm).max(MIN_WEIGHT_FWHM_PX))
                        .collect(),
                );
                let renderer = SpotRenderer::new(ctx.spot, ctx.sampling, n, SLOPE_OFFSET_PX);
                let weighting = Weighting::gaussian(&widths, &renderer)?;
                Box::new(Thresholded::new(
                    self.kind,
                    weighting,
                    ctx.levels_e.to_vec(),
                    n,
                ))
            }
            CentroiderKind::BrightestN => {
                if n * n < 2 {
                    return Err(Error::invalid(
                        "centroider",
                        "brightest-n needs a sub-aperture of at least 2 pixels",
                    ));
                }
                let grid = match self.param {
                    Some(p) if p as usize >= n * n => {
                        return Err(Error::invalid(
                            "centroider",
                            format!(
                            "brightest-n:{p}: N must be below the {} pixels of the sub-aperture",
                            n * n
                        ),
                        ))
                    }
                    Some(p) => vec![p as usize],
                    None => n_grid(n * n - 1),
                };
                Box::new(BrightestN::new(grid, n))
            }
        })
    }
}

/// Read-noise sigmas below this (e-) are raised to it where one divides by them.
pub(super) const SIGMA_FLOOR_E: f64 = 1e-6;
/// Masking thresholds swept (times the median sigma).
const MASK_GRID: [f64; 8] = [1.25, 1.5, 2.0, 2.5, 3.0, 4.0, 6.0, 10.0];
/// Weight widths swept (times the spot's FWHM).
const WCOG_FWHM_FACTORS: [f64; 7] = [0.5, 0.75, 1.0, 1.5, 2.0, 3.0, 4.0];
/// Narrowest weight (FWHM, px): narrower weights see one pixel.
const MIN_WEIGHT_FWHM_PX: f64 = 0.5;

/// Thresholds k (sigmas): 0 to 8 by 0.25, then 10 % steps up to `top` (the brightest mean
/// pixel in sigmas), beyond which every pixel is cut.
fn k_grid(top: f64) -> Vec<f64> {
    let mut k: Vec<f64> = (0..=32).map(|i| i as f64 * 0.25).collect();
    let mut v = 8.0 * 1.1;
    while v < top.min(1e6) {
        k.push(v);
        v *= 1.1;
    }
    k
}

/// Pixel counts N: 1 to 16, then 25 % steps, and `most`.
fn n_grid(most: usize) -> Vec<usize> {
    let mut n: Vec<usize> = (1..=most.min(16)).collect();
    let mut v = 16.0f64;
    loop {
        v *= 1.25;
        let k = v.round() as usize;
        if k >= most {
            break;
        }
        n.push(k);
    }
    if *n.last().expect("most >= 1") < most {
        n.push(most);
    }
    n
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_parse_with_and_without_parameters() {
        for k in ALL_KINDS {
            assert_eq!(
                CentroiderSpec::parse(k.name()).unwrap(),
                CentroiderSpec::of(k)
            );
        }
        let m = CentroiderSpec::parse("masked-cog:3").unwrap();
        assert_eq!((m.kind, m.param), (CentroiderKind::MaskedCog, Some(3.0)));
        assert_eq!(m.label(), "masked-cog:3");
        for bad in [
            "cg",
            "cog:2",
            "ivw-cog:1",
            "tcog:-1",
            "brightest-n:2.5",
            "wcog:0",
            "tcog:x",
        ] {
            let e = CentroiderSpec::parse(bad).unwrap_err().to_string();
            assert!(
                e.contains("centroider") && e.contains(bad.split(':').next().unwrap()),
                "{e}"
            );
        }
    }

    #[test]
    fn grids_are_ascending_and_bounded() {
        let k = k_grid(40.0);
        assert!(k.windows(2).all(|w| w[0] < w[1]) && k[0] == 0.0 && *k.last().unwrap() < 40.0);
        for most in [1, 3, 15, 16, 17, 63, 255] {
            let n = n_grid(most);
            assert!(n.windows(2).all(|w| w[0] < w[1]), "{n:?}");
            assert_eq!((n[0], *n.last().unwrap()), (1, most));
        }
    }
}
